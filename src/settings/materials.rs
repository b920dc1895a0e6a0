//! The materials stage's settings: [`MaterialsOverride`] (scene.json's `bake.materials`) and
//! [`MaterialsSettings`], what the stage runs with and records in its index and manifest
//! record, from [`MaterialsSettings::resolve`].

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::{Quality, SettingError};

/// Material-stage settings that override the preset: scene.json's `bake.materials`.
#[derive(
    clap::Args, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema,
)]
#[serde(deny_unknown_fields)]
pub struct MaterialsOverride {
    /// Samples per lobe the regular pattern should come closest to, 1 ..= 100000.
    #[arg(long, value_name = "N")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sample_budget: Option<u32>,
    /// Cube-map face size of prefiltered environment maps, texels: a power of two in 4 ..= 4096.
    #[arg(long, value_name = "N")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub env_map_size: Option<u32>,
}

/// A MIP filter of Luksch et al. Table 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum MipFilter {
    /// 2×2 box: the standard MIP map.
    Box2,
    /// 4×4 Gaussian (binomial 1 3 3 1), a pyramid of Gaussians.
    Gauss4,
    /// 6×6 Gaussian (binomial 1 5 10 10 5 1).
    Gauss6,
}

impl MipFilter {
    /// Every filter, narrowest first.
    pub const ALL: [MipFilter; 3] = [MipFilter::Box2, MipFilter::Gauss4, MipFilter::Gauss6];

    /// `box2`, `gauss4` or `gauss6`.
    pub fn name(self) -> &'static str {
        match self {
            MipFilter::Box2 => "box2",
            MipFilter::Gauss4 => "gauss4",
            MipFilter::Gauss6 => "gauss6",
        }
    }

    /// The separable 1D weights (sum 1), applied at fine texels 2i − p … 2i + 1 + p around
    /// coarse texel i: binomial coefficients, the even-length analogue of Adelson's
    /// Gaussian pyramid kernel, centred between the two fine texels a coarse one covers.
    pub fn weights(self) -> &'static [f32] {
        match self {
            MipFilter::Box2 => &[0.5, 0.5],
            MipFilter::Gauss4 => &[0.125, 0.375, 0.375, 0.125],
            MipFilter::Gauss6 => &[
                1.0 / 32.0,
                5.0 / 32.0,
                10.0 / 32.0,
                10.0 / 32.0,
                5.0 / 32.0,
                1.0 / 32.0,
            ],
        }
    }
}

/// Settings of the materials stage (a preset, then the scene's `bake.materials` overrides).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct MaterialsSettings {
    /// Samples per lobe the regular pattern should come closest to.
    pub sample_budget: u32,
    /// Density threshold ξ₀ of the patterns (Eq. 11).
    pub xi0: f32,
    /// Most circles tried when matching the budget.
    pub max_circles: u32,
    /// Finest angle a kernel texel subtends, degrees.
    pub kernel_texel_deg: f32,
    /// Largest kernel radius in texels.
    pub kernel_max_radius: u32,
    /// Sphere-map size of R, texels.
    pub sphere_map_size: u32,
    /// 1D-map size of R, texels.
    pub map_1d_size: u32,
    /// Albedo channel: sample grid per axis.
    pub albedo_steps: u32,
    /// Environment-map face size, texels (a power of two).
    pub env_map_size: u32,
    /// MIP filter of environment maps.
    pub env_filter: MipFilter,
    /// Environment-map rays per texel and axis.
    pub env_supersample: u32,
}

impl MaterialsSettings {
    /// The preset's values. Pattern budgets follow Luksch §8 (about 20 samples per pixel
    /// are affordable; ξ₀ = 0.2 at 14–17 samples, smaller at larger budgets); kernel pitch
    /// and R-map sizes double with each preset.
    pub fn preset(quality: Quality) -> MaterialsSettings {
        match quality {
            Quality::Draft => MaterialsSettings {
                sample_budget: 14,
                xi0: 0.2,
                max_circles: 64,
                kernel_texel_deg: 0.5,
                kernel_max_radius: 7,
                sphere_map_size: 64,
                map_1d_size: 64,
                albedo_steps: 16,
                env_map_size: 64,
                env_filter: MipFilter::Box2,
                env_supersample: 1,
            },
            Quality::Default => MaterialsSettings {
                sample_budget: 20,
                xi0: 0.1,
                max_circles: 64,
                kernel_texel_deg: 0.25,
                kernel_max_radius: 15,
                sphere_map_size: 128,
                map_1d_size: 128,
                albedo_steps: 32,
                env_map_size: 128,
                env_filter: MipFilter::Gauss6,
                env_supersample: 2,
            },
            Quality::High => MaterialsSettings {
                sample_budget: 64,
                xi0: 0.05,
                max_circles: 64,
                kernel_texel_deg: 0.125,
                kernel_max_radius: 31,
                sphere_map_size: 256,
                map_1d_size: 256,
                albedo_steps: 48,
                env_map_size: 256,
                env_filter: MipFilter::Gauss6,
                env_supersample: 3,
            },
        }
    }

    /// The preset `quality`, then each of `overrides` in turn, checked ([`Self::check`]).
    pub fn resolve(
        quality: Quality,
        overrides: &[&MaterialsOverride],
    ) -> Result<MaterialsSettings, SettingError> {
        let mut s = Self::preset(quality);
        for over in overrides {
            let MaterialsOverride {
                sample_budget,
                env_map_size,
            } = **over;
            s.sample_budget = sample_budget.unwrap_or(s.sample_budget);
            s.env_map_size = env_map_size.unwrap_or(s.env_map_size);
        }
        s.check()?;
        Ok(s)
    }

    /// Checks every value: sizes and counts within their ranges, `env_map_size` a power of
    /// two, ξ₀ in (0, 1], kernel texels in (0°, 45°].
    pub fn check(&self) -> Result<(), SettingError> {
        let sizes = [
            ("sample_budget", self.sample_budget, 100_000),
            ("max_circles", self.max_circles, 4096),
            ("kernel_max_radius", self.kernel_max_radius, 1024),
            ("sphere_map_size", self.sphere_map_size, 4096),
            ("map_1d_size", self.map_1d_size, 65536),
            ("albedo_steps", self.albedo_steps, 4096),
            ("env_supersample", self.env_supersample, 16),
        ];
        for (name, v, hi) in sizes {
            if !(1..=hi).contains(&v) {
                return Err(SettingError::new(name, format!("{v} is not in 1 ..= {hi}")));
            }
        }
        let e = self.env_map_size;
        if !(4..=4096).contains(&e) || !e.is_power_of_two() {
            return Err(SettingError::new(
                "env_map_size",
                format!("{e} is not a power of two in 4 ..= 4096"),
            ));
        }
        if !(self.xi0 > 0.0 && self.xi0 <= 1.0) {
            return Err(SettingError::new(
                "xi0",
                format!("{} is not in (0, 1]", self.xi0),
            ));
        }
        if !(self.kernel_texel_deg > 0.0 && self.kernel_texel_deg <= 45.0) {
            return Err(SettingError::new(
                "kernel_texel_deg",
                format!("{} is not in (0, 45] degrees", self.kernel_texel_deg),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overrides_are_checked() {
        let over = MaterialsOverride {
            sample_budget: Some(0),
            env_map_size: None,
        };
        assert_eq!(
            MaterialsSettings::resolve(Quality::Default, &[&over])
                .unwrap_err()
                .field,
            "sample_budget"
        );
        let over = MaterialsOverride {
            sample_budget: Some(30),
            env_map_size: Some(100),
        };
        assert!(
            MaterialsSettings::resolve(Quality::Default, &[&over])
                .unwrap_err()
                .message
                .contains("power of two")
        );
        let over = MaterialsOverride {
            sample_budget: Some(30),
            env_map_size: Some(512),
        };
        let s = MaterialsSettings::resolve(Quality::Draft, &[&over]).unwrap();
        assert_eq!((s.sample_budget, s.env_map_size), (30, 512));
    }
}
