//! Reflection probes in the viewer: the specular term of every glossy surface that no
//! reflector declares (declared planar and curved reflectors keep their own passes).
//!
//! Per glossy group ([`crate::materials::probes::scene_groups`]) the pass draws its triangles
//! over the finished scene and adds, by blending, ks·A(n·ω_o) × the probe's prefiltered
//! radiance in the mirror direction r: a split-sum reading of the material's lobe, where A
//! is the directional albedo the materials stage bakes into its 1D reflectance maps (the
//! modulation the planar passes read, `--reflectance-channel`) and the MIP level is the
//! lobe's footprint on the cube ([`crate::materials::probes::lobe_lod`]). r is first moved
//! to where the ray from the shaded point meets the room, from the distances the probe
//! stores ([`parallax_direction`]), as the curved reflectors' lookups are. Each group reads
//! the probe [`crate::materials::probes::assign`] gives it; `--probes off` leaves the pass
//! out. The GPU half is [`gpu::ProbeReflections`] (`shaders/probes.wgsl`).

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

/// Fixed-point steps of [`parallax_direction`] (`PROBE_STEPS` in the shader).
pub const PARALLAX_STEPS: usize = 4;

/// Mirrors `ProbeParams` in `shaders/probes.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct ProbeParams {
    /// xyz: the probe's centre; w: 1 distance-corrected lookups, 0 from the centre.
    pub centre: [f32; 4],
    /// x: the lobe's MIP level; y: 1 where the material is double-sided, 0 where its back
    /// faces reflect nothing.
    pub info: [f32; 4],
    /// ks·A at the 1D reflectance map's cosines.
    pub modulation: [[f32; 4]; MODULATION_SIZE],
}

/// The direction from a probe's centre to where the ray from the point `offset` away from it
/// along unit `dir` meets the room (`distances`: a cube map holding, in x, the distance from
/// the centre to what each texel sees, 0 where nothing): the stored distance in the current
/// direction taken as a sphere about the centre, the ray's exit from it the next direction
/// (the shader's `probe_lookup`).
pub fn parallax_direction(distances: &CubeMap, offset: Vec3, dir: Vec3) -> Vec3 {
    let (b, c) = (offset.dot(dir), offset.dot(offset));
    let mut d = dir;
    for _ in 0..PARALLAX_STEPS {
        let s = distances.bilinear(d).x;
        if s <= 0.0 {
            return d;
        }
        let t = -b + (b * b - c + s * s).max(0.0).sqrt();
        let x = offset + dir * t;
        if x.length_squared() <= 0.0 {
            return d;
        }
        d = x.normalize();
    }
    d
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
        let d = parallax_direction(&distances, Vec3::new(0.0, 0.0, 1.0), Vec3::X);
        let want = Vec3::new(2.0, 0.0, 1.0).normalize();
        assert!(d.angle_between(want) < 0.03, "{d} vs {want}");
        // From the centre itself nothing moves.
        assert!(parallax_direction(&distances, Vec3::ZERO, Vec3::X).distance(Vec3::X) < 1e-6);
    }
}
