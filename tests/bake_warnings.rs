//! `glint-bake` warns of every declared reflector it skips and every impostor nothing shows,
//! saying why, on stderr and in its JSON report.

mod common;

use common::{lit_floor, run_exe, write_scene};

#[test]
fn a_reflector_without_a_glossy_lobe_and_an_impostor_nothing_reflects_are_named_with_why() {
    let dir = tempfile::tempdir().unwrap();
    lit_floor(dir.path());
    // The floor's material is diffuse: declared `curved`, it gets no environment map; and with
    // no glossy reflector, nothing draws the lamp's impostor.
    let scene = write_scene(
        dir.path(),
        r#"{ "version": 1, "geometry": "box.gltf",
             "reflectors": [ { "mesh": "Floor", "kind": "curved" } ],
             "impostors": [ { "mesh": "Light", "views": 1 } ],
             "bake": { "quality": "draft", "radiosity": { "rays": 16, "light_samples": 4 } } }"#,
    );
    let bundle = dir.path().join("warned.glint");
    let (code, stdout, stderr) = run_exe(
        env!("CARGO_BIN_EXE_glint-bake"),
        &[
            scene.as_os_str(),
            "--bundle".as_ref(),
            bundle.as_os_str(),
            "--json".as_ref(),
        ],
    );
    assert_eq!(code, 0, "{stderr}");
    let warn: Vec<&str> = stderr.lines().filter(|l| l.contains("WARN")).collect();
    assert!(
        warn.iter().any(|l| l.contains(
            "scene.json: reflectors[0] (Floor): curved reflector skipped, no environment map"
        ) && l.contains("material \"white\" has no glossy lobe")),
        "{stderr}"
    );
    assert!(
        warn.iter()
            .any(|l| l.contains("impostors[0] (Light): baked, but never drawn")),
        "{stderr}"
    );
    let report: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let warnings = report["warnings"].as_array().unwrap();
    assert_eq!(warnings.len(), 2, "{report}");
    assert_eq!(warnings[0]["field"], "reflectors[0]");
    assert_eq!(warnings[0]["name"], "Floor");
    assert!(
        warnings[0]["reason"]
            .as_str()
            .unwrap()
            .contains("no glossy lobe")
    );
    assert_eq!(warnings[1]["field"], "impostors[0]");
}

#[test]
fn a_scene_whose_declarations_are_all_baked_warns_of_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let scene = lit_floor(dir.path());
    let bundle = dir.path().join("quiet.glint");
    let (code, stdout, stderr) = run_exe(
        env!("CARGO_BIN_EXE_glint-bake"),
        &[
            scene.as_os_str(),
            "--bundle".as_ref(),
            bundle.as_os_str(),
            "--json".as_ref(),
            "--quality".as_ref(),
            "draft".as_ref(),
        ],
    );
    assert_eq!(code, 0, "{stderr}");
    assert!(!stderr.contains("WARN"), "{stderr}");
    let report: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(report["warnings"], serde_json::json!([]));
}
