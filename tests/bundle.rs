//! Bundle format v1: atomic stage writes, concurrent writers, refusing bad bundles, and the
//! `glint-bundle` command line.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use glint::bundle::{Bundle, BundleError, MANIFEST, StageInfo, StageWriter};

fn info(hash: &str) -> StageInfo {
    StageInfo {
        scene_name: "test".into(),
        scene_hash: hash.into(),
        settings: serde_json::json!({ "rays": 16 }),
        stats: BTreeMap::from([("texels".to_string(), serde_json::json!(42))]),
        bake_seconds: 0.5,
        force: false,
    }
}

fn bake(
    dir: &Path,
    stage: &str,
    hash: &str,
    files: &[(&str, &str, &[u8])],
) -> Result<(), BundleError> {
    let mut w = StageWriter::begin(dir, stage)?;
    for (rel, kind, bytes) in files {
        w.write(rel, kind, bytes)?;
    }
    w.commit(info(hash)).map(|_| ())
}

#[test]
fn stage_round_trip_and_verify() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("a.glint");
    bake(
        &dir,
        "radiosity",
        "h1",
        &[
            ("page0.exr", "radiosity-exr", b"exr bytes"),
            ("sub/atlas.bin", "atlas", b"atlas"),
        ],
    )
    .unwrap();
    let b = Bundle::open(&dir).unwrap();
    let rec = b.stage("radiosity").unwrap();
    assert_eq!(rec.assets.len(), 2);
    assert_eq!(rec.assets[1].path, "radiosity/sub/atlas.bin");
    assert_eq!(
        rec.assets[0].blake3,
        blake3::hash(b"exr bytes").to_hex().as_str()
    );
    assert_eq!(rec.settings["rays"], 16);
    assert!(b.verify().is_empty());
    assert_eq!(b.read_asset(&rec.assets[0]).unwrap(), b"exr bytes");
    // No temporary folders are left behind.
    let names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        names
            .iter()
            .all(|n| !n.contains(".tmp-") && !n.contains(".old-")),
        "{names:?}"
    );

    // Re-baking replaces the stage's folder whole: the old file is gone.
    bake(
        &dir,
        "radiosity",
        "h1",
        &[("page0.exr", "radiosity-exr", b"new")],
    )
    .unwrap();
    let b = Bundle::open(&dir).unwrap();
    assert_eq!(b.stage("radiosity").unwrap().assets.len(), 1);
    assert!(!dir.join("radiosity/sub/atlas.bin").exists());
    assert!(b.verify().is_empty());
}

#[test]
fn tampered_or_missing_asset_fails_verify_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("b.glint");
    bake(
        &dir,
        "radiosity",
        "h",
        &[
            ("x.bin", "atlas", b"0123456789"),
            ("y.bin", "atlas", b"abc"),
        ],
    )
    .unwrap();
    std::fs::write(dir.join("radiosity/x.bin"), b"0123456780").unwrap();
    std::fs::remove_file(dir.join("radiosity/y.bin")).unwrap();
    let problems: Vec<String> = Bundle::open(&dir)
        .unwrap()
        .verify()
        .iter()
        .map(|e| e.to_string())
        .collect();
    assert_eq!(problems.len(), 2, "{problems:?}");
    assert!(
        problems
            .iter()
            .any(|p| p.contains("x.bin") && p.contains("BLAKE3")),
        "{problems:?}"
    );
    assert!(
        problems
            .iter()
            .any(|p| p.contains("y.bin") && p.contains("cannot be read")),
        "{problems:?}"
    );
}

#[test]
fn uncommitted_stage_leaves_the_bundle_unchanged() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("c.glint");
    bake(&dir, "radiosity", "h", &[("x.bin", "atlas", b"keep")]).unwrap();
    let before = std::fs::read(dir.join(MANIFEST)).unwrap();
    {
        let mut w = StageWriter::begin(&dir, "radiosity").unwrap();
        w.write("x.bin", "atlas", b"half-baked").unwrap();
        // Dropped: an error or Ctrl-C before commit.
    }
    assert_eq!(std::fs::read(dir.join(MANIFEST)).unwrap(), before);
    assert_eq!(std::fs::read(dir.join("radiosity/x.bin")).unwrap(), b"keep");
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        3,
        "manifest, lock and radiosity/ only"
    );
}

#[test]
fn concurrent_stage_writers_keep_each_others_entries() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("d.glint");
    let stages = ["radiosity", "materials", "radiance", "srdm"];
    for round in 0..5 {
        std::thread::scope(|s| {
            for stage in stages {
                let dir = &dir;
                s.spawn(move || {
                    let body = format!("{stage} {round}");
                    bake(dir, stage, "same", &[("data.bin", "blob", body.as_bytes())]).unwrap();
                });
            }
        });
        let b = Bundle::open(&dir).unwrap();
        assert_eq!(b.manifest().stages.len(), 4, "round {round}");
        assert!(b.verify().is_empty(), "round {round}");
    }
}

#[test]
fn concurrent_processes_keep_each_others_entries() {
    // Two glint-bundle-independent processes: this test binary re-run as writer children.
    if let Ok(stage) = std::env::var("GLINT_TEST_WRITER_STAGE") {
        let dir = std::env::var("GLINT_TEST_WRITER_DIR").unwrap();
        for i in 0..10 {
            bake(
                Path::new(&dir),
                &stage,
                "same",
                &[("f.bin", "blob", format!("{i}").as_bytes())],
            )
            .unwrap();
        }
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("p.glint");
    let exe = std::env::current_exe().unwrap();
    let children: Vec<_> = ["radiosity", "srdm"]
        .iter()
        .map(|stage| {
            Command::new(&exe)
                .args([
                    "--exact",
                    "concurrent_processes_keep_each_others_entries",
                    "--nocapture",
                ])
                .env("GLINT_TEST_WRITER_STAGE", stage)
                .env("GLINT_TEST_WRITER_DIR", &dir)
                .stdout(std::process::Stdio::null())
                .spawn()
                .unwrap()
        })
        .collect();
    for mut c in children {
        assert!(c.wait().unwrap().success());
    }
    let b = Bundle::open(&dir).unwrap();
    assert_eq!(
        b.manifest().stages.keys().collect::<Vec<_>>(),
        ["radiosity", "srdm"]
    );
    assert!(b.verify().is_empty());
}

#[test]
fn another_scenes_bundle_is_replaced_only_with_force() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("e.glint");
    bake(&dir, "radiosity", "scene-a", &[("x.bin", "atlas", b"a")]).unwrap();
    bake(&dir, "materials", "scene-a", &[("k.exr", "kernel", b"k")]).unwrap();
    let e = bake(&dir, "radiosity", "scene-b", &[("x.bin", "atlas", b"b")]).unwrap_err();
    assert!(matches!(e, BundleError::SceneMismatch { .. }));
    assert!(
        e.to_string().contains("--force") && e.to_string().contains("e.glint"),
        "{e}"
    );
    assert_eq!(std::fs::read(dir.join("radiosity/x.bin")).unwrap(), b"a");

    let mut w = StageWriter::begin(&dir, "radiosity").unwrap();
    w.write("x.bin", "atlas", b"b").unwrap();
    w.commit(StageInfo {
        force: true,
        ..info("scene-b")
    })
    .unwrap();
    let b = Bundle::open(&dir).unwrap();
    assert_eq!(b.manifest().scene_hash, "scene-b");
    assert_eq!(
        b.manifest().stages.keys().collect::<Vec<_>>(),
        ["radiosity"],
        "stale stage dropped"
    );
    assert!(!dir.join("materials").exists());
}

#[test]
fn bad_bundles_are_refused_with_a_message_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("f.glint");
    std::fs::create_dir(&dir).unwrap();
    let e = Bundle::open(&dir).unwrap_err().to_string();
    assert!(
        e.contains("f.glint") && e.contains("manifest.json is missing"),
        "{e}"
    );

    std::fs::write(dir.join(MANIFEST), "{ not json").unwrap();
    let e = Bundle::open(&dir).unwrap_err().to_string();
    assert!(e.contains("manifest.json") && e.contains("corrupt"), "{e}");

    bake(&dir, "radiosity", "h", &[("x.bin", "atlas", b"a")]).unwrap_err();
    std::fs::remove_file(dir.join(MANIFEST)).unwrap();
    bake(&dir, "radiosity", "h", &[("x.bin", "atlas", b"a")]).unwrap();
    let text = std::fs::read_to_string(dir.join(MANIFEST)).unwrap();
    std::fs::write(dir.join(MANIFEST), text.replace("\"1.0.0\"", "\"2.1.0\"")).unwrap();
    let e = Bundle::open(&dir).unwrap_err().to_string();
    assert!(
        e.contains("2.1.0") && e.contains("1.0.0") && e.contains("newer"),
        "{e}"
    );

    // A newer minor version with an added field is read.
    let newer_minor =
        text.replace("\"1.0.0\"", "\"1.3.0\"")
            .replacen('{', "{ \"added_later\": true,", 1);
    std::fs::write(dir.join(MANIFEST), newer_minor).unwrap();
    Bundle::open(&dir).unwrap();

    // An asset path escaping the bundle is corrupt.
    std::fs::write(
        dir.join(MANIFEST),
        text.replace("radiosity/x.bin", "../x.bin"),
    )
    .unwrap();
    let e = Bundle::open(&dir).unwrap_err().to_string();
    assert!(e.contains("corrupt") && e.contains("../x.bin"), "{e}");
}

#[test]
fn bad_stage_and_asset_names_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("g.glint");
    assert!(StageWriter::begin(&dir, "../evil").is_err());
    assert!(StageWriter::begin(&dir, "a/b").is_err());
    let mut w = StageWriter::begin(&dir, "radiosity").unwrap();
    assert!(w.write("/abs", "k", b"").is_err());
    assert!(w.write("a/../../b", "k", b"").is_err());
    w.write("ok.bin", "k", b"").unwrap();
    assert!(w.write("ok.bin", "k", b"").is_err(), "same path twice");
}

fn glint_bundle(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_glint-bundle"))
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
fn glint_bundle_stats_verify_ls() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("h.glint");
    bake(
        &dir,
        "radiosity",
        "h",
        &[
            ("p0.exr", "radiosity-exr", &[7u8; 1000]),
            ("p1.exr", "radiosity-exr", &[8u8; 500]),
            ("atlas.bin", "atlas", b"xyz"),
        ],
    )
    .unwrap();
    bake(&dir, "srdm", "h", &[("bunny.srdm", "srdm", &[1u8; 64])]).unwrap();
    let d = dir.to_str().unwrap();

    let (code, out, _) = glint_bundle(&["stats", d]);
    assert_eq!(code, 0);
    assert!(
        out.contains("radiosity") && out.contains("radiosity-exr") && out.contains("1500"),
        "{out}"
    );
    assert!(out.contains("total") && out.contains("1567"), "{out}");
    assert!(out.contains("texels"), "{out}");

    let (code, out, _) = glint_bundle(&["stats", d, "--json"]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["total"]["bytes"], 1567);
    assert_eq!(v["total"]["files"], 4);
    assert_eq!(v["stages"][0]["kinds"]["radiosity-exr"]["files"], 2);

    let (code, out, _) = glint_bundle(&["ls", d]);
    assert_eq!(code, 0);
    assert_eq!(out.lines().count(), 2 + 4, "{out}");
    assert!(out.contains("srdm/bunny.srdm"));

    let (code, out, _) = glint_bundle(&["verify", d]);
    assert_eq!(code, 0, "{out}");
    assert!(out.starts_with("ok:"), "{out}");

    std::fs::write(dir.join("srdm/bunny.srdm"), [2u8; 64]).unwrap();
    let (code, out, _) = glint_bundle(&["verify", d]);
    assert_eq!(code, 1, "{out}");
    assert!(
        out.contains("FAILED") && out.contains("bunny.srdm"),
        "{out}"
    );

    let (code, _, err) = glint_bundle(&["stats", tmp.path().join("nope.glint").to_str().unwrap()]);
    assert_eq!(code, 1);
    assert!(
        err.contains("nope.glint") && err.contains("manifest.json is missing"),
        "{err}"
    );

    let (code, _, err) = glint_bundle(&["frobnicate"]);
    assert_eq!(code, 2, "{err}");
}
