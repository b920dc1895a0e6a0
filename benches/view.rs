//! Frame times of the viewer: each shipped scene's first camera path replayed headless at
//! 720×486, every frame timed (one untimed warm-up frame first), no frames written.
//!
//! Bundles are baked at draft quality into `target/tmp/view-bench/NAME.glint` when missing or
//! out of date (the radiosity textures' resolution barely changes the frame time; the triangle
//! count and the pixels covered do). Per-scene timings land next to them as
//! `NAME/timings.json`.
//!
//! Each path is replayed [`REPEATS`] times (`GLINT_BENCH_REPEATS` overrides) and the run with
//! the lowest median GPU time is reported: on a shared machine other processes only ever add
//! time, so the quietest run is the best estimate of the frame cost.
//!
//! A second table compares glossy reflections (issue 9) on glossy-room and breakfast-room in
//! one run: off, geometry-based, and image-based with 1, 2 and 4 maps by angle (2 by
//! distance): frame time, its ratio to the geometry-based mode, and the mean error against
//! the CPU evaluation of the same equation. The frame time (start to GPU done) is the measure:
//! the GPU timestamps bracket the scene pass only, not the reflection passes.
//!
//! `cargo bench --bench view` (the `view` feature, on by default). The adapter is the one
//! `Gpu::headless` picks: a hardware GPU when there is one, else Mesa's lavapipe; `WGPU_BACKEND`
//! narrows the choice. The table says which, and how the GPU time was measured.

use std::path::{Path, PathBuf};
use std::time::Instant;

use glint::bake::radiance_stage;
use glint::bake::{Stage, radiosity_stage, scene_stage, up_to_date};
use glint::bundle::stats::format_table;
use glint::geometry::Bvh;
use glint::progress::Silent;
use glint::scene::desc::RadiositySettings;
use glint::scene::{Quality, Scene};
use glint::view::cpu_render;
use glint::view::gpu::Gpu;
use glint::view::headless::Offscreen;
use glint::view::headless::{ReplayOptions, replay_with};
use glint::view::load::load;
use glint::view::radiance_maps::Selection;
use glint::view::reflections::{self, ReflectionMode};
use glint::view::replay::GpuTimeSource;
use glint::view::replay::schedule;

const SCENES: [&str; 4] = [
    "cornell-box",
    "breakfast-room",
    "glossy-room",
    "bunny-mirror",
];
const SIZE: (u32, u32) = (720, 486);
const REPEATS: usize = 3;

fn main() {
    let _ = env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn"))
        .try_init();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let work = Path::new(env!("CARGO_TARGET_TMPDIR")).join("view-bench");
    let gpu = Gpu::headless_with_features(wgpu::Features::TIMESTAMP_QUERY)
        .unwrap_or_else(|e| panic!("{e}"));
    let adapter = gpu.adapter_summary();
    let repeats = std::env::var("GLINT_BENCH_REPEATS")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
        .unwrap_or(REPEATS)
        .max(1);
    let mut rows = vec![
        [
            "scene",
            "triangles",
            "path",
            "frames",
            "GPU median ms",
            "GPU p95 ms",
            "GPU max ms",
            "frame median ms",
            "frame p95 ms",
            "CPU median ms",
        ]
        .map(String::from),
    ];
    let mut source = None;
    for name in SCENES {
        let bundle = bake_if_needed(&root.join(format!("scenes/{name}/scene.json")), &work, name);
        let data = load(&bundle).unwrap_or_else(|e| panic!("{e}"));
        let options = ReplayOptions {
            path: None,
            width: SIZE.0,
            height: SIZE.1,
            out: Some(work.join(name)),
            every: 0,
            hdr: false,
            exposure: 1.0,
            reflections: ReflectionMode::Off,
            ..ReplayOptions::default()
        };
        let t = (0..repeats)
            .map(|_| replay_with(&gpu, &data, &options, &Silent).unwrap_or_else(|e| panic!("{e}")))
            .min_by(|a, b| a.summary.gpu_ms.median.total_cmp(&b.summary.gpu_ms.median))
            .expect("at least one run");
        // The kept run's timings.json (each replay rewrote it).
        t.write(&work.join(name)).unwrap_or_else(|e| panic!("{e}"));
        source = Some(t.gpu_time_source);
        let s = &t.summary;
        rows.push([
            name.to_string(),
            data.scene.triangles.len().to_string(),
            t.path.clone(),
            t.frames.len().to_string(),
            format!("{:.2}", s.gpu_ms.median),
            format!("{:.2}", s.gpu_ms.p95),
            format!("{:.2}", s.gpu_ms.max),
            format!("{:.2}", s.frame_ms.median),
            format!("{:.2}", s.frame_ms.p95),
            format!("{:.3}", s.cpu_ms.median),
        ]);
    }
    println!(
        "\nglint-view frame times at {}x{}, first camera path of each scene, draft bake, best of {repeats} runs",
        SIZE.0, SIZE.1
    );
    println!("adapter: {adapter}");
    println!(
        "GPU time: {}",
        match source {
            Some(GpuTimeSource::TimestampQuery) => "timestamp queries around the render pass",
            _ => "submit to complete (the adapter has no timestamp queries)",
        }
    );
    println!("frame: start of the frame until the GPU finished it; CPU: record + submit\n");
    print!(
        "{}",
        format_table(
            &rows,
            &[false, true, false, true, true, true, true, true, true, true]
        )
    );
    reflection_table(&gpu, &work, root, repeats);
}

/// Glossy reflections on glossy-room and breakfast-room (their bundles also get the draft
/// `radiance` stage): per mode, the median frame time over the first camera path and the
/// mean error (8-bit sRGB units) at the path's first and middle frames against the CPU
/// evaluation of the same equation ([`reflections::cpu_reference`]; the reference path
/// tracer's image is not used yet). R = 1 here (no materials stage): the cost is the same.
fn reflection_table(gpu: &Gpu, work: &Path, root: &Path, repeats: usize) {
    let mut rows = vec![
        [
            "scene",
            "reflectors",
            "mode",
            "frame median ms",
            "× geometry",
            "GPU scene pass ms",
            "error vs CPU eq.",
        ]
        .map(String::from),
    ];
    // Geometry first: the other rows' ratios are to it.
    let modes: [(&str, ReflectionMode, Selection, usize); 6] = [
        ("geometry", ReflectionMode::Geometry, Selection::Angle, 0),
        ("off", ReflectionMode::Off, Selection::Angle, 0),
        (
            "image, 1 map (angle)",
            ReflectionMode::Image,
            Selection::Angle,
            1,
        ),
        (
            "image, 2 maps (angle)",
            ReflectionMode::Image,
            Selection::Angle,
            2,
        ),
        (
            "image, 4 maps (angle)",
            ReflectionMode::Image,
            Selection::Angle,
            4,
        ),
        (
            "image, 2 maps (distance)",
            ReflectionMode::Image,
            Selection::Distance,
            2,
        ),
    ];
    for name in ["glossy-room", "breakfast-room"] {
        let scene_json = root.join(format!("scenes/{name}/scene.json"));
        let bundle = bake_if_needed(&scene_json, work, name);
        let scene = Scene::load(&scene_json).unwrap_or_else(|e| panic!("{e}"));
        if !up_to_date(&bundle, &scene, Stage::Radiance, None) {
            radiance_stage::bake(&scene, &bundle, Quality::Draft, true, &Silent)
                .unwrap_or_else(|e| panic!("{e}"));
        }
        let data = load(&bundle).unwrap_or_else(|e| panic!("{e}"));
        let path = data.scene.camera_path(None).expect("a camera path");
        let frames = schedule(path);
        let views = [frames[0].camera, frames[frames.len() / 2].camera];
        let bvh = Bvh::build(&data.scene.triangles);
        let reflectors = reflections::reflectors_with_reflectance(&data);
        let references: Vec<Vec<u8>> = views
            .iter()
            .map(|c| {
                cpu_render::to_srgb8(&reflections::cpu_reference(
                    &data.scene,
                    &reflectors,
                    &bvh,
                    &data.map,
                    c,
                    SIZE.0,
                    SIZE.1,
                    1.0,
                ))
            })
            .collect();
        let mut geometry_ms = f64::NAN;
        for (label, mode, selection, count) in modes {
            let options = ReplayOptions {
                path: None,
                width: SIZE.0,
                height: SIZE.1,
                out: None,
                every: 0,
                hdr: false,
                exposure: 1.0,
                reflections: mode,
                selection,
                map_count: count,
                ..ReplayOptions::default()
            };
            let summary = (0..repeats)
                .map(|_| {
                    replay_with(gpu, &data, &options, &Silent).unwrap_or_else(|e| panic!("{e}"))
                })
                .min_by(|a, b| {
                    a.summary
                        .frame_ms
                        .median
                        .total_cmp(&b.summary.frame_ms.median)
                })
                .expect("at least one run")
                .summary;
            if mode == ReflectionMode::Geometry {
                geometry_ms = summary.frame_ms.median;
            }
            let mut off =
                Offscreen::new(gpu, &data, SIZE.0, SIZE.1, false).unwrap_or_else(|e| panic!("{e}"));
            off.selection = selection;
            off.map_count = count;
            off.set_reflections(gpu, &data, mode)
                .unwrap_or_else(|e| panic!("{e}"));
            let err: f64 = views
                .iter()
                .zip(&references)
                .map(|(c, r)| {
                    off.render(gpu, c).unwrap_or_else(|e| panic!("{e}"));
                    mean_diff(&off.read_rgba8(gpu).unwrap_or_else(|e| panic!("{e}")), r)
                })
                .sum::<f64>()
                / views.len() as f64;
            rows.push([
                name.to_string(),
                reflectors.len().to_string(),
                label.to_string(),
                format!("{:.2}", summary.frame_ms.median),
                format!("{:.2}", summary.frame_ms.median / geometry_ms),
                format!("{:.2}", summary.gpu_ms.median),
                format!("{err:.2}"),
            ]);
        }
    }
    println!(
        "\nglossy reflections at {}x{}: frame time (start to GPU done; the GPU timestamps bracket the scene pass only) and mean error vs the CPU equation (8-bit units, 2 views), best of {repeats} runs\n",
        SIZE.0, SIZE.1
    );
    print!(
        "{}",
        format_table(&rows, &[false, true, false, true, true, true, true])
    );
}

/// Mean absolute difference over RGB of two RGBA8 images, 8-bit units.
fn mean_diff(a: &[u8], b: &[u8]) -> f64 {
    let (mut sum, mut n) = (0u64, 0u64);
    for (pa, pb) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
        for k in 0..3 {
            sum += u64::from(pa[k].abs_diff(pb[k]));
            n += 1;
        }
    }
    sum as f64 / n.max(1) as f64
}

/// The scene's bundle with the scene and draft radiosity stages, baked unless up to date.
fn bake_if_needed(scene_json: &Path, work: &Path, name: &str) -> PathBuf {
    let bundle = work.join(format!("{name}.glint"));
    let scene = Scene::load(scene_json).unwrap_or_else(|e| panic!("{e}"));
    let settings = RadiositySettings::resolve(Quality::Draft, &scene.desc.bake.radiosity);
    let settings_json = radiosity_stage::settings_json(&settings);
    if !up_to_date(&bundle, &scene, Stage::Scene, None) {
        scene_stage::bake(&scene, &bundle, true).unwrap_or_else(|e| panic!("{e}"));
    }
    if !up_to_date(&bundle, &scene, Stage::Radiosity, Some(&settings_json)) {
        let start = Instant::now();
        radiosity_stage::bake(&scene, &bundle, &settings, true, &Silent)
            .unwrap_or_else(|e| panic!("{e}"));
        eprintln!(
            "baked {name} (draft) in {:.1} s",
            start.elapsed().as_secs_f64()
        );
    }
    bundle
}
