//! The SRDM stage's settings (Popescu §4, §5.1): rotated domains n, points per row m and the
//! depth-map resolution w, from a quality preset, scene.json's `bake.srdm` and the command line.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{MAX_DOMAINS, MAX_POINTS, MAX_RESOLUTION};
use crate::scene::Quality;
use crate::scene::desc::{SettingError, SrdmOverride};

/// Resolved SRDM settings: preset, then scene.json's `bake.srdm`, then the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
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

    /// The preset with the scene's overrides, each checked ([`SrdmSettings::check`]); the
    /// error names scene.json and the field.
    pub fn resolve(
        scene_path: &Path,
        quality: Quality,
        over: &SrdmOverride,
    ) -> Result<SrdmSettings, String> {
        let mut s = SrdmSettings::preset(quality);
        if let Some(v) = over.domains {
            s.domains = v;
        }
        if let Some(v) = over.points {
            s.points = v;
        }
        if let Some(v) = over.resolution {
            s.resolution = v;
        }
        s.check().map_err(|e| {
            format!(
                "{}: field `bake.srdm.{}`: {}",
                scene_path.display(),
                e.field,
                e.message
            )
        })?;
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
