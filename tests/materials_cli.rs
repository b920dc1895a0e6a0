//! The materials stage end to end: `glint-materials` on small scenes and a shipped one, what
//! it writes and skips, determinism across thread counts, environment maps with a shader,
//! and errors that name the file and field.

mod common;

use std::path::{Path, PathBuf};

use common::*;
use glam::Vec3;
use glint::bake::materials::{
    EnvShading, MaterialsSettings, Outcome, bake_with, recorded_settings,
};
use glint::bundle::Bundle;
use glint::image_io::decode_exr;
use glint::materials::pattern_format::decode_pattern;
use glint::progress::Silent;
use glint::radiosity::d_identity;
use glint::scene::{Quality, Scene};

fn run(bin: &str, args: &[&str]) -> (i32, String, String) {
    common::run_exe(bin, args)
}

fn materials(args: &[&str]) -> (i32, String, String) {
    run(env!("CARGO_BIN_EXE_glint-materials"), args)
}

/// The fixture room (diffuse floor, metal panel, emissive ceiling) plus a glossy,
/// anisotropic closed "Ball" declared a curved reflector.
fn glossy_scene(dir: &Path, extra: &str) -> PathBuf {
    let a = 0.2f32;
    let ball = MeshSpec {
        normals: Vec::new(),
        name: "Ball",
        material: 3,
        positions: vec![
            [-a, 1.0 - a, -a],
            [a, 1.0 - a, -a],
            [a, 1.0 + a, -a],
            [-a, 1.0 + a, -a],
            [-a, 1.0 - a, a],
            [a, 1.0 - a, a],
            [a, 1.0 + a, a],
            [-a, 1.0 + a, a],
        ],
        indices: vec![
            0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4, 3, 6, 2, 3, 7, 6, 0, 7, 3, 0, 4,
            7, 1, 2, 6, 1, 6, 5,
        ],
    };
    let (mut meshes, mut materials) = room();
    meshes.push(ball);
    materials.push(MaterialSpec::diffuse("Brushed", 0.5));
    write_gltf(dir, "room", &meshes, &materials);
    write_scene(
        dir,
        &format!(
            r#"{{ "version": 1, "geometry": "room.gltf",
  "materials": {{ "Brushed": {{ "lobes": [ {{ "model": "kurt", "ks": [0.8, 0.8, 0.8], "r0": 0.9, "mx": 0.2, "my": 0.05, "alpha": 0.5 }},
                                            {{ "model": "kurt", "ks": [0.2, 0.2, 0.2], "r0": 0.04, "mx": 0.01, "my": 0.01, "alpha": 0 }} ] }} }},
  "reflectors": [ {{ "mesh": "Panel", "kind": "planar" }}, {{ "mesh": "Ball", "kind": "curved" }} ]{extra} }}"#
        ),
    )
}

#[test]
fn diffuse_only_scene_is_skipped_with_its_reason_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let bundle = dir.path().join("cornell.glint");
    let scene = repo("scenes/cornell-box/scene.json");
    let (code, out, err) = materials(&[
        scene.to_str().unwrap(),
        "--bundle",
        bundle.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(
        out.trim(),
        "cornell-box: materials skipped: no material in use has a glossy lobe"
    );
    assert!(!bundle.exists());
    let (code, out, _) = materials(&[
        scene.to_str().unwrap(),
        "--bundle",
        bundle.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["status"], "skipped");
    assert!(v["reason"].as_str().unwrap().contains("glossy"));
}

#[test]
fn glossy_scene_bakes_every_asset_and_skips_env_maps_without_d() {
    let dir = tempfile::tempdir().unwrap();
    let scene = glossy_scene(dir.path(), "");
    let bundle = dir.path().join("out/room.glint");
    let (s, b) = (scene.to_str().unwrap(), bundle.to_str().unwrap());
    let (code, out, err) = materials(&[s, "--bundle", b, "--quality", "draft"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("PanelMat") && out.contains("Brushed"), "{out}");
    assert!(
        out.contains("environment maps skipped") && out.contains("`radiosity` stage"),
        "{out}"
    );

    let opened = Bundle::open(&bundle).unwrap();
    assert!(opened.verify().is_empty());
    let rec = opened.stage("materials").unwrap();
    let paths: Vec<&str> = rec.assets.iter().map(|a| a.path.as_str()).collect();
    // PanelMat: 1 isotropic lobe (4 files); Brushed: anisotropic lobe (3) + isotropic (4).
    for p in [
        "materials/PanelMat/lobe0-kernel.exr",
        "materials/PanelMat/lobe0-reflectance.exr",
        "materials/PanelMat/lobe0-reflectance-1d.exr",
        "materials/PanelMat/lobe0-pattern.bin",
        "materials/Brushed/lobe0-kernel.exr",
        "materials/Brushed/lobe0-reflectance.exr",
        "materials/Brushed/lobe0-pattern.bin",
        "materials/Brushed/lobe1-reflectance-1d.exr",
        "materials/index.json",
    ] {
        assert!(paths.contains(&p), "{p} missing from {paths:?}");
    }
    assert!(!paths.contains(&"materials/Brushed/lobe0-reflectance-1d.exr"));
    assert!(
        !paths
            .iter()
            .any(|p| p.contains("FloorMat") || p.contains("env/"))
    );
    assert_eq!(rec.stats["env_maps"], 0);
    assert!(
        rec.stats["env_maps_skipped"]
            .as_str()
            .unwrap()
            .contains("radiosity")
    );
    assert_eq!(rec.settings["sample_budget"], 14);
    assert!(rec.settings["d_source"].is_null());

    let asset = |p: &str| {
        let a = rec.assets.iter().find(|a| a.path == p).unwrap();
        opened.read_asset(a).unwrap()
    };
    // The kernel sums to 1; the pattern is the one closest to the budget.
    let k = decode_exr(&asset("materials/Brushed/lobe0-kernel.exr")).unwrap();
    let sum: f64 = k.channel("Y").unwrap().iter().map(|&w| w as f64).sum();
    assert!((sum - 1.0).abs() < 1e-5 && k.width == k.height && k.width > 1);
    let p = decode_pattern(&asset("materials/Brushed/lobe0-pattern.bin")).unwrap();
    assert_eq!((p.mx, p.my, p.xi0), (0.2, 0.05, 0.2));
    let r = decode_exr(&asset("materials/PanelMat/lobe0-reflectance-1d.exr")).unwrap();
    assert_eq!((r.width, r.height), (64, 1));
    assert!(r.channel("R").is_ok() && r.channel("A").is_ok());
    let index: serde_json::Value = serde_json::from_slice(&asset("materials/index.json")).unwrap();
    assert_eq!(index["version"], 1);
    assert_eq!(index["materials"][1]["lobes"].as_array().unwrap().len(), 2);
    assert_eq!(
        index["materials"][0]["lobes"][0]["pattern"]["samples"],
        p_samples(&opened, "PanelMat")
    );

    // glint-bundle stats lists the per-material assets.
    let (code, out, err) = run(env!("CARGO_BIN_EXE_glint-bundle"), &["stats", b]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("material PanelMat") && out.contains("material Brushed"),
        "{out}"
    );
    assert!(
        out.contains("kernel") && out.contains("sample-pattern"),
        "{out}"
    );
}

fn p_samples(b: &Bundle, material: &str) -> serde_json::Value {
    let rec = b.stage("materials").unwrap();
    let a = rec
        .assets
        .iter()
        .find(|a| a.path == format!("materials/{material}/lobe0-pattern.bin"))
        .unwrap();
    decode_pattern(&b.read_asset(a).unwrap())
        .unwrap()
        .half_vectors
        .len()
        .into()
}

/// A stand-in for D in tests: each hit shows its triangle's material index + 1.
fn shading(scene: &Scene) -> EnvShading {
    let mats: Vec<f32> = scene
        .triangles
        .iter()
        .map(|t| t.material as f32 + 1.0)
        .collect();
    EnvShading {
        shade: Box::new(move |hit| Vec3::splat(mats[hit.triangle as usize])),
        sides: Default::default(),
        source: "test".into(),
    }
}

fn asset_hashes(dir: &Path) -> Vec<(String, String)> {
    let b = Bundle::open(dir).unwrap();
    b.stage("materials")
        .unwrap()
        .assets
        .iter()
        .map(|a| (a.path.clone(), a.blake3.clone()))
        .collect()
}

#[test]
fn bakes_are_identical_whatever_the_thread_count_and_env_maps_use_the_shader() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::load(glossy_scene(dir.path(), "")).unwrap();
    let mut settings = MaterialsSettings::preset(Quality::Draft);
    settings.env_map_size = 16;
    settings.env_supersample = 2;
    let bake_in = |threads: usize, out: &Path| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| bake_with(&scene, out, &settings, false, Ok(shading(&scene)), &Silent))
            .unwrap()
    };
    let (a, b) = (dir.path().join("a.glint"), dir.path().join("b.glint"));
    let Outcome::Baked(report) = bake_in(1, &a) else {
        panic!("not baked")
    };
    bake_in(2, &b);
    assert_eq!(asset_hashes(&a), asset_hashes(&b));

    // One environment map, for the curved Ball, with its MIP levels 16 … 1.
    assert!(report.env_maps_skipped.is_none());
    assert_eq!(report.env_maps.len(), 1);
    assert_eq!(report.env_maps[0].levels, 5);
    let opened = Bundle::open(&a).unwrap();
    let rec = opened.stage("materials").unwrap();
    let mips: Vec<_> = rec.assets.iter().filter(|x| x.kind == "env-mip").collect();
    assert_eq!(mips.len(), 5);
    assert_eq!(mips[0].path, "materials/env/Ball/mip00.exr");
    assert_eq!(rec.settings["d_source"], "test");
    let level0 = decode_exr(&opened.read_asset(mips[0]).unwrap()).unwrap();
    assert_eq!((level0.width, level0.height), (96, 16));
    // Looking down (−Y face, columns 48…63) from the ball's centroid shows the floor.
    let floor = scene
        .materials
        .iter()
        .position(|m| m.name == "FloorMat")
        .unwrap() as f32
        + 1.0;
    let r = level0.channel("R").unwrap();
    assert_eq!(r[8 * 96 + 56], floor);
    assert!(r.iter().all(|&v| v.is_finite() && v >= 0.0));
}

#[test]
fn env_maps_are_shaded_with_d_from_the_radiosity_stage() {
    let dir = tempfile::tempdir().unwrap();
    let scene = glossy_scene(dir.path(), "");
    let bundle = dir.path().join("room.glint");
    let (s, b) = (scene.to_str().unwrap(), bundle.to_str().unwrap());
    let (code, _, err) = run(
        env!("CARGO_BIN_EXE_glint-radiosity"),
        &[s, "--bundle", b, "--quality", "draft"],
    );
    assert_eq!(code, 0, "{err}");
    let (code, out, err) = materials(&[s, "--bundle", b, "--quality", "draft"]);
    assert_eq!(code, 0, "{err}");
    assert!(!out.contains("skipped"), "{out}");
    let opened = Bundle::open(&bundle).unwrap();
    assert!(opened.verify().is_empty());
    let rec = opened.stage("materials").unwrap();
    assert_eq!(rec.stats["env_maps"], 1);
    assert_eq!(rec.settings["d_source"].as_str().unwrap().len(), 64);
    // What glint-bake would compare for "up to date".
    let loaded = Scene::load(&scene).unwrap();
    let settings = MaterialsSettings::preset(Quality::Draft);
    let expect = recorded_settings(
        &settings,
        d_identity(&bundle, &loaded.content_hash).as_deref(),
    );
    assert_eq!(rec.settings, expect);
    let mip0 = rec
        .assets
        .iter()
        .find(|a| a.path == "materials/env/Ball/mip00.exr")
        .unwrap();
    let img = decode_exr(&opened.read_asset(mip0).unwrap()).unwrap();
    let n = img.height;
    let r = img.channel("R").unwrap();
    assert!(r.iter().all(|v| v.is_finite() && *v >= 0.0));
    // Up (+Y face): the emissive ceiling (radiance 10, D includes emission); down (−Y): the
    // diffuse floor (the fixture's ceiling emits away from the room, so it stays dark).
    let up = r[(n / 2) * 6 * n + 2 * n + n / 2];
    let down = r[(n / 2) * 6 * n + 3 * n + n / 2];
    assert!((up - 10.0).abs() < 0.1, "ceiling {up}");
    assert!(down < 0.5 * up, "floor {down}");
}

#[test]
fn bad_settings_name_the_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let scene = glossy_scene(
        dir.path(),
        r#", "bake": { "materials": { "env_map_size": 100 } }"#,
    );
    let bundle = dir.path().join("x.glint");
    let (code, _, err) = materials(&[
        scene.to_str().unwrap(),
        "--bundle",
        bundle.to_str().unwrap(),
    ]);
    assert_eq!(code, 1);
    assert!(
        err.contains("scene.json")
            && err.contains("bake.materials.env_map_size")
            && err.contains("power of two"),
        "{err}"
    );
    assert!(!bundle.exists());
    let (code, _, err) = materials(&["--bundle", "x"]);
    assert_ne!(code, 0);
    assert!(err.contains("SCENE.json"), "{err}");
}

#[test]
fn shipped_glossy_room_bakes_its_glossy_materials() {
    let dir = tempfile::tempdir().unwrap();
    let bundle = dir.path().join("glossy-room.glint");
    let scene = repo("scenes/glossy-room/scene.json");
    let (code, out, err) = materials(&[
        scene.to_str().unwrap(),
        "--bundle",
        bundle.to_str().unwrap(),
        "--quality",
        "draft",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["status"], "baked");
    let names: Vec<&str> = v["report"]["materials"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert!(
        names.contains(&"GlossyFloor") && names.contains(&"GlossyTable"),
        "{names:?}"
    );
    // The mirror's kernel is the identity.
    let mirror = v["report"]["materials"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["name"] == "Mirror")
        .unwrap();
    assert_eq!(mirror["lobes"][0]["kernel_size"], 1);
    assert!(Bundle::open(&bundle).unwrap().verify().is_empty());
}
