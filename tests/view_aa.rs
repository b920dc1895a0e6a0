//! glint-view's anti-aliasing (`--samples`), through the binary on the software Vulkan adapter
//! (lavapipe): the default frame is multisampled (silhouettes get intermediate values that a
//! single-sampled frame has not), `--samples 1` draws exactly what the viewer drew before it
//! had anti-aliasing, a sample count it does not offer is refused with the accepted values, one
//! the GPU cannot draw falls back with a warning, and a new count rebuilds built passes.
//!
//! `tests/golden/cornell-box-samples1.png` is the `orbit` path's frame 0 at [`SIZE`] of this
//! test's bake, written by glint-view before multisampling existed (exact bytes: the
//! single-sampled path must not move). Regenerate it only when the viewer's single-sampled
//! frame is meant to change: `GLINT_UPDATE_GOLDENS=1 cargo test --test view_aa`.

#![cfg(feature = "view")]

mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use common::*;

/// Frame size: small enough for a debug build, large enough for many silhouette pixels.
const SIZE: &str = "160x108";

/// Luma step (8-bit sRGB units) across a silhouette in the single-sampled frame.
const EDGE_STEP: i32 = 48;

/// How far (8-bit units) a value must lie inside the two sides of a silhouette to count as
/// intermediate.
const INSIDE: i32 = 8;

/// The Cornell box (boxes with slanted silhouettes against the walls), quick radiosity.
fn cornell() -> &'static Path {
    static BUNDLE: OnceLock<PathBuf> = OnceLock::new();
    BUNDLE.get_or_init(|| {
        shipped_bundle(
            &Recipe::new("cornell-box")
                .then(Step::Scene)
                .then(Step::Radiosity(quick_radiosity(3))),
        )
    })
}

/// Runs glint-view headless on frame 0 of the `orbit` path with `extra` arguments; returns
/// its exit code, stderr and the frame (RGB, top row first) when it wrote one.
fn frame(extra: &[&str]) -> (i32, String, Option<Vec<u8>>) {
    let out = tempfile::tempdir().unwrap();
    let mut args = vec![
        cornell().to_str().unwrap(),
        "--replay",
        "orbit",
        "--frame",
        "0",
        "--headless",
        "--size",
        SIZE,
        "--out",
        out.path().to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let (code, _, stderr) = run_exe(env!("CARGO_BIN_EXE_glint-view"), &args);
    let png = out.path().join("frame_00000.png");
    let rgb = png.exists().then(|| read_rgb(&png));
    (code, stderr, rgb)
}

fn read_rgb(path: &Path) -> Vec<u8> {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
        .into_raw()
}

fn size() -> (usize, usize) {
    let (w, h) = SIZE.split_once('x').unwrap();
    (w.parse().unwrap(), h.parse().unwrap())
}

/// Rec. 601 luma of pixel `i` of an RGB image, 8-bit units.
fn luma(rgb: &[u8], i: usize) -> i32 {
    let p = &rgb[3 * i..3 * i + 3];
    (299 * i32::from(p[0]) + 587 * i32::from(p[1]) + 114 * i32::from(p[2])) / 1000
}

/// The silhouette crossings of `sharp` (a single-sampled frame): runs of four pixels along a
/// row or a column, two flat ones (within 4) on each side of a step of at least
/// [`EDGE_STEP`]; each as its four pixel indices.
fn crossings(sharp: &[u8], w: usize, h: usize) -> Vec<[usize; 4]> {
    let mut found = Vec::new();
    let mut scan = |run: [usize; 4]| {
        let l = run.map(|i| luma(sharp, i));
        if (l[0] - l[1]).abs() <= 4 && (l[2] - l[3]).abs() <= 4 && (l[1] - l[2]).abs() >= EDGE_STEP
        {
            found.push(run);
        }
    };
    for y in 0..h {
        for x in 0..w - 3 {
            let i = y * w + x;
            scan([i, i + 1, i + 2, i + 3]);
        }
    }
    for y in 0..h - 3 {
        for x in 0..w {
            let i = y * w + x;
            scan([i, i + w, i + 2 * w, i + 3 * w]);
        }
    }
    found
}

/// Whether `frame`'s pixels on `run` hold a value strictly between its two ends (by
/// [`INSIDE`]).
fn has_intermediate(frame: &[u8], run: &[usize; 4]) -> bool {
    let l = run.map(|i| luma(frame, i));
    let (lo, hi) = (l[0].min(l[3]), l[0].max(l[3]));
    hi - lo >= 2 * INSIDE + 2 && l[1..3].iter().any(|&v| v > lo + INSIDE && v < hi - INSIDE)
}

#[test]
fn the_default_frame_smooths_silhouettes_that_one_sample_leaves_stepped() {
    let (code, stderr, sharp) = frame(&["--samples", "1"]);
    assert_eq!(code, 0, "--samples 1: {stderr}");
    let (code, stderr, smooth) = frame(&[]);
    assert_eq!(code, 0, "default: {stderr}");
    let (sharp, smooth) = (sharp.unwrap(), smooth.unwrap());
    let (w, h) = size();
    let runs = crossings(&sharp, w, h);
    assert!(
        runs.len() >= 50,
        "only {} silhouette crossings in the single-sampled frame",
        runs.len()
    );
    let stepped = runs.iter().filter(|r| has_intermediate(&sharp, r)).count();
    let smoothed = runs.iter().filter(|r| has_intermediate(&smooth, r)).count();
    println!(
        "{} silhouette crossings: {stepped} with an intermediate value at --samples 1, {smoothed} at the default",
        runs.len()
    );
    assert_eq!(stepped, 0, "a crossing is two values at --samples 1");
    // A 4× multisampled edge pixel is covered by 1–3 of its samples unless the edge passes
    // between them; the brightest edges (the lamp) resolve close to white before the tone
    // curve, so not every crossing shows it.
    assert!(
        smoothed * 3 >= runs.len(),
        "only {smoothed} of {} silhouette crossings have an intermediate value at the default \
         (no anti-aliasing?)",
        runs.len()
    );
}

#[test]
fn one_sample_draws_the_frame_of_the_viewer_without_anti_aliasing() {
    let (code, stderr, frame) = frame(&["--samples", "1"]);
    assert_eq!(code, 0, "{stderr}");
    let frame = frame.unwrap();
    let stored = repo("tests/golden/cornell-box-samples1.png");
    let (w, h) = size();
    if update_goldens() {
        let png = glint::image_io::encode_png(w as u32, h as u32, &frame, false).unwrap();
        std::fs::write(&stored, png).unwrap();
        println!("rewritten: {}", stored.display());
        return;
    }
    let golden = read_rgb(&stored);
    // lavapipe compiles shaders for the host CPU and rounds differently from one CPU to
    // another (the same frame on two hosts: one 8-bit level in 310 of 17,280 pixels); an
    // anti-aliased edge moves a pixel by far more than that.
    let differ = frame
        .chunks_exact(3)
        .zip(golden.chunks_exact(3))
        .filter(|(a, b)| a.iter().zip(b.iter()).any(|(x, y)| x.abs_diff(*y) > 1))
        .count();
    if differ > 0 {
        let dir = failure_dir("cornell-box-samples1");
        let png = glint::image_io::encode_png(w as u32, h as u32, &frame, false).unwrap();
        std::fs::write(dir.join("samples1.png"), png).unwrap();
        panic!(
            "--samples 1 differs from {} by more than one level in {differ} pixels (frame in {})",
            stored.display(),
            dir.display()
        );
    }
}

#[test]
fn a_sample_count_the_viewer_does_not_offer_is_refused() {
    for bad in ["3", "0", "16", "four"] {
        let (code, stderr, written) = frame(&["--samples", bad]);
        assert_eq!(code, 2, "--samples {bad}: {stderr}");
        assert!(written.is_none(), "--samples {bad} wrote a frame");
        assert!(
            stderr.contains("--samples") && stderr.contains("give 1 (no anti-aliasing), 2, 4 or 8"),
            "--samples {bad}: {stderr}"
        );
    }
}

#[test]
fn a_count_the_gpu_cannot_draw_falls_back_with_a_warning() {
    let (code, stderr, eight) = frame(&["--samples", "8"]);
    assert_eq!(code, 0, "{stderr}");
    // lavapipe multisamples 4 times, not 8: the frame is drawn with 4 samples and says so.
    let Some(drawn) = stderr
        .split("drawing ")
        .nth(1)
        .and_then(|s| s.split(" sample").next())
    else {
        println!("this adapter multisamples 8 times: nothing falls back");
        return;
    };
    assert!(stderr.contains("cannot multisample"), "{stderr}");
    let (code, stderr, fallback) = frame(&["--samples", drawn]);
    assert_eq!(code, 0, "--samples {drawn}: {stderr}");
    assert!(
        eight == fallback,
        "--samples 8 did not draw what --samples {drawn} draws"
    );
}

/// Switching the sample count of built passes rebuilds them for it: the frame is the one
/// passes built with that count draw, and switching back draws the single-sampled frame again.
#[test]
fn a_new_sample_count_rebuilds_the_passes() {
    use glint::camera::pose_at;
    use glint::view::gpu::Gpu;
    use glint::view::headless::Offscreen;
    use glint::view::options::ViewOptions;
    let data = glint::view::load::load(cornell()).unwrap_or_else(|e| panic!("{e}"));
    let path = data.scene.camera_path(Some("orbit")).unwrap();
    let camera = pose_at(path, path.keyframes[0].time);
    let gpu = gpu();
    let (w, h) = (96, 64);
    let draw = |gpu: &Gpu, o: &Offscreen| {
        o.render(gpu, &camera).unwrap();
        o.read_rgba8(gpu).unwrap()
    };
    let mut switched = Offscreen::new(&gpu, &data, w, h).unwrap();
    assert_eq!(switched.frame().samples(), 1);
    let single = draw(&gpu, &switched);
    let one = switched.options;
    let four = ViewOptions { samples: 4, ..one };
    switched.set_options(&gpu, &data, &four).unwrap();
    assert_eq!(switched.frame().samples(), 4);
    let built = Offscreen::with_options(&gpu, &data, w, h, &four).unwrap();
    let multi = draw(&gpu, &switched);
    assert!(
        multi == draw(&gpu, &built),
        "switched to 4 samples vs built with 4"
    );
    assert!(multi != single, "4 samples draw what 1 sample draws");
    switched.set_options(&gpu, &data, &one).unwrap();
    assert!(draw(&gpu, &switched) == single, "switched back to 1 sample");
}
