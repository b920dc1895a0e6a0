//! Work units: `glint-bake --plan / --unit / --units` and `glint-bundle merge`. A sharded
//! bake of glossy-room (every kind of unit: scene, radiosity, materials, an environment map,
//! radiance maps, an impostor) gives the same assets as a whole bake; a failed or killed
//! unit leaves a shard the merge refuses by name, and rerunning that unit fixes it; a
//! change re-bakes only the units whose inputs it touches.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use common::*;
use glint::scene::Quality;

fn run(bin: &str, args: &[&str]) -> (i32, String, String) {
    common::run_exe(bin, args)
}

fn bake(args: &[&str]) -> (i32, String, String) {
    run(env!("CARGO_BIN_EXE_glint-bake"), args)
}

fn bundle_tool(args: &[&str]) -> (i32, String, String) {
    run(env!("CARGO_BIN_EXE_glint-bundle"), args)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Bakes `scene`'s draft radiosity unit into the shard `bundle`.
fn radiosity_unit(scene: &Path, bundle: &Path) -> (i32, String, String) {
    bake(&[
        s(scene),
        "--quality",
        "draft",
        "--unit",
        "radiosity",
        "--bundle",
        s(bundle),
    ])
}

/// glossy-room's folder copied (so tests may edit its scene.json) and every unit baked at
/// draft into `shards/`, once per test binary; tests copy both before changing anything.
fn pristine() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap().keep();
        copy_dir(&repo("scenes/glossy-room"), &dir.join("scene"));
        let scene = dir.join("scene/scene.json");
        let (code, _, err) = bake(&[
            s(&scene),
            "--quality",
            "draft",
            "--units",
            s(&dir.join("shards")),
        ]);
        assert_eq!(code, 0, "{err}");
        dir
    })
}

/// A private copy of [`pristine`]: (root, scene.json, shards folder).
fn copy_of_pristine(root: &Path) -> (PathBuf, PathBuf) {
    copy_dir(pristine(), root);
    (root.join("scene/scene.json"), root.join("shards"))
}

fn shards_of(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path().to_str().unwrap().to_string())
        .collect();
    v.sort();
    v
}

/// Per stage: (settings, every asset's path, kind, size and BLAKE3 in manifest order).
type Stages = BTreeMap<String, (serde_json::Value, Vec<(String, String, u64, String)>)>;

fn stages(bundle: &Path) -> Stages {
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(bundle.join("manifest.json")).unwrap()).unwrap();
    m["stages"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(name, r)| {
            let assets = r["assets"]
                .as_array()
                .unwrap()
                .iter()
                .map(|a| {
                    (
                        a["path"].as_str().unwrap().to_string(),
                        a["kind"].as_str().unwrap().to_string(),
                        a["bytes"].as_u64().unwrap(),
                        a["blake3"].as_str().unwrap().to_string(),
                    )
                })
                .collect();
            (name.clone(), (r["settings"].clone(), assets))
        })
        .collect()
}

fn whole_bake() -> PathBuf {
    shipped_bundle(&Recipe::every_needed_stage("glossy-room", Quality::Draft))
}

fn assert_same_as_whole(merged: &Path) {
    let (whole, merged_stages) = (stages(&whole_bake()), stages(merged));
    assert_eq!(
        whole.keys().collect::<Vec<_>>(),
        merged_stages.keys().collect::<Vec<_>>(),
        "stages"
    );
    for (name, (settings, assets)) in &whole {
        let (m_settings, m_assets) = &merged_stages[name];
        assert_eq!(settings, m_settings, "stage {name}: settings");
        assert_eq!(assets.len(), m_assets.len(), "stage {name}: asset count");
        for (a, b) in assets.iter().zip(m_assets) {
            assert_eq!(a, b, "stage {name}: asset");
        }
    }
    let (code, out, _) = bundle_tool(&["verify", s(merged)]);
    assert_eq!(code, 0, "{out}");
}

#[test]
fn the_plan_lists_every_unit_with_its_inputs_cost_and_wave() {
    let scene = repo("scenes/glossy-room/scene.json");
    let (code, out, err) = bake(&[s(&scene), "--plan", "--json", "--quality", "draft"]);
    assert_eq!(code, 0, "{err}");
    let plan: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(plan["format"], "glint-units");
    let units = plan["units"].as_array().unwrap();
    let ids: Vec<&str> = units.iter().map(|u| u["id"].as_str().unwrap()).collect();
    assert_eq!(
        ids,
        [
            "scene",
            "gather.0",
            "gather.1",
            "radiosity",
            "material.GlossyFloor",
            "material.Mirror",
            "material.GlossyTable",
            "material.PolishedMetal",
            "envmap.Teapot",
            "radiance.Floor",
            "radiance.MirrorPanel",
            "radiance.TableTop",
            "srdm.TableTop"
        ]
    );
    let mut keys = std::collections::BTreeSet::new();
    for u in units {
        let inputs = u["inputs"].as_object().unwrap();
        assert!(!inputs.is_empty(), "{u}");
        for (name, h) in inputs {
            let h = h.as_str().unwrap();
            assert!(
                h.len() == 64 && h.bytes().all(|b| b.is_ascii_hexdigit()),
                "{}: input {name} is not a BLAKE3: {h}",
                u["id"]
            );
        }
        assert!(u["cost"].as_f64().unwrap() > 0.0, "{u}");
        assert!(keys.insert(u["key"].as_str().unwrap().to_string()), "{u}");
        // The radiosity unit reads the gathering units' shards, the units that read D wait
        // for it, and the others read no unit.
        let id = u["id"].as_str().unwrap();
        let reads_d = ["envmap", "radiance", "srdm"]
            .iter()
            .any(|k| id.starts_with(k));
        let reads: Vec<&str> = u["depends_on"]
            .as_array()
            .map(|d| d.iter().map(|x| x.as_str().unwrap()).collect())
            .unwrap_or_default();
        let (wave, want): (u64, Vec<&str>) = if reads_d {
            (2, vec!["radiosity"])
        } else if id == "radiosity" {
            (1, vec!["gather.0", "gather.1"])
        } else {
            (0, vec![])
        };
        assert_eq!(u["wave"], wave, "{u}");
        assert_eq!(reads, want, "{u}");
    }
    // The ray-heavy units cost more than the table lookups of the scene copy.
    let cost = |id: &str| {
        units.iter().find(|u| u["id"] == id).unwrap()["cost"]
            .as_f64()
            .unwrap()
    };
    assert!(
        cost("radiosity") > cost("radiance.TableTop") && cost("radiance.TableTop") > cost("scene")
    );
    for wave in [0u64, 1, 2] {
        let w = wave.to_string();
        let (code, out, err) = bake(&[s(&scene), "--plan", "--wave", &w, "--quality", "draft"]);
        assert_eq!(code, 0, "{err}");
        let want: Vec<&str> = units
            .iter()
            .filter(|u| u["wave"] == wave)
            .map(|u| u["id"].as_str().unwrap())
            .collect();
        assert_eq!(out.lines().collect::<Vec<_>>(), want, "wave {wave}");
    }
}

/// `--plan --wave N` past the plan's last wave is an error naming the wave count (it printed
/// nothing and exited 0, which a wave-by-wave script reads as an empty wave).
#[test]
fn a_wave_past_the_plan_is_an_error_naming_the_wave_count() {
    let scene = repo("scenes/glossy-room/scene.json");
    let (code, out, err) = bake(&[s(&scene), "--plan", "--json", "--quality", "draft"]);
    assert_eq!(code, 0, "{err}");
    let plan: serde_json::Value = serde_json::from_str(&out).unwrap();
    let waves = plan["units"]
        .as_array()
        .unwrap()
        .iter()
        .map(|u| u["wave"].as_u64().unwrap() + 1)
        .max()
        .unwrap();
    let (code, out, err) = bake(&[s(&scene), "--plan", "--wave", "7", "--quality", "draft"]);
    assert_eq!((code, out.as_str()), (1, ""), "{err}");
    assert!(
        err.contains(&format!(
            "--wave 7: the plan has {waves} waves, numbered 0 to {}",
            waves - 1
        )),
        "{err}"
    );
    let last = (waves - 1).to_string();
    let (code, out, err) = bake(&[s(&scene), "--plan", "--wave", &last, "--quality", "draft"]);
    assert_eq!(code, 0, "{err}");
    assert!(!out.is_empty());
}

#[test]
fn a_sharded_bake_merges_into_the_same_bytes_as_a_whole_bake() {
    let tmp = tempfile::tempdir().unwrap();
    let (_, shards) = copy_of_pristine(tmp.path());
    let merged = tmp.path().join("merged.glint");
    let mut args = vec!["merge".to_string(), s(&merged).to_string()];
    args.extend(shards_of(&shards));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let (code, out, err) = bundle_tool(&args);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("13 units"), "{out}");
    assert_same_as_whole(&merged);

    // A shard left out is named.
    let mut some: Vec<&str> = args.clone();
    some.retain(|a| !a.ends_with("srdm.TableTop.glint"));
    some[1] = "unused";
    let (code, out, err) = bundle_tool(&some);
    assert_ne!(code, 0, "{out}");
    assert!(err.contains("no complete shard: srdm.TableTop"), "{err}");
}

/// Waits until `cond` holds (at most a minute).
fn wait_for(what: &str, cond: impl Fn() -> bool) {
    let t = Instant::now();
    while !cond() {
        assert!(
            t.elapsed() < Duration::from_secs(60),
            "timed out waiting: {what}"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn a_failed_or_killed_unit_is_refused_by_name_and_rerunning_it_fixes_the_merge() {
    let tmp = tempfile::tempdir().unwrap();
    let (scene, shards) = copy_of_pristine(tmp.path());
    let unit = "radiance.MirrorPanel";
    let shard = shards.join(format!("{unit}.glint"));
    let merge = |out: &str| {
        let mut args = vec![
            "merge".to_string(),
            tmp.path().join(out).to_str().unwrap().to_string(),
        ];
        args.extend(shards_of(&shards));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        bundle_tool(&args)
    };

    let rerun = || {
        bake(&[
            s(&scene),
            "--quality",
            "draft",
            "--unit",
            unit,
            "--bundle",
            s(&shard),
        ])
    };

    // A damaged asset (a unit that wrote garbage, a disk that lost it): refused by name.
    let exr = std::fs::read_dir(&shard)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.is_dir())
        .and_then(|d| std::fs::read_dir(d.join("MirrorPanel")).ok())
        .and_then(|mut it| it.next())
        .map(|e| e.unwrap().path())
        .expect("a map file in the shard");
    std::fs::write(&exr, b"not a map").unwrap();
    let (code, _, err) = merge("a.glint");
    assert_ne!(code, 0);
    assert!(err.contains(s(&shard)) && err.contains(unit), "{err}");
    assert!(!tmp.path().join("a.glint").exists(), "nothing is written");

    // The unit rerun and killed mid-bake: no marker, the merge says so and names the shard.
    let mut child = Command::new(env!("CARGO_BIN_EXE_glint-bake"))
        .args([
            s(&scene),
            "--quality",
            "draft",
            "--unit",
            unit,
            "--bundle",
            s(&shard),
        ])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    wait_for("the unit to remove its marker", || {
        !shard.join("unit.json").exists()
    });
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        !shard.join("unit.json").exists(),
        "killed before it finished"
    );
    let (code, _, err) = merge("b.glint");
    assert_ne!(code, 0);
    assert!(
        err.contains(&format!("{}: incomplete shard", shard.display()))
            && err.contains(&format!("--unit {unit}")),
        "{err}"
    );

    // Rerunning that one unit fixes it; the others are untouched.
    let (code, out, err) = rerun();
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("baked"), "{out}");
    let (code, out, err) = merge("c.glint");
    assert_eq!(code, 0, "{out}{err}");
    assert_same_as_whole(&tmp.path().join("c.glint"));

    // Run again, the unit is up to date.
    let (code, out, err) = rerun();
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("up to date"), "{out}");
}

/// `glint-bake --units` after an edit of scene.json: which units were baked.
fn rebake(scene: &Path, shards: &Path, merged: &Path) -> Vec<String> {
    let (code, out, err) = bake(&[
        s(scene),
        "--quality",
        "draft",
        "--units",
        s(shards),
        "--bundle",
        s(merged),
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let units = v["units"].as_array().unwrap();
    assert_eq!(units.len(), 13, "{out}");
    units
        .iter()
        .filter(|u| u["status"] == "baked")
        .map(|u| u["unit"].as_str().unwrap().to_string())
        .collect()
}

fn edit(scene: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(scene).unwrap()).unwrap();
    f(&mut v);
    std::fs::write(scene, serde_json::to_string_pretty(&v).unwrap()).unwrap();
}

#[test]
fn a_change_rebakes_only_the_units_whose_inputs_it_touches() {
    let tmp = tempfile::tempdir().unwrap();
    let (scene, shards) = copy_of_pristine(tmp.path());
    let merged = tmp.path().join("merged.glint");
    assert_eq!(
        rebake(&scene, &shards, &merged),
        Vec::<String>::new(),
        "nothing changed"
    );

    // One reflector's material: its lobes, and D (which every material's light reaches
    // through glossy transport) with every unit shaded with D. The other materials' units
    // are left alone.
    edit(&scene, |v| {
        v["materials"]["GlossyTable"]["lobes"][0]["mx"] = 0.2.into()
    });
    // That material's unit alone rerun (into another folder): the merge refuses to mix its
    // shard with those of the old plan, naming them.
    let shard = tmp.path().join("new/material.GlossyTable.glint");
    let (code, _, err) = bake(&[
        s(&scene),
        "--quality",
        "draft",
        "--unit",
        "material.GlossyTable",
        "--bundle",
        s(&shard),
    ]);
    assert_eq!(code, 0, "{err}");
    let mut args = vec![
        "merge".to_string(),
        s(&tmp.path().join("mixed.glint")).to_string(),
    ];
    args.extend(
        shards_of(&shards)
            .into_iter()
            .filter(|p| !p.ends_with("material.GlossyTable.glint")),
    );
    args.push(s(&shard).to_string());
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let (code, _, err) = bundle_tool(&args);
    assert_ne!(code, 0);
    assert!(
        err.contains("radiosity.glint: unit `radiosity` belongs to another plan")
            || err.contains(&format!(
                "{}: unit `material.GlossyTable` belongs to another plan",
                shard.display()
            )),
        "{err}"
    );
    let baked = rebake(&scene, &shards, &merged);
    assert_eq!(
        baked,
        [
            "scene",
            "gather.0",
            "gather.1",
            "material.GlossyTable",
            "radiosity",
            "envmap.Teapot",
            "radiance.Floor",
            "radiance.MirrorPanel",
            "radiance.TableTop",
            "srdm.TableTop"
        ]
    );

    // One reflector's radiance-map sampling: the scene copy and that reflector's maps only.
    edit(&scene, |v| {
        v["reflectors"][2]["radiance"] = serde_json::json!({ "resolution": 24 })
    });
    assert_eq!(
        rebake(&scene, &shards, &merged),
        ["scene", "radiance.TableTop"]
    );

    // A camera path other than the first (impostor views face the first): the scene only.
    edit(&scene, |v| v["camera_paths"][1]["fps"] = 24.into());
    assert_eq!(rebake(&scene, &shards, &merged), ["scene"]);

    // The merged bundle is what a whole bake of the edited scene gives.
    let whole = tmp.path().join("whole.glint");
    let (code, _, err) = bake(&[s(&scene), "--quality", "draft", "--bundle", s(&whole)]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(stages(&whole), stages(&merged));
}

#[test]
fn the_radiosity_unit_needs_every_gathering_shard_and_then_solves_the_same_d() {
    let tmp = tempfile::tempdir().unwrap();
    let (scene, shards) = copy_of_pristine(tmp.path());
    let other = tmp.path().join("other");
    std::fs::create_dir_all(&other).unwrap();
    copy_dir(
        &shards.join("gather.0.glint"),
        &other.join("gather.0.glint"),
    );
    let radiosity = other.join("radiosity.glint");
    let unit = || radiosity_unit(&scene, &radiosity);
    // gather.1's shard is missing: the unit says which and how to make it.
    let (code, _, err) = unit();
    assert_ne!(code, 0);
    assert!(
        err.contains("unit `radiosity` reads unit `gather.1`'s shard")
            && err.contains("--unit gather.1"),
        "{err}"
    );
    assert!(!radiosity.join("unit.json").exists());

    // With both, D is the bytes of the pristine sharded bake (and so of a whole bake).
    copy_dir(
        &shards.join("gather.1.glint"),
        &other.join("gather.1.glint"),
    );
    let (code, out, err) = unit();
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("baked"), "{out}");
    let d = |b: &Path| stages(b).remove("radiosity").unwrap();
    assert_eq!(d(&radiosity), d(&shards.join("radiosity.glint")));
}

#[test]
fn a_missing_dependency_shard_is_called_missing_and_a_partial_one_incomplete() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = repo("scenes/cornell-box/scene.json");
    let radiosity = tmp.path().join("radiosity.glint");
    let gather = tmp.path().join("gather.0.glint");
    let unit = || radiosity_unit(&scene, &radiosity);
    // No gather.0 shard at all: it is missing there, and nothing says its unit failed.
    let (code, _, err) = unit();
    assert_ne!(code, 0);
    assert!(
        err.contains(&format!(
            "unit `radiosity` reads unit `gather.0`'s shard, which is missing at {}",
            gather.display()
        )) && err.contains("--unit gather.0"),
        "{err}"
    );
    assert!(!err.contains("failed or was killed"), "{err}");

    // A shard its unit began but never finished (a bundle without unit.json): incomplete.
    std::fs::create_dir_all(&gather).unwrap();
    std::fs::write(
        gather.join("manifest.json"),
        r#"{"format":"glint-bundle","format_version":"2.1.0","generator":"glint","scene_name":"","scene_hash":"","stages":{}}"#,
    )
    .unwrap();
    let (code, _, err) = unit();
    assert_ne!(code, 0);
    assert!(
        err.contains(&format!("{}: incomplete shard", gather.display()))
            && err.contains("failed or was killed")
            && err.contains("--unit gather.0"),
        "{err}"
    );
    assert!(!radiosity.join("unit.json").exists());
}

/// Paths that are not UTF-8 are written lossily in the JSON reports of `glint-bake --units
/// --json` (it panicked) and `glint-bundle merge --json` (it said "invalid UTF-8" after
/// merging), and both succeed.
#[test]
fn json_reports_write_paths_that_are_not_utf8_lossily() {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    let scene = lit_floor(dir.path());
    let shards = dir.path().join(OsStr::from_bytes(b"shards-\xff"));
    let bundle = dir.path().join(OsStr::from_bytes(b"units-\xff.glint"));
    let json = |cmd: &mut Command| {
        let out = cmd.output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert_eq!(out.status.code(), Some(0), "{err}");
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let v = json(
        Command::new(env!("CARGO_BIN_EXE_glint-bake"))
            .arg(&scene)
            .arg("--units")
            .arg(&shards)
            .arg("--bundle")
            .arg(&bundle)
            .arg("--json"),
    );
    let units = v["units"].as_array().unwrap();
    assert!(!units.is_empty(), "{v}");
    for u in units {
        let shard = u["shard"].as_str().unwrap();
        assert!(shard.contains("shards-\u{fffd}/"), "{shard}");
    }
    let merged = v["merged"]["bundle"].as_str().unwrap();
    assert!(merged.ends_with("units-\u{fffd}.glint"), "{merged}");

    let again = dir.path().join(OsStr::from_bytes(b"merged-\xff.glint"));
    let mut merge = Command::new(env!("CARGO_BIN_EXE_glint-bundle"));
    merge.arg("merge").arg(&again);
    for e in std::fs::read_dir(&shards).unwrap() {
        merge.arg(e.unwrap().path());
    }
    let v = json(merge.arg("--json"));
    let merged = v["bundle"].as_str().unwrap();
    assert!(merged.ends_with("merged-\u{fffd}.glint"), "{merged}");
    assert_eq!(v["units"], units.len(), "{v}");
}
