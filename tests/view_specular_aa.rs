//! Specular anti-aliasing of curved reflectors: glossy-room's copper teapot (`--curved
//! cubemap`, the mirror lookup) seen from the walkthrough's first keyframe at a low
//! resolution with 4× MSAA, which shades once per pixel, holds the path tracer's mean
//! luminance.

#![cfg(feature = "view")]

mod common;

use common::*;
use glam::Vec3;
use glint::camera::Camera;
use glint::scene::Scene;
use glint::view::curved::{CurvedMode, curved_reflectors};
use glint::view::headless::Offscreen;
use glint::view::load::load;
use glint::view::options::ViewOptions;

/// Low resolution of the frame.
const SIZE: (u32, u32) = (192, 128);
/// Sub-pixel rays per axis that must all meet the teapot for a pixel to count as its.
const SUPER: u32 = 4;

/// The frame's linear radiance at `w` × `h`, 4× MSAA, the teapot's mirror term on.
fn render(data: &glint::view::load::ViewData, camera: &Camera, (w, h): (u32, u32)) -> Vec<Vec3> {
    let gpu = gpu();
    let options = ViewOptions {
        curved: CurvedMode::Cubemap,
        samples: 4,
        ..ViewOptions::default().linear_display()
    };
    let off = Offscreen::with_options(&gpu, data, w, h, &options).unwrap();
    off.render(&gpu, camera).unwrap();
    off.read_hdr(&gpu).unwrap()
}

/// A highlight narrower than a pixel must not fill the pixel: the teapot's mean luminance at
/// 192×128 is within 10% of the path tracer's over the same pixels.
#[test]
fn teapot_highlights_keep_their_mean_at_low_resolution() {
    let bundle = shipped_bundle(
        &Recipe::new("glossy-room")
            .then(Step::Scene)
            .then(Step::Radiosity(quick_radiosity(3))),
    );
    let data = load(&bundle).unwrap_or_else(|e| panic!("{e}"));
    let path = data
        .scene
        .camera_paths
        .iter()
        .find(|p| p.name == "walkthrough")
        .expect("glossy-room has a walkthrough");
    let camera = Camera::from_keyframe(&path.keyframes[0]);
    let teapot = curved_reflectors(&data.scene)
        .into_iter()
        .find(|r| r.name == "Teapot")
        .expect("glossy-room has a curved teapot");

    // Low-resolution pixels all of whose 4×4 sub-pixel rays meet the teapot first.
    let bvh = data.scene.build_bvh();
    let mut mine = vec![false; data.scene.triangles.len()];
    for &t in &teapot.triangles {
        mine[t as usize] = true;
    }
    let (w, h) = SIZE;
    let (sw, sh) = (w * SUPER, h * SUPER);
    let hits = |x: u32, y: u32| {
        let d = camera.ray_direction(Camera::pixel_ndc(x, y, sw, sh), sw as f32 / sh as f32);
        bvh.closest_hit(camera.position, d, f32::INFINITY)
            .is_some_and(|hit| mine[hit.triangle as usize])
    };
    let mask: Vec<bool> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            (0..SUPER * SUPER).all(|k| hits(x * SUPER + k % SUPER, y * SUPER + k / SUPER))
        })
        .collect();
    let count = mask.iter().filter(|&&m| m).count();
    assert!(count > 40, "the teapot covers {count} pixels");

    let frame = render(&data, &camera, SIZE);
    let view: f64 = mask
        .iter()
        .zip(&frame)
        .filter(|(m, _)| **m)
        .map(|(_, c)| f64::from(glint::eval::luminance(*c)))
        .sum::<f64>()
        / count as f64;

    // The reference: the scene the viewer represents, the teapot's lobes kept and every
    // other material diffuse (D is the diffuse solution).
    let mut scene =
        Scene::load(repo("scenes/glossy-room/scene.json")).unwrap_or_else(|e| panic!("{e}"));
    let material = scene
        .reflectors
        .iter()
        .find(|r| r.name == "Teapot")
        .expect("glossy-room has a teapot reflector")
        .material;
    let (_, traced) = traced_with_lobes_of(&mut scene, material, &camera, SIZE);
    let on = |i: &usize| mask[*i];
    let reference = (0..mask.len())
        .filter(on)
        .map(|i| f64::from(glint::eval::luminance(traced.image.rgb[i])))
        .sum::<f64>()
        / count as f64;
    let error = (0..mask.len())
        .filter(on)
        .map(|i| f64::from(traced.variance[i]))
        .sum::<f64>()
        .sqrt()
        / count as f64;
    let ratio = view / reference;
    eprintln!(
        "teapot over {count} px at {w}×{h}, 4× MSAA: mean luminance {view:.4}, path tracer {reference:.4} (± {error:.4}): ratio {ratio:.3}"
    );
    assert!(
        (ratio - 1.0).abs() < 0.1,
        "the teapot's mean luminance at {w}×{h} is {ratio:.3} of the path tracer's"
    );
}
