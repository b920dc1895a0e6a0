//! The radiance stage's settings: [`RadianceStageOverride`] (scene.json's `bake.radiance`, for
//! every planar reflector) and [`RadianceOverride`] (one reflector's `radiance`); the stage
//! resolves them with its quality preset and each reflector's glossiness.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::{Quality, SettingError};

/// The radiance stage's preset: the multiplier of map resolution and camera count.
pub fn quality_scale(q: Quality) -> f32 {
    match q {
        Quality::Draft => 0.5,
        Quality::Default => 1.0,
        Quality::High => 2.0,
    }
}

/// Radiance-map stage settings that override the preset: scene.json's `bake.radiance`.
#[derive(
    clap::Args, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema,
)]
#[serde(deny_unknown_fields)]
pub struct RadianceStageOverride {
    /// Multiplies the resolution chosen from glossiness, in (0, 16].
    #[arg(long, value_name = "F")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolution_scale: Option<f32>,
}

/// Per-reflector radiance-map sampling overrides (Bastos §8.1.3).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RadianceOverride {
    /// Reflector elements along each of the plane's two axes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub elements: Option<[u32; 2]>,
    /// Cameras per hemisphere.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cameras_per_hemisphere: Option<u32>,
    /// Square map resolution in pixels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolution: Option<u32>,
}

/// Largest `bake.radiance.resolution_scale`.
pub const MAX_RESOLUTION_SCALE: f32 = 16.0;

impl RadianceStageOverride {
    /// The multiplier of every planar reflector's map resolution and camera count: the
    /// preset's ([`quality_scale`]) times `resolution_scale`.
    pub fn scale(&self, quality: Quality) -> f32 {
        quality_scale(quality) * self.resolution_scale.unwrap_or(1.0)
    }

    /// Checks `resolution_scale`: finite, in (0, [`MAX_RESOLUTION_SCALE`]].
    pub fn check(&self) -> Result<(), SettingError> {
        match self.resolution_scale {
            Some(v) if !(v.is_finite() && v > 0.0 && v <= MAX_RESOLUTION_SCALE) => {
                Err(SettingError::new(
                    "resolution_scale",
                    format!("{v} is not in (0, {MAX_RESOLUTION_SCALE}]"),
                ))
            }
            _ => Ok(()),
        }
    }
}

/// Largest reflector elements per axis, and cameras per hemisphere, of a radiance override.
pub const MAX_RADIANCE_ELEMENTS: u32 = 64;

/// Largest radiance-map resolution of an override, pixels.
pub const MAX_RADIANCE_RESOLUTION: u32 = 4096;

impl RadianceOverride {
    /// Checks each value given: elements per axis and cameras in 1 ..= 64, resolution in
    /// 1 ..= 4096.
    pub fn check(&self) -> Result<(), SettingError> {
        if let Some([a, b]) = self.elements
            && !((1..=MAX_RADIANCE_ELEMENTS).contains(&a)
                && (1..=MAX_RADIANCE_ELEMENTS).contains(&b))
        {
            return Err(SettingError::new(
                "elements",
                format!("[{a}, {b}]: each must be in 1 ..= {MAX_RADIANCE_ELEMENTS}"),
            ));
        }
        if let Some(c) = self.cameras_per_hemisphere
            && !(1..=MAX_RADIANCE_ELEMENTS).contains(&c)
        {
            return Err(SettingError::new(
                "cameras_per_hemisphere",
                format!("{c} is not in 1 ..= {MAX_RADIANCE_ELEMENTS}"),
            ));
        }
        if let Some(r) = self.resolution
            && !(1..=MAX_RADIANCE_RESOLUTION).contains(&r)
        {
            return Err(SettingError::new(
                "resolution",
                format!("{r} is not in 1 ..= {MAX_RADIANCE_RESOLUTION}"),
            ));
        }
        Ok(())
    }
}
