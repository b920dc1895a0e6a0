//! Loading scenes: the happy path and every kind of bad input, each with one clear error
//! naming the file and field.

mod common;

use common::*;
use glam::Vec3;
use glint::scene::{ReflectorKind, Scene, SceneError};

fn room_scene(extra: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    write_room(dir.path());
    let path = write_scene(
        dir.path(),
        &format!(r#"{{ "version": 1, "geometry": "room.gltf"{extra} }}"#),
    );
    (dir, path)
}

fn load_err(extra: &str) -> String {
    let (_dir, path) = room_scene(extra);
    match Scene::load(&path) {
        Ok(_) => panic!("scene with {extra} loaded"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn room_loads_with_materials_reflectors_and_paths() {
    let (_dir, path) = room_scene(
        r#",
        "reflectors": [ { "mesh": "Panel", "kind": "planar" }, { "material": "FloorMat", "kind": "planar" } ],
        "materials": { "FloorMat": { "lobes": [ { "model": "kurt", "ks": [0.5, 0.5, 0.5], "r0": 0.05, "mx": 0.1, "my": 0.1, "alpha": 0 } ] } },
        "camera_paths": [ { "name": "a", "keyframes": [
            { "time": 0, "position": [0, 1, 0.9], "target": [0, 1, 0], "fov_y_deg": 60 },
            { "time": 1, "position": [0.5, 1, 0.9], "target": [0, 1, 0], "fov_y_deg": 60 } ] } ]"#,
    );
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.triangles.len(), 6);
    assert_eq!(scene.objects.len(), 3);
    assert!(scene.has_emitters());
    let light = &scene.materials[scene.triangles[4].material as usize];
    assert_eq!(light.emission, Vec3::splat(10.0));
    let panel = &scene.reflectors[0];
    assert_eq!(
        (panel.name.as_str(), panel.kind),
        ("Panel", ReflectorKind::Planar)
    );
    assert!((panel.plane.unwrap().normal - Vec3::X).length() < 1e-6);
    assert!(scene.materials[panel.material as usize].is_glossy());
    let floor = &scene.reflectors[1];
    assert_eq!(floor.triangles, vec![0, 1]);
    assert!((floor.plane.unwrap().normal - Vec3::Y).length() < 1e-6);
    assert_eq!(scene.materials[floor.material as usize].lobes[0].mx, 0.1);
    assert_eq!(scene.camera_path(None).unwrap().name, "a");
    assert_eq!(scene.content_hash.len(), 64);
}

#[test]
fn content_hash_follows_every_input_file() {
    let (dir, path) = room_scene("");
    let a = Scene::load(&path).unwrap().content_hash;
    assert_eq!(a, Scene::load(&path).unwrap().content_hash);
    // Change one byte of the binary buffer: the hash must change.
    let bin = dir.path().join("room.bin");
    let mut bytes = std::fs::read(&bin).unwrap();
    bytes[0] ^= 1;
    std::fs::write(&bin, bytes).unwrap();
    assert_ne!(a, Scene::load(&path).unwrap().content_hash);
}

#[test]
fn malformed_json_names_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_scene(
        dir.path(),
        "{\n  \"version\": 1,\n  \"geometry\": \"room.gltf\",,\n}",
    );
    let e = Scene::load(&path).unwrap_err();
    assert!(matches!(e, SceneError::Json { line: 3, .. }), "{e:?}");
    assert!(
        e.to_string().starts_with(&format!("{}:3:", path.display())),
        "{e}"
    );
}

#[test]
fn unknown_field_is_an_error_naming_it() {
    let e = load_err(r#", "refletcors": []"#);
    assert!(e.contains("unknown field `refletcors`"), "{e}");
    assert!(e.contains("scene.json"), "{e}");
    let e = load_err(
        r#", "lights": [ { "name": "l", "corner": [0,0,0], "edge_u": [1,0,0], "edge_v": [0,0,1], "radiance": [1,1,1], "colour": 1 } ]"#,
    );
    assert!(e.contains("unknown field `colour`"), "{e}");
}

#[test]
fn wrong_or_missing_version_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    write_room(dir.path());
    let path = write_scene(
        dir.path(),
        r#"{ "version": 2, "geometry": "room.gltf", "new_thing": 1 }"#,
    );
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(
        e.contains("field `version`: found 2") && e.contains("reads scene version 1"),
        "{e}"
    );
    let path = write_scene(dir.path(), r#"{ "geometry": "room.gltf" }"#);
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(e.contains("field `version`: missing"), "{e}");
}

#[test]
fn missing_gltf_or_buffer_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_scene(dir.path(), r#"{ "version": 1, "geometry": "nowhere.glb" }"#);
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(
        e.contains("field `geometry`") && e.contains("nowhere.glb") && e.contains("does not exist"),
        "{e}"
    );

    let (dir, path) = room_scene("");
    std::fs::remove_file(dir.path().join("room.bin")).unwrap();
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(e.contains("room.gltf") && e.contains("room.bin"), "{e}");
}

#[test]
fn reflector_name_matching_nothing_lists_what_exists() {
    let e = load_err(r#", "reflectors": [ { "mesh": "Flor", "kind": "planar" } ]"#);
    assert!(
        e.contains("reflectors[0].mesh") && e.contains("\"Flor\" matches no glTF mesh"),
        "{e}"
    );
    assert!(e.contains("\"Floor\""), "{e}");
    let e = load_err(r#", "reflectors": [ { "material": "Chrome", "kind": "curved" } ]"#);
    assert!(e.contains("reflectors[0].material"), "{e}");
    let e = load_err(r#", "reflectors": [ { "kind": "curved" } ]"#);
    assert!(e.contains("exactly one of `mesh` and `material`"), "{e}");
    let e = load_err(r#", "impostors": [ { "mesh": "Bunny" } ]"#);
    assert!(e.contains("impostors[0].mesh"), "{e}");
    let e = load_err(r#", "materials": { "Gold": { "albedo": [0.5, 0.5, 0.5] } }"#);
    assert!(
        e.contains("materials.Gold") && e.contains("\"FloorMat\""),
        "{e}"
    );
}

/// A reflector whose mesh is there but lost every triangle at load (its node scaled by 0)
/// is told so, not that its name matches nothing.
#[test]
fn reflector_whose_triangles_were_all_dropped_says_so() {
    let dir = tempfile::tempdir().unwrap();
    write_room(dir.path());
    let gltf = dir.path().join("room.gltf");
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&gltf).unwrap()).unwrap();
    let panel = doc["meshes"]
        .as_array()
        .unwrap()
        .iter()
        .position(|m| m["name"] == "Panel")
        .unwrap();
    for node in doc["nodes"].as_array_mut().unwrap() {
        if node["mesh"] == panel {
            node["scale"] = serde_json::json!([0.0, 0.0, 0.0]);
        }
    }
    std::fs::write(&gltf, serde_json::to_string(&doc).unwrap()).unwrap();
    let path = write_scene(
        dir.path(),
        r#"{ "version": 1, "geometry": "room.gltf", "reflectors": [ { "mesh": "Panel", "kind": "planar" } ] }"#,
    );
    let Err(e) = Scene::load(&path).map(|_| ()) else {
        panic!("loaded with all of Panel's triangles dropped");
    };
    let e = e.to_string();
    assert!(
        e.contains("reflectors[0].mesh")
            && e.contains("\"Panel\" matches a glTF mesh or node")
            && e.contains("all its triangles were dropped"),
        "{e}"
    );
    assert!(!e.contains("matches no glTF mesh"), "{e}");
}

#[test]
fn non_planar_planar_reflector_is_refused_at_any_scale() {
    for scale in [1e-3_f32, 1.0, 1e3] {
        let dir = tempfile::tempdir().unwrap();
        let bent = MeshSpec {
            normals: Vec::new(),
            name: "Bent",
            material: 0,
            positions: vec![
                [0.0, 0.0, 0.0],
                [scale, 0.0, 0.0],
                [scale, 0.0, scale],
                [0.0, 0.05 * scale, scale],
            ],
            indices: vec![0, 2, 1, 0, 3, 2],
        };
        let flat = quad("Flat", 0, 1, 0.5 * scale, scale);
        write_gltf(
            dir.path(),
            "bent",
            &[bent, flat],
            &[MaterialSpec::diffuse("m", 0.5)],
        );
        let path = write_scene(
            dir.path(),
            r#"{ "version": 1, "geometry": "bent.gltf", "reflectors": [ { "mesh": "Flat", "kind": "planar" }, { "mesh": "Bent", "kind": "planar" } ] }"#,
        );
        let e = Scene::load(&path).unwrap_err().to_string();
        assert!(
            e.contains("reflectors[1].kind") && e.contains("not planar")
                || e.contains("declared planar"),
            "{e}"
        );
        // Curved is fine, and so is a generous tolerance.
        let path = write_scene(
            dir.path(),
            r#"{ "version": 1, "geometry": "bent.gltf", "reflectors": [ { "mesh": "Bent", "kind": "planar", "planarity_tolerance": 0.1 } ] }"#,
        );
        Scene::load(&path).unwrap();
    }
}

#[test]
fn non_finite_triangles_are_dropped_and_an_empty_scene_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let mut bad = quad("Bad", 0, 1, 0.0, 1.0);
    bad.positions[0] = [f32::NAN, 0.0, 0.0];
    bad.positions[2] = [0.0, f32::INFINITY, 0.0];
    let good = quad("Good", 0, 1, 1.0, 1.0);
    write_gltf(
        dir.path(),
        "nan",
        &[bad, good],
        &[MaterialSpec::diffuse("m", 0.5)],
    );
    let path = write_scene(dir.path(), r#"{ "version": 1, "geometry": "nan.gltf" }"#);
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.triangles.len(), 2);
    assert_eq!(scene.dropped_triangles, 2);

    let dir = tempfile::tempdir().unwrap();
    let mut bad = quad("Bad", 0, 1, 0.0, 1.0);
    bad.positions[0] = [f32::NAN, 0.0, 0.0];
    bad.positions[2] = [0.0, f32::INFINITY, 0.0];
    write_gltf(
        dir.path(),
        "nan",
        &[bad],
        &[MaterialSpec::diffuse("m", 0.5)],
    );
    let path = write_scene(dir.path(), r#"{ "version": 1, "geometry": "nan.gltf" }"#);
    let e = Scene::load(&path).unwrap_err();
    assert!(matches!(e, SceneError::Empty { dropped: 2, .. }), "{e:?}");
    assert!(
        e.to_string().contains("nan.gltf") && e.to_string().contains("no valid triangles"),
        "{e}"
    );
}

#[test]
fn bad_values_name_their_field() {
    let e = load_err(r#", "materials": { "FloorMat": { "albedo": [1.0, 0.5, 0.5] } }"#);
    assert!(
        e.contains("materials.FloorMat.albedo") && e.contains("cannot converge"),
        "{e}"
    );
    let e = load_err(
        r#", "materials": { "FloorMat": { "lobes": [ { "model": "kurt", "ks": [1,1,1], "r0": 0.04, "mx": 0, "my": 0.1, "alpha": 0 } ] } }"#,
    );
    assert!(e.contains("materials.FloorMat.lobes"), "{e}");
    // Values in words, not Rust's Debug output of the lobe.
    assert!(
        e.contains("lobe 0 (model kurt, ks [1, 1, 1], r0 0.04, mx 0, my 0.1, alpha 0)")
            && !e.contains("KurtLobe")
            && !e.contains('{'),
        "{e}"
    );
    let e = load_err(
        r#", "lights": [ { "name": "l", "corner": [0,0,0], "edge_u": [1,0,0], "edge_v": [2,0,0], "radiance": [1,1,1] } ]"#,
    );
    assert!(e.contains("lights[0]") && e.contains("no area"), "{e}");
    let e = load_err(
        r#", "camera_paths": [ { "name": "p", "keyframes": [ { "time": 0, "position": [0,1,0], "target": [0,1,-1], "fov_y_deg": 180 } ] } ]"#,
    );
    assert!(e.contains("camera_paths[0].keyframes[0].fov_y_deg"), "{e}");
    let e = load_err(
        r#", "camera_paths": [ { "name": "p", "keyframes": [ { "time": 0, "position": [0,1,0], "target": [0,2,0], "fov_y_deg": 60 } ] } ]"#,
    );
    assert!(e.contains("keyframes[0].up"), "{e}");
    let e = load_err(
        r#", "camera_paths": [ { "name": "p", "keyframes": [
        { "time": 1, "position": [0,1,0], "target": [0,1,-1], "fov_y_deg": 60 },
        { "time": 1, "position": [0,1,0], "target": [0,1,-1], "fov_y_deg": 60 } ] } ]"#,
    );
    assert!(e.contains("keyframes[1].time"), "{e}");
}

#[test]
fn lobes_name_their_model_and_a_bad_model_is_refused_naming_the_choices() {
    let (_dir, path) = room_scene(
        r#", "materials": { "FloorMat": { "lobes": [ { "model": "ggx", "ks": [1,1,1], "r0": 0.04, "mx": 0.09, "my": 0.09 } ] } }"#,
    );
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let m = scene
        .materials
        .iter()
        .find(|m| m.name == "FloorMat")
        .unwrap();
    assert_eq!(m.lobes[0].model, glint::scene::LobeModel::Ggx);
    assert_eq!(m.lobes[0].alpha, None);
    let e = load_err(
        r#", "materials": { "FloorMat": { "lobes": [ { "model": "phong", "ks": [1,1,1], "r0": 0.04, "mx": 0.1, "my": 0.1 } ] } }"#,
    );
    assert!(
        e.contains("scene.json")
            && e.contains("lobe `model` \"phong\" is unknown")
            && e.contains("kurt")
            && e.contains("ggx")
            && e.contains("beckmann"),
        "{e}"
    );
    let e = load_err(
        r#", "materials": { "FloorMat": { "lobes": [ { "model": "beckmann", "ks": [1,1,1], "r0": 0.04, "mx": 0.1, "my": 0.1, "alpha": 0.5 } ] } }"#,
    );
    assert!(
        e.contains("materials.FloorMat.lobes") && e.contains("remove alpha"),
        "{e}"
    );
    let e = load_err(
        r#", "materials": { "FloorMat": { "lobes": [ { "model": "kurt", "ks": [1,1,1], "r0": 0.04, "mx": 0.1, "my": 0.1 } ] } }"#,
    );
    assert!(e.contains("needs `alpha`"), "{e}");
}

#[test]
fn a_lobe_without_model_is_ggx_and_kurt_is_named_when_wanted() {
    let (_dir, path) = room_scene(
        r#", "materials": { "FloorMat": { "lobes": [ { "ks": [1,1,1], "r0": 0.04, "mx": 0.09, "my": 0.09 } ] } }"#,
    );
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let m = scene
        .materials
        .iter()
        .find(|m| m.name == "FloorMat")
        .unwrap();
    assert_eq!(m.lobes[0].model, glint::scene::LobeModel::Ggx);
    // Written back, the default is left out and `kurt` is named.
    let ggx = serde_json::to_value(m.lobes[0]).unwrap();
    assert!(ggx.get("model").is_none(), "{ggx}");
    let mut kurt = m.lobes[0];
    kurt.model = glint::scene::LobeModel::Kurt;
    assert_eq!(serde_json::to_value(kurt).unwrap()["model"], "kurt");
    // A lobe with `alpha` and no `model`, as scene.json files and bundles written while
    // `kurt` was the default have it, stays `kurt`.
    let (_dir, path) = room_scene(
        r#", "materials": { "FloorMat": { "lobes": [ { "ks": [1,1,1], "r0": 0.04, "mx": 0.1, "my": 0.1, "alpha": 0 } ] } }"#,
    );
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let m = scene
        .materials
        .iter()
        .find(|m| m.name == "FloorMat")
        .unwrap();
    assert_eq!(m.lobes[0].model, glint::scene::LobeModel::Kurt);
    // `alpha` on a lobe that names another model is refused, saying how to keep kurt.
    let e = load_err(
        r#", "materials": { "FloorMat": { "lobes": [ { "model": "ggx", "ks": [1,1,1], "r0": 0.04, "mx": 0.1, "my": 0.1, "alpha": 0 } ] } }"#,
    );
    assert!(
        e.contains("materials.FloorMat.lobes")
            && e.contains("model ggx")
            && e.contains(r#"name "model": "kurt""#),
        "{e}"
    );
}

#[test]
fn glb_with_default_material_and_white_albedo_loads() {
    // A base colour of 1 is common in glTF; it is clamped below 1 with a warning, not refused.
    let dir = tempfile::tempdir().unwrap();
    write_gltf(
        dir.path(),
        "white",
        &[quad("Q", 0, 1, 0.0, 1.0)],
        &[MaterialSpec::diffuse("white", 1.0)],
    );
    let path = write_scene(dir.path(), r#"{ "version": 1, "geometry": "white.gltf" }"#);
    let scene = Scene::load(&path).unwrap();
    assert!(scene.materials[0].albedo.max_element() < 1.0);
    assert!(!scene.has_emitters());
}

#[test]
fn duplicate_reflectors_and_impostors_are_refused() {
    let e = load_err(
        r#", "reflectors": [ { "mesh": "Panel", "kind": "planar" }, { "material": "PanelMat", "kind": "planar", "name": "Panel" } ]"#,
    );
    assert!(
        e.contains("reflectors[1].name") && e.contains("earlier reflector"),
        "{e}"
    );
    let e = load_err(r#", "impostors": [ { "mesh": "Panel" }, { "mesh": "Panel" } ]"#);
    assert!(
        e.contains("impostors[1].mesh") && e.contains("twice"),
        "{e}"
    );
}

#[test]
fn scale_converts_gltf_units_to_metres() {
    let (_dir, path) =
        room_scene(r#", "scale": 0.25, "reflectors": [ { "mesh": "Panel", "kind": "planar" } ]"#);
    let scene = Scene::load(&path).unwrap();
    assert!(
        (scene.bounds.max.y - 0.5).abs() < 1e-6,
        "ceiling at 2 units = 0.5 m"
    );
    assert!((scene.reflectors[0].plane.unwrap().point.x - -0.225).abs() < 1e-6);
    let e = load_err(r#", "scale": 0"#);
    assert!(e.contains("field `scale`"), "{e}");
}

#[test]
fn impostor_billboards_resolve_and_bad_ones_are_refused() {
    // Popescu §3/§3.2: a flat object's billboard in its own plane, connected by walls H.
    let (_dir, path) = room_scene(
        r#", "impostors": [ { "mesh": "Panel", "billboard": { "placement": "surface", "wall_height": 0.25 } }, { "mesh": "Floor" } ]"#,
    );
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let b = scene.impostors[0].billboard;
    assert_eq!(b.wall, 0.25);
    let plane = b.surface.expect("surface placement");
    assert!(
        plane.normal.x.abs() > 0.999 && (plane.point.x + 0.9).abs() < 1e-5,
        "{plane:?}"
    );
    assert_eq!(scene.impostors[1].billboard, Default::default());

    for h in ["0", "-1"] {
        let e = load_err(&format!(
            r#", "impostors": [ {{ "mesh": "Panel", "billboard": {{ "wall_height": {h} }} }} ]"#
        ));
        assert!(
            e.contains("impostors[0].billboard.wall_height") && e.contains("> 0"),
            "{e}"
        );
    }
    let e = load_err(
        r#", "impostors": [ { "mesh": "Panel", "billboard": { "placement": "plane" } } ]"#,
    );
    assert!(e.contains("centroid") && e.contains("surface"), "{e}");

    // A folded object cannot have a surface billboard.
    let dir = tempfile::tempdir().unwrap();
    let folded = MeshSpec {
        normals: Vec::new(),
        name: "Fold",
        material: 0,
        positions: vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 1.0, 0.0],
        ],
        indices: vec![0, 2, 1, 0, 1, 3],
    };
    write_gltf(
        dir.path(),
        "fold",
        &[folded],
        &[MaterialSpec::diffuse("M", 0.5)],
    );
    let path = write_scene(
        dir.path(),
        r#"{ "version": 1, "geometry": "fold.gltf", "impostors": [ { "mesh": "Fold", "billboard": { "placement": "surface" } } ] }"#,
    );
    let e = Scene::load(&path).expect_err("refused").to_string();
    assert!(
        e.contains("impostors[0].billboard.placement") && e.contains("flat"),
        "{e}"
    );
}

/// A one-path scene whose keyframes are `keys` (JSON objects) at `fps`.
fn path_err(fps: &str, keys: &str) -> String {
    load_err(&format!(
        r#", "camera_paths": [ {{ "name": "p", "fps": {fps}, "keyframes": [ {keys} ] }} ]"#
    ))
}

#[test]
fn camera_paths_beyond_sane_bounds_are_refused_naming_the_field() {
    let key = |t: &str, pos: &str, fov: &str| {
        format!(r#"{{ "time": {t}, "position": {pos}, "target": [0,1,-1], "fov_y_deg": {fov} }}"#)
    };
    let ok = key("0", "[0,1,0]", "60");
    // A keyframe at 1e12 s: 3e13 frames at 30 fps (the viewer aborted allocating 1.9 PB).
    let e = path_err("30", &format!("{ok}, {}", key("1e12", "[0,1,0]", "60")));
    assert!(
        e.contains("scene.json") && e.contains("camera_paths[0].keyframes[1].time"),
        "{e}"
    );
    let e = path_err("1e9", &format!("{ok}, {}", key("10", "[0,1,0]", "60")));
    assert!(
        e.contains("camera_paths[0].fps") && e.contains("1000000000"),
        "{e}"
    );
    // Each bound alone is sane, but together they make too many frames.
    let e = path_err("1000", &format!("{ok}, {}", key("86000", "[0,1,0]", "60")));
    assert!(
        e.contains("camera_paths[0].fps") && e.contains("at most 1000000"),
        "{e}"
    );
    let e = path_err("30", &key("0", "[0,1,0]", "1e-30"));
    assert!(e.contains("keyframes[0].fov_y_deg"), "{e}");
    let e = path_err("30", &key("0", "[0,1e30,0]", "60"));
    assert!(e.contains("keyframes[0].position"), "{e}");
    // The longest sane path loads, and its frame count is what the viewer will allocate.
    let (_dir, path) = room_scene(&format!(
        r#", "camera_paths": [ {{ "name": "p", "fps": 10, "keyframes": [ {ok}, {} ] }} ]"#,
        key("86400", "[0,1,0]", "60")
    ));
    let scene = Scene::load(&path).unwrap();
    let p = scene.camera_path(None).unwrap();
    assert_eq!(glint::camera::frame_count(p), 864_001);
    assert!(glint::camera::frame_count(p) <= glint::camera::MAX_FRAMES);
}

/// A path whose interpolated poses lose their orientation between sound keyframes is refused
/// when the scene loads, naming the path, the time and the frame: passing through its target
/// (the ray caster got NaN rays and panicked), or looking along up.
#[test]
fn camera_paths_that_lose_their_orientation_between_keyframes_are_refused() {
    let key = |t: &str, pos: &str, target: &str| {
        format!(
            r#"{{ "time": {t}, "position": {pos}, "target": {target}, "up": [0,1,0], "fov_y_deg": 60 }}"#
        )
    };
    let e = path_err(
        "30",
        &format!(
            "{}, {}",
            key("0", "[0,1,3]", "[0,1,0]"),
            key("2", "[0,1,-3]", "[0,1,0]")
        ),
    );
    for want in [
        "scene.json",
        "camera_paths[0].keyframes",
        r#"camera path "p" between keyframes 0 and 1"#,
        "t = 1 s (frame 30 at 30 fps)",
        "passes through its target",
    ] {
        assert!(e.contains(want), "{want:?} missing from: {e}");
    }
    // Looking straight up at frame 30, with up [0, 1, 0] at both keyframes.
    let e = path_err(
        "30",
        &format!(
            "{}, {}",
            key("0", "[0,0,0]", "[1,1,0]"),
            key("2", "[0,0,0]", "[-1,1,0]")
        ),
    );
    for want in ["t = 1 s (frame 30 at 30 fps)", "parallel to up"] {
        assert!(e.contains(want), "{want:?} missing from: {e}");
    }
    // Between frames: at 2.5 fps, t = 1 s is no frame.
    let e = path_err(
        "2.5",
        &format!(
            "{}, {}",
            key("0", "[0,1,3]", "[0,1,0]"),
            key("2", "[0,1,-3]", "[0,1,0]")
        ),
    );
    assert!(
        e.contains("t = 1 s (between frames 2 and 3 at 2.5 fps)"),
        "{e}"
    );
    // Passing beside the target, or turning through a view that is not along up, loads.
    for keys in [
        [
            key("0", "[0.1,1,3]", "[0,1,0]"),
            key("2", "[0.1,1,-3]", "[0,1,0]"),
        ],
        [
            key("0", "[0,0,0]", "[1,1,0.1]"),
            key("2", "[0,0,0]", "[-1,1,0.1]"),
        ],
    ] {
        let (_dir, path) = room_scene(&format!(
            r#", "camera_paths": [ {{ "name": "p", "fps": 30, "keyframes": [ {}, {} ] }} ]"#,
            keys[0], keys[1]
        ));
        let scene = Scene::load(&path).unwrap();
        let p = scene.camera_path(None).unwrap();
        for f in 0..glint::camera::frame_count(p) {
            let c = glint::camera::frame_camera(p, f).unwrap();
            assert!(c.forward.is_finite() && c.right.is_finite(), "frame {f}");
        }
    }
}

/// The room's glTF with `edit` applied to its JSON.
fn room_with_gltf_edit(edit: impl Fn(&mut serde_json::Value)) -> (tempfile::TempDir, String) {
    let (dir, path) = room_scene("");
    let gltf = dir.path().join("room.gltf");
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&gltf).unwrap()).unwrap();
    edit(&mut doc);
    std::fs::write(&gltf, serde_json::to_string(&doc).unwrap()).unwrap();
    let e = match Scene::load(&path) {
        Ok(s) => panic!("loaded with {} triangles", s.triangles.len()),
        Err(e) => e.to_string(),
    };
    (dir, e)
}

#[test]
fn accessors_and_views_beyond_their_data_are_errors_naming_them() {
    // POSITION of the floor claims 400 vertices; its view holds 4.
    let (_dir, e) = room_with_gltf_edit(|d| d["accessors"][0]["count"] = 400.into());
    assert!(
        e.contains("room.gltf") && e.contains("accessor 0") && e.contains("400"),
        "{e}"
    );
    // Indices past their view by an offset.
    let (_dir, e) = room_with_gltf_edit(|d| d["accessors"][1]["byteOffset"] = 4.into());
    assert!(
        e.contains("accessor 1") && e.contains("buffer view 1"),
        "{e}"
    );
    // A view past the end of the buffer.
    let (_dir, e) = room_with_gltf_edit(|d| d["bufferViews"][5]["byteLength"] = 100_000.into());
    assert!(e.contains("buffer view 5") && e.contains("buffer 0"), "{e}");
    // A named accessor is named in the message.
    let (_dir, e) = room_with_gltf_edit(|d| {
        d["accessors"][2]["count"] = 5.into();
        d["accessors"][2]["name"] = "PanelPos".into();
    });
    assert!(e.contains("accessor 2 \"PanelPos\""), "{e}");
}

#[test]
fn buffer_uri_outside_the_gltf_folder_loads_and_bakes_into_a_bundle() {
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("scene");
    std::fs::create_dir(&sub).unwrap();
    let gltf = write_room(&sub);
    std::fs::rename(sub.join("room.bin"), dir.path().join("shared data.bin")).unwrap();
    let set_uri = |uri: &str| {
        let mut doc: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&gltf).unwrap()).unwrap();
        doc["buffers"][0]["uri"] = uri.into();
        std::fs::write(&gltf, serde_json::to_string(&doc).unwrap()).unwrap();
    };
    // A legal relative reference, percent-escaped (glTF 2.0 §3.9.2).
    set_uri("../shared%20data.bin");
    let path = write_scene(&sub, r#"{ "version": 1, "geometry": "room.gltf" }"#);
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.triangles.len(), 6);

    // The bundle stores the buffer inside its scene stage and its copy still loads.
    let bundle = dir.path().join("b.glint");
    glint::bake::scene_stage::bake(&scene, &bundle, false).unwrap();
    let b = glint::bundle::Bundle::open(&bundle).unwrap();
    let copy = Scene::load(b.asset_path(b.stage_asset("scene", "scene.json").unwrap())).unwrap();
    assert_eq!(copy.triangles, scene.triangles);
    assert!(b.stage_asset("scene", "buffers/0.bin").is_ok());

    // A folder or a missing file is still refused, naming the URI and the file.
    set_uri("..");
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(
        e.contains("room.gltf") && e.contains("buffer 0") && e.contains("not a file"),
        "{e}"
    );
    set_uri("../gone.bin");
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(e.contains("buffer 0") && e.contains("gone.bin"), "{e}");
}

/// Packs `room.gltf` + `room.bin` of `dir`, with `edit` applied to the JSON, into `room.glb`
/// (glTF 2.0 §4.4: a 12-byte header, a JSON chunk and a BIN chunk, each padded to 4 bytes).
fn room_glb(dir: &std::path::Path, edit: impl Fn(&mut serde_json::Value)) {
    write_room(dir);
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("room.gltf")).unwrap()).unwrap();
    edit(&mut doc);
    doc["buffers"][0]
        .as_object_mut()
        .unwrap()
        .remove("uri")
        .unwrap();
    let mut json = serde_json::to_vec(&doc).unwrap();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = std::fs::read(dir.join("room.bin")).unwrap();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut glb = Vec::with_capacity(total);
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&(total as u32).to_le_bytes());
    for (kind, chunk) in [(b"JSON", &json), (b"BIN\0", &bin)] {
        glb.extend_from_slice(&(chunk.len() as u32).to_le_bytes());
        glb.extend_from_slice(kind);
        glb.extend_from_slice(chunk);
    }
    std::fs::write(dir.join("room.glb"), glb).unwrap();
    std::fs::remove_file(dir.join("room.gltf")).unwrap();
    std::fs::remove_file(dir.join("room.bin")).unwrap();
}

/// glTF 2.0 §3.10: each perspective camera node becomes a one-keyframe camera path named after
/// its node, at its world transform (parents and scene.json's scale applied), looking down its
/// −Z with its +Y up and `yfov` as the field of view; an orthographic camera is skipped; a
/// scene.json path of the same name wins.
#[test]
fn gltf_camera_nodes_become_camera_paths() {
    let dir = tempfile::tempdir().unwrap();
    room_glb(dir.path(), |d| {
        d["cameras"] = serde_json::json!([
            { "type": "perspective", "perspective": { "yfov": 0.7, "aspectRatio": 1.5, "znear": 0.01 } },
            { "type": "orthographic", "orthographic": { "xmag": 1, "ymag": 1, "znear": 0.01, "zfar": 10 } }
        ]);
        let nodes = d["nodes"].as_array_mut().unwrap();
        let first = nodes.len();
        // A parent moved up 1 unit; its child turned 90° about +Y (looking down −X) at
        // (2, 0.5, 1), then pitched 30° down about its own +X.
        let (s, c) = (
            std::f32::consts::FRAC_PI_4.sin(),
            std::f32::consts::FRAC_PI_4.cos(),
        );
        let yaw = glam::Quat::from_xyzw(0.0, s, 0.0, c);
        let pitch = glam::Quat::from_rotation_x(-30f32.to_radians());
        let q = yaw * pitch;
        nodes.push(
            serde_json::json!({ "name": "Rig", "translation": [0, 1, 0], "children": [first + 1] }),
        );
        nodes.push(serde_json::json!({
            "name": "Overview", "camera": 0,
            "translation": [2, 0.5, 1], "rotation": [q.x, q.y, q.z, q.w]
        }));
        nodes.push(serde_json::json!({ "name": "Plan", "camera": 1 }));
        nodes.push(serde_json::json!({ "name": "front", "camera": 0, "translation": [9, 9, 9] }));
        let roots = d["scenes"][0]["nodes"].as_array_mut().unwrap();
        roots.extend([first, first + 2, first + 3].map(serde_json::Value::from));
    });
    let path = write_scene(
        dir.path(),
        r#"{ "version": 1, "geometry": "room.glb", "scale": 0.5, "camera_paths": [
            { "name": "front", "keyframes": [ { "time": 0, "position": [0, 1, 3], "target": [0, 1, 0], "fov_y_deg": 50 } ] } ] }"#,
    );
    let scene = Scene::load(&path).unwrap();
    let names: Vec<&str> = scene.camera_paths.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["front", "Overview"], "Plan is orthographic");
    assert_eq!(
        scene.desc.camera_paths.len(),
        1,
        "the description stays as written"
    );
    assert_eq!(
        scene.camera_path(Some("front")).unwrap().keyframes[0].position,
        [0.0, 1.0, 3.0],
        "scene.json's path wins the clash"
    );
    let p = scene.camera_path(Some("Overview")).unwrap();
    assert_eq!(p.keyframes.len(), 1);
    let k = p.keyframes[0];
    // World position: (2, 1.5, 1) units × 0.5 m.
    let pos = Vec3::from(k.position);
    assert!((pos - Vec3::new(1.0, 0.75, 0.5)).length() < 1e-5, "{pos}");
    // Looking down −X, pitched 30° down; up tilted towards −X by the same angle.
    let (s30, c30) = (0.5f32, 0.75f32.sqrt());
    let look = (Vec3::from(k.target) - pos).normalize();
    assert!(
        (look - Vec3::new(-c30, -s30, 0.0)).length() < 1e-5,
        "{look}"
    );
    let up = Vec3::from(k.up);
    assert!((up - Vec3::new(-s30, c30, 0.0)).length() < 1e-5, "{up}");
    assert!(
        (k.fov_y_deg - 0.7f32.to_degrees()).abs() < 1e-4,
        "{}",
        k.fov_y_deg
    );

    // With no camera_paths in scene.json, the glTF's camera is the first (default) path.
    let path = write_scene(dir.path(), r#"{ "version": 1, "geometry": "room.glb" }"#);
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.camera_path(None).unwrap().name, "Overview");
}

/// The room with a slab mirror "Mirror" (1 × 0.7 × 0.01 m, 5 mm bevels on the front, 20
/// triangles) whose front faces +z at z = 0.5, a sphere "Ball" and, with `wall`, a wall 2 mm
/// behind the slab's back, with `reflector` as the only entry of `reflectors`.
fn wall_slab_scene(reflector: &str, wall: bool) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let (mut meshes, mut materials) = room();
    materials.push(MaterialSpec {
        name: "MirrorMat",
        base: [0.95, 0.95, 0.95, 1.0],
        metallic: 1.0,
        roughness: 0.0,
        emissive: [0.0; 3],
        strength: 1.0,
    });
    meshes.push(slab(
        "Mirror",
        3,
        [0.0, 1.0, 0.5],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        (1.0, 0.7, 0.01),
        0.005,
    ));
    meshes.push(uv_sphere("Ball", 3, [0.0, 0.5, 0.0], 0.2, false));
    if wall {
        meshes.push(quad("Wall", 0, 2, 0.488, 2.0));
    }
    write_gltf(dir.path(), "room", &meshes, &materials);
    let path = write_scene(
        dir.path(),
        &format!(r#"{{ "version": 1, "geometry": "room.gltf", "reflectors": [ {reflector} ] }}"#),
    );
    (dir, path)
}

fn slab_scene(reflector: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    wall_slab_scene(reflector, false)
}

/// The triangles of object `name`.
fn object_triangles(scene: &Scene, name: &str) -> Vec<u32> {
    let o = scene.objects.iter().find(|o| o.is_named(name)).unwrap();
    o.triangles.clone().collect()
}

/// A slab mirror declared planar reflects from its front (named by `face`: "+z" or a
/// direction): the two front triangles, the plane z = 0.5 facing +z, an outline of
/// 0.99 × 0.69 m (the front inside its bevels); the back and edges are not the reflector.
/// "-z" takes the back (facing −z at z = 0.49). `"auto"` (and no `face`), with a wall 2 mm
/// behind the slab, takes the front although the back is larger (0.7 m² against 0.683 m²):
/// front and back are within 10% in area, and the front has more open space before it.
#[test]
fn slab_mirror_is_a_planar_reflector_on_its_named_face() {
    use glint::radiance::sampling::ReflectorFrame;
    for face in [r#""+z""#, "[0, 0.2, 1]"] {
        let (_dir, path) = slab_scene(&format!(
            r#"{{ "mesh": "Mirror", "kind": "planar", "face": {face} }}"#
        ));
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{face}: {e}"));
        let all = object_triangles(&scene, "Mirror");
        assert_eq!(all.len(), 20);
        let r = &scene.reflectors[0];
        assert_eq!(r.kind, ReflectorKind::Planar);
        assert_eq!(
            r.triangles,
            all[..2].to_vec(),
            "{face}: the front's two triangles"
        );
        let plane = r.plane.unwrap();
        assert!(
            (plane.normal - Vec3::Z).length() < 1e-6,
            "{face}: {plane:?}"
        );
        assert!((plane.point - Vec3::new(0.0, 1.0, 0.5)).length() < 1e-5);
        let frame = ReflectorFrame::new(&plane, r, &scene.triangles);
        let (lo, hi) = (frame.size.min_element(), frame.size.max_element());
        assert!(
            (lo - 0.69).abs() < 1e-5 && (hi - 0.99).abs() < 1e-5,
            "outline {}",
            frame.size
        );
        assert!((r.bounds.max.z - 0.5).abs() < 1e-6 && (r.bounds.min.z - 0.5).abs() < 1e-6);
        assert_eq!(scene.materials[r.material as usize].name, "MirrorMat");
    }
    for face in [r#", "face": "-z""#, r#", "face": [0, 0.1, -1]"#] {
        let (_dir, path) = slab_scene(&format!(
            r#"{{ "mesh": "Mirror", "kind": "planar"{face} }}"#
        ));
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{face}: {e}"));
        let r = &scene.reflectors[0];
        let plane = r.plane.unwrap();
        assert!(
            (plane.normal + Vec3::Z).length() < 1e-6,
            "{face}: {plane:?}"
        );
        assert!((plane.point.z - 0.49).abs() < 1e-5);
        assert_eq!(
            r.triangles,
            object_triangles(&scene, "Mirror")[2..4].to_vec()
        );
    }
    for face in ["", r#", "face": "auto""#] {
        let (_dir, path) = wall_slab_scene(
            &format!(r#"{{ "mesh": "Mirror", "kind": "planar"{face} }}"#),
            true,
        );
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{face}: {e}"));
        let r = &scene.reflectors[0];
        assert!(
            (r.plane.unwrap().normal - Vec3::Z).length() < 1e-6,
            "{face}"
        );
        assert_eq!(
            r.triangles,
            object_triangles(&scene, "Mirror")[..2].to_vec()
        );
    }
    // A single quad is unchanged by a face that names its side, refused by one that does not.
    let (_dir, path) = slab_scene(r#"{ "mesh": "Floor", "kind": "planar", "face": "+y" }"#);
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.reflectors[0].triangles, vec![0, 1]);
}

/// Every way a planar face can be missing names the file, the field, the reflector and what
/// was found: no face set faces the named side; a sphere (no face set dominates); a face that
/// is not one; a face on a curved reflector.
#[test]
fn slab_mirror_errors_name_the_reflector_and_what_was_found() {
    let err = |r: &str| {
        let (_dir, path) = slab_scene(r);
        match Scene::load(&path) {
            Ok(_) => panic!("{r} loaded"),
            Err(e) => e.to_string(),
        }
    };
    let e = err(r#"{ "mesh": "Mirror", "kind": "planar", "face": "+x" }"#);
    assert!(
        e.contains("scene.json")
            && e.contains("reflectors[0].face")
            && e.contains("reflector \"Mirror\"")
            && e.contains("the largest coplanar face set facing +x holds only 1%")
            && e.contains("20 triangles form 10 coplanar face sets")
            && e.contains("0.7000 m² facing (0.00, 0.00, -1.00)"),
        "{e}"
    );
    // A side no face set faces at all.
    let (_dir, path) = slab_scene(r#"{ "mesh": "Floor", "kind": "planar", "face": "-y" }"#);
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(
        e.contains("reflectors[0].face")
            && e.contains("no coplanar face set faces -y")
            && e.contains("4.0000 m² facing (0.00, 1.00, 0.00), 2 triangles"),
        "{e}"
    );
    let e = err(r#"{ "mesh": "Ball", "kind": "planar" }"#);
    assert!(
        e.contains("reflectors[0].kind")
            && e.contains("reflector \"Ball\"")
            && e.contains("face opposite ways")
            && e.contains("declare it \"curved\""),
        "{e}"
    );
    let e = err(r#"{ "mesh": "Mirror", "kind": "planar", "face": "front" }"#);
    assert!(
        e.contains("reflectors[0].face") && e.contains("\"front\" is not a face"),
        "{e}"
    );
    let e = err(r#"{ "mesh": "Mirror", "kind": "planar", "face": [0, 0, 0] }"#);
    assert!(e.contains("is not a direction"), "{e}");
    let e = err(r#"{ "mesh": "Ball", "kind": "curved", "face": "+z" }"#);
    assert!(
        e.contains("reflectors[0].face") && e.contains("only a \"planar\" reflector"),
        "{e}"
    );
}

#[test]
fn transmission_and_ior_are_read_from_scene_json_and_checked() {
    let (_dir, path) =
        room_scene(r#", "materials": { "FloorMat": { "transmission": 0.5, "ior": 2.0 } }"#);
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let m = scene
        .materials
        .iter()
        .find(|m| m.name == "FloorMat")
        .unwrap();
    assert_eq!((m.transmission.factor, m.transmission.ior), (0.5, 2.0));
    // The glTF's diffuse 0.5, halved.
    assert!((m.albedo - Vec3::splat(0.25)).abs().max_element() < 1e-6);
    let e = load_err(r#", "materials": { "FloorMat": { "transmission": 1.5 } }"#);
    assert!(
        e.contains("materials.FloorMat.transmission") && e.contains("[0, 1]"),
        "{e}"
    );
    let e = load_err(r#", "materials": { "FloorMat": { "ior": 0.5 } }"#);
    assert!(e.contains("materials.FloorMat.ior"), "{e}");
}

#[test]
fn gltf_transmission_and_ior_make_thin_glass() {
    let dir = tempfile::tempdir().unwrap();
    let gltf = write_room(dir.path());
    // PanelMat (index 1): metallic 1 in the room; make it a smooth dielectric of IOR 2.
    add_transmission(&gltf, 1, 0.9);
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&gltf).unwrap()).unwrap();
    let m = &mut doc["materials"][1];
    m["pbrMetallicRoughness"]["metallicFactor"] = 0.0.into();
    m["extensions"]["KHR_materials_ior"] = serde_json::json!({ "ior": 2.0 });
    std::fs::write(&gltf, serde_json::to_string(&doc).unwrap()).unwrap();
    let path = write_scene(dir.path(), r#"{ "version": 1, "geometry": "room.gltf" }"#);
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let m = scene
        .materials
        .iter()
        .find(|m| m.name == "PanelMat")
        .unwrap();
    assert_eq!((m.transmission.factor, m.transmission.ior), (0.9, 2.0));
    assert_eq!(m.transmission.tint, Vec3::splat(0.9));
    // glTF's dielectric lobe takes F₀ = 1/9 of IOR 2; the diffuse keeps a tenth.
    assert!((m.lobes[0].r0 - 1.0 / 9.0).abs() < 1e-6, "{:?}", m.lobes);
    assert!(
        (m.albedo - Vec3::splat(0.9 * 0.96 * 0.1))
            .abs()
            .max_element()
            < 1e-6
    );
}
