//! The `srdm` stage end to end: captures against the geometry they come from, the bundle's
//! files read back, colour from D or albedo, views, skipping, and the `glint-srdm` command.

mod common;

use std::path::Path;

use common::*;
use glam::{Vec2, Vec3};
use glint::bake::radiosity_stage;
use glint::bake::srdm_stage::{self, SrdmOutcome, SrdmSettings};
use glint::bundle::Bundle;
use glint::progress::Silent;
use glint::scene::desc::RadiositySettings;
use glint::scene::{Quality, Scene};
use glint::srdm::{Srdm, SrdmParams};

/// A lit room-less scene: a card (the impostor, a unit square facing +Z at z = 0, tilted
/// about X), a floor below and an emissive panel above.
fn card_scene(dir: &Path, extra: &str) -> Scene {
    let mut card = quad("Card", 0, 2, 0.0, 0.5);
    // Tilt: z = 0.3·y, so depth varies across the capture.
    for p in &mut card.positions {
        p[2] = 0.3 * p[1];
    }
    write_gltf(
        dir,
        "s",
        &[card, quad("Floor", 1, 1, -1.0, 2.0), {
            let mut l = quad("Lamp", 2, 1, 2.0, 0.5);
            l.indices = vec![0, 2, 1, 0, 3, 2]; // facing down
            l
        }],
        &[
            MaterialSpec::diffuse("CardMat", 0.6),
            MaterialSpec::diffuse("FloorMat", 0.4),
            MaterialSpec {
                name: "LampMat",
                base: [0.0, 0.0, 0.0, 1.0],
                metallic: 0.0,
                roughness: 1.0,
                emissive: [1.0, 1.0, 1.0],
                strength: 20.0,
            },
        ],
    );
    Scene::load(write_scene(
        dir,
        &format!(r#"{{ "version": 1, "geometry": "s.gltf", "impostors": [ {{ "mesh": "Card"{extra} }} ] }}"#),
    ))
    .unwrap()
}

fn small() -> SrdmSettings {
    SrdmSettings {
        domains: 12,
        points: 8,
        resolution: 64,
    }
}

#[test]
fn capture_lies_on_the_geometry_and_the_srdm_intersects_like_it() {
    let dir = tempfile::tempdir().unwrap();
    let scene = card_scene(dir.path(), "");
    let imp = &scene.impostors[0];
    let cam = srdm_stage::view_camera(&scene, imp, 0, 96);
    // No camera path: the view looks from +Z at the card's centre.
    assert!(
        (cam.view.forward - -Vec3::Z).length() < 1e-5,
        "{:?}",
        cam.view
    );
    let cap = srdm_stage::capture(
        &scene,
        imp,
        &cam,
        &srdm_stage::ColourSource::Albedo,
        &Silent,
    )
    .unwrap();
    let cov = cap.depth.coverage();
    assert!(cov > 0.3 && cov < 0.95, "coverage {cov}");
    let albedo = scene.materials[0].albedo;
    for y in 0..96 {
        for x in 0..96 {
            let i = (y * 96 + x) as usize;
            match cap.depth.at(x, y) {
                Some(d) => {
                    let p = cam.unproject(Vec2::new(x as f32 + 0.5, y as f32 + 0.5), d);
                    assert!((p.z - 0.3 * p.y).abs() < 1e-4, "texel ({x}, {y}) at {p}");
                    assert!(p.x.abs() <= 0.5 + 1e-4 && p.y.abs() <= 0.5 + 1e-4);
                    assert_eq!(cap.colour[i], albedo);
                }
                None => assert_eq!(cap.colour[i], Vec3::ZERO),
            }
        }
    }
    // Rays from in front towards the card: the SRDM's t against the exact plane.
    let srdm = Srdm::build(
        &cap.depth,
        cam,
        SrdmParams {
            domains: 60,
            points: 8,
        },
        &Silent,
    )
    .unwrap();
    let mut rng = glint::sampling::Rng::new(3, 0);
    let (mut hits, mut worst) = (0, 0.0f32);
    for _ in 0..500 {
        let o = Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, 1.0) * Vec3::new(2.0, 2.0, 1.0);
        let target = Vec3::new(
            0.8 * (rng.uniform() - 0.5),
            0.8 * (rng.uniform() - 0.5),
            0.0,
        );
        let target = Vec3::new(target.x, target.y, 0.3 * target.y);
        let dir = (target - o).normalize();
        let exact = (target - o).length();
        let hit = srdm
            .intersect(o, dir, 10.0)
            .expect("the ray hits the card's interior");
        // A plane is exact in every row; what is left is the row's distance from the ray's
        // projection (up to ½ texel across rows, plus θ's 1.5°) times the card's depth slope,
        // which the brute-force march does not pay (it matches t to 1e-6).
        assert!(
            (hit.t - exact).abs() < 5e-3 * exact,
            "{hit:?} vs t = {exact}"
        );
        worst = worst.max((hit.t - exact).abs() / exact);
        hits += 1;
    }
    assert_eq!(hits, 500);
    eprintln!("worst relative t error {worst}");
    // Rays that pass beside it miss.
    assert!(
        srdm.intersect(Vec3::new(0.9, 0.0, 1.0), -Vec3::Z, 10.0)
            .is_none()
    );
}

#[test]
fn stage_writes_files_that_read_back_and_are_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    let scene = card_scene(dir.path(), r#", "views": 3"#);
    let bundle = dir.path().join("b.glint");
    let out = srdm_stage::bake(&scene, &bundle, &small(), false, &Silent).unwrap();
    let SrdmOutcome::Baked {
        record,
        views,
        colour,
    } = out
    else {
        panic!("baked")
    };
    assert_eq!(colour, "albedo");
    assert_eq!(record.settings["colour"], "albedo");
    assert_eq!(record.settings["domains"], 12);
    assert_eq!(record.stats["views"], 3);
    assert_eq!(record.stats["colour"], "albedo");
    assert_eq!(views.len(), 3);
    let kinds: Vec<&str> = record.assets.iter().map(|a| a.kind.as_str()).collect();
    assert_eq!(kinds.iter().filter(|k| **k == "srdm").count(), 3);
    assert_eq!(kinds.iter().filter(|k| **k == "impostor-exr").count(), 3);
    assert!(kinds.contains(&"srdm-index"));
    let srdm_bytes: u64 = record
        .assets
        .iter()
        .filter(|a| a.kind == "srdm")
        .map(|a| a.bytes)
        .sum();
    assert_eq!(srdm_bytes, 3 * Srdm::file_bytes(12, 64, 8));
    assert_eq!(record.stats["srdm_bytes"], srdm_bytes);

    let b = Bundle::open(&bundle).unwrap();
    assert!(b.verify().is_empty());
    let (index, loaded) = glint::srdm::index::load(&b).unwrap().unwrap();
    assert_eq!(index.views.len(), 3);
    assert_eq!(index.colour, "albedo");
    // Views 120° apart around +Y.
    let f: Vec<Vec3> = index.views.iter().map(|v| Vec3::from(v.forward)).collect();
    for k in 0..3 {
        let cos = f[k].dot(f[(k + 1) % 3]);
        assert!((cos + 0.5).abs() < 1e-4, "{f:?}");
    }
    // What was read is what a fresh capture and build give.
    let imp = &scene.impostors[0];
    for (v, l) in loaded.iter().enumerate() {
        let cam = srdm_stage::view_camera(&scene, imp, v as u32, 64);
        assert_eq!(*l.srdm.camera(), cam);
        let cap = srdm_stage::capture(
            &scene,
            imp,
            &cam,
            &srdm_stage::ColourSource::Albedo,
            &Silent,
        )
        .unwrap();
        assert_eq!(l.capture.depth, cap.depth, "depth is stored as f32: exact");
        let again = Srdm::build(
            &cap.depth,
            cam,
            SrdmParams {
                domains: 12,
                points: 8,
            },
            &Silent,
        )
        .unwrap();
        assert_eq!(l.srdm, again);
    }
    // A second bake writes the same bytes.
    let hashes = |b: &Bundle| -> Vec<String> {
        b.stage("srdm")
            .unwrap()
            .assets
            .iter()
            .map(|a| a.blake3.clone())
            .collect()
    };
    let first = hashes(&b);
    srdm_stage::bake(&scene, &bundle, &small(), false, &Silent).unwrap();
    assert_eq!(first, hashes(&Bundle::open(&bundle).unwrap()));
}

#[test]
fn colour_comes_from_d_when_the_bundle_has_radiosity() {
    let dir = tempfile::tempdir().unwrap();
    let scene = card_scene(dir.path(), "");
    let bundle = dir.path().join("b.glint");
    let mut rs = RadiositySettings::preset(Quality::Draft);
    rs.rays = 16;
    rs.bounces = 1;
    radiosity_stage::bake(&scene, &bundle, &rs, false, &Silent).unwrap();
    let SrdmOutcome::Baked { record, .. } =
        srdm_stage::bake(&scene, &bundle, &small(), false, &Silent).unwrap()
    else {
        panic!("baked")
    };
    assert_eq!(record.settings["colour"], "radiosity");
    let b = Bundle::open(&bundle).unwrap();
    let (index, loaded) = glint::srdm::index::load(&b).unwrap().unwrap();
    assert_eq!(index.colour, "radiosity");
    let cap = &loaded[0].capture;
    let lit: Vec<Vec3> = cap
        .colour
        .iter()
        .zip(cap.depth.texels())
        .filter(|(_, d)| **d >= 0.0)
        .map(|(c, _)| *c)
        .collect();
    assert!(!lit.is_empty());
    assert!(lit.iter().all(|c| c.is_finite() && c.min_element() >= 0.0));
    assert!(
        lit.iter().any(|c| *c != scene.materials[0].albedo),
        "D, not the albedo"
    );
}

#[test]
fn a_scene_without_impostors_is_skipped_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    write_room(dir.path());
    let scene = Scene::load(write_scene(
        dir.path(),
        r#"{ "version": 1, "geometry": "room.gltf" }"#,
    ))
    .unwrap();
    let bundle = dir.path().join("b.glint");
    let out = srdm_stage::bake(&scene, &bundle, &small(), false, &Silent).unwrap();
    assert!(matches!(out, SrdmOutcome::Skipped { ref reason } if reason.contains("impostor")));
    assert!(!bundle.exists());
}

fn run(bin: &str, args: &[&str]) -> (i32, String, String) {
    common::run_exe(bin, args)
}

#[test]
fn glint_srdm_command_line() {
    let srdm = env!("CARGO_BIN_EXE_glint-srdm");
    let dir = tempfile::tempdir().unwrap();
    card_scene(dir.path(), "");
    let scene = dir.path().join("scene.json");
    let bundle = dir.path().join("out.glint");
    let (s, b) = (scene.to_str().unwrap(), bundle.to_str().unwrap());

    let (code, out, err) = run(
        srdm,
        &[
            s,
            "--bundle",
            b,
            "-n",
            "6",
            "-m",
            "4",
            "--resolution",
            "32",
            "--json",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["status"], "baked");
    assert_eq!(v["record"]["settings"]["points"], 4);
    assert_eq!(v["views"][0]["impostor"], "Card");
    let stats = run(env!("CARGO_BIN_EXE_glint-bundle"), &["stats", b]).1;
    assert!(
        stats.contains("srdm") && stats.contains("srdm_bytes") && stats.contains("impostors"),
        "{stats}"
    );

    let (code, out, _) = run(srdm, &[s, "--bundle", b]);
    assert_eq!(code, 0);
    assert!(
        out.contains("Card") && out.contains("colour: albedo"),
        "{out}"
    );

    // Out-of-range flags are refused by the settings' check, naming the flag.
    let (code, _, err) = run(srdm, &[s, "--bundle", b, "-m", "1"]);
    assert_ne!(code, 0);
    assert!(err.contains("--points") || err.contains("-m"), "{err}");
    // A bad scene setting names the file and field.
    std::fs::write(
        &scene,
        r#"{ "version": 1, "geometry": "s.gltf", "impostors": [ { "mesh": "Card" } ], "bake": { "srdm": { "points": 0 } } }"#,
    )
    .unwrap();
    let (code, _, err) = run(srdm, &[s, "--bundle", b]);
    assert_ne!(code, 0);
    assert!(
        err.contains("bake.srdm.points") && err.contains("scene.json"),
        "{err}"
    );

    // No impostors: one line, exit 0, nothing written.
    let other = tempfile::tempdir().unwrap();
    write_room(other.path());
    let room = write_scene(other.path(), r#"{ "version": 1, "geometry": "room.gltf" }"#);
    let ob = other.path().join("room.glint");
    let (code, out, err) = run(
        srdm,
        &[room.to_str().unwrap(), "--bundle", ob.to_str().unwrap()],
    );
    assert_eq!(code, 0, "{err}");
    assert_eq!(out.lines().count(), 1, "{out}");
    assert!(
        out.contains("skipped") && out.contains("no impostor"),
        "{out}"
    );
    assert!(!ob.exists());
}
