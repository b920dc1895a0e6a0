//! A multisampled pixel that a small triangle covers only in part is shaded once, at its
//! centre, where the triangle's lightmap coordinates are extrapolated: for a sliver of
//! glossy-room's teapot that reached the ceiling light's chart in the atlas, one sample of
//! the mirror's map read the lamp's D (glossy-room `walkthrough`'s first keyframe, 192×128:
//! one white pixel of the lamp in the MirrorPanel). Here the atlas is marked: every texel
//! of another chart holds a large D, the teapot's own charts keep their D of 0 (a metal),
//! so any teapot pixel above 0 read another chart.

#![cfg(feature = "view")]

mod common;

use common::*;
use glam::Vec3;
use glint::camera::Camera;
use glint::view::curved::{CurvedMode, curved_reflectors};
use glint::view::headless::Offscreen;
use glint::view::load::{ViewData, load};
use glint::view::options::ViewOptions;
use glint::view::reflections::ReflectionMode;

const SIZE: (u32, u32) = (192, 128);
/// D of every texel outside the teapot's charts.
const MARK: f32 = 100.0;
/// Directions around the teapot the cameras look from.
const CAMERAS: u32 = 24;

/// glossy-room, draft-quick radiosity, every texel with some D set to `MARK`.
fn marked_glossy_room() -> ViewData {
    let bundle = shipped_bundle(
        &Recipe::new("glossy-room")
            .then(Step::Scene)
            .then(Step::Radiosity(quick_radiosity(3))),
    );
    let mut data = load(&bundle).unwrap_or_else(|e| panic!("{e}"));
    for page in &mut data.map.pages {
        for t in page.iter_mut() {
            if t.max_element() > 0.0 {
                *t = Vec3::splat(MARK);
            }
        }
    }
    data
}

/// At 4× MSAA no pixel that shows the teapot alone reads D from another chart (one sample
/// of 4 at `MARK` reads 25).
#[test]
fn teapot_pixels_read_no_other_chart() {
    let data = marked_glossy_room();
    let teapot = curved_reflectors(&data.scene)
        .into_iter()
        .find(|r| r.name == "Teapot")
        .expect("teapot");
    let bvh = data.scene.build_bvh();
    let mut mine = vec![false; data.scene.triangles.len()];
    for &t in &teapot.triangles {
        mine[t as usize] = true;
    }
    let gpu = gpu();
    let options = ViewOptions {
        curved: CurvedMode::Off,
        reflections: ReflectionMode::Off,
        samples: 4,
        ..ViewOptions::default().linear_display()
    };
    let (w, h) = SIZE;
    let off = Offscreen::with_options(&gpu, &data, w, h, &options).unwrap();
    // The largest D a pixel all of whose 4×4 sub-pixel rays meet the teapot shows, over
    // cameras around it near and far (so its triangles span few and many texels a pixel).
    let mut worst = (0.0f32, String::new());
    for k in 0..CAMERAS {
        let a = k as f32 / CAMERAS as f32 * std::f32::consts::TAU;
        for (r, y) in [(1.2f32, 1.3f32), (2.5, 1.6)] {
            let eye = teapot.centre + Vec3::new(a.cos() * r, y - teapot.centre.y, a.sin() * r);
            let camera = Camera::look_at(eye, teapot.centre, Vec3::Y, 20f32.to_radians());
            off.render(&gpu, &camera).unwrap();
            let frame = off.read_hdr(&gpu).unwrap();
            let on_teapot = covered_pixels(&camera, SIZE, 4, |d| {
                bvh.closest_hit(eye, d, f32::INFINITY)
                    .is_some_and(|hit| mine[hit.triangle as usize])
            });
            for (i, value) in frame.iter().enumerate() {
                let (x, y) = (i as u32 % w, i as u32 / w);
                if on_teapot[i] && value.max_element() > worst.0 {
                    worst = (
                        value.max_element(),
                        format!("camera {k} at {r} m, pixel ({x}, {y})"),
                    );
                }
            }
        }
    }
    eprintln!("largest D on the teapot: {:.4} ({})", worst.0, worst.1);
    assert!(
        worst.0 < 1.0,
        "a teapot pixel read D {} of another chart: {}",
        worst.0,
        worst.1
    );
}
