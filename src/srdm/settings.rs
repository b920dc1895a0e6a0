//! The SRDM stage's settings (Popescu §4, §5.1): rotated domains n, points per row m and the
//! depth-map resolution w, from a quality preset, scene.json's `bake.srdm` and the command line.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{MAX_DOMAINS, MAX_POINTS, MAX_RESOLUTION};
use crate::scene::Quality;
use crate::scene::desc::SrdmOverride;

/// A setting out of range; the message names the field or flag (and scene.json).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct SettingError(pub String);

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

    /// The preset with the scene's overrides, each checked; errors name scene.json and the field.
    pub fn resolve(
        scene_path: &Path,
        quality: Quality,
        over: &SrdmOverride,
    ) -> Result<SrdmSettings, SettingError> {
        let mut s = SrdmSettings::preset(quality);
        let field = |name: &str, v: u32, lo: u32, hi: u32| {
            if (lo..=hi).contains(&v) {
                Ok(v)
            } else {
                Err(SettingError(format!(
                    "{}: field `bake.srdm.{name}`: {v} is outside {lo}…{hi}",
                    scene_path.display()
                )))
            }
        };
        if let Some(v) = over.domains {
            s.domains = field("domains", v, 1, MAX_DOMAINS)?;
        }
        if let Some(v) = over.points {
            s.points = field("points", v, 2, MAX_POINTS)?;
        }
        if let Some(v) = over.resolution {
            s.resolution = field("resolution", v, 2, MAX_RESOLUTION)?;
        }
        Ok(s)
    }

    /// Checks every value (for settings assembled elsewhere).
    pub fn check(&self) -> Result<(), SettingError> {
        let bad = |what: &str, v: u32, lo: u32, hi: u32| {
            Err(SettingError(format!("{what} {v} is outside {lo}…{hi}")))
        };
        if !(1..=MAX_DOMAINS).contains(&self.domains) {
            return bad("domains", self.domains, 1, MAX_DOMAINS);
        }
        if !(2..=MAX_POINTS).contains(&self.points) {
            return bad("points", self.points, 2, MAX_POINTS);
        }
        if !(2..=MAX_RESOLUTION).contains(&self.resolution) {
            return bad("resolution", self.resolution, 2, MAX_RESOLUTION);
        }
        Ok(())
    }
}
