//! Reflection probes at bake time: where the bake places them on the shipped scenes, what
//! scene.json's `probes` changes, the errors it gets for bad ones, and the probe work units.

mod common;

use std::path::{Path, PathBuf};

use common::*;
use glint::bake::BakeSettings;
use glint::bake::units::plan_units;
use glint::materials::probes::{assign, scene_groups, scene_probes};
use glint::scene::Scene;
use glint::scene::desc::Quality;

/// A copy of shipped scene `name` in `dir` with its scene.json edited by `edit`.
fn edited(dir: &Path, name: &str, edit: impl FnOnce(&mut serde_json::Value)) -> PathBuf {
    let to = dir.join(name);
    copy_dir(&repo(&format!("scenes/{name}")), &to);
    let path = to.join("scene.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    edit(&mut v);
    std::fs::write(&path, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    path
}

fn load(path: &Path) -> Scene {
    Scene::load(path).unwrap_or_else(|e| panic!("{e}"))
}

/// glossy-room with its glossy table top left undeclared (no `TableTop` reflector): the
/// scene of a user who declares only the floor, the mirror and the teapot.
fn undeclared_table(dir: &Path, edit: impl FnOnce(&mut serde_json::Value)) -> PathBuf {
    edited(dir, "glossy-room", |v| {
        let reflectors = v["reflectors"].as_array_mut().unwrap();
        reflectors.retain(|r| r["mesh"] != "TableTop");
        edit(v);
    })
}

#[test]
fn an_undeclared_glossy_table_gets_one_probe_above_it() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(&undeclared_table(dir.path(), |_| {}));
    let groups = scene_groups(&scene);
    let names: Vec<&str> = groups
        .iter()
        .map(|g| scene.materials[g.material as usize].name.as_str())
        .collect();
    assert_eq!(names, ["GlossyTable"]);
    let probes = scene_probes(&scene);
    assert_eq!(probes.len(), 1);
    let p = &probes[0];
    assert_eq!(p.name, "GlossyTable");
    // Above the table top (its normal is +y), over its centre, within reach of it.
    let b = &groups[0].bounds;
    assert!(p.position.y > b.max.y + 0.05, "{}", p.position);
    assert!((p.position.x - b.center().x).abs() < 1e-4);
    assert!((p.position.z - b.center().z).abs() < 1e-4);
    // Clear of the teapot standing on the table (it would see the teapot's inside).
    let teapot = scene
        .reflectors
        .iter()
        .find(|r| r.name == "Teapot")
        .unwrap();
    assert!(
        p.position.y > teapot.bounds.max.y,
        "{} inside the teapot",
        p.position
    );
    assert!(scene.bounds.min.cmple(p.position).all() && p.position.cmple(scene.bounds.max).all());
    assert!(p.position.distance(b.center()) <= p.radius);
    assert_eq!(assign(&probes, &groups, 0), Some(0));
}

#[test]
fn scenes_without_undeclared_glossy_surfaces_get_no_probes() {
    // Shipped glossy-room declares every glossy surface; cornell-box has none.
    assert!(scene_probes(&load(&repo("scenes/glossy-room/scene.json"))).is_empty());
    assert!(scene_probes(&load(&repo("scenes/cornell-box/scene.json"))).is_empty());
    let dir = tempfile::tempdir().unwrap();
    // Without the table's lobe nothing undeclared is glossy, and a probe asked for is moot.
    let path = undeclared_table(dir.path(), |v| {
        v["materials"]["GlossyTable"]["lobes"] = serde_json::json!([]);
        v["probes"] = serde_json::json!([{ "name": "extra", "position": [0.0, 1.5, 0.0] }]);
    });
    let scene = load(&path);
    assert!(scene_groups(&scene).is_empty());
    assert!(scene_probes(&scene).is_empty());
}

#[test]
fn scene_json_moves_and_adds_probes() {
    let dir = tempfile::tempdir().unwrap();
    let path = undeclared_table(dir.path(), |v| {
        v["probes"] = serde_json::json!([
            { "name": "GlossyTable", "position": [0.1, 1.6, -0.2] },
            { "name": "corner", "position": [2.5, 1.0, 2.0], "radius": 0.5 }
        ]);
    });
    let scene = load(&path);
    let probes = scene_probes(&scene);
    let placed = scene_probes(&load(&undeclared_table(&dir.path().join("b"), |_| {})));
    assert_eq!(probes.len(), 2);
    assert_eq!(probes[0].name, "GlossyTable");
    assert_eq!(probes[0].position.to_array(), [0.1, 1.6, -0.2]);
    // Moved without a radius: the placed reach is kept.
    assert_eq!(probes[0].radius, placed[0].radius);
    assert_eq!((probes[1].name.as_str(), probes[1].radius), ("corner", 0.5));
    // The table still reads its own probe: the added one does not reach it.
    assert_eq!(assign(&probes, &scene_groups(&scene), 0), Some(0));

    // Each probe is its own work unit, after the materials' and before the environment maps'.
    let plan = plan_units(
        &scene,
        &BakeSettings::resolve(&scene, Quality::Draft).unwrap(),
    )
    .unwrap();
    let ids: Vec<&str> = plan
        .units
        .iter()
        .filter(|u| u.stage == "materials")
        .map(|u| u.id.as_str())
        .collect();
    let probe_ids: Vec<&str> = ids
        .iter()
        .copied()
        .filter(|id| id.starts_with("probe."))
        .collect();
    assert_eq!(probe_ids, ["probe.GlossyTable", "probe.corner"]);
    let pos = |id: &str| ids.iter().position(|i| *i == id).unwrap();
    assert!(pos("probe.corner") < pos("envmap.Teapot"), "{ids:?}");
    // Moving a probe changes its unit's key alone.
    let before = plan_units(
        &load(&undeclared_table(&dir.path().join("c"), |_| {})),
        &BakeSettings::resolve(&scene, Quality::Draft).unwrap(),
    )
    .unwrap();
    let key = |p: &glint::bake::units::UnitPlan, id: &str| p.unit(id).unwrap().key.clone();
    assert_ne!(
        key(&plan, "probe.GlossyTable"),
        key(&before, "probe.GlossyTable")
    );
    assert_eq!(key(&plan, "envmap.Teapot"), key(&before, "envmap.Teapot"));
}

#[test]
fn breakfast_rooms_sides_that_no_camera_sees_get_no_probe() {
    // The undersides of the saucers and of the rough metal on the table turn their backs to
    // their materials' probes above the table, so each is a side of its own; no camera path
    // sees them (the table top hides them), so neither gets a probe. The skirting's side
    // that faces the room is seen and keeps its own.
    let scene = load(&repo("scenes/breakfast-room/scene.json"));
    let groups = scene_groups(&scene);
    let sides: Vec<&str> = groups
        .iter()
        .filter(|g| g.side)
        .map(|g| g.name.as_str())
        .collect();
    for name in ["Ceramic.2", "RoughMetal.2", "SkirtWood.2"] {
        assert!(sides.contains(&name), "{sides:?}");
    }
    let probes = scene_probes(&scene);
    let names: Vec<&str> = probes.iter().map(|p| p.name.as_str()).collect();
    assert!(names.contains(&"SkirtWood.2"), "{names:?}");
    for name in ["Ceramic.2", "RoughMetal.2"] {
        assert!(!names.contains(&name), "{names:?}");
    }
    assert_eq!(probes.len(), groups.len() - 2, "{names:?}");
    // Each unseen side reads a probe of the rest, none of another group's side.
    for (k, g) in groups.iter().enumerate() {
        let p = &probes[assign(&probes, &groups, k).unwrap()];
        let others_side = groups
            .iter()
            .any(|h| h.side && h.name == p.name && h.name != g.name);
        assert!(!others_side, "{} reads {}", g.name, p.name);
    }
}

#[test]
fn bad_probes_are_rejected_with_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    for (i, (probes, field, says)) in [
        (
            serde_json::json!([{ "name": "a", "position": [0.0, 9.0, 0.0] }]),
            "probes[0].position",
            "outside the scene's bounds",
        ),
        (
            serde_json::json!([
                { "name": "a", "position": [0.0, 1.0, 0.0] },
                { "name": "a", "position": [0.0, 1.2, 0.0] }
            ]),
            "probes[1].name",
            "names two probes",
        ),
        (
            serde_json::json!([{ "name": "a", "position": [0.0, 1.0, 0.0], "radius": -1.0 }]),
            "probes[0].radius",
            "not a finite number > 0",
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let sub = dir.path().join(i.to_string());
        let path = edited(&sub, "glossy-room", |v| v["probes"] = probes);
        let e = Scene::load(&path).unwrap_err().to_string();
        assert!(
            e.contains(&path.display().to_string())
                && e.contains(&format!("field `{field}`"))
                && e.contains(says),
            "{e}"
        );
    }
    // Unknown keys and missing fields are serde's errors, with the file and line.
    let path = edited(&dir.path().join("x"), "glossy-room", |v| {
        v["probes"] = serde_json::json!([{ "name": "a", "where": [0.0, 1.0, 0.0] }])
    });
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(
        e.contains(&path.display().to_string()) && e.contains("where"),
        "{e}"
    );
}

/// A cube's texels as bits: equal only when byte for byte the same.
fn bits(cube: &glint::materials::envmap::CubeMap) -> Vec<u32> {
    cube.texels
        .iter()
        .flat_map(|t| t.to_array().map(f32::to_bits))
        .collect()
}

#[test]
fn a_probe_evaluated_from_its_records_is_the_probe_captured() {
    use glam::{Vec2, Vec3};
    use glint::materials::envmap::{
        CaptureSettings, ENV_GLOSSY_SAMPLES, MAX_MIRROR_BOUNCES, capture_cube, capture_recorded,
    };
    use glint::progress::Silent;
    use glint::radiance::reads::Replay;

    // stand-in, with an area light under its ceiling: its probes' rays meet the light, the
    // mirror floor, the glass and the glossy tiles.
    let dir = tempfile::tempdir().unwrap();
    let b = load(&repo("scenes/stand-in/scene.json")).bounds;
    let (c, top) = (b.center(), b.max.y - 0.05);
    let light = serde_json::json!([{ "name": "lamp", "corner": [c.x - 0.3, top, c.z - 0.3],
        "edge_u": [0.6, 0.0, 0.0], "edge_v": [0.0, 0.0, 0.6], "radiance": [4.0, 4.0, 4.0] }]);
    let path = edited(dir.path(), "stand-in", |v| v["lights"] = light.clone());
    let scene = load(&path);
    assert!(!scene.lights.is_empty());
    let rougher = load(&edited(&dir.path().join("b"), "stand-in", |v| {
        v["lights"] = light.clone();
        v["materials"]["Tiles"] = serde_json::json!({ "lobes": [{ "ks": [1.0, 1.0, 1.0],
            "r0": 0.04, "mx": 0.16, "my": 0.16 }] });
    }));
    let tiles = material_id(&scene, "Tiles") as usize;
    let settings = CaptureSettings {
        face_size: 8,
        supersample: 2,
        mirror_bounces: MAX_MIRROR_BOUNCES,
        glossy_samples: ENV_GLOSSY_SAMPLES,
    };
    let texels = 6 * 8 * 8;
    // D of a made-up bake, and D after an albedo edit.
    let d = |t: u32, b: Vec2| Vec3::new(0.1 + (t % 7) as f32 * 0.05 + b.x, 0.2 + b.y, 0.3);
    let edited_d = |t: u32, b: Vec2| d(t, b) * Vec3::new(1.5, 0.5, 1.0) + 0.01;
    let direct = |scene: &Scene, at: Vec3, d: &(dyn Fn(u32, Vec2) -> Vec3 + Sync)| {
        let shade = |h: &glint::geometry::Hit| d(h.triangle, h.bary);
        let bvh = scene.build_bvh();
        bits(&capture_cube(scene, &bvh, at, &settings, &[], &shade, &Silent).unwrap())
    };
    let recorded = |scene: &Scene, at: Vec3, d: &(dyn Fn(u32, Vec2) -> Vec3 + Sync), replay| {
        let bvh = scene.build_bvh();
        let none = glint::radiosity::sides::Sides::default();
        capture_recorded(scene, &bvh, at, &settings, &[], (&none, d), replay, &Silent).unwrap()
    };
    let unchanged = vec![false; scene.materials.len()];
    let mut changed = unchanged.clone();
    changed[tiles] = true;
    let probes = scene_probes(&scene);
    assert!(probes.len() > 1, "{probes:?}");
    let mut retraced = Vec::new();
    for p in &probes {
        let at = p.position;
        // Recorded, every texel comes from its record: the capture's bytes.
        let first = recorded(&scene, at, &d, None);
        assert_eq!(first.traced, texels as u64);
        assert_eq!(bits(&first.cube), direct(&scene, at, &d), "{}", p.name);
        // D alone changed: no texel traced, the bytes of a capture with the new D.
        let replay = Replay::of(first.reads.clone(), &unchanged);
        let again = recorded(&scene, at, &edited_d, Some(replay));
        assert_eq!(again.traced, 0, "{}", p.name);
        assert_eq!(
            bits(&again.cube),
            direct(&scene, at, &edited_d),
            "{}",
            p.name
        );
        // Tiles' lobe changed too: the texels whose rays met Tiles are traced again, and the
        // cube is the edited scene's.
        let replay = Replay::of(first.reads, &changed);
        let edit = recorded(&rougher, at, &edited_d, Some(replay));
        assert_eq!(
            bits(&edit.cube),
            direct(&rougher, at, &edited_d),
            "{}",
            p.name
        );
        retraced.push(edit.traced);
    }
    // Some probe sees Tiles, none sees only Tiles.
    assert!(retraced.iter().any(|&t| t > 0), "{retraced:?}");
    assert!(retraced.iter().all(|&t| t < texels as u64), "{retraced:?}");
}
