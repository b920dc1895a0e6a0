//! `glint-bundle export`: the .glb an engine loads.
//!
//! - Every shipped scene's export (radiosity baked at test settings) has a `TEXCOORD_1` and
//!   an `MSFT_lightmap` binding (mirrored in `extras`) on every primitive's material, one
//!   camera per camera path, and passes the Khronos glTF validator (npm `gltf-validator`,
//!   `tests/web/`) with 0 errors.
//! - The real client: Babylon.js in headless Chromium (WebGL on SwiftShader) renders
//!   glossy-room's and textured-room's export, unlit plus lightmap, at the scene's first
//!   camera, within [`MAX_RELATIVE_RMSE`] whole-frame relative RMSE of `glint-view
//!   --reflections off` at the same camera and size, and within [`MAX_LUMINANCE_DIFF`] in
//!   mean luminance. Prints `SKIPPED: ...` and passes where Chromium is missing
//!   (`.ci/run` installs it).
//!
//! On failure the two frames are left in `target/export-failures/SCENE/`.

#![cfg(feature = "view")]

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::shipped::{Recipe, Step, shipped_bundle};

/// Largest whole-frame relative RMSE, ‖babylon − glint‖ / ‖glint‖ over every pixel and
/// channel of the 8-bit display frames.
const MAX_RELATIVE_RMSE: f64 = 0.05;

/// Largest relative difference of the frames' mean luminance (Rec. 709, of the linearized
/// display values).
const MAX_LUMINANCE_DIFF: f64 = 0.02;

/// Frame size of the comparison (small: SwiftShader and lavapipe both render on the CPU).
const SIZE: (u32, u32) = (480, 320);

const SHIPPED: [&str; 5] = [
    "cornell-box",
    "glossy-room",
    "textured-room",
    "bunny-mirror",
    "breakfast-room",
];

fn bundle(scene: &'static str) -> PathBuf {
    shipped_bundle(
        &Recipe::new(scene)
            .then(Step::Scene)
            .then(Step::Radiosity(common::quick_radiosity(3))),
    )
}

fn out_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("export")
        .join(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn export(scene: &'static str) -> PathBuf {
    let glb = out_dir(scene).join(format!("{scene}.glb"));
    let (code, stdout, stderr) = common::run_exe(
        env!("CARGO_BIN_EXE_glint-bundle"),
        &[
            "export".as_ref(),
            bundle(scene).as_os_str(),
            glb.as_os_str(),
        ],
    );
    assert_eq!(code, 0, "export of {scene}: {stdout}{stderr}");
    glb
}

fn web() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/web")
}

/// `tests/web/node_modules`, installed from the lock file when missing.
fn node_modules() {
    if web().join("node_modules").is_dir() {
        return;
    }
    let status = Command::new("npm")
        .args(["ci", "--no-audit", "--no-fund"])
        .current_dir(web())
        .status()
        .expect("npm (Node.js) is needed for tests/web");
    assert!(status.success(), "npm ci in tests/web failed");
}

/// The GLB's JSON chunk as written (the gltf crate's document drops extensions it does not
/// know, MSFT_lightmap among them).
fn glb_json(glb: &Path) -> serde_json::Value {
    let bytes = std::fs::read(glb).unwrap();
    gltf::Gltf::from_slice(&bytes).unwrap_or_else(|e| panic!("{}: {e}", glb.display()));
    let g = gltf::Glb::from_slice(&bytes).unwrap();
    serde_json::from_slice(&g.json).unwrap()
}

#[test]
fn every_shipped_scene_exports_a_valid_lightmapped_glb() {
    let mut files = Vec::new();
    for scene in SHIPPED {
        let glb = export(scene);
        let json = glb_json(&glb);
        let materials = json["materials"].as_array().unwrap();
        for (m, mesh) in json["meshes"].as_array().unwrap().iter().enumerate() {
            for p in mesh["primitives"].as_array().unwrap() {
                assert!(
                    p["attributes"].get("TEXCOORD_1").is_some(),
                    "{scene}: mesh {m} lacks TEXCOORD_1"
                );
                let mat = &materials[p["material"].as_u64().unwrap() as usize];
                let tex = &mat["extensions"]["MSFT_lightmap"]["lightmapTexture"];
                assert_eq!(tex["texCoord"], 1, "{scene}: mesh {m}");
                assert_eq!(
                    mat["extras"]["glint_lightmap"]["texture"], tex["index"],
                    "{scene}: extras and MSFT_lightmap bind the same page"
                );
            }
        }
        let scene_json: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(common::scaffold::repo(&format!(
                "scenes/{scene}/scene.json"
            )))
            .unwrap(),
        )
        .unwrap();
        let paths = scene_json["camera_paths"].as_array().map_or(0, Vec::len);
        let cameras = json["cameras"].as_array().map_or(0, Vec::len);
        assert!(
            cameras >= paths,
            "{scene}: {cameras} cameras for {paths} camera paths"
        );
        files.push(glb);
    }
    node_modules();
    let out = Command::new("node")
        .arg(web().join("validate.mjs"))
        .args(&files)
        .output()
        .expect("node");
    let text = String::from_utf8_lossy(&out.stdout);
    println!("{text}");
    assert!(
        out.status.success(),
        "gltf-validator reported errors: {text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(text.lines().count(), SHIPPED.len(), "one report per file");
    assert!(text.lines().all(|l| l.contains("\"errors\":0")), "{text}");
}

/// The Chromium to drive: `GLINT_CHROMIUM`, else the Debian package's.
fn chromium() -> Option<PathBuf> {
    std::env::var_os("GLINT_CHROMIUM")
        .map(PathBuf::from)
        .or_else(|| Some(PathBuf::from("/usr/bin/chromium")))
        .filter(|p| p.is_file())
}

fn rgb8(path: &Path) -> image::RgbImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
}

/// (relative RMSE, relative mean-luminance difference) of `frame` against `reference`.
fn compare(frame: &image::RgbImage, reference: &image::RgbImage) -> (f64, f64) {
    assert_eq!(frame.dimensions(), reference.dimensions());
    let (mut se, mut ss) = (0.0f64, 0.0f64);
    let (mut la, mut lb) = (0.0f64, 0.0f64);
    let lin = |v: u8| f64::from(glint::scene::texture::srgb_to_linear(f32::from(v) / 255.0));
    let lum = |p: &image::Rgb<u8>| 0.2126 * lin(p[0]) + 0.7152 * lin(p[1]) + 0.0722 * lin(p[2]);
    for (a, b) in frame.pixels().zip(reference.pixels()) {
        for c in 0..3 {
            let (x, y) = (f64::from(a[c]) / 255.0, f64::from(b[c]) / 255.0);
            se += (x - y) * (x - y);
            ss += y * y;
        }
        la += lum(a);
        lb += lum(b);
    }
    ((se / ss).sqrt(), (la - lb) / lb)
}

fn glint_view_frame(bundle: &Path, dir: &Path) -> PathBuf {
    let frames = dir.join("glint-view");
    let size = format!("{}x{}", SIZE.0, SIZE.1);
    let out = Command::new(env!("CARGO_BIN_EXE_glint-view"))
        .args([
            bundle.as_os_str(),
            "--replay".as_ref(),
            "--headless".as_ref(),
        ])
        .args([
            "--size",
            &size,
            "--reflections",
            "off",
            "--curved",
            "off",
            "--impostors",
            "off",
            "--every",
            "1000000",
        ])
        .arg("--out")
        .arg(&frames)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "glint-view: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    frames.join("frame_00000.png")
}

#[test]
fn babylon_renders_the_export_like_glint_view() {
    let Some(chromium) = chromium() else {
        println!(
            "SKIPPED: no Chromium (/usr/bin/chromium or GLINT_CHROMIUM): apt-get install chromium"
        );
        return;
    };
    node_modules();
    for scene in ["glossy-room", "textured-room"] {
        let dir = out_dir(scene);
        let glb = export(scene);
        let reference = glint_view_frame(&bundle(scene), &dir);
        // The first camera node is the first camera path's first keyframe: glint-view's frame 0.
        let json = glb_json(&glb);
        let camera = json["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .find(|n| n.get("camera").is_some())
            .expect("a camera node")["extras"]["glint_camera"]
            .clone();
        let shot = dir.join("babylon.png");
        let out = Command::new("timeout")
            .arg("180")
            .arg("node")
            .arg(web().join("render.mjs"))
            .arg(&chromium)
            .arg(&glb)
            .arg(&shot)
            .args([SIZE.0.to_string(), SIZE.1.to_string(), camera.to_string()])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{scene}: render.mjs: {}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        let (rmse, lum) = compare(&rgb8(&shot), &rgb8(&reference));
        println!(
            "{scene}: Babylon.js vs glint-view --reflections off at {}x{}: relative RMSE {:.4}, mean luminance {:+.4}",
            SIZE.0, SIZE.1, rmse, lum
        );
        let keep = || {
            let d = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("target/export-failures")
                .join(scene);
            std::fs::create_dir_all(&d).unwrap();
            std::fs::copy(&shot, d.join("babylon.png")).unwrap();
            std::fs::copy(&reference, d.join("glint-view.png")).unwrap();
            d
        };
        if rmse > MAX_RELATIVE_RMSE || lum.abs() > MAX_LUMINANCE_DIFF {
            let d = keep();
            panic!(
                "{scene}: relative RMSE {rmse:.4} (at most {MAX_RELATIVE_RMSE}), mean luminance differs by {lum:+.4} (at most ±{MAX_LUMINANCE_DIFF}); frames in {}",
                d.display()
            );
        }
    }
}

#[test]
fn the_comparison_sees_a_wrong_exposure() {
    // Not vacuous: a frame one stop darker is far outside both bounds.
    let a = image::RgbImage::from_fn(8, 8, |x, _| image::Rgb([100 + x as u8 * 10; 3]));
    let b = image::RgbImage::from_fn(8, 8, |x, _| {
        let v = glint::scene::texture::srgb_to_linear((100 + x as u8 * 10) as f32 / 255.0) * 0.5;
        image::Rgb([(glint::image_io::linear_to_srgb(v) * 255.0).round() as u8; 3])
    });
    let (rmse, lum) = compare(&b, &a);
    assert!(
        rmse > MAX_RELATIVE_RMSE && lum < -MAX_LUMINANCE_DIFF,
        "{rmse} {lum}"
    );
    assert_eq!(compare(&a, &a), (0.0, 0.0));
}

#[test]
fn a_bundle_without_radiosity_is_refused_naming_the_stage() {
    let scene_only = shipped_bundle(&Recipe::new("cornell-box").then(Step::Scene));
    let glb = out_dir("refused").join("x.glb");
    let (code, _, stderr) = common::run_exe(
        env!("CARGO_BIN_EXE_glint-bundle"),
        &["export".as_ref(), scene_only.as_os_str(), glb.as_os_str()],
    );
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.contains("no `radiosity` stage") && stderr.contains(&*scene_only.to_string_lossy()),
        "{stderr}"
    );
    assert!(!glb.exists(), "nothing written");
}

#[test]
fn page_size_and_format_options_shape_the_lightmaps() {
    let glb = out_dir("options").join("glossy-room-64-srgb.glb");
    let (code, stdout, stderr) = common::run_exe(
        env!("CARGO_BIN_EXE_glint-bundle"),
        &[
            "export".as_ref(),
            bundle("glossy-room").as_os_str(),
            glb.as_os_str(),
            "--page-size".as_ref(),
            "64".as_ref(),
            "--format".as_ref(),
            "srgb".as_ref(),
            "--json".as_ref(),
        ],
    );
    assert_eq!(code, 0, "{stdout}{stderr}");
    let report: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(report["encoding"], "srgb");
    let bytes = std::fs::read(&glb).unwrap();
    let g = gltf::Glb::from_slice(&bytes).unwrap();
    let json: serde_json::Value = serde_json::from_slice(&g.json).unwrap();
    assert_eq!(json["extras"]["glint_lightmaps"]["encoding"], "srgb");
    let bin = g.bin.unwrap();
    let mut pages = 0;
    for image in json["images"].as_array().unwrap() {
        if !image["name"]
            .as_str()
            .is_some_and(|n| n.starts_with("lightmap"))
        {
            continue;
        }
        let view = &json["bufferViews"][image["bufferView"].as_u64().unwrap() as usize];
        let start = view["byteOffset"].as_u64().unwrap() as usize;
        let end = start + view["byteLength"].as_u64().unwrap() as usize;
        let png = image::load_from_memory(&bin[start..end]).unwrap();
        assert!(
            png.width().max(png.height()) <= 64,
            "{}×{}",
            png.width(),
            png.height()
        );
        assert!(!png.color().has_alpha(), "srgb pages are RGB");
        pages += 1;
    }
    assert_eq!(pages, report["pages"].as_array().unwrap().len());
    let (code, _, stderr) = common::run_exe(
        env!("CARGO_BIN_EXE_glint-bundle"),
        &[
            "export".as_ref(),
            bundle("glossy-room").as_os_str(),
            glb.as_os_str(),
            "--format".as_ref(),
            "exr".as_ref(),
        ],
    );
    assert_eq!(code, 2, "an unknown format is a usage error: {stderr}");
    assert!(stderr.contains("rgbd, srgb"), "{stderr}");
}

#[test]
fn the_export_lightmaps_example_runs() {
    // `cargo test` builds the examples before the tests; `cargo test --test export` does not.
    let exe = std::env::current_exe().unwrap();
    let example = exe
        .parent()
        .and_then(Path::parent)
        .unwrap()
        .join("examples/export_lightmaps");
    if !example.is_file() {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let status = Command::new(cargo)
            .args(["build", "--example", "export_lightmaps"])
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .status()
            .unwrap();
        assert!(status.success());
    }
    let glb = out_dir("example").join("glossy-room.glb");
    let (code, stdout, stderr) = common::run_exe(
        example.to_str().unwrap(),
        &[
            bundle("glossy-room").as_os_str(),
            glb.as_os_str(),
            "32".as_ref(),
        ],
    );
    assert_eq!(code, 0, "{stdout}{stderr}");
    assert!(stdout.contains("lightmap page 0: 32×"), "{stdout}");
    assert!(glb.is_file());
}

#[test]
fn an_export_is_deterministic() {
    let dir = out_dir("twice");
    let [a, b] = ["a.glb", "b.glb"].map(|n| dir.join(n));
    for glb in [&a, &b] {
        let (code, _, stderr) = common::run_exe(
            env!("CARGO_BIN_EXE_glint-bundle"),
            &[
                "export".as_ref(),
                bundle("textured-room").as_os_str(),
                glb.as_os_str(),
            ],
        );
        assert_eq!(code, 0, "{stderr}");
    }
    assert!(
        std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(),
        "same bundle, same bytes"
    );
}
