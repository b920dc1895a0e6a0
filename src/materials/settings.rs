//! The materials stage's settings: a quality preset, then the scene's `bake.materials`
//! overrides. Recorded in the stage's index and manifest record.

use serde::{Deserialize, Serialize};

use super::envmap::MipFilter;
use crate::scene::Quality;
use crate::scene::desc::{MaterialsOverride, SettingError};

/// Settings of the materials stage (a preset, then the scene's `bake.materials` overrides).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
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

    /// The preset with the scene's overrides; an invalid override is `Err((field, why))`
    /// with the field as written in scene.json ([`MaterialsSettings::check`]).
    pub fn resolve(
        quality: Quality,
        over: &MaterialsOverride,
    ) -> Result<MaterialsSettings, (String, String)> {
        let mut s = Self::preset(quality);
        if let Some(b) = over.sample_budget {
            s.sample_budget = b;
        }
        if let Some(e) = over.env_map_size {
            s.env_map_size = e;
        }
        s.check()
            .map_err(|e| (format!("bake.materials.{}", e.field), e.message))?;
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
            MaterialsSettings::resolve(Quality::Default, &over)
                .unwrap_err()
                .0,
            "bake.materials.sample_budget"
        );
        let over = MaterialsOverride {
            sample_budget: Some(30),
            env_map_size: Some(100),
        };
        assert!(
            MaterialsSettings::resolve(Quality::Default, &over)
                .unwrap_err()
                .1
                .contains("power of two")
        );
        let over = MaterialsOverride {
            sample_budget: Some(30),
            env_map_size: Some(512),
        };
        let s = MaterialsSettings::resolve(Quality::Draft, &over).unwrap();
        assert_eq!((s.sample_budget, s.env_map_size), (30, 512));
    }
}
