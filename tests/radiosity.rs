//! Radiosity against exact answers: the white furnace, the analytic form factor of a
//! parallel square, scale invariance, determinism across thread counts, geometry piercing a
//! chart, cancellation and bad input.

mod common;

use std::path::Path;

use common::*;
use glam::{Vec2, Vec3};
use glint::bake::radiosity_stage::{self, RadiosityError};
use glint::progress::{Progress, Silent};
use glint::radiosity::atlas;
use glint::radiosity::solve::{Solution, SolveSettings, solve};
use glint::scene::Scene;
use glint::scene::desc::RadiositySettings;

fn emissive(name: &'static str, albedo: f32, e: f32) -> MaterialSpec {
    MaterialSpec {
        emissive: [1.0; 3],
        strength: e,
        ..MaterialSpec::diffuse(name, albedo)
    }
}

fn load(dir: &Path, meshes: &[MeshSpec], materials: &[MaterialSpec]) -> Scene {
    write_gltf(dir, "s", meshes, materials);
    Scene::load(write_scene(
        dir,
        r#"{ "version": 1, "geometry": "s.gltf" }"#,
    ))
    .unwrap()
}

fn run(
    scene: &Scene,
    density: f32,
    rays: u32,
    light_samples: u32,
    bounces: u32,
) -> (atlas::Atlas, Solution) {
    let (atlas, samples) = atlas::build(&scene.triangles, density).unwrap();
    let bvh = scene.build_bvh();
    let set = SolveSettings {
        rays,
        light_samples,
        bounces,
        glossy_depth: 0,
        target_error: None,
        tolerance: 1e-7,
        seed: 1,
        cache_budget: glint::radiosity::solve::CACHE_BUDGET,
    };
    let sol = solve(scene, &bvh, &atlas, &samples, &set, &Silent).unwrap();
    (atlas, sol)
}

/// Exitant radiance at a point of a triangle, read from the texel holding it.
fn at(scene: &Scene, atlas: &atlas::Atlas, sol: &Solution, p: Vec3) -> Vec3 {
    let offsets = atlas.page_offsets();
    for (i, t) in scene.triangles.iter().enumerate() {
        let (d, b) = atlas::closest_point(
            [
                Vec2::new(0.0, 0.0),
                Vec2::new(1.0, 0.0),
                Vec2::new(0.0, 1.0),
            ],
            bary_of(t.p, p),
        );
        if d == 0.0 && (t.point(b) - p).length() < 1e-4 * (t.p[1] - t.p[0]).length() {
            return sol.radiance[atlas.texel_at(&offsets, i as u32, b) as usize];
        }
    }
    panic!("{p} lies on no triangle")
}

/// Barycentrics of p in the triangle's plane, as a point of the unit triangle.
fn bary_of(t: [Vec3; 3], p: Vec3) -> Vec2 {
    let (e1, e2, d) = (t[1] - t[0], t[2] - t[0], p - t[0]);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d1, d2) = (d.dot(e1), d.dot(e2));
    let den = d11 * d22 - d12 * d12;
    Vec2::new((d22 * d1 - d12 * d2) / den, (d11 * d2 - d12 * d1) / den)
}

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

#[test]
fn white_furnace_converges_to_e_over_one_minus_rho() {
    for rho in [0.0f32, 0.5, 0.95] {
        let dir = tempfile::tempdir().unwrap();
        let scene = load(dir.path(), &closed_box(0.5), &[emissive("walls", rho, 1.0)]);
        let (_, sol) = run(&scene, 6.0, 256, 64, 400);
        let expected = 1.0 / (1.0 - rho);
        let values: Vec<f32> = sol
            .radiance
            .iter()
            .filter(|v| v.x > 0.0)
            .map(|v| v.x)
            .collect();
        assert!(!values.is_empty());
        let mean = values.iter().sum::<f32>() / values.len() as f32;
        let worst = values
            .iter()
            .map(|v| (v / expected - 1.0).abs())
            .fold(0.0f32, f32::max);
        assert!(
            (mean / expected - 1.0).abs() < 0.01,
            "rho {rho}: mean {mean}, expected {expected}"
        );
        assert!(
            worst < 0.01,
            "rho {rho}: worst texel off by {:.2}% (expected {expected})",
            worst * 100.0
        );
        assert_eq!(
            sol.stats.excluded, 0,
            "a closed box has no texel inside geometry"
        );
    }
}

/// Form factor from a differential area to a parallel a × b rectangle at distance c, the
/// element below one corner (Howell's catalogue, configuration B-3).
fn ff_corner(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
}

/// Form factor from a point at (px, pz) below a square [−s, s]² at height c.
fn ff_square(s: f64, c: f64, px: f64, pz: f64) -> f64 {
    // Sum of the four rectangles that meet above the point.
    [
        (s - px, s - pz),
        (s + px, s - pz),
        (s - px, s + pz),
        (s + px, s + pz),
    ]
    .iter()
    .map(|&(a, b)| ff_corner(a, b, c))
    .sum()
}

/// A receiver (albedo ρ, facing up at y = 0) under an emitter square (radiance L, facing
/// down at height c, black). Returns (scene, s, c).
fn parallel_squares(dir: &Path, scale: f32, s: f32, c: f32) -> Scene {
    let receiver = quad("Receiver", 0, 1, 0.0, 1.0 * scale);
    let emitter = flip(quad("Emitter", 1, 1, c * scale, s * scale));
    load(
        dir,
        &[receiver, emitter],
        &[
            MaterialSpec::diffuse("grey", 0.5),
            emissive("lamp", 0.0, 2.0),
        ],
    )
}

#[test]
fn parallel_square_matches_the_analytic_form_factor() {
    let dir = tempfile::tempdir().unwrap();
    let (s, c) = (0.5f64, 0.5f64);
    let scene = parallel_squares(dir.path(), 1.0, s as f32, c as f32);
    let (atlas, sol) = run(&scene, 16.0, 1024, 256, 1);
    for (px, pz) in [(0.0, 0.0), (0.3, -0.2), (-0.7, 0.6)] {
        // The receiver runs from texel centre to texel centre: centres are at −1 + i/16.
        // Evaluate the formula where the texel samples.
        let snap = |v: f64| (v * 16.0).round() / 16.0;
        let (px, pz) = (snap(px), snap(pz));
        let got = at(&scene, &atlas, &sol, Vec3::new(px as f32, 0.0, pz as f32)).x as f64;
        // L_r = ρ L F (the receiver emits nothing).
        let want = 0.5 * 2.0 * ff_square(s, c, px, pz);
        assert!(
            (got / want - 1.0).abs() < 0.02,
            "at ({px}, {pz}): {got} vs analytic {want}"
        );
    }
}

#[test]
fn tiny_and_huge_scenes_give_the_same_answer_up_to_scale() {
    let mut results = Vec::new();
    for scale in [1e-3f32, 1.0, 1e3] {
        let dir = tempfile::tempdir().unwrap();
        let scene = parallel_squares(dir.path(), scale, 0.5, 0.5);
        let (_, sol) = run(&scene, 16.0 / scale, 128, 32, 2);
        results.push(sol.radiance);
    }
    for r in &results[1..] {
        assert_eq!(r.len(), results[0].len());
        for (a, b) in r.iter().zip(&results[0]) {
            assert!(
                (*a - *b).abs().max_element() <= 0.02 * b.max_element().max(1e-3),
                "{a} vs {b}"
            );
        }
    }
}

#[test]
fn a_box_piercing_the_floor_neither_leaks_nor_darkens() {
    let dir = tempfile::tempdir().unwrap();
    // Floor 2 × 2 m; a 0.5 m closed box standing through it (from y = −0.25 to 0.25).
    let mut meshes = vec![
        quad("Floor", 0, 1, 0.0, 1.0),
        flip(quad("Lamp", 1, 1, 2.0, 1.0)),
    ];
    let cube = closed_box(0.25).into_iter().map(flip); // outward faces
    meshes.extend(cube.map(|mut m| {
        m.material = 0;
        m
    }));
    let scene = load(
        dir.path(),
        &meshes,
        &[
            MaterialSpec::diffuse("white", 0.5),
            emissive("lamp", 0.0, 1.0),
        ],
    );
    let (atlas, sol) = run(&scene, 16.0, 256, 64, 3);
    // The 8 × 8 floor texels under the box are inside geometry.
    assert!(sol.stats.excluded >= 64, "excluded {}", sol.stats.excluded);
    // Under the box, the floor shows its neighbours' light, not black.
    let under = at(&scene, &atlas, &sol, Vec3::new(0.03, 0.0, 0.03));
    let beside = at(&scene, &atlas, &sol, Vec3::new(0.3, 0.0, 0.03));
    assert!(under.x > 0.5 * beside.x, "under {under} vs beside {beside}");
}

#[test]
fn a_wall_behind_a_one_sided_panel_is_in_its_shadow_up_to_the_rim() {
    // A closed 2 m room, a lamp under its ceiling, and a one-sided 1 × 1 m panel 3 cm in
    // front of the wall x = −1, facing the room. The wall behind the panel sees the panel's
    // back over most of its hemisphere; near the rim it also sees the room through the gap,
    // so it is not inside anything: its own, dark, light must show, not the lit wall's beside
    // the panel (which drew a lit strip along glossy-room's mirror panel).
    let dir = tempfile::tempdir().unwrap();
    let mut meshes = closed_box(1.0);
    meshes.push(flip(quad("Lamp", 1, 1, 0.98, 0.3)));
    meshes.push(quad("Panel", 0, 0, -0.97, 0.5));
    let scene = load(
        dir.path(),
        &meshes,
        &[
            MaterialSpec::diffuse("white", 0.5),
            emissive("lamp", 0.0, 4.0),
        ],
    );
    let (atlas, sol) = run(&scene, 32.0, 64, 16, 1);
    let open = at(&scene, &atlas, &sol, Vec3::new(-1.0, 0.0, 0.8));
    // 3 cm behind the rim (the texel holding it lies 0–3 cm behind) and deep behind.
    let rim = at(&scene, &atlas, &sol, Vec3::new(-1.0, 0.0, 0.47));
    let deep = at(&scene, &atlas, &sol, Vec3::new(-1.0, 0.0, 0.0));
    assert!(open.x > 0.02, "the open wall is lit: {open}");
    assert!(
        rim.x < 0.35 * open.x,
        "behind the rim {rim} vs the open wall {open}"
    );
    assert!(
        deep.x < 0.35 * open.x,
        "deep behind {deep} vs the open wall {open}"
    );
}

/// Runs `f` on a rayon pool of `threads` threads.
fn with_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

#[test]
fn bakes_are_byte_identical_whatever_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let scene = parallel_squares(dir.path(), 1.0, 0.5, 0.5);
    let plain = RadiositySettings {
        rays: 64,
        light_samples: 8,
        bounces: 3,
        ..small_settings()
    };
    // Refined to a target the first batch misses: the rounds pack their rays into the links
    // in parallel and their first bounces read sums the estimate took.
    let refined = RadiositySettings {
        rays: 16,
        target_error: Some(0.01),
        tolerance: 1e-4,
        bounces: 8,
        ..plain
    };
    let mut rounds = Vec::new();
    let bundles: Vec<_> = [(1, &plain), (2, &plain), (3, &plain)]
        .into_iter()
        .chain([(1, &refined), (2, &refined), (3, &refined)])
        .enumerate()
        .map(|(k, (n, settings))| {
            let out = dir.path().join(format!("t{k}.glint"));
            let record = with_threads(n, || {
                radiosity_stage::bake(&scene, &out, settings, false, &Silent).unwrap()
            });
            rounds.push(record.stats["refine_rounds"].as_u64().unwrap());
            out
        })
        .collect();
    assert_eq!(rounds[0], 0);
    assert!(rounds[3] >= 1, "the refined bake ran no round");
    let read = |b: &std::path::Path, file: &str| {
        glint::bundle::Bundle::open(b)
            .unwrap()
            .read_stage_file("radiosity", file)
            .unwrap()
    };
    for group in bundles.chunks(3) {
        for file in ["page0.exr", "atlas.bin", "page0.png"] {
            let first = read(&group[0], file);
            for b in &group[1..] {
                assert!(
                    first == read(b, file),
                    "{file} differs between thread counts"
                );
            }
        }
    }
}

struct CancelAfter(std::sync::atomic::AtomicU64);

impl Progress for CancelAfter {
    fn phase(&self, _: &str, _: u64) {}
    fn advance(&self, n: u64) {
        self.0.fetch_add(n, std::sync::atomic::Ordering::SeqCst);
    }
    fn cancelled(&self) -> bool {
        self.0.load(std::sync::atomic::Ordering::SeqCst) > 0
    }
}

/// Cheap settings on a plain atlas (no raised charts, contacts or seams, no element limit).
fn small_settings() -> RadiositySettings {
    RadiositySettings {
        texel_density: 8.0,
        min_chart_texels: 0,
        min_scene_texels: 0,
        contact_boost: 0.0,
        texels_per_radian: 0.0,
        rays: 16,
        light_samples: 4,
        bounces: 2,
        tolerance: 0.0,
        glossy_depth: 0,
        target_error: None,
        stitch_seams: false,
        cache_budget_mib: 2048,
        max_elements: 0,
    }
}

#[test]
fn cancelling_leaves_the_bundle_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let scene = parallel_squares(dir.path(), 1.0, 0.5, 0.5);
    let out = dir.path().join("c.glint");
    let settings = small_settings();
    radiosity_stage::bake(&scene, &out, &settings, false, &Silent).unwrap();
    let manifest = std::fs::read(out.join("manifest.json")).unwrap();
    let read_page = || {
        glint::bundle::Bundle::open(&out)
            .unwrap()
            .read_stage_file("radiosity", "page0.exr")
            .unwrap()
    };
    let page = read_page();
    let denser = RadiositySettings {
        texel_density: 32.0,
        ..settings
    };
    let e =
        radiosity_stage::bake(&scene, &out, &denser, false, &CancelAfter(0.into())).unwrap_err();
    assert!(matches!(e, RadiosityError::Cancelled(_)), "{e}");
    assert_eq!(std::fs::read(out.join("manifest.json")).unwrap(), manifest);
    assert_eq!(read_page(), page);
    let names: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(
        names.iter().all(|n| !n.to_string_lossy().contains("tmp")),
        "{names:?}"
    );
}

#[test]
fn no_emitters_and_impossible_sizes_are_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(
        dir.path(),
        &[quad("Floor", 0, 1, 0.0, 1.0)],
        &[MaterialSpec::diffuse("grey", 0.5)],
    );
    let s = RadiositySettings::preset(glint::scene::Quality::Draft);
    let e = radiosity_stage::check(&scene, &s).unwrap_err().to_string();
    assert!(e.contains("scene.json") && e.contains("no emitters"), "{e}");

    let scene = parallel_squares(dir.path(), 1.0, 0.5, 0.5);
    // With no element limit, a density no memory holds is refused before anything is made.
    let huge = RadiositySettings {
        texel_density: 1e6,
        max_elements: 0,
        ..s
    };
    let e = radiosity_stage::check(&scene, &huge)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("GiB") && e.contains("lower --texel-density"),
        "{e}"
    );
    // Under the preset's limit the same density is scaled down to fit it.
    let limited = RadiositySettings {
        texel_density: 1e6,
        ..s
    };
    assert!(limited.max_elements > 0);
    radiosity_stage::check(&scene, &limited).unwrap();
}

#[test]
fn a_scene_over_max_elements_bakes_at_one_lower_density_within_it() {
    let dir = tempfile::tempdir().unwrap();
    let scene = parallel_squares(dir.path(), 1.0, 0.5, 0.5);
    let settings = |max_elements| RadiositySettings {
        texel_density: 64.0,
        max_elements,
        ..small_settings()
    };
    let elements = |max| {
        let out = dir.path().join(format!("m{max}.glint"));
        let record = radiosity_stage::bake(&scene, &out, &settings(max), false, &Silent).unwrap();
        record.stats["elements"].as_u64().unwrap()
    };
    let all = elements(0);
    assert!(all > 4000, "{all}");
    // A limit above them changes nothing; a quarter of them halves the density.
    assert_eq!(elements(2 * all), all);
    let quarter = elements(all / 4);
    assert!(
        quarter <= all / 4 && quarter > all / 6,
        "{quarter} elements for a limit of {}",
        all / 4
    );
    // Fewer than the charts need at any density: refused, naming the setting.
    let e = radiosity_stage::check(&scene, &settings(3))
        .unwrap_err()
        .to_string();
    assert!(e.contains("`max_elements` 3") && e.contains("raise"), "{e}");
}

#[test]
fn glint_radiosity_refuses_another_scenes_bundle_without_force() {
    let dir = tempfile::tempdir().unwrap();
    let bin = env!("CARGO_BIN_EXE_glint-radiosity");
    let a = dir.path().join("a");
    let b = dir.path().join("b");
    std::fs::create_dir_all(&a).unwrap();
    std::fs::create_dir_all(&b).unwrap();
    parallel_squares(&a, 1.0, 0.5, 0.5);
    parallel_squares(&b, 1.0, 0.25, 0.5);
    let out = dir.path().join("x.glint");
    let run = |scene: &Path, force: bool| {
        let mut cmd = std::process::Command::new(bin);
        cmd.arg(scene.join("scene.json"))
            .arg("--bundle")
            .arg(&out)
            .args(["--quality", "draft", "--rays", "8"]);
        if force {
            cmd.arg("--force");
        }
        cmd.output().unwrap()
    };
    assert!(run(&a, false).status.success());
    let second = run(&b, false);
    assert_eq!(second.status.code(), Some(1));
    let err = String::from_utf8_lossy(&second.stderr);
    assert!(err.contains("--force") && err.contains("x.glint"), "{err}");
    assert!(run(&b, true).status.success());
    let bundle = glint::bundle::Bundle::open(&out).unwrap();
    assert!(bundle.verify().is_empty());
    let map = glint::radiosity::RadiosityMap::load(&bundle)
        .unwrap()
        .unwrap();
    // The receiver's centre is lit.
    assert!(map.radiance(0, Vec2::new(0.3, 0.3)).x > 0.0);
}

#[test]
fn texels_per_radian_resolves_the_shading_of_a_curved_surface() {
    // A 10 cm sphere (albedo 0.5) lit from 5 m straight above by a 20 cm emitter, nothing
    // else: D(p) = ρ/π · L_e · A / d² · max(0, n·l) to 0.1% (the lamp is nearly a point).
    // At 16 texels a metre the sphere's charts are 1–2 texels across and a texel's value
    // smears the cosine; with 24 texels a radian they follow it.
    let dir = tempfile::tempdir().unwrap();
    let (r, height, half, le) = (0.1f32, 5.0f32, 0.1f32, 100.0f32);
    let scene = load(
        dir.path(),
        &[
            uv_sphere("Ball", 0, [0.0; 3], r, true),
            flip(quad("Lamp", 1, 1, height, half)),
        ],
        &[
            MaterialSpec::diffuse("Clay", 0.5),
            emissive("Lamp", 0.0, le),
        ],
    );
    let analytic = |p: Vec3| {
        let n = p.normalize();
        let to_lamp = Vec3::new(0.0, height, 0.0) - p;
        let cos_lamp = to_lamp.y / to_lamp.length();
        let e = le * (2.0 * half).powi(2) * cos_lamp * n.dot(to_lamp.normalize()).max(0.0)
            / to_lamp.length_squared();
        0.5 / std::f32::consts::PI * e
    };
    // Probe points on the lit cap, away from the terminator, on the facets under them.
    // A Fibonacci spiral over the cap y > 0.3 (even in area).
    let points: Vec<Vec3> = (0..300)
        .map(|k| {
            let y = 1.0 - 0.7 * (k as f32 + 0.5) / 300.0;
            let phi = k as f32 * 2.399_963;
            let s = (1.0 - y * y).sqrt();
            Vec3::new(s * phi.cos(), y, s * phi.sin()) * r
        })
        .collect();
    let error = |per_radian: f32| {
        let rule = atlas::DensityRule {
            per_metre: 16.0,
            min_across: 0.0,
            per_radian,
        };
        let (atlas, samples) = atlas::build_with(&scene.triangles, rule).unwrap();
        let bvh = scene.build_bvh();
        let set = SolveSettings {
            rays: 16,
            light_samples: 16,
            bounces: 1,
            glossy_depth: 0,
            target_error: None,
            tolerance: 1e-7,
            seed: 1,
            cache_budget: glint::radiosity::solve::CACHE_BUDGET,
        };
        let sol = solve(&scene, &bvh, &atlas, &samples, &set, &Silent).unwrap();
        let mut se = 0.0f64;
        for &p in &points {
            // The facet under p: the nearest hit of a ray from outside towards the centre.
            let hit = bvh
                .closest_hit(p * 2.0, -p.normalize(), f32::INFINITY)
                .unwrap();
            let q = p * 2.0 - p.normalize() * hit.t;
            let d = at(&scene, &atlas, &sol, q).x;
            let exact = analytic(q);
            se += ((d - exact) / exact).powi(2) as f64;
        }
        (se / points.len() as f64).sqrt()
    };
    let (off, on) = (error(0.0), error(24.0));
    eprintln!(
        "sphere's D vs the analytic cosine: rel. RMSE {off:.4} off, {on:.4} at 24 texels a radian"
    );
    assert!(on < 0.5 * off, "{off} → {on}");
    assert!(on < 0.05, "{on}");
}

#[test]
fn texels_per_radian_is_a_setting_like_the_others() {
    use glint::scene::desc::{Quality, RadiosityOverride};
    let over: RadiosityOverride = serde_json::from_str(r#"{ "texels_per_radian": 12 }"#).unwrap();
    let s = RadiositySettings::resolve(Quality::Default, &[&over], None).unwrap();
    assert_eq!(s.texels_per_radian, 12.0);
    s.check(None).unwrap();
    let preset = |q| RadiositySettings::preset(q).texels_per_radian;
    assert_eq!(
        [
            preset(Quality::Draft),
            preset(Quality::Default),
            preset(Quality::High)
        ],
        [0.0, 24.0, 36.0]
    );
    for bad in [-1.0, 161.0, f32::NAN, f32::INFINITY] {
        let s = RadiositySettings {
            texels_per_radian: bad,
            ..RadiositySettings::preset(Quality::Default)
        };
        let e = s.check(None).unwrap_err().to_string();
        assert!(e.contains("texels_per_radian"), "{e}");
    }
    // Settings recorded before the field existed read as off (so such bundles re-bake).
    let mut json = serde_json::to_value(RadiositySettings::preset(Quality::High)).unwrap();
    json.as_object_mut().unwrap().remove("texels_per_radian");
    let old: RadiositySettings = serde_json::from_value(json).unwrap();
    assert_eq!(old.texels_per_radian, 0.0);
}

/// A receiver (albedo 0.5, facing up at y = 0) lit by a 1 × 1 emitter of radiance 2 facing
/// down at y = 1, through a rough glass pane of base colour `tint` at y = 0.5 that covers it.
fn light_behind_a_pane(dir: &Path, tint: [f32; 3], factor: f32) -> Scene {
    let meshes = [
        quad("Receiver", 0, 1, 0.0, 1.0),
        flip(quad("Emitter", 1, 1, 1.0, 0.5)),
        quad("Pane", 2, 1, 0.5, 2.0),
    ];
    let glass = MaterialSpec {
        name: "glass",
        base: [tint[0], tint[1], tint[2], 1.0],
        ..MaterialSpec::diffuse("glass", 0.0)
    };
    let materials = [
        MaterialSpec::diffuse("grey", 0.5),
        emissive("lamp", 0.0, 2.0),
        glass,
    ];
    write_gltf(dir, "s", &meshes, &materials);
    add_transmission(&dir.join("s.gltf"), 2, factor);
    Scene::load(write_scene(
        dir,
        r#"{ "version": 1, "geometry": "s.gltf" }"#,
    ))
    .unwrap()
}

/// ρ/π ∫ L T(cos θ) cos θ cos θ_l / r² dA over the emitter of [`light_behind_a_pane`], seen
/// from the receiver's centre: the pane is parallel to both, so a ray crosses it at the
/// receiver's angle θ, where thin glass passes tint × factor × (1 − F_Schlick(0.04, cos θ)).
fn through_pane_analytic(tint: [f32; 3], factor: f32) -> [f64; 3] {
    let n = 400;
    let mut sum = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let x = -0.5 + (i as f64 + 0.5) / n as f64;
            let z = -0.5 + (j as f64 + 0.5) / n as f64;
            let r2 = x * x + z * z + 1.0;
            let cos = 1.0 / r2.sqrt();
            let f = 0.04 + 0.96 * (1.0 - cos).powi(5);
            sum += (1.0 - f) * cos * cos / r2 / (n * n) as f64;
        }
    }
    tint.map(|t| 0.5 * 2.0 * t as f64 * factor as f64 * sum / std::f64::consts::PI)
}

#[test]
fn a_light_behind_a_tinted_pane_lights_the_receiver_through_it() {
    use glint::eval::probe::ProbePoint;
    use glint::eval::reference::{ProbeTraceOptions, trace_probes};
    let dir = tempfile::tempdir().unwrap();
    let tint = [0.8, 0.6, 0.4];
    let scene = light_behind_a_pane(dir.path(), tint, 1.0);
    let glass = &scene.materials[scene.triangles[4].material as usize];
    assert_eq!(
        glass.transmission.factor, 1.0,
        "the glTF's transmission is read"
    );
    assert_eq!(
        glass.albedo,
        Vec3::ZERO,
        "a fully transmissive pane diffuses nothing"
    );
    let want = through_pane_analytic(tint, 1.0);

    let (atlas, sol) = run(&scene, 16.0, 1024, 256, 4);
    let got = at(&scene, &atlas, &sol, Vec3::ZERO);
    eprintln!("solve {got} vs analytic {want:?}");
    for c in 0..3 {
        assert!(
            (got[c] as f64 / want[c] - 1.0).abs() < 0.02,
            "solve, channel {c}: {got} vs analytic {want:?}"
        );
    }

    let bvh = scene.build_bvh();
    let points = [ProbePoint {
        name: None,
        position: [0.0, 0.0, 0.0],
        normal: [0.0, 1.0, 0.0],
    }];
    let opts = ProbeTraceOptions {
        paths: 16384,
        ..ProbeTraceOptions::default()
    };
    let traced = &trace_probes(&scene, &bvh, &points, 0.01, &opts, &Silent).unwrap()[0];
    let se = traced.std_error.unwrap();
    eprintln!("path tracer {:?} ± {se:?}", traced.radiance);
    for c in 0..3 {
        let (v, w) = (traced.radiance[c] as f64, want[c]);
        assert!(
            (v - w).abs() < 4.0 * se[c] as f64 + 0.01 * w,
            "path tracer, channel {c}: {v} ± {} vs analytic {w}",
            se[c]
        );
    }
}

#[test]
fn a_half_transmissive_pane_passes_half_and_keeps_half_its_diffuse_albedo() {
    let dir = tempfile::tempdir().unwrap();
    let tint = [0.9, 0.9, 0.9];
    let scene = light_behind_a_pane(dir.path(), tint, 0.5);
    let glass = &scene.materials[scene.triangles[4].material as usize];
    assert!((glass.albedo - Vec3::splat(0.45)).abs().max_element() < 1e-6);
    let want = through_pane_analytic(tint, 0.5)[0];
    // The pane's diffuse half faces the emitter: its light goes up, not to the receiver.
    let (atlas, sol) = run(&scene, 16.0, 1024, 256, 4);
    let got = at(&scene, &atlas, &sol, Vec3::ZERO).x as f64;
    eprintln!("solve {got} vs analytic {want}");
    assert!((got / want - 1.0).abs() < 0.02, "{got} vs analytic {want}");
}
