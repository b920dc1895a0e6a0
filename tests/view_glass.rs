//! Thin glass in glint-view: a pane with `KHR_materials_transmission` shows the room behind it,
//! tinted by its base colour × (1 − F), in both reflection modes.
//!
//! The scene: a closed 4 × 3 × 4 m room with coloured walls and a ceiling light; a 1 × 1 m
//! rough pane (base colour [0.9, 0.5, 0.2], transmission 1: no diffuse part, no lobe) stands
//! between the camera and the back wall. Over the pane's pixels the frame must equal, as
//! linear HDR, T(cos θ) × D of the surface behind it (reconstructed on the CPU as the shader
//! does), T = tint × (1 − F_Schlick(0.04, cos θ)).

#![cfg(feature = "view")]

mod common;

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use glint::camera::Camera;
use glint::scene::Scene;
use glint::view::load::load;
use glint::view::reflections::ReflectionMode;

const TINT: [f32; 3] = [0.9, 0.5, 0.2];

/// Writes and bakes the room with its pane; returns the bundle.
fn bake_room() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("view-glass");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (meshes, materials) = common::pane_room(TINT, 0, 0.8);
    let gltf = common::write_gltf(&dir, "room", &meshes, &materials);
    common::add_transmission(&gltf, 5, 1.0);
    let scene_json = common::write_scene(
        &dir,
        r#"{ "version": 1, "name": "glass-room", "geometry": "room.gltf" }"#,
    );
    let scene = Scene::load(&scene_json).unwrap_or_else(|e| panic!("{e}"));
    let bundle = dir.join("glass.glint");
    common::bake_with_radiance(&scene, &bundle, &common::quick_radiosity(2));
    bundle
}

/// The expected linear radiance of the pixel whose camera ray is `dir`, and whether that ray
/// meets the pane first: T(cos θ) × D behind the pane, or D of what it meets.
fn expected(
    data: &glint::view::load::ViewData,
    bvh: &glint::geometry::Bvh,
    camera: &Camera,
    dir: Vec3,
) -> Option<(Vec3, bool)> {
    let scene = &data.scene;
    let h = bvh.closest_hit(camera.position, dir, f32::INFINITY)?;
    let m = scene.material_of(h.triangle);
    if !m.is_transmissive() {
        return Some((
            glint::view::cpu::bicubic::radiance(&data.map, h.triangle, h.bary),
            false,
        ));
    }
    let ng = scene.triangles[h.triangle as usize].face_normal();
    let cos = dir.dot(ng);
    let p = bvh.offset_origin(camera.position + dir * h.t, ng * cos.signum());
    let behind = bvh.closest_hit(p, dir, f32::INFINITY)?;
    let d = glint::view::cpu::bicubic::radiance(&data.map, behind.triangle, behind.bary);
    Some((m.transmission.weight(cos) * d, true))
}

#[test]
fn a_glass_pane_shows_the_room_behind_it_tinted_in_both_modes() {
    let data = load(&bake_room()).unwrap_or_else(|e| panic!("{e}"));
    let glass = data
        .scene
        .materials
        .iter()
        .find(|m| m.name == "Glass")
        .unwrap();
    assert_eq!(glass.transmission.factor, 1.0);
    const SIZE: (u32, u32) = (160, 120);
    let camera = Camera::look_at(
        Vec3::new(0.3, 1.4, 1.8),
        Vec3::new(0.0, 1.2, -2.0),
        Vec3::Y,
        45f32.to_radians(),
    );
    let bvh = data.scene.build_bvh();
    let aspect = SIZE.0 as f32 / SIZE.1 as f32;
    let ray = |x: i32, y: i32| {
        let ndc = Vec2::new(
            2.0 * (x as f32 + 0.5) / SIZE.0 as f32 - 1.0,
            1.0 - 2.0 * (y as f32 + 0.5) / SIZE.1 as f32,
        );
        camera.ray_direction(ndc, aspect)
    };
    let through =
        |x: i32, y: i32| expected(&data, &bvh, &camera, ray(x, y)).is_some_and(|(_, pane)| pane);
    // Pane pixels whose neighbours are pane pixels too (edges rasterise as they may).
    let mut want = Vec::new();
    for y in 1..SIZE.1 as i32 - 1 {
        for x in 1..SIZE.0 as i32 - 1 {
            let inner = [(0, 0), (1, 0), (-1, 0), (0, 1), (0, -1)]
                .iter()
                .all(|(dx, dy)| through(x + dx, y + dy));
            if inner {
                let (v, _) = expected(&data, &bvh, &camera, ray(x, y)).unwrap();
                want.push(((y as u32 * SIZE.0 + x as u32) as usize, v));
            }
        }
    }
    assert!(want.len() > 1500, "the pane covers {} pixels", want.len());
    let frames = common::hdr_frames(
        &data,
        &camera,
        SIZE,
        &[ReflectionMode::Geometry, ReflectionMode::Image],
    );
    for (frame, mode) in frames.iter().zip(["geometry", "image"]) {
        let (mut num, mut den) = (0.0f64, 0.0f64);
        let (mut got_sum, mut want_sum) = (Vec3::ZERO, Vec3::ZERO);
        for &(i, v) in &want {
            num += f64::from((frame[i] - v).abs().element_sum());
            den += f64::from(v.element_sum());
            got_sum += frame[i];
            want_sum += v;
        }
        let d = num / den;
        eprintln!(
            "{mode}: through the pane {got_sum} vs {want_sum} over {} pixels: {d:.4}",
            want.len()
        );
        assert!(d < 0.03, "{mode}: the pane's pixels differ by {d:.4}");
    }
}
