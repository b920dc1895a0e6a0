//! glint-view's defaults come from the bundle: a glossy-room baked with every stage it needs
//! (draft) is replayed headless with no reflection flags, and its mirror panel and copper
//! teapot (metals: no diffuse term, so kd·D alone draws them black) show reflections; the
//! flags still turn them off.

#![cfg(feature = "view")]

mod common;

use std::path::Path;

use common::*;
use glint::camera::pose_at;
use glint::scene::desc::Quality;

/// Frame size: the teapot covers a few hundred pixels of it at `front`.
const SIZE: (u32, u32) = (240, 160);

/// An 8-bit channel at or above this is not black (the mirror and the teapot reflect the lit
/// room; their kd·D is 0).
const LIT: u8 = 24;

/// `glint-view BUNDLE --replay front --headless` with `flags`: its exit code, stderr and the
/// frame (RGB8).
fn replay_front(bundle: &Path, flags: &[&str]) -> (i32, String, Vec<u8>) {
    let out = tempfile::tempdir().unwrap();
    let size = format!("{}x{}", SIZE.0, SIZE.1);
    let mut args = vec![
        bundle.to_str().unwrap(),
        "--replay",
        "front",
        "--headless",
        "--size",
        &size,
        "--out",
        out.path().to_str().unwrap(),
    ];
    args.extend_from_slice(flags);
    let (code, stdout, stderr) = run_exe(env!("CARGO_BIN_EXE_glint-view"), &args);
    assert_eq!(code, 0, "glint-view {args:?}:\n{stdout}\n{stderr}");
    let png = image::open(out.path().join("frame_00000.png"))
        .unwrap_or_else(|e| panic!("frame_00000.png: {e}\n{stderr}"))
        .to_rgb8();
    assert_eq!(png.dimensions(), SIZE);
    (code, stderr, png.into_raw())
}

/// Fraction of `mask`'s pixels whose brightest channel is at least [`LIT`].
fn lit_fraction(rgb: &[u8], mask: &[bool]) -> f64 {
    let (lit, n) = rgb.chunks_exact(3).zip(mask).filter(|(_, m)| **m).fold(
        (0usize, 0usize),
        |(lit, n), (p, _)| {
            (
                lit + usize::from(p.iter().max().copied().unwrap_or(0) >= LIT),
                n + 1,
            )
        },
    );
    lit as f64 / n.max(1) as f64
}

#[test]
fn default_replay_of_glossy_room_shows_the_mirror_and_the_teapot_reflecting() {
    let bundle = shipped_bundle(&Recipe::every_needed_stage("glossy-room", Quality::Draft));
    let data = glint::view::load::load(&bundle).unwrap_or_else(|e| panic!("{e}"));
    let camera = pose_at(data.scene.camera_path(Some("front")).unwrap(), 0.0);
    let masks: Vec<(&str, Vec<bool>)> = ["MirrorPanel", "Teapot"]
        .into_iter()
        .map(|name| {
            let r = data
                .scene
                .reflectors
                .iter()
                .position(|r| r.name == name)
                .unwrap_or_else(|| panic!("glossy-room has no reflector {name}"));
            (name, reflector_mask(&data, r, &camera, SIZE.0, SIZE.1))
        })
        .collect();
    for (name, mask) in &masks {
        let n = mask.iter().filter(|m| **m).count();
        assert!(n > 100, "{name} covers only {n} pixels of the frame");
    }

    let (_, stderr, default) = replay_front(&bundle, &[]);
    for (name, mask) in &masks {
        let lit = lit_fraction(&default, mask);
        eprintln!("default: {name} {:.1}% lit", 100.0 * lit);
        assert!(
            lit > 0.9,
            "{name}: only {:.1}% of its pixels reflect anything by default\n{stderr}",
            100.0 * lit
        );
    }
    assert!(
        stderr.contains(
            "view: reflections image (radiance maps baked), curved cubemap (1 curved reflector), \
             impostors off (radiance maps show the impostor objects)"
        ),
        "the modes chosen are named in one line: {stderr}"
    );

    // The same as asked for explicitly; and off when asked: the metals are then black.
    let (_, _, explicit) =
        replay_front(&bundle, &["--reflections", "image", "--curved", "cubemap"]);
    assert!(default == explicit, "the defaults are image + cubemap");
    let (_, stderr, off) = replay_front(&bundle, &["--reflections", "off", "--curved", "off"]);
    assert!(
        stderr.contains(
            "view: reflections off (--reflections), curved off (--curved), impostors off (radiance maps show the impostor objects)"
        ),
        "{stderr}"
    );
    for (name, mask) in &masks {
        let lit = lit_fraction(&off, mask);
        assert!(
            lit < 0.05,
            "{name}: {:.1}% lit with reflections off",
            100.0 * lit
        );
    }
}
