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
//! A second table compares glossy planar reflections (Bastos et al. 1999 Eq. 2) on
//! glossy-room and breakfast-room in one run: off, geometry-based, and image-based with 1, 2
//! and 4 maps by angle (2 by distance): frame time, its ratio to the geometry-based mode, the
//! GPU time (timestamps from the first pass's beginning to the last pass's end, reflection
//! passes included), and the mean error against the reference path tracer and against the CPU
//! evaluation of the same equation ([`reflection_table`]). `GLINT_BENCH_SCENES` may also name
//! scenes outside `scenes/` by their scene.json (an entry ending in `.json`, named by its
//! folder: a generated building), `GLINT_BENCH_PATHS` (a comma list) the camera paths timed
//! (each its own rows; the first path when unset), `GLINT_BENCH_ERRORS=off` leaves the error
//! columns out (the path tracer on a large building), and `GLINT_BENCH_PASSES=on` adds a
//! table of each mode's reflection passes (mirror passes, gap fill, pyramid, composite), each
//! timed by the frame time it saves when left out ([`SkippedPasses`]).
//!
//! A third table measures fidelity ([`fidelity_table`]): per shipped scene (every folder of
//! `scenes/`), drawn as `glint-view` draws by default (its multisampling, probes and glass),
//! and per mode (geometry mode at recursion depths 1 and 2, image, off; reflections off alone
//! without planar reflectors), the whole-frame relative RMSE and the relative RMSE over
//! the reflectors' pixels against the reference path tracer at the same camera (each camera
//! path's first keyframe, [`FIDELITY_SIZE`], [`FIDELITY_SPP`] paths per pixel: its noise is
//! part of the figure), over the reflectors' pixels against the CPU evaluation of the
//! viewer's own equation (the viewer's share of the error), and per glossy material in view
//! its mean luminance over the path tracer's. `GLINT_BENCH_TABLES` (a comma list
//! of `frames`, `reflections`, `fidelity`, `aa`; all by default) picks the tables and
//! `GLINT_BENCH_SCENES` (a comma list) the scenes, `GLINT_BENCH_MODES` (a comma list of
//! `geometry`, `geometry2` (depth 2), `off`, `image1`, `image2`, `image4`, `image2d`; all by
//! default) the reflection table's modes (geometry always runs: the ratios are to it). `GLINT_BENCH_FIDELITY_QUALITY`
//! (`draft`, `default`, `high`), `GLINT_BENCH_FIDELITY_SIZE` (`WxH`) and
//! `GLINT_BENCH_FIDELITY_SPP` set the fidelity table's bakes, frame and references (cached in
//! `target/tmp/view-bench/references/`); `GLINT_BENCH_FIDELITY_SUPERSAMPLE=s` (1 to 8, 1 by
//! default) renders the viewer's frame at s × s samples a pixel, box-filtered as the path
//! tracer's pixels are, for the path-tracer columns (at one sample a pixel the per-pixel
//! error at every silhouette is the viewer's aliasing, not its light);
//! `GLINT_BENCH_CUBE_PARALLAX=off` turns the curved reflectors' distance-corrected lookups off
//! (as `glint-view --cube-parallax off`); `GLINT_BENCH_CUBE_SELF_OCCLUSION=off` likewise
//! (`--cube-self-occlusion off`); `GLINT_BENCH_GLOSSY_SAMPLES=N` and `GLINT_BENCH_FACE_SIZE=N`
//! set `--glossy-samples` (the bake's sample budget by default, as `glint-view`) and `--cube-size`;
//! `GLINT_BENCH_TERMINAL=off` turns the near-mirrors' terminal cube maps off in the
//! reflections table (as `--terminal-cubemaps off`); `GLINT_BENCH_VIEW_ARGS` passes further
//! `glint-view` flags to the fidelity table's viewer (`"--probes off"`: how much of a
//! scene's error the probes carry).
//!
//! A fourth table (`aa`, [`aa_table`]) is anti-aliasing's cost: the frame table's replays
//! (one run each) at one sample a pixel and at the default multisample count, with reflections
//! off and in both modes (`GLINT_BENCH_MODES`: `off`, `geometry`, `image`). A fifth
//! (`probes`, not in the default list) times glossy-room, its table top left undeclared, with
//! and without the reflection probe that then lights it ([`probe_table`]).
//!
//! `cargo bench --bench view` (the `view` feature, on by default). The adapter is the one
//! `Gpu::headless` picks: a hardware GPU when there is one, else Mesa's lavapipe; `WGPU_BACKEND`
//! narrows the choice. The table says which, and how the GPU time was measured.

use std::path::Path;
use std::time::Instant;

use glint::bundle::stats::format_table;
use glint::eval::Image;
use glint::eval::compare::compare;
use glint::eval::reference::{self, RenderOptions};
use glint::geometry::Bvh;
use glint::progress::Silent;
use glint::scene::{Quality, Scene};
use glint::view::cpu;
use glint::view::gpu::Gpu;
use glint::view::headless::Offscreen;
use glint::view::headless::replay::GpuTimeSource;
use glint::view::headless::replay::schedule;
use glint::view::headless::{ReplayOptions, replay_with};
use glint::view::load::load;
use glint::view::options::{CurvedSettings, RecursionSettings, ViewOptions};
use glint::view::reflections::downsample::map_factor;
use glint::view::reflections::radiance_maps::Selection;
use glint::view::reflections::{self, ReflectionMode, SkippedPasses};

mod common;
#[path = "common/cpu_time.rs"]
mod cpu_time;
use common::{bake_all_at, bake_if_needed, gpu, half_size, mean_diff, median, repo};

const SCENES: [&str; 4] = [
    "cornell-box",
    "breakfast-room",
    "glossy-room",
    "bunny-mirror",
];
const SIZE: (u32, u32) = (720, 486);

/// The anti-aliasing table's supersampled column: `--supersample 2`, four shaded samples a
/// pixel.
const AA_SUPERSAMPLE: u32 = 2;
const REPEATS: usize = 3;

fn main() {
    let _ = env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn"))
        .try_init();
    let work = Path::new(env!("CARGO_TARGET_TMPDIR")).join("view-bench");
    let gpu = gpu();
    let adapter = gpu.adapter_summary();
    let repeats = std::env::var("GLINT_BENCH_REPEATS")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
        .unwrap_or(REPEATS)
        .max(1);
    let tables = std::env::var("GLINT_BENCH_TABLES")
        .unwrap_or_else(|_| "frames,reflections,fidelity,aa".to_string());
    let wanted = |t: &str| tables.split(',').any(|w| w.trim() == t);
    if wanted("frames") {
        frame_table(&gpu, &work, &adapter, repeats);
    }
    if wanted("reflections") {
        reflection_table(&gpu, &work, repeats);
    }
    if wanted("fidelity") {
        fidelity_table(&gpu, &work);
    }
    if wanted("aa") {
        aa_table(&gpu, &work);
    }
    if wanted("probes") {
        probe_table(&gpu, &work, repeats);
    }
}

/// Reflection probes' cost: glossy-room with its `TableTop` reflector removed from scene.json
/// (shipped glossy-room declares every glossy surface, so it has no probe; without the
/// reflector the glossy table top reads the probe the bake places above it), draft bake with
/// the materials stage (which holds the probe), its first camera path replayed with every
/// reflection pass off, with and without the probe pass (`--probes on|off`), best of
/// `repeats` runs each.
fn probe_table(gpu: &Gpu, work: &Path, repeats: usize) {
    let name = "glossy-room-undeclared-table";
    let folder = work.join(name).join("scene");
    std::fs::create_dir_all(&folder).unwrap_or_else(|e| panic!("{}: {e}", folder.display()));
    let shipped = repo("scenes/glossy-room");
    for file in ["scene.json", "glossy-room.glb"] {
        std::fs::copy(shipped.join(file), folder.join(file))
            .unwrap_or_else(|e| panic!("{file}: {e}"));
    }
    let scene_json = folder.join("scene.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&scene_json).unwrap()).unwrap();
    v["reflectors"]
        .as_array_mut()
        .expect("glossy-room has reflectors")
        .retain(|r| r["mesh"] != "TableTop");
    std::fs::write(&scene_json, v.to_string()).unwrap();
    let bundle = bake_if_needed(&scene_json, work, name, true);
    let data = load(&bundle).unwrap_or_else(|e| panic!("{e}"));
    let mut rows = vec![["scene", "probes", "GPU median ms", "frame median ms"].map(String::from)];
    for probes in [false, true] {
        let options = ReplayOptions {
            width: SIZE.0,
            height: SIZE.1,
            view: ViewOptions {
                probes,
                ..ViewOptions::default()
            },
            ..ReplayOptions::default()
        };
        let t = (0..repeats)
            .map(|_| replay_with(gpu, &data, &options, &Silent).unwrap_or_else(|e| panic!("{e}")))
            .min_by(|a, b| a.summary.gpu_ms.median.total_cmp(&b.summary.gpu_ms.median))
            .expect("at least one run");
        rows.push([
            name.to_string(),
            if probes { "on" } else { "off" }.to_string(),
            format!("{:.2}", t.summary.gpu_ms.median),
            format!("{:.2}", t.summary.frame_ms.median),
        ]);
    }
    println!(
        "\nreflection probes at {}x{}, first camera path, reflections and curved reflectors off, draft bake, best of {repeats} runs\n",
        SIZE.0, SIZE.1
    );
    print!("{}", format_table(&rows, &[false, false, true, true]));
}

/// The scenes of `all` that `GLINT_BENCH_SCENES` (a comma list; all when unset) names.
fn picked<'a>(all: &[&'a str]) -> Vec<&'a str> {
    let only = std::env::var("GLINT_BENCH_SCENES").ok();
    all.iter()
        .copied()
        .filter(|s| {
            only.as_deref()
                .is_none_or(|o| o.split(',').any(|w| w.trim() == *s))
        })
        .collect()
}

/// Each shipped scene's first camera path replayed, best of `repeats` runs.
fn frame_table(gpu: &Gpu, work: &Path, adapter: &str, repeats: usize) {
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
    for name in picked(&SCENES) {
        let bundle = bake_if_needed(
            &repo(&format!("scenes/{name}/scene.json")),
            work,
            name,
            false,
        );
        let data = load(&bundle).unwrap_or_else(|e| panic!("{e}"));
        let options = ReplayOptions {
            path: None,
            width: SIZE.0,
            height: SIZE.1,
            out: Some(work.join(name)),
            every: 0,
            hdr: false,
            ..ReplayOptions::default()
        };
        let t = (0..repeats)
            .map(|_| replay_with(gpu, &data, &options, &Silent).unwrap_or_else(|e| panic!("{e}")))
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
            Some(GpuTimeSource::TimestampQuery) =>
                "timestamp queries from the first pass's beginning to the last pass's end",
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

/// Anti-aliasing's cost: each shipped scene's first camera path replayed as in
/// [`frame_table`] (every frame timed, one run) at `--samples 1`, at the default sample
/// count, and at the default sample count with `--supersample` [`AA_SUPERSAMPLE`], the
/// per-frame medians side by side, with reflections off (a bundle of D alone) and on in both
/// modes (a bundle with every stage the scene requires).
fn aa_table(gpu: &Gpu, work: &Path) {
    let on = ViewOptions::default().samples;
    let ss = AA_SUPERSAMPLE;
    let mut rows = vec![[
        "scene".to_string(),
        "reflections".to_string(),
        "frames".to_string(),
        "GPU median ms, 1 sample".to_string(),
        format!("GPU median ms, {on}x MSAA"),
        "ratio".to_string(),
        "frame median ms, 1 sample".to_string(),
        format!("frame median ms, {on}x MSAA"),
        format!("GPU median ms, {on}x MSAA, {ss}x{ss} supersampled"),
        "ratio".to_string(),
    ]];
    let modes = [
        ("off", ReflectionMode::Off),
        ("geometry", ReflectionMode::Geometry),
        ("image", ReflectionMode::Image),
    ];
    let only = std::env::var("GLINT_BENCH_MODES").ok();
    for name in picked(&SCENES) {
        let scene_json = repo(&format!("scenes/{name}/scene.json"));
        let d_only =
            load(&bake_if_needed(&scene_json, work, name, false)).unwrap_or_else(|e| panic!("{e}"));
        let mut all = None;
        for (label, mode) in modes {
            if only
                .as_deref()
                .is_some_and(|o| !o.split(',').any(|w| w.trim() == label))
            {
                continue;
            }
            let data = match mode {
                ReflectionMode::Off => &d_only,
                _ => all.get_or_insert_with(|| {
                    load(&bake_all_at(&scene_json, work, name, Quality::Draft))
                        .unwrap_or_else(|e| panic!("{e}"))
                }),
            };
            let run = |samples: u32, supersample: u32| {
                let options = ReplayOptions {
                    width: SIZE.0,
                    height: SIZE.1,
                    every: 0,
                    supersample,
                    view: ViewOptions {
                        samples,
                        reflections: mode,
                        ..ViewOptions::default()
                    },
                    ..ReplayOptions::default()
                };
                replay_with(gpu, data, &options, &Silent).unwrap_or_else(|e| panic!("{e}"))
            };
            let (off, aa, sup) = (run(1, 1), run(on, 1), run(on, ss));
            let (a, b, c) = (&off.summary, &aa.summary, &sup.summary);
            rows.push([
                name.to_string(),
                label.to_string(),
                off.frames.len().to_string(),
                format!("{:.2}", a.gpu_ms.median),
                format!("{:.2}", b.gpu_ms.median),
                format!("{:.2}", b.gpu_ms.median / a.gpu_ms.median),
                format!("{:.2}", a.frame_ms.median),
                format!("{:.2}", b.frame_ms.median),
                format!("{:.2}", c.gpu_ms.median),
                format!("{:.2}", c.gpu_ms.median / a.gpu_ms.median),
            ]);
        }
    }
    println!(
        "\nanti-aliasing at {}x{}: every frame of each scene's first camera path (draft bake; reflections off: D only), one run per sample count; ratios to 1 sample\n",
        SIZE.0, SIZE.1
    );
    print!(
        "{}",
        format_table(
            &rows,
            &[false, false, true, true, true, true, true, true, true, true]
        )
    );
}

/// Glossy reflections on glossy-room and breakfast-room (their bundles also get the draft
/// `materials` and `radiance` stages): per mode, in one run, the median frame time over every
/// [`FRAME_STRIDE`]-th frame of the first camera path (best of `repeats`), its ratio to the
/// geometry-based mode, the GPU time spanning all passes, and the mean error (8-bit sRGB
/// units) at the path's middle frame against the reference path tracer
/// ([`glint::eval::reference`], [`REFERENCE_SPP`] paths per pixel; both images box-filtered
/// 2×2 against its noise) and against the CPU evaluation of the same equation
/// ([`reflections::cpu_reference`]: reconstruction error alone).
fn reflection_table(gpu: &Gpu, work: &Path, repeats: usize) {
    let mut rows = vec![
        [
            "scene",
            "reflectors",
            "mode",
            "frame median ms",
            "CPU ms",
            "× geometry",
            "CPU × geometry",
            "GPU all passes ms",
            "splats drawn",
            "splat draw calls",
            "splats on GPU MiB",
            "error vs path tracer",
            "error vs CPU eq.",
            "reflector px error vs CPU eq.",
        ]
        .map(String::from),
    ];
    // Geometry first: the other rows' ratios are to it. (label, mode, map selection, maps,
    // recursion depth)
    let modes: [(&str, ReflectionMode, Selection, usize, u8); 7] = [
        ("geometry", ReflectionMode::Geometry, Selection::Angle, 0, 1),
        (
            "geometry, depth 2",
            ReflectionMode::Geometry,
            Selection::Angle,
            0,
            2,
        ),
        ("off", ReflectionMode::Off, Selection::Angle, 0, 1),
        (
            "image, 1 map (angle)",
            ReflectionMode::Image,
            Selection::Angle,
            1,
            1,
        ),
        (
            "image, 2 maps (angle)",
            ReflectionMode::Image,
            Selection::Angle,
            2,
            1,
        ),
        (
            "image, 4 maps (angle)",
            ReflectionMode::Image,
            Selection::Angle,
            4,
            1,
        ),
        (
            "image, 2 maps (distance)",
            ReflectionMode::Image,
            Selection::Distance,
            2,
            1,
        ),
    ];
    let only = std::env::var("GLINT_BENCH_MODES").ok();
    let keys = [
        "geometry",
        "geometry2",
        "off",
        "image1",
        "image2",
        "image4",
        "image2d",
    ];
    let modes: Vec<_> = modes
        .into_iter()
        .zip(keys)
        .filter(|(_, key)| {
            *key == "geometry"
                || only
                    .as_deref()
                    .is_none_or(|o| o.split(',').any(|w| w.trim() == *key))
        })
        .map(|(m, _)| m)
        .collect();
    let errors = std::env::var("GLINT_BENCH_ERRORS").as_deref() != Ok("off");
    let passes = std::env::var("GLINT_BENCH_PASSES").as_deref() == Ok("on");
    let path_names = std::env::var("GLINT_BENCH_PATHS").ok();
    let mut pass_rows = vec![
        [
            "scene",
            "path",
            "mode",
            "maps",
            "CPU ms",
            "mirror passes ms",
            "gap fill ms",
            "pyramid ms",
            "composite ms",
            "the rest ms",
        ]
        .map(String::from),
    ];
    let mut scenes: Vec<(String, std::path::PathBuf)> = picked(&["glossy-room", "breakfast-room"])
        .into_iter()
        .map(|n| (n.to_string(), repo(&format!("scenes/{n}/scene.json"))))
        .collect();
    scenes.extend(extra_scenes());
    for (name, scene_json) in &scenes {
        let name = name.as_str();
        let bundle = bake_all_at(scene_json, work, name, Quality::Draft);
        let data = load(&bundle).unwrap_or_else(|e| panic!("{e}"));
        let paths: Vec<_> = match &path_names {
            None => vec![data.scene.camera_path(None).expect("a camera path")],
            Some(list) => list
                .split(',')
                .filter_map(|p| data.scene.camera_path(Some(p.trim())))
                .collect(),
        };
        let bvh = errors.then(|| Bvh::build(&data.scene.triangles));
        let reflectors = reflections::reflectors_with_reflectance(&data);
        for path in paths {
            let frames = schedule(path).unwrap_or_else(|e| panic!("{e}"));
            let timed: Vec<_> = frames
                .iter()
                .step_by(FRAME_STRIDE)
                .map(|f| f.camera)
                .collect();
            let view = frames[frames.len() / 2].camera;
            let label_path = if path_names.is_some() {
                format!("{name} ({})", path.name)
            } else {
                name.to_string()
            };
            let references = bvh.as_ref().map(|bvh| {
                let start = Instant::now();
                let traced = reference::render(
                    &data.scene,
                    bvh,
                    &view,
                    &RenderOptions {
                        width: SIZE.0,
                        height: SIZE.1,
                        spp: REFERENCE_SPP,
                        seed: 1,
                        ..RenderOptions::default()
                    },
                    &Silent,
                )
                .unwrap_or_else(|e| panic!("{e}"));
                eprintln!(
                    "{label_path}: path-traced reference in {:.1} s",
                    start.elapsed().as_secs_f64()
                );
                let traced = half_size(&cpu::to_srgb8(&traced.image.rgb), SIZE.0, SIZE.1);
                let equation = cpu::to_srgb8(&reflections::cpu_reference(
                    &data.scene,
                    &reflectors,
                    bvh,
                    &data.map,
                    &view,
                    SIZE.0,
                    SIZE.1,
                    1.0,
                ));
                let mask = reflections::reflector_pixels(bvh, &reflectors, &view, SIZE.0, SIZE.1);
                (traced, equation, mask)
            });
            let masked = |img: &[u8], mask: &[bool]| -> Vec<u8> {
                img.chunks_exact(4)
                    .zip(mask)
                    .filter(|(_, m)| **m)
                    .flat_map(|(p, _)| p.iter().copied())
                    .collect()
            };
            let (mut geometry_ms, mut geometry_cpu) = (f64::NAN, f64::NAN);
            for &(label, mode, selection, count, depth) in &modes {
                let mut off =
                    Offscreen::new(gpu, &data, SIZE.0, SIZE.1).unwrap_or_else(|e| panic!("{e}"));
                off.options.selection = selection;
                off.options.maps = count;
                off.options.recursion.depth = depth;
                off.options.recursion.terminal =
                    std::env::var("GLINT_BENCH_TERMINAL").as_deref() != Ok("off");
                off.set_reflections(gpu, &data, mode)
                    .unwrap_or_else(|e| panic!("{e}"));
                off.render(gpu, &timed[0]).unwrap_or_else(|e| panic!("{e}")); // warm-up
                // (median frame ms, median GPU ms, splats, draws, CPU ms a frame), best of
                // `repeats` runs; the CPU ms (this process's, lavapipe's threads included)
                // are the least of the runs' means.
                let time = |off: &Offscreen| {
                    let mut best: Option<(f64, f64, u64, usize)> = None;
                    let mut cpu_ms = f64::INFINITY;
                    for _ in 0..repeats {
                        let (mut frame, mut gpu_ms, mut splats) = (Vec::new(), Vec::new(), 0u64);
                        let mut draws = 0usize;
                        let cpu_start = cpu_time::cpu_seconds();
                        for c in &timed {
                            let t = off.render(gpu, c).unwrap_or_else(|e| panic!("{e}"));
                            frame.push(t.frame_ms);
                            gpu_ms.push(t.gpu_ms);
                            if let Some(r) = off.reflections() {
                                let stats = r.frame_stats();
                                splats += stats.iter().map(|s| s.drawn_splats).sum::<u64>();
                                draws += stats.iter().map(|s| s.draws).sum::<usize>();
                            }
                        }
                        cpu_ms = cpu_ms
                            .min((cpu_time::cpu_seconds() - cpu_start) * 1e3 / timed.len() as f64);
                        let run = (
                            median(&mut frame),
                            median(&mut gpu_ms),
                            splats / timed.len() as u64,
                            draws / timed.len(),
                        );
                        if best.is_none_or(|b| run.0 < b.0) {
                            best = Some(run);
                        }
                    }
                    let b = best.expect("at least one run");
                    (b.0, b.1, b.2, b.3, cpu_ms)
                };
                let (frame_ms, gpu_ms, splats, draws, cpu_ms) = time(&off);
                if mode == ReflectionMode::Geometry && depth == 1 {
                    geometry_ms = frame_ms;
                    geometry_cpu = cpu_ms;
                }
                let maps = off.reflections().map(|r| r.map_count(&timed[0]));
                if passes && let Some(r) = off.reflections() {
                    // Each pass's cost: the CPU time a frame saves when it is left out with
                    // every pass after it (composite, then pyramid, gap fill, mirror passes):
                    // a pass left out alone would change what the passes after it read, and
                    // the hole fill's and filter's loops depend on it.
                    let mut left = SkippedPasses::default();
                    let mut last = cpu_ms;
                    let mut saved = |add: fn(&mut SkippedPasses)| {
                        add(&mut left);
                        r.skip_passes(left);
                        let t = time(&off).4;
                        let d = last - t;
                        last = t;
                        d
                    };
                    let composite = saved(|s| s.composite = true);
                    let pyramid = saved(|s| s.pyramid = true);
                    let gap = if mode == ReflectionMode::Image {
                        saved(|s| s.gap_fill = true)
                    } else {
                        0.0
                    };
                    let mirror = saved(|s| s.mirror = true);
                    r.skip_passes(SkippedPasses::default());
                    pass_rows.push([
                        name.to_string(),
                        path.name.clone(),
                        label.to_string(),
                        maps.map_or("-".to_string(), |m| m.to_string()),
                        format!("{cpu_ms:.1}"),
                        format!("{mirror:.1}"),
                        if mode == ReflectionMode::Image {
                            format!("{gap:.1}")
                        } else {
                            "-".to_string()
                        },
                        format!("{pyramid:.1}"),
                        format!("{composite:.1}"),
                        format!("{last:.1}"),
                    ]);
                }
                let errors = references.as_ref().map(|(traced, equation, mask)| {
                    off.render(gpu, &view).unwrap_or_else(|e| panic!("{e}"));
                    let img = off.read_rgba8(gpu).unwrap_or_else(|e| panic!("{e}"));
                    [
                        mean_diff(&half_size(&img, SIZE.0, SIZE.1), traced),
                        mean_diff(&img, equation),
                        mean_diff(&masked(&img, mask), &masked(equation, mask)),
                    ]
                });
                let error = |i: usize| errors.map_or("-".to_string(), |e| format!("{:.2}", e[i]));
                rows.push([
                    label_path.clone(),
                    maps.map_or_else(
                        || reflectors.len().to_string(),
                        |m| format!("{m} of {}", reflectors.len()),
                    ),
                    label.to_string(),
                    format!("{frame_ms:.2}"),
                    format!("{cpu_ms:.1}"),
                    format!("{:.2}", frame_ms / geometry_ms),
                    format!("{:.2}", cpu_ms / geometry_cpu),
                    format!("{gpu_ms:.2}"),
                    if mode == ReflectionMode::Image {
                        splats.to_string()
                    } else {
                        "-".to_string()
                    },
                    if mode == ReflectionMode::Image {
                        draws.to_string()
                    } else {
                        "-".to_string()
                    },
                    match off.reflections() {
                        Some(r) if mode == ReflectionMode::Image => {
                            format!("{:.1}", r.resident_bytes() as f64 / (1u64 << 20) as f64)
                        }
                        _ => "-".to_string(),
                    },
                    error(0),
                    error(1),
                    error(2),
                ]);
            }
        }
    }
    println!(
        "\nglossy reflections at {}x{}: median frame time over every {FRAME_STRIDE}th frame of the first path (best of {repeats} runs), GPU time from the first pass's beginning to the last pass's end, mean error (8-bit sRGB) at the middle frame vs the path tracer ({REFERENCE_SPP} spp, both box-filtered 2x2) and vs the CPU equation (whole frame, and over the reflectors' pixels)\n",
        SIZE.0, SIZE.1
    );
    print!(
        "{}",
        format_table(
            &rows,
            &[
                false, true, false, true, true, true, true, true, true, true, true, true, true,
                true
            ]
        )
    );
    if passes {
        println!(
            "\neach mode's reflection passes: CPU ms a frame (this process, lavapipe's threads included; the least mean of {repeats} runs), and what each pass saves when left out with the passes after it; the rest: the scene pass, the display, the frame's preparation\n"
        );
        print!(
            "{}",
            format_table(
                &pass_rows,
                &[
                    false, false, false, true, true, true, true, true, true, true
                ]
            )
        );
    }
}

/// Scenes outside `scenes/` that `GLINT_BENCH_SCENES` names by their scene.json (an entry
/// ending in `.json`), each named by its folder (e.g. a generated building,
/// `scenes/tools/make_building.py OUT/building-1_4 --size 1/4`).
fn extra_scenes() -> Vec<(String, std::path::PathBuf)> {
    let Ok(list) = std::env::var("GLINT_BENCH_SCENES") else {
        return Vec::new();
    };
    list.split(',')
        .map(str::trim)
        .filter(|e| e.ends_with(".json"))
        .map(|e| {
            let path = std::path::PathBuf::from(e);
            let name = path
                .parent()
                .and_then(|p| p.file_name())
                .unwrap_or_else(|| panic!("GLINT_BENCH_SCENES: {e}: no folder"))
                .to_string_lossy()
                .into_owned();
            (name, path)
        })
        .collect()
}

/// Every how many frames of a path the reflection table times.
const FRAME_STRIDE: usize = 8;

/// Paths per pixel of the reference images.
const REFERENCE_SPP: u32 = 32;

/// Frame size of the fidelity table (`GLINT_BENCH_FIDELITY_SIZE`, `WxH`, overrides).
const FIDELITY_SIZE: (u32, u32) = (192, 128);

/// Paths per pixel of each of the fidelity table's two references (`GLINT_BENCH_FIDELITY_SPP`
/// overrides).
const FIDELITY_SPP: u32 = 64;

/// The fidelity table's settings: the bake preset (`GLINT_BENCH_FIDELITY_QUALITY`, draft by
/// default), the frame size and the references' paths per pixel.
fn fidelity_settings() -> (Quality, (u32, u32), u32, u32) {
    let var = |k: &str| std::env::var(k).ok().filter(|v| !v.trim().is_empty());
    let quality = var("GLINT_BENCH_FIDELITY_QUALITY").map_or(Quality::Draft, |v| {
        glint::cli::parse_quality(v.trim())
            .unwrap_or_else(|e| panic!("GLINT_BENCH_FIDELITY_QUALITY={v}: {e}"))
    });
    let size = var("GLINT_BENCH_FIDELITY_SIZE").map_or(FIDELITY_SIZE, |v| {
        glint::cli::parse_size(v.trim())
            .unwrap_or_else(|e| panic!("GLINT_BENCH_FIDELITY_SIZE={v}: {e}"))
    });
    let spp = var("GLINT_BENCH_FIDELITY_SPP").map_or(FIDELITY_SPP, |v| {
        v.trim()
            .parse()
            .ok()
            .filter(|&n: &u32| n > 0)
            .unwrap_or_else(|| panic!("GLINT_BENCH_FIDELITY_SPP={v}: expected a positive count"))
    });
    let ss = var("GLINT_BENCH_FIDELITY_SUPERSAMPLE").map_or(1, |v| {
        v.trim()
            .parse()
            .ok()
            .filter(|&n: &u32| (1..=8).contains(&n))
            .unwrap_or_else(|| panic!("GLINT_BENCH_FIDELITY_SUPERSAMPLE={v}: expected 1 to 8"))
    });
    (quality, size, spp, ss)
}

/// Where `GLINT_BENCH_FIDELITY_DUMP` asks the fidelity table to write its images, for
/// per-pixel study: raw little-endian `f32` RGB rows (`STEM-ref-a.f32`, `-ref-b`, `-equation`,
/// one per mode), the primary hit's material and object per pixel centre (`STEM-hits.u32`,
/// two `u32` a pixel, `u32::MAX` for a miss), the materials' and the objects' names
/// (`STEM-materials.txt`, `STEM-objects.txt`: glTF node names). `benches/tools/fidelity_dump.py`
/// reads them.
fn dump_dir() -> Option<std::path::PathBuf> {
    let dir = std::env::var_os("GLINT_BENCH_FIDELITY_DUMP").filter(|v| !v.is_empty())?;
    let dir = std::path::PathBuf::from(dir);
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    Some(dir)
}

fn dump_f32(stem: &Path, what: &str, rgb: &[glam::Vec3]) {
    let bytes: Vec<u8> = rgb
        .iter()
        .flat_map(|p| p.to_array())
        .flat_map(f32::to_le_bytes)
        .collect();
    let file = stem.with_file_name(format!(
        "{}-{what}.f32",
        stem.file_name().unwrap().to_string_lossy()
    ));
    std::fs::write(&file, bytes).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
}

fn dump_hits(stem: &Path, scene: &Scene, objects: &[[u32; 2]]) {
    let bytes: Vec<u8> = objects
        .iter()
        .flatten()
        .copied()
        .flat_map(u32::to_le_bytes)
        .collect();
    let name = stem.file_name().unwrap().to_string_lossy().to_string();
    let write = |what: &str, bytes: Vec<u8>| {
        let file = stem.with_file_name(format!("{name}-{what}"));
        std::fs::write(&file, bytes).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    };
    write("hits.u32", bytes);
    let lines = |names: Vec<&str>| names.join("\n").into_bytes();
    write(
        "materials.txt",
        lines(scene.materials.iter().map(|m| m.name.as_str()).collect()),
    );
    write(
        "objects.txt",
        lines(scene.objects.iter().map(|o| o.node_name.as_str()).collect()),
    );
}

/// Per pixel centre of `camera`'s `w` × `h` frame, the material and object of the primary
/// hit (`u32::MAX` twice for a miss).
fn primary_hits(
    scene: &Scene,
    bvh: &Bvh,
    camera: &glint::camera::Camera,
    w: u32,
    h: u32,
) -> Vec<[u32; 2]> {
    let aspect = w as f32 / h as f32;
    (0..w * h)
        .map(|k| {
            let ndc = glint::camera::Camera::pixel_ndc(k % w, k / w, w, h);
            let hit = bvh.closest_hit(
                camera.position,
                camera.ray_direction(ndc, aspect),
                f32::INFINITY,
            );
            hit.map_or([u32::MAX; 2], |hit| {
                let t = &scene.triangles[hit.triangle as usize];
                [t.material, t.object]
            })
        })
        .collect()
}

/// The path tracer's image of `camera` (`scene`'s path `path`, first keyframe) with `options`,
/// read from `work/references/` when rendered before with the same settings (the scene's
/// content hash is in the name), else rendered and kept there. The same image as
/// `glint-eval reference SCENE --camera PATH --size WxH --spp N --seed S` writes.
fn cached_reference(
    scene: &Scene,
    bvh: &Bvh,
    work: &Path,
    path: &str,
    camera: &glint::camera::Camera,
    options: &RenderOptions,
) -> Image {
    let (w, h, spp, seed) = (options.width, options.height, options.spp, options.seed);
    let dir = work.join("references");
    let file = dir.join(format!(
        "{}-{}-{path}-{w}x{h}-{spp}spp-seed{seed}.exr",
        scene.desc.name.as_deref().unwrap_or("scene"),
        &scene.content_hash[..16.min(scene.content_hash.len())]
    ));
    if let Ok(bytes) = std::fs::read(&file)
        && let Ok(image) = Image::from_exr(&bytes)
        && image.width == w as usize
        && image.height == h as usize
    {
        return image;
    }
    let start = Instant::now();
    let traced =
        reference::render(scene, bvh, camera, options, &Silent).unwrap_or_else(|e| panic!("{e}"));
    eprintln!(
        "traced {} {path} {w}x{h} {spp} spp seed {seed} in {:.1} s",
        scene.desc.name.as_deref().unwrap_or("scene"),
        start.elapsed().as_secs_f64()
    );
    let image = Image {
        width: w as usize,
        height: h as usize,
        rgb: traced.image.rgb,
    };
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let tmp = file.with_extension("exr.tmp");
    std::fs::write(&tmp, image.to_exr().unwrap_or_else(|e| panic!("{e}")))
        .and_then(|()| std::fs::rename(&tmp, &file))
        .unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    image
}

/// Glossy materials covering fewer pixels than this in a frame get no row in the fidelity
/// table's per-material part (their mean is mostly edge pixels).
const MIN_MATERIAL_PIXELS: usize = 50;

/// A glossy material's mean luminance off by more than this fraction of the path tracer's
/// is flagged in the fidelity table (issue 44's bound).
const MATERIAL_TOLERANCE: f64 = 0.10;

/// A frame's relative RMSE (noise out) above this is flagged in the fidelity table.
const FRAME_TOLERANCE: f64 = 0.05;

/// The fidelity table's modes: geometry at recursion depths 1 and 2 (a glossy floor's
/// reflection of a mirror, and of the lamp in it, is there only from depth 2 on), image,
/// and reflections off (a scene without planar reflectors has that mode alone).
static FIDELITY_MODES: [(&str, ReflectionMode, u8); 4] = [
    ("geometry", ReflectionMode::Geometry, 1),
    ("geometry d2", ReflectionMode::Geometry, 2),
    ("image", ReflectionMode::Image, 1),
    ("off", ReflectionMode::Off, 1),
];

/// Every shipped scene: the folders of `scenes/` that hold a scene.json, by name.
fn shipped_scenes() -> Vec<String> {
    let dir = repo("scenes");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(Result::ok)
        .filter(|e| e.path().join("scene.json").is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// The viewer's options for `data` as `glint-view` starts with no arguments (its default
/// multisampling, probes and curved cube maps where baked), with the identity display
/// mapping and the bench's curved-reflector knobs.
fn fidelity_options(data: &glint::view::load::ViewData) -> ViewOptions {
    let baked = glint::view::defaults::baked(data);
    // Flags as on glint-view's command line (`GLINT_BENCH_VIEW_ARGS`).
    let extra = std::env::var("GLINT_BENCH_VIEW_ARGS").unwrap_or_default();
    let options = ViewOptions::from_args_for(extra.split_whitespace(), &baked)
        .unwrap_or_else(|e| panic!("{e}"))
        .linear_display();
    // Curved reflectors by cube maps (Nielsen §3.2), glossy ones by regular sampling of the
    // baked MIP environment map at the bake's sample budget (Luksch §6–7).
    let curved_settings = CurvedSettings {
        // The bake's sample budget by default, as `glint-view` reads it from the bundle.
        glossy_samples: std::env::var("GLINT_BENCH_GLOSSY_SAMPLES").map_or(
            options.curved_settings.glossy_samples,
            |v| {
                v.parse()
                    .unwrap_or_else(|e| panic!("GLINT_BENCH_GLOSSY_SAMPLES={v}: {e}"))
            },
        ),
        parallax: std::env::var("GLINT_BENCH_CUBE_PARALLAX").map_or(true, |v| v != "off"),
        self_occlusion: std::env::var("GLINT_BENCH_CUBE_SELF_OCCLUSION")
            .map_or(true, |v| v != "off"),
        specular_aa: true,
        face_size: std::env::var("GLINT_BENCH_FACE_SIZE").map_or(
            glint::view::curved::DEFAULT_FACE_SIZE,
            |v| {
                v.parse()
                    .unwrap_or_else(|e| panic!("GLINT_BENCH_FACE_SIZE={v}: {e}"))
            },
        ),
        ..options.curved_settings
    };
    ViewOptions {
        curved_settings,
        ..options
    }
}

/// Mean luminance of `rgb` over the pixels `of`.
fn mean_luminance(rgb: &[glam::Vec3], of: &[usize]) -> f64 {
    let sum: f64 = of
        .iter()
        .map(|&k| f64::from(glint::colour::luminance(rgb[k])))
        .sum();
    sum / of.len().max(1) as f64
}

/// Fidelity of both reflection modes (and reflections off): per shipped scene (every folder
/// of `scenes/`) and per camera path's first keyframe, on bakes at the preset of
/// [`fidelity_settings`] (materials and radiance stages too), drawn as `glint-view` draws by
/// default ([`fidelity_options`]: its multisampling, probes, glass and curved cube maps), the
/// relative RMSE (`glint::eval::compare`, linear radiance, per pixel) of the whole frame and
/// of the planar reflectors' pixels against the reference path tracer, and of the
/// reflectors' pixels against the CPU equation ([`reflections::cpu_reference`], M*K exact:
/// the viewer's own share). A scene without planar reflectors has one mode, reflections off.
/// A second part gives, per glossy material covering at least [`MIN_MATERIAL_PIXELS`]
/// pixel centres, its pixels' mean luminance in each mode over the path tracer's.
///
/// The reference is the mean of two path-traced images with seeds 1 and 2 (cached,
/// [`cached_reference`]). Their difference measures its noise: for independent images
/// A, B of the same variance, the mean's relative noise is rel(A, B) / 2, and a frame's
/// error with the noise taken out is √(e² − noise²) (the "noise out" columns).
fn fidelity_table(gpu: &Gpu, work: &Path) {
    let (quality, (w, h), spp, ss) = fidelity_settings();
    let mut rows = vec![
        [
            "scene",
            "camera",
            "mode",
            "frame vs path tracer",
            "noise out",
            "reflector px vs path tracer",
            "noise out",
            "reflector px vs CPU eq.",
            "reflector px",
        ]
        .map(String::from),
    ];
    let mut material_rows = vec![
        [
            "scene",
            "camera",
            "material",
            "specular term",
            "px",
            "path tracer",
            "geometry",
            "geometry d2",
            "image",
            "off",
        ]
        .map(String::from),
    ];
    let image = |rgb: Vec<glam::Vec3>| Image {
        width: w as usize,
        height: h as usize,
        rgb,
    };
    let mut noise_rows = Vec::new();
    let mut misses = Vec::new();
    let shipped = shipped_scenes();
    let shipped: Vec<&str> = shipped.iter().map(String::as_str).collect();
    for name in picked(&shipped) {
        let scene_json = repo(&format!("scenes/{name}/scene.json"));
        let bundle = bake_all_at(&scene_json, work, name, quality);
        let scene = Scene::load(&scene_json).unwrap_or_else(|e| panic!("{e}"));
        let data = load(&bundle).unwrap_or_else(|e| panic!("{e}"));
        let reflectors = reflections::reflectors_with_reflectance(&data);
        // With the scene's cut-out filter: the path tracer sees through alpha-masked texels.
        let bvh = data.scene.build_bvh();
        let options = fidelity_options(&data);
        let mut off =
            Offscreen::with_options(gpu, &data, w, h, &options).unwrap_or_else(|e| panic!("{e}"));
        let mut fine = (ss > 1).then(|| {
            Offscreen::with_options(gpu, &data, w * ss, h * ss, &options)
                .unwrap_or_else(|e| panic!("{e}"))
        });
        let modes = if reflectors.is_empty() {
            &FIDELITY_MODES[3..]
        } else {
            &FIDELITY_MODES[..]
        };
        let specular_term = |m: u32| {
            let material = &data.scene.materials[m as usize];
            if data.scene.reflectors.iter().any(|r| r.material == m) {
                "reflector"
            } else if !material.transmission.is_none() {
                "glass, probe"
            } else {
                "probe"
            }
        };
        for path in &data.scene.camera_paths {
            let camera = glint::camera::pose_at(path, 0.0);
            let [a, b] = [1, 2].map(|seed| {
                let options = RenderOptions {
                    width: w,
                    height: h,
                    spp,
                    seed,
                    ..RenderOptions::default()
                };
                cached_reference(&scene, &bvh, work, &path.name, &camera, &options)
            });
            let traced = image(
                a.rgb
                    .iter()
                    .zip(&b.rgb)
                    .map(|(x, y)| 0.5 * (*x + *y))
                    .collect(),
            );
            // The equation at the pixels' centres (what recursive passes draw) and, where the
            // single-level passes draw M at a finer grid and box-filter it
            // (`reflections::downsample`), box-filtered from that grid too.
            let factor = map_factor(off.frame().samples());
            let equation_at = |f: u32| {
                image(reflections::cpu_reference_box(
                    &data.scene,
                    &reflectors,
                    &bvh,
                    &data.map,
                    &camera,
                    w,
                    h,
                    f,
                ))
            };
            let equation = (!reflectors.is_empty()).then(|| equation_at(1));
            let equation_filtered =
                (!reflectors.is_empty() && factor > 1).then(|| equation_at(factor));
            let mask = reflections::reflector_pixels(&bvh, &reflectors, &camera, w, h);
            // The CPU equation has no cube-mapped reflectors: its column leaves out the
            // pixels whose mirrored ray meets one (the teapot seen in glossy-room's mirror, or
            // the mirror seen in its floor, geometry mode's terminal cube maps).
            let (equation_mask, curved_seen) =
                without_cube_mapped(&mask, &data.scene, &bvh, &reflectors, &camera, w, h);
            let hits = primary_hits(&data.scene, &bvh, &camera, w, h);
            let dump = dump_dir().map(|dir| dir.join(format!("{name}-{}", path.name)));
            if let Some(stem) = &dump {
                dump_f32(stem, "ref-a", &a.rgb);
                dump_f32(stem, "ref-b", &b.rgb);
                if let Some(equation) = &equation {
                    dump_f32(stem, "equation", &equation.rgb);
                }
                dump_hits(stem, &data.scene, &hits);
            }
            // Each glossy material's pixels (by the primary hit at the pixel's centre).
            let glossy: Vec<(u32, Vec<usize>)> = (0..data.scene.materials.len() as u32)
                .filter(|&m| data.scene.materials[m as usize].is_glossy())
                .map(|m| {
                    let px = (0..hits.len()).filter(|&k| hits[k][0] == m).collect();
                    (m, px)
                })
                .filter(|(_, px): &(u32, Vec<usize>)| px.len() >= MIN_MATERIAL_PIXELS)
                .collect();
            let mut ratios = vec![vec!["-".to_string(); FIDELITY_MODES.len()]; glossy.len()];
            let pixels = mask.iter().filter(|m| **m).count();
            let masked = (pixels > 0).then_some(&mask[..]);
            // The mean's noise: half the relative difference of its two halves.
            let noise =
                |m: Option<&[bool]>| compare(&a, &b, m).map_or(f64::NAN, |r| 0.5 * r.rel_rmse);
            let (noise_frame, noise_reflector) =
                (noise(None), masked.map_or(f64::NAN, |m| noise(Some(m))));
            noise_rows.push(format!(
                "{name} {}: reference noise {noise_frame:.3} (frame), {noise_reflector:.3} (reflector px); \
                 {curved_seen} reflector px see a cube-mapped reflector, left out of the CPU equation's column",
                path.name
            ));
            for &(label, mode, depth) in modes {
                let set = |o: &mut Offscreen| {
                    let options = ViewOptions {
                        reflections: mode,
                        recursion: RecursionSettings {
                            depth,
                            ..o.options.recursion
                        },
                        ..o.options
                    };
                    o.set_options(gpu, &data, &options)
                        .unwrap_or_else(|e| panic!("{e}"));
                };
                set(&mut off);
                off.render(gpu, &camera).unwrap_or_else(|e| panic!("{e}"));
                let frame = image(off.read_hdr(gpu).unwrap_or_else(|e| panic!("{e}")));
                // Against the path tracer (a box filter over each pixel): the viewer's frame
                // box-filtered from ss × ss samples per pixel.
                let filtered = match &mut fine {
                    Some(fine) => {
                        set(fine);
                        fine.render(gpu, &camera).unwrap_or_else(|e| panic!("{e}"));
                        let hdr = fine.read_hdr(gpu).unwrap_or_else(|e| panic!("{e}"));
                        image(glint::image_io::downsample(
                            &hdr,
                            (w * ss) as usize,
                            (h * ss) as usize,
                            w as usize,
                            h as usize,
                        ))
                    }
                    None => frame.clone(),
                };
                let rel = |a: &Image, b: &Image, m: Option<&[bool]>| {
                    compare(a, b, m).map(|r| r.rel_rmse).ok()
                };
                let show = |e: Option<f64>| e.map_or("-".to_string(), |e| format!("{e:.3}"));
                let out = |e: Option<f64>, n: f64| e.map(|e| (e * e - n * n).max(0.0).sqrt());
                if let Some(stem) = &dump {
                    dump_f32(stem, label, &filtered.rgb);
                }
                let frame_error = rel(&filtered, &traced, None);
                let frame_out = out(frame_error, noise_frame);
                let flag = if frame_out.is_some_and(|e| e > FRAME_TOLERANCE) {
                    misses.push(format!("{name} {} {label}: frame", path.name));
                    " !"
                } else {
                    ""
                };
                let reflector_error = masked.and_then(|m| rel(&filtered, &traced, Some(m)));
                let column = FIDELITY_MODES.iter().position(|m| m.0 == label).unwrap();
                for ((m, px), ratio) in glossy.iter().zip(&mut ratios) {
                    let r = mean_luminance(&filtered.rgb, px) / mean_luminance(&traced.rgb, px);
                    let flag = if (r - 1.0).abs() > MATERIAL_TOLERANCE {
                        let material = &data.scene.materials[*m as usize].name;
                        misses.push(format!("{name} {} {label}: {material}", path.name));
                        " !"
                    } else {
                        ""
                    };
                    ratio[column] = format!("{r:.3}{flag}");
                }
                rows.push([
                    name.to_string(),
                    path.name.clone(),
                    label.to_string(),
                    show(frame_error),
                    format!("{}{flag}", show(frame_out)),
                    show(reflector_error),
                    show(out(reflector_error, noise_reflector)),
                    show(
                        off.reflections()
                            .and(equation_filtered.as_ref())
                            .or(equation.as_ref())
                            .and_then(|equation| {
                                masked.and_then(|_| rel(&frame, equation, Some(&equation_mask)))
                            }),
                    ),
                    pixels.to_string(),
                ]);
            }
            for ((m, px), ratio) in glossy.iter().zip(ratios) {
                let [depth1, depth2, image_mode, reflections_off] =
                    <[String; 4]>::try_from(ratio).unwrap();
                material_rows.push([
                    name.to_string(),
                    path.name.clone(),
                    data.scene.materials[*m as usize].name.clone(),
                    specular_term(*m).to_string(),
                    px.len().to_string(),
                    format!("{:.4}", mean_luminance(&traced.rgb, px)),
                    depth1,
                    depth2,
                    image_mode,
                    reflections_off,
                ]);
            }
        }
    }
    println!(
        "\nfidelity at {w}x{h}, {} bakes, {} samples a pixel (the viewer's default), each camera path's first keyframe: relative RMSE (linear, per pixel) vs the path tracer (the mean of 2 × {spp} spp; \"noise out\": its noise taken out, \"!\" above {FRAME_TOLERANCE}; the viewer's frame box-filtered from {ss}×{ss} samples a pixel) and vs the CPU equation (M*K exact, at pixel centres; it has no cube-mapped reflectors, curved or a near-mirror seen in another reflector, so reflector pixels that see one are left out of that column)\n",
        quality.name(),
        glint::view::options::DEFAULT_SAMPLES,
    );
    print!(
        "{}",
        format_table(
            &rows,
            &[false, false, false, true, true, true, true, true, true]
        )
    );
    for line in noise_rows {
        println!("{line}");
    }
    println!(
        "\nglossy materials in view (at least {MIN_MATERIAL_PIXELS} pixel centres): the path tracer's mean luminance over their pixels, and each mode's over it (\"!\": off by more than {MATERIAL_TOLERANCE})\n"
    );
    print!(
        "{}",
        format_table(
            &material_rows,
            &[
                false, false, false, false, true, true, true, true, true, true
            ]
        )
    );
    println!(
        "\noutside the bounds: {}",
        if misses.is_empty() {
            "none".to_string()
        } else {
            misses.join("; ")
        }
    );
}

/// `mask` without the pixels whose ray, mirrored at the planar reflector it meets, meets a
/// cube-mapped reflector next (a curved one, or a near-mirror planar one: geometry mode's
/// terminal cube maps); and how many those are.
fn without_cube_mapped(
    mask: &[bool],
    scene: &Scene,
    bvh: &Bvh,
    reflectors: &[reflections::PlanarReflector],
    camera: &glint::camera::Camera,
    w: u32,
    h: u32,
) -> (Vec<bool>, usize) {
    let mut cube_mapped = vec![false; scene.triangles.len()];
    for r in scene.reflectors.iter().filter(|r| {
        r.kind == glint::scene::ReflectorKind::Curved
            || glint::radiosity::is_mirror(&scene.materials[r.material as usize])
    }) {
        for &t in &r.triangles {
            cube_mapped[t as usize] = true;
        }
    }
    let mut plane_of = std::collections::HashMap::new();
    for r in reflectors {
        for &t in &r.triangles {
            plane_of.insert(t, r.plane);
        }
    }
    let aspect = w as f32 / h as f32;
    let mut out = mask.to_vec();
    let mut seen = 0;
    for (k, m) in out.iter_mut().enumerate() {
        if !*m {
            continue;
        }
        let ndc = glint::camera::Camera::pixel_ndc(k as u32 % w, k as u32 / w, w, h);
        let d = camera.ray_direction(ndc, aspect);
        let Some(hit) = bvh.closest_hit(camera.position, d, f32::INFINITY) else {
            continue;
        };
        let Some(plane) = plane_of.get(&hit.triangle) else {
            continue;
        };
        let n = plane.normal;
        let p = camera.position + d * hit.t;
        let r = reflections::mirror_direction(n, d);
        let meets = bvh
            .closest_hit(p + n * 1e-3, r, f32::INFINITY)
            .is_some_and(|h| cube_mapped[h.triangle as usize]);
        if meets {
            *m = false;
            seen += 1;
        }
    }
    (out, seen)
}
