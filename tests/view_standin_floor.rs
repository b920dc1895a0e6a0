//! The stand-in's mirror floor seen from its `room` camera in geometry mode, 4× MSAA (what
//! `glint-view` draws by default): where the mirror floor meets the back wall, the pixels the
//! floor's edge crosses show the wall on part of their samples and the reflection on the rest,
//! as the CPU equation ray cast at 4 × 4 points a pixel does; none is dark.
//!
//! The composite reads M at the pixel's centre. At such an edge pixel the centre may lie on the
//! wall, off the mirror: M there continues the floor's plane behind the wall, where the
//! mirrored view sees nothing, and the mirror's covered samples took that emptiness: a dotted
//! dark line along the floor's edge.

#![cfg(feature = "view")]

mod common;

use glam::Vec3;
use glint::camera::Camera;
use glint::geometry::Bvh;
use glint::scene::desc::{Quality, RadiositySettings};
use glint::view::headless::Offscreen;
use glint::view::load::load;
use glint::view::options::ViewOptions;
use glint::view::reflections;

use common::{Recipe, Step, shipped_bundle};

const SIZE: (u32, u32) = (192, 128);

/// CPU rays per pixel along each axis for the box-filtered reference.
const SUPERSAMPLE: u32 = 4;

/// An edge pixel is dark when the viewer's value is below this fraction of the box-filtered
/// CPU equation's (luminance-like sum of channels).
const DARK: f32 = 0.75;

/// Dark edge pixels allowed: the rasteriser's 4 samples and the reference's 16 rays split an
/// edge pixel differently, but not by a quarter of its value.
const MAX_DARK: usize = 1;

#[test]
fn mirror_floor_edge_at_the_back_wall_has_no_dark_dots_with_msaa() {
    let bundle = shipped_bundle(
        &Recipe::new("stand-in")
            .then(Step::Scene)
            .then(Step::Radiosity(RadiositySettings::preset(Quality::Draft))),
    );
    let data = load(&bundle).unwrap_or_else(|e| panic!("{e}"));
    let path = data
        .scene
        .camera_paths
        .iter()
        .find(|p| p.name == "room")
        .expect("stand-in has a `room` camera path");
    let camera = glint::camera::pose_at(path, 0.0);
    let options = ViewOptions::from_args_for(
        ["--reflections", "geometry", "--samples", "4"],
        &glint::view::defaults::baked(&data),
    )
    .unwrap_or_else(|e| panic!("{e}"))
    .linear_display();
    let gpu = common::gpu();
    let off = Offscreen::with_options(&gpu, &data, SIZE.0, SIZE.1, &options).unwrap();
    off.render(&gpu, &camera).unwrap();
    let frame = off.read_hdr(&gpu).unwrap();

    // The CPU equation at 4 × 4 points a pixel, box-filtered; and which of those points hit
    // the mirror floor.
    let (w, h) = (SIZE.0 * SUPERSAMPLE, SIZE.1 * SUPERSAMPLE);
    let bvh = Bvh::build(&data.scene.triangles);
    let reflectors = reflections::reflectors_with_reflectance(&data);
    assert_eq!(reflectors.len(), 1, "the mirror floor");
    let fine = reflections::cpu_reference(
        &data.scene,
        &reflectors,
        &bvh,
        &data.map,
        &camera,
        w,
        h,
        1.0,
    );
    let walls: Vec<u32> = data
        .scene
        .objects
        .iter()
        .filter(|o| o.mesh_name.ends_with("Walls") || o.mesh_name == "AccentWall")
        .flat_map(|o| o.triangles.clone())
        .collect();
    assert!(!walls.is_empty(), "stand-in's walls");
    let aspect = w as f32 / h as f32;
    let on_mirror = reflections::reflector_pixels(&bvh, &reflectors, &camera, w, h);
    let s = SUPERSAMPLE as usize;
    let mut dark = Vec::new();
    let mut edge = 0;
    for y in 0..SIZE.1 as usize {
        for x in 0..SIZE.0 as usize {
            let fine_at = |i: usize, j: usize| (y * s + j) * w as usize + x * s + i;
            let covered = (0..s)
                .flat_map(|j| (0..s).map(move |i| (i, j)))
                .filter(|&(i, j)| on_mirror[fine_at(i, j)])
                .count();
            // Edge pixels of the floor's far side: partly on the mirror, the rest on a wall.
            let on_wall = (0..s)
                .flat_map(|j| (0..s).map(move |i| (i, j)))
                .filter(|&(i, j)| !on_mirror[fine_at(i, j)])
                .all(|(i, j)| {
                    let dir = camera.ray_direction(
                        Camera::pixel_ndc((x * s + i) as u32, (y * s + j) as u32, w, h),
                        aspect,
                    );
                    bvh.closest_hit(camera.position, dir, f32::INFINITY)
                        .is_some_and(|hit| walls.contains(&hit.triangle))
                });
            if covered == 0 || covered == s * s || !on_wall {
                continue;
            }
            edge += 1;
            let truth: Vec3 = (0..s)
                .flat_map(|j| (0..s).map(move |i| (i, j)))
                .map(|(i, j)| fine[fine_at(i, j)])
                .sum::<Vec3>()
                / (s * s) as f32;
            let got = frame[y * SIZE.0 as usize + x];
            if got.element_sum() < DARK * truth.element_sum() {
                dark.push((x, y, got, truth));
            }
        }
    }
    eprintln!(
        "{edge} pixels where the mirror floor meets a wall; {} dark: {:?}",
        dark.len(),
        &dark[..dark.len().min(6)]
    );
    assert!(edge > 40, "only {edge} edge pixels: the camera moved?");
    assert!(
        dark.len() <= MAX_DARK,
        "{} of {edge} edge pixels below {DARK} of the box-filtered CPU equation",
        dark.len()
    );
}
