//! How a reflector reflects (Bastos et al. 1999 §8.2), as the viewer reads it from the
//! bundle's `materials` stage: the kernel K it convolves the reflected image with (M*K) and
//! the reflectance modulation R it multiplies the result by. No wgpu here.
//!
//! - **K**: the lobe's kernel texture (normalized D·G, `texel_angle_rad` radians per texel at
//!   the reflection point). The viewer keeps its most significant taps ([`significant_taps`]:
//!   [`KERNEL_MASS`] of the weight, renormalized), which the composite reads through the
//!   constant-cost filter of [`super::filter`]. On screen a texel
//!   spans tan Δ · f / pitch pixels ([`texel_pixels`]), f = the fraction of the reflected
//!   ray's length beyond the reflector: a lobe of angle Δ at the reflection point blurs the
//!   reflected point over t_beyond · tan Δ, seen from the mirrored eye at t_total. Objects
//!   touching the mirror stay sharp, far ones blur by the full lobe. Kernel columns run along
//!   screen x, rows along screen up (exact for isotropic lobes, as Bastos's space-invariant
//!   kernel is); the composite squeezes them by cos θ across the plane of incidence, where a
//!   lobe seen at θ narrows ([`super::filter::Grazing`]).
//! - **R**: per view direction, Σ over lobes of ks × a channel of the baked map, from the
//!   sphere map (indexed by the reflected direction in the reflector's tangent frame) or the
//!   1D grazing-dense map (indexed by cos θ), switchable ([`ReflectanceLayout`]). Channel
//!   ([`ReflectanceChannel`]): the directional albedo `A` by default (the modulation that
//!   goes with a kernel normalized to 1; what the reference path tracer reproduces), or
//!   Bastos's literal `R` = F/(π cos²θ).
//!
//! A material with several lobes uses the kernel of its strongest lobe (largest ks) for all
//! of them; R sums all lobes.

use glam::{Vec2, Vec3};

use super::lobe_shape::LobeShape;
use crate::bundle::Bundle;
use crate::materials::MaterialsIndex;
use crate::materials::index::IndexedLobe;
use crate::materials::reflectance;
use crate::scene::desc::LobeDesc;

/// Entries of a 1D modulation table (the shader's `modulation` array).
pub const MODULATION_SIZE: usize = 64;

/// Fraction of the kernel's weight its kept taps must hold.
pub const KERNEL_MASS: f32 = 0.99;

pub use crate::view::options::{ReflectanceChannel, ReflectanceLayout};

/// ks·R of a reflector, in one of the two layouts.
#[derive(Clone, Debug, PartialEq)]
pub enum Modulation {
    /// [`MODULATION_SIZE`] entries at the 1D map's cosines ([`reflectance::map_1d_cos`]).
    OneD(Vec<Vec3>),
    /// A `size`² sphere map (row 0 at +bitangent), 0 outside the disk.
    Sphere {
        /// Texels per side.
        size: u32,
        /// Row-major texels.
        texels: Vec<Vec3>,
    },
}

impl Modulation {
    /// R = 1: ks at every direction.
    pub fn constant(ks: Vec3) -> Modulation {
        Modulation::OneD(vec![ks; MODULATION_SIZE])
    }

    /// ks·R for the reflected direction `r` = (r·tangent, r·bitangent, r·normal).
    pub fn at(&self, r: Vec3) -> Vec3 {
        match self {
            Modulation::OneD(table) => sample_modulation(table, r.z),
            Modulation::Sphere { size, texels } => {
                let [x, y] = sphere_texel(r, *size);
                texels[(y * size + x) as usize]
            }
        }
    }

    /// The 1D form: ks·R at the 1D map's cosines, for passes that index R by view angle only
    /// (a sphere map is read in the plane of incidence along the tangent).
    pub fn table_1d(&self) -> Vec<Vec3> {
        match self {
            Modulation::OneD(table) => table.clone(),
            Modulation::Sphere { .. } => (0..MODULATION_SIZE as u32)
                .map(|k| {
                    let c = reflectance::map_1d_cos(k, MODULATION_SIZE as u32);
                    self.at(Vec3::new((1.0 - c * c).max(0.0).sqrt(), 0.0, c))
                })
                .collect(),
        }
    }
}

/// ks·F per 1D-map cosine for a reflector without a materials stage: Σ over `lobes` of
/// k_s · Schlick's F(r₀, cos θ) (Kurt et al. 2010 Eq. 3; glTF 2.0 Appendix B's F), taken at
/// the mirror direction (V·H = cos θ, the value a narrow lobe reflects). A glTF metal of
/// coloured F₀, two lobes {k_s = F₀, r₀ = 1} + {k_s = 1 − F₀, r₀ = 0}, comes out F₀ at
/// normal incidence and whitens towards grazing, as Schlick's F does; a lobe of r₀ = 1 is
/// its k_s at every angle. Without the directional albedo's shadowing (that is R's part).
pub fn fresnel_table(lobes: &[LobeDesc]) -> Vec<Vec3> {
    (0..MODULATION_SIZE as u32)
        .map(|k| {
            let c = reflectance::map_1d_cos(k, MODULATION_SIZE as u32);
            lobes.iter().fold(Vec3::ZERO, |sum, l| {
                sum + Vec3::from_array(l.ks) * crate::brdf::kurt::fresnel_schlick(l.r0, c)
            })
        })
        .collect()
}

/// Linear lookup of a 1D modulation table at view cosine `cos_theta`, as the 1D map is read
/// ([`reflectance::sample_1d`]; the shader's `modulation` is the same).
pub fn sample_modulation(table: &[Vec3], cos_theta: f32) -> Vec3 {
    let channel = |k: usize| -> Vec<f32> { table.iter().map(|v| v[k]).collect() };
    Vec3::new(
        reflectance::sample_1d(&channel(0), cos_theta),
        reflectance::sample_1d(&channel(1), cos_theta),
        reflectance::sample_1d(&channel(2), cos_theta),
    )
}

/// The sphere-map texel of reflected direction `r` (tangent frame): the disk point (r_x, r_y)
/// (Bastos §8.2.2), its cosine bounded by [`reflectance::C_GRAZING`] as the bake does, looked
/// up nearest (the shader's `sphere_texel` is the same).
pub fn sphere_texel(r: Vec3, size: u32) -> [u32; 2] {
    let s = size.max(1) as f32;
    let mut d = Vec2::new(r.x, r.y);
    // Inside the last ring of texels whose centres are in the disk.
    let rim = (1.0 - reflectance::C_GRAZING * reflectance::C_GRAZING)
        .sqrt()
        .min(1.0 - 1.5 / s);
    if d.length() > rim {
        d = d.normalize_or_zero() * rim;
    }
    let x = ((d.x + 1.0) * 0.5 * s).floor().clamp(0.0, s - 1.0);
    let y = ((1.0 - d.y) * 0.5 * s).floor().clamp(0.0, s - 1.0);
    [x as u32, y as u32]
}

/// One kernel tap: offset in kernel texels (x along screen right, y along screen up) and its
/// weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tap {
    /// Offset in texels.
    pub offset: Vec2,
    /// Weight (the kept taps sum to 1).
    pub weight: f32,
}

/// K on screen: its kept taps and the angle of one texel.
#[derive(Clone, Debug, PartialEq)]
pub struct ScreenKernel {
    /// Angle one texel subtends at the reflection point (radians).
    pub texel_angle: f32,
    /// The taps, heaviest first.
    pub taps: Vec<Tap>,
    /// How the lobe K was baked from leans and narrows at each view angle.
    pub shape: LobeShape,
}

impl ScreenKernel {
    /// K = identity (a mirror).
    pub fn identity() -> ScreenKernel {
        ScreenKernel {
            texel_angle: 0.0,
            taps: vec![Tap {
                offset: Vec2::ZERO,
                weight: 1.0,
            }],
            shape: LobeShape::mirror_limit(),
        }
    }

    /// Whether it is the identity.
    pub fn is_identity(&self) -> bool {
        self.taps.len() == 1 && self.taps[0].offset == Vec2::ZERO
    }
}

/// The heaviest taps of a `size`² kernel (row-major, row 0 at +y, summing to about 1) that
/// hold `mass` of its weight, at most `max_taps`, renormalized to sum to 1.
pub fn significant_taps(weights: &[f32], size: u32, mass: f32, max_taps: usize) -> Vec<Tap> {
    let r = (size / 2) as i32;
    let mut taps: Vec<Tap> = weights
        .iter()
        .enumerate()
        .filter(|(_, w)| **w > 0.0)
        .map(|(k, &w)| {
            let (i, j) = ((k as u32 % size) as i32, (k as u32 / size) as i32);
            Tap {
                offset: Vec2::new((i - r) as f32, (r - j) as f32),
                weight: w,
            }
        })
        .collect();
    taps.sort_by(|a, b| b.weight.total_cmp(&a.weight));
    let total: f32 = taps.iter().map(|t| t.weight).sum();
    let mut kept = 0.0;
    let mut n = 0;
    for t in &taps {
        if n >= max_taps.max(1) || (n > 0 && kept >= mass * total) {
            break;
        }
        kept += t.weight;
        n += 1;
    }
    taps.truncate(n);
    if kept > 0.0 {
        for t in &mut taps {
            t.weight /= kept;
        }
    }
    taps
}

/// Screen pixels per kernel texel for the reflected point at fraction `f` of the reflected
/// ray beyond the reflector: tan Δ · f over the view's pixel pitch `pixel_tangent`.
pub fn texel_pixels(texel_angle: f32, f: f32, pixel_tangent: f32) -> f32 {
    texel_angle.tan() * f / pixel_tangent.max(1e-12)
}

/// The fraction of the ray from the mirrored eye to a reflected point beyond the plane:
/// s_p / (s_p + s_e), the point's and the real eye's distances from the plane.
pub fn beyond_fraction(point_side: f32, eye_side: f32) -> f32 {
    let s = point_side.max(0.0);
    let total = s + eye_side.max(0.0);
    if total > 0.0 { s / total } else { 0.0 }
}

/// K and ks·R of material `name` from the bundle's materials stage (with its index), every
/// file read hash-checked.
pub fn load_material(
    bundle: &Bundle,
    index: &MaterialsIndex,
    name: &str,
    layout: ReflectanceLayout,
    channel: ReflectanceChannel,
) -> Result<(ScreenKernel, Modulation), String> {
    let read = |path: &str| -> Result<crate::image_io::ExrImage, String> {
        MaterialsIndex::read_image(bundle, path).map_err(|e| e.to_string())
    };
    load_material_from(&read, index, name, layout, channel)
}

/// [`load_material`] with the stage's images read by `read` (a path as the index lists it).
pub fn load_material_from(
    read: &dyn Fn(&str) -> Result<crate::image_io::ExrImage, String>,
    index: &MaterialsIndex,
    name: &str,
    layout: ReflectanceLayout,
    channel: ReflectanceChannel,
) -> Result<(ScreenKernel, Modulation), String> {
    let material = index
        .material(name)
        .ok_or_else(|| format!("material {name:?} is not in materials/index.json"))?;
    let finite = |path: &str, v: &[f32]| -> Result<(), String> {
        if v.is_empty() || !v.iter().all(|x| x.is_finite()) {
            return Err(format!("{path}: empty or non-finite"));
        }
        Ok(())
    };
    let mut modulation: Option<Modulation> = None;
    let mut strongest: Option<(f32, &IndexedLobe)> = None;
    for lobe in &material.lobes {
        let ks = Vec3::from(lobe.ks);
        let weight = ks.x + ks.y + ks.z;
        if strongest.is_none_or(|(w, _)| weight > w) {
            strongest = Some((weight, lobe));
        }
        match layout {
            ReflectanceLayout::OneD => {
                let path = &lobe
                    .reflectance_1d
                    .as_ref()
                    .ok_or_else(|| {
                        format!(
                            "material {name:?}: a lobe has no 1D reflectance map (anisotropic?)"
                        )
                    })?
                    .path;
                let image = read(path)?;
                let values = image
                    .channel(channel.exr_channel())
                    .map_err(|e| format!("{path}: {e}"))?;
                finite(path, values)?;
                let table = match modulation
                    .get_or_insert_with(|| Modulation::OneD(vec![Vec3::ZERO; MODULATION_SIZE]))
                {
                    Modulation::OneD(t) => t,
                    Modulation::Sphere { .. } => unreachable!("one layout per material"),
                };
                for (k, t) in table.iter_mut().enumerate() {
                    let c = reflectance::map_1d_cos(k as u32, MODULATION_SIZE as u32);
                    *t += ks * reflectance::sample_1d(values, c);
                }
            }
            ReflectanceLayout::Sphere => {
                let path = &lobe.reflectance_sphere.path;
                let image = read(path)?;
                if image.width != image.height {
                    return Err(format!("{path}: not square"));
                }
                let values = image
                    .channel(channel.exr_channel())
                    .map_err(|e| format!("{path}: {e}"))?;
                finite(path, values)?;
                let size = image.width as u32;
                let m = modulation.get_or_insert_with(|| Modulation::Sphere {
                    size,
                    texels: vec![Vec3::ZERO; (size * size) as usize],
                });
                match m {
                    Modulation::Sphere { size: s, texels } if *s == size => {
                        for (t, v) in texels.iter_mut().zip(values) {
                            *t += ks * *v;
                        }
                    }
                    _ => return Err(format!("material {name:?}: sphere maps of different sizes")),
                }
            }
        }
    }
    let (_, lobe) = strongest.ok_or_else(|| format!("material {name:?} has no lobes"))?;
    let kernel = &lobe.kernel;
    let kernel = if kernel.identity {
        ScreenKernel::identity()
    } else {
        let path = &kernel.path;
        let image = read(path)?;
        let w = image.channel("Y").map_err(|e| format!("{path}: {e}"))?;
        finite(path, w)?;
        if image.width != image.height || image.width % 2 == 0 {
            return Err(format!("{path}: a kernel is square and odd-sized"));
        }
        ScreenKernel {
            texel_angle: kernel.texel_angle_rad,
            taps: significant_taps(w, image.width as u32, KERNEL_MASS, usize::MAX),
            shape: LobeShape::of_lobe(&crate::brdf::Lobe {
                alpha: lobe.alpha,
                ..crate::brdf::Lobe::of_model(lobe.model, lobe.r0, lobe.mx, lobe.my)
            }),
        }
    };
    Ok((
        kernel,
        modulation.ok_or_else(|| format!("material {name:?} has no lobes"))?,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn taps_keep_the_heaviest_mass_and_sum_to_one() {
        // 3×3: centre 0.6, edges 0.08, corners 0.02.
        let w = [0.02, 0.08, 0.02, 0.08, 0.6, 0.08, 0.02, 0.08, 0.02];
        let t = significant_taps(&w, 3, 0.9, 64);
        assert_eq!(t.len(), 5, "centre + 4 edges hold 0.92");
        assert_eq!(t[0].offset, Vec2::ZERO);
        assert!((t.iter().map(|t| t.weight).sum::<f32>() - 1.0).abs() < 1e-6);
        // Row 0 is +y: index 1 is (0, +1).
        let up = t.iter().find(|t| t.offset == Vec2::new(0.0, 1.0)).unwrap();
        assert!((up.weight - 0.08 / 0.92).abs() < 1e-6);
        assert_eq!(significant_taps(&w, 3, 1.0, 2).len(), 2);
        assert_eq!(significant_taps(&[1.0], 1, 0.99, 64).len(), 1);
    }

    #[test]
    fn kernel_scale_follows_the_reflected_distance() {
        assert_eq!(beyond_fraction(0.0, 2.0), 0.0, "touching the mirror: sharp");
        assert!((beyond_fraction(2.0, 2.0) - 0.5).abs() < 1e-6);
        assert!(beyond_fraction(1e6, 1.0) > 0.999);
        let p = texel_pixels(0.01, 0.5, 0.001);
        assert!((p - 0.01f32.tan() * 500.0).abs() < 1e-3);
    }

    #[test]
    fn sphere_texels_follow_the_reflected_direction() {
        assert_eq!(sphere_texel(Vec3::Z, 64), [32, 32]);
        // Towards +tangent: right of centre; towards +bitangent: above (smaller row).
        assert!(sphere_texel(Vec3::new(0.9, 0.0, 0.43), 64)[0] > 56);
        assert!(sphere_texel(Vec3::new(0.0, 0.9, 0.43), 64)[1] < 8);
        // Grazing and beyond stay inside the disk.
        let [x, y] = sphere_texel(Vec3::new(1.0, 0.0, 0.0), 64);
        assert!(x == 63 && y == 32);
        assert_eq!(
            "sphere".parse::<ReflectanceLayout>(),
            Ok(ReflectanceLayout::Sphere)
        );
        assert!("2d".parse::<ReflectanceLayout>().is_err());
        assert_eq!(
            "bastos".parse::<ReflectanceChannel>(),
            Ok(ReflectanceChannel::Bastos)
        );
    }
}

#[cfg(test)]
mod fresnel_tests {
    use super::*;
    use crate::scene::material::gltf_specular_lobes;

    /// Without a materials stage a gold-like glTF metal (F₀ = (1, 0.77, 0.34): two lobes whose
    /// k_s sum to white) reflects gold at normal incidence, F₀ itself, and stays gold-tinted
    /// (blue below red) until it whitens at grazing as Schlick's F does; a grey F₀ is one lobe
    /// and gives the same curve per channel.
    #[test]
    fn a_coloured_metal_without_materials_stage_reflects_its_f0_not_white() {
        let f0 = Vec3::new(1.0, 0.77, 0.34);
        let lobes = gltf_specular_lobes(f0, 0.04);
        assert_eq!(lobes.len(), 2);
        let ks_sum = lobes
            .iter()
            .fold(Vec3::ZERO, |a, l| a + Vec3::from_array(l.ks));
        assert!((ks_sum - Vec3::ONE).abs().max_element() < 1e-6, "{ks_sum}");
        let table = fresnel_table(&lobes);
        let at = |c: f32| sample_modulation(&table, c);
        assert!(
            (at(1.0) - f0).abs().max_element() < 1e-4,
            "normal: {}",
            at(1.0)
        );
        for c in [1.0f32, 0.7, 0.5, 0.3] {
            let v = at(c);
            let want = f0 + (Vec3::ONE - f0) * (1.0 - c).powi(5);
            assert!(
                (v - want).abs().max_element() < 2e-3,
                "cos {c}: {v} vs {want}"
            );
            assert!(v.z < 0.8 * v.x, "cos {c}: {v} is not gold");
        }
        let grazing = at(reflectance::C_GRAZING);
        assert!(grazing.min_element() > 0.9, "grazing: {grazing}");
        let grey = fresnel_table(&gltf_specular_lobes(Vec3::splat(0.04), 0.04));
        let g = sample_modulation(&grey, 1.0);
        assert!((g - Vec3::splat(0.04)).abs().max_element() < 1e-4, "{g}");
    }
}
