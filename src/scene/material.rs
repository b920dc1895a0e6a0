//! Materials as the bakers see them, and the mapping from glTF metallic/roughness.

use glam::Vec3;
use serde::Serialize;

use super::desc::{LobeDesc, LobeModel, MaterialOverride};
use super::texture::{Sampler, UvTransform};
use crate::brdf::{Brdf, Lobe};

/// Roughness below which a dielectric glTF material gets a glossy lobe. Rougher ones are
/// treated as diffuse: their GGX lobe (α = roughness² ≥ 0.36) is too wide for reflections to
/// be worth baking, and the solver, probes and viewer treat such a wall as Lambertian.
pub const GLOSSY_ROUGHNESS_MAX: f32 = 0.6;

/// glTF's Fresnel reflectance at normal incidence for dielectrics (IOR 1.5).
pub const DIELECTRIC_F0: f32 = 0.04;

/// Smallest lobe width (GGX α or Beckmann m) a glTF material maps to; below it a lobe is a
/// mirror for every purpose.
pub const MIN_LOBE_WIDTH: f32 = 1e-4;

/// The former name of [`MIN_LOBE_WIDTH`].
pub const MIN_BECKMANN_M: f32 = MIN_LOBE_WIDTH;

/// A resolved material: diffuse albedo, emission and glossy lobes.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Material {
    /// glTF material name (`default` for primitives without one).
    pub name: String,
    /// Diffuse albedo k_d (linear RGB).
    pub albedo: Vec3,
    /// Emitted radiance (linear RGB).
    pub emission: Vec3,
    /// Specular lobes (empty: purely diffuse).
    pub lobes: Vec<LobeDesc>,
    /// glTF `baseColorTexture`: its RGB multiplies [`Material::albedo`], its alpha the alpha
    /// factor (the texture modulates the diffuse term; a metal's F₀ keeps the factor).
    #[serde(skip)]
    pub base_texture: Option<TextureRef>,
    /// glTF `emissiveTexture`: its RGB multiplies [`Material::emission`].
    #[serde(skip)]
    pub emissive_texture: Option<TextureRef>,
    /// Base colour alpha factor (glTF `baseColorFactor[3]`).
    #[serde(skip)]
    pub alpha_factor: f32,
    /// Whether rays pass through where alpha is below a cutoff.
    #[serde(skip)]
    pub alpha_mode: AlphaMode,
    /// glTF `doubleSided`: a ray meeting the back face is reflected as by the front face (the
    /// two sides share the surface's lightmap texels) instead of stopping as black.
    #[serde(skip)]
    pub double_sided: bool,
    /// Thin transmission (glTF `KHR_materials_transmission`); [`Transmission::NONE`] for an
    /// opaque material, which serializes as before.
    #[serde(skip_serializing_if = "Transmission::is_none")]
    pub transmission: Transmission,
}

/// Thin-glass transmission: light passes straight through the surface (no refraction: the
/// surface has no thickness), scaled by `tint` × `factor` × (1 − F), F the dielectric Fresnel
/// reflectance of `ior` (Schlick). The material's diffuse albedo already carries
/// (1 − `factor`); its Fresnel reflection F is its glossy lobe.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Transmission {
    /// glTF `transmissionFactor` in [0, 1] (0: opaque). `transmissionTexture` is not read.
    pub factor: f32,
    /// Colour of the transmitted light: the base colour factor (linear RGB).
    pub tint: Vec3,
    /// Index of refraction (`KHR_materials_ior`, 1.5 by default).
    pub ior: f32,
}

impl Transmission {
    /// An opaque material's.
    pub const NONE: Transmission = Transmission {
        factor: 0.0,
        tint: Vec3::ONE,
        ior: DEFAULT_IOR,
    };

    /// Whether nothing is transmitted.
    pub fn is_none(&self) -> bool {
        self.factor <= 0.0
    }

    /// Fresnel reflectance at normal incidence, ((n − 1)/(n + 1))².
    pub fn f0(&self) -> f32 {
        f0_of_ior(self.ior)
    }

    /// Fraction of the radiance arriving at angle cos θ (either side) that leaves straight
    /// through: tint × factor × (1 − F(cos θ)).
    pub fn weight(&self, cos: f32) -> Vec3 {
        if self.is_none() {
            return Vec3::ZERO;
        }
        let f = crate::brdf::kurt::fresnel_schlick(self.f0(), cos.abs().min(1.0));
        self.tint * (self.factor * (1.0 - f))
    }
}

/// glTF's default index of refraction (`KHR_materials_ior`).
pub const DEFAULT_IOR: f32 = 1.5;

/// Dielectric Fresnel reflectance at normal incidence for index of refraction `ior` (in air).
pub fn f0_of_ior(ior: f32) -> f32 {
    let r = (ior - 1.0) / (ior + 1.0);
    r * r
}

/// A material's use of one texture: which image, how it is sampled, which UV set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    /// Index into [`super::Scene::textures`].
    pub image: u32,
    /// Sampler (wrap modes and filter).
    pub sampler: Sampler,
    /// Which UV set: 0 (`TEXCOORD_0`) or 1 (`TEXCOORD_1`).
    pub tex_coord: u32,
    /// `KHR_texture_transform`.
    pub transform: UvTransform,
}

/// glTF `alphaMode`, as rays see it.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum AlphaMode {
    /// Alpha ignored.
    #[default]
    Opaque,
    /// Rays pass where alpha < `cutoff` (glTF MASK; BLEND is read as MASK with cutoff ½).
    Mask {
        /// glTF `alphaCutoff` (default ½).
        cutoff: f32,
    },
}

/// The `ggx` lobes whose sum is the glTF specular term with Schlick Fresnel of RGB
/// reflectance `f0` at normal incidence and GGX width `alpha`.
///
/// glint's lobes have a scalar r0 and an RGB k_s, and k_s (r0 + (1 − r0) w) with
/// w = (1 − V·H)⁵ equals f0 + (1 − f0) w for every w only when f0 is grey (k_s = 1, r0 = f0).
/// A coloured f0 is split exactly into two lobes of the same D and G:
/// f0 + (1 − f0) w = f0 · [r0 = 1: F ≡ 1] + (1 − f0) · [r0 = 0: F = w].
pub fn gltf_specular_lobes(f0: Vec3, alpha: f32) -> Vec<LobeDesc> {
    let lobe = |ks: Vec3, r0: f32| LobeDesc {
        model: LobeModel::Ggx,
        ks: ks.to_array(),
        r0,
        mx: alpha,
        my: alpha,
        alpha: None,
    };
    if f0.x == f0.y && f0.y == f0.z {
        vec![lobe(Vec3::ONE, f0.x)]
    } else {
        vec![lobe(f0, 1.0), lobe(Vec3::ONE - f0, 0.0)]
    }
}

impl Material {
    /// Whether the material has at least one glossy lobe.
    pub fn is_glossy(&self) -> bool {
        !self.lobes.is_empty()
    }

    /// Whether any texture modulates the material (its lightmap texels average it over their
    /// footprints; with a base colour texture they hold D over that texture's mean, see
    /// [`super::texturing`]).
    pub fn is_textured(&self) -> bool {
        self.base_texture.is_some() || self.emissive_texture.is_some()
    }

    /// Whether rays may pass through the material (alpha MASK).
    pub fn has_cutouts(&self) -> bool {
        matches!(self.alpha_mode, AlphaMode::Mask { .. })
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

    /// Maps a glTF metallic/roughness material to glint's k_d/π + Σ k_s f_lobe with `ggx`
    /// lobes, following glTF 2.0 Appendix B:
    ///
    /// ```text
    /// f = mix(fresnel_mix(diffuse(c), spec), conductor_fresnel(c, spec), metallic)
    ///   = (1 − metallic) c/π (1 − F_d) + spec · (f0 + (1 − f0)(1 − V·H)⁵),
    /// f0 = mix(0.04, c, metallic),  F_d = 0.04 + 0.96 (1 − V·H)⁵,  spec = D V (α = roughness²)
    /// ```
    ///
    /// - Specular: exactly the second term, as [`gltf_specular_lobes`] (one lobe for a grey
    ///   f0, two for a coloured one); α = roughness² clamped to ≥ [`MIN_LOBE_WIDTH`],
    ///   isotropic.
    /// - Diffuse: glint's diffuse term is Lambertian (the radiosity solution is
    ///   view-independent), so 1 − F_d is taken at normal incidence, V·H = 1:
    ///   k_d = c (1 − metallic)(1 − 0.04). This is exact at normal incidence; towards grazing
    ///   Appendix B moves up to 96 % of the diffuse energy into the lobe, which glint keeps in
    ///   the diffuse term.
    /// - Rough dielectrics (roughness ≥ [`GLOSSY_ROUGHNESS_MAX`] and metallic < 0.5) keep
    ///   only the diffuse term, k_d = c (1 − metallic).
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
            // fresnel_mix at V·H = 1: what the lobe reflects at normal incidence is not also
            // diffused.
            albedo *= 1.0 - DIELECTRIC_F0;
            let f0 = Vec3::splat(DIELECTRIC_F0).lerp(base, metallic);
            let alpha = (roughness * roughness).max(MIN_LOBE_WIDTH);
            lobes = gltf_specular_lobes(f0, alpha);
        }
        Material {
            name: name.to_owned(),
            albedo,
            emission: Vec3::from_array(emissive) * emissive_strength,
            lobes,
            base_texture: None,
            emissive_texture: None,
            alpha_factor: base_color[3],
            alpha_mode: AlphaMode::Opaque,
            double_sided: false,
            transmission: Transmission {
                tint: base,
                ..Transmission::NONE
            },
        }
    }

    /// Makes the material thin glass with glTF `transmissionFactor` `factor` and index of
    /// refraction `ior`: the diffuse albedo keeps (1 − factor) of itself, and a dielectric's
    /// Fresnel lobe (glTF's r0 0.04, for IOR 1.5) takes the r0 of `ior`.
    pub fn set_transmission(&mut self, factor: f32, ior: f32) {
        let old = self.transmission.factor;
        let before = if old < 1.0 {
            self.albedo / (1.0 - old)
        } else {
            Vec3::ZERO
        };
        self.albedo = before * (1.0 - factor);
        let f0 = f0_of_ior(ior);
        for l in &mut self.lobes {
            if (l.r0 - f0_of_ior(self.transmission.ior)).abs() < 1e-6 && l.ks == [1.0; 3] {
                l.r0 = f0;
            }
        }
        self.transmission.factor = factor;
        self.transmission.ior = ior;
    }

    /// Whether light passes through the material (thin transmission).
    pub fn is_transmissive(&self) -> bool {
        !self.transmission.is_none()
    }

    /// Applies scene.json overrides.
    pub fn apply(&mut self, over: &MaterialOverride) {
        if over.transmission.is_some() || over.ior.is_some() {
            self.set_transmission(
                over.transmission.unwrap_or(self.transmission.factor),
                over.ior.unwrap_or(self.transmission.ior),
            );
        }
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
        let t = &self.transmission;
        if !(0.0..=1.0).contains(&t.factor) {
            return Err(("transmission", format!("{} is not in [0, 1]", t.factor)));
        }
        if !(t.ior.is_finite() && t.ior >= 1.0) {
            return Err(("ior", format!("{} is not ≥ 1 and finite", t.ior)));
        }
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
                && l.alpha.is_none_or(|a| (0.0..=1.0).contains(&a));
            let [r, g, b] = l.ks;
            let alpha = l.alpha.map_or("none".to_string(), |a| a.to_string());
            let model = l.model.name();
            if !ok {
                return Err((
                    "lobes",
                    format!(
                        "lobe {i} (model {model}, ks [{r}, {g}, {b}], r0 {}, mx {}, my {}, alpha {alpha}): need ks ≥ 0, r0 and alpha in [0, 1], mx and my > 0 and finite",
                        l.r0, l.mx, l.my
                    ),
                ));
            }
            match (l.model, l.alpha) {
                (LobeModel::Kurt, None) => {
                    return Err((
                        "lobes",
                        format!(
                            "lobe {i} (model kurt): needs `alpha`, the shadowing exponent in [0, 1] (0 keeps the albedo ≤ 1)"
                        ),
                    ));
                }
                (LobeModel::Ggx | LobeModel::Beckmann, Some(_)) => {
                    return Err((
                        "lobes",
                        format!(
                            "lobe {i} (model {model}): `alpha` is the kurt model's shadowing exponent; {model} has Smith shadowing and takes ks, r0, mx, my (remove alpha, or name \"model\": \"kurt\")"
                        ),
                    ));
                }
                _ => {}
            }
        }
        Ok(())
    }
}

/// The lobe a scene.json lobe describes.
impl From<&LobeDesc> for Lobe {
    fn from(l: &LobeDesc) -> Lobe {
        Lobe {
            ks: Vec3::from_array(l.ks),
            r0: l.r0,
            mx: l.mx,
            my: l.my,
            alpha: l.alpha.unwrap_or(0.0),
            model: l.model,
        }
    }
}

/// The BRDF of a material (Eq. 1).
impl From<&Material> for Brdf {
    fn from(m: &Material) -> Brdf {
        Brdf {
            kd: m.albedo,
            lobes: m.lobes.iter().map(Lobe::from).collect(),
        }
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
        // Appendix B's conductor Fresnel f0 + (1 − f0)(1 − V·H)⁵ with f0 = base colour: the
        // second lobe carries (1 − f0)(1 − V·H)⁵.
        assert_eq!(m.lobes.len(), 2);
        let w = m.lobes[1];
        assert_eq!((w.r0, w.mx, w.model), (0.0, l.mx, LobeModel::Ggx));
        for (k, want) in w.ks.iter().zip([0.0, 0.2, 0.7]) {
            assert!((k - want).abs() < 1e-6);
        }
        assert_eq!(l.model, LobeModel::Ggx);
        assert!(m.check().is_ok());
    }

    #[test]
    fn gltf_specular_lobes_sum_to_the_rgb_schlick_fresnel() {
        use crate::brdf::kurt::fresnel_schlick;
        let f0 = Vec3::new(0.9, 0.6, 0.2);
        let lobes = gltf_specular_lobes(f0, 0.2);
        for u in [0.0f32, 0.1, 0.5, 0.9, 1.0] {
            let got = lobes.iter().fold(Vec3::ZERO, |a, l| {
                a + Vec3::from_array(l.ks) * fresnel_schlick(l.r0, u)
            });
            let w = (1.0 - u).powi(5);
            let want = f0 + (Vec3::ONE - f0) * w;
            assert!(
                (got - want).abs().max_element() < 1e-6,
                "u={u}: {got} vs {want}"
            );
        }
        let grey = gltf_specular_lobes(Vec3::splat(0.04), 0.2);
        assert_eq!(grey.len(), 1);
        assert_eq!((grey[0].ks, grey[0].r0), ([1.0; 3], 0.04));
    }

    #[test]
    fn alpha_belongs_to_kurt_alone() {
        let mut m = Material::from_gltf("floor", [0.5; 4], 0.0, 0.3, [0.0; 3], 1.0);
        m.lobes[0].alpha = Some(0.5);
        let (field, msg) = m.check().unwrap_err();
        assert_eq!(field, "lobes");
        assert!(
            msg.contains("model ggx") && msg.contains("remove alpha"),
            "{msg}"
        );
        m.lobes[0].model = LobeModel::Kurt;
        assert!(m.check().is_ok());
        m.lobes[0].alpha = None;
        let (_, msg) = m.check().unwrap_err();
        assert!(msg.contains("needs `alpha`"), "{msg}");
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
    fn thin_glass_keeps_one_minus_transmission_of_its_diffuse_and_takes_its_ior() {
        let mut m = Material::from_gltf("glass", [0.8, 0.6, 0.4, 1.0], 0.0, 0.0, [0.0; 3], 1.0);
        assert!(!m.is_transmissive());
        let opaque_albedo = m.albedo;
        m.set_transmission(0.75, 1.5);
        assert!(m.is_transmissive());
        assert!((m.albedo - opaque_albedo * 0.25).abs().max_element() < 1e-6);
        assert_eq!(m.transmission.tint, Vec3::new(0.8, 0.6, 0.4));
        assert!((m.lobes[0].r0 - 0.04).abs() < 1e-6);
        // Normal incidence: tint × factor × (1 − F₀); grazing: F = 1, nothing passes.
        let w = m.transmission.weight(-1.0);
        assert!(
            (w - Vec3::new(0.8, 0.6, 0.4) * 0.75 * 0.96)
                .abs()
                .max_element()
                < 1e-6
        );
        assert_eq!(m.transmission.weight(0.0), Vec3::ZERO);
        // IOR 2: F₀ = 1/9, in the transmission and in glTF's dielectric lobe.
        m.set_transmission(0.75, 2.0);
        assert!((m.transmission.f0() - 1.0 / 9.0).abs() < 1e-6);
        assert!((m.lobes[0].r0 - 1.0 / 9.0).abs() < 1e-6);
        assert!((m.albedo - opaque_albedo * 0.25).abs().max_element() < 1e-6);
        assert!(m.check().is_ok());
    }

    #[test]
    fn transmission_overrides_are_checked() {
        let mut m = Material::from_gltf("pane", [0.9; 4], 0.0, 1.0, [0.0; 3], 1.0);
        m.apply(&MaterialOverride {
            transmission: Some(0.5),
            ..Default::default()
        });
        assert!((m.albedo - Vec3::splat(0.45)).abs().max_element() < 1e-6);
        assert_eq!(m.transmission.ior, DEFAULT_IOR);
        // An albedo given with it is the diffuse albedo as the solve uses it.
        m.apply(&MaterialOverride {
            albedo: Some([0.1; 3]),
            transmission: Some(0.8),
            ..Default::default()
        });
        assert_eq!((m.albedo, m.transmission.factor), (Vec3::splat(0.1), 0.8));
        m.transmission.factor = 1.5;
        assert_eq!(m.check().unwrap_err().0, "transmission");
        m.transmission.factor = 0.5;
        m.transmission.ior = 0.9;
        assert_eq!(m.check().unwrap_err().0, "ior");
    }

    #[test]
    fn overrides_replace_fields() {
        let mut m = Material::from_gltf("floor", [0.5; 4], 0.0, 1.0, [0.0; 3], 1.0);
        let lobe = LobeDesc {
            model: LobeModel::Kurt,
            ks: [0.3; 3],
            r0: 0.05,
            mx: 0.1,
            my: 0.1,
            alpha: Some(0.0),
        };
        m.apply(&MaterialOverride {
            albedo: Some([0.2, 0.2, 0.2]),
            emission: None,
            lobes: Some(vec![lobe]),
            ..Default::default()
        });
        assert_eq!(m.albedo, Vec3::splat(0.2));
        assert_eq!(m.lobes, vec![lobe]);
    }
}
