//! Reflections of depth-map impostors in glint-view (Popescu §3–4), on the
//! software Vulkan adapter (lavapipe in CI).
//!
//! 1. The WGSL SRDM intersection (`shaders/srdm.wgsl`) against the CPU one
//!    ([`Srdm::intersect`]) on a grid of rays: hits, misses, grazing rays and rays starting
//!    inside the impostor's frustum, over two views packed in one set of tables.
//! 2. On bunny-mirror: the reflected bunny covers the pixels where the mirrored geometry
//!    predicts (CPU ray casting against the real triangles), and its radiance matches the
//!    reference path tracer's image of the same view in that region.

#![cfg(feature = "view")]

mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use glam::{Vec2, Vec3};
use glint::bake::srdm_stage::{self, SrdmSettings};
use glint::camera::Camera;
use glint::eval::luminance;
use glint::eval::reference::{RenderOptions, render};
use glint::geometry::Bvh;
use glint::progress::Silent;
use glint::sampling::Rng;
use glint::scene::Scene;
use glint::scene::desc::RadiositySettings;
use glint::srdm::{DepthMap, ImpostorCamera, Srdm, SrdmParams};
use glint::view::gpu::Gpu;
use glint::view::headless::Offscreen;
use glint::view::impostors::srdm_tables::{ImpostorParams, SrdmTables, ViewSource, colour_at};
use glint::view::impostors::{ProbeRay, SrdmProbe};
use glint::view::load::load;
use glint::view::reflections::ReflectionMode;

use common::{Recipe, Step, gpu, repo, shipped_bundle};

// ---------------------------------------------------------------------------------------------
// 1. WGSL against CPU.

/// Largest fraction of rays whose hit/miss differs between WGSL and CPU. Both follow the same
/// steps, but the GPU rounds differently (FMA contraction, its own atan2 and divisions): a ray
/// whose direction lies within rounding of halfway between two domains may search the other
/// domain, and a ray that touches a row segment within rounding of its end may pass it.
const MAX_HIT_MISMATCH: f64 = 0.01;

/// Smallest fraction of rays that both hit which must search the same domain and row.
const MIN_SAME_ROW: f64 = 0.99;

/// Largest |t_gpu − t_cpu| / t_cpu where both search the same row: a few hundred f32 ulps,
/// the rounding of the projection, clipping and the (u, depth) segment crossing.
const T_TOLERANCE: f32 = 2e-4;

/// A bumpy sphere cap with a hole and a depth step: rows with several spans and slopes.
fn depth_map(w: u32) -> DepthMap {
    let c = w as f32 / 2.0;
    DepthMap::from_fn(w, |x, y| {
        let (fx, fy) = (x as f32 + 0.5 - c, y as f32 + 0.5 - c);
        let r2 = (fx * fx + fy * fy) / (0.45 * w as f32).powi(2);
        if r2 > 1.0 {
            return None;
        }
        if (fx - 0.25 * c).abs() < 0.1 * c && fy.abs() < 0.2 * c {
            return None;
        }
        let mut d = 0.3 + 0.4 * (1.0 - r2).sqrt() + 0.05 * (x as f32 / 3.0).sin();
        if fx < -0.3 * c {
            d -= 0.1;
        }
        Some(d.clamp(0.01, 1.0))
    })
    .unwrap()
}

fn colours(w: u32) -> Vec<Vec3> {
    (0..w * w)
        .map(|i| Vec3::new((i % w) as f32 / w as f32, (i / w) as f32 / w as f32, 0.5))
        .collect()
}

/// Two views of the object around (0, 0, −2): one from the origin, one from the side.
fn views() -> Vec<(Srdm, Vec<Vec3>)> {
    let centre = Vec3::new(0.0, 0.0, -2.0);
    let cams = [
        (Vec3::ZERO, 64, 24, 8),
        (centre + Vec3::new(2.0, 0.5, 0.0), 48, 7, 16),
    ];
    cams.iter()
        .map(|&(eye, w, n, m)| {
            let camera = ImpostorCamera {
                view: Camera::look_at(eye, centre, Vec3::Y, 40f32.to_radians()),
                hither: (centre - eye).length() - 1.0,
                yon: (centre - eye).length() + 1.0,
                resolution: w,
            };
            let srdm = Srdm::build(
                &depth_map(w),
                camera,
                SrdmParams {
                    domains: n,
                    points: m,
                },
                &Silent,
            )
            .unwrap();
            (srdm, colours(w))
        })
        .collect()
}

/// Labelled rays for view `view`: (origin, direction, kind).
fn rays(srdm: &Srdm) -> Vec<(Vec3, Vec3, &'static str)> {
    let cam = srdm.camera();
    let centre = Vec3::new(0.0, 0.0, -2.0);
    let mut out = Vec::new();
    // From outside, through a grid of targets over the object.
    let mut rng = Rng::new(7, 0);
    for k in 0..12 {
        let a = k as f32 / 12.0 * std::f32::consts::TAU;
        let origin = centre + 2.5 * Vec3::new(a.cos() * 0.8, 0.4 * (a * 2.0).sin(), a.sin() * 0.8);
        for i in 0..9 {
            for j in 0..9 {
                let target = centre
                    + Vec3::new(
                        -0.8 + 0.2 * i as f32,
                        -0.8 + 0.2 * j as f32,
                        0.3 * (rng.uniform() - 0.5),
                    );
                out.push((origin, (target - origin).normalize(), "outside"));
            }
        }
    }
    // Along lines of sight of the capture camera (projections of a point or nearly).
    for i in 0..20 {
        for j in 0..20 {
            let ndc = Vec2::new(-0.9 + 0.09 * i as f32, -0.9 + 0.09 * j as f32);
            let d = cam.view.ray_direction(ndc, 1.0);
            let jitter = Vec3::new(1e-5 * (i as f32 - 10.0), 1e-5 * (j as f32 - 10.0), 0.0);
            out.push((cam.view.position, (d + jitter).normalize(), "grazing"));
        }
    }
    // Nearly parallel to the image plane, at several depths (long projections).
    for k in 0..200 {
        let z = -1.2 - 1.6 * (k as f32 / 200.0);
        let y = -0.7 + 1.4 * rng.uniform();
        let origin = Vec3::new(-3.0, y, z);
        let dir = Vec3::new(
            1.0,
            0.02 * (rng.uniform() - 0.5),
            0.02 * (rng.uniform() - 0.5),
        );
        out.push((origin, dir.normalize(), "grazing"));
    }
    // Starting inside the frustum, between hither and yon.
    for _ in 0..600 {
        let origin = centre
            + Vec3::new(
                0.9 * (rng.uniform() - 0.5),
                0.9 * (rng.uniform() - 0.5),
                1.6 * (rng.uniform() - 0.5),
            );
        let dir = Vec3::new(
            rng.uniform() - 0.5,
            rng.uniform() - 0.5,
            rng.uniform() - 0.5,
        )
        .normalize();
        out.push((origin, dir, "inside"));
    }
    out
}

#[test]
fn wgsl_srdm_intersection_agrees_with_the_cpu() {
    let gpu = gpu();
    let views = views();
    let sources: Vec<ViewSource<'_>> = views
        .iter()
        .map(|(s, c)| ViewSource {
            impostor: 0,
            srdm: s,
            colour: c,
        })
        .collect();
    let tables = SrdmTables::pack(&sources);
    let probe = SrdmProbe::new(&gpu, &tables).unwrap_or_else(|e| panic!("{e}"));
    let t_max = 10.0;
    for (vi, (srdm, colour)) in views.iter().enumerate() {
        let rays = rays(srdm);
        let batch: Vec<ProbeRay> = rays
            .iter()
            .map(|&(o, d, _)| ProbeRay::new(o, d, t_max, vi as u32))
            .collect();
        let hits = probe
            .intersect(&gpu, &batch)
            .unwrap_or_else(|e| panic!("{e}"));
        let (mut mismatch, mut both, mut same_row, mut worst_t) = (0usize, 0usize, 0usize, 0f32);
        let mut kinds: std::collections::BTreeMap<&str, (usize, usize)> = Default::default();
        let mut colour_checked = 0;
        for ((o, d, kind), g) in rays.iter().zip(&hits) {
            let cpu = srdm.intersect(*o, *d, t_max);
            let gpu_hit = g.found[0] == 1;
            let e = kinds.entry(kind).or_default();
            e.0 += 1;
            e.1 += usize::from(cpu.is_some());
            match cpu {
                Some(c) if gpu_hit => {
                    both += 1;
                    if (c.domain, c.row) == (g.found[1], g.found[2]) {
                        same_row += 1;
                        let rel = (g.t_pixel_depth[0] - c.t).abs() / c.t.max(1e-3);
                        worst_t = worst_t.max(rel);
                        let gp = Vec2::new(g.t_pixel_depth[1], g.t_pixel_depth[2]);
                        assert!(
                            (gp - c.pixel).abs().max_element() < 0.05,
                            "view {vi} {kind} ray {o} {d}: pixel {gp} vs CPU {}",
                            c.pixel
                        );
                        // The same texel unless the hit is within rounding of a texel edge.
                        let f = c.pixel.fract();
                        if f.min_element() > 1e-3 && f.max_element() < 1.0 - 1e-3 {
                            let want = colour_at(colour, srdm.resolution(), c.pixel);
                            let got = Vec3::from_slice(&g.colour[..3]);
                            assert!(
                                (want - got).abs().max_element() < 1e-6,
                                "view {vi} {kind}: colour {got} vs CPU {want}"
                            );
                            colour_checked += 1;
                        }
                    }
                }
                None if !gpu_hit => {}
                _ => mismatch += 1,
            }
        }
        let n = rays.len() as f64;
        eprintln!(
            "view {vi}: {} rays, {both} both hit, {mismatch} hit/miss mismatches, {same_row} same row, \
             worst relative t error {worst_t:e}, {colour_checked} colours checked; per kind (rays, CPU hits): {kinds:?}",
            rays.len()
        );
        assert!(
            mismatch as f64 <= MAX_HIT_MISMATCH * n,
            "view {vi}: {mismatch} of {n} rays hit on one side only"
        );
        assert!(
            same_row as f64 >= MIN_SAME_ROW * both as f64,
            "view {vi}: only {same_row} of {both} hits searched the same row"
        );
        assert!(
            worst_t <= T_TOLERANCE,
            "view {vi}: t differs by {worst_t:e} (relative)"
        );
        // Not vacuous: every kind of ray has hits, and misses are common too.
        for (kind, (count, cpu_hits)) in &kinds {
            assert!(
                *cpu_hits > 0,
                "view {vi}: no {kind} ray hits ({count} rays)"
            );
        }
        assert!(
            both as f64 > 0.1 * n && (both as f64) < 0.9 * n,
            "view {vi}: {both} of {n} rays hit; the grid should mix hits and misses"
        );
        assert!(
            colour_checked > 100,
            "only {colour_checked} colours checked"
        );
    }
}

/// Every `repr(C)` struct the impostor passes upload has its WGSL twin's layout (naga's
/// layouter: size and each member's offset).
#[test]
fn params_match_the_shader_layout() {
    use glint::assert_wgsl_layout;
    use glint::view::impostors::srdm_tables::GpuView;
    use glint::view::impostors::{
        IMPOSTOR_SHADER_SOURCE, ProbeHit, SRDM_PROBE_SHADER_SOURCE, SRDM_SHADER_SOURCE,
    };
    use glint::view::passes::renderer::SHADER_SOURCE;
    // ImpostorParams: three vec4 + 64 vec4 (WGSL uniform layout, 16-byte aligned).
    assert_eq!(std::mem::size_of::<ImpostorParams>(), (3 + 64) * 16);
    assert_eq!(std::mem::size_of::<GpuView>(), 6 * 16);
    // As the impostor pipeline builds its module.
    let impostors = format!("{SHADER_SOURCE}\n{SRDM_SHADER_SOURCE}\n{IMPOSTOR_SHADER_SOURCE}");
    assert_wgsl_layout!(
        impostors,
        "ImpostorParams",
        ImpostorParams {
            normal,
            eye,
            settings,
            modulation
        }
    );
    assert_wgsl_layout!(
        impostors,
        "SrdmView",
        GpuView {
            position,
            right,
            up,
            forward,
            shape,
            offsets
        }
    );
    // As the SRDM probe builds its module.
    let probe = format!("{SRDM_SHADER_SOURCE}\n{SRDM_PROBE_SHADER_SOURCE}");
    assert_wgsl_layout!(probe, "ProbeRay", ProbeRay { origin, dir });
    assert_wgsl_layout!(
        probe,
        "ProbeHit",
        ProbeHit {
            t_pixel_depth,
            found,
            colour
        }
    );
}

// ---------------------------------------------------------------------------------------------
// 2. bunny-mirror.

const SIZE: (u32, u32) = (200, 135);

/// bunny-mirror's scene, radiosity (reduced) and srdm (draft) stages.
fn bunny_bundle() -> &'static Path {
    static BUNDLE: OnceLock<PathBuf> = OnceLock::new();
    BUNDLE.get_or_init(|| {
        let settings = RadiositySettings {
            texel_density: 16.0,
            rays: 64,
            light_samples: 8,
            bounces: 4,
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
        };
        let srdm = SrdmSettings {
            domains: 30,
            points: 16,
            resolution: 128,
        };
        shipped_bundle(
            &Recipe::new("bunny-mirror")
                .then(Step::Scene)
                .then(Step::Radiosity(settings))
                // R (the mirror's directional albedo, its Fresnel) for the modulation.
                .then(Step::Materials(
                    glint::bake::materials::MaterialsSettings::preset(
                        glint::scene::desc::Quality::Draft,
                    ),
                ))
                .then(Step::Srdm(srdm)),
        )
    })
}

fn front_camera() -> Camera {
    Camera::look_at(
        Vec3::new(0.0, 0.25, 0.9),
        Vec3::new(0.0, 0.11, 0.0),
        Vec3::Y,
        35f32.to_radians(),
    )
}

/// Pixels whose view ray meets the mirror floor first and whose mirrored ray then meets the
/// bunny first: where the reflected bunny must be (CPU ray casting, pixel centres).
fn predicted_mask(scene: &Scene, bvh: &Bvh, camera: &Camera) -> Vec<bool> {
    let floor: std::collections::HashSet<u32> =
        scene.reflectors[0].triangles.iter().copied().collect();
    let bunny: std::collections::HashSet<u32> =
        srdm_stage::impostor_triangles(scene, &scene.impostors[0])
            .into_iter()
            .collect();
    let (w, h) = SIZE;
    let aspect = w as f32 / h as f32;
    (0..w * h)
        .map(|i| {
            let ndc = Camera::pixel_ndc(i % w, i / w, w, h);
            let d = camera.ray_direction(ndc, aspect);
            let Some(hit) = bvh.closest_hit(camera.position, d, f32::INFINITY) else {
                return false;
            };
            if !floor.contains(&hit.triangle) {
                return false;
            }
            let p = camera.position + hit.t * d;
            let n = scene.triangles[hit.triangle as usize].face_normal();
            let r = d - 2.0 * d.dot(n) * n;
            bvh.closest_hit(p + 1e-4 * r, r, f32::INFINITY)
                .is_some_and(|h2| bunny.contains(&h2.triangle))
        })
        .collect()
}

/// The frame's linear radiance with impostor reflections on or off.
fn frame(gpu: &Gpu, impostors: bool) -> Vec<Vec3> {
    frame_with(gpu, impostors, ReflectionMode::Off)
}

/// The frame with impostor reflections on or off and planar reflections in `mode`.
fn frame_with(gpu: &Gpu, impostors: bool, mode: ReflectionMode) -> Vec<Vec3> {
    let data = load(bunny_bundle()).unwrap_or_else(|e| panic!("{e}"));
    let mut off = Offscreen::new(gpu, &data, SIZE.0, SIZE.1).unwrap();
    off.set_impostors(gpu, &data, impostors)
        .unwrap_or_else(|e| panic!("{e}"));
    off.set_reflections(gpu, &data, mode)
        .unwrap_or_else(|e| panic!("{e}"));
    off.render(gpu, &front_camera()).unwrap();
    off.read_hdr(gpu).unwrap()
}

/// Writes a linear image as a tone-mapped PNG into `target/tmp/view-impostors-tests/` (for
/// inspection).
fn dump(name: &str, rgb: &[Vec3]) {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("view-impostors-tests");
    let _ = std::fs::create_dir_all(&dir);
    let bytes = glint::image_io::tonemap_preview(rgb);
    let png = glint::image_io::encode_png(SIZE.0, SIZE.1, &bytes, false).unwrap();
    std::fs::write(dir.join(format!("{name}.png")), png).unwrap();
}

/// The pixels the impostor pass changed (luminance up by more than `threshold`).
fn changed(on: &[Vec3], off: &[Vec3], threshold: f32) -> Vec<bool> {
    on.iter()
        .zip(off)
        .map(|(a, b)| luminance(*a) - luminance(*b) > threshold)
        .collect()
}

/// Smallest intersection-over-union of the reflected bunny's pixels with the predicted ones.
/// Below 1 because the impostor is a draft capture (128², m = 16: silhouette rows are
/// simplified) seen from another viewpoint than the one it was captured from, and the mask is
/// taken at pixel centres on both sides.
const MIN_IOU: f64 = 0.8;

#[test]
fn reflected_bunny_appears_where_the_mirrored_geometry_predicts() {
    let gpu = gpu();
    let scene = Scene::load(repo("scenes/bunny-mirror/scene.json")).unwrap();
    let bvh = Bvh::build(&scene.triangles);
    let predicted = predicted_mask(&scene, &bvh, &front_camera());
    let (on, off) = (frame(&gpu, true), frame(&gpu, false));
    let seen = changed(&on, &off, 1e-3);
    let inter = predicted
        .iter()
        .zip(&seen)
        .filter(|(a, b)| **a && **b)
        .count();
    let union = predicted
        .iter()
        .zip(&seen)
        .filter(|(a, b)| **a || **b)
        .count();
    let iou = inter as f64 / union.max(1) as f64;
    let count = predicted.iter().filter(|p| **p).count();
    eprintln!(
        "reflected bunny: {count} predicted pixels, {} drawn, IoU {iou:.3}",
        seen.iter().filter(|p| **p).count()
    );
    assert!(
        count > 200,
        "the view should show the reflection ({count} px)"
    );
    assert!(iou >= MIN_IOU, "IoU {iou:.3} < {MIN_IOU}");
}

/// Largest relative difference of the mean luminance over the reflected bunny (the interior of
/// the predicted mask) between the viewer with impostor reflections and the reference path
/// tracer. Measured 62% on lavapipe (viewer darker; 45% before the glTF mirror mapped to a
/// GGX lobe, whose albedo F, not Kurt's F cos θ, throws more light onto the bunny's underside in
/// the reference, a term D lacks, see below). The pass is not what limits it: the same
/// region drawn from the mirrored geometry with the same D and R (the planar reflections'
/// geometry mode) differs from the reference just as much (see [`GEOMETRY_TOLERANCE`]). What
/// does is what the viewer's equation leaves out: D is the diffuse radiosity only (the bunny
/// seen directly is 26% darker than in the reference, its glossy lobe and the light the mirror
/// throws onto its underside are missing), and ks·R from the draft materials stage.
const REFERENCE_TOLERANCE: f64 = 0.7;

/// Largest relative difference of the same mean between impostor reflections and the mirrored
/// geometry (same D, same ks·R): the impostor's own error (a 128² draft capture from one view
/// above the mirror, nearest-texel colour, m = 16). Measured 3%.
const GEOMETRY_TOLERANCE: f64 = 0.1;

#[test]
fn golden_bunny_mirror_against_the_reference_path_tracer() {
    let gpu = gpu();
    let scene = Scene::load(repo("scenes/bunny-mirror/scene.json")).unwrap();
    let bvh = Bvh::build(&scene.triangles);
    let camera = front_camera();
    let predicted = predicted_mask(&scene, &bvh, &camera);
    // The mask's interior: a pixel and its 4 neighbours predicted (edges mix surfaces).
    let (w, h) = (SIZE.0 as usize, SIZE.1 as usize);
    let mask: Vec<bool> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            x > 0
                && y > 0
                && x + 1 < w
                && y + 1 < h
                && [i, i - 1, i + 1, i - w, i + w]
                    .iter()
                    .all(|&k| predicted[k])
        })
        .collect();
    let reference = render(
        &scene,
        &bvh,
        &camera,
        &RenderOptions {
            width: SIZE.0,
            height: SIZE.1,
            spp: 16,
            ..Default::default()
        },
        &Silent,
    )
    .unwrap();
    let (on, off) = (frame(&gpu, true), frame(&gpu, false));
    let mean = |img: &[Vec3]| {
        let (s, n) = img
            .iter()
            .zip(&mask)
            .filter(|(_, m)| **m)
            .fold((0.0f64, 0usize), |(s, n), (c, _)| {
                (s + luminance(*c) as f64, n + 1)
            });
        (s / n.max(1) as f64, n)
    };
    dump("reference", &reference.image.rgb);
    dump("impostors-on", &on);
    dump("impostors-off", &off);
    // For the record: the bunny seen directly, D against the path tracer.
    let bunny: std::collections::HashSet<u32> =
        srdm_stage::impostor_triangles(&scene, &scene.impostors[0])
            .into_iter()
            .collect();
    let direct: Vec<bool> = (0..w * h)
        .map(|i| {
            let ndc = Camera::pixel_ndc((i % w) as u32, (i / w) as u32, SIZE.0, SIZE.1);
            let d = camera.ray_direction(ndc, SIZE.0 as f32 / SIZE.1 as f32);
            bvh.closest_hit(camera.position, d, f32::INFINITY)
                .is_some_and(|hit| bunny.contains(&hit.triangle))
        })
        .collect();
    let direct_mean = |img: &[Vec3]| {
        let v: Vec<f64> = img
            .iter()
            .zip(&direct)
            .filter(|(_, m)| **m)
            .map(|(c, _)| luminance(*c) as f64)
            .collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    eprintln!(
        "bunny seen directly: reference {:.4}, viewer D {:.4}",
        direct_mean(&reference.image.rgb),
        direct_mean(&off)
    );
    let geometry = frame_with(&gpu, false, ReflectionMode::Geometry);
    dump("geometry", &geometry);
    let (g, _) = mean(&geometry);
    let (r, n) = mean(&reference.image.rgb);
    let (a, _) = mean(&on);
    let (b, _) = mean(&off);
    let err_on = (a - r).abs() / r;
    let err_off = (b - r).abs() / r;
    let err_geometry = (a - g).abs() / g;
    eprintln!(
        "bunny reflection, {n} px: reference {r:.4}, impostors on {a:.4} ({:.1}%), off {b:.4} ({:.1}%), \
         mirrored geometry {g:.4} ({:.1}% off the reference; impostors {:.1}% off it)",
        100.0 * err_on,
        100.0 * err_off,
        100.0 * (g - r).abs() / r,
        100.0 * err_geometry
    );
    assert!(n > 100, "mask too small ({n} px)");
    assert!(
        err_on <= REFERENCE_TOLERANCE,
        "impostor reflection is {:.1}% off the reference",
        100.0 * err_on
    );
    assert!(
        err_geometry <= GEOMETRY_TOLERANCE,
        "impostor reflection is {:.1}% off the mirrored geometry",
        100.0 * err_geometry
    );
    assert!(
        err_off > 0.9,
        "without impostors the region is only {:.1}% off: the test would not notice a missing reflection",
        100.0 * err_off
    );
}
