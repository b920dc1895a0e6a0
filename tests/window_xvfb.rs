//! The window's own frame loop (swapchain, every reflection pass, key-free start options) run
//! under a virtual X server: each switch of `glint-view` opens the window, draws frames and
//! exits through `--screenshot-after`. wgpu validation errors in any pass abort the process,
//! so a clean exit means the window's passes are valid on the software adapter.
//!
//! The window's screenshot (read back from its surface) is also held against a headless frame
//! of the same camera and options: both draw through one `FramePasses`, so they agree.
//!
//! Needs `xvfb-run` (Debian: `xvfb xauth`, installed by `.ci/run`). Without it the tests say
//! so and check nothing, except under CI (`CI` set), where they fail.

#![cfg(feature = "view")]

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{Recipe, shipped_bundle, skip};
use glint::scene::desc::Quality;

fn xvfb_run() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join("xvfb-run"))
        .find(|p| p.is_file())
}

/// Opens the window on `bundle` with `args`, draws 3 frames, saves a screenshot and exits;
/// returns the screenshot's pixels.
fn window_frames(xvfb: &Path, bundle: &Path, out: &Path, args: &[&str]) -> Vec<u8> {
    window_shot(xvfb, bundle, out, args).into_raw()
}

/// As [`window_frames`], the screenshot as an image.
fn window_shot(xvfb: &Path, bundle: &Path, out: &Path, args: &[&str]) -> image::RgbImage {
    let _ = std::fs::remove_dir_all(out);
    let run = Command::new(xvfb)
        .args(["-a", "-s", "-screen 0 640x480x24"])
        .arg(env!("CARGO_BIN_EXE_glint-view"))
        .arg(bundle)
        .args(["--size", "320x216", "--screenshot-after", "3", "--out"])
        .arg(out)
        .args(args)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        run.status.success(),
        "glint-view {args:?} in the window failed ({}): {stderr}",
        run.status
    );
    assert!(
        !stderr.contains("Validation Error"),
        "glint-view {args:?}: {stderr}"
    );
    let shot = String::from_utf8_lossy(&run.stdout).trim().to_string();
    assert!(
        shot.ends_with(".png") && Path::new(&shot).is_file(),
        "glint-view {args:?} printed no screenshot: {shot:?}; {stderr}"
    );
    for line in stderr.lines().filter(|l| l.contains("screenshot")) {
        eprintln!("glint-view {args:?}: {line}");
    }
    image::open(&shot).unwrap().to_rgb8()
}

fn mean_diff(a: &[u8], b: &[u8]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(&x, &y)| (f64::from(x) - f64::from(y)).abs())
        .sum::<f64>()
        / a.len() as f64
}

/// `xvfb-run`, or `None` (and a note) where it is missing outside CI.
fn xvfb_or_skip() -> Option<PathBuf> {
    let found = xvfb_run();
    if found.is_none() {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must install xvfb-run (apt-get install -y xvfb xauth)"
        );
        skip("xvfb-run not found: the window is not exercised here");
    }
    found
}

#[test]
fn every_reflection_switch_runs_in_the_window() {
    let Some(xvfb) = xvfb_or_skip() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    // What `glint-bake --quality draft` bakes.
    let glossy = shipped_bundle(&Recipe::every_needed_stage("glossy-room", Quality::Draft));
    let bunny = shipped_bundle(&Recipe::every_needed_stage("bunny-mirror", Quality::Draft));

    // Each switch against everything off (the bundles' defaults turn reflections on).
    let shot = |bundle: &Path, name: &str, args: &[&str]| {
        let mut all = args.to_vec();
        for flag in ["--reflections", "--curved", "--impostors"] {
            if !args.contains(&flag) {
                all.extend([flag, "off"]);
            }
        }
        window_frames(&xvfb, bundle, &dir.path().join(name), &all)
    };
    let off = shot(&glossy, "off", &[]);
    let geometry = shot(&glossy, "geometry", &["--reflections", "geometry"]);
    let image = shot(&glossy, "image", &["--reflections", "image", "--maps", "4"]);
    let recursive = shot(
        &glossy,
        "recursive",
        &["--reflections", "geometry", "--recursion-depth", "2"],
    );
    let plain = shot(
        &glossy,
        "plain",
        &["--reflections", "geometry", "--terminal-cubemaps", "off"],
    );
    let curved = shot(
        &glossy,
        "curved",
        &["--curved", "cubemap", "--glossy-samples", "4"],
    );
    let bunny_off = shot(&bunny, "bunny-off", &[]);
    let bunny_impostors = shot(&bunny, "bunny-impostors", &["--impostors", "on"]);
    let bunny_billboards = shot(
        &bunny,
        "bunny-billboards",
        &["--impostors", "on", "--impostor-kind", "billboard"],
    );

    // Each switch changes what is drawn (the screenshot uses the window's start options).
    // Thresholds are about a third of what lavapipe draws at the start pose (the teapot is
    // small in glossy-room's first view, the bunny's reflection in bunny-mirror's).
    for (name, img, against, least) in [
        ("geometry", &geometry, &off, 3.0),
        ("image", &image, &off, 3.0),
        ("curved", &curved, &off, 0.08),
        ("impostors", &bunny_impostors, &bunny_off, 1.0),
        ("billboards", &bunny_billboards, &bunny_off, 1.0),
    ] {
        let d = mean_diff(img, against);
        eprintln!("{name}: mean change {d:.2} (8-bit units)");
        assert!(
            d > least,
            "{name} reflections change the window's frame: {d}"
        );
    }
    // The mirror panel and the floor see each other at depth 2, so the frame differs from
    // depth 1 with the panel's kd·D alone in the floor; depth 1's terminal cube maps stand in
    // for most of that.
    let d = mean_diff(&recursive, &plain);
    eprintln!("depth 2 vs depth 1 without terminal cube maps: mean change {d:.3}");
    assert!(d > 0.1, "depth 2 differs from depth 1: {d}");
    let t = mean_diff(&geometry, &plain);
    eprintln!("terminal cube maps: mean change {t:.3}");
    assert!(
        t > 0.5 * d,
        "--terminal-cubemaps changes the frame: {t} vs {d}"
    );
}

/// The headless frame `glint-view ARGS` draws from the window's starting camera.
fn headless_frame(bundle: &Path, args: &[&str], (w, h): (u32, u32)) -> Vec<u8> {
    use glint::view::headless::{Offscreen, rgba_to_rgb};
    use glint::view::options::ViewOptions;
    use glint::view::window::{FlyCamera, initial_camera};
    let data = glint::view::load::load(bundle).unwrap();
    let gpu = glint::view::gpu::Gpu::headless().unwrap();
    let options =
        ViewOptions::from_args_for(args.iter().copied(), &glint::view::defaults::baked(&data))
            .unwrap();
    // The window starts at the fly camera of the initial view.
    let camera = FlyCamera::from_camera(&initial_camera(&data)).camera();
    let off = Offscreen::with_options(&gpu, &data, w, h, &options).unwrap();
    off.render(&gpu, &camera).unwrap();
    rgba_to_rgb(&off.read_rgba8(&gpu).unwrap())
}

/// Fraction of 8-bit channel values that differ by more than `by`.
fn differing(a: &[u8], b: &[u8], by: u8) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .filter(|(x, y)| x.abs_diff(**y) > by)
        .count() as f64
        / a.len() as f64
}

#[test]
fn the_window_draws_what_headless_replay_draws() {
    let Some(xvfb) = xvfb_or_skip() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let glossy = shipped_bundle(&Recipe::every_needed_stage("glossy-room", Quality::Draft));
    let size = (320, 216);
    // Option sets the window used to get wrong: it ignored --maps and --selection, and drew
    // the recursive pass before the curved reflectors.
    let sets: [&[&str]; 2] = [
        &[
            "--reflections",
            "image",
            "--maps",
            "1",
            "--selection",
            "distance",
        ],
        &[
            "--reflections",
            "geometry",
            "--recursion-depth",
            "2",
            "--curved",
            "cubemap",
        ],
    ];
    for (i, args) in sets.iter().enumerate() {
        let shot = window_shot(&xvfb, &glossy, &dir.path().join(format!("set-{i}")), args);
        assert_eq!(shot.dimensions(), size, "{args:?}: the window's size");
        let window = shot.into_raw();
        let headless = headless_frame(&glossy, args, size);
        let saved = std::env::temp_dir().join(format!("glint-window-vs-headless-{i}.png"));
        image::RgbImage::from_raw(size.0, size.1, headless.clone())
            .unwrap()
            .save(&saved)
            .unwrap();
        let shot_copy = std::env::temp_dir().join(format!("glint-window-shot-{i}.png"));
        image::RgbImage::from_raw(size.0, size.1, window.clone())
            .unwrap()
            .save(&shot_copy)
            .unwrap();
        let (mean, off) = (
            mean_diff(&window, &headless),
            differing(&window, &headless, 8),
        );
        eprintln!(
            "{args:?}: window vs headless mean {mean:.4}, {:.4}% off by > 8",
            off * 100.0
        );
        // The camera goes through the fly camera's yaw and pitch in both: only rounding of
        // the same passes may differ.
        assert!(
            mean < 0.25 && off < 0.002,
            "{args:?}: the window's frame differs from the headless one (mean {mean}, {off} off)"
        );
    }
    // Not vacuous: the options of the first set change the headless frame, so a window that
    // ignored them would fail above.
    let defaults = headless_frame(&glossy, &["--reflections", "image"], size);
    let chosen = headless_frame(&glossy, sets[0], size);
    let d = mean_diff(&defaults, &chosen);
    eprintln!("--maps 1 --selection distance vs the defaults: mean change {d:.4}");
    assert!(
        d > 0.01,
        "--maps 1 --selection distance change the frame: {d}"
    );
}
