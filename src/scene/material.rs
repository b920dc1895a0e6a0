//! Materials as the bakers see them, and the mapping from glTF metallic/roughness.

use glam::Vec3;
use serde::Serialize;

use super::desc::{KurtLobe, MaterialOverride};

/// Roughness below which a dielectric glTF material gets a glossy lobe. Rougher ones are
/// treated as diffuse: their Beckmann lobe (m = roughness² ≥ 0.36) is too wide for
/// reflections to be worth baking.
pub const GLOSSY_ROUGHNESS_MAX: f32 = 0.6;

/// glTF's Fresnel reflectance at normal incidence for dielectrics.
pub const DIELECTRIC_F0: f32 = 0.04;

/// Smallest Beckmann roughness; below it a lobe is a mirror for every purpose.
pub const MIN_BECKMANN_M: f32 = 1e-4;

/// A resolved material: diffuse albedo, emission and Kurt et al. lobes.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Material {
    /// glTF material name (`default` for primitives without one).
    pub name: String,
    /// Diffuse albedo k_d (linear RGB).
    pub albedo: Vec3,
    /// Emitted radiance (linear RGB).
    pub emission: Vec3,
    /// Specular lobes (empty: purely diffuse).
    pub lobes: Vec<KurtLobe>,
}

impl Material {
    /// Whether the material has at least one glossy lobe.
    pub fn is_glossy(&self) -> bool {
        !self.lobes.is_empty()
    }

    /// Whether the material emits light.
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// The narrowest lobe's roughness max(mx, my), or `None` for a diffuse material.
    pub fn sharpest_roughness(&self) -> Option<f32> {
        self.lobes
            .iter()
            .map(|l| l.mx.max(l.my))
            .min_by(|a, b| a.total_cmp(b))
    }

    /// Maps a glTF metallic/roughness material to the Kurt model.
    ///
    /// - k_d = base colour × (1 − metallic): metals have no diffuse term; × (1 − 0.04) when
    ///   there is a lobe, so a white glossy dielectric conserves energy at normal incidence.
    /// - One lobe when the surface is smooth enough (roughness < [`GLOSSY_ROUGHNESS_MAX`]) or
    ///   metallic ≥ 0.5: k_s = mix(white, base colour, metallic) carries the metal's colour,
    ///   r0 = mix(0.04, 1, metallic) (0.04: the glTF dielectric F0), Beckmann m = roughness²
    ///   (glTF roughness is perceptual: α_GGX = roughness², and Beckmann m ≈ α_GGX for the
    ///   lobe widths used here), clamped to ≥ [`MIN_BECKMANN_M`]; isotropic, α = 0 so that
    ///   the directional albedo stays ≤ 1.
    /// - emission = emissive factor × `KHR_materials_emissive_strength`.
    pub fn from_gltf(
        name: &str,
        base_color: [f32; 4],
        metallic: f32,
        roughness: f32,
        emissive: [f32; 3],
        emissive_strength: f32,
    ) -> Material {
        let base = Vec3::new(base_color[0], base_color[1], base_color[2]);
        let metallic = metallic.clamp(0.0, 1.0);
        let roughness = roughness.clamp(0.0, 1.0);
        let mut lobes = Vec::new();
        let mut albedo = base * (1.0 - metallic);
        if roughness < GLOSSY_ROUGHNESS_MAX || metallic >= 0.5 {
            // What the lobe reflects at normal incidence is not also diffused.
            albedo *= 1.0 - DIELECTRIC_F0;
            let ks = Vec3::ONE.lerp(base, metallic);
            let m = (roughness * roughness).max(MIN_BECKMANN_M);
            lobes.push(KurtLobe {
                ks: ks.to_array(),
                r0: DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * metallic,
                mx: m,
                my: m,
                alpha: 0.0,
            });
        }
        Material {
            name: name.to_owned(),
            albedo,
            emission: Vec3::from_array(emissive) * emissive_strength,
            lobes,
        }
    }

    /// Applies scene.json overrides.
    pub fn apply(&mut self, over: &MaterialOverride) {
        if let Some(a) = over.albedo {
            self.albedo = Vec3::from_array(a);
        }
        if let Some(e) = over.emission {
            self.emission = Vec3::from_array(e);
        }
        if let Some(l) = &over.lobes {
            self.lobes = l.clone();
        }
    }

    /// Checks the values' ranges; returns the offending field and why.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        let finite = |v: Vec3| v.is_finite();
        if !finite(self.albedo) || self.albedo.min_element() < 0.0 {
            return Err(("albedo", format!("{} is not ≥ 0 and finite", self.albedo)));
        }
        if self.albedo.max_element() >= 1.0 {
            return Err((
                "albedo",
                format!(
                    "{} has a channel ≥ 1: radiosity cannot converge (energy would grow at every bounce)",
                    self.albedo
                ),
            ));
        }
        if !finite(self.emission) || self.emission.min_element() < 0.0 {
            return Err((
                "emission",
                format!("{} is not ≥ 0 and finite", self.emission),
            ));
        }
        for (i, l) in self.lobes.iter().enumerate() {
            let ok = l.ks.iter().all(|k| k.is_finite() && *k >= 0.0)
                && (0.0..=1.0).contains(&l.r0)
                && l.mx.is_finite()
                && l.my.is_finite()
                && l.mx > 0.0
                && l.my > 0.0
                && (0.0..=1.0).contains(&l.alpha);
            if !ok {
                let [r, g, b] = l.ks;
                return Err((
                    "lobes",
                    format!(
                        "lobe {i} (ks [{r}, {g}, {b}], r0 {}, mx {}, my {}, alpha {}): need ks ≥ 0, r0 and alpha in [0, 1], mx and my > 0 and finite",
                        l.r0, l.mx, l.my, l.alpha
                    ),
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rough_dielectric_is_diffuse_only() {
        let m = Material::from_gltf("wall", [0.8, 0.5, 0.2, 1.0], 0.0, 1.0, [0.0; 3], 1.0);
        assert!(!m.is_glossy());
        assert_eq!(m.albedo, Vec3::new(0.8, 0.5, 0.2));
    }

    #[test]
    fn smooth_metal_is_a_coloured_lobe_without_diffuse() {
        let m = Material::from_gltf("gold", [1.0, 0.8, 0.3, 1.0], 1.0, 0.1, [0.0; 3], 1.0);
        assert_eq!(m.albedo, Vec3::ZERO);
        let l = m.lobes[0];
        assert_eq!(l.ks, [1.0, 0.8, 0.3]);
        assert_eq!(l.r0, 1.0);
        assert!((l.mx - 0.01).abs() < 1e-7 && l.mx == l.my);
    }

    #[test]
    fn roughness_zero_clamps_to_a_mirror_not_zero() {
        let m = Material::from_gltf("mirror", [1.0; 4], 1.0, 0.0, [0.0; 3], 1.0);
        assert_eq!(m.sharpest_roughness(), Some(MIN_BECKMANN_M));
        assert!(m.check().is_ok());
    }

    #[test]
    fn white_glossy_dielectric_leaves_room_for_its_lobe() {
        let m = Material::from_gltf("plastic", [1.0; 4], 0.0, 0.3, [0.0; 3], 1.0);
        assert!(m.is_glossy());
        assert_eq!(m.albedo, Vec3::splat(0.96));
        assert!(m.check().is_ok());
    }

    #[test]
    fn emissive_strength_scales_emission() {
        let m = Material::from_gltf(
            "light",
            [0.0, 0.0, 0.0, 1.0],
            0.0,
            1.0,
            [1.0, 0.5, 0.25],
            17.0,
        );
        assert_eq!(m.emission, Vec3::new(17.0, 8.5, 4.25));
        assert!(m.is_emissive());
    }

    #[test]
    fn albedo_of_one_is_rejected() {
        let m = Material::from_gltf("white", [1.0, 1.0, 1.0, 1.0], 0.0, 1.0, [0.0; 3], 1.0);
        let (field, _) = m.check().unwrap_err();
        assert_eq!(field, "albedo");
    }

    #[test]
    fn overrides_replace_fields() {
        let mut m = Material::from_gltf("floor", [0.5; 4], 0.0, 1.0, [0.0; 3], 1.0);
        let lobe = KurtLobe {
            ks: [0.3; 3],
            r0: 0.05,
            mx: 0.1,
            my: 0.1,
            alpha: 0.0,
        };
        m.apply(&MaterialOverride {
            albedo: Some([0.2, 0.2, 0.2]),
            emission: None,
            lobes: Some(vec![lobe]),
        });
        assert_eq!(m.albedo, Vec3::splat(0.2));
        assert_eq!(m.lobes, vec![lobe]);
    }
}
