//! Bundle format v2: atomic stage commits (fault injection at every step, in process and by
//! killing a writer), readers during commits, concurrent writers, refusing bad bundles and
//! folders that are not bundles, collecting leftovers, and the `glint-bundle` command line.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use glint::bundle::{
    Bundle, BundleError, CommitStep, FORMAT_VERSION, MANIFEST, StageInfo, StageWriter,
};

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

    // The files lie in the versioned folder the manifest names; paths stay logical.
    assert_eq!(rec.dir.as_deref(), Some("radiosity.1"));
    assert_eq!(
        b.asset_path(&rec.assets[1]),
        dir.join("radiosity.1/sub/atlas.bin")
    );
    assert_eq!(
        b.read_stage_file("radiosity", "sub/atlas.bin").unwrap(),
        b"atlas"
    );
    drop(b);

    // Re-baking replaces the stage whole: a new folder, the old one collected.
    bake(
        &dir,
        "radiosity",
        "h1",
        &[("page0.exr", "radiosity-exr", b"new")],
    )
    .unwrap();
    let b = Bundle::open(&dir).unwrap();
    assert_eq!(b.stage("radiosity").unwrap().assets.len(), 1);
    assert_eq!(
        b.stage("radiosity").unwrap().dir.as_deref(),
        Some("radiosity.2")
    );
    assert_eq!(entries(&dir), [".lock", "manifest.json", "radiosity.2"]);
    assert!(b.verify().is_empty());
}

/// The names in a folder, sorted.
fn entries(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
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
    let b = Bundle::open(&dir).unwrap();
    let rec = b.stage("radiosity").unwrap();
    std::fs::write(b.asset_path(&rec.assets[0]), b"0123456780").unwrap();
    std::fs::remove_file(b.asset_path(&rec.assets[1])).unwrap();
    let problems: Vec<String> = b.verify().iter().map(|e| e.to_string()).collect();
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
    let b = Bundle::open(&dir).unwrap();
    assert_eq!(b.read_stage_file("radiosity", "x.bin").unwrap(), b"keep");
    assert_eq!(
        entries(&dir),
        [".lock", "manifest.json", "radiosity.1"],
        "manifest, lock and the stage's folder only"
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
                    bake(
                        dir,
                        stage,
                        "same",
                        &[("data.bin", "atlas", body.as_bytes())],
                    )
                    .unwrap();
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
                &[("f.bin", "atlas", format!("{i}").as_bytes())],
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
    let b = Bundle::open(&dir).unwrap();
    assert_eq!(b.read_stage_file("radiosity", "x.bin").unwrap(), b"a");
    drop(b);

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
    assert_eq!(
        entries(&dir),
        [".lock", "manifest.json", "radiosity.2"],
        "the stale stage's folder is collected"
    );
}

/// The refusal to mix two scenes' stages names the stage and prints enough of both hashes
/// to tell them apart (it printed two equal 12-character prefixes), and the scene names.
#[test]
fn a_scene_mismatch_prints_hashes_that_differ_and_the_scene_names() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("m.glint");
    let (a, b) = ("0123456789abcdef0123a", "0123456789abcdef0123b");
    bake(&dir, "radiosity", a, &[("x.bin", "atlas", b"a")]).unwrap();
    let mut w = StageWriter::begin(&dir, "radiosity").unwrap();
    w.write("x.bin", "atlas", b"b").unwrap();
    let e = w
        .commit(StageInfo {
            scene_name: "edited".into(),
            ..info(b)
        })
        .unwrap_err()
        .to_string();
    for want in [
        "stage `radiosity`",
        "hash 0123456789abcdef0123a…",
        "\"test\"",
        "this scene \"edited\" (hash 0123456789abcdef0123b…)",
    ] {
        assert!(e.contains(want), "{want:?} missing from: {e}");
    }
    // The bakers' early check says the same.
    let early = glint::bundle::check_scene(&dir, "edited", b, false)
        .unwrap_err()
        .to_string();
    assert_eq!(early, e);
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
    let current = format!("\"{FORMAT_VERSION}\"");
    assert_eq!(current, "\"2.1.0\"");
    std::fs::write(dir.join(MANIFEST), text.replace(&current, "\"3.1.0\"")).unwrap();
    let e = Bundle::open(&dir).unwrap_err().to_string();
    assert!(
        e.contains("3.1.0") && e.contains("2.1.0") && e.contains("newer"),
        "{e}"
    );

    // A newer minor version with an added field is read.
    let newer_minor =
        text.replace(&current, "\"2.3.0\"")
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

    // So is a stage folder outside the stage's own names, or an asset of another stage.
    std::fs::write(
        dir.join(MANIFEST),
        text.replace("\"radiosity.1\"", "\"srdm.1\""),
    )
    .unwrap();
    let e = Bundle::open(&dir).unwrap_err().to_string();
    assert!(e.contains("corrupt") && e.contains("`dir`"), "{e}");
    std::fs::write(
        dir.join(MANIFEST),
        text.replace("\"radiosity/x.bin\"", "\"srdm/x.bin\""),
    )
    .unwrap();
    let e = Bundle::open(&dir).unwrap_err().to_string();
    assert!(e.contains("corrupt") && e.contains("srdm/x.bin"), "{e}");
}

#[test]
fn bad_stage_and_asset_names_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("g.glint");
    assert!(StageWriter::begin(&dir, "../evil").is_err());
    assert!(StageWriter::begin(&dir, "a/b").is_err());
    assert!(
        StageWriter::begin(&dir, "a.1").is_err(),
        "a '.' would clash with versions"
    );
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
    // An SRDM stage as readers require it: its index lists the view's files.
    let index =
        br#"{"version":1,"colour":"radiosity","settings":{"domains":3,"points":3,"resolution":16},
        "views":[{"impostor":"bunny","view":0,"srdm":"bunny.srdm","capture":"bunny.exr",
        "position":[0,0,1],"forward":[0,0,-1]}]}"#;
    bake(
        &dir,
        "srdm",
        "h",
        &[
            ("index.json", "srdm-index", index),
            ("bunny.srdm", "srdm", &[1u8; 64]),
            ("bunny.exr", "impostor-exr", &[3u8; 16]),
        ],
    )
    .unwrap();
    let total = 1567 + index.len() + 16;
    let d = dir.to_str().unwrap();

    let (code, out, _) = glint_bundle(&["stats", d]);
    assert_eq!(code, 0);
    assert!(
        out.contains("radiosity") && out.contains("radiosity-exr") && out.contains("1500"),
        "{out}"
    );
    assert!(
        out.contains("total") && out.contains(&total.to_string()),
        "{out}"
    );
    assert!(out.contains("texels"), "{out}");

    let (code, out, _) = glint_bundle(&["stats", d, "--json"]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["total"]["bytes"], total);
    assert_eq!(v["total"]["files"], 6);
    assert_eq!(v["stages"][0]["kinds"]["radiosity-exr"]["files"], 2);

    let (code, out, _) = glint_bundle(&["ls", d]);
    assert_eq!(code, 0);
    assert_eq!(out.lines().count(), 2 + 6, "{out}");
    assert!(out.contains("srdm/bunny.srdm"));

    let (code, out, _) = glint_bundle(&["verify", d]);
    assert_eq!(code, 0, "{out}");
    assert!(out.starts_with("ok:"), "{out}");

    let bunny = {
        let b = Bundle::open(&dir).unwrap();
        b.asset_path(b.stage_asset("srdm", "bunny.srdm").unwrap())
    };
    std::fs::write(&bunny, [2u8; 64]).unwrap();
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

#[test]
fn a_folder_that_is_not_a_bundle_is_refused_and_left_alone() {
    let tmp = tempfile::tempdir().unwrap();
    // The user's folder, with a subfolder named like a stage.
    let dir = tmp.path().join("d");
    std::fs::create_dir_all(dir.join("scene")).unwrap();
    std::fs::write(dir.join("scene/notes.txt"), b"x").unwrap();
    let e = bake(&dir, "scene", "h", &[("scene.json", "scene-json", b"{}")]).unwrap_err();
    assert!(matches!(e, BundleError::NotABundle { .. }), "{e}");
    let msg = e.to_string();
    assert!(
        msg.contains(&dir.display().to_string())
            && msg.contains("not a glint bundle")
            && msg.contains("`scene`"),
        "{msg}"
    );
    let e = glint::bundle::check_scene(&dir, "s", "h", true).unwrap_err();
    assert!(matches!(e, BundleError::NotABundle { .. }), "{e}");
    assert_eq!(std::fs::read(dir.join("scene/notes.txt")).unwrap(), b"x");
    assert_eq!(entries(&dir), ["scene"], "nothing added either");

    // A file is refused too.
    let file = tmp.path().join("file.glint");
    std::fs::write(&file, b"mine").unwrap();
    let e = bake(&file, "scene", "h", &[]).unwrap_err();
    assert!(
        matches!(e, BundleError::NotABundle { .. }) && e.to_string().contains("file.glint"),
        "{e}"
    );
    assert_eq!(std::fs::read(&file).unwrap(), b"mine");

    // New, empty, and a folder with only glint's lock and scratch are written.
    for (name, scratch) in [
        ("new", &[][..]),
        ("empty", &[][..]),
        ("killed", &[".lock", ".manifest.json.tmp-17-0"][..]),
    ] {
        let d = tmp.path().join(name);
        if name != "new" {
            std::fs::create_dir(&d).unwrap();
        }
        for s in scratch {
            std::fs::write(d.join(s), b"").unwrap();
        }
        bake(&d, "radiosity", "h", &[("atlas.bin", "atlas", b"{}")]).unwrap();
        assert!(Bundle::open(&d).unwrap().verify().is_empty(), "{name}");
        assert_eq!(
            entries(&d),
            [".lock", "manifest.json", "radiosity.1"],
            "{name}: scratch collected"
        );
    }
}

/// A bundle with `radiosity` holding `old.bin` = "old" and an `srdm` stage, for commits
/// of a new radiosity stage to fail in.
fn bundle_with_old_stage(dir: &Path) {
    bake(dir, "radiosity", "h", &[("old.bin", "atlas", b"old")]).unwrap();
    bake(dir, "srdm", "h", &[("keep.bin", "srdm", b"keep")]).unwrap();
}

/// Checks that the bundle verifies and holds the old radiosity stage (`Some(false)`) or the
/// new one (`Some(true)`), with the srdm stage intact.
fn old_or_new(dir: &Path, label: &str) -> bool {
    let b = Bundle::open(dir).unwrap_or_else(|e| panic!("{label}: {e}"));
    let problems: Vec<String> = b.verify().iter().map(|e| e.to_string()).collect();
    assert!(problems.is_empty(), "{label}: {problems:?}");
    assert_eq!(
        b.read_stage_file("srdm", "keep.bin").unwrap(),
        b"keep",
        "{label}"
    );
    let old = b.read_stage_file("radiosity", "old.bin").ok();
    let new = b.read_stage_file("radiosity", "new.bin").ok();
    match (old.as_deref(), new.as_deref()) {
        (Some(b"old"), None) => false,
        (None, Some(b"new")) => true,
        other => panic!("{label}: neither the old stage nor the new one: {other:?}"),
    }
}

/// Commits the new radiosity stage (`new.bin` = "new") with `hook`.
fn commit_new(dir: &Path, hook: glint::bundle::FaultHook) -> Result<(), BundleError> {
    let mut w = StageWriter::begin(dir, "radiosity")
        .unwrap()
        .with_fault_hook(hook);
    w.write("new.bin", "atlas", b"new").unwrap();
    w.commit(info("h")).map(|_| ())
}

/// The steps of a clean commit of the new stage over the old one.
fn commit_steps() -> Vec<CommitStep> {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("steps.glint");
    bundle_with_old_stage(&dir);
    let steps = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let seen = steps.clone();
    commit_new(
        &dir,
        Box::new(move |s| {
            seen.lock().unwrap().push(s);
            Ok(())
        }),
    )
    .unwrap();
    assert!(old_or_new(&dir, "clean commit"));
    std::mem::take(&mut *steps.lock().unwrap())
}

#[test]
fn a_failure_at_any_commit_step_leaves_the_old_stage_or_the_new_one() {
    let steps = commit_steps();
    // Every step of the commit, the collection of the replaced folder included.
    for s in [
        CommitStep::OpenLock,
        CommitStep::Lock,
        CommitStep::ReadManifest,
        CommitStep::ListBundle,
        CommitStep::SyncStage,
        CommitStep::RenameStage,
        CommitStep::SyncBundle,
        CommitStep::CreateManifest,
        CommitStep::WriteManifest,
        CommitStep::RenameManifest,
        CommitStep::SyncCommit,
        CommitStep::Collect,
    ] {
        assert!(steps.contains(&s), "{s:?} not in {steps:?}");
    }
    let commit_at = steps
        .iter()
        .position(|s| *s == CommitStep::RenameManifest)
        .unwrap();
    for (k, &step) in steps.iter().enumerate() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("f.glint");
        bundle_with_old_stage(&dir);
        let mut n = 0;
        let result = commit_new(
            &dir,
            Box::new(move |_| {
                n += 1;
                if n == k + 1 {
                    Err(std::io::Error::other("injected fault"))
                } else {
                    Ok(())
                }
            }),
        );
        let label = format!("fault at step {k} ({step:?})");
        let new = old_or_new(&dir, &label);
        // Up to the manifest's rename the old stage stays; after it the new one is in.
        assert_eq!(new, k > commit_at, "{label}");
        match step {
            // The commit happened; only the leftovers' collection failed.
            CommitStep::Collect => result.unwrap(),
            _ => assert!(
                result.unwrap_err().to_string().contains("injected fault"),
                "{label}"
            ),
        }
        // A failed commit leaves at most an unnamed folder, and the next commit (of any
        // stage) collects it.
        bake(&dir, "srdm", "h", &[("keep.bin", "srdm", b"keep")]).unwrap();
        let folder = |s: &str| {
            let b = Bundle::open(&dir).unwrap();
            b.stage(s).unwrap().dir.clone().unwrap()
        };
        let mut expect = vec![
            ".lock".to_string(),
            MANIFEST.to_string(),
            folder("radiosity"),
            folder("srdm"),
        ];
        expect.sort();
        assert_eq!(entries(&dir), expect, "{label}");
    }
}

#[test]
fn a_writer_killed_at_any_commit_step_leaves_the_old_stage_or_the_new_one() {
    // The child: commit the new stage and abort the process at step K (no unwinding, no
    // clean-up: what a kill -9 or a power cut leaves, bar unflushed data).
    if let Ok(k) = std::env::var("GLINT_TEST_CRASH_STEP") {
        let k: usize = k.parse().unwrap();
        let dir = std::env::var("GLINT_TEST_CRASH_DIR").unwrap();
        let mut n = 0;
        let _ = commit_new(
            Path::new(&dir),
            Box::new(move |_| {
                n += 1;
                if n == k + 1 {
                    std::process::abort();
                }
                Ok(())
            }),
        );
        std::process::exit(0);
    }
    let steps = commit_steps();
    let commit_at = steps
        .iter()
        .position(|s| *s == CommitStep::RenameManifest)
        .unwrap();
    let exe = std::env::current_exe().unwrap();
    for (k, &step) in steps.iter().enumerate() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("k.glint");
        bundle_with_old_stage(&dir);
        let status = Command::new(&exe)
            .args([
                "--exact",
                "a_writer_killed_at_any_commit_step_leaves_the_old_stage_or_the_new_one",
                "--nocapture",
            ])
            .env("GLINT_TEST_CRASH_STEP", k.to_string())
            .env("GLINT_TEST_CRASH_DIR", &dir)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .unwrap();
        let label = format!("killed at step {k} ({step:?})");
        assert!(!status.success(), "{label}: the child was not killed");
        let new = old_or_new(&dir, &label);
        assert_eq!(new, k > commit_at, "{label}");
        // The killed writer's leftovers (its temporary or unnamed folder) go at the next
        // commit; a bundle killed before its commit can be committed into again.
        bake(&dir, "srdm", "h", &[("keep.bin", "srdm", b"keep")]).unwrap();
        let left: Vec<String> = entries(&dir)
            .into_iter()
            .filter(|n| {
                n.contains(".tmp-")
                    || (n.starts_with("radiosity.") && {
                        let b = Bundle::open(&dir).unwrap();
                        b.stage("radiosity").unwrap().dir.as_deref() != Some(n.as_str())
                    })
            })
            .collect();
        assert!(left.is_empty(), "{label}: left behind {left:?}");
        assert_eq!(old_or_new(&dir, &label), new, "{label}");
    }
}

#[test]
fn readers_never_see_a_half_committed_stage() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("r.glint");
    let page = |i: usize| vec![(i % 251) as u8; 64 * 1024];
    bake(
        &dir,
        "radiosity",
        "h",
        &[("page.exr", "radiosity-exr", &page(0))],
    )
    .unwrap();
    let done = std::sync::atomic::AtomicBool::new(false);
    let (reads, failures) = std::thread::scope(|s| {
        let reader = s.spawn(|| {
            let (mut reads, mut failures) = (0, Vec::new());
            while !done.load(std::sync::atomic::Ordering::Relaxed) {
                let b = Bundle::open(&dir).unwrap();
                failures.extend(b.verify().iter().map(|e| e.to_string()));
                // The stage read through this one manifest is whole.
                let bytes = b.read_stage_file("radiosity", "page.exr").unwrap();
                assert!(bytes.iter().all(|&v| v == bytes[0]));
                reads += 1;
            }
            (reads, failures)
        });
        for i in 1..=60 {
            bake(
                &dir,
                "radiosity",
                "h",
                &[
                    ("page.exr", "radiosity-exr", &page(i)),
                    ("more.bin", "atlas", &page(i + 1)),
                ],
            )
            .unwrap();
        }
        done.store(true, std::sync::atomic::Ordering::Relaxed);
        reader.join().unwrap()
    });
    assert!(
        failures.is_empty(),
        "{} failed reads: {failures:?}",
        failures.len()
    );
    assert!(reads >= 5, "only {reads} reads overlapped the commits");
    // Replaced versions are collected once no reader holds them.
    bake(
        &dir,
        "radiosity",
        "h",
        &[("page.exr", "radiosity-exr", b"x")],
    )
    .unwrap();
    assert_eq!(entries(&dir), [".lock", "manifest.json", "radiosity.62"]);
}

#[test]
fn a_reader_keeps_its_version_until_it_lets_go() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("pin.glint");
    bake(&dir, "radiosity", "h", &[("x.bin", "atlas", b"one")]).unwrap();
    let reader = Bundle::open(&dir).unwrap();
    bake(&dir, "radiosity", "h", &[("x.bin", "atlas", b"two")]).unwrap();
    bake(&dir, "srdm", "h", &[("y.bin", "srdm", b"y")]).unwrap();
    // The reader still reads the version its manifest names; a new reader the new one.
    assert_eq!(
        reader.read_stage_file("radiosity", "x.bin").unwrap(),
        b"one"
    );
    assert!(reader.verify().is_empty());
    let now = Bundle::open(&dir).unwrap();
    assert_eq!(now.read_stage_file("radiosity", "x.bin").unwrap(), b"two");
    assert!(entries(&dir).contains(&"radiosity.1".to_string()));
    drop((reader, now));
    bake(&dir, "srdm", "h", &[("y.bin", "srdm", b"y2")]).unwrap();
    assert_eq!(
        entries(&dir),
        [".lock", "manifest.json", "radiosity.2", "srdm.2"],
        "collected once released"
    );
}

#[test]
fn leftovers_are_collected_but_a_live_writer_is_not() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("gc.glint");
    bake(&dir, "radiosity", "h", &[("x.bin", "atlas", b"x")]).unwrap();
    // What killed writers leave: temporary folders and manifests, a version-1 writer's
    // replaced folder, a versioned folder never committed.
    for d in [".radiosity.tmp-99999-0", ".srdm.old-99999-1", "radiosity.7"] {
        std::fs::create_dir_all(dir.join(d).join("sub")).unwrap();
        std::fs::write(dir.join(d).join("sub/f"), b"f").unwrap();
    }
    std::fs::write(dir.join(".manifest.json.tmp-99999-2"), b"{").unwrap();
    // A writer at work, and a file of the user's that looks like nothing of glint's.
    let mut live = StageWriter::begin(&dir, "materials").unwrap();
    live.write("k.exr", "kernel", b"k").unwrap();
    std::fs::write(dir.join("notes.txt"), b"mine").unwrap();

    bake(&dir, "srdm", "h", &[("y.bin", "srdm", b"y")]).unwrap();
    let names = entries(&dir);
    let live_tmp: Vec<&String> = names
        .iter()
        .filter(|n| n.starts_with(".materials.tmp-"))
        .collect();
    assert_eq!(
        live_tmp.len(),
        1,
        "the live writer's folder stays: {names:?}"
    );
    assert_eq!(
        names
            .iter()
            .filter(|n| !n.starts_with(".materials.tmp-"))
            .collect::<Vec<_>>(),
        [
            ".lock",
            "manifest.json",
            "notes.txt",
            "radiosity.1",
            "srdm.1"
        ]
    );
    live.commit(info("h")).unwrap();
    let b = Bundle::open(&dir).unwrap();
    assert!(b.verify().is_empty());
    assert_eq!(b.read_stage_file("materials", "k.exr").unwrap(), b"k");
    drop(b);
    bake(&dir, "radiosity", "h", &[("x.bin", "atlas", b"x2")]).unwrap();
    assert_eq!(
        entries(&dir),
        [
            ".lock",
            "manifest.json",
            "materials.1",
            "notes.txt",
            "radiosity.2",
            "srdm.1"
        ]
    );
    assert_eq!(std::fs::read(dir.join("notes.txt")).unwrap(), b"mine");
}

#[test]
fn a_stage_read_and_replaced_before_the_commit_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("src.glint");
    bake(&dir, "radiosity", "h", &[("d.exr", "radiosity-exr", b"D1")]).unwrap();
    let read = Bundle::open(&dir)
        .unwrap()
        .stage("radiosity")
        .unwrap()
        .identity();
    let mut w = StageWriter::begin(&dir, "radiance").unwrap();
    w.read_from("radiosity", &read);
    w.write("m.exr", "radiance-exr", b"shaded with D1").unwrap();
    // Another baker commits a new D meanwhile.
    bake(&dir, "radiosity", "h", &[("d.exr", "radiosity-exr", b"D2")]).unwrap();
    let e = w.commit(info("h")).unwrap_err();
    assert!(matches!(e, BundleError::SourceChanged { .. }), "{e}");
    assert!(
        e.to_string().contains("`radiosity`") && e.to_string().contains("re-baked"),
        "{e}"
    );
    let b = Bundle::open(&dir).unwrap();
    assert!(b.stage("radiance").is_none(), "nothing committed");
    assert!(b.verify().is_empty());

    // Read from the current D, the commit goes through.
    let mut w = StageWriter::begin(&dir, "radiance").unwrap();
    w.read_from("radiosity", &b.stage("radiosity").unwrap().identity());
    w.write("m.exr", "radiance-exr", b"shaded with D2").unwrap();
    w.commit(info("h")).unwrap();
}

#[test]
fn version_1_bundles_are_read_and_upgraded_by_the_next_commit() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("v1.glint");
    std::fs::create_dir_all(dir.join("radiosity")).unwrap();
    std::fs::create_dir_all(dir.join("srdm")).unwrap();
    std::fs::write(dir.join("radiosity/x.bin"), b"v1 x").unwrap();
    std::fs::write(dir.join("srdm/y.bin"), b"v1 y").unwrap();
    let asset = |path: &str, bytes: &[u8]| {
        serde_json::json!({ "path": path, "kind": "atlas", "bytes": bytes.len(),
            "blake3": blake3::hash(bytes).to_hex().to_string() })
    };
    let stage = |a: serde_json::Value| {
        serde_json::json!({ "generator": "glint 0.1.0", "scene_hash": "h", "settings": {},
            "bake_seconds": 1.0, "assets": [a] })
    };
    let v1 = serde_json::json!({
        "format": "glint-bundle", "format_version": "1.0.0", "generator": "glint 0.1.0",
        "scene_name": "test", "scene_hash": "h",
        "stages": { "radiosity": stage(asset("radiosity/x.bin", b"v1 x")),
                    "srdm": stage(asset("srdm/y.bin", b"v1 y")) },
    });
    std::fs::write(dir.join(MANIFEST), v1.to_string()).unwrap();
    let b = Bundle::open(&dir).unwrap();
    assert!(b.verify().is_empty());
    assert_eq!(b.read_stage_file("radiosity", "x.bin").unwrap(), b"v1 x");
    drop(b);

    bake(&dir, "radiosity", "h", &[("x.bin", "atlas", b"v2 x")]).unwrap();
    let b = Bundle::open(&dir).unwrap();
    assert_eq!(b.manifest().format_version, FORMAT_VERSION.to_string());
    assert_eq!(b.read_stage_file("radiosity", "x.bin").unwrap(), b"v2 x");
    assert_eq!(
        b.read_stage_file("srdm", "y.bin").unwrap(),
        b"v1 y",
        "kept as it was"
    );
    assert!(b.verify().is_empty());
    assert_eq!(
        entries(&dir),
        [".lock", "manifest.json", "radiosity.1", "srdm"],
        "the replaced version-1 folder is collected"
    );
}

#[test]
fn glint_bundle_stats_warns_about_missing_or_resized_assets() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("s.glint");
    bake(
        &dir,
        "radiosity",
        "h",
        &[
            ("a.bin", "atlas", b"aaaa"),
            ("b.bin", "atlas", b"bbbb"),
            ("c.bin", "atlas", b"cccc"),
        ],
    )
    .unwrap();
    let d = dir.to_str().unwrap();
    let (code, out, err) = glint_bundle(&["stats", d]);
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("warning"), "{err}");
    let (a, b) = {
        let bundle = Bundle::open(&dir).unwrap();
        let path = |rel| bundle.asset_path(bundle.stage_asset("radiosity", rel).unwrap());
        (path("a.bin"), path("b.bin"))
    };
    std::fs::remove_file(&a).unwrap();
    std::fs::write(&b, b"bb").unwrap();
    let (code, out2, err) = glint_bundle(&["stats", d]);
    assert_eq!(code, 1, "damage is an exit status: {err}");
    assert!(out2.contains("total"), "the table is still printed: {out2}");
    assert!(
        err.contains("warning") && err.contains("a.bin") && err.contains("missing"),
        "{err}"
    );
    assert!(
        err.contains("b.bin") && err.contains("2 bytes") && err.contains("4"),
        "{err}"
    );
    assert!(err.contains("2 of 3 assets"), "{err}");
    assert!(!err.contains("c.bin"), "{err}");
    let _ = out;

    let (code, out, _) = glint_bundle(&["stats", d, "--json"]);
    assert_eq!(code, 1);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let damaged = v["damaged"].as_array().unwrap();
    assert_eq!(damaged.len(), 2, "{v}");
    assert!(
        damaged.iter().any(|p| p["path"] == "radiosity/a.bin"
            && p["problem"].as_str().unwrap().contains("missing"))
    );
}

#[test]
fn verify_refuses_every_manifest_the_viewer_refuses() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("m.glint");
    bake(
        &dir,
        "radiosity",
        "h",
        &[("a.bin", "atlas", b"a"), ("p.exr", "radiosity-exr", b"p")],
    )
    .unwrap();
    let good: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join(MANIFEST)).unwrap()).unwrap();
    type Edit = fn(&mut serde_json::Value);
    let edits: [(&str, Edit, &str); 7] = [
        (
            "stages renamed",
            |m| {
                let s = m.as_object_mut().unwrap().remove("stages").unwrap();
                m["stagus"] = s;
            },
            "unknown field `stagus`",
        ),
        (
            "stages missing",
            |m| {
                m.as_object_mut().unwrap().remove("stages");
            },
            "missing field `stages`",
        ),
        (
            "unknown asset key",
            |m| m["stages"]["radiosity"]["assets"][0]["blake"] = true.into(),
            "unknown field `blake`",
        ),
        (
            "unknown stage key",
            |m| m["stages"]["radiosity"]["folder"] = "radiosity.1".into(),
            "unknown field `folder`",
        ),
        (
            "duplicate asset path",
            |m| {
                let assets = m["stages"]["radiosity"]["assets"].as_array_mut().unwrap();
                assets[1] = assets[0].clone();
            },
            "listed twice",
        ),
        (
            "unknown asset kind",
            |m| m["stages"]["radiosity"]["assets"][0]["kind"] = "atlass".into(),
            "field `kind` is \"atlass\"",
        ),
        (
            "non-hex BLAKE3",
            |m| {
                m["stages"]["radiosity"]["assets"][0]["blake3"] = "zz".repeat(32).into();
            },
            "not a valid BLAKE3 hex digest",
        ),
    ];
    for (what, edit, expect) in edits {
        let mut m = good.clone();
        edit(&mut m);
        std::fs::write(dir.join(MANIFEST), serde_json::to_vec_pretty(&m).unwrap()).unwrap();
        let (code, out, err) = glint_bundle(&["verify", dir.to_str().unwrap()]);
        assert_eq!(code, 1, "{what}: verify accepted it:\n{out}{err}");
        assert!(
            err.contains("manifest.json") && err.contains(expect),
            "{what}: verify says:\n{out}{err}"
        );
        let e = Bundle::open(&dir).unwrap_err().to_string();
        assert!(e.contains(expect), "{what}: {e}");
        #[cfg(feature = "view")]
        {
            let e = glint::view::load::load(&dir).unwrap_err().to_string();
            assert!(e.contains(expect), "{what}: the viewer says {e}");
        }
    }
    // A newer minor version may add keys and kinds: they are passed over.
    let mut m = good.clone();
    m["format_version"] = "2.9.0".into();
    m["added_later"] = true.into();
    m["stages"]["radiosity"]["added_later"] = true.into();
    m["stages"]["radiosity"]["assets"][0]["added_later"] = true.into();
    m["stages"]["radiosity"]["assets"][0]["kind"] = "added-later".into();
    std::fs::write(dir.join(MANIFEST), serde_json::to_vec_pretty(&m).unwrap()).unwrap();
    let (code, out, err) = glint_bundle(&["verify", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{out}{err}");
}
