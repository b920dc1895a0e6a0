//! Anti-aliased mirror maps: in a 4× MSAA frame, the edge of a bright emitter seen in a
//! near-mirror is anti-aliased as the frame's own edges are, in both reflection modes. The
//! planar reflector's mirror pass draws at the frame's sample count and is resolved into its
//! map M before the pyramid; a near-mirror's composite reads M almost unfiltered, so a
//! single-sampled M shows the edge as a staircase (each pixel all lamp or all wall).
//!
//! The scene: a closed 4 × 3 × 4 m room, its floor a mirror (white metal, glTF roughness
//! 0.02), a 1.4 m square lamp 10 cm under the ceiling, turned 30° about the vertical so its edges run slanted
//! across the frame. The camera looks down at the lamp's reflection at a low resolution. The
//! reference is the viewer's own frame at 4× the resolution each way, averaged over each
//! pixel's 4×4 block.

#![cfg(feature = "view")]

mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use glam::Vec3;
use glint::camera::Camera;
use glint::scene::Scene;
use glint::view::headless::Offscreen;
use glint::view::load::{ViewData, load};
use glint::view::options::ViewOptions;
use glint::view::reflections::ReflectionMode;

use common::MaterialSpec;

/// The low resolution of the frame.
const SIZE: (u32, u32) = (96, 64);
/// The reference's resolution factor per axis (and the sub-pixel rays per axis of the mask).
const SUPER: u32 = 4;
/// Samples a pixel of the anti-aliased frame.
const SAMPLES: u32 = 4;
/// The edge pixels' RMS difference from the reference, over the reference's mean there.
const TOLERANCE: f64 = 0.25;

/// The room's bundle, written and baked once for every test here.
fn bundle() -> &'static PathBuf {
    static ROOM: OnceLock<PathBuf> = OnceLock::new();
    ROOM.get_or_init(bake_room)
}

/// Writes and bakes the room (scene, radiosity and radiance stages); returns its bundle.
fn bake_room() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("view-mirror-aa");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut materials = common::coloured_walls();
    materials.push(MaterialSpec::emitter("Light", [1.0, 1.0, 1.0], 6.0));
    // A white metal of glTF roughness 0.02: a near-mirror.
    materials.push(MaterialSpec {
        base: [1.0; 4],
        metallic: 1.0,
        roughness: 0.02,
        ..MaterialSpec::diffuse("FloorMat", 0.0)
    });
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    let turn = glam::Quat::from_rotation_y(30f32.to_radians());
    let (u, v) = (turn * x * 1.4, turn * z * 1.4);
    let meshes = vec![
        common::rect("Floor", 5, Vec3::new(-2.0, 0.0, 2.0), 4.0 * x, -4.0 * z),
        common::rect("Ceiling", 0, Vec3::new(-2.0, 3.0, -2.0), 4.0 * x, 4.0 * z),
        common::rect("Back", 3, Vec3::new(-2.0, 0.0, -2.0), 4.0 * x, 3.0 * y),
        common::rect("Front", 0, Vec3::new(2.0, 0.0, 2.0), -4.0 * x, 3.0 * y),
        common::rect("Left", 1, Vec3::new(-2.0, 0.0, 2.0), -4.0 * z, 3.0 * y),
        common::rect("Right", 2, Vec3::new(2.0, 0.0, -2.0), 4.0 * z, 3.0 * y),
        // Facing down (u × v = −y), centred under the ceiling's middle.
        common::rect("Lamp", 4, Vec3::new(0.0, 2.9, 0.0) - (u + v) * 0.5, u, v),
    ];
    common::write_gltf(&dir, "room", &meshes, &materials);
    let scene_json = common::write_scene(
        &dir,
        r#"{ "version": 1, "name": "mirror-aa-room", "geometry": "room.gltf",
  "reflectors": [ { "mesh": "Floor", "kind": "planar" } ] }"#,
    );
    let scene = Scene::load(&scene_json).unwrap_or_else(|e| panic!("{e}"));
    let bundle = dir.join("room.glint");
    common::bake_with_radiance(&scene, &bundle, &common::quick_radiosity(2));
    bundle
}

/// Looking down at the lamp's mirror image from above the front half of the room.
fn camera() -> Camera {
    Camera::look_at(
        Vec3::new(0.0, 1.6, 1.6),
        Vec3::new(0.0, -2.9, 0.0),
        Vec3::Y,
        45f32.to_radians(),
    )
}

/// The frame's linear radiance at `w` × `h` with `samples` samples a pixel in `mode`.
fn render(data: &ViewData, mode: ReflectionMode, (w, h): (u32, u32), samples: u32) -> Vec<Vec3> {
    let gpu = common::gpu();
    let options = ViewOptions {
        reflections: mode,
        samples,
        ..ViewOptions::default().linear_display()
    };
    let off = Offscreen::with_options(&gpu, data, w, h, &options).unwrap();
    off.render(&gpu, &camera()).unwrap();
    off.read_hdr(&gpu).unwrap()
}

/// The pixels of a `SIZE` frame all of whose 4×4 sub-pixel rays meet the mirror floor first,
/// some of them then the lamp and some not: the lamp's edge seen in the mirror.
fn edge_pixels(data: &ViewData) -> Vec<bool> {
    let scene = &data.scene;
    let bvh = scene.build_bvh();
    let camera = camera();
    let (w, h) = SIZE;
    let (sw, sh) = (w * SUPER, h * SUPER);
    // Per sub-pixel ray: None when it does not meet the floor first, else whether its
    // reflection meets the lamp.
    let sees_lamp = |sx: u32, sy: u32| {
        let dir = camera.ray_direction(Camera::pixel_ndc(sx, sy, sw, sh), sw as f32 / sh as f32);
        let floor = bvh.closest_hit(camera.position, dir, f32::INFINITY)?;
        if scene.material_of(floor.triangle).name != "FloorMat" {
            return None;
        }
        let n = scene.triangles[floor.triangle as usize].face_normal();
        let r = dir - 2.0 * dir.dot(n) * n;
        let p = bvh.offset_origin(camera.position + dir * floor.t, n);
        let seen = bvh.closest_hit(p, r, f32::INFINITY)?;
        Some(scene.material_of(seen.triangle).name == "Light")
    };
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let rays: Option<Vec<bool>> = (0..SUPER * SUPER)
                .map(|k| sees_lamp(x * SUPER + k % SUPER, y * SUPER + k / SUPER))
                .collect();
            rays.is_some_and(|r| r.iter().any(|&l| l) && !r.iter().all(|&l| l))
        })
        .collect()
}

/// `frame` (`SIZE` × `SUPER`) averaged over each pixel's `SUPER` × `SUPER` block.
fn box_down(frame: &[Vec3]) -> Vec<Vec3> {
    let (w, h) = SIZE;
    let sw = w * SUPER;
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let sum: Vec3 = (0..SUPER * SUPER)
                .map(|k| frame[((y * SUPER + k / SUPER) * sw + x * SUPER + k % SUPER) as usize])
                .sum();
            sum / (SUPER * SUPER) as f32
        })
        .collect()
}

/// The RMS difference of `frame`'s luminance from `reference`'s over `mask`, relative to the
/// reference's mean there.
fn relative_rms(frame: &[Vec3], reference: &[Vec3], mask: &[bool]) -> f64 {
    let lum = |c: Vec3| f64::from(glint::eval::luminance(c));
    let on: Vec<usize> = (0..mask.len()).filter(|&i| mask[i]).collect();
    let n = on.len() as f64;
    let mean = on.iter().map(|&i| lum(reference[i])).sum::<f64>() / n;
    let squared = on
        .iter()
        .map(|&i| (lum(frame[i]) - lum(reference[i])).powi(2))
        .sum::<f64>()
        / n;
    squared.sqrt() / mean
}

/// In `mode`, the lamp's edge seen in the mirror floor at `SIZE` with 4× MSAA is within
/// `TOLERANCE` (relative RMS over the edge pixels) of the viewer's frame at 4× the resolution
/// box-filtered down; a single-sampled frame is not (the check sees the staircase).
fn mirrored_edge_is_anti_aliased(mode: ReflectionMode) {
    let data = load(bundle()).unwrap_or_else(|e| panic!("{e}"));
    let mask = edge_pixels(&data);
    let count = mask.iter().filter(|&&m| m).count();
    assert!(count > 40, "the lamp's mirrored edge covers {count} pixels");
    let (w, h) = SIZE;
    let reference = box_down(&render(&data, mode, (w * SUPER, h * SUPER), SAMPLES));
    let single = relative_rms(&render(&data, mode, SIZE, 1), &reference, &mask);
    let multi = relative_rms(&render(&data, mode, SIZE, SAMPLES), &reference, &mask);
    eprintln!(
        "{mode:?}: the lamp's mirrored edge over {count} px at {w}×{h}, relative RMS from the \
         box-filtered 4× frame: 1 sample {single:.3}, {SAMPLES} samples {multi:.3}"
    );
    assert!(
        single > TOLERANCE,
        "{mode:?}: the single-sampled edge ({single:.3}) should show the staircase"
    );
    assert!(
        multi < TOLERANCE,
        "{mode:?}: the lamp's edge seen in the mirror with {SAMPLES}× MSAA is {multi:.3} \
         (relative RMS) from the box-filtered 4× frame"
    );
}

#[test]
fn a_lamp_edge_seen_in_a_mirror_is_anti_aliased_in_geometry_mode() {
    mirrored_edge_is_anti_aliased(ReflectionMode::Geometry);
}

#[test]
fn a_lamp_edge_seen_in_a_mirror_is_anti_aliased_in_image_mode() {
    mirrored_edge_is_anti_aliased(ReflectionMode::Image);
}
