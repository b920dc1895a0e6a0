//! Thin glass seen in reflections: a pane with `KHR_materials_transmission` reflected in a
//! mirror floor shows the wall behind it, tinted, in both reflection modes (geometry mode's
//! mirrored scene pass, image mode's baked radiance maps), as the path tracer does; and a cube
//! map captured in front of the pane (environment maps, probes) sees through it. So do geometry
//! mode's recursive maps (`--recursion-depth` 2) and the viewer's live cube maps (curved
//! reflectors, the near-mirrors' terminal maps).
//!
//! The scene: a closed 4 × 3 × 4 m room with coloured walls and a ceiling light, its floor a
//! mirror (white metal, glTF roughness 0.02); a 1 × 1 m pane (base colour
//! [`TINT`], transmission 1: no diffuse part) stands 0.3 m above the floor, 2 m in front of
//! the blue back wall. The camera looks down at the pane's reflection.

#![cfg(feature = "view")]

mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use glam::Vec3;
use glint::brdf::Lobe;
use glint::camera::Camera;
use glint::geometry::{Bvh, Hit};
use glint::materials::envmap::{CaptureSettings, capture_cube, face_direction};
use glint::progress::Silent;
use glint::scene::Scene;
use glint::view::curved::gpu::CurvedReflections;
use glint::view::curved::{CurvedReflector, CurvedSettings};
use glint::view::headless::Offscreen;
use glint::view::load::{ViewData, load};
use glint::view::reflections::ReflectionMode;
use glint::view::reflections::recursive::RecursionSettings;

use common::MaterialSpec;

const TINT: [f32; 3] = [0.9, 0.5, 0.2];
const SIZE: (u32, u32) = (160, 120);

/// The room's scene.json and bundle, written and baked once for every test here.
fn room() -> &'static (PathBuf, PathBuf) {
    static ROOM: OnceLock<(PathBuf, PathBuf)> = OnceLock::new();
    ROOM.get_or_init(bake_room)
}

/// Writes and bakes the room; returns its scene.json and bundle.
fn bake_room() -> (PathBuf, PathBuf) {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("view-glass-reflected");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (meshes, mut materials) = common::pane_room(TINT, 6, 0.3);
    // A white metal of glTF roughness 0.02: a GGX mirror whose reflectance is 1 at every
    // angle, as the viewer's R is without a materials stage.
    materials.push(MaterialSpec {
        base: [1.0; 4],
        metallic: 1.0,
        roughness: 0.02,
        ..MaterialSpec::diffuse("FloorMat", 0.0)
    });
    let gltf = common::write_gltf(&dir, "room", &meshes, &materials);
    common::add_transmission(&gltf, 5, 1.0);
    let scene_json = common::write_scene(
        &dir,
        r#"{ "version": 1, "name": "glass-mirror-room", "geometry": "room.gltf",
  "reflectors": [ { "mesh": "Floor", "kind": "planar" } ] }"#,
    );
    let scene = Scene::load(&scene_json).unwrap_or_else(|e| panic!("{e}"));
    let bundle = dir.join("glass.glint");
    // D holds the light the mirror floor sends into the room, as the path tracer's does.
    let settings = glint::scene::desc::RadiositySettings {
        glossy_depth: 2,
        ..common::quick_radiosity(2)
    };
    common::bake_with_radiance(&scene, &bundle, &settings);
    (scene_json, bundle)
}

fn camera() -> Camera {
    Camera::look_at(
        Vec3::new(0.2, 1.1, 1.9),
        Vec3::new(0.0, -0.7, -0.2),
        Vec3::Y,
        60f32.to_radians(),
    )
}

/// What the pixel's ray sees in the mirror floor: `Some(true)` the pane, `Some(false)` the back
/// wall, `None` anything else (or not the floor first); with what the viewer's equation gives
/// there: the pane's D plus T(cos θ) × D behind it, or the wall's D.
fn seen_in_mirror(
    data: &ViewData,
    bvh: &Bvh,
    camera: &Camera,
    x: i64,
    y: i64,
) -> Option<(bool, Vec3)> {
    let (w, h) = SIZE;
    if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
        return None;
    }
    let scene = &data.scene;
    let dir = camera.ray_direction(
        Camera::pixel_ndc(x as u32, y as u32, w, h),
        w as f32 / h as f32,
    );
    let floor = bvh.closest_hit(camera.position, dir, f32::INFINITY)?;
    if scene.material_of(floor.triangle).name != "FloorMat" {
        return None;
    }
    let n = scene.triangles[floor.triangle as usize].face_normal();
    let r = dir - 2.0 * dir.dot(n) * n;
    let p = bvh.offset_origin(camera.position + dir * floor.t, n);
    let seen = bvh.closest_hit(p, r, f32::INFINITY)?;
    let d = |h: &Hit| glint::view::cpu::bicubic::radiance(&data.map, h.triangle, h.bary);
    let m = scene.material_of(seen.triangle);
    match m.name.as_str() {
        "Glass" => {
            let ng = scene.triangles[seen.triangle as usize].face_normal();
            let cos = r.dot(ng);
            let past = bvh.offset_origin(p + r * seen.t, ng * cos.signum());
            let behind = bvh.closest_hit(past, r, f32::INFINITY)?;
            Some((true, d(&seen) + m.transmission.weight(cos) * d(&behind)))
        }
        "Blue" => Some((false, d(&seen))),
        _ => None,
    }
}

/// Per pixel: `Some(pane)` where the pixel and its 8 neighbours see the pane (or all see the
/// back wall beside it) in the mirror; and per pixel the viewer's equation there (zero
/// elsewhere).
fn regions(data: &ViewData, camera: &Camera) -> (Vec<Option<bool>>, Vec<Vec3>) {
    let bvh = data.scene.build_bvh();
    let (w, h) = SIZE;
    let both: Vec<Option<(bool, Vec3)>> = (0..h as i64)
        .flat_map(|y| (0..w as i64).map(move |x| (x, y)))
        .map(|(x, y)| seen_in_mirror(data, &bvh, camera, x, y))
        .collect();
    let seen: Vec<Option<bool>> = both.iter().map(|s| s.map(|(p, _)| p)).collect();
    let equation = both
        .iter()
        .map(|s| s.map_or(Vec3::ZERO, |(_, v)| v))
        .collect();
    let at = |x: i64, y: i64| {
        (x >= 0 && y >= 0 && x < w as i64 && y < h as i64)
            .then(|| seen[(y * w as i64 + x) as usize])
            .flatten()
    };
    let regions = (0..h as i64)
        .flat_map(|y| (0..w as i64).map(move |x| (x, y)))
        .map(|(x, y)| {
            let c = at(x, y)?;
            (-1..=1)
                .all(|dy| (-1..=1).all(|dx| at(x + dx, y + dy) == Some(c)))
                .then_some(c)
        })
        .collect();
    (regions, equation)
}

/// Mean linear radiance of `frame` over the pixels of `regions` equal to `Some(which)`.
fn mean(frame: &[Vec3], regions: &[Option<bool>], which: bool) -> Vec3 {
    let (sum, n) = frame
        .iter()
        .zip(regions)
        .filter(|(_, r)| **r == Some(which))
        .fold((Vec3::ZERO, 0u32), |(s, n), (v, _)| (s + *v, n + 1));
    sum / n.max(1) as f32
}

/// Luminance-like weight of a colour: the sum of its channels.
fn sum(v: Vec3) -> f64 {
    f64::from(v.element_sum())
}

/// The pane's reflection in the mirror floor, over the pixels that see the pane in the mirror,
/// in each mode:
/// - against the viewer's own equation (the pane's D + T(cos θ) × D behind it, evaluated on the
///   CPU along the mirrored ray): geometry mode, which renders the mirrored view exactly, per
///   pixel (mean absolute difference over the mean) within 3%; image mode, which
///   reconstructs it from splats, over the region's mean within 8%;
/// - against the path tracer: its ratio to the reflected back wall beside the pane (no glass
///   there, so D's own error against the path tracer cancels) within [`TRACED_TOLERANCE`].
///
/// With glass drawn opaque in the mirrored view and in the radiance maps, the reflected pane
/// is its D, black (no diffuse part): 100% off in both.
#[test]
fn a_glass_pane_reflected_in_a_mirror_floor_shows_the_wall_behind_it() {
    const PER_PIXEL_TOLERANCE: f64 = 0.03;
    const MEAN_TOLERANCE: f64 = 0.08;
    const TRACED_TOLERANCE: f64 = 0.15;
    let (scene_json, bundle) = room();
    let data = load(bundle).unwrap_or_else(|e| panic!("{e}"));
    let camera = camera();
    let (regions, equation) = regions(&data, &camera);
    let pane = regions.iter().filter(|r| **r == Some(true)).count();
    let wall = regions.iter().filter(|r| **r == Some(false)).count();
    assert!(
        pane > 400 && wall > 400,
        "{pane} pixels see the pane and {wall} the wall in the mirror"
    );
    let mut scene = Scene::load(scene_json).unwrap_or_else(|e| panic!("{e}"));
    let floor = common::material_id(&scene, "FloorMat");
    let (_, traced) = common::traced_with_lobes_of(&mut scene, &[floor], &camera, SIZE);
    let traced: Vec<Vec3> = traced.image.rgb.clone();
    let traced_ratio = sum(mean(&traced, &regions, true)) / sum(mean(&traced, &regions, false));
    let frames = common::hdr_frames(
        &data,
        &camera,
        SIZE,
        &[ReflectionMode::Geometry, ReflectionMode::Image],
    );
    let mut failures = Vec::new();
    let want = sum(mean(&equation, &regions, true));
    for (frame, mode) in frames.iter().zip(["geometry", "image"]) {
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for ((v, want), r) in frame.iter().zip(&equation).zip(&regions) {
            if *r == Some(true) {
                num += sum((*v - *want).abs());
                den += sum(*want);
            }
        }
        let per_pixel = num / den;
        let got = mean(frame, &regions, true);
        let off_mean = (sum(got) / want - 1.0).abs();
        let ratio = sum(got) / sum(mean(frame, &regions, false));
        let off_traced = (ratio / traced_ratio - 1.0).abs();
        eprintln!(
            "{mode}: the reflected pane {got} ({pane} pixels): from the equation {per_pixel:.4} \
             per pixel, {off_mean:.4} in the mean; to the wall beside it {ratio:.4} against \
             the path tracer's {traced_ratio:.4} ({off_traced:.4})"
        );
        let off_equation = match mode {
            "geometry" => per_pixel > PER_PIXEL_TOLERANCE,
            _ => off_mean > MEAN_TOLERANCE,
        };
        if off_equation || off_traced > TRACED_TOLERANCE {
            failures.push(format!(
                "{mode}: from the equation {per_pixel:.4} per pixel, {off_mean:.4} in the \
                 mean; {off_traced:.4} from the path tracer"
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// A cube map captured 1 m in front of the pane (as environment maps and probes are) sees the
/// wall behind it: the texel looking straight through is T(0°) × D of the wall plus the pane's
/// own D, within 1%; opaque, it would be the pane's D, black.
#[test]
fn a_cube_map_captured_in_front_of_a_pane_sees_through_it() {
    let data = load(&room().1).unwrap_or_else(|e| panic!("{e}"));
    let scene = &data.scene;
    let bvh = scene.build_bvh();
    let d = |h: &Hit| glint::view::cpu::bicubic::radiance(&data.map, h.triangle, h.bary);
    let centre = Vec3::new(0.0, 0.8, 1.0);
    let settings = CaptureSettings {
        face_size: 8,
        supersample: 1,
        mirror_bounces: 0,
        glossy_samples: 0,
    };
    let cube = capture_cube(scene, &bvh, centre, &settings, &[], &d, &Silent)
        .unwrap_or_else(|_| panic!("cancelled"));
    // −z face, the texel nearest its centre.
    let face = (0..6)
        .find(|&f| face_direction(f, 0.0, 0.0).normalize().dot(-Vec3::Z) > 0.99)
        .unwrap();
    // One ray a texel, at the first point of capture_cube's R2 pattern.
    let (s, t) = (
        2.0 * (4.0 + (0.5f64 * 0.754_877_666_246_692_7).fract() as f32) / 8.0 - 1.0,
        2.0 * (4.0 + (0.5f64 * 0.569_840_290_998_053_3).fract() as f32) / 8.0 - 1.0,
    );
    let dir = face_direction(face, s, t).normalize();
    let got = cube.texels[(face * 8 + 4) * 8 + 4];
    let want = pane_over_wall(scene, &bvh, centre, dir, d);
    let off = ((got - want) / want).abs().max_element();
    eprintln!("through the pane: {got} against {want} ({off:.4})");
    assert!(off < 0.01, "{got} against {want}: {off:.4}");
}

/// What a ray from `from` along `dir` sees through the pane: the pane's D plus its
/// transmittance at that angle × the D of the blue wall behind it (`d` reads D at a hit).
fn pane_over_wall(
    scene: &Scene,
    bvh: &Bvh,
    from: Vec3,
    dir: Vec3,
    d: impl Fn(&Hit) -> Vec3,
) -> Vec3 {
    let pane = bvh.closest_hit(from, dir, f32::INFINITY).unwrap();
    let glass = scene.material_of(pane.triangle);
    assert!(glass.is_transmissive());
    let ng = scene.triangles[pane.triangle as usize].face_normal();
    let cos = dir.dot(ng);
    let past = bvh.offset_origin(from + dir * pane.t, ng * cos.signum());
    let wall = bvh.closest_hit(past, dir, f32::INFINITY).unwrap();
    assert_eq!(scene.material_of(wall.triangle).name, "Blue");
    d(&pane) + glass.transmission.weight(cos) * d(&wall)
}

/// Per pixel, over the pixels that see the pane in the mirror: the mean absolute difference of
/// `frame` from the viewer's equation, over the equation's mean.
fn off_equation(frame: &[Vec3], equation: &[Vec3], regions: &[Option<bool>]) -> f64 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for ((v, want), r) in frame.iter().zip(equation).zip(regions) {
        if *r == Some(true) {
            num += sum((*v - *want).abs());
            den += sum(*want);
        }
    }
    num / den
}

/// At `--recursion-depth` 2 the mirror floor's map is drawn by the recursive passes: the
/// pane's reflection there is the viewer's equation per pixel within 3%, as at depth 1, and
/// the frame matches depth 1's over it (one mirror: no level-1 map). With glass drawn opaque
/// in the recursive maps the reflected pane is black, 100% off.
#[test]
fn a_glass_pane_reflected_at_recursion_depth_two_shows_the_wall_behind_it() {
    const PER_PIXEL_TOLERANCE: f64 = 0.03;
    let data = load(&room().1).unwrap_or_else(|e| panic!("{e}"));
    let camera = camera();
    let (regions, equation) = regions(&data, &camera);
    let gpu = common::gpu();
    let mut off = Offscreen::new(&gpu, &data, SIZE.0, SIZE.1).unwrap();
    let mut frame_at = |depth: u8| {
        off.options.recursion = RecursionSettings {
            depth,
            ..off.options.recursion
        };
        off.set_reflections(&gpu, &data, ReflectionMode::Geometry)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(off.recursive().is_some(), depth >= 2);
        off.render(&gpu, &camera).unwrap();
        off.read_hdr(&gpu).unwrap()
    };
    let one = frame_at(1);
    let two = frame_at(2);
    let got = off_equation(&two, &equation, &regions);
    let from_one = off_equation(&two, &one, &regions);
    eprintln!(
        "depth 2: the reflected pane {} against the equation's {}: {got:.4} per pixel; \
         {from_one:.4} from depth 1",
        mean(&two, &regions, true),
        mean(&equation, &regions, true)
    );
    assert!(
        got < PER_PIXEL_TOLERANCE,
        "depth 2: {got:.4} per pixel from the equation"
    );
    assert!(from_one < 0.01, "depth 2: {from_one:.4} from depth 1");
}

/// The viewer's live cube maps (curved reflectors' `--curved cubemap`, the near-mirrors'
/// terminal maps) are drawn by one generation pass: a map taken 1 m in front of the pane sees
/// the wall through it, D(pane) + T(0°) × D(wall) at the lookup straight through, within 2%
/// (the bilinear read of the four texels around it); opaque, it would be the pane's D, black.
#[test]
fn a_live_cube_map_in_front_of_a_pane_sees_through_it() {
    let data = load(&room().1).unwrap_or_else(|e| panic!("{e}"));
    let scene = &data.scene;
    let bvh = scene.build_bvh();
    let floor = common::material_id(scene, "FloorMat") as usize;
    let centre = Vec3::new(0.0, 0.8, 1.0);
    // The mirror floor as a cube-mapped reflector taken at `centre`: its map holds the room
    // without the floor.
    let reflector = CurvedReflector {
        name: "Floor".into(),
        triangles: (0..scene.triangles.len() as u32)
            .filter(|&t| scene.triangles[t as usize].material as usize == floor)
            .collect(),
        centre,
        lobes: scene.materials[floor]
            .lobes
            .iter()
            .map(Lobe::from)
            .collect(),
    };
    assert!(!reflector.triangles.is_empty() && !reflector.lobes.is_empty());
    let gpu = common::gpu();
    let off = Offscreen::new(&gpu, &data, SIZE.0, SIZE.1).unwrap();
    let settings = CurvedSettings {
        glossy_samples: 0,
        face_size: 32,
        generations: 1,
        parallax: true,
        self_occlusion: false,
        specular_aa: true,
    };
    let cubes =
        CurvedReflections::with_reflectors(&gpu, off.renderer(), &data, settings, vec![reflector])
            .unwrap_or_else(|e| panic!("{e}"));
    let got = cubes
        .probe_live_map(&gpu, 0, &[[0.0, 0.0, -1.0, 0.0]])
        .unwrap()[0];
    let d = |h: &Hit| glint::view::cpu::bicubic::radiance(&data.map, h.triangle, h.bary);
    let want = pane_over_wall(scene, &bvh, centre, -Vec3::Z, d);
    let off_by = ((got - want) / want).abs().max_element();
    eprintln!("the live cube map through the pane: {got} against {want} ({off_by:.4})");
    assert!(off_by < 0.02, "{got} against {want}: {off_by:.4}");
}
