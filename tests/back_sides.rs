//! Open double-sided sheets (a lamp shade, a one-layer chair shell, a leaf) are lit on each side
//! by what that side sees: the bake gives a sheet's back side texels of its own, and every reader
//! of D (probes, the viewer) reads the side it looks at.
//!
//! The scene: a closed 2 m room (albedo 0.5) lit by one small lamp on its floor, facing up; a
//! horizontal 1 × 1 m double-sided sheet (albedo 0.8) at mid-height, its front facing the
//! ceiling, so its back faces the lamp; a closed double-sided box on the floor, whose back
//! faces see only its own inside; a double-sided canvas 1 cm in front of a wall; and a 4 cm
//! double-sided chip above the sheet.

mod common;

use std::path::{Path, PathBuf};

use common::*;
use glam::{Vec2, Vec3};
use glint::eval::probe::{self, ProbePoint};
use glint::eval::reference::{ProbeTraceOptions, trace_probes};
use glint::progress::Silent;
use glint::radiosity::RadiosityMap;
use glint::scene::Scene;

/// `q` wound so that its normal points along `n`.
fn facing(q: [[f32; 3]; 4], n: Vec3) -> [[f32; 3]; 4] {
    let p = q.map(Vec3::from);
    let mut q = q;
    if (p[1] - p[0]).cross(p[2] - p[0]).dot(n) < 0.0 {
        q.reverse();
    }
    q
}

/// The six faces of the box from `lo` to `hi`, facing out.
fn cube(lo: Vec3, hi: Vec3) -> Vec<[[f32; 3]; 4]> {
    let c = 0.5 * (lo + hi);
    let mut faces = Vec::new();
    for axis in 0..3 {
        for at in [lo[axis], hi[axis]] {
            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |s: f32, t: f32| {
                let mut p = Vec3::ZERO;
                p[axis] = at;
                p[a] = if s < 0.0 { lo[a] } else { hi[a] };
                p[b] = if t < 0.0 { lo[b] } else { hi[b] };
                p.to_array()
            };
            let mut n = Vec3::ZERO;
            n[axis] = at - c[axis];
            let q = [
                corner(-1.0, -1.0),
                corner(1.0, -1.0),
                corner(1.0, 1.0),
                corner(-1.0, 1.0),
            ];
            faces.push(facing(q, n));
        }
    }
    faces
}

/// A near-perfect mirror (as in tests/transport.rs).
const MIRROR: &str = r#"{ "albedo": [0, 0, 0], "lobes": [{ "model": "kurt", "ks": [1, 1, 1], "r0": 1.0, "mx": 0.001, "my": 0.001, "alpha": 0.5 }] }"#;

/// Writes the scene (see the module comment) into `dir`, its floor a planar mirror when
/// `mirror`; returns it loaded.
fn sheet_room(dir: &Path, mirror: bool) -> Scene {
    let mut meshes = Vec::new();
    let names = ["X0", "X1", "Y0", "Y1", "Z0", "Z1"];
    for axis in 0..3 {
        let m = if axis == 1 && mirror { 4 } else { 0 };
        meshes.push(quad(names[2 * axis], m, axis, -1.0, 1.0));
        meshes.push(flip(quad(names[2 * axis + 1], 0, axis, 1.0, 1.0)));
    }
    meshes.push(quad("Sheet", 1, 1, 0.0, 0.5));
    // A canvas 1 cm in front of the −X wall: its back sees only the wall across that gap.
    meshes.push(quad("Canvas", 1, 0, -0.99, 0.3));
    // A 4 cm chip above the sheet: open below, but under 2% of the room's size.
    meshes.push(quad("Chip", 1, 1, 0.6, 0.02));
    meshes.push(quad("Lamp", 2, 1, -0.98, 0.1));
    meshes.push(quads(
        "Block",
        3,
        &cube(Vec3::new(0.5, -1.0, 0.5), Vec3::new(0.8, -0.7, 0.8)),
    ));
    let gltf = write_gltf(
        dir,
        "room",
        &meshes,
        &[
            MaterialSpec::diffuse("Walls", 0.5),
            MaterialSpec::diffuse("SheetMat", 0.8),
            MaterialSpec::emitter("LampMat", [1.0; 3], 50.0),
            MaterialSpec::diffuse("BlockMat", 0.6),
            MaterialSpec::diffuse("MirrorMat", 0.0),
        ],
    );
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&gltf).unwrap()).unwrap();
    for m in [1, 3] {
        doc["materials"][m]["doubleSided"] = true.into();
    }
    std::fs::write(&gltf, serde_json::to_string_pretty(&doc).unwrap()).unwrap();
    let json = if mirror {
        format!(
            r#"{{ "version": 1, "name": "sheet-room", "geometry": "room.gltf", "materials": {{ "MirrorMat": {MIRROR} }}, "reflectors": [{{ "mesh": "Y0", "kind": "planar" }}] }}"#
        )
    } else {
        r#"{ "version": 1, "name": "sheet-room", "geometry": "room.gltf" }"#.to_string()
    };
    Scene::load(write_scene(dir, &json)).unwrap_or_else(|e| panic!("{e}"))
}

/// The radiosity settings of these tests: 8 texels a metre, 256 rays and 16 emitter samples
/// an element.
fn settings() -> glint::scene::desc::RadiositySettings {
    glint::scene::desc::RadiositySettings {
        rays: 256,
        light_samples: 16,
        ..quick_radiosity(16)
    }
}

/// Bakes the scene and radiosity stages of `scene` into `dir/sheet.glint`.
fn bake(scene: &Scene, dir: &Path) -> PathBuf {
    use glint::bake::{radiosity_stage, scene_stage};
    let bundle = dir.join("sheet.glint");
    scene_stage::bake(scene, &bundle, false).unwrap_or_else(|e| panic!("{e}"));
    radiosity_stage::bake(scene, &bundle, &settings(), false, &Silent)
        .unwrap_or_else(|e| panic!("{e}"));
    bundle
}

fn triangles_of(scene: &Scene, mesh: &str) -> Vec<u32> {
    (0..scene.triangles.len() as u32)
        .filter(|&t| scene.objects[scene.triangles[t as usize].object as usize].is_named(mesh))
        .collect()
}

fn map_of(bundle: &Path) -> RadiosityMap {
    let b = glint::bundle::Bundle::open(bundle).unwrap();
    RadiosityMap::load(&b).unwrap().unwrap()
}

#[test]
fn a_sheet_open_to_the_room_is_lit_on_each_side_by_what_that_side_sees() {
    let dir = tempfile::tempdir().unwrap();
    let scene = sheet_room(dir.path(), false);
    let map = map_of(&bake(&scene, dir.path()));
    // Only the open sheet's back gets texels of its own: not the closed box's, not the
    // canvas's (whose back sees the wall 1 cm away), not the chip's (too small to matter), not
    // the single-sided walls'.
    let sheet = triangles_of(&scene, "Sheet");
    assert_eq!(sheet.len(), 2);
    assert_eq!(map.atlas.backs, sheet);
    assert_eq!(
        map.atlas.tri_page.len(),
        scene.triangles.len() + sheet.len()
    );

    // Probes on both sides of the sheet, against the path tracer.
    let mut points = Vec::new();
    for (x, z) in [(-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)] {
        for (side, ny) in [("under", -1.0), ("over", 1.0)] {
            points.push(ProbePoint {
                name: Some(format!("{side} {x} {z}")),
                position: [x, 0.0, z],
                normal: [0.0, ny, 0.0],
            });
        }
    }
    let bvh = scene.build_bvh();
    let d = probe::probe(&scene, &bvh, &map, &points, 0.01).unwrap();
    let opts = ProbeTraceOptions {
        paths: 4096,
        ..Default::default()
    };
    let truth = trace_probes(&scene, &bvh, &points, 0.01, &opts, &Silent).unwrap();
    for (v, t) in d.iter().zip(&truth) {
        let name = v.name.as_deref().unwrap();
        assert!(v.found && t.found, "{name}: no surface found");
        assert!(sheet.contains(&v.triangle.unwrap()), "{name}: {v:?}");
        eprintln!(
            "{name}: D {:.4}, path tracer {:.4}",
            v.radiance[1], t.radiance[1]
        );
    }
    let mean = |vs: &[glint::eval::probe::ProbeValue], side: &str| {
        let on: Vec<f64> = vs
            .iter()
            .filter(|v| v.name.as_deref().unwrap().starts_with(side))
            .map(|v| v.radiance[1] as f64)
            .collect();
        on.iter().sum::<f64>() / on.len() as f64
    };
    let (under, over) = (mean(&d, "under"), mean(&d, "over"));
    let (t_under, t_over) = (mean(&truth, "under"), mean(&truth, "over"));
    eprintln!("under: D {under:.4} truth {t_under:.4}; over: D {over:.4} truth {t_over:.4}");
    // The side facing the lamp is several times brighter than the side facing the ceiling,
    // and each side's D is the path tracer's.
    assert!(t_under > 3.0 * t_over, "{t_under} vs {t_over}");
    for (side, got, want) in [("under", under, t_under), ("over", over, t_over)] {
        assert!(
            (got / want - 1.0).abs() < 0.08,
            "{side}: D {got:.4}, path tracer {want:.4}"
        );
    }
}

#[test]
fn open_backs_are_the_same_whatever_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let scene = sheet_room(dir.path(), false);
    let bvh = scene.build_bvh();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| glint::radiosity::back_sides::open_backs(&scene, &bvh));
    let many = glint::radiosity::back_sides::open_backs(&scene, &bvh);
    assert_eq!(one, many);
    assert_eq!(one, triangles_of(&scene, "Sheet"));
}

/// Over the pixels where `shows(x, y)` names a sheet hit and the side seen, and where the four
/// neighbours' do too (no edges): the means of the frame's luminance, of the seen side's
/// bicubic D and of the other side's, the pixel count and how many saw the back.
#[cfg(feature = "view")]
fn side_means(
    data: &glint::view::load::ViewData,
    frame: &[Vec3],
    size: (u32, u32),
    shows: impl Fn(i32, i32) -> Option<(glint::geometry::Hit, bool)>,
) -> (f64, f64, f64, usize, usize) {
    use glint::view::cpu::bicubic;
    let (mut got, mut seen, mut other, mut n, mut backs) = (0.0f64, 0.0f64, 0.0f64, 0, 0);
    for y in 1..size.1 as i32 - 1 {
        for x in 1..size.0 as i32 - 1 {
            let Some((h, back)) = shows(x, y) else {
                continue;
            };
            if [(1, 0), (-1, 0), (0, 1), (0, -1)]
                .iter()
                .any(|(dx, dy)| shows(x + dx, y + dy).is_none())
            {
                continue;
            }
            let (t, b) = data.map.atlas.side(h.triangle, h.bary, back);
            let (u, c) = data.map.atlas.side(h.triangle, h.bary, !back);
            assert_ne!(t, u, "the sheet has two sides in the atlas");
            got += frame[(y as u32 * size.0 + x as u32) as usize].y as f64;
            seen += bicubic::radiance(&data.map, t, b).y as f64;
            other += bicubic::radiance(&data.map, u, c).y as f64;
            n += 1;
            backs += back as usize;
        }
    }
    let m = n.max(1) as f64;
    (got / m, seen / m, other / m, n, backs)
}

/// The viewer reads each side's D: seen from under the sheet, its pixels show the back side's
/// texels (lit by the lamp), from above the front's.
#[cfg(feature = "view")]
#[test]
fn the_viewer_shows_each_side_of_a_sheet_its_own_light() {
    use glint::camera::Camera;
    use glint::view::reflections::ReflectionMode;
    let dir = tempfile::tempdir().unwrap();
    let scene = sheet_room(dir.path(), false);
    let bundle = bake(&scene, dir.path());
    let data = glint::view::load::load(&bundle).unwrap_or_else(|e| panic!("{e}"));
    let bvh = data.scene.build_bvh();
    let sheet = triangles_of(&data.scene, "Sheet");
    const SIZE: (u32, u32) = (96, 72);
    for (eye, from_below) in [
        (Vec3::new(0.1, -0.6, 0.9), true),
        (Vec3::new(0.1, 0.6, 0.9), false),
    ] {
        let camera = Camera::look_at(eye, Vec3::ZERO, Vec3::Y, 60f32.to_radians());
        let frame = &hdr_frames(&data, &camera, SIZE, &[ReflectionMode::Off])[0];
        let aspect = SIZE.0 as f32 / SIZE.1 as f32;
        let on_sheet = |x: i32, y: i32| {
            let ndc = Camera::pixel_ndc(x as u32, y as u32, SIZE.0, SIZE.1);
            bvh.closest_hit(eye, camera.ray_direction(ndc, aspect), f32::INFINITY)
                .filter(|h| sheet.contains(&h.triangle))
                .map(|h| (h, from_below))
        };
        let (got, seen, other, n, _) = side_means(&data, frame, SIZE, on_sheet);
        assert!(n > 200, "{n} sheet pixels");
        eprintln!(
            "from {}: frame {got:.4}, this side's D {seen:.4}, the other side's {other:.4}",
            if from_below { "below" } else { "above" }
        );
        assert!((got / seen - 1.0).abs() < 0.02, "{got} vs {seen}");
        // The two sides differ enough that reading the wrong one would fail.
        let ratio = if from_below {
            seen / other
        } else {
            other / seen
        };
        assert!(ratio > 3.0, "under / over = {ratio}");
    }
}

#[test]
fn a_twin_is_read_with_swapped_barycentrics() {
    let dir = tempfile::tempdir().unwrap();
    let scene = sheet_room(dir.path(), false);
    let map = map_of(&bake(&scene, dir.path()));
    let t = map.atlas.backs[0];
    let twin = map.atlas.back_of(t).unwrap();
    assert_eq!(twin as usize, scene.triangles.len());
    let b = Vec2::new(0.2, 0.3);
    assert_eq!(map.atlas.side(t, b, true), (twin, Vec2::new(0.3, 0.2)));
    assert_eq!(map.atlas.side(t, b, false), (t, b));
    // A triangle without a back side of its own reads its front from behind.
    assert_eq!(map.atlas.side(0, b, true), (0, b));
}

/// An environment map (a curved reflector's, a probe's) captured under the sheet shows its
/// lit underside: the capture's rays meet the sheet's back and read its back side's texels,
/// through the bake's own shading of D.
#[test]
fn an_environment_map_under_a_sheet_shows_its_underside() {
    use glint::bake::materials::shade_with_d;
    use glint::materials::envmap::{
        CaptureSettings, ENV_GLOSSY_SAMPLES, MAX_MIRROR_BOUNCES, capture_recorded, face_direction,
    };
    let dir = tempfile::tempdir().unwrap();
    let scene = sheet_room(dir.path(), false);
    let bundle = bake(&scene, dir.path());
    let map = map_of(&bundle);
    let shading = shade_with_d(&bundle, &scene).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(shading.sides.backs, map.atlas.backs);
    let d = |t: u32, b: Vec2| {
        (shading.shade)(&glint::geometry::Hit {
            t: 0.0,
            triangle: t,
            bary: b,
        })
    };
    let bvh = scene.build_bvh();
    let settings = CaptureSettings {
        face_size: 16,
        supersample: 1,
        mirror_bounces: MAX_MIRROR_BOUNCES,
        glossy_samples: ENV_GLOSSY_SAMPLES,
    };
    let centre = Vec3::new(0.1, -0.4, -0.1);
    let captured = capture_recorded(
        &scene,
        &bvh,
        centre,
        &settings,
        &[],
        (&shading.sides, &d),
        None,
        &Silent,
    )
    .unwrap();
    let sheet = triangles_of(&scene, "Sheet");
    // The +Y face's middle texels: each ray meets the sheet from below.
    let (size, face) = (settings.face_size, 2);
    let (mut got, mut under, mut top, mut n) = (0.0, 0.0, 0.0, 0);
    for y in size / 4..3 * size / 4 {
        for x in size / 4..3 * size / 4 {
            let st = |i: usize| 2.0 * (i as f32 + 0.5) / size as f32 - 1.0;
            let dir = face_direction(face, st(x), st(y)).normalize();
            let h = bvh.closest_hit(centre, dir, f32::INFINITY).unwrap();
            assert!(
                sheet.contains(&h.triangle),
                "texel ({x}, {y}) sees the sheet"
            );
            let (twin, b) = map.atlas.side(h.triangle, h.bary, true);
            under += map.radiance(twin, b).element_sum() / 3.0;
            top += map.radiance(h.triangle, h.bary).element_sum() / 3.0;
            got += captured.cube.texels[(face * size + y) * size + x].element_sum() / 3.0;
            n += 1;
        }
    }
    let (got, under, top) = (got / n as f32, under / n as f32, top / n as f32);
    eprintln!(
        "environment map under the sheet: {got:.4}, the underside's D {under:.4}, the top's {top:.4}"
    );
    assert!((got / under - 1.0).abs() < 0.1, "{got} vs {under}");
    assert!(under > 3.0 * top, "{under} vs {top}");
}

/// The exported glTF writes a sheet with a back side as two one-sided layers, each with its
/// own lightmap place, so an engine shows each side its own light; a double-sided surface
/// without one (the canvas) stays one double-sided layer.
#[test]
fn export_writes_a_sheet_with_a_back_side_as_two_one_sided_layers() {
    use glint::export::lightmap::LightmapFormat;
    use glint::export::{ExportOptions, export};
    let dir = tempfile::tempdir().unwrap();
    let scene = sheet_room(dir.path(), false);
    let bundle = bake(&scene, dir.path());
    let glb = dir.path().join("sheet.glb");
    let opts = ExportOptions {
        max_page: 0,
        format: LightmapFormat::Rgbd,
    };
    export(&bundle, &glb, &opts).unwrap_or_else(|e| panic!("{e}"));
    let bytes = std::fs::read(&glb).unwrap();
    let json: serde_json::Value =
        serde_json::from_slice(&gltf::Glb::from_slice(&bytes).unwrap().json).unwrap();
    // Per mesh: (material name, doubleSided, index count) of each primitive.
    let prims = |mesh: &str| -> Vec<(String, bool, u64)> {
        let m = json["meshes"]
            .as_array()
            .unwrap()
            .iter()
            .find(|m| m["name"] == mesh)
            .unwrap_or_else(|| panic!("no mesh {mesh}"));
        m["primitives"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| {
                let mat = &json["materials"][p["material"].as_u64().unwrap() as usize];
                let count = json["accessors"][p["indices"].as_u64().unwrap() as usize]["count"]
                    .as_u64()
                    .unwrap();
                let name = mat["name"].as_str().unwrap_or("").to_string();
                (name, mat["doubleSided"] == true, count)
            })
            .collect()
    };
    let sheet = prims("Sheet");
    let layers: u64 = sheet.iter().map(|p| p.2).sum();
    assert_eq!(
        layers,
        2 * 3 * 2,
        "{sheet:?}: two triangles, each front and back"
    );
    assert!(
        sheet
            .iter()
            .all(|(name, double, _)| !double && name.ends_with("(one side)")),
        "{sheet:?}"
    );
    let canvas = prims("Canvas");
    assert!(
        canvas.iter().all(|(_, double, n)| *double && *n == 6),
        "{canvas:?}"
    );
}

/// An impostor's colour from D is the side its capture ray meets.
#[test]
fn an_impostor_reads_the_side_its_ray_meets() {
    use glint::srdm::capture::ColourSource;
    let dir = tempfile::tempdir().unwrap();
    let scene = sheet_room(dir.path(), false);
    let bundle = bake(&scene, dir.path());
    let map = map_of(&bundle);
    let t = triangles_of(&scene, "Sheet")[0];
    let bary = Vec2::new(0.3, 0.2);
    let (twin, swapped) = map.atlas.side(t, bary, true);
    let (under, top) = (map.radiance(twin, swapped), map.radiance(t, bary));
    let colour = ColourSource::Radiosity(Box::new(map));
    assert_eq!(colour.colour(&scene, t, bary, true), under);
    assert_eq!(colour.colour(&scene, t, bary, false), top);
    assert!(
        under.element_sum() > 3.0 * top.element_sum(),
        "{under} vs {top}"
    );
}

/// A mirror shows the side of the sheet its mirrored eye sees: from a camera above the sheet,
/// the mirror floor reflects the sheet's underside, lit by the lamp, in both modes (geometry
/// mode draws the scene mirrored, its eye mirrored below the floor; image mode shows the
/// radiance maps, whose rays meet the sheet's back and read its back side's texels).
#[cfg(feature = "view")]
#[test]
fn a_mirror_shows_the_side_of_a_sheet_its_mirrored_eye_sees() {
    use glint::camera::Camera;
    use glint::view::reflections::ReflectionMode;
    let dir = tempfile::tempdir().unwrap();
    let scene = sheet_room(dir.path(), true);
    let bundle = dir.path().join("mirror.glint");
    bake_with_materials(&scene, &bundle, &settings());
    let draft = glint::scene::desc::Quality::Draft;
    glint::bake::radiance_stage::bake(&scene, &bundle, draft, false, &Silent)
        .unwrap_or_else(|e| panic!("{e}"));
    let data = glint::view::load::load(&bundle).unwrap_or_else(|e| panic!("{e}"));
    let bvh = data.scene.build_bvh();
    let (sheet, mirror) = (
        triangles_of(&data.scene, "Sheet"),
        triangles_of(&data.scene, "Y0"),
    );
    const SIZE: (u32, u32) = (96, 72);
    // The real eye is above the sheet, the mirrored one below it.
    let eye = Vec3::new(0.0, 0.5, 0.95);
    let camera = Camera::look_at(eye, Vec3::new(0.0, -1.0, 0.4), Vec3::Y, 70f32.to_radians());
    let modes = [ReflectionMode::Geometry, ReflectionMode::Image];
    let frames = hdr_frames(&data, &camera, SIZE, &modes);
    let aspect = SIZE.0 as f32 / SIZE.1 as f32;
    // What a pixel's ray shows in the mirror: the sheet's triangle, barycentrics and side.
    let in_mirror = |x: i32, y: i32| {
        let ndc = Camera::pixel_ndc(x as u32, y as u32, SIZE.0, SIZE.1);
        let d = camera.ray_direction(ndc, aspect);
        let h = bvh
            .closest_hit(eye, d, f32::INFINITY)
            .filter(|h| mirror.contains(&h.triangle))?;
        let r = Vec3::new(d.x, -d.y, d.z);
        let p = eye + d * h.t + Vec3::Y * 1e-4;
        let s = bvh
            .closest_hit(p, r, f32::INFINITY)
            .filter(|s| sheet.contains(&s.triangle))?;
        let back = r.dot(data.scene.triangles[s.triangle as usize].face_normal()) > 0.0;
        Some((s, back))
    };
    for (mode, frame) in modes.iter().zip(&frames) {
        let (got, seen, other, n, backs) = side_means(&data, frame, SIZE, in_mirror);
        assert!(n > 100, "{n} pixels see the sheet in the mirror");
        assert_eq!(backs, n, "the mirrored eye sees the sheet's underside");
        eprintln!(
            "in the mirror ({mode:?}): frame {got:.4}, the underside's D {seen:.4}, the top's {other:.4}"
        );
        assert!((got / seen - 1.0).abs() < 0.1, "{mode:?}: {got} vs {seen}");
        assert!(seen > 3.0 * other, "{seen} vs {other}");
    }
}
