//! Reflection probes in the viewer: the specular term of every glossy surface that no
//! reflector declares (declared planar and curved reflectors keep their own passes).
//!
//! Per glossy group ([`crate::materials::probes::scene_groups`]) the pass draws its triangles
//! over the finished scene and adds, by blending, ks·A(n·ω_o) × the probe's radiance over
//! the material's lobe: a split-sum reading of the lobe, where A is the directional albedo
//! the materials stage bakes into its 1D reflectance maps (the modulation the planar passes
//! read, `--reflectance-channel`). The radiance is the weighted mean of [`LOBE_SAMPLES`]
//! directions drawn from the lobe's GGX normals (filtered importance sampling: each read at
//! the MIP level of its share of the lobe, weighted by the lobe's F·G), those under the
//! surface dropped: at a grazing view the part of the lobe above the surface is what the
//! surface reflects, which the mirror direction at the whole lobe's level
//! ([`crate::materials::probes::lobe_lod`]) misses. Each direction is first moved to where
//! the ray from the shaded point meets the room, from the distances the probe stores
//! ([`parallax_lookup`]), as the curved reflectors' lookups are, and its level to its
//! footprint there as the probe's centre sees it ([`footprint_lod`]): a floor in front of a
//! cabinet reflects the cabinet alone, where the probe, farther off, sees it small beside
//! the floor. The result is scaled by what the surface receives over what the probe sees
//! ([`Normalization`], at most 1): a probe is one point of the room, and a surface lit less
//! than that point (under a table, far from the lamp the probe stands by) reflects less of it.
//! Each group reads the probe [`crate::materials::probes::assign`] gives it;
//! `--probes off` leaves the pass out. The GPU half is [`gpu::ProbeReflections`]
//! (`shaders/probes.wgsl`).

pub mod gpu;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::materials::envmap::CubeMap;
use crate::view::reflections::material::MODULATION_SIZE;

/// WGSL of the probe pass (appended to [`crate::view::passes::renderer::SHADER_SOURCE`]).
pub const PROBE_SHADER_SOURCE: &str = include_str!("../../../shaders/probes.wgsl");

/// The full WGSL module of the probe pass.
pub fn shader_source() -> String {
    format!(
        "{}\n{}",
        crate::view::passes::renderer::SHADER_SOURCE,
        PROBE_SHADER_SOURCE
    )
}

/// Fixed-point steps of [`parallax_lookup`] (`PROBE_STEPS` in the shader).
pub const PARALLAX_STEPS: usize = 4;

/// Directions of the lobe the shader reads per fragment (`PROBE_SAMPLES`).
pub const LOBE_SAMPLES: u32 = 8;

/// Mirrors `ProbeParams` in `shaders/probes.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct ProbeParams {
    /// xyz: the probe's centre; w: 1 distance-corrected lookups, 0 from the centre.
    pub centre: [f32; 4],
    /// x: the lobe's MIP level; y: 1 where the material is double-sided, 0 where its back
    /// faces reflect nothing; z: the lobe's GGX α (its [`LOBE_SAMPLES`] directions' spread);
    /// w: its Fresnel reflectance at normal incidence (their weights).
    pub info: [f32; 4],
    /// What the surface receives, read from its lightmap texel ([`Normalization`]): x the
    /// luminance of the material's diffuse albedo factor (0: not normalized), y the luminance
    /// of the emission its stored texels hold (0 for a base-colour-textured material, whose
    /// texels hold Q); z 1 where the lobe is widened by the pixel's spread of normals
    /// (specular anti-aliasing, `--specular-aa`), else 0; w unused.
    pub surface: [f32; 4],
    /// The probe's irradiance over π as luminance, [`irradiance_sh`]'s nine coefficients
    /// (the last three floats unused).
    pub irradiance: [[f32; 4]; 3],
    /// ks·A at the 1D reflectance map's cosines.
    pub modulation: [[f32; 4]; MODULATION_SIZE],
}

/// A diffuse albedo factor whose luminance is under this tells too little of what the surface
/// receives to scale a probe by (a metal's 0): its probe light is not normalized.
pub const MIN_NORMALIZING_ALBEDO: f32 = 0.02;

/// How a group's probe light is scaled to what its surface receives (the shader's
/// `probe_normalization`): the square root of the irradiance its lightmap texel was solved
/// with, E/π = (D − emission)/albedo (Q/albedo for a base-colour-textured material), over the
/// probe's own, E/π at the surface's normal from [`irradiance_sh`], at most 1. A probe
/// captured where the room is brighter than at the surface (next to a lamp, above a chair in
/// the lamp's shadow) then lights it less; a surface lit as the probe is keeps the probe's
/// light. This is the environment-map normalization of Lazarov ("Getting More Physical in
/// Call of Duty: Black Ops II", SIGGRAPH 2013 course), with the lightmap's irradiance in place
/// of its per-vertex one, at half strength in log terms: irradiance also falls with distance
/// from a light where the mirrored room does not (a floor farther from the lamp than its
/// probe reflects the same lamp), and the full ratio dims such a floor
/// (docs/tuning.md#probe-normalization).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Normalization {
    /// Luminance of the material's albedo factor (0: off).
    pub albedo: f32,
    /// Luminance of the emission in its stored texels.
    pub emission: f32,
}

impl Normalization {
    /// The normalization of `material` (off for an albedo under
    /// [`MIN_NORMALIZING_ALBEDO`], a metal's).
    pub fn of(material: &crate::scene::Material) -> Normalization {
        let albedo = crate::colour::luminance(material.albedo);
        Normalization {
            albedo: if albedo >= MIN_NORMALIZING_ALBEDO {
                albedo
            } else {
                0.0
            },
            emission: if material.base_texture.is_some() {
                0.0
            } else {
                crate::colour::luminance(material.emission)
            },
        }
    }

    /// The factor on the probe's light at a texel storing `stored`, the probe's E/π there
    /// being `probe` (the shader's `probe_normalization`).
    pub fn factor(&self, stored: Vec3, probe: f32) -> f32 {
        if self.albedo <= 0.0 || probe <= 0.0 {
            return 1.0;
        }
        let received = (crate::colour::luminance(stored) - self.emission).max(0.0) / self.albedo;
        (received / probe).min(1.0).sqrt()
    }
}

/// The real spherical harmonics of bands 0–2 at unit `n` (Ramamoorthi and Hanrahan 2001,
/// "An Efficient Representation for Irradiance Environment Maps", Eq. 3), in the order
/// Y₀₀, Y₁₋₁, Y₁₀, Y₁₁, Y₂₋₂, Y₂₋₁, Y₂₀, Y₂₁, Y₂₂ (the shader's `probe_irradiance`).
pub fn sh_basis(n: Vec3) -> [f32; 9] {
    let (x, y, z) = (n.x, n.y, n.z);
    [
        0.282_095,
        0.488_603 * y,
        0.488_603 * z,
        0.488_603 * x,
        1.092_548 * x * y,
        1.092_548 * y * z,
        0.315_392 * (3.0 * z * z - 1.0),
        1.092_548 * x * z,
        0.546_274 * (x * x - y * y),
    ]
}

/// The luminance irradiance over π of `cube` (radiance) as nine coefficients on
/// [`sh_basis`]: its projection on bands 0–2 convolved with the clamped cosine (Eq. 7–8 of
/// the same paper: Â₀ = π, Â₁ = 2π/3, Â₂ = π/4), over π. Each texel weighs its exact
/// solid angle.
pub fn irradiance_sh(cube: &CubeMap) -> [f32; 9] {
    let size = cube.size;
    let mut sum = [0.0f64; 9];
    for face in 0..6 {
        for y in 0..size {
            for x in 0..size {
                let d = crate::materials::envmap::texel_direction(size, face, x, y);
                let w = crate::materials::envmap::texel_solid_angle(size, x, y) as f64
                    * f64::from(crate::colour::luminance(
                        cube.texels[(face * size + y) * size + x],
                    ));
                for (s, b) in sum.iter_mut().zip(sh_basis(d)) {
                    *s += w * f64::from(b);
                }
            }
        }
    }
    let band = [
        1.0,
        2.0 / 3.0,
        2.0 / 3.0,
        2.0 / 3.0,
        0.25,
        0.25,
        0.25,
        0.25,
        0.25,
    ];
    std::array::from_fn(|i| (sum[i] * band[i]) as f32)
}

/// [`irradiance_sh`]'s coefficients at unit normal `n`.
pub fn irradiance_at(sh: &[f32; 9], n: Vec3) -> f32 {
    sh.iter().zip(sh_basis(n)).map(|(c, b)| c * b).sum()
}

/// The direction from a probe's centre to where the ray from the point `offset` away from it
/// along unit `dir` meets the room (`distances`: a cube map holding, in x, the distance from
/// the centre to what each texel sees, 0 where nothing), and that point's distance from the
/// ray's origin over its distance from the centre (1 where nothing moved): the stored
/// distance in the current direction taken as a sphere about the centre, the ray's exit from
/// it the next direction (the shader's `probe_lookup`).
pub fn parallax_lookup(distances: &CubeMap, offset: Vec3, dir: Vec3) -> (Vec3, f32) {
    let (b, c) = (offset.dot(dir), offset.dot(offset));
    let mut d = dir;
    let mut ratio = 1.0;
    for _ in 0..PARALLAX_STEPS {
        let s = distances.bilinear(d).x;
        if s <= 0.0 {
            break;
        }
        let t = -b + (b * b - c + s * s).max(0.0).sqrt();
        let x = offset + dir * t;
        if x.length_squared() <= 0.0 {
            break;
        }
        ratio = t / x.length();
        d = x.normalize();
    }
    (d, ratio)
}

/// The least distance ratio [`footprint_lod`] takes (a surface at the shaded point itself).
pub const MIN_FOOTPRINT_RATIO: f32 = 1e-3;

/// The MIP level of a probe lookup whose lobe, `lod` as seen from the centre
/// ([`crate::materials::probes::lobe_lod`]), meets the room at `ratio` times its distance
/// from the centre ([`parallax_lookup`]): there the lobe's footprint subtends ratio² of its
/// solid angle from the centre, so a surface near the shaded point reads a sharper level
/// (the shader's `probe_footprint_lod`).
pub fn footprint_lod(lod: f32, ratio: f32) -> f32 {
    (lod + ratio.max(MIN_FOOTPRINT_RATIO).log2()).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn probe_params_match_the_wgsl_struct() {
        crate::view::gpu::wgsl_layout::assert_layout(
            &shader_source(),
            "ProbeParams",
            "ProbeParams",
            std::mem::size_of::<ProbeParams>(),
            &[
                ("centre", std::mem::offset_of!(ProbeParams, centre)),
                ("info", std::mem::offset_of!(ProbeParams, info)),
                ("surface", std::mem::offset_of!(ProbeParams, surface)),
                ("irradiance", std::mem::offset_of!(ProbeParams, irradiance)),
                ("modulation", std::mem::offset_of!(ProbeParams, modulation)),
            ],
        );
    }

    #[test]
    fn a_lookup_finds_the_wall_the_point_itself_sees() {
        // A room: every direction meets the plane x = 2 or lies farther (a box of half size 2).
        let distances = CubeMap::from_fn(32, |d| {
            let a = d.abs().max_element();
            Vec3::splat(2.0 / a)
        });
        // From a point 1 m off the centre along +z, looking along +x: it meets x = 2 at
        // (2, 0, 1), which the centre sees in the direction (2, 0, 1).
        let (d, ratio) = parallax_lookup(&distances, Vec3::new(0.0, 0.0, 1.0), Vec3::X);
        let want = Vec3::new(2.0, 0.0, 1.0).normalize();
        assert!(d.angle_between(want) < 0.03, "{d} vs {want}");
        // The point lies 2 m from the ray's origin and √5 m from the centre.
        assert!((ratio - 2.0 / 5f32.sqrt()).abs() < 0.02, "{ratio}");
        // From the centre itself nothing moves.
        let (d, ratio) = parallax_lookup(&distances, Vec3::ZERO, Vec3::X);
        assert!(d.distance(Vec3::X) < 1e-6 && (ratio - 1.0).abs() < 1e-6);
    }

    #[test]
    fn a_surface_near_the_shaded_point_reads_a_sharper_level() {
        // Half the centre's distance: a quarter of the solid angle, one level down.
        assert!((footprint_lod(4.0, 0.5) - 3.0).abs() < 1e-6);
        assert!((footprint_lod(4.0, 2.0) - 5.0).abs() < 1e-6);
        assert_eq!(footprint_lod(4.0, 1.0), 4.0);
        // Never below level 0, nor undefined where the surface is the point itself.
        assert_eq!(footprint_lod(1.0, 0.1), 0.0);
        assert_eq!(footprint_lod(1.0, 0.0), 0.0);
    }

    /// White furnace: a cube of radiance 1 everywhere gives E/π = 1 at every normal; the
    /// upper hemisphere alone gives 1 facing it and 0 facing away (bands 0–2 hold the clamped
    /// cosine's irradiance to within a few percent, Ramamoorthi and Hanrahan §3).
    #[test]
    fn the_probe_irradiance_is_the_furnace_and_the_hemisphere() {
        let sh = irradiance_sh(&CubeMap::from_fn(32, |_| Vec3::ONE));
        for n in [Vec3::X, -Vec3::Y, Vec3::new(1.0, 2.0, -3.0).normalize()] {
            assert!((irradiance_at(&sh, n) - 1.0).abs() < 1e-3, "{n}");
        }
        let sky = irradiance_sh(&CubeMap::from_fn(32, |d| Vec3::splat(f32::from(d.y > 0.0))));
        assert!((irradiance_at(&sky, Vec3::Y) - 1.0).abs() < 0.07);
        assert!(irradiance_at(&sky, -Vec3::Y).abs() < 0.07);
        // Sideways, half the hemisphere's cosine-weighted light: ½.
        assert!((irradiance_at(&sky, Vec3::X) - 0.5).abs() < 0.03);
    }

    /// The factor is the square root of what the texel received over what the probe sees, at
    /// most 1: a surface a quarter as lit as the probe reflects half its light; one lit more,
    /// all of it; a metal's albedo turns it off; the emission a texel holds is not light it
    /// received.
    #[test]
    fn normalization_scales_by_what_the_surface_receives() {
        let plastic = Normalization {
            albedo: 0.8,
            emission: 0.0,
        };
        // E/π = 0.2 / 0.8 = 0.25 received, 1.0 seen.
        assert!((plastic.factor(Vec3::splat(0.2), 1.0) - 0.5).abs() < 1e-6);
        assert_eq!(plastic.factor(Vec3::splat(4.0), 1.0), 1.0);
        assert_eq!(plastic.factor(Vec3::ZERO, 1.0), 0.0);
        assert_eq!(plastic.factor(Vec3::splat(0.4), 0.0), 1.0);
        let glowing = Normalization {
            albedo: 0.8,
            emission: 0.4,
        };
        assert_eq!(glowing.factor(Vec3::splat(0.4), 1.0), 0.0);
        let metal = crate::scene::Material::from_gltf("m", [0.9; 4], 1.0, 0.1, [0.0; 3], 1.0);
        assert_eq!(Normalization::of(&metal).albedo, 0.0);
        assert_eq!(Normalization::of(&metal).factor(Vec3::ZERO, 1.0), 1.0);
    }
}
