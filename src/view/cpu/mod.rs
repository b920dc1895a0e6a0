//! The CPU reference of the viewer's frame: one ray through each pixel centre, cast through the
//! scene's BVH, D looked up at the nearest hit with the same cubic B-spline the fragment shader
//! uses ([`bicubic::radiance`]). The golden-image tests compare the GPU frame to this.

pub mod bicubic;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::camera::Camera;
use crate::geometry::Bvh;
use crate::image_io::linear_to_srgb;
use crate::radiosity::RadiosityMap;
use crate::scene::Scene;

/// Linear radiance × `exposure` per pixel of a `width` × `height` image, row 0 at the top;
/// black where the ray hits nothing. D as stored: for a scene with base colour textures,
/// [`render_scene`] multiplies them in as the shader does.
pub fn render(
    bvh: &Bvh,
    map: &RadiosityMap,
    camera: &Camera,
    width: u32,
    height: u32,
    exposure: f32,
) -> Vec<Vec3> {
    render_with(bvh, map, camera, width, height, exposure, &|_, _, q| q)
}

/// [`render`] of `scene`: D at full texture resolution ([`Scene::d_at`], as `surface_d` in
/// the shader).
pub fn render_scene(
    scene: &Scene,
    bvh: &Bvh,
    map: &RadiosityMap,
    camera: &Camera,
    width: u32,
    height: u32,
    exposure: f32,
) -> Vec<Vec3> {
    render_with(bvh, map, camera, width, height, exposure, &|t, b, q| {
        scene.d_at(t, b, q)
    })
}

#[allow(clippy::too_many_arguments)]
fn render_with(
    bvh: &Bvh,
    map: &RadiosityMap,
    camera: &Camera,
    width: u32,
    height: u32,
    exposure: f32,
    d: &(dyn Fn(u32, Vec2, Vec3) -> Vec3 + Sync),
) -> Vec<Vec3> {
    let aspect = width.max(1) as f32 / height.max(1) as f32;
    (0..height)
        .into_par_iter()
        .flat_map_iter(|y| {
            (0..width).map(move |x| {
                let dir = camera.ray_direction(Camera::pixel_ndc(x, y, width, height), aspect);
                match bvh.closest_hit(camera.position, dir, f32::INFINITY) {
                    Some(hit) => {
                        let q = bicubic::radiance(map, hit.triangle, hit.bary).max(Vec3::ZERO);
                        d(hit.triangle, hit.bary, q) * exposure
                    }
                    None => Vec3::ZERO,
                }
            })
        })
        .collect()
}

/// Linear radiance to 8-bit sRGB RGBA (opaque), as the GPU's sRGB target stores it: clamped to
/// [0, 1], the sRGB curve, rounded to nearest.
pub fn to_srgb8(rgb: &[Vec3]) -> Vec<u8> {
    rgb.iter()
        .flat_map(|c| {
            let [r, g, b] = c
                .to_array()
                .map(|v| (linear_to_srgb(v) * 255.0 + 0.5) as u8);
            [r, g, b, 255]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb8_rounds_and_clamps() {
        let px = to_srgb8(&[Vec3::new(0.0, 1.0, 2.0), Vec3::splat(0.5)]);
        assert_eq!(&px[..4], &[0, 255, 255, 255]);
        // sRGB(0.5) = 0.7354 → 187.5 → 188.
        assert_eq!(px[4], 188);
    }
}
