//! A scene lit by a scene.json area light (a quad, not geometry, as breakfast-room's window
//! and pendants are): a chrome ball (a declared curved reflector, seen through its live cube
//! map) and a black glossy box that no reflector declares (its specular term from the probe
//! the bake places), both facing the light, against the path tracer, whose reflected rays
//! collect the light where they cross it. Each material's pixels are those all of whose 4×4
//! sub-pixel rays meet it first; the reference keeps that material's lobes alone and the
//! radiosity leaves glossy transport out, so D is the same diffuse solution on both sides.

#![cfg(feature = "view")]

mod common;

use common::*;
use glam::Vec3;
use glint::camera::Camera;
use glint::scene::Scene;
use glint::view::curved::CurvedMode;
use glint::view::headless::Offscreen;
use glint::view::load::{ViewData, load};
use glint::view::options::ViewOptions;

/// The frame's size.
const SIZE: (u32, u32) = (128, 96);
/// Sub-pixel rays per axis that must all meet the material for a pixel to count as its.
const SUPER: u32 = 4;
/// Issue 44's bound on a glossy material's mean luminance against the path tracer's.
const TOLERANCE: f64 = 0.10;

/// A closed 4 × 3 × 4 m room of [`coloured_walls`] lit only by two 1.6 × 1.2 m area lights,
/// on its back and front walls, facing the room; a chrome ball (glTF metallic, breakfast-room's Chrome) and
/// a black glossy box (breakfast-room's BlackPaint) stand before the back wall. Baked at draft
/// with the diffuse radiosity solution, with the materials stage (the ball's environment map,
/// the box's probe); and its scene.json.
fn bundle(dir: &std::path::Path) -> (ViewData, std::path::PathBuf) {
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    let mut materials = coloured_walls();
    materials.push(MaterialSpec {
        name: "Chrome",
        base: [0.6875, 0.6491, 0.687, 1.0],
        metallic: 1.0,
        roughness: 0.2236,
        emissive: [0.0; 3],
        strength: 1.0,
    });
    materials.push(MaterialSpec {
        name: "BlackPaint",
        base: [0.01, 0.01, 0.01, 1.0],
        metallic: 0.0,
        roughness: 0.4472,
        emissive: [0.0; 3],
        strength: 1.0,
    });
    let (lo, hi) = (Vec3::new(-0.35, 0.0, -0.5), Vec3::new(0.25, 0.5, 0.1));
    let d = hi - lo;
    let box_faces = [
        [lo + d * z, lo + d * z + d * x, hi, lo + d * z + d * y],
        [lo, lo + d * y, lo + d * y + d * x, lo + d * x],
        [lo, lo + d * z, lo + d * z + d * y, lo + d * y],
        [lo + d * x, lo + d * x + d * y, hi, lo + d * x + d * z],
        [lo + d * y, lo + d * y + d * z, hi, lo + d * y + d * x],
    ]
    .map(|q| q.map(|p| p.to_array()));
    let meshes = vec![
        rect("Floor", 0, Vec3::new(-2.0, 0.0, 2.0), 4.0 * x, -4.0 * z),
        rect("Ceiling", 0, Vec3::new(-2.0, 3.0, -2.0), 4.0 * x, 4.0 * z),
        rect("Back", 3, Vec3::new(-2.0, 0.0, -2.0), 4.0 * x, 3.0 * y),
        rect("Front", 0, Vec3::new(2.0, 0.0, 2.0), -4.0 * x, 3.0 * y),
        rect("Left", 1, Vec3::new(-2.0, 0.0, 2.0), -4.0 * z, 3.0 * y),
        rect("Right", 2, Vec3::new(2.0, 0.0, -2.0), 4.0 * z, 3.0 * y),
        uv_sphere("Ball", 4, [0.75, 0.45, -0.6], 0.3, true),
        quads("Box", 5, &box_faces),
    ];
    write_gltf(dir, "room", &meshes, &materials);
    let scene_json = write_scene(
        dir,
        r#"{
          "version": 1,
          "geometry": "room.gltf",
          "lights": [{ "name": "window", "corner": [-0.8, 0.9, -1.99],
                       "edge_u": [1.6, 0.0, 0.0], "edge_v": [0.0, 1.2, 0.0],
                       "radiance": [8.0, 8.0, 9.0] },
                     { "name": "lamp", "corner": [-0.8, 1.1, 1.99],
                       "edge_u": [0.0, 1.2, 0.0], "edge_v": [1.6, 0.0, 0.0],
                       "radiance": [8.0, 8.0, 9.0] }],
          "reflectors": [{ "name": "Ball", "mesh": "Ball", "kind": "curved" }]
        }"#,
    );
    let scene = Scene::load(&scene_json).unwrap_or_else(|e| panic!("{e}"));
    let bundle = dir.join("room.glint");
    bake_with_materials(&scene, &bundle, &quick_radiosity(3));
    (load(&bundle).unwrap_or_else(|e| panic!("{e}")), scene_json)
}

/// From near the front wall, below its light, looking down at the box: the ball reflects the
/// front wall's light, the box's top the back wall's.
fn camera() -> Camera {
    Camera::look_at(
        Vec3::new(-0.1, 1.3, 1.6),
        Vec3::new(0.2, 0.45, -0.3),
        Vec3::Y,
        50f32.to_radians(),
    )
}

/// The viewer's linear frame with its cube-mapped reflector and probes, 4× MSAA.
fn view(data: &ViewData, camera: &Camera) -> Vec<Vec3> {
    let gpu = gpu();
    let options = ViewOptions {
        curved: CurvedMode::Cubemap,
        probes: true,
        samples: 4,
        ..ViewOptions::default().linear_display()
    };
    let off = Offscreen::with_options(&gpu, data, SIZE.0, SIZE.1, &options).unwrap();
    off.render(&gpu, camera).unwrap();
    off.read_hdr(&gpu).unwrap()
}

#[test]
fn chrome_and_black_paint_reflect_an_area_light_as_the_path_tracer_does() {
    let dir = tempfile::tempdir().unwrap();
    let (data, scene_json) = bundle(dir.path());
    let camera = camera();
    let frame = view(&data, &camera);
    let bvh = data.scene.build_bvh();
    let mut failed = Vec::new();
    for (name, least) in [("Chrome", 400), ("BlackPaint", 1000)] {
        let material = material_id(&data.scene, name);
        let mask = covered_pixels(&camera, SIZE, SUPER, |d| {
            bvh.closest_hit(camera.position, d, f32::INFINITY)
                .is_some_and(|hit| data.scene.triangles[hit.triangle as usize].material == material)
        });
        let count = mask.iter().filter(|m| **m).count();
        assert!(count > least, "{name} covers {count} pixels");
        let mut scene = Scene::load(&scene_json).unwrap_or_else(|e| panic!("{e}"));
        let traced = traced_with_lobes_of(&mut scene, &[material], &camera, SIZE)
            .1
            .image
            .rgb;
        let (got, want) = (
            masked_luminance(&frame, &mask),
            masked_luminance(&traced, &mask),
        );
        let ratio = got / want;
        eprintln!("{name}, {count} px: {got:.4} vs {want:.4} ({ratio:.3})");
        if (ratio - 1.0).abs() >= TOLERANCE {
            failed.push(format!("{name} is {ratio:.3} of the path tracer's"));
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("; "));
}
