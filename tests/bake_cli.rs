//! `glint-bake` round trips: what it writes, what it skips, and that a bad scene writes nothing.

mod common;

use std::process::Command;

use common::*;
use glint::bundle::Bundle;

fn glint_bake(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_glint-bake"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn bakes_the_scene_stage_then_finds_it_up_to_date() {
    let dir = tempfile::tempdir().unwrap();
    write_room(dir.path());
    let scene = write_scene(
        dir.path(),
        r#"{ "version": 1, "geometry": "room.gltf", "reflectors": [ { "mesh": "Panel", "kind": "planar" } ] }"#,
    );
    let bundle = dir.path().join("out/room.glint");
    let (s, b) = (scene.to_str().unwrap(), bundle.to_str().unwrap());
    let (code, out, err) = glint_bake(&[s, "--bundle", b, "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let stage = |name: &str| {
        v["stages"]
            .as_array()
            .unwrap()
            .iter()
            .find(|x| x["stage"] == name)
            .unwrap()
            .clone()
    };
    assert!(
        stage("scene")["status"]
            .as_str()
            .unwrap()
            .starts_with("baked"),
        "{out}"
    );
    assert_eq!(
        stage("radiance")["needed"],
        true,
        "the metal panel is a glossy planar reflector"
    );
    assert!(
        stage("radiance")["reason"]
            .as_str()
            .unwrap()
            .contains("Panel")
    );
    assert_eq!(stage("srdm")["needed"], false);
    assert!(
        stage("radiosity")["status"]
            .as_str()
            .unwrap()
            .starts_with("baked"),
        "{out}"
    );

    let opened = Bundle::open(&bundle).unwrap();
    assert!(opened.verify().is_empty());
    let paths: Vec<&str> = opened
        .stage("scene")
        .unwrap()
        .assets
        .iter()
        .map(|a| a.path.as_str())
        .collect();
    assert_eq!(
        paths,
        ["scene/scene.json", "scene/room.gltf", "scene/room.bin"]
    );
    // The copy inside the bundle loads on its own, with the same geometry.
    let copy = glint::scene::Scene::load(bundle.join("scene/scene.json")).unwrap();
    assert_eq!(copy.triangles.len(), 6);

    assert!(opened.stage("radiosity").is_some());

    let (code, out, _) = glint_bake(&[s, "--bundle", b]);
    assert_eq!(code, 0);
    let up_to_date = out.lines().filter(|l| l.contains("up to date")).count();
    assert_eq!(
        up_to_date, 4,
        "scene, radiosity, materials and radiance are up to date: {out}"
    );
    // Another preset is not up to date.
    let (code, out, _) = glint_bake(&[s, "--bundle", b, "--quality", "draft"]);
    assert_eq!(code, 0);
    assert_eq!(
        out.lines().filter(|l| l.contains("up to date")).count(),
        1,
        "{out}"
    );
}

#[test]
fn a_bad_scene_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    write_room(dir.path());
    let scene = write_scene(
        dir.path(),
        r#"{ "version": 1, "geometry": "room.gltf", "reflectors": [ { "mesh": "Nope", "kind": "planar" } ] }"#,
    );
    let bundle = dir.path().join("bad.glint");
    let (code, _, err) = glint_bake(&[
        scene.to_str().unwrap(),
        "--bundle",
        bundle.to_str().unwrap(),
    ]);
    assert_eq!(code, 1);
    assert!(
        err.contains("scene.json") && err.contains("reflectors[0].mesh"),
        "{err}"
    );
    assert!(!bundle.exists());

    let (code, _, err) = glint_bake(&[
        scene.to_str().unwrap(),
        "--bundle",
        bundle.to_str().unwrap(),
        "--quality",
        "ultra",
    ]);
    assert_eq!(code, 2);
    assert!(
        err.contains("--quality") && err.contains("draft, default or high"),
        "{err}"
    );
}

#[test]
fn diffuse_scene_skips_glossy_stages_with_reasons() {
    let dir = tempfile::tempdir().unwrap();
    write_gltf(
        dir.path(),
        "box",
        &[quad("Floor", 0, 1, 0.0, 1.0), quad("Light", 1, 1, 1.0, 0.2)],
        &[
            MaterialSpec::diffuse("white", 0.7),
            MaterialSpec {
                emissive: [1.0; 3],
                strength: 5.0,
                ..MaterialSpec::diffuse("lamp", 0.0)
            },
        ],
    );
    let scene = write_scene(dir.path(), r#"{ "version": 1, "geometry": "box.gltf" }"#);
    let bundle = dir.path().join("box.glint");
    let (code, out, _) = glint_bake(&[
        scene.to_str().unwrap(),
        "--bundle",
        bundle.to_str().unwrap(),
    ]);
    assert_eq!(code, 0);
    assert!(
        out.contains("no material in use has a glossy lobe"),
        "{out}"
    );
    assert!(
        out.contains("no planar reflector has a glossy material"),
        "{out}"
    );
    assert!(out.contains("no impostor objects declared"), "{out}");
}

/// Bake settings in scene.json are checked with the scene: refused before any stage is
/// written, naming scene.json and the field.
#[test]
fn bad_bake_settings_are_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    write_room(dir.path());
    let bundle = dir.path().join("b.glint");
    for (bake, field, says) in [
        (
            r#"{ "radiosity": { "texel_density": 1e-30 } }"#,
            "bake.radiosity.texel_density",
            "gives no element",
        ),
        (
            r#"{ "radiosity": { "texel_density": -1 } }"#,
            "bake.radiosity.texel_density",
            "-1",
        ),
        (
            r#"{ "radiosity": { "rays": 0 } }"#,
            "bake.radiosity.rays",
            "≥ 1",
        ),
        (
            r#"{ "materials": { "env_map_size": 100 } }"#,
            "bake.materials.env_map_size",
            "power of two",
        ),
        (
            r#"{ "srdm": { "domains": 0 } }"#,
            "bake.srdm.domains",
            "1 ..= ",
        ),
        (
            r#"{ "radiance": { "resolution_scale": -2 } }"#,
            "bake.radiance.resolution_scale",
            "(0, 16]",
        ),
    ] {
        let scene = write_scene(
            dir.path(),
            &format!(r#"{{ "version": 1, "geometry": "room.gltf", "bake": {bake} }}"#),
        );
        let (code, _, err) = glint_bake(&[
            scene.to_str().unwrap(),
            "--bundle",
            bundle.to_str().unwrap(),
        ]);
        assert_eq!(code, 1, "{bake}: {err}");
        assert!(
            err.contains("scene.json") && err.contains(field) && err.contains(says),
            "{bake}: {err}"
        );
        assert!(!bundle.exists(), "{bake}: nothing is written");
    }
}

/// `--texel-density 1e-30` would bake a black D: refused by the same check as scene.json's,
/// naming the flag, before anything is written.
#[test]
fn glint_radiosity_refuses_a_density_that_gives_no_element() {
    let dir = tempfile::tempdir().unwrap();
    write_room(dir.path());
    let scene = write_scene(dir.path(), r#"{ "version": 1, "geometry": "room.gltf" }"#);
    let bundle = dir.path().join("b.glint");
    let out = Command::new(env!("CARGO_BIN_EXE_glint-radiosity"))
        .arg(&scene)
        .arg("--bundle")
        .arg(&bundle)
        .args(["--texel-density", "1e-30"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("--texel-density") && err.contains("gives no element"),
        "{err}"
    );
    assert!(!bundle.exists());
}
