//! glint-eval against exact answers: the white furnace, a Lambertian plane under a uniform
//! sky, the diffuse Cornell box against the radiosity bake, determinism across thread counts,
//! image metrics, probes, a sweep's CSV and plot, and the command line.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::*;
use glam::Vec3;
use glint::bundle::Bundle;
use glint::camera::Camera;
use glint::eval::compare::{self, REL_EPSILON};
use glint::eval::probe::{self, ProbePoint};
use glint::eval::reference::{self, RenderOptions, Rendered};
use glint::eval::sweep::{self, SweepConfig};
use glint::eval::{Image, luminance};
use glint::progress::Silent;
use glint::radiosity::RadiosityMap;
use glint::scene::Scene;
use glint::scene::desc::{Quality, RadiositySettings};

/// Six inward-facing faces of a cube of half-size h, all of material 0.
fn closed_box(h: f32) -> Vec<MeshSpec> {
    let names = ["X0", "X1", "Y0", "Y1", "Z0", "Z1"];
    (0..3)
        .flat_map(|axis| {
            [
                quad(names[2 * axis], 0, axis, -h, h),
                flip(quad(names[2 * axis + 1], 0, axis, h, h)),
            ]
        })
        .collect()
}

fn emissive(name: &'static str, albedo: f32, e: f32) -> MaterialSpec {
    MaterialSpec {
        emissive: [1.0; 3],
        strength: e,
        ..MaterialSpec::diffuse(name, albedo)
    }
}

fn load(dir: &Path, meshes: &[MeshSpec], materials: &[MaterialSpec], extra: &str) -> Scene {
    write_gltf(dir, "s", meshes, materials);
    Scene::load(write_scene(
        dir,
        &format!(r#"{{ "version": 1, "geometry": "s.gltf"{extra} }}"#),
    ))
    .unwrap()
}

/// Mean luminance of the pixels in `range` and its standard error (from the renderer's
/// per-pixel variances; pixels are independent).
fn mean_and_se(r: &Rendered, pixels: impl Iterator<Item = usize>) -> (f64, f64) {
    let (mut s, mut v, mut n) = (0.0f64, 0.0f64, 0usize);
    for i in pixels {
        s += luminance(r.image.rgb[i]) as f64;
        v += r.variance[i] as f64;
        n += 1;
    }
    (s / n as f64, v.sqrt() / n as f64)
}

#[test]
fn white_furnace_converges_to_e_over_one_minus_rho() {
    // Every face emits E = 1 and reflects ρ = 0.5: L = E / (1 − ρ) = 2 everywhere.
    let dir = tempfile::tempdir().unwrap();
    let scene = load(dir.path(), &closed_box(1.0), &[emissive("W", 0.5, 1.0)], "");
    let bvh = scene.build_bvh();
    let cam = Camera::look_at(
        Vec3::new(0.1, 0.2, 0.3),
        Vec3::new(1.0, -0.3, -0.5),
        Vec3::Y,
        1.6,
    );
    let opts = RenderOptions {
        width: 16,
        height: 16,
        spp: 16,
        ..RenderOptions::default()
    };
    let r = reference::render(&scene, &bvh, &cam, &opts, &Silent).unwrap();
    let expected = reference::furnace_radiance(1.0, 0.5) as f64;
    let (mean, se) = mean_and_se(&r, 0..r.image.rgb.len());
    // Tolerance: 4 standard errors of the mean (estimated from the paths) + 1e-3 for f32 sums.
    assert!(
        (mean - expected).abs() < 4.0 * se + 1e-3,
        "furnace mean {mean} vs {expected} (standard error {se})"
    );
    // No pixel far off: each within 8 of its own standard errors + 2%.
    for (i, p) in r.image.rgb.iter().enumerate() {
        let d = (luminance(*p) as f64 - expected).abs();
        assert!(
            d < 8.0 * (r.variance[i] as f64).sqrt() + 0.02 * expected,
            "pixel {i}: {p} vs {expected} (variance {})",
            r.variance[i]
        );
    }
}

#[test]
fn lambertian_plane_under_a_uniform_sky_returns_albedo_times_sky() {
    // One bounce off a plane that cannot see itself: the cosine-sampled BRDF weight is exactly
    // ρ and every continuation ray escapes, so every path returns ρ·sky (zero variance).
    let dir = tempfile::tempdir().unwrap();
    let scene = load(
        dir.path(),
        &[quad("Floor", 0, 1, 0.0, 1.0)],
        &[MaterialSpec::diffuse("F", 0.6)],
        "",
    );
    let bvh = scene.build_bvh();
    let cam = Camera::look_at(Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO, Vec3::Z, 0.5);
    let sky = Vec3::new(1.0, 2.0, 3.0);
    let opts = RenderOptions {
        width: 8,
        height: 8,
        spp: 4,
        background: sky,
        ..RenderOptions::default()
    };
    let r = reference::render(&scene, &bvh, &cam, &opts, &Silent).unwrap();
    let expected = 0.6 * sky;
    for p in &r.image.rgb {
        // Tolerance: f32 rounding only (1e-5 relative).
        assert!(
            (*p - expected).abs().max_element() < 1e-5 * expected.max_element(),
            "{p} vs {expected}"
        );
    }
}

#[test]
fn diffuse_cornell_box_agrees_with_converged_radiosity() {
    let scene = Scene::load(repo("scenes/cornell-box/scene.json")).unwrap();
    let settings = RadiositySettings {
        texel_density: 8.0,
        min_chart_texels: 0,
        min_scene_texels: 0,
        contact_boost: 0.0,
        texels_per_radian: 0.0,
        rays: 256,
        light_samples: 32,
        bounces: 16,
        tolerance: 1e-3,
        glossy_depth: 0,
        target_error: None,
        stitch_seams: false,
        cache_budget_mib: 2048,
        max_elements: 0,
    };
    let bundle = shipped_bundle(&Recipe::new("cornell-box").then(Step::Radiosity(settings)));
    let map = RadiosityMap::load(&Bundle::open(&bundle).unwrap())
        .unwrap()
        .unwrap();
    let bvh = scene.build_bvh();
    let cam = glint::camera::pose_at(scene.camera_path(Some("front")).unwrap(), 0.0);
    let (w, h) = (24u32, 24u32);
    let opts = RenderOptions {
        width: w,
        height: h,
        spp: 64,
        diffuse_only: true,
        ..RenderOptions::default()
    };
    let r = reference::render(&scene, &bvh, &cam, &opts, &Silent).unwrap();
    let view = reference::render_radiosity(&scene, &bvh, &map, &cam, w, h, 4);
    // Pixels within one pixel of a directly seen emitter are left out: at 8 texels per metre
    // the bake blurs the light's edge into the ceiling's texels (a lightmap's resolution
    // limit, not a disagreement about transport).
    let sees_emitter = |x: i64, y: i64| {
        let ndc = Camera::pixel_ndc(
            x.clamp(0, w as i64 - 1) as u32,
            y.clamp(0, h as i64 - 1) as u32,
            w,
            h,
        );
        let d = cam.ray_direction(ndc, w as f32 / h as f32);
        bvh.closest_hit(cam.position, d, f32::INFINITY)
            .is_some_and(|hit| {
                let t = &scene.triangles[hit.triangle as usize];
                scene.materials[t.material as usize].is_emissive()
            })
    };
    let keep: Vec<bool> = (0..(w * h) as i64)
        .map(|i| {
            let (x, y) = (i % w as i64, i / w as i64);
            !(-1..=1).any(|dy| (-1..=1).any(|dx| sees_emitter(x + dx, y + dy)))
        })
        .collect();
    assert!(
        keep.iter().filter(|k| !**k).count() > 0,
        "the light is in view"
    );
    // Whole image and 3×3 blocks of 8×8 pixels. Tolerance: 4 standard errors of the
    // reference's mean + a discretization allowance of the radiosity bake (8 texels per
    // metre, bilinear): 3% of the whole image's mean, 8% of a block's.
    let all = (0..(w * h) as usize).collect::<Vec<_>>();
    let check = |pixels: &[usize], allowance: f64, what: &str| {
        let pixels: Vec<usize> = pixels.iter().copied().filter(|&i| keep[i]).collect();
        let (m_ref, se) = mean_and_se(&r, pixels.iter().copied());
        let m_view = pixels
            .iter()
            .map(|&i| luminance(view.rgb[i]) as f64)
            .sum::<f64>()
            / pixels.len() as f64;
        eprintln!("{what}: reference {m_ref:.4} ± {se:.4}, radiosity view {m_view:.4}");
        assert!(
            (m_view - m_ref).abs() < 4.0 * se + allowance * m_ref,
            "{what}: radiosity {m_view} vs reference {m_ref} (standard error {se})"
        );
    };
    check(&all, 0.03, "image");
    for by in 0..3 {
        for bx in 0..3 {
            let block: Vec<usize> = (0..64)
                .map(|k| (by * 8 + k / 8) * w as usize + bx * 8 + k % 8)
                .collect();
            check(&block, 0.08, &format!("block ({bx}, {by})"));
        }
    }
}

#[test]
fn reference_is_deterministic_across_thread_counts() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(dir.path(), &closed_box(1.0), &[emissive("W", 0.7, 1.0)], "");
    let bvh = scene.build_bvh();
    let cam = Camera::look_at(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), Vec3::Y, 1.2);
    let opts = RenderOptions {
        width: 8,
        height: 6,
        spp: 4,
        seed: 7,
        ..RenderOptions::default()
    };
    let render = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| reference::render(&scene, &bvh, &cam, &opts, &Silent).unwrap())
    };
    let (a, b) = (render(1), render(3));
    assert_eq!(a.image, b.image);
    let other = reference::render(
        &scene,
        &bvh,
        &cam,
        &RenderOptions {
            seed: 8,
            ..opts.clone()
        },
        &Silent,
    )
    .unwrap();
    assert_ne!(a.image, other.image, "the seed changes the noise");
}

fn flat(w: usize, h: usize, v: Vec3) -> Image {
    Image {
        width: w,
        height: h,
        rgb: vec![v; w * h],
    }
}

#[test]
fn metrics_of_known_differences() {
    let b = flat(4, 2, Vec3::new(1.0, 0.5, 0.25));
    let mut a = b.clone();
    for p in &mut a.rgb {
        *p += Vec3::splat(0.1);
    }
    let m = compare::compare(&a, &b, None).unwrap();
    assert!((m.rmse - 0.1).abs() < 1e-6, "{m:?}");
    assert!((m.max_error - 0.1).abs() < 1e-6);
    assert!(
        (m.psnr_db - 20.0).abs() < 1e-4,
        "peak 1, RMSE 0.1: 20 dB, got {}",
        m.psnr_db
    );
    let rel = ((0.01 / (1.0 + REL_EPSILON)
        + 0.01 / (0.25 + REL_EPSILON)
        + 0.01 / (0.0625 + REL_EPSILON))
        / 3.0)
        .sqrt();
    assert!((m.rel_rmse - rel).abs() < 1e-6);
    assert_eq!(m.pixels, 8);
    // A mask that keeps only a pixel that differs by 1.
    a.rgb[3] = b.rgb[3] + Vec3::ONE;
    let mut mask = vec![false; 8];
    mask[3] = true;
    let m = compare::compare(&a, &b, Some(&mask)).unwrap();
    assert_eq!(m.pixels, 1);
    assert!((m.rmse - 1.0).abs() < 1e-6 && (m.max_error - 1.0).abs() < 1e-6);
    assert!(compare::compare(&a, &b, None).unwrap().max_error > 0.99);
    assert_eq!(
        compare::compare(&b, &b, None).unwrap().psnr_db,
        f64::INFINITY
    );
    assert!(compare::compare(&a, &flat(2, 2, Vec3::ONE), None).is_err());
    assert!(compare::compare(&a, &b, Some(&[false; 8])).is_err());
    let px = compare::diff_image(&a, &b, None, None);
    assert_eq!(px.len(), 8 * 3);
    assert_eq!(&px[9..12], &[255, 0, 0], "largest difference is red");
}

/// A floor that emits 2 (albedo 0.5) with nothing else: D = 2 everywhere on its top.
fn emissive_floor(dir: &Path) -> (Scene, PathBuf) {
    let scene = load(
        dir,
        &[quad("Floor", 0, 1, 0.0, 1.0)],
        &[emissive("F", 0.5, 2.0)],
        r#", "camera_paths": [ { "name": "top", "keyframes": [ { "time": 0, "position": [0, 2, 0.01], "target": [0, 0, 0], "fov_y_deg": 40 } ] } ]"#,
    );
    let bundle = dir.join("f.glint");
    glint::bake::scene_stage::bake(&scene, &bundle, false).unwrap();
    let s = RadiositySettings::preset(Quality::Draft);
    glint::bake::radiosity_stage::bake(&scene, &bundle, &s, false, &Silent).unwrap();
    (scene, bundle)
}

#[test]
fn probes_find_the_surface_along_the_normal() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, bundle) = emissive_floor(dir.path());
    let map = RadiosityMap::load(&Bundle::open(&bundle).unwrap())
        .unwrap()
        .unwrap();
    let bvh = scene.build_bvh();
    let pts: Vec<ProbePoint> = serde_json::from_str(
        r#"[ { "name": "on", "position": [0.2, 0.01, 0.3], "normal": [0, 1, 0] },
             { "position": [0.2, 0.5, 0.3], "normal": [0, 1, 0] },
             { "position": [0.2, 0.0, 0.3], "normal": [0, -1, 0] } ]"#,
    )
    .unwrap();
    let v = probe::probe(&scene, &bvh, &map, &pts, 0.05).unwrap();
    assert!(v[0].found, "{v:?}");
    assert_eq!(v[0].name.as_deref(), Some("on"));
    assert!((v[0].offset.unwrap() - 0.01).abs() < 1e-4);
    // D is exactly the emission (nothing to reflect); tolerance: half-float storage.
    for c in v[0].radiance {
        assert!((c - 2.0).abs() < 2e-3, "{:?}", v[0].radiance);
    }
    assert!(!v[1].found, "0.5 m above the floor is out of reach");
    assert!(
        !v[2].found,
        "the floor's back face is not a surface seen from below"
    );
    assert!(
        serde_json::from_str::<Vec<ProbePoint>>(r#"[{"position":[0,0,0],"normal":[0,1,0],"x":1}]"#)
            .is_err(),
        "unknown keys are errors"
    );
    // An enormous reach is bounded by the scene: the same surface, at the same offset (a
    // reach ≥ 1e10 put the ray's origin where f32 has no centimetres left).
    for reach in [1e10, 1e30, f32::MAX] {
        let far = probe::probe(&scene, &bvh, &map, &pts[..1], reach).unwrap();
        assert!(far[0].found, "reach {reach}: {far:?}");
        assert_eq!(far[0].triangle, v[0].triangle, "reach {reach}");
        assert!(
            (far[0].offset.unwrap() - 0.01).abs() < 1e-4,
            "reach {reach}: {far:?}"
        );
    }
    // A zero normal has no side to look from: refused, naming the probe.
    let zero: Vec<ProbePoint> = serde_json::from_str(
        r#"[ { "position": [0, 0, 0], "normal": [0, 1, 0] },
             { "name": "flat", "position": [0.2, 0.01, 0.3], "normal": [0, 0, 0] } ]"#,
    )
    .unwrap();
    let e = probe::probe(&scene, &bvh, &map, &zero, 0.05)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("probe 1 (flat)") && e.contains("normal [0, 0, 0]"),
        "{e}"
    );
    for reach in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        assert!(probe::probe(&scene, &bvh, &map, &pts, reach).is_err());
    }
}

/// A sweep's config: `knobs`, the CPU view of D or the headless viewer.
fn sweep_config<'a>(
    knobs: &'a [sweep::Knob],
    cam: &'a Camera,
    out: &'a Path,
    use_viewer: bool,
) -> SweepConfig<'a> {
    SweepConfig {
        quality: Quality::Draft,
        knobs,
        camera: cam,
        view: sweep::ViewOptions::default(),
        use_viewer,
        frames: 3,
        view_spp: 4,
        out,
    }
}

/// Checks that `svg` is well-formed XML with an `<svg>` root, and returns its text content.
fn svg_text(svg: &str) -> String {
    use quick_xml::events::Event;
    let mut reader = quick_xml::Reader::from_str(svg);
    let (mut depth, mut root, mut text) = (0usize, None, String::new());
    loop {
        match reader.read_event() {
            Ok(Event::Start(e)) => {
                root.get_or_insert_with(|| e.name().as_ref().to_vec());
                depth += 1;
            }
            Ok(Event::End(_)) => depth -= 1,
            Ok(Event::Empty(e)) => {
                root.get_or_insert_with(|| e.name().as_ref().to_vec());
            }
            Ok(Event::Text(t)) => {
                text += &String::from_utf8_lossy(t.as_ref());
                text.push('\n');
            }
            Ok(Event::Eof) => break,
            Ok(_) => {}
            Err(e) => panic!("the plot is not well-formed XML: {e}\n{svg}"),
        }
    }
    assert_eq!(depth, 0, "unclosed elements");
    assert_eq!(root.as_deref(), Some(&b"svg"[..]), "root element");
    text
}

#[test]
fn sweep_writes_csv_and_plot() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, _) = emissive_floor(dir.path());
    let bvh = scene.build_bvh();
    let cam = glint::camera::pose_at(scene.camera_path(None).unwrap(), 0.0);
    let opts = RenderOptions {
        width: 8,
        height: 8,
        spp: 4,
        diffuse_only: true,
        ..RenderOptions::default()
    };
    let reference = reference::render(&scene, &bvh, &cam, &opts, &Silent)
        .unwrap()
        .image;
    let knobs = [
        sweep::parse_knob("radiosity.rays=16,32").unwrap(),
        sweep::parse_knob("radiosity.texel_density=4").unwrap(),
    ];
    let out = dir.path().join("sweep");
    let rows = sweep::sweep(
        &scene,
        &reference,
        &sweep_config(&knobs, &cam, &out, false),
        &Silent,
    )
    .unwrap();
    assert_eq!(rows.len(), 3);
    for r in &rows {
        assert!(r.bundle_bytes > 0 && r.bake_seconds > 0.0);
        assert!(
            r.stage_seconds
                .is_some_and(|s| s > 0.0 && s <= r.bake_seconds)
        );
        assert!(r.frame_ms.is_none(), "the CPU view is not timed");
        // D = emission = the path-traced value; tolerance: half-float storage.
        assert!(r.metrics.max_error < 5e-3, "{r:?}");
    }
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 4, "{csv}");
    assert!(lines[0].starts_with("knob,value,bake_seconds,stage_seconds,bundle_bytes,frame_ms"));
    assert!(lines[1].starts_with("radiosity.rays,16,"));
    assert!(lines[3].starts_with("radiosity.texel_density,4,"));
    // Every setting's bundle is complete and verifies.
    let b = Bundle::open(out.join("bundles/radiosity.rays=32.glint")).unwrap();
    assert!(b.verify().is_empty());
    assert_eq!(
        b.stage("radiosity").unwrap().settings["rays"],
        32,
        "the knob reached the bake"
    );
    let svg = std::fs::read_to_string(out.join("sweep.svg")).unwrap();
    let text = svg_text(&svg);
    for name in ["radiosity.rays", "radiosity.texel_density", "bake time"] {
        assert!(text.contains(name), "the plot names {name}: {text}");
    }
    for value in ["16", "32", "4"] {
        assert!(
            text.lines().any(|l| l.trim() == value),
            "point labelled {value}"
        );
    }
    assert!(
        !text.contains("frame time"),
        "no frame-time panel without frame times"
    );
}

#[test]
fn unknown_knobs_and_bad_values_are_refused() {
    let e = sweep::parse_knob("radiosity.rayz=1")
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown knob `radiosity.rayz`"), "{e}");
    // The message lists every valid knob, of every stage and the viewer.
    for k in sweep::valid_knobs() {
        assert!(e.contains(&k), "{k} missing from: {e}");
    }
    for k in [
        "radiosity.rays",
        "materials.sample_budget",
        "materials.map_1d_size",
        "radiance.resolution_scale",
        "srdm.domains",
        "view.reflections",
        "view.maps",
        "view.selection",
        "view.recursion_depth",
        "view.curved",
        "view.glossy_samples",
        "view.impostors",
        "view.terminal_cubemaps",
    ] {
        assert!(sweep::valid_knobs().iter().any(|v| v == k), "{k} is a knob");
    }
    let e = sweep::parse_knob("materials.x=1").unwrap_err().to_string();
    assert!(
        e.contains("materials.x") && e.contains("materials.sample_budget"),
        "{e}"
    );
    for (bad, says) in [
        ("radiosity.rays=many", "radiosity.rays"),
        ("radiosity.rays=0", "rays"),
        ("radiosity.texel_density=-1", "texel_density"),
        ("materials.env_map_size=100", "power of two"),
        ("materials.sample_budget=0", "sample_budget"),
        ("srdm.domains=0", "domains"),
        ("radiance.resolution_scale=0", "resolution_scale"),
        ("radiance.resolution_scale=big", "number"),
    ] {
        let e = sweep::parse_knob(bad).unwrap_err().to_string();
        assert!(e.contains(says), "{bad}: {e}");
    }
    assert!(sweep::parse_knob("radiosity.rays").is_err());
    assert!(sweep::parse_knob("radiosity.rays=").is_err());
    if sweep::VIEWER_BUILT {
        let e = sweep::parse_knob("view.reflections=shiny")
            .unwrap_err()
            .to_string();
        assert!(e.contains("off, geometry, image"), "{e}");
        let e = sweep::parse_knob("view.maps=0").unwrap_err().to_string();
        assert!(e.contains("1 ..= 16"), "{e}");
        let e = sweep::parse_knob("view.selection=near")
            .unwrap_err()
            .to_string();
        assert!(e.contains("angle, distance"), "{e}");
        let k = sweep::parse_knob("view.reflections=off,geometry,image").unwrap();
        assert_eq!(k.values.len(), 3);
        for (bad, says) in [
            ("view.recursion_depth=5", "0 ..= 4"),
            ("view.recursion_depth=1.5", "0 ..= 4"),
            ("view.curved=sphere", "off, cubemap"),
            ("view.impostors=yes", "off, on"),
            ("view.terminal_cubemaps=maybe", "off, on"),
            ("view.glossy_samples=-1", "0 ..= 256"),
        ] {
            let e = sweep::parse_knob(bad).unwrap_err().to_string();
            assert!(e.contains(says), "{bad}: {e}");
        }
        let k = sweep::parse_knob("view.curved=off,cubemap").unwrap();
        assert_eq!(k.values.len(), 2);
        assert!(sweep::shows_reflections(
            &sweep::ViewOptions::default(),
            &[k]
        ));
    } else {
        let e = sweep::parse_knob("view.maps=1").unwrap_err().to_string();
        assert!(e.contains("`view` feature"), "{e}");
    }
    let k = sweep::parse_knob("materials.env_filter=box2,gauss6").unwrap();
    assert_eq!(k.values.len(), 2);
}

/// The room of `tests/common`, its ceiling light turned to face the floor, its panel a
/// planar reflector, and a camera that sees the panel's reflection of the lit floor.
#[cfg(feature = "view")]
fn glossy_room(dir: &Path) -> Scene {
    glossy_room_with(dir, "")
}

/// [`glossy_room`] with `extra` JSON members in scene.json.
fn glossy_room_with(dir: &Path, extra: &str) -> Scene {
    let (mut meshes, materials) = room();
    let ceiling = meshes.pop().unwrap();
    meshes.push(flip(ceiling));
    write_gltf(dir, "room", &meshes, &materials);
    Scene::load(write_scene(
        dir,
        &format!(
            r#"{{ "version": 1, "geometry": "room.gltf",
                 "reflectors": [ {{ "mesh": "Panel", "kind": "planar" }} ],
                 "camera_paths": [ {{ "name": "panel", "keyframes": [ {{ "time": 0, "position": [0.6, 1.0, 0.3], "target": [-0.9, 0.7, 0.0], "fov_y_deg": 60 }} ] }} ]{extra} }}"#
        ),
    ))
    .unwrap()
}

#[test]
fn stage_knobs_reach_their_stage_and_only_rebake_what_they_change() {
    let dir = tempfile::tempdir().unwrap();
    let scene = glossy_room_with(dir.path(), r#", "impostors": [ { "mesh": "Panel" } ]"#);
    let bvh = scene.build_bvh();
    let cam = glint::camera::pose_at(scene.camera_path(None).unwrap(), 0.0);
    let opts = RenderOptions {
        width: 16,
        height: 12,
        spp: 4,
        diffuse_only: true,
        ..RenderOptions::default()
    };
    let reference = reference::render(&scene, &bvh, &cam, &opts, &Silent)
        .unwrap()
        .image;
    let knobs = [
        sweep::parse_knob("materials.map_1d_size=16").unwrap(),
        sweep::parse_knob("radiance.resolution_scale=0.5").unwrap(),
        sweep::parse_knob("srdm.domains=7").unwrap(),
    ];
    let out = dir.path().join("sweep");
    let rows = sweep::sweep(
        &scene,
        &reference,
        &sweep_config(&knobs, &cam, &out, false),
        &Silent,
    )
    .unwrap();
    assert_eq!(rows.len(), 3);
    let open = |label: &str| Bundle::open(out.join(format!("bundles/{label}.glint"))).unwrap();
    let base = open("base");
    let settings = |b: &Bundle, stage: &str| b.stage(stage).unwrap().settings.clone();
    let m = open("materials.map_1d_size=16");
    assert_eq!(settings(&m, "materials")["map_1d_size"], 16);
    assert_eq!(settings(&m, "radiosity"), settings(&base, "radiosity"));
    let r = open("radiance.resolution_scale=0.5");
    assert_ne!(settings(&r, "radiance"), settings(&base, "radiance"));
    assert_eq!(settings(&r, "materials"), settings(&base, "materials"));
    let s = open("srdm.domains=7");
    assert_eq!(settings(&s, "srdm")["domains"], 7);
    // A stage the knob does not touch is the base bake's, copied: not baked again.
    for (b, kept) in [(&m, "radiosity"), (&r, "materials"), (&s, "radiance")] {
        assert_eq!(
            b.stage(kept).unwrap().bake_seconds,
            base.stage(kept).unwrap().bake_seconds,
            "{kept}"
        );
    }
    for r in &rows {
        assert!(r.stage_seconds.is_some_and(|t| t > 0.0), "{r:?}");
        assert!(r.bake_seconds >= r.stage_seconds.unwrap());
    }
}

#[cfg(feature = "view")]
#[test]
fn viewer_sweep_times_frames_and_sees_reflections() {
    let dir = tempfile::tempdir().unwrap();
    let scene = glossy_room(dir.path());
    let bvh = scene.build_bvh();
    let cam = glint::camera::pose_at(scene.camera_path(None).unwrap(), 0.0);
    // The full glossy scene: what the viewer's reflections approximate.
    let opts = RenderOptions {
        width: 48,
        height: 32,
        spp: 64,
        ..RenderOptions::default()
    };
    let reference = reference::render(&scene, &bvh, &cam, &opts, &Silent)
        .unwrap()
        .image;
    let knobs = [
        sweep::parse_knob("radiosity.rays=16,64").unwrap(),
        sweep::parse_knob("view.reflections=off,geometry").unwrap(),
        sweep::parse_knob("view.maps=1,2").unwrap(),
    ];
    let out = dir.path().join("sweep");
    let mut cfg = sweep_config(&knobs, &cam, &out, true);
    cfg.view.reflections = glint::view::options::ReflectionMode::Image;
    let rows = sweep::sweep(&scene, &reference, &cfg, &Silent).unwrap();
    assert_eq!(rows.len(), 6);
    for r in &rows {
        assert!(
            r.frame_ms.is_some_and(|f| f > 0.0) && r.gpu_ms.is_some_and(|g| g >= 0.0),
            "timed in the viewer: {r:?}"
        );
        assert!(r.metrics.rel_rmse.is_finite());
    }
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let frame = header.iter().position(|h| *h == "frame_ms").unwrap();
    for line in csv.lines().skip(1) {
        let f: f64 = line.split(',').nth(frame).unwrap().parse().unwrap();
        assert!(f > 0.0, "{line}");
    }
    let rel = |knob: &str, value: &str| {
        rows.iter()
            .find(|r| r.knob == knob && r.value == value)
            .unwrap()
            .metrics
            .rel_rmse
    };
    let (off, geometry) = (
        rel("view.reflections", "off"),
        rel("view.reflections", "geometry"),
    );
    eprintln!("rel. RMSE against the glossy reference: off {off:.4}, geometry {geometry:.4}");
    assert!(
        geometry < off,
        "reflections bring the view closer to the glossy reference"
    );
    // View knobs look at the base bundle: no bake of their own.
    assert!(!out.join("bundles/view.maps=1.glint").exists());
    assert!(out.join("bundles/radiosity.rays=16.glint").exists());
    let text = svg_text(&std::fs::read_to_string(out.join("sweep.svg")).unwrap());
    for name in [
        "radiosity.rays",
        "view.reflections",
        "view.maps",
        "frame time",
        "geometry",
    ] {
        assert!(text.contains(name), "the plot names {name}: {text}");
    }
}

fn eval_cmd() -> Command {
    Command::new(env!("CARGO_BIN_EXE_glint-eval"))
}

#[test]
fn cli_reference_compare_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    let (_, bundle) = emissive_floor(dir.path());
    let scene = dir.path().join("scene.json");
    let a = dir.path().join("a.exr");
    let st = eval_cmd()
        .args(["reference"])
        .arg(&scene)
        .args(["--camera", "top", "--size", "8x6", "--spp", "2", "--out"])
        .arg(&a)
        .status()
        .unwrap();
    assert!(st.success());
    let diff = dir.path().join("d.png");
    let out = eval_cmd()
        .arg("compare")
        .arg(&a)
        .arg(&a)
        .arg("--diff")
        .arg(&diff)
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let m: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(m["rmse"], 0.0);
    assert_eq!(m["pixels"], 48);
    assert!(diff.exists());

    let points = dir.path().join("p.json");
    std::fs::write(&points, r#"[{"position":[0,0.01,0],"normal":[0,1,0]}]"#).unwrap();
    let out = eval_cmd()
        .arg("probe")
        .arg(&bundle)
        .arg("--points")
        .arg(&points)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v[0]["found"], true);

    // `glint-eval probe … | head -1` with head gone before the first write: a closed stdout
    // ends the run quietly with 0, like every glint tool, not with a panic (101).
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = eval_cmd()
        .arg("probe")
        .arg(&bundle)
        .arg("--points")
        .arg(&points)
        .stdout(writer)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap()
        .wait_with_output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(
        !err.contains("panicked") && !err.contains("Broken pipe"),
        "{err}"
    );

    // Errors name the file or flag and exit non-zero.
    let out = eval_cmd()
        .arg("compare")
        .arg(dir.path().join("missing.exr"))
        .arg(&a)
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.exr"));
    let out = eval_cmd()
        .arg("reference")
        .arg(&scene)
        .args(["--camera", "nope", "--out"])
        .arg(&a)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("nope") && err.contains("top"), "{err}");
    let out = eval_cmd()
        .arg("reference")
        .arg(&scene)
        .args(["--size", "8by6", "--out"])
        .arg(&a)
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--size"));
    assert!(eval_cmd().arg("--help").output().unwrap().stdout.len() > 100);
}

/// `glint-bake` on shipped scenes (draft): every needed stage baked, then a second run finds
/// every one up to date and changes no file.
#[test]
fn glint_bake_twice_on_shipped_scenes_bakes_nothing_the_second_time() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["cornell-box", "glossy-room"] {
        let scene = repo(&format!("scenes/{name}/scene.json"));
        let bundle = dir.path().join(format!("{name}.glint"));
        let bake = || {
            let out = Command::new(env!("CARGO_BIN_EXE_glint-bake"))
                .arg(&scene)
                .arg("--bundle")
                .arg(&bundle)
                .args(["--quality", "draft", "--json"])
                .output()
                .unwrap();
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
            let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
            v["stages"]
                .as_array()
                .unwrap()
                .iter()
                .map(|s| {
                    (
                        s["stage"].as_str().unwrap().to_string(),
                        s["needed"].as_bool().unwrap(),
                        s["status"].as_str().unwrap().to_string(),
                    )
                })
                .collect::<Vec<_>>()
        };
        let first = bake();
        let manifest = std::fs::read(bundle.join("manifest.json")).unwrap();
        let second = bake();
        for ((stage, needed, status), (_, _, again)) in first.iter().zip(&second) {
            if *needed {
                assert!(status.starts_with("baked"), "{name} {stage}: {status}");
                assert_eq!(again, "up to date", "{name} {stage}");
            } else {
                assert!(again.starts_with("skipped"), "{name} {stage}: {again}");
            }
        }
        let needed: Vec<&str> = first.iter().filter(|s| s.1).map(|s| s.0.as_str()).collect();
        let expected: &[&str] = match name {
            "cornell-box" => &["scene", "radiosity"],
            // The TableTop impostor (a billboard for the teapot) needs the srdm stage.
            "glossy-room" => &["scene", "radiosity", "materials", "radiance", "srdm"],
            _ => &["scene", "radiosity", "materials", "radiance"],
        };
        assert_eq!(needed, expected, "{name}");
        assert_eq!(
            std::fs::read(bundle.join("manifest.json")).unwrap(),
            manifest,
            "{name}: the second run rewrote the manifest"
        );
    }
}

#[test]
fn cli_probe_points_reference_and_compare() {
    let dir = tempfile::tempdir().unwrap();
    let (_, bundle) = emissive_floor(dir.path());
    let scene = dir.path().join("scene.json");
    let run = |args: &[&std::ffi::OsStr]| {
        let out = eval_cmd().args(args).output().unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let p = |s: &'static str| std::ffi::OsStr::new(s);
    let path = |name: &str| dir.path().join(name);
    let (points, truth, d) = (path("points.json"), path("truth.json"), path("d.json"));

    let (code, _, err) = run(&[
        p("probe-points"),
        scene.as_os_str(),
        p("--count"),
        p("12"),
        p("--out"),
        points.as_os_str(),
    ]);
    assert_eq!(code, Some(0), "{err}");
    let pts: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(&points).unwrap()).unwrap();
    assert_eq!(pts.len(), 12);

    let (code, _, err) = run(&[
        p("probe-reference"),
        scene.as_os_str(),
        p("--points"),
        points.as_os_str(),
        p("--paths"),
        p("64"),
        p("--out"),
        truth.as_os_str(),
    ]);
    assert_eq!(code, Some(0), "{err}");
    let t: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(&truth).unwrap()).unwrap();
    assert!(
        t.iter()
            .all(|v| v["found"] == true && v["std_error"].is_array())
    );

    let (code, _, err) = run(&[
        p("probe"),
        bundle.as_os_str(),
        p("--points"),
        points.as_os_str(),
        p("--out"),
        d.as_os_str(),
    ]);
    assert_eq!(code, Some(0), "{err}");
    let (code, out, err) = run(&[
        p("probe-compare"),
        d.as_os_str(),
        truth.as_os_str(),
        p("--json"),
    ]);
    assert_eq!(code, Some(0), "{err}");
    let m: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(m["probes"], 12);
    let rmse = m["rel_rmse"].as_f64().unwrap();
    assert!(rmse.is_finite() && rmse < 0.5, "{m}");
    // A set compared with itself has no error.
    let (_, out, _) = run(&[
        p("probe-compare"),
        truth.as_os_str(),
        truth.as_os_str(),
        p("--json"),
    ]);
    let m: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(m["rel_rmse"], 0.0);

    // Points where values are expected, and sets of different probes, are refused by name.
    let (code, _, err) = run(&[p("probe-compare"), points.as_os_str(), truth.as_os_str()]);
    assert_ne!(code, Some(0));
    assert!(
        err.contains("points.json") && err.contains("probe values"),
        "{err}"
    );
    let one = path("one.json");
    std::fs::write(&one, "[]").unwrap();
    let (code, _, err) = run(&[p("probe-compare"), one.as_os_str(), truth.as_os_str()]);
    assert_ne!(code, Some(0));
    assert!(err.contains("0 probes against 12"), "{err}");
    let (code, _, err) = run(&[
        p("probe-reference"),
        scene.as_os_str(),
        p("--points"),
        truth.as_os_str(),
    ]);
    assert_ne!(code, Some(0));
    assert!(
        err.contains("truth.json") && err.contains("position"),
        "{err}"
    );
}
