//! The library as a program uses it: the examples in `examples/` built and run against a
//! bundle baked here, and the build-script bake API that README's `build.rs` recipe calls.

mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use common::{MaterialSpec, flip, quad, run_exe, write_gltf, write_scene};
use glint::bake::StageStatus;
use glint::bake::build_script::{bake_in_build_script, bake_telling_cargo, scene_files};
use glint::bundle::Bundle;
use glint::scene::{Quality, Scene};

/// The folder the examples are built into (`target/debug/examples` beside this test), built
/// once per run: plain `cargo test` has built them already, `cargo test --test examples` has
/// not.
fn examples_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let exe = std::env::current_exe().unwrap();
        let profile_dir = exe.parent().and_then(Path::parent).unwrap().to_owned();
        let target_dir = profile_dir.parent().unwrap();
        let profile = match profile_dir.file_name().and_then(|n| n.to_str()) {
            Some("debug") => "dev",
            Some(other) => other,
            None => panic!("{}: no profile folder", exe.display()),
        };
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let mut cmd = std::process::Command::new(cargo);
        cmd.args(["build", "--offline", "--examples", "--no-default-features"])
            .arg("--profile")
            .arg(profile)
            .arg("--target-dir")
            .arg(target_dir)
            .arg("--manifest-path")
            .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml"));
        if cfg!(feature = "view") {
            cmd.args(["--features", "view"]);
        }
        let out = cmd.output().unwrap();
        assert!(
            out.status.success(),
            "building the examples failed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        profile_dir.join("examples")
    })
}

/// Runs example `name` with `args`: exit code, stdout, stderr.
fn example<S: AsRef<std::ffi::OsStr>>(name: &str, args: &[S]) -> (i32, String, String) {
    let exe = examples_dir().join(format!("{name}{}", std::env::consts::EXE_SUFFIX));
    run_exe(exe.to_str().unwrap(), args)
}

/// A floor under a lamp that faces it (`box.gltf`, `box.bin` and scene.json in `dir`): a
/// scene with no glossy material, quick to bake whole. Returns the scene.json's path.
fn lit_floor(dir: &Path) -> PathBuf {
    write_gltf(
        dir,
        "box",
        &[
            quad("Floor", 0, 1, 0.0, 1.0),
            flip(quad("Light", 1, 1, 1.0, 0.2)),
        ],
        &[
            MaterialSpec::diffuse("white", 0.7),
            MaterialSpec::emitter("lamp", [1.0; 3], 5.0),
        ],
    );
    write_scene(dir, r#"{ "version": 1, "geometry": "box.gltf" }"#)
}

/// [`lit_floor`] (scene and radiosity stages) baked at draft into `dir/floor.glint`.
fn floor_bundle(dir: &Path) -> PathBuf {
    let scene = lit_floor(dir);
    let bundle = dir.join("floor.glint");
    bake_in_build_script(&scene, &bundle, Quality::Draft).unwrap();
    bundle
}

#[test]
fn bundle_stats_lists_every_stage_and_asset() {
    let dir = tempfile::tempdir().unwrap();
    let bundle = floor_bundle(dir.path());
    let (code, out, err) = example("bundle_stats", &[&bundle]);
    assert_eq!(code, 0, "{err}");
    let opened = Bundle::open(&bundle).unwrap();
    let m = opened.manifest();
    assert_eq!(
        out.lines().next().unwrap(),
        format!("scene {} (format {})", m.scene_name, m.format_version)
    );
    assert_eq!(
        m.stages.keys().collect::<Vec<_>>(),
        ["radiosity", "scene"],
        "the fixture's stages"
    );
    for (name, stage) in &m.stages {
        let header = format!("{name}: {} assets, ", stage.assets.len());
        assert!(
            out.lines().any(|l| l.starts_with(&header)),
            "{header}\n{out}"
        );
        for a in &stage.assets {
            let line = format!("  {} {} {}", a.path, a.kind, a.bytes);
            assert!(out.lines().any(|l| l == line), "{line}\n{out}");
        }
    }
    let assets: usize = m.stages.values().map(|s| s.assets.len()).sum();
    assert_eq!(out.lines().count(), 1 + m.stages.len() + assets, "{out}");

    // Not a bundle: exit 1 naming the folder; a wrong command line: exit 2 with the usage.
    let missing = dir.path().join("none.glint");
    let (code, _, err) = example("bundle_stats", &[&missing]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("none.glint"), "{err}");
    let (code, _, err) = example::<&str>("bundle_stats", &[]);
    assert_eq!(code, 2);
    assert!(err.contains("usage: bundle_stats BUNDLE"), "{err}");
}

/// The numbers after `D` in sample_d's line: R, G, B.
fn parse_d(out: &str) -> [f32; 3] {
    let fields: Vec<f32> = out
        .strip_prefix("D ")
        .unwrap_or_else(|| panic!("not a D line: {out}"))
        .split_whitespace()
        .take(3)
        .map(|f| f.parse().unwrap())
        .collect();
    fields.try_into().unwrap()
}

#[test]
fn sample_d_reads_what_glint_eval_probe_reads() {
    let dir = tempfile::tempdir().unwrap();
    let bundle = floor_bundle(dir.path());
    // Points on the floor (y = 0), lit by the lamp above; one off the floor's edge.
    let points = [[0.0, 0.0, 0.0], [0.5, 0.0, -0.3], [-0.9, 0.001, 0.9]];
    let json = serde_json::to_string(
        &points
            .iter()
            .map(|p| serde_json::json!({ "position": p, "normal": [0.0, 1.0, 0.0] }))
            .collect::<Vec<_>>(),
    )
    .unwrap();
    let points_json = dir.path().join("points.json");
    std::fs::write(&points_json, json).unwrap();
    let (code, out, err) = run_exe(
        env!("CARGO_BIN_EXE_glint-eval"),
        &[
            "probe".as_ref(),
            bundle.as_os_str(),
            "--points".as_ref(),
            points_json.as_os_str(),
        ],
    );
    assert_eq!(code, 0, "{err}");
    let values: Vec<serde_json::Value> = serde_json::from_str(&out).unwrap();
    for (p, v) in points.iter().zip(&values) {
        let mut args = vec![bundle.to_str().unwrap().to_owned()];
        args.extend(p.iter().map(|c| c.to_string()));
        args.extend(["0", "1", "0"].map(String::from));
        let (code, out, err) = example("sample_d", &args);
        assert_eq!(code, 0, "{err}");
        let d = parse_d(&out);
        let expected: [f32; 3] = serde_json::from_value(v["radiance"].clone()).unwrap();
        assert_eq!(d, expected, "at {p:?}: {out}");
        assert!(d.iter().all(|c| *c > 0.0), "the lit floor is dark at {p:?}");
        let triangle = format!("(triangle {},", v["triangle"]);
        assert!(out.contains(&triangle), "{triangle} in {out}");
    }

    // Far from any surface: exit 1 saying so; not a bundle: exit 1 naming it; a wrong
    // command line: exit 2.
    let (code, _, err) = example(
        "sample_d",
        &[bundle.to_str().unwrap(), "0", "9", "0", "0", "1", "0"],
    );
    assert_eq!(code, 1);
    assert!(err.contains("no surface within"), "{err}");
    let (code, _, err) = example("sample_d", &["none.glint", "0", "0", "0", "0", "1", "0"]);
    assert_eq!(code, 1);
    assert!(err.contains("none.glint"), "{err}");
    let (code, _, err) = example("sample_d", &[bundle.to_str().unwrap(), "0", "0", "zero"]);
    assert_eq!(code, 2);
    assert!(err.contains("usage: sample_d"), "{err}");
}

#[test]
fn build_script_bake_watches_the_scene_files_and_rebakes_an_edited_scene() {
    let dir = tempfile::tempdir().unwrap();
    let scene_json = lit_floor(dir.path());
    let scene = Scene::load(&scene_json).unwrap();
    let names: Vec<_> = scene_files(&scene)
        .iter()
        .map(|f| f.strip_prefix(dir.path()).unwrap().to_owned())
        .collect();
    let expected: Vec<PathBuf> = ["box.bin", "box.gltf", "scene.json"]
        .map(PathBuf::from)
        .into();
    assert_eq!(names, expected);

    let bundle = dir.path().join("out").join("floor.glint");
    let statuses = |quality| -> Vec<(String, StageStatus)> {
        let mut told = Vec::new();
        let report = bake_telling_cargo(&scene_json, &bundle, quality, &mut told).unwrap();
        // Each file of the scene, watched once.
        let watched: Vec<String> = ["scene.json", "box.bin", "box.gltf"]
            .iter()
            .map(|f| format!("cargo:rerun-if-changed={}\n", dir.path().join(f).display()))
            .collect();
        assert_eq!(String::from_utf8(told).unwrap(), watched.concat());
        report
            .into_iter()
            .map(|r| (r.plan.stage.name().to_owned(), r.status))
            .filter(|(_, s)| !matches!(s, StageStatus::Skipped { .. }))
            .collect()
    };
    let baked = |list: &[(String, StageStatus)]| {
        list.iter()
            .filter(|(_, s)| matches!(s, StageStatus::Baked { .. }))
            .map(|(n, _)| n.clone())
            .collect::<Vec<_>>()
    };
    assert_eq!(baked(&statuses(Quality::Draft)), ["scene", "radiosity"]);
    // The next build: nothing to do.
    let again = statuses(Quality::Draft);
    assert!(
        again.iter().all(|(_, s)| *s == StageStatus::UpToDate),
        "{again:?}"
    );
    // The scene edited: its bundle is the build's own, so the stages are baked afresh.
    write_scene(
        dir.path(),
        r#"{ "version": 1, "geometry": "box.gltf", "name": "floor" }"#,
    );
    assert_eq!(baked(&statuses(Quality::Draft)), ["scene", "radiosity"]);
    assert_eq!(
        Bundle::open(&bundle).unwrap().manifest().scene_name,
        "floor"
    );

    // A scene that does not load fails the bake, naming the file and the field.
    write_scene(
        dir.path(),
        r#"{ "version": 1, "geometry": "missing.gltf" }"#,
    );
    let e = bake_in_build_script(&scene_json, &bundle, Quality::Draft)
        .unwrap_err()
        .to_string();
    assert!(e.contains("scene.json") && e.contains("geometry"), "{e}");
}

#[test]
fn scene_files_lists_the_gltf_s_external_images_by_their_decoded_paths() {
    let dir = tempfile::tempdir().unwrap();
    let scene_json = lit_floor(dir.path());
    // An image beside the glTF (under a percent-escaped URI) and one inside it.
    let gltf_path = dir.path().join("box.gltf");
    let mut gltf: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&gltf_path).unwrap()).unwrap();
    gltf["images"] = serde_json::json!([
        { "uri": "maps/wood%20grain.png" },
        { "uri": "data:image/png;base64,AAAA" }
    ]);
    std::fs::write(&gltf_path, gltf.to_string()).unwrap();
    std::fs::create_dir(dir.path().join("maps")).unwrap();
    std::fs::write(dir.path().join("maps/wood grain.png"), b"png").unwrap();
    let scene = Scene::load(&scene_json).unwrap();
    let names: Vec<_> = scene_files(&scene)
        .iter()
        .map(|f| f.strip_prefix(dir.path()).unwrap().to_owned())
        .collect();
    let expected: Vec<PathBuf> = ["box.bin", "box.gltf", "maps/wood grain.png", "scene.json"]
        .map(PathBuf::from)
        .into();
    assert_eq!(names, expected);
}

/// The `build.rs` of README's recipe is the one lib.rs's documentation compiles as a doctest.
#[test]
fn readme_build_rs_recipe_is_the_compiled_one() {
    let readme = std::fs::read_to_string(common::repo("README.md")).unwrap();
    let lib = std::fs::read_to_string(common::repo("src/lib.rs")).unwrap();
    let recipe = readme
        .split("```rust\n")
        .nth(1)
        .and_then(|rest| rest.split("```").next())
        .expect("README has a ```rust block: the build.rs recipe");
    assert!(recipe.contains("bake_in_build_script"), "{recipe}");
    let doc: String = lib
        .lines()
        .filter_map(|l| l.strip_prefix("//!"))
        .map(|l| format!("{}\n", l.strip_prefix(' ').unwrap_or(l)))
        .collect();
    assert!(
        doc.contains(recipe),
        "README's build.rs recipe differs from the one in src/lib.rs's docs:\n{recipe}"
    );
}
