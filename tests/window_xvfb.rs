//! The window's own frame loop (swapchain, every reflection pass, key-free start options) run
//! under a virtual X server: each switch of `glint-view` opens the window, draws frames and
//! exits through `--screenshot-after`. wgpu validation errors in any pass abort the process,
//! so a clean exit means the window's passes are valid on the software adapter.
//!
//! Needs `xvfb-run` (Debian: `xvfb xauth`, installed by `.ci/run`). Without it the test says
//! so and checks nothing, except under CI (`CI` set), where it fails.

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
    image::open(&shot).unwrap().to_rgb8().into_raw()
}

fn mean_diff(a: &[u8], b: &[u8]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(&x, &y)| (f64::from(x) - f64::from(y)).abs())
        .sum::<f64>()
        / a.len() as f64
}

#[test]
fn every_reflection_switch_runs_in_the_window() {
    let Some(xvfb) = xvfb_run() else {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must install xvfb-run (apt-get install -y xvfb xauth)"
        );
        skip("xvfb-run not found: the window is not exercised here");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    // What `glint-bake --quality draft` bakes.
    let glossy = shipped_bundle(&Recipe::every_needed_stage("glossy-room", Quality::Draft));
    let bunny = shipped_bundle(&Recipe::every_needed_stage("bunny-mirror", Quality::Draft));

    let shot = |bundle: &Path, name: &str, args: &[&str]| {
        window_frames(&xvfb, bundle, &dir.path().join(name), args)
    };
    let off = shot(&glossy, "off", &[]);
    let geometry = shot(&glossy, "geometry", &["--reflections", "geometry"]);
    let image = shot(&glossy, "image", &["--reflections", "image", "--maps", "4"]);
    let recursive = shot(
        &glossy,
        "recursive",
        &["--reflections", "geometry", "--recursion-depth", "2"],
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
    // The mirror panel and the floor see each other at depth 2, so the frame differs from depth 1.
    let d = mean_diff(&recursive, &geometry);
    eprintln!("depth 2 vs depth 1: mean change {d:.3}");
    assert!(d > 0.1, "depth 2 differs from depth 1: {d}");
}
