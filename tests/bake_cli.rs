//! `glint-bake` round trips: what it writes, what it skips, and that a bad scene writes nothing.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use common::*;
use glint::bake::materials;
use glint::bake::{BakeSettings, Stage, StageStatus, bake_all, radiance_stage, radiosity_stage};
use glint::bundle::Bundle;
use glint::progress::{Progress, Silent};
use glint::scene::{Quality, Scene};

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
    let copy = glint::scene::Scene::load(
        opened.asset_path(opened.stage_asset("scene", "scene.json").unwrap()),
    )
    .unwrap();
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
    let scene = lit_floor(dir.path());
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

/// Runs a glint binary by name.
fn glint(bin: &str, args: &[&str]) -> (i32, String, String) {
    let exe = Path::new(env!("CARGO_BIN_EXE_glint-bake")).with_file_name(bin);
    let out = Command::new(exe).args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The room with a glossy planar panel, and a tiny impostor setting for glint-srdm.
fn room_scene(dir: &Path, extra: &str) -> PathBuf {
    write_room(dir);
    write_scene(
        dir,
        &format!(
            r#"{{ "version": 1, "geometry": "room.gltf", "reflectors": [ {{ "mesh": "Panel", "kind": "planar" }} ]{extra} }}"#
        ),
    )
}

#[test]
fn every_baker_refuses_a_folder_that_is_not_a_bundle_and_deletes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let scene = room_scene(
        dir.path(),
        r#", "impostors": [ { "mesh": "Floor" } ], "bake": { "srdm": { "resolution": 8, "domains": 2, "points": 2 } }"#,
    );
    let s = scene.to_str().unwrap();
    // The user's folder, with subfolders named like every stage.
    let mine = dir.path().join("d");
    for stage in ["scene", "radiosity", "materials", "radiance", "srdm"] {
        std::fs::create_dir_all(mine.join(stage)).unwrap();
        std::fs::write(mine.join(stage).join("notes.txt"), stage).unwrap();
    }
    let snapshot = |d: &Path| {
        let mut all = Vec::new();
        for e in std::fs::read_dir(d).unwrap() {
            let e = e.unwrap();
            for f in std::fs::read_dir(e.path()).unwrap() {
                let f = f.unwrap();
                all.push((f.path(), std::fs::read(f.path()).unwrap()));
            }
        }
        all.sort();
        all
    };
    let before = snapshot(&mine);
    let m = mine.to_str().unwrap();
    for bin in [
        "glint-bake",
        "glint-radiosity",
        "glint-materials",
        "glint-radiance",
        "glint-srdm",
    ] {
        let (code, out, err) = glint(bin, &[s, "--bundle", m]);
        assert_ne!(code, 0, "{bin}: {out}");
        assert!(
            err.contains(m) && err.contains("not a glint bundle"),
            "{bin}: {err}"
        );
        assert_eq!(snapshot(&mine), before, "{bin} changed the folder");
        assert_eq!(
            std::fs::read_dir(&mine).unwrap().count(),
            5,
            "{bin} added to the folder"
        );
    }
}

/// Records the phases begun, and on the first unit of work runs `midway` (once).
struct Midway<'a> {
    phases: Mutex<Vec<String>>,
    fired: AtomicBool,
    midway: Box<dyn Fn() + Sync + 'a>,
}

impl<'a> Midway<'a> {
    fn new(midway: impl Fn() + Sync + 'a) -> Midway<'a> {
        Midway {
            phases: Mutex::new(Vec::new()),
            fired: AtomicBool::new(false),
            midway: Box::new(midway),
        }
    }
}

impl Progress for Midway<'_> {
    fn phase(&self, name: &str, _: u64) {
        self.phases.lock().unwrap().push(name.into());
    }
    fn advance(&self, _: u64) {
        if !self.fired.swap(true, Ordering::SeqCst) {
            (self.midway)();
        }
    }
}

fn status(report: &[glint::bake::StageReport], stage: Stage) -> StageStatus {
    report
        .iter()
        .find(|r| r.plan.stage == stage)
        .unwrap()
        .status
        .clone()
}

#[test]
fn a_stage_shaded_with_a_d_replaced_meanwhile_is_refused_and_stays_stale() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::load(room_scene(dir.path(), "")).unwrap();
    let bundle = dir.path().join("race.glint");
    let first = BakeSettings::resolve(&scene, Quality::Draft).unwrap();
    bake_all(&scene, &bundle, &first, false, &Silent).unwrap();
    let mut second = first.clone();
    // A different D: another atlas (D here is the ceiling's emission and light that does not
    // depend on the sample counts; without the scene-size minimum, which sets this small room's
    // density, the per-metre density decides).
    second.radiosity.min_scene_texels = 0;
    second.radiosity.texel_density *= 1.5;
    {
        // Another baker commits a new D while the radiance maps are being shaded with the old.
        let race = Midway::new(|| {
            radiosity_stage::bake(&scene, &bundle, &second.radiosity, false, &Silent).unwrap();
        });
        let e = radiance_stage::bake(&scene, &bundle, Quality::Draft, false, &race).unwrap_err();
        assert!(race.fired.load(Ordering::SeqCst));
        let msg = e.to_string();
        assert!(
            msg.contains("`radiosity`") && msg.contains("re-baked") && msg.contains("race.glint"),
            "{msg}"
        );
    }
    // The same race against the materials stage (its d_source is D's identity too).
    second.radiosity.texel_density *= 1.5;
    {
        let race = Midway::new(|| {
            radiosity_stage::bake(&scene, &bundle, &second.radiosity, false, &Silent).unwrap();
        });
        let e = materials::bake(&scene, &bundle, &first.materials, false, &race).unwrap_err();
        assert!(race.fired.load(Ordering::SeqCst));
        assert!(e.to_string().contains("re-baked"), "{e}");
    }

    // glint-bake with the new D's settings: D is up to date, the maps and materials are not.
    let report = bake_all(&scene, &bundle, &second, false, &Silent).unwrap();
    assert_eq!(status(&report, Stage::Radiosity), StageStatus::UpToDate);
    assert!(
        matches!(status(&report, Stage::Radiance), StageStatus::Baked { .. }),
        "{report:?}"
    );
    assert!(
        matches!(status(&report, Stage::Materials), StageStatus::Baked { .. }),
        "{report:?}"
    );
    // Now they record the D they were shaded with, and are up to date.
    let b = Bundle::open(&bundle).unwrap();
    let d = b.stage("radiosity").unwrap().identity();
    assert_eq!(
        b.stage("radiance").unwrap().settings["d_source"],
        d.as_str()
    );
    assert_eq!(
        b.stage("materials").unwrap().settings["d_source"],
        d.as_str()
    );
    drop(b);
    let report = bake_all(&scene, &bundle, &second, false, &Silent).unwrap();
    assert_eq!(status(&report, Stage::Radiance), StageStatus::UpToDate);
}

#[test]
fn a_bundle_that_cannot_be_written_fails_before_the_compute() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::load(room_scene(dir.path(), "")).unwrap();
    let settings = BakeSettings::resolve(&scene, Quality::Draft).unwrap();

    // Under a file: the folder cannot be made.
    let file = dir.path().join("file.txt");
    std::fs::write(&file, b"x").unwrap();
    let bad = file.join("out.glint");
    let p = Midway::new(|| {});
    let e = radiosity_stage::bake(&scene, &bad, &settings.radiosity, false, &p).unwrap_err();
    assert!(e.to_string().contains("file.txt"), "{e}");
    assert!(p.phases.lock().unwrap().is_empty(), "computed first");

    // A bundle whose lock cannot be taken (a folder in its place: refused even to root).
    let bundle = dir.path().join("ro.glint");
    bake_all(&scene, &bundle, &settings, false, &Silent).unwrap();
    std::fs::remove_file(bundle.join(".lock")).unwrap();
    std::fs::create_dir(bundle.join(".lock")).unwrap();
    let expect_fast = |what: &str, e: String, p: &Midway| {
        assert!(e.contains("ro.glint") && e.contains(".lock"), "{what}: {e}");
        assert!(
            p.phases.lock().unwrap().is_empty(),
            "{what}: computed before finding the bundle unwritable: {:?}",
            p.phases.lock().unwrap()
        );
    };
    let p = Midway::new(|| {});
    let e = radiosity_stage::bake(&scene, &bundle, &settings.radiosity, true, &p).unwrap_err();
    expect_fast("radiosity", e.to_string(), &p);
    let p = Midway::new(|| {});
    let e = radiance_stage::bake(&scene, &bundle, Quality::Draft, true, &p).unwrap_err();
    expect_fast("radiance", e.to_string(), &p);
    let p = Midway::new(|| {});
    let e = materials::bake(&scene, &bundle, &settings.materials, true, &p).unwrap_err();
    expect_fast("materials", e.to_string(), &p);
    // The bundle is as it was.
    std::fs::remove_dir(bundle.join(".lock")).unwrap();
    assert!(Bundle::open(&bundle).unwrap().verify().is_empty());
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

/// A bundle path that is not UTF-8 is written lossily in the JSON reports: `glint-bake
/// --json` panicked after committing, `glint-materials --json` on its skip.
#[test]
fn json_reports_write_a_bundle_path_that_is_not_utf8_lossily() {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    let scene = lit_floor(dir.path());
    let bundle = dir.path().join(OsStr::from_bytes(b"out-\xff.glint"));
    let exe = Path::new(env!("CARGO_BIN_EXE_glint-bake"));
    for bin in ["glint-bake", "glint-materials"] {
        let out = Command::new(exe.with_file_name(bin))
            .arg(&scene)
            .arg("--bundle")
            .arg(&bundle)
            .arg("--json")
            .output()
            .unwrap();
        let (stdout, stderr) = (
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
        assert_eq!(out.status.code(), Some(0), "{bin}: {stderr}");
        let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        let written = v["bundle"].as_str().unwrap();
        assert!(written.ends_with("out-\u{fffd}.glint"), "{bin}: {written}");
    }
    assert!(Bundle::open(&bundle).unwrap().verify().is_empty());
}

/// A `--bundle` that is a symbolic link to nothing, or below a file, is refused saying so,
/// not with a bare "File exists (os error 17)"; `--units` the same.
#[test]
fn a_bundle_path_blocked_by_a_dangling_link_or_a_file_says_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let scene = lit_floor(dir.path());
    let link = dir.path().join("link.glint");
    std::os::unix::fs::symlink(dir.path().join("gone/x.glint"), &link).unwrap();
    let file = dir.path().join("file");
    std::fs::write(&file, b"not a folder").unwrap();
    let s = scene.to_str().unwrap();
    for (args, says) in [
        (
            ["--bundle", link.to_str().unwrap()],
            "link.glint: not a glint bundle: it is a symbolic link to ",
        ),
        (
            ["--bundle", file.join("b.glint").to_str().unwrap()],
            "file (above it) is a file, not a folder",
        ),
        (
            ["--units", link.to_str().unwrap()],
            "link.glint: it is a symbolic link to ",
        ),
    ] {
        let (code, _, err) = glint_bake(&[s, args[0], args[1]]);
        assert_eq!(code, 1, "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!err.contains("os error"), "{args:?}: {err}");
    }
    assert!(!dir.path().join("gone").exists());
    assert_eq!(std::fs::read(&file).unwrap(), b"not a folder");
}
