//! Curved reflectors in the viewer: Luksch et al.'s frame time against samples
//! per pixel, and the cost of Nielsen's cube maps.
//!
//! Table 1 — glossy-room at 720×486, the camera close to the curved teapot (it covers most of
//! the frame, so the frame time is the glossy shader's), twice: as shipped (a near-mirror
//! copper teapot, m = 0.01, where one sample is as good as many) and with the teapot's
//! material overridden to m = 0.2 (`glossy-room-rough`, baked alike): `--curved cubemap` with a mirror
//! lookup (0) and with regular patterns closest to 1, 4, 8, 16 and 32 samples per pixel
//! (the baked MIP environment map), plus `--curved off`, and the mirror lookup and 16
//! samples again without self-reflection (`--cube-self-occlusion off`), for its cost. Per row: the pattern's actual sample
//! count, the frame time (median and p95 of [`FRAMES`] frames, start to GPU done: the GPU
//! timestamps bracket the scene pass only), and the error on the teapot against the
//! reference path tracer (64 paths per pixel, cached as `reference.exr`): relative mean
//! absolute error of 4×4 block means and the relative bias of the mean, as in
//! `tests/view_curved.rs` (whose tolerances explain what the method cannot reproduce).
//!
//! Table 2 — cube-map generation: per scene, face size and generation count, the time from
//! submission to completion for all maps, and per reflector and generation.
//!
//! Bundles are baked at draft quality into `target/tmp/curved-bench/`. `cargo bench --bench
//! curved`; `GLINT_BENCH_SCENES=glossy-room` leaves breakfast-room out of table 2 (its draft
//! radiosity bake takes minutes on two cores).

use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::Vec3;
use glint::bundle::stats::format_table;
use glint::camera::Camera;
use glint::eval::Image;
use glint::eval::reference::{RenderOptions, render};
use glint::progress::Silent;
use glint::scene::Scene;
use glint::view::curved::{CurvedMode, CurvedSettings, curved_reflectors};
use glint::view::gpu::Gpu;
use glint::view::headless::Offscreen;
use glint::view::load::{ViewData, load};

mod common;
use common::{bake_if_needed, gpu, repo};

const SIZE: (u32, u32) = (720, 486);
const FRAMES: usize = 10;
const REFERENCE_SPP: u32 = 64;
const BLOCK: usize = 4;

fn main() {
    let _ = env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn"))
        .try_init();
    let work = Path::new(env!("CARGO_TARGET_TMPDIR")).join("curved-bench");
    let gpu = gpu();
    println!("adapter: {}", gpu.adapter_summary());

    let glossy_json = repo("scenes/glossy-room/scene.json");
    let glossy = bake_if_needed(&glossy_json, &work, "glossy-room", true);
    let data = load(&glossy).unwrap_or_else(|e| panic!("{e}"));
    samples_table(&gpu, &data, &glossy_json, &work, "teapot m = 0.01");
    // The same room with a rough teapot, where the number of samples matters.
    let rough_json = rough_teapot_scene(&glossy_json, &work);
    let rough = bake_if_needed(&rough_json, &work, "glossy-room-rough", true);
    let data = load(&rough).unwrap_or_else(|e| panic!("{e}"));
    samples_table(&gpu, &data, &rough_json, &work, "teapot m = 0.2");

    let scenes: Vec<String> = std::env::var("GLINT_BENCH_SCENES")
        .map(|s| s.split(',').map(str::to_owned).collect())
        .unwrap_or_else(|_| vec!["glossy-room".into(), "breakfast-room".into()]);
    let mut rows = vec![
        [
            "scene",
            "curved reflectors",
            "face size",
            "generations",
            "total ms",
            "ms per reflector and generation",
            "live map MiB",
        ]
        .map(String::from),
    ];
    for name in &scenes {
        let bundle = bake_if_needed(
            &repo(&format!("scenes/{name}/scene.json")),
            &work,
            name,
            true,
        );
        let data = load(&bundle).unwrap_or_else(|e| panic!("{e}"));
        let mut off = Offscreen::new(&gpu, &data, 64, 64).unwrap_or_else(|e| panic!("{e}"));
        for face_size in [64u32, 128, 256] {
            for generations in [1u32, 2] {
                let settings = CurvedSettings {
                    glossy_samples: 0,
                    face_size,
                    generations,
                    parallax: true,
                    self_occlusion: true,
                    specular_aa: true,
                };
                // The quietest of three builds (pipelines are created each time, not timed).
                let mut best = f64::INFINITY;
                let mut count = 0;
                let mut bytes = 0;
                for _ in 0..3 {
                    off.set_curved(&gpu, &data, CurvedMode::Cubemap, settings)
                        .unwrap_or_else(|e| panic!("{e}"));
                    let c = off.curved().expect("built");
                    best = best.min(c.generation_seconds * 1e3);
                    count = c.reflector_count();
                    bytes = c.live_map_bytes();
                }
                rows.push([
                    name.clone(),
                    count.to_string(),
                    face_size.to_string(),
                    generations.to_string(),
                    format!("{best:.1}"),
                    format!("{:.2}", best / (count.max(1) as f64 * generations as f64)),
                    format!("{:.1}", bytes as f64 / (1 << 20) as f64),
                ]);
            }
        }
    }
    println!("\nCube-map generation (all six faces, MIP levels included)");
    print!(
        "{}",
        format_table(&rows, &[false, true, true, true, true, true, true])
    );
}

/// Roughness of the teapot in the second run of table 1.
const ROUGH_M: f32 = 0.2;

/// glossy-room's scene.json with the teapot's material (`PolishedMetal`) overridden to a
/// rough copper lobe (m = [`ROUGH_M`]), written with a copy of the geometry into `work`.
fn rough_teapot_scene(scene_json: &Path, work: &Path) -> PathBuf {
    let dir = work.join("glossy-room-rough-scene");
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let mut v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(scene_json).unwrap_or_else(|e| panic!("{e}")))
            .unwrap_or_else(|e| panic!("{e}"));
    let glb = v["geometry"].as_str().expect("a geometry file").to_owned();
    std::fs::copy(scene_json.parent().unwrap().join(&glb), dir.join(&glb))
        .unwrap_or_else(|e| panic!("{e}"));
    v["name"] = "glossy-room-rough".into();
    v["materials"]["PolishedMetal"] = serde_json::json!({
        "albedo": [0.0, 0.0, 0.0],
        "lobes": [{ "model": "kurt", "ks": [0.95, 0.64, 0.54], "r0": 1.0, "mx": ROUGH_M, "my": ROUGH_M, "alpha": 0.0 }]
    });
    let path = dir.join("scene.json");
    std::fs::write(&path, serde_json::to_string_pretty(&v).unwrap())
        .unwrap_or_else(|e| panic!("{e}"));
    path
}

/// Table 1: frame time and error against samples per pixel.
fn samples_table(gpu: &Gpu, data: &ViewData, scene_json: &Path, work: &Path, label: &str) {
    let teapot = curved_reflectors(&data.scene)
        .into_iter()
        .find(|r| r.name == "Teapot")
        .expect("glossy-room has a curved teapot");
    let camera = Camera::look_at(
        teapot.centre + Vec3::new(0.32, 0.22, 0.42),
        teapot.centre,
        Vec3::Y,
        38f32.to_radians(),
    );
    let (w, h) = SIZE;
    let reference = reference_image(scene_json, work, &camera, &data.scene.name);
    let mask = teapot_mask(data, &teapot.triangles, &camera);
    let count = mask.iter().filter(|&&m| m).count();
    let lum = |c: Vec3| f64::from(glint::eval::luminance(c));
    let reference_mean = mask
        .iter()
        .zip(&reference.rgb)
        .filter(|(m, _)| **m)
        .map(|(_, c)| lum(*c))
        .sum::<f64>()
        / count as f64;

    let mut off = Offscreen::new(gpu, data, w, h).unwrap_or_else(|e| panic!("{e}"));
    let mut rows = vec![
        [
            "mode",
            "--glossy-samples",
            "pattern samples",
            "env map",
            "self-reflection",
            "frame median ms",
            "frame p95 ms",
            "block MAE",
            "bias",
        ]
        .map(String::from),
    ];
    // With self-reflection (rays cast at the teapot's own triangles) and, for its cost,
    // without it at two sample counts.
    let runs = [
        (CurvedMode::Off, 0u32, true),
        (CurvedMode::Cubemap, 0, true),
        (CurvedMode::Cubemap, 0, false),
        (CurvedMode::Cubemap, 1, true),
        (CurvedMode::Cubemap, 4, true),
        (CurvedMode::Cubemap, 8, true),
        (CurvedMode::Cubemap, 16, true),
        (CurvedMode::Cubemap, 16, false),
        (CurvedMode::Cubemap, 32, true),
    ];
    for (mode, samples, self_occlusion) in runs {
        let settings = CurvedSettings {
            glossy_samples: samples,
            self_occlusion,
            ..Default::default()
        };
        off.set_curved(gpu, data, mode, settings)
            .unwrap_or_else(|e| panic!("{e}"));
        off.render(gpu, &camera).unwrap_or_else(|e| panic!("{e}")); // warm-up
        let mut times: Vec<f64> = (0..FRAMES)
            .map(|_| {
                off.render(gpu, &camera)
                    .unwrap_or_else(|e| panic!("{e}"))
                    .frame_ms
            })
            .collect();
        times.sort_by(f64::total_cmp);
        let median = times[times.len() / 2];
        let p95 = times[((times.len() as f64 * 0.95).ceil() as usize).min(times.len()) - 1];
        let frame = off.read_hdr(gpu).unwrap();
        let (block_mae, bias) = errors(&frame, &reference.rgb, &mask, w as usize, h as usize);
        let (pattern, source) = match off.curved() {
            Some(c) if samples > 0 => (
                c.pattern_samples()[0][0].to_string(),
                format!("{:?}", c.sources()[0].1).to_lowercase(),
            ),
            Some(_) => ("mirror".into(), "live".into()),
            None => ("–".into(), "–".into()),
        };
        rows.push([
            mode.to_string(),
            samples.to_string(),
            pattern,
            source,
            if mode == CurvedMode::Off {
                "–".into()
            } else if self_occlusion {
                "on".into()
            } else {
                "off".into()
            },
            format!("{median:.2}"),
            format!("{p95:.2}"),
            format!("{:.3}", block_mae / reference_mean),
            format!("{:+.3}", bias / reference_mean),
        ]);
    }
    println!(
        "\n{} ({label}) at {w}×{h}, camera on the teapot ({count} teapot pixels; reference {REFERENCE_SPP} paths/pixel)",
        data.scene.name
    );
    print!(
        "{}",
        format_table(
            &rows,
            &[false, true, true, false, false, true, true, true, true]
        )
    );
}

/// Mean absolute difference of 4×4 block means wholly in `mask`, and the difference of the
/// means over `mask` (both in luminance).
fn errors(a: &[Vec3], b: &[Vec3], mask: &[bool], w: usize, h: usize) -> (f64, f64) {
    let lum = |c: Vec3| f64::from(glint::eval::luminance(c));
    let (mut abs, mut blocks) = (0.0f64, 0usize);
    for by in 0..h / BLOCK {
        for bx in 0..w / BLOCK {
            let idx: Vec<usize> = (0..BLOCK * BLOCK)
                .map(|k| (by * BLOCK + k / BLOCK) * w + bx * BLOCK + k % BLOCK)
                .collect();
            if idx.iter().all(|&i| mask[i]) {
                let ga: f64 = idx.iter().map(|&i| lum(a[i])).sum();
                let gb: f64 = idx.iter().map(|&i| lum(b[i])).sum();
                abs += (ga - gb).abs() / (BLOCK * BLOCK) as f64;
                blocks += 1;
            }
        }
    }
    let n = mask.iter().filter(|&&m| m).count().max(1) as f64;
    let diff: f64 = mask
        .iter()
        .zip(a.iter().zip(b))
        .filter(|(m, _)| **m)
        .map(|(_, (x, y))| lum(*x) - lum(*y))
        .sum();
    (abs / blocks.max(1) as f64, diff / n)
}

/// Pixels whose centre ray hits the teapot.
fn teapot_mask(data: &ViewData, triangles: &[u32], camera: &Camera) -> Vec<bool> {
    let (w, h) = SIZE;
    let bvh = data.scene.build_bvh();
    let mut is_teapot = vec![false; data.scene.triangles.len()];
    for &t in triangles {
        is_teapot[t as usize] = true;
    }
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let d = camera.ray_direction(Camera::pixel_ndc(x, y, w, h), w as f32 / h as f32);
            bvh.closest_hit(camera.position, d, f32::INFINITY)
                .is_some_and(|hit| is_teapot[hit.triangle as usize])
        })
        .collect()
}

/// The reference of the scene the viewer represents (the teapot's lobes kept, every other
/// material diffuse), cached in `work`.
fn reference_image(scene_json: &Path, work: &Path, camera: &Camera, key: &str) -> Image {
    let path = work.join(format!(
        "reference-{key}-{}x{}-{REFERENCE_SPP}spp.exr",
        SIZE.0, SIZE.1
    ));
    if let Ok(bytes) = std::fs::read(&path)
        && let Ok(image) = Image::from_exr(&bytes)
    {
        return image;
    }
    let mut scene = Scene::load(scene_json).unwrap_or_else(|e| panic!("{e}"));
    let teapot = scene
        .reflectors
        .iter()
        .find(|r| r.name == "Teapot")
        .expect("a teapot")
        .material;
    for (i, m) in scene.materials.iter_mut().enumerate() {
        if i as u32 != teapot {
            m.lobes.clear();
        }
    }
    let bvh = scene.build_bvh();
    let start = Instant::now();
    let image = render(
        &scene,
        &bvh,
        camera,
        &RenderOptions {
            width: SIZE.0,
            height: SIZE.1,
            spp: REFERENCE_SPP,
            ..Default::default()
        },
        &Silent,
    )
    .unwrap_or_else(|e| panic!("{e}"))
    .image;
    eprintln!(
        "reference rendered in {:.1} s",
        start.elapsed().as_secs_f64()
    );
    std::fs::create_dir_all(work).unwrap_or_else(|e| panic!("{e}"));
    std::fs::write(&path, image.to_exr().unwrap_or_else(|e| panic!("{e}")))
        .unwrap_or_else(|e| panic!("{e}"));
    image
}
