//! glint-view on the software Vulkan adapter (Mesa lavapipe in CI; package `mesa-vulkan-drivers`):
//! golden images against the CPU reference, the WGSL bicubic filter against the CPU's,
//! headless replay through the binary, and bad bundles refused with a clear message.
//!
//! Test bundles are baked here, from the shipped scenes, with reduced radiosity settings
//! ([`test_settings`]): the comparisons hold GPU and CPU to the same bake, so its quality does
//! not matter, only that it is deterministic.
//!
//! Golden images, two kinds:
//! - **The CPU reference** (the real golden): the same view ray cast through the BVH, D looked
//!   up at each hit with the same cubic B-spline. Metric: mean absolute difference over every
//!   pixel and channel in 8-bit sRGB units, at most [`CPU_TOLERANCE`]. Rasterisation and ray
//!   casting disagree only on pixels that straddle an edge (a different surface wins the
//!   pixel); a mean over all pixels tolerates those without hiding a shading error, which
//!   moves every pixel of a surface.
//! - **Stored goldens** `tests/golden/NAME.png` (160×108, the GPU frame box-filtered 2×2):
//!   catch a change that moves GPU and CPU alike (camera conventions, the filter, the atlas).
//!   Tolerance [`STORED_TOLERANCE`]. They change when the radiosity solver does: regenerate
//!   deliberately with `GLINT_UPDATE_GOLDENS=1 cargo test --test view`; a plain run never
//!   writes them.
//!
//! On failure the GPU image, the CPU (or stored) image and the difference (×8) are written to
//! `target/golden-failures/NAME/`.

#![cfg(feature = "view")]

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use glam::{Vec2, Vec3};
use glint::camera::{Camera, pose_at};
use glint::radiosity::RadiosityMap;
use glint::radiosity::atlas::{Atlas, PageSize};
use glint::scene::desc::RadiositySettings;
use glint::view::cpu;
use glint::view::cpu::bicubic;
use glint::view::gpu::probe::bicubic_probe;
use glint::view::headless::Offscreen;
use glint::view::headless::replay::{Rendered, Timings};
use glint::view::load::{LoadError, load};

use common::*;

/// Mean absolute difference (8-bit sRGB units, all pixels and channels) allowed between the
/// GPU frame and the CPU reference. Measured on lavapipe: 0.06 (cornell-box, 0.02% of pixels
/// off by more than 16: edges) and 0.21 (breakfast-room, 0.4%: many thin edges). Errors it
/// must catch, measured the same way: radiance 10% too bright, 1.7 and 3.4; bilinear instead
/// of the B-spline, 0.63 and 3.2 (the WGSL filter is also held to the CPU's exactly by
/// `wgsl_bicubic_matches_the_cpu_filter`). Hardware adapters with 8-bit filter weights and
/// other edge rules may need more room.
const CPU_TOLERANCE: f64 = 0.5;

/// Mean absolute difference (8-bit units) allowed against a stored golden.
const STORED_TOLERANCE: f64 = 2.0;

/// Size of the compared frames (the benchmarks' 720×486 divided by 2.25).
const GOLDEN_SIZE: (u32, u32) = (320, 216);

/// Largest difference allowed between the WGSL filter and the CPU's, relative to the page's
/// largest value: half-float texels are exact in both, so this is the GPU's filter-weight
/// precision (lavapipe interpolates in f32; 8-bit weights on hardware stay below 1/256).
const PROBE_TOLERANCE: f32 = 5e-3;

/// `target/` (integration tests get `target/tmp` as CARGO_TARGET_TMPDIR).
fn target_dir() -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .map(Path::to_owned)
        .unwrap_or_else(|| repo("target"))
}

/// Reduced radiosity: deterministic and quick in the dev profile.
fn test_settings(texel_density: f32) -> RadiositySettings {
    RadiositySettings {
        texel_density,
        rays: 32,
        light_samples: 4,
        bounces: 3,
        tolerance: 1e-2,
        glossy_depth: 0,
        target_error: None,
        min_chart_texels: 0,
        min_scene_texels: 0,
        contact_boost: 0.0,
        texels_per_radian: 0.0,
        stitch_seams: false,
        cache_budget_mib: 2048,
        max_elements: 0,
    }
}

/// The Cornell box with an extra 10-frame path `ten` (9 fps over 1 s: frames at 0, 1/9, …, 1).
fn cornell_bundle() -> &'static Path {
    static BUNDLE: OnceLock<PathBuf> = OnceLock::new();
    BUNDLE.get_or_init(|| {
        let ten = serde_json::json!([{
            "name": "ten", "fps": 9,
            "keyframes": [
                { "time": 0.0, "position": [-0.5, 1.0, 3.8], "target": [0.0, 1.0, 0.0], "fov_y_deg": 39.3 },
                { "time": 1.0, "position": [0.5, 1.0, 3.8], "target": [0.0, 1.0, 0.0], "fov_y_deg": 39.3 }
            ]
        }]);
        shipped_bundle(
            &Recipe::new("cornell-box")
                .with_camera_paths(ten)
                .then(Step::Scene)
                .then(Step::Radiosity(test_settings(8.0))),
        )
    })
}

fn breakfast_bundle() -> &'static Path {
    static BUNDLE: OnceLock<PathBuf> = OnceLock::new();
    BUNDLE.get_or_init(|| {
        shipped_bundle(
            &Recipe::new("breakfast-room")
                .then(Step::Scene)
                .then(Step::Radiosity(test_settings(8.0))),
        )
    })
}

fn glint_view(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_glint-view"))
        .args(args)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Mean absolute difference over RGB of two RGBA8 images, in 8-bit units, and the fraction
/// of pixels whose largest channel difference exceeds 16.
fn compare(a: &[u8], b: &[u8]) -> (f64, f64) {
    assert_eq!(a.len(), b.len());
    let (mut sum, mut big, mut n) = (0u64, 0usize, 0usize);
    for (pa, pb) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
        let d: Vec<u8> = (0..3).map(|k| pa[k].abs_diff(pb[k])).collect();
        sum += d.iter().map(|&x| u64::from(x)).sum::<u64>();
        big += usize::from(d.iter().any(|&x| x > 16));
        n += 1;
    }
    (sum as f64 / (3 * n) as f64, big as f64 / n as f64)
}

fn write_png(path: &Path, w: u32, h: u32, rgba: &[u8]) {
    let rgb: Vec<u8> = rgba
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    std::fs::write(
        path,
        glint::image_io::encode_png(w, h, &rgb, false).unwrap(),
    )
    .unwrap();
}

fn read_png(path: &Path) -> Option<(u32, u32, Vec<u8>)> {
    let img = image::open(path).ok()?.to_rgba8();
    Some((img.width(), img.height(), img.into_raw()))
}

/// Writes `a`, `b` and |a − b| × 8 under target/golden-failures/`name`/; returns the folder.
fn write_failure(name: &str, w: u32, h: u32, a: (&str, &[u8]), b: (&str, &[u8])) -> PathBuf {
    let dir = target_dir().join("golden-failures").join(name);
    std::fs::create_dir_all(&dir).unwrap();
    write_png(&dir.join(format!("{}.png", a.0)), w, h, a.1);
    write_png(&dir.join(format!("{}.png", b.0)), w, h, b.1);
    let diff: Vec<u8> =
        a.1.chunks_exact(4)
            .zip(b.1.chunks_exact(4))
            .flat_map(|(x, y)| {
                let d = |k: usize| x[k].abs_diff(y[k]).saturating_mul(8);
                [d(0), d(1), d(2), 255]
            })
            .collect();
    write_png(&dir.join("difference-x8.png"), w, h, &diff);
    dir
}

/// 2×2 box filter of an RGBA8 image (in 8-bit values: a regression check, not photometry).
fn half_size(w: u32, h: u32, rgba: &[u8]) -> (u32, u32, Vec<u8>) {
    let (hw, hh) = (w / 2, h / 2);
    let mut out = Vec::with_capacity((hw * hh * 4) as usize);
    for y in 0..hh {
        for x in 0..hw {
            for k in 0..4 {
                let at = |dx: u32, dy: u32| {
                    u32::from(rgba[(((2 * y + dy) * w + 2 * x + dx) * 4 + k) as usize])
                };
                out.push(((at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1) + 2) / 4) as u8);
            }
        }
    }
    (hw, hh, out)
}

/// Renders the scene's `front` view on the GPU and on the CPU and compares them; then
/// compares the GPU frame with the stored golden (or rewrites it in update mode).
fn golden(name: &str, bundle: &Path) {
    let data = load(bundle).unwrap_or_else(|e| panic!("{e}"));
    let path = data
        .scene
        .camera_path(Some("front"))
        .expect("a `front` path");
    let camera: Camera = pose_at(path, path.keyframes[0].time);
    let (w, h) = GOLDEN_SIZE;

    let gpu = gpu();
    let off = Offscreen::new(&gpu, &data, w, h).unwrap_or_else(|e| panic!("{e}"));
    off.render(&gpu, &camera).unwrap();
    let gpu_px = off.read_rgba8(&gpu).unwrap();

    let bvh = data.scene.build_bvh();
    let cpu_px = cpu::to_srgb8(&cpu::render(&bvh, &data.map, &camera, w, h, 1.0));

    let (mad, edge) = compare(&gpu_px, &cpu_px);
    println!(
        "{name}: GPU vs CPU reference at {w}x{h}: mean |difference| {mad:.3} (8-bit units, tolerance {CPU_TOLERANCE}), {:.2}% of pixels differ by more than 16",
        edge * 100.0
    );
    let lit = gpu_px
        .chunks_exact(4)
        .filter(|p| p[..3].iter().any(|&c| c > 8))
        .count();
    assert!(
        lit * 2 > (w * h) as usize,
        "{name}: only {lit} of {} pixels are lit; the view should be mostly scene",
        w * h
    );
    if mad > CPU_TOLERANCE {
        let dir = write_failure(name, w, h, ("gpu", &gpu_px), ("cpu", &cpu_px));
        panic!(
            "{name}: GPU frame differs from the CPU reference by {mad:.3} > {CPU_TOLERANCE}; images in {}",
            dir.display()
        );
    }

    let (gw, gh, small) = half_size(w, h, &gpu_px);
    let stored = repo(&format!("tests/golden/{name}.png"));
    if update_goldens() {
        std::fs::create_dir_all(stored.parent().unwrap()).unwrap();
        write_png(&stored, gw, gh, &small);
        println!("{name}: golden rewritten: {}", stored.display());
        return;
    }
    let Some((sw, sh, golden_px)) = read_png(&stored) else {
        let dir = write_failure(name, gw, gh, ("gpu", &small), ("gpu-again", &small));
        panic!(
            "{name}: no stored golden {} (the frame is in {}); create it deliberately with GLINT_UPDATE_GOLDENS=1 cargo test --test view",
            stored.display(),
            dir.display()
        );
    };
    assert_eq!((sw, sh), (gw, gh), "{}: size", stored.display());
    let (mad, _) = compare(&small, &golden_px);
    println!(
        "{name}: GPU vs stored golden {}: mean |difference| {mad:.3} (tolerance {STORED_TOLERANCE})",
        stored.display()
    );
    if mad > STORED_TOLERANCE {
        let dir = write_failure(
            &format!("{name}-stored"),
            gw,
            gh,
            ("gpu", &small),
            ("golden", &golden_px),
        );
        panic!(
            "{name}: GPU frame differs from {} by {mad:.3} > {STORED_TOLERANCE}; images in {}. \
             If the change is intended (e.g. the radiosity solver changed), regenerate with \
             GLINT_UPDATE_GOLDENS=1 cargo test --test view",
            stored.display(),
            dir.display()
        );
    }
}

#[test]
fn golden_cornell_box() {
    golden("cornell-box", cornell_bundle());
}

#[test]
fn golden_breakfast_room() {
    golden("breakfast-room", breakfast_bundle());
}

/// The shader's `sample_radiosity` against `bicubic::bspline` on a random two-page atlas
/// (pages of different sizes: the smaller is padded in the texture array), at texel centres,
/// texel edges, arbitrary points, and past the page edges.
#[test]
fn wgsl_bicubic_matches_the_cpu_filter() {
    let pages = [
        PageSize {
            width: 13,
            height: 7,
        },
        PageSize {
            width: 6,
            height: 11,
        },
    ];
    let mut s = 0x1234_5678_u32;
    let mut next = || {
        s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (s >> 8) as f32 / (1u32 << 24) as f32
    };
    // Values exact in half float, up to 8 (HDR).
    let texels: Vec<Vec<Vec3>> = pages
        .iter()
        .map(|p| {
            (0..p.width * p.height)
                .map(|_| {
                    Vec3::new(next(), next(), next()).map(|v| (v * 8.0 * 256.0).round() / 256.0)
                })
                .collect()
        })
        .collect();
    let map = RadiosityMap {
        atlas: Atlas {
            texel_density: 1.0,
            pages: pages.to_vec(),
            tri_page: vec![],
            tri_coords: vec![],
            texel_chart: vec![],
            charts: 0,
            from_uv1: false,
            backs: Vec::new(),
        },
        pages: texels.clone(),
    };
    let mut points = Vec::new();
    for (page, size) in pages.iter().enumerate() {
        for j in 0..=(size.height * 4 + 4) {
            for i in 0..=(size.width * 4 + 4) {
                let p = Vec2::new(i as f32 * 0.25 - 0.5, j as f32 * 0.25 - 0.5);
                points.push((p, page as u32));
            }
        }
        for _ in 0..200 {
            let p = Vec2::new(next() * size.width as f32, next() * size.height as f32);
            points.push((p, page as u32));
        }
    }
    let gpu = gpu();
    let got = bicubic_probe(&gpu, &map, &points).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(got.len(), points.len());
    let mut worst = 0f32;
    for ((p, page), g) in points.iter().zip(&got) {
        let size = pages[*page as usize];
        let want = bicubic::bspline(&texels[*page as usize], size.width, size.height, *p);
        let err = (want - *g).abs().max_element() / 8.0;
        worst = worst.max(err);
        assert!(
            err <= PROBE_TOLERANCE,
            "page {page} at {p}: WGSL {g}, CPU {want} (relative error {err})"
        );
    }
    println!(
        "WGSL vs CPU B-spline: {} lookups, worst relative error {worst:.2e} (tolerance {PROBE_TOLERANCE})",
        points.len()
    );
}

#[test]
fn replay_of_a_ten_frame_path_writes_ten_frames_and_timings() {
    let bundle = cornell_bundle();
    let out = tempfile::tempdir().unwrap();
    let (code, stdout, stderr) = glint_view(&[
        bundle.to_str().unwrap(),
        "--replay",
        "ten",
        "--headless",
        "--size",
        "96x64",
        "--out",
        out.path().to_str().unwrap(),
        "--hdr",
    ]);
    assert_eq!(code, 0, "stdout:\n{stdout}\nstderr:\n{stderr}");
    assert!(
        stdout.contains("median") && stdout.contains("p95"),
        "{stdout}"
    );
    let names = |ext: &str| {
        let mut v: Vec<String> = std::fs::read_dir(out.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(ext))
            .collect();
        v.sort();
        v
    };
    let pngs = names(".png");
    assert_eq!(pngs.len(), 10, "{pngs:?}");
    assert_eq!(pngs[0], "frame_00000.png");
    assert_eq!(pngs[9], "frame_00009.png");
    assert_eq!(names(".exr").len(), 10);
    let (w, h, px) = read_png(&out.path().join("frame_00005.png")).unwrap();
    assert_eq!((w, h), (96, 64));
    assert!(
        px.chunks_exact(4).any(|p| p[0] > 60 && p[1] < p[0] / 2),
        "the red wall is in view"
    );
    let exr =
        glint::image_io::decode_exr(&std::fs::read(out.path().join("frame_00005.exr")).unwrap())
            .unwrap();
    assert_eq!((exr.width, exr.height), (96, 64));
    assert!(
        exr.rgb().unwrap().iter().any(|c| c.max_element() > 1.0),
        "the light is HDR"
    );

    let timings: Timings =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("timings.json")).unwrap())
            .unwrap();
    assert_eq!(timings.frames.len(), 10);
    assert_eq!(timings.path, "ten");
    assert_eq!(timings.size, [96, 64]);
    assert!(
        timings
            .frames
            .iter()
            .enumerate()
            .all(|(i, f)| f.frame == i && f.gpu_ms > 0.0 && f.frame_ms >= f.cpu_ms)
    );
    assert!(timings.summary.gpu_ms.max >= timings.summary.gpu_ms.p95);
    assert!(timings.summary.gpu_ms.p95 >= timings.summary.gpu_ms.median);

    assert_eq!(timings.path_frames, 10);
    assert_eq!(timings.rendered, Rendered::All);

    // --every 4 renders, times and writes frames 0, 4, 8 alone, and timings.json says so.
    let out2 = tempfile::tempdir().unwrap();
    let (code, _, stderr) = glint_view(&[
        bundle.to_str().unwrap(),
        "--replay",
        "ten",
        "--headless",
        "--size",
        "48x32",
        "--out",
        out2.path().to_str().unwrap(),
        "--every",
        "4",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let json = std::fs::read_to_string(out2.path().join("timings.json")).unwrap();
    let t: Timings = serde_json::from_str(&json).unwrap();
    let rendered: Vec<usize> = t.frames.iter().map(|f| f.frame).collect();
    assert_eq!(rendered, [0, 4, 8], "only the written frames are rendered");
    assert!(
        t.frames
            .iter()
            .all(|f| f.files == [format!("frame_{:05}.png", f.frame)])
    );
    assert_eq!((t.path_frames, t.rendered), (10, Rendered::Every(4)));
    assert!(
        json.contains("\"path_frames\": 10") && json.contains("\"every\": 4"),
        "{json}"
    );
}

/// `--frame K` renders and writes frame K of the path alone, the same image as a replay
/// writes for it; a frame past the path's end, or `--frame` without `--replay`, is refused
/// naming the flag and what it expected.
#[test]
fn frame_k_renders_one_frame_of_the_path() {
    let bundle = cornell_bundle().to_str().unwrap();
    let (one, every) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let replay = |out: &Path, extra: &[&str]| {
        let mut args = vec![bundle, "--replay", "ten", "--headless", "--size", "48x32"];
        args.extend_from_slice(extra);
        args.extend(["--out", out.to_str().unwrap()]);
        glint_view(&args)
    };
    let (code, stdout, stderr) = replay(one.path(), &["--frame", "5"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("1 frames of cornell-box/ten (frame 5 of 10)"),
        "{stdout}"
    );
    assert!(
        stderr.contains("view: reflections off (no radiance maps baked), curved off (no curved reflectors), impostors off (no impostor depth maps baked)"),
        "{stderr}"
    );
    let files: Vec<String> = std::fs::read_dir(one.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".png"))
        .collect();
    assert_eq!(files, ["frame_00005.png"]);
    let t: Timings =
        serde_json::from_str(&std::fs::read_to_string(one.path().join("timings.json")).unwrap())
            .unwrap();
    assert_eq!(t.frames.len(), 1);
    assert_eq!((t.frames[0].frame, t.rendered), (5, Rendered::Frame(5)));
    let (code, _, stderr) = replay(every.path(), &["--every", "5"]);
    assert_eq!(code, 0, "{stderr}");
    let frame = |dir: &Path| read_png(&dir.join("frame_00005.png")).unwrap();
    assert!(
        frame(one.path()) == frame(every.path()),
        "frame 5 is frame 5"
    );

    let (code, _, stderr) = replay(one.path(), &["--frame", "10"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.contains("--frame 10: camera path `ten` has 10 frame(s), numbered 0 to 9"),
        "{stderr}"
    );
    let (code, _, stderr) = replay(one.path(), &["--frame", "1.5"]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("'--frame <K>'"), "{stderr}");
    let (code, _, stderr) = glint_view(&[bundle, "--headless", "--frame", "2", "--out", "x"]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("--replay"), "{stderr}");
}

/// `--supersample 2` writes the frame drawn at twice the size, box-filtered in radiance: its
/// EXR is the mean of each 2×2 block of the 2× frame's EXR, its PNG that radiance through the
/// display mapping (within a unit of the display pass's own frame where the frame is flat).
#[test]
fn supersampled_frames_are_the_box_filtered_larger_frame() {
    let bundle = cornell_bundle().to_str().unwrap();
    let replay = |size: &str, extra: &[&str]| {
        let out = tempfile::tempdir().unwrap();
        let mut args = vec![
            bundle,
            "--replay",
            "ten",
            "--frame",
            "5",
            "--headless",
            "--hdr",
        ];
        args.extend(["--size", size, "--out", out.path().to_str().unwrap()]);
        args.extend_from_slice(extra);
        let (code, stdout, stderr) = glint_view(&args);
        assert_eq!(code, 0, "stdout:\n{stdout}\nstderr:\n{stderr}");
        let exr = glint::image_io::decode_exr(
            &std::fs::read(out.path().join("frame_00005.exr")).unwrap(),
        )
        .unwrap();
        let png = read_png(&out.path().join("frame_00005.png")).unwrap();
        let timings: Timings = serde_json::from_str(
            &std::fs::read_to_string(out.path().join("timings.json")).unwrap(),
        )
        .unwrap();
        (exr.rgb().unwrap(), png, timings, stdout)
    };
    let (big, _, _, _) = replay("96x64", &[]);
    let (small, small_png, small_t, _) = replay("48x32", &[]);
    let (ss, ss_png, ss_t, stdout) = replay("48x32", &["--supersample", "2"]);
    assert_eq!((ss_t.size, ss_t.supersample), ([48, 32], 2));
    assert_eq!(small_t.supersample, 1);
    assert!(
        stdout.contains("at 48x32 (2x2 samples a pixel)"),
        "{stdout}"
    );
    assert_eq!((ss_png.0, ss_png.1), (48, 32));
    // The EXR holds half floats: the filtered mean is rounded once more.
    let want = glint::image_io::downsample(&big, 96, 64, 48, 32);
    for (i, (a, b)) in ss.iter().zip(&want).enumerate() {
        assert!(
            (*a - *b).abs().max_element() <= 2e-3 * (1.0 + b.max_element()),
            "pixel {i}: {a} against the 2x frame's block mean {b}"
        );
    }
    // Where the one-sample frame is flat (a pixel equal to its 8 neighbours), the filtered
    // frame's PNG matches the display pass's to a unit: the CPU mapping is the shader's.
    let at = |png: &(u32, u32, Vec<u8>), x: usize, y: usize, c: usize| png.2[(y * 48 + x) * 4 + c];
    let mut flat = 0;
    for y in 1..31 {
        for x in 1..47 {
            let c = small[y * 48 + x];
            let is_flat = (0..9).all(|k| {
                let n = small[(y + k / 3 - 1) * 48 + x + k % 3 - 1];
                (n - c).abs().max_element() <= 1e-4 * (1.0 + c.max_element())
            });
            if !is_flat {
                continue;
            }
            flat += 1;
            for ch in 0..3 {
                let (a, b) = (at(&ss_png, x, y, ch), at(&small_png, x, y, ch));
                assert!(
                    a.abs_diff(b) <= 1,
                    "({x}, {y}) channel {ch}: {a} against {b}"
                );
            }
        }
    }
    assert!(flat > 50, "only {flat} flat pixels");
    let (code, _, stderr) = glint_view(&[
        bundle,
        "--replay",
        "ten",
        "--headless",
        "--supersample",
        "9",
        "--out",
        "x",
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("1 (off) to 8"), "{stderr}");
    let (code, _, stderr) = glint_view(&[bundle, "--supersample", "2"]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("--headless"), "{stderr}");
}

/// `--eye`, `--target` and `--fov` render one view without a path: the `ten` path's first
/// pose given on the command line draws its frame 0; bad values name the flag and what it
/// expected.
#[test]
fn a_camera_on_the_command_line_renders_one_view() {
    let bundle = cornell_bundle().to_str().unwrap();
    let (cam, path) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let view = |extra: &[&str]| {
        let mut args = vec![bundle, "--headless", "--size", "48x32", "--out"];
        args.push(cam.path().to_str().unwrap());
        args.extend_from_slice(extra);
        glint_view(&args)
    };
    let pose = ["--eye", "-0.5,1,3.8", "--target", "0,1,0", "--fov", "39.3"];
    let (code, stdout, stderr) = view(&pose);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("(camera from the command line)"),
        "{stdout}"
    );
    let t: Timings =
        serde_json::from_str(&std::fs::read_to_string(cam.path().join("timings.json")).unwrap())
            .unwrap();
    assert_eq!((t.frames.len(), t.path.as_str()), (1, ""));
    let Rendered::Camera(k) = t.rendered else {
        panic!("{:?}", t.rendered)
    };
    assert_eq!(
        (k.position, k.target, k.fov_y_deg),
        ([-0.5, 1.0, 3.8], [0.0, 1.0, 0.0], 39.3)
    );
    let (code, _, stderr) = glint_view(&[
        bundle,
        "--replay",
        "ten",
        "--frame",
        "0",
        "--headless",
        "--size",
        "48x32",
        "--out",
        path.path().to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    let frame = |dir: &Path| read_png(&dir.join("frame_00000.png")).unwrap();
    assert!(
        frame(cam.path()) == frame(path.path()),
        "the same pose draws the same frame"
    );

    for (args, says) in [
        (
            &["--eye", "1,2", "--target", "0,0,0"][..],
            "'--eye <X,Y,Z>': expected three numbers X,Y,Z",
        ),
        (
            &["--eye", "1,2,x", "--target", "0,0,0"],
            "'--eye <X,Y,Z>': expected three numbers",
        ),
        (
            &["--eye", "1,2,3", "--target", "0,0,1e9"],
            "'--target <X,Y,Z>': expected three numbers X,Y,Z within",
        ),
        (
            &["--eye", "0,1,0", "--target", "0,1,0"],
            "--eye 0,1,0 and --target 0,1,0: the camera is at its target",
        ),
        (
            &["--eye", "0,1,0", "--target", "0,3,0"],
            "looks straight up or down",
        ),
        (
            &["--eye", "0,1,3", "--target", "0,1,0", "--fov", "180"],
            "'--fov <DEG>': expected a vertical field of view in degrees, from 0.1 to 179",
        ),
        (&["--eye", "0,1,3"], "--target"),
        (
            &["--eye", "0,1,3", "--target", "0,1,0", "--replay"],
            "cannot be used with",
        ),
    ] {
        let (code, _, stderr) = view(args);
        assert!(code == 1 || code == 2, "{args:?}: exit {code}");
        assert!(
            stderr.contains(says),
            "{args:?}: {says:?} missing from {stderr}"
        );
    }
}

/// A bundle path that is not UTF-8 is written lossily in timings.json (the replay panicked
/// after writing its frames, leaving no timings).
#[test]
fn replay_of_a_bundle_whose_path_is_not_utf8_writes_its_timings() {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    let bundle = dir.path().join(OsStr::from_bytes(b"cornell-\xff.glint"));
    copy_dir(cornell_bundle(), &bundle);
    let out = dir.path().join("frames");
    let run = Command::new(env!("CARGO_BIN_EXE_glint-view"))
        .arg(&bundle)
        .args([
            "--replay",
            "ten",
            "--headless",
            "--size",
            "16x16",
            "--every",
            "0",
        ])
        .arg("--out")
        .arg(&out)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(0), "{stderr}");
    let timings: Timings =
        serde_json::from_str(&std::fs::read_to_string(out.join("timings.json")).unwrap()).unwrap();
    assert_eq!(timings.frames.len(), 10);
    let written = timings.bundle.to_str().unwrap();
    assert!(written.ends_with("cornell-\u{fffd}.glint"), "{written}");
}

/// `--out` naming a file is refused saying so, not "File exists (os error 17)", and the
/// file is left as it was.
#[test]
fn replay_into_an_out_that_is_a_file_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("frames");
    std::fs::write(&file, b"not a folder").unwrap();
    let (code, _, stderr) = glint_view(&[
        cornell_bundle().to_str().unwrap(),
        "--replay",
        "ten",
        "--headless",
        "--size",
        "16x16",
        "--out",
        file.to_str().unwrap(),
    ]);
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.contains("frames: it is a file, not a folder") && !stderr.contains("os error"),
        "{stderr}"
    );
    assert_eq!(std::fs::read(&file).unwrap(), b"not a folder");
}

/// Ctrl-C during a replay exits 130 and says how many frames were written and where (it said
/// "nothing was written" after writing frames); those frames are on disk.
#[test]
fn an_interrupted_replay_says_how_many_frames_it_wrote() {
    let out = tempfile::tempdir().unwrap();
    let pngs = || {
        std::fs::read_dir(out.path())
            .unwrap()
            .filter(|e| {
                e.as_ref()
                    .unwrap()
                    .path()
                    .extension()
                    .is_some_and(|x| x == "png")
            })
            .count()
    };
    let child = Command::new(env!("CARGO_BIN_EXE_glint-view"))
        .arg(cornell_bundle())
        .args([
            "--replay",
            "orbit",
            "--headless",
            "--size",
            "320x216",
            "--out",
        ])
        .arg(out.path())
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while pngs() < 2 {
        assert!(start.elapsed().as_secs() < 300, "no frames written");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    // SAFETY: kill(2) on the child's own pid.
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGINT) }, 0);
    let run = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(130), "{stderr}");
    let written = pngs();
    assert!(
        (2..61).contains(&written),
        "{written} frames written: {stderr}"
    );
    let says = format!(
        "of 61 frames: {written} frame(s) were written to {}, no timings.json",
        out.path().display()
    );
    assert!(
        stderr.contains("error: interrupted after ") && stderr.contains(&says),
        "{says:?} missing from: {stderr}"
    );
    assert!(!out.path().join("timings.json").exists());
}

/// A headless run outside a desktop session (no `XDG_RUNTIME_DIR`, no Wayland) succeeds
/// without libwayland's "error: XDG_RUNTIME_DIR is invalid or not set" line, which Mesa's
/// Vulkan device-select layer caused.
#[test]
fn headless_replay_without_a_session_prints_no_error_line() {
    let out = tempfile::tempdir().unwrap();
    let run = Command::new(env!("CARGO_BIN_EXE_glint-view"))
        .arg(cornell_bundle())
        .args([
            "--replay",
            "ten",
            "--headless",
            "--size",
            "32x24",
            "--every",
            "0",
            "--out",
        ])
        .arg(out.path())
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("NODEVICE_SELECT")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(0), "{stderr}");
    assert!(
        !stderr
            .lines()
            .any(|l| l.starts_with("error:") || l.contains("XDG_RUNTIME_DIR")),
        "{stderr}"
    );
}

/// The Cornell box's `front` camera, its data and a GPU.
fn cornell_front() -> (glint::view::load::ViewData, Camera) {
    let data = load(cornell_bundle()).unwrap_or_else(|e| panic!("{e}"));
    let path = data
        .scene
        .camera_path(Some("front"))
        .expect("a `front` path");
    let camera = pose_at(path, path.keyframes[0].time);
    (data, camera)
}

/// The HDR output is the frame's linear radiance: exposure and the tone curve change only the
/// 8-bit frame. Two frames at +2 and −2 EV have bit-identical HDR and 8-bit frames whose mean
/// differs by the exposure.
#[test]
fn hdr_output_is_identical_at_any_exposure() {
    use glint::view::options::{Exposure, Tonemap};
    let (data, camera) = cornell_front();
    let gpu = gpu();
    let (w, h) = (96, 64);
    let mut off = Offscreen::new(&gpu, &data, w, h).unwrap();
    let mut frame = |ev: f32| {
        off.set_display(Exposure::Ev(ev), Tonemap::Neutral);
        off.render(&gpu, &camera).unwrap();
        (off.read_hdr(&gpu).unwrap(), off.read_rgba8(&gpu).unwrap())
    };
    let (hdr_bright, ldr_bright) = frame(2.0);
    let (hdr_dark, ldr_dark) = frame(-2.0);
    assert!(
        hdr_bright.iter().any(|c| c.max_element() > 0.0),
        "the frame shows the scene"
    );
    assert!(
        hdr_bright == hdr_dark,
        "HDR frames at +2 and −2 EV differ: the HDR output must not be exposed"
    );
    let mean = |px: &[u8]| px.iter().map(|&v| f64::from(v)).sum::<f64>() / px.len() as f64;
    let (b, d) = (mean(&ldr_bright), mean(&ldr_dark));
    assert!(b > d + 30.0, "8-bit means at +2 and −2 EV: {b:.1}, {d:.1}");
}

/// The display pass (`shaders/display.wgsl`) maps the radiance target as the CPU's
/// [`glint::view::passes::display::DisplayMapping`] does (exposure, PBR Neutral, sRGB), to
/// within one 8-bit step (f32 rounding between the two sRGB encoders).
#[test]
fn display_pass_matches_the_cpu_mapping() {
    use glint::view::options::{Exposure, Tonemap};
    let (data, camera) = cornell_front();
    let gpu = gpu();
    let (w, h) = (96, 64);
    let mut off = Offscreen::new(&gpu, &data, w, h).unwrap();
    for (exposure, tonemap) in [
        (Exposure::Auto, Tonemap::Neutral),
        (Exposure::Ev(3.0), Tonemap::Neutral),
        (Exposure::Ev(1.0), Tonemap::None),
    ] {
        off.set_display(exposure, tonemap);
        off.render(&gpu, &camera).unwrap();
        let mapping = off.frame().display_mapping();
        let hdr = off.read_hdr(&gpu).unwrap();
        let shown: Vec<Vec3> = hdr.iter().map(|&c| mapping.apply(c)).collect();
        let cpu = cpu::to_srgb8(&shown);
        let gpu_px = off.read_rgba8(&gpu).unwrap();
        let worst = gpu_px
            .iter()
            .zip(&cpu)
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap();
        assert!(
            worst <= 1,
            "{exposure} {tonemap}: largest difference {worst}"
        );
        let lit = shown.iter().filter(|c| c.max_element() > 0.05).count();
        assert!(
            lit * 2 > shown.len(),
            "{exposure} {tonemap}: the frame is lit"
        );
    }
}

/// `--exposure auto` (the default) brings a blown-out frame to mid-grey: the Cornell box with
/// every emitter × 30 (D is linear in emission, so its D is 30 × the bake's) has an exposed
/// log-average luminance within half a stop of 0.18 over the pixels that show the scene (the
/// black void around the open box left out), and its 8-bit frame is the × 1 frame's to within
/// one step (auto compensates exactly log2 30 EV). Measured on lavapipe: 0.164, −0.13 EV (auto
/// averages D over every surface, the frame shows some of them).
#[test]
fn auto_exposure_brings_a_blown_out_frame_to_mid_grey() {
    use glint::view::exposure::{KEY, log_average_luminance};
    use glint::view::options::ViewOptions;
    let (mut data, camera) = cornell_front();
    let gpu = gpu();
    let (w, h) = (96, 64);
    let frame = |data: &glint::view::load::ViewData| {
        let off = Offscreen::with_options(&gpu, data, w, h, &ViewOptions::default()).unwrap();
        off.render(&gpu, &camera).unwrap();
        let scale = off
            .frame()
            .display_mapping()
            .exposure
            .scale(off.frame().auto_ev());
        let hdr = off.read_hdr(&gpu).unwrap();
        (scale, hdr, off.read_rgba8(&gpu).unwrap())
    };
    let (scale1, _, ldr1) = frame(&data);
    for page in &mut data.map.pages {
        for c in page.iter_mut() {
            *c *= 30.0;
        }
    }
    let (scale30, hdr30, ldr30) = frame(&data);
    let scene: Vec<Vec3> = hdr30
        .into_iter()
        .filter(|c| c.max_element() > 0.0)
        .collect();
    assert!(
        scene.len() * 2 > (w * h) as usize,
        "the view is mostly scene"
    );
    let exposed = log_average_luminance(scene.iter().map(|c| *c * scale30)).unwrap();
    let unexposed = log_average_luminance(scene.iter().copied()).unwrap();
    eprintln!(
        "× 30: frame log-average {unexposed:.3}, exposed × {scale30:.4} ({:+.2} EV) → {exposed:.3} (key {KEY}); × 1 at {:+.2} EV",
        scale30.log2(),
        scale1.log2()
    );
    assert!(
        unexposed > 2.0 * KEY,
        "the × 30 frame is blown out: {unexposed}"
    );
    assert!(
        (exposed / KEY).log2().abs() <= 0.5,
        "exposed log-average {exposed} is not within half a stop of {KEY}"
    );
    assert!(
        ((scale1 / scale30) / 30.0 - 1.0).abs() < 1e-3,
        "{scale1} / {scale30}"
    );
    let worst = ldr1
        .iter()
        .zip(&ldr30)
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap();
    assert!(worst <= 1, "× 1 and × 30 frames differ by up to {worst}");
}

/// Without a Vulkan driver wgpu would fall back to GL, whose frames have black walls: the
/// viewer refuses instead, exit code 1, naming the package to install. Two ways to get there:
/// the Vulkan loader finds no driver (`VK_ICD_FILENAMES` pointing nowhere), or `WGPU_BACKEND`
/// asks for GL only.
#[test]
fn without_vulkan_the_viewer_refuses_and_names_the_driver_package() {
    // (case, environment): the Vulkan loader finds no driver (older and newer loaders'
    // variable), or wgpu is told to use GL only.
    let no_driver = [
        ("VK_ICD_FILENAMES", "/nonexistent/icd.json"),
        ("VK_DRIVER_FILES", "/nonexistent/icd.json"),
    ];
    let gl_only = [("WGPU_BACKEND", "gl")];
    for (case, env) in [
        ("no Vulkan driver", &no_driver[..]),
        ("GL only", &gl_only[..]),
    ] {
        let out = tempfile::tempdir().unwrap();
        let run = Command::new(env!("CARGO_BIN_EXE_glint-view"))
            .arg(cornell_bundle())
            .args(["--replay", "ten", "--headless", "--size", "32x24", "--out"])
            .arg(out.path())
            .env("XDG_RUNTIME_DIR", std::env::temp_dir())
            .env_remove("WGPU_BACKEND")
            .envs(env.iter().copied())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(1), "{case}: {stderr}");
        assert!(
            stderr.contains("apt-get install mesa-vulkan-drivers"),
            "{case}: the message names the package: {stderr}"
        );
        assert!(
            !out.path().join("timings.json").exists(),
            "{case}: nothing is written"
        );
    }
}

/// The Breakfast Room's .glb has a camera node `Camera`, which scene.json does not name: it
/// replays as a one-frame path from the glTF's pose (glTF cameras, `scene::gltf_cameras`).
#[test]
fn a_gltf_camera_node_replays_by_its_name() {
    let out = tempfile::tempdir().unwrap();
    let (code, _, stderr) = glint_view(&[
        breakfast_bundle().to_str().unwrap(),
        "--replay",
        "Camera",
        "--headless",
        "--size",
        "32x24",
        "--out",
        out.path().to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    let t: Timings =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("timings.json")).unwrap())
            .unwrap();
    assert_eq!((t.path.as_str(), t.frames.len()), ("Camera", 1));
    let data = load(breakfast_bundle()).unwrap();
    let k = data.scene.camera_path(Some("Camera")).unwrap().keyframes[0];
    // The node's matrix: translation (−0.587317, 2.7623, 9.71429) glTF units × scale 0.3.
    let expected = Vec3::new(-0.587317, 2.7623, 9.71429) * 0.3;
    assert!(
        (Vec3::from(k.position) - expected).length() < 1e-5,
        "{:?}",
        k.position
    );
    assert!((k.fov_y_deg - 0.6280288f32.to_degrees()).abs() < 1e-3);
}

#[test]
fn replay_of_an_unknown_path_names_the_ones_there_are() {
    let out = tempfile::tempdir().unwrap();
    let (code, _, stderr) = glint_view(&[
        cornell_bundle().to_str().unwrap(),
        "--replay",
        "nope",
        "--headless",
        "--out",
        out.path().to_str().unwrap(),
    ]);
    assert_eq!(code, 1);
    assert!(
        stderr.contains("no camera path \"nope\"") && stderr.contains("orbit, front, ten"),
        "{stderr}"
    );
}

/// Runs the loader and the binary on a bad bundle; both must refuse with `expected` in the
/// message, and the binary must exit 1 without panicking.
fn refused(bundle: &Path, expected: &[&str]) -> LoadError {
    let err = load(bundle).expect_err("a bad bundle must be refused");
    let msg = err.to_string();
    assert!(
        msg.starts_with(&format!("bundle {}", bundle.display())),
        "the message names the bundle: {msg}"
    );
    for e in expected {
        assert!(msg.contains(e), "{msg:?} should contain {e:?}");
    }
    let out = tempfile::tempdir().unwrap();
    let (code, _, stderr) = glint_view(&[
        bundle.to_str().unwrap(),
        "--replay",
        "--headless",
        "--out",
        out.path().to_str().unwrap(),
    ]);
    assert_eq!(code, 1, "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    for e in expected {
        assert!(stderr.contains(e), "{stderr:?} should contain {e:?}");
    }
    err
}

#[test]
fn newer_format_version_is_refused_naming_both_versions() {
    let dir = tempfile::tempdir().unwrap();
    let bundle = dir.path().join("newer.glint");
    copy_dir(cornell_bundle(), &bundle);
    let manifest = bundle.join("manifest.json");
    let text = std::fs::read_to_string(&manifest).unwrap();
    std::fs::write(
        &manifest,
        text.replace(
            "\"format_version\": \"2.1.0\"",
            "\"format_version\": \"3.0.0\"",
        ),
    )
    .unwrap();
    let err = refused(&bundle, &["format version 3.0.0 is newer", "2.1.0"]);
    assert!(matches!(err, LoadError::Bundle { .. }));
}

#[test]
fn corrupt_asset_is_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let bundle = dir.path().join("corrupt.glint");
    copy_dir(cornell_bundle(), &bundle);
    let asset = |rel: &str| {
        let b = glint::bundle::Bundle::open(&bundle).unwrap();
        b.asset_path(b.stage_asset("radiosity", rel).unwrap())
    };
    let page = asset("page0.exr");
    let mut bytes = std::fs::read(&page).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x55;
    std::fs::write(&page, bytes).unwrap();
    let err = refused(&bundle, &["damaged", "page0.exr", "BLAKE3"]);
    assert!(matches!(err, LoadError::Damaged { .. }));

    // A truncated asset: the size differs.
    let atlas = asset("atlas.bin");
    let bytes = std::fs::read(&atlas).unwrap();
    std::fs::write(&atlas, &bytes[..bytes.len() - 3]).unwrap();
    refused(&bundle, &["2 asset(s) damaged", "atlas.bin", "size is"]);
}

#[test]
fn missing_stage_and_missing_manifest_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let bundle = dir.path().join("nostage.glint");
    copy_dir(cornell_bundle(), &bundle);
    let manifest = bundle.join("manifest.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&manifest).unwrap()).unwrap();
    v["stages"].as_object_mut().unwrap().remove("radiosity");
    std::fs::write(&manifest, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    let err = refused(
        &bundle,
        &["no `radiosity` stage", "it has: scene", "glint-bake"],
    );
    assert!(matches!(err, LoadError::MissingStage { .. }));

    std::fs::remove_file(&manifest).unwrap();
    refused(&bundle, &["not a glint bundle", "manifest.json is missing"]);

    std::fs::write(&manifest, "{ not json").unwrap();
    refused(&bundle, &["corrupt manifest"]);

    refused(&dir.path().join("absent.glint"), &["no such folder"]);
}
