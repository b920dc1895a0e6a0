//! Reflection defects seen on glint's shipped scenes, each held to what the path tracer shows.
//!
//! - glossy-room's copper teapot (`--curved cubemap`) seen from the walkthrough's last
//!   keyframe: the part of its body that faces the mirror panel reflects the room the mirror
//!   shows, not the mirror's black kd·D.

#![cfg(feature = "view")]

mod common;

use common::*;
use glam::Vec3;
use glint::camera::Camera;
use glint::view::curved::{CurvedMode, CurvedSettings, curved_reflectors};
use glint::view::headless::Offscreen;
use glint::view::load::{ViewData, load};

/// Pixels of `camera`'s `w` × `h` frame whose ray and its four neighbours' rays meet one of
/// `triangles` first (rasterisation and ray casting disagree on edge pixels).
fn interior_mask(data: &ViewData, triangles: &[u32], camera: &Camera, w: u32, h: u32) -> Vec<bool> {
    let bvh = data.scene.build_bvh();
    let mut mine = vec![false; data.scene.triangles.len()];
    for &t in triangles {
        mine[t as usize] = true;
    }
    let hits: Vec<bool> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let d = camera.ray_direction(Camera::pixel_ndc(x, y, w, h), w as f32 / h as f32);
            bvh.closest_hit(camera.position, d, f32::INFINITY)
                .is_some_and(|hit| mine[hit.triangle as usize])
        })
        .collect();
    let (w, h) = (w as usize, h as usize);
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            x > 0
                && y > 0
                && x + 1 < w
                && y + 1 < h
                && [i, i - 1, i + 1, i - w, i + w].iter().all(|&j| hits[j])
        })
        .collect()
}

/// Luminance below which a pixel of the teapot (a metal: kd·D is 0) counts as black: its
/// specular term added nothing.
const BLACK: f32 = 1e-3;

/// glossy-room's teapot from the walkthrough's last keyframe (frames 200–240 of the README's
/// job), narrowed onto it. A fifth of its body faces the mirror panel, whose kd·D is black:
/// the cube map must hold the room the mirror reflects there, as the path tracer shows.
#[test]
fn teapot_cube_map_shows_what_the_mirror_panel_reflects() {
    let bundle = shipped_bundle(
        &Recipe::new("glossy-room")
            .then(Step::Scene)
            .then(Step::Radiosity(quick_radiosity(3))),
    );
    let data = load(&bundle).unwrap_or_else(|e| panic!("{e}"));
    let teapot = curved_reflectors(&data.scene)
        .into_iter()
        .find(|r| r.name == "Teapot")
        .expect("glossy-room has a curved teapot");
    let camera = Camera::look_at(
        Vec3::new(2.2, 1.7, -1.6),
        Vec3::new(0.0, 0.9, -0.3),
        Vec3::Y,
        12f32.to_radians(),
    );
    let (w, h) = (180u32, 120u32);
    let mask = interior_mask(&data, &teapot.triangles, &camera, w, h);
    let count = mask.iter().filter(|&&m| m).count();
    assert!(count > 2000, "the teapot covers {count} interior pixels");

    let gpu = gpu();
    let mut off = Offscreen::new(&gpu, &data, w, h).unwrap();
    off.set_curved(&gpu, &data, CurvedMode::Cubemap, CurvedSettings::default())
        .unwrap();
    off.render(&gpu, &camera).unwrap();
    let frame = off.read_hdr(&gpu).unwrap();
    let black = frame
        .iter()
        .zip(&mask)
        .filter(|(c, m)| **m && glint::eval::luminance(**c) < BLACK)
        .count();
    let fraction = black as f64 / count as f64;
    eprintln!("teapot: {black} of {count} interior pixels black ({fraction:.4})");
    assert!(
        fraction < 0.005,
        "{black} of the teapot's {count} interior pixels are black ({:.1}%)",
        100.0 * fraction
    );
}
