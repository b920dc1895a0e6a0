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
//! the floor. Each group reads the probe [`crate::materials::probes::assign`] gives it;
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
    /// ks·A at the 1D reflectance map's cosines.
    pub modulation: [[f32; 4]; MODULATION_SIZE],
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
}
