//! Reflections of impostors (Popescu et al. 2006 §4–5): frame time against m (points per SRDM
//! row: 6, 8, 12, 16, the SRDM re-built from the baked capture for each) and against the
//! number of reflectors (bunny-mirror's floor, plus its walls and ceiling drawn as extra
//! mirrors: 1, 2, 4, 6), at 720×486, each with the image error against the reference path tracer.
//!
//! `cargo bench --bench impostors` (release). Bakes bunny-mirror (scene, radiosity, materials
//! at draft, srdm at the default preset: 256², n = 60) into `target/bench-impostors/` once,
//! path-traces the reference once (cached as EXR next to it), then renders the `front` view
//! `FRAMES` times per configuration and prints a table. Errors are over two masks:
//! `mirror` (every pixel whose view ray meets the mirror floor first) and `bunny` (the pixels
//! whose mirrored ray then meets the bunny first, where impostor reflections are drawn).
//! Billboard rows (§3, `--impostor-kind billboard`): the same view with one billboard per
//! impostor object and reflector, against the billboard resolution (64, 128, 256) and the
//! number of reflectors (1, 2, 4, 6: as many billboards); the column `bb` counts them.
//! Environment variables: `GLINT_BENCH_FRAMES` (default 30), `GLINT_BENCH_SPP` (reference,
//! default 16).

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use glam::Vec3;
use glint::bake::srdm_stage::{self, SrdmSettings};
use glint::bake::{materials, radiosity_stage, scene_stage};
use glint::bundle::Bundle;
use glint::camera::Camera;
use glint::eval::Image;
use glint::eval::compare::compare;
use glint::eval::reference::{RenderOptions, render};
use glint::geometry::Bvh;
use glint::progress::Silent;
use glint::scene::Scene;
use glint::scene::desc::{Quality, RadiositySettings};
use glint::srdm::{Srdm, SrdmParams};
use glint::view::gpu::Gpu;
use glint::view::headless::Offscreen;
use glint::view::impostors::srdm_tables::{
    ImpostorReflector, SrdmTables, ViewSource, impostor_reflectors,
};
use glint::view::impostors::{ImpostorReflections, ImpostorSettings, build_billboards};
use glint::view::load::{ViewData, load};
use glint::view::reflections::{MODULATION_SIZE, ReflectionMode, reflectors_with_reflectance};

mod common;
use common::{gpu, repo};

const SIZE: (u32, u32) = (720, 486);
const M_VALUES: [u32; 4] = [6, 8, 12, 16];
const REFLECTOR_COUNTS: [usize; 4] = [1, 2, 4, 6];
const BILLBOARD_RESOLUTIONS: [u32; 3] = [64, 128, 256];

fn env_usize(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn bundle_dir() -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo("target"));
    target.join("bench-impostors").join("bunny-mirror.glint")
}

/// Bakes the bundle unless it already has the four stages from this scene.
fn bake_if_needed(scene: &Scene, bundle: &Path) {
    let fresh = Bundle::open(bundle).is_ok_and(|b| {
        ["scene", "radiosity", "materials", "srdm"].iter().all(|s| {
            b.stage(s)
                .is_some_and(|r| r.scene_hash == scene.content_hash)
        })
    });
    if fresh {
        return;
    }
    eprintln!("baking {} …", bundle.display());
    let _ = std::fs::remove_dir_all(bundle);
    scene_stage::bake(scene, bundle, false).unwrap_or_else(|e| panic!("{e}"));
    let settings = RadiositySettings {
        texel_density: 32.0,
        rays: 128,
        light_samples: 16,
        bounces: 6,
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
    radiosity_stage::bake(scene, bundle, &settings, false, &Silent)
        .unwrap_or_else(|e| panic!("{e}"));
    materials::bake(
        scene,
        bundle,
        &materials::MaterialsSettings::preset(Quality::Draft),
        false,
        &Silent,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    srdm_stage::bake(
        scene,
        bundle,
        &SrdmSettings::preset(Quality::Default),
        false,
        &Silent,
    )
    .unwrap_or_else(|e| panic!("{e}"));
}

fn front_camera() -> Camera {
    Camera::look_at(
        Vec3::new(0.0, 0.25, 0.9),
        Vec3::new(0.0, 0.11, 0.0),
        Vec3::Y,
        35f32.to_radians(),
    )
}

/// The reference image, path-traced once and cached.
fn reference(scene: &Scene, bvh: &Bvh, spp: u32) -> Image {
    let path = bundle_dir().with_file_name(format!("reference-{spp}spp.exr"));
    if let Ok(bytes) = std::fs::read(&path)
        && let Ok(img) = Image::from_exr(&bytes)
        && (img.width, img.height) == (SIZE.0 as usize, SIZE.1 as usize)
    {
        return img;
    }
    eprintln!("path-tracing the reference ({spp} spp) …");
    let img = render(
        scene,
        bvh,
        &front_camera(),
        &RenderOptions {
            width: SIZE.0,
            height: SIZE.1,
            spp,
            ..Default::default()
        },
        &Silent,
    )
    .unwrap()
    .image;
    std::fs::write(&path, img.to_exr().unwrap()).unwrap();
    img
}

/// (mirror, bunny) masks: see the module docs.
fn masks(scene: &Scene, bvh: &Bvh) -> (Vec<bool>, Vec<bool>) {
    let floor: HashSet<u32> = scene.reflectors[0].triangles.iter().copied().collect();
    let bunny: HashSet<u32> = srdm_stage::impostor_triangles(scene, &scene.impostors[0])
        .into_iter()
        .collect();
    let camera = front_camera();
    let (w, h) = SIZE;
    let aspect = w as f32 / h as f32;
    (0..w * h)
        .map(|i| {
            let d = camera.ray_direction(Camera::pixel_ndc(i % w, i / w, w, h), aspect);
            let Some(hit) = bvh.closest_hit(camera.position, d, f32::INFINITY) else {
                return (false, false);
            };
            if !floor.contains(&hit.triangle) {
                return (false, false);
            }
            let n = scene.triangles[hit.triangle as usize].face_normal();
            let r = d - 2.0 * d.dot(n) * n;
            let p = camera.position + hit.t * d + 1e-4 * r;
            let on_bunny = bvh
                .closest_hit(p, r, f32::INFINITY)
                .is_some_and(|h2| bunny.contains(&h2.triangle));
            (true, on_bunny)
        })
        .unzip()
}

struct Row {
    label: String,
    billboards: Option<usize>,
    frame_ms: f64,
    best_ms: f64,
    mirror_rmse: f64,
    bunny_rmse: f64,
    bunny_rel: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Renders `FRAMES` frames and measures the last against the reference.
fn measure(
    gpu: &Gpu,
    off: &Offscreen,
    label: String,
    frames: usize,
    reference: &Image,
    (mirror, bunny): (&[bool], &[bool]),
) -> Row {
    let camera = front_camera();
    off.render(gpu, &camera).unwrap(); // warm-up
    let times: Vec<f64> = (0..frames)
        .map(|_| off.render(gpu, &camera).unwrap().frame_ms)
        .collect();
    let best = times.iter().copied().fold(f64::INFINITY, f64::min);
    let img = Image {
        width: SIZE.0 as usize,
        height: SIZE.1 as usize,
        rgb: off.read_hdr(gpu).unwrap(),
    };
    let m = compare(&img, reference, Some(mirror)).unwrap();
    let b = compare(&img, reference, Some(bunny)).unwrap();
    Row {
        label,
        billboards: None,
        frame_ms: median(times),
        best_ms: best,
        mirror_rmse: m.rmse,
        bunny_rmse: b.rmse,
        bunny_rel: b.rel_rmse,
    }
}

/// The walls and the ceiling of bunny-mirror drawn as extra mirrors (ks = 0.5), for the cost
/// per reflector. They are not mirrors in the scene, so their pixels are outside both masks
/// and the errors stay those of the floor.
fn extra_mirrors(scene: &Scene) -> Vec<ImpostorReflector> {
    ["WallN", "WallE", "WallW", "WallS", "Ceiling"]
        .iter()
        .filter_map(|name| {
            let o = scene.objects.iter().find(|o| o.is_named(name))?;
            let triangles: Vec<u32> = o.triangles.clone().collect();
            let normal = scene.triangles[*triangles.first()? as usize].face_normal();
            Some(ImpostorReflector {
                name: name.to_string(),
                triangles,
                normal: Some(normal),
                modulation: vec![Vec3::splat(0.5); MODULATION_SIZE],
            })
        })
        .collect()
}

/// The SRDM of every baked view re-built with `m` points per row.
fn tables_with_m(data: &ViewData, m: u32) -> SrdmTables {
    let (index, views) = glint::srdm::index::load(&data.bundle).unwrap().unwrap();
    let rebuilt: Vec<Srdm> = views
        .iter()
        .map(|v| {
            Srdm::build(
                &v.capture.depth,
                *v.srdm.camera(),
                SrdmParams {
                    domains: index.settings.domains,
                    points: m,
                },
                &Silent,
            )
            .unwrap()
        })
        .collect();
    let mut names: Vec<&str> = Vec::new();
    let sources: Vec<ViewSource<'_>> = views
        .iter()
        .zip(&rebuilt)
        .map(|(v, s)| {
            let k = names
                .iter()
                .position(|n| *n == v.entry.impostor)
                .unwrap_or_else(|| {
                    names.push(&v.entry.impostor);
                    names.len() - 1
                });
            ViewSource {
                impostor: k as u32,
                srdm: s,
                colour: &v.capture.colour,
            }
        })
        .collect();
    SrdmTables::pack(&sources)
}

fn main() {
    // `cargo bench` passes `--bench`; a plain `cargo test --benches` run passes nothing and
    // only checks that it builds and starts.
    if !std::env::args().any(|a| a == "--bench") {
        eprintln!("impostors bench: run with `cargo bench --bench impostors`");
        return;
    }
    let frames = env_usize("GLINT_BENCH_FRAMES", 30);
    let spp = env_usize("GLINT_BENCH_SPP", 16) as u32;
    let scene = Scene::load(repo("scenes/bunny-mirror/scene.json")).unwrap();
    let bundle = bundle_dir();
    bake_if_needed(&scene, &bundle);
    let bvh = Bvh::build(&scene.triangles);
    let reference = reference(&scene, &bvh, spp);
    let (mirror, bunny) = masks(&scene, &bvh);
    let masks = (&mirror[..], &bunny[..]);
    let data = load(&bundle).unwrap();
    let gpu = gpu();
    let mut off = Offscreen::new(&gpu, &data, SIZE.0, SIZE.1).unwrap();
    let reflectors = impostor_reflectors(&data.scene, &reflectors_with_reflectance(&data));
    let settings = ImpostorSettings::default();

    let mut rows = Vec::new();
    rows.push(measure(
        &gpu,
        &off,
        "impostors off (D only)".into(),
        frames,
        &reference,
        masks,
    ));
    off.set_reflections(&gpu, &data, ReflectionMode::Geometry)
        .unwrap();
    rows.push(measure(
        &gpu,
        &off,
        "planar geometry (mirrored scene)".into(),
        frames,
        &reference,
        masks,
    ));
    off.set_reflections(&gpu, &data, ReflectionMode::Off)
        .unwrap();
    for m in M_VALUES {
        let tables = tables_with_m(&data, m);
        let pass = ImpostorReflections::with(
            &gpu,
            off.renderer(),
            &data,
            &tables,
            reflectors.clone(),
            settings,
        )
        .unwrap();
        off.set_impostor_pass(Some(pass));
        rows.push(measure(
            &gpu,
            &off,
            format!("impostors m = {m:>2}, 1 reflector"),
            frames,
            &reference,
            masks,
        ));
    }
    let tables = tables_with_m(&data, 16);
    for k in REFLECTOR_COUNTS.iter().skip(1) {
        let mut more = reflectors.clone();
        more.extend(extra_mirrors(&data.scene).into_iter().take(k - 1));
        let count = more.len();
        let pass = ImpostorReflections::with(&gpu, off.renderer(), &data, &tables, more, settings)
            .unwrap();
        off.set_impostor_pass(Some(pass));
        rows.push(measure(
            &gpu,
            &off,
            format!("impostors m = 16, {count} reflectors"),
            frames,
            &reference,
            masks,
        ));
    }

    // §3: billboards instead of depth maps.
    for res in BILLBOARD_RESOLUTIONS {
        let tables = build_billboards(&data, &reflectors, res).unwrap();
        let count = tables.billboards.len();
        let pass = ImpostorReflections::with_billboards(
            &gpu,
            off.renderer(),
            &data,
            &tables,
            reflectors.clone(),
            settings,
        )
        .unwrap();
        off.set_impostor_pass(Some(pass));
        let mut row = measure(
            &gpu,
            &off,
            format!("billboards {res}², 1 reflector"),
            frames,
            &reference,
            masks,
        );
        row.billboards = Some(count);
        rows.push(row);
    }
    for k in REFLECTOR_COUNTS.iter().skip(1) {
        let mut more = reflectors.clone();
        more.extend(extra_mirrors(&data.scene).into_iter().take(k - 1));
        let n = more.len();
        let tables = build_billboards(&data, &more, 128).unwrap();
        let count = tables.billboards.len();
        let pass = ImpostorReflections::with_billboards(
            &gpu,
            off.renderer(),
            &data,
            &tables,
            more,
            settings,
        )
        .unwrap();
        off.set_impostor_pass(Some(pass));
        let mut row = measure(
            &gpu,
            &off,
            format!("billboards 128², {n} reflectors"),
            frames,
            &reference,
            masks,
        );
        row.billboards = Some(count);
        rows.push(row);
    }

    let (index, _) = glint::srdm::index::load(&data.bundle).unwrap().unwrap();
    println!(
        "\nbunny-mirror, front view, {}×{}, {} ({frames} frames, median); SRDM n = {}, w = {}; reference {spp} spp",
        SIZE.0,
        SIZE.1,
        gpu.adapter_summary(),
        index.settings.domains,
        index.settings.resolution
    );
    println!(
        "masks: mirror {} px, reflected bunny {} px; RMSE of linear radiance against the reference",
        mirror.iter().filter(|m| **m).count(),
        bunny.iter().filter(|m| **m).count()
    );
    println!(
        "{:<34} {:>3} {:>10} {:>8} {:>12} {:>12} {:>13}",
        "configuration", "bb", "median ms", "min ms", "mirror RMSE", "bunny RMSE", "bunny relRMSE"
    );
    for r in &rows {
        println!(
            "{:<34} {:>3} {:>10.2} {:>8.2} {:>12.4} {:>12.4} {:>13.3}",
            r.label,
            r.billboards.map_or("-".to_string(), |n| n.to_string()),
            r.frame_ms,
            r.best_ms,
            r.mirror_rmse,
            r.bunny_rmse,
            r.bunny_rel
        );
    }
}
