//! The SRDM stage's settings (Popescu §4, §5.1): rotated domains n, points per row m and the
//! depth-map resolution w. [`SrdmOverride`] is scene.json's `bake.srdm` and `glint-srdm`'s
//! flags; [`SrdmSettings`], what the stage runs with and records, comes from
//! [`SrdmSettings::resolve`].

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::{Quality, SettingError};

/// Largest number of rotated domains (0.1° apart).
pub const MAX_DOMAINS: u32 = 1800;

/// Largest number of points per row (counts are stored as u16).
pub const MAX_POINTS: u32 = 4096;

/// Largest resolution accepted (a 4096² map with n = 180, m = 64 is already 754 MB of SRDM).
pub const MAX_RESOLUTION: u32 = 4096;

/// SRDM settings that override the preset: scene.json's `bake.srdm`, then `glint-srdm`'s
/// flags.
#[derive(
    clap::Args, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema,
)]
#[serde(deny_unknown_fields)]
pub struct SrdmOverride {
    /// Rotated domains n (angular step 180°/n), 1 ..= 1800.
    #[arg(short = 'n', long = "domains", value_name = "DOMAINS")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub domains: Option<u32>,
    /// Points per simplified row m, 2 ..= 4096.
    #[arg(short = 'm', long = "points", value_name = "POINTS")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub points: Option<u32>,
    /// Depth-map resolution W (W × W texels), 2 ..= 4096.
    #[arg(long, value_name = "W")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolution: Option<u32>,
}

/// Resolved SRDM settings: preset, then scene.json's `bake.srdm`, then the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct SrdmSettings {
    /// Rotated domains n.
    pub domains: u32,
    /// Points per row m.
    pub points: u32,
    /// Depth-map resolution w (square).
    pub resolution: u32,
}

impl SrdmSettings {
    /// The preset's values. `default` is the paper's set-up (256², n = 60, m within its 8–16).
    pub fn preset(quality: Quality) -> SrdmSettings {
        let (domains, points, resolution) = match quality {
            Quality::Draft => (30, 8, 128),
            Quality::Default => (60, 16, 256),
            Quality::High => (120, 32, 512),
        };
        SrdmSettings {
            domains,
            points,
            resolution,
        }
    }

    /// The preset `quality`, then each of `overrides` in turn (scene.json's, then the flags'),
    /// checked ([`SrdmSettings::check`]).
    pub fn resolve(
        quality: Quality,
        overrides: &[&SrdmOverride],
    ) -> Result<SrdmSettings, SettingError> {
        let mut s = SrdmSettings::preset(quality);
        for over in overrides {
            let SrdmOverride {
                domains,
                points,
                resolution,
            } = **over;
            s.domains = domains.unwrap_or(s.domains);
            s.points = points.unwrap_or(s.points);
            s.resolution = resolution.unwrap_or(s.resolution);
        }
        s.check()?;
        Ok(s)
    }

    /// Checks every value: domains in 1 ..= [`MAX_DOMAINS`], points in 2 ..= [`MAX_POINTS`],
    /// resolution in 2 ..= [`MAX_RESOLUTION`].
    pub fn check(&self) -> Result<(), SettingError> {
        let ranges = [
            ("domains", self.domains, 1, MAX_DOMAINS),
            ("points", self.points, 2, MAX_POINTS),
            ("resolution", self.resolution, 2, MAX_RESOLUTION),
        ];
        for (name, v, lo, hi) in ranges {
            if !(lo..=hi).contains(&v) {
                return Err(SettingError::new(
                    name,
                    format!("{v} is outside {lo} ..= {hi}"),
                ));
            }
        }
        Ok(())
    }
}
