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
//! `cargo bench --bench view` (the `view` feature, on by default). The adapter is the one
//! `Gpu::headless` picks: a hardware GPU when there is one, else Mesa's lavapipe; `WGPU_BACKEND`
//! narrows the choice. The table says which, and how the GPU time was measured.

use std::path::{Path, PathBuf};
use std::time::Instant;

use glint::bake::{Stage, radiosity_stage, scene_stage, up_to_date};
use glint::bundle::stats::format_table;
use glint::progress::Silent;
use glint::scene::desc::RadiositySettings;
use glint::scene::{Quality, Scene};
use glint::view::gpu::Gpu;
use glint::view::headless::{ReplayOptions, replay_with};
use glint::view::load::load;
use glint::view::replay::GpuTimeSource;

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
