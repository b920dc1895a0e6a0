//! The CPU reference of the reflection passes, for the golden-image tests: the same
//! equation, L = D + ks·R·(M*K), ray traced instead of rasterized, with M*K exact (K's taps)
//! or as the GPU filters it ([`MkFilter`]).

use glam::{Vec2, Vec3, Vec4};
use rayon::prelude::*;

use super::filter::{FILTER_RINGS, Grazing, Pyramid, exact, filter_taps};
use super::material::{beyond_fraction, texel_pixels};
use super::splats::pixel_tangent;
use super::{CLIP_FRACTION, PlanarReflector, mirror_camera, signed_distance};
use crate::camera::Camera;
use crate::geometry::Bvh;
use crate::radiosity::RadiosityMap;
use crate::scene::Scene;

/// Per pixel: radiance, beyond-fraction, and the reflector hit (index, point) if any.
type Pixel = (Vec3, f32, Option<(usize, Vec3)>);

/// How the CPU reference convolves M with K.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MkFilter {
    /// K's taps as point reads of M (bilinear), the equation as written.
    Exact,
    /// K's taps, each kernel texel the box of pixels it covers on screen
    /// ([`super::filter::exact`] `continuous`): the convolution without the aliasing of taps
    /// spaced wider than a pixel.
    Continuous,
    /// The composite's constant-cost filter: the regular pattern reading M's pyramid
    /// ([`super::filter`]).
    Pyramid,
}

/// The CPU reference of the geometry-based mode. Per pixel, the view ray's nearest hit gives
/// D; where it is a glossy planar reflector seen from its reflecting side, ks·R × (M*K) is
/// added, with
/// - M: the reflected view ([`mirror_camera`]) ray traced at every pixel, ignoring hits
///   within `clip` of the plane as the GPU's clip plane does, with the fraction of the
///   reflected ray beyond the plane ([`beyond_fraction`]);
/// - M*K: K's taps at the pixel, bilinear between pixel centres, clamped to the frame, a
///   texel spanning [`texel_pixels`] at the pixel's beyond-fraction, shaped along and across
///   the plane of incidence by the lobe's shape at the view angle ([`Grazing`]; as
///   `fs_composite`);
/// - R: [`PlanarReflector::modulation_at`] at the hit.
///
/// Linear × `exposure`, row 0 at the top, black where nothing is hit. M*K exact
/// ([`MkFilter::Exact`]; [`cpu_reference_filtered`] for the others).
#[allow(clippy::too_many_arguments)]
pub fn cpu_reference(
    scene: &Scene,
    reflectors: &[PlanarReflector],
    bvh: &Bvh,
    map: &RadiosityMap,
    camera: &Camera,
    width: u32,
    height: u32,
    exposure: f32,
) -> Vec<Vec3> {
    cpu_reference_filtered(
        scene,
        reflectors,
        bvh,
        map,
        camera,
        width,
        height,
        exposure,
        MkFilter::Exact,
    )
}

/// [`cpu_reference`] (exposure 1) at `factor` × `factor` points a pixel, box-filtered: what
/// the single-level passes draw from M at that many texels a pixel (`super::downsample`).
#[allow(clippy::too_many_arguments)]
pub fn cpu_reference_box(
    scene: &Scene,
    reflectors: &[PlanarReflector],
    bvh: &Bvh,
    map: &RadiosityMap,
    camera: &Camera,
    width: u32,
    height: u32,
    factor: u32,
) -> Vec<Vec3> {
    let (w, h) = (width * factor, height * factor);
    let fine = cpu_reference(scene, reflectors, bvh, map, camera, w, h, 1.0);
    crate::image_io::downsample(
        &fine,
        w as usize,
        h as usize,
        width as usize,
        height as usize,
    )
}

/// [`cpu_reference`] with M*K computed as `filter` says.
#[allow(clippy::too_many_arguments)]
pub fn cpu_reference_filtered(
    scene: &Scene,
    reflectors: &[PlanarReflector],
    bvh: &Bvh,
    map: &RadiosityMap,
    camera: &Camera,
    width: u32,
    height: u32,
    exposure: f32,
    filter: MkFilter,
) -> Vec<Vec3> {
    let mut of_triangle = vec![usize::MAX; scene.triangles.len()];
    for (i, r) in reflectors.iter().enumerate() {
        for &t in &r.triangles {
            of_triangle[t as usize] = i;
        }
    }
    let clip = (scene.bounds.diagonal() * CLIP_FRACTION).max(1e-5);
    let aspect = width.max(1) as f32 / height.max(1) as f32;
    let d = |t: u32, bary| {
        let q = crate::view::cpu::bicubic::radiance(map, t, bary).max(Vec3::ZERO);
        scene.d_at(t, bary, q)
    };
    let pixels = |f: &(dyn Fn(u32, u32) -> Pixel + Sync)| {
        (0..height)
            .into_par_iter()
            .flat_map_iter(|y| (0..width).map(move |x| f(x, y)))
            .collect::<Vec<_>>()
    };
    // Primary: D, and the reflector hit (index, point).
    let primary = pixels(&|x, y| {
        let dir = camera.ray_direction(Camera::pixel_ndc(x, y, width, height), aspect);
        let Some(hit) = bvh.closest_hit(camera.position, dir, f32::INFINITY) else {
            return (Vec3::ZERO, 0.0, None);
        };
        let r = of_triangle[hit.triangle as usize];
        let on = (r != usize::MAX && signed_distance(&reflectors[r].plane, camera.position) > 0.0)
            .then(|| (r, camera.position + dir * hit.t));
        (d(hit.triangle, hit.bary), 0.0, on)
    });
    let mut out: Vec<Vec3> = primary.iter().map(|p| p.0).collect();
    let pitch = pixel_tangent(camera.fov_y, height);
    let view_proj = crate::view::passes::renderer::view_projection(camera, aspect, 0.01);
    let size = Vec2::new(width as f32, height as f32);
    for (ri, refl) in reflectors.iter().enumerate() {
        if !primary.iter().any(|p| p.2.is_some_and(|(r, _)| r == ri)) {
            continue;
        }
        let plane = &refl.plane;
        let mirrored = mirror_camera(camera, plane);
        let eye_side = signed_distance(plane, camera.position);
        // M over the whole frame (K reads around each pixel), alpha = beyond fraction.
        let m = pixels(&|x, y| {
            let dir = mirrored.ray_direction(Camera::pixel_ndc(x, y, width, height), aspect);
            let mut origin = mirrored.position;
            let mut travelled = 0.0f32;
            for _ in 0..64 {
                let Some(h) = bvh.closest_hit(origin, dir, f32::INFINITY) else {
                    break;
                };
                let q = origin + dir * h.t;
                let s = signed_distance(plane, q);
                if s > clip {
                    return (d(h.triangle, h.bary), beyond_fraction(s, eye_side), None);
                }
                let step = h.t + 1e-4 * (1.0 + travelled);
                travelled += step;
                origin += dir * step;
            }
            (Vec3::ZERO, 0.0, None)
        });
        let texels: Vec<Vec4> = m.iter().map(|p| p.0.extend(1.0)).collect();
        let pyramid = (filter == MkFilter::Pyramid).then(|| {
            let rgb: Vec<Vec3> = m.iter().map(|p| p.0).collect();
            Pyramid::of_image(width, height, &rgb, &vec![true; rgb.len()])
        });
        let taps = filter_taps(&refl.kernel.taps, FILTER_RINGS);
        let texel = texel_pixels(refl.kernel.texel_angle, 1.0, pitch);
        let convolved: Vec<Option<Vec3>> = (0..primary.len())
            .into_par_iter()
            .map(|k| {
                let (r, point) = primary[k].2?;
                let (centre, f, _) = m[k];
                if r != ri || refl.kernel.taps.len() <= 1 || f <= 0.0 {
                    return Some(centre);
                }
                let pixel =
                    Vec2::new((k % width as usize) as f32, (k / width as usize) as f32) + 0.5;
                let scale = texel * f;
                let grazing = Grazing::at(
                    view_proj,
                    point,
                    plane.normal,
                    camera.position,
                    size,
                    &refl.kernel.shape,
                    refl.kernel.texel_angle,
                );
                Some(match &pyramid {
                    Some(p) => p.filtered(pixel, scale, &taps, &grazing).unwrap_or(centre),
                    None => exact(
                        width,
                        height,
                        &texels,
                        pixel,
                        scale,
                        &refl.kernel.taps,
                        filter == MkFilter::Continuous,
                        &grazing,
                    ),
                })
            })
            .collect();
        for (k, p) in primary.iter().enumerate() {
            let Some((r, point)) = p.2 else { continue };
            if r != ri {
                continue;
            }
            let mk = convolved[k].unwrap_or(m[k].0);
            out[k] += refl.modulation_at(point, camera.position) * mk;
        }
    }
    out.iter().map(|l| *l * exposure).collect()
}

/// Per pixel of `camera`'s `width` × `height` view, row by row: whether its primary ray
/// first meets one of `reflectors` from its reflecting side (the pixels the reflection passes
/// shade). The fidelity bench and tests score reflections on these pixels.
pub fn reflector_pixels(
    bvh: &Bvh,
    reflectors: &[PlanarReflector],
    camera: &Camera,
    width: u32,
    height: u32,
) -> Vec<bool> {
    let mut of = std::collections::HashMap::new();
    for (i, r) in reflectors.iter().enumerate() {
        for &t in &r.triangles {
            of.insert(t, i);
        }
    }
    let aspect = width as f32 / height as f32;
    (0..width * height)
        .into_par_iter()
        .map(|k| {
            let ndc = Camera::pixel_ndc(k % width, k / width, width, height);
            bvh.closest_hit(
                camera.position,
                camera.ray_direction(ndc, aspect),
                f32::INFINITY,
            )
            .and_then(|hit| of.get(&hit.triangle))
            .is_some_and(|&i| signed_distance(&reflectors[i].plane, camera.position) > 0.0)
        })
        .collect()
}
