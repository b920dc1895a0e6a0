//! Scenes with more emitters than each element samples one by one (a building's lamps): the
//! radiosity solve draws its emitter samples from one per-element distribution over them all.
//! D must stay unbiased (against the path-traced probes, which sample every emitter on their
//! own), direct and through a mirror, and an element's rays must not grow with the emitters.

mod common;

use std::path::Path;

use common::*;
use glint::eval::probe::{self, diffuse_points};
use glint::eval::reference::{ProbeTraceOptions, trace_probes};
use glint::progress::Silent;
use glint::radiosity::solve::{Solution, SolveSettings, solve};
use glint::radiosity::{RadiosityMap, atlas};
use glint::scene::Scene;

/// A near-perfect mirror (as in tests/transport.rs).
const MIRROR: &str = r#"{ "albedo": [0, 0, 0], "lobes": [{ "model": "kurt", "ks": [1, 1, 1], "r0": 1.0, "mx": 0.001, "my": 0.001, "alpha": 0.5 }] }"#;

/// A closed box of half-size 0.5 with a mirror floor, `lamps` area lights of scene.json in a
/// row under the ceiling and `panels` emissive ceiling panels (each its own quad, so its own
/// group of emissive triangles); the lamps and panels share the same total power whatever
/// their number. The room is split by a half-height wall at x = 0.1.
fn lamps_box(dir: &Path, lamps: usize, panels: usize) -> Scene {
    let mut meshes = box_faces(1);
    // A wall from the floor to mid-height, both faces.
    let wall = [
        [0.1, -0.5, -0.5],
        [0.1, -0.5, 0.5],
        [0.1, 0.0, 0.5],
        [0.1, 0.0, -0.5],
    ];
    meshes.push(quads("wall", 0, &both_faces(wall)));
    let strength = 12.0 / panels.max(1) as f32;
    let faces: Vec<[[f32; 3]; 4]> = (0..panels)
        .map(|i| {
            let x0 = -0.45 + 0.9 * i as f32 / panels as f32;
            let x1 = x0 + 0.6 / panels as f32;
            // Facing down (−y), just under the ceiling.
            [
                [x0, 0.49, 0.2],
                [x1, 0.49, 0.2],
                [x1, 0.49, 0.35],
                [x0, 0.49, 0.35],
            ]
        })
        .collect();
    if panels > 0 {
        meshes.push(quads("panels", 2, &faces));
    }
    write_gltf(
        dir,
        "s",
        &meshes,
        &[
            MaterialSpec::diffuse("walls", 0.6),
            MaterialSpec::diffuse("floor", 0.5),
            MaterialSpec::emitter("panel", [1.0, 1.0, 1.0], strength),
        ],
    );
    let radiance = 40.0 / lamps.max(1) as f32;
    let lights: Vec<String> = (0..lamps)
        .map(|i| {
            let x = -0.45 + 0.9 * i as f32 / lamps as f32;
            format!(
                r#"{{ "name": "lamp{i}", "corner": [{x}, 0.45, -0.3], "edge_u": [0.05, 0, 0], "edge_v": [0, 0, 0.2], "radiance": [{radiance}, {radiance}, {radiance}] }}"#
            )
        })
        .collect();
    let json = format!(
        r#"{{ "version": 1, "geometry": "s.gltf", "materials": {{ "floor": {MIRROR} }}, "reflectors": [{{ "mesh": "Y0", "kind": "planar" }}], "lights": [{}] }}"#,
        lights.join(", ")
    );
    Scene::load(write_scene(dir, &json)).unwrap()
}

/// The six faces of the box of half-size 0.5, facing in, all of material 0 but the floor
/// (`floor`).
fn box_faces(floor: usize) -> Vec<MeshSpec> {
    let names = ["X0", "X1", "Y0", "Y1", "Z0", "Z1"];
    let mut meshes = Vec::new();
    for axis in 0..3 {
        let m0 = if axis == 1 { floor } else { 0 };
        meshes.push(quad(names[2 * axis], m0, axis, -0.5, 0.5));
        meshes.push(flip(quad(names[2 * axis + 1], 0, axis, 0.5, 0.5)));
    }
    meshes
}

/// A quad and the same quad facing the other way.
fn both_faces(q: [[f32; 3]; 4]) -> [[[f32; 3]; 4]; 2] {
    let mut back = q;
    back.reverse();
    [q, back]
}

fn settings(rays: u32, light_samples: u32) -> SolveSettings {
    SolveSettings {
        rays,
        light_samples,
        bounces: 64,
        glossy_depth: 6,
        tolerance: 1e-6,
        target_error: None,
        seed: 5,
        cache_budget: glint::radiosity::solve::CACHE_BUDGET,
    }
}

fn solve_box(scene: &Scene, density: f32, set: &SolveSettings) -> (atlas::Atlas, Solution) {
    let (atlas, samples) = atlas::build(&scene.triangles, density).unwrap();
    let sol = solve(scene, &scene.build_bvh(), &atlas, &samples, set, &Silent).unwrap();
    (atlas, sol)
}

/// Rays cast an element and Σ D (luminance) of a coarse solve of `scene` (32 rays, 4 emitter
/// samples, 4 texels a metre).
fn rays_and_light(scene: &Scene) -> (f64, f64) {
    let (_, sol) = solve_box(scene, 4.0, &settings(32, 4));
    let lit = sol.radiance.iter().map(|v| v.y as f64).sum::<f64>();
    (sol.stats.rays_cast as f64 / sol.stats.elements as f64, lit)
}

#[test]
fn many_emitters_sampled_by_their_weight_match_the_path_traced_probes() {
    // 7 lamps + 5 panels = 12 emitters: more than are sampled each on their own.
    let dir = tempfile::tempdir().unwrap();
    let scene = lamps_box(dir.path(), 7, 5);
    assert_eq!(scene.lights.len(), 7);
    let bvh = scene.build_bvh();
    let points = diffuse_points(&scene, &bvh, 48, 3);
    assert_eq!(points.len(), 48);
    let opts = ProbeTraceOptions {
        paths: 4096,
        ..Default::default()
    };
    let truth = trace_probes(&scene, &bvh, &points, 0.01, &opts, &Silent).unwrap();
    let (atlas, sol) = solve_box(&scene, 8.0, &settings(1024, 32));
    let map = RadiosityMap::from_texels(atlas, &sol.radiance);
    let d = probe::probe(&scene, &bvh, &map, &points, 0.01).unwrap();
    let m = probe::compare_probes(&d, &truth).unwrap();
    eprintln!(
        "D / truth {:.4}, rel RMSE {:.4} over {} probes",
        m.mean_ratio, m.rel_rmse, m.probes
    );
    assert_eq!(m.probes, truth.len());
    assert!(
        (m.mean_ratio - 1.0).abs() < 0.03,
        "D / truth = {:.4} (rel RMSE {:.4})",
        m.mean_ratio,
        m.rel_rmse
    );
    assert!(m.rel_rmse < 0.10, "rel RMSE {:.4}", m.rel_rmse);
}

#[test]
fn an_elements_rays_do_not_grow_with_the_emitters() {
    // The same power split over 12 or 48 emitters: with each sampled on its own, the shadow
    // rays (and the mirror-image rays) would grow fourfold.
    let dir = tempfile::tempdir().unwrap();
    let rays_per_element = |lamps, panels| {
        let sub = dir.path().join(format!("{lamps}-{panels}"));
        std::fs::create_dir_all(&sub).unwrap();
        rays_and_light(&lamps_box(&sub, lamps, panels))
    };
    let (few, d_few) = rays_per_element(7, 5);
    let (many, d_many) = rays_per_element(28, 20);
    eprintln!("rays per element: 12 emitters {few:.1}, 48 emitters {many:.1}");
    assert!(
        many < 1.25 * few,
        "12 emitters: {few:.1} rays an element; 48: {many:.1}"
    );
    // Both rooms are lit about alike (the same power, spread differently).
    assert!(
        (d_many / d_few - 1.0).abs() < 0.25,
        "Σ D {d_few:.1} vs {d_many:.1}"
    );
}

/// The box of [`lamps_box`] without its inner wall, 12 lamps under the ceiling of its x > 0
/// half and the other half walled off floor to ceiling, a closet whose floor is a mirror (a
/// planar reflector) when `mirror`, else diffuse. No light reaches the closet, so its mirror
/// shows nothing.
fn closet_box(dir: &Path, mirror: bool) -> Scene {
    let mut meshes = box_faces(0);
    let (c, lo, hi) = (0.0f32, -0.5f32, 0.5f32);
    meshes.push(quads(
        "closet",
        0,
        &both_faces([[c, lo, lo], [c, lo, hi], [c, hi, hi], [c, hi, lo]]),
    ));
    let y = -0.499;
    meshes.push(quads(
        "closet_floor",
        1,
        &[[[lo, y, lo], [lo, y, hi], [c, y, hi], [c, y, lo]]],
    ));
    write_gltf(
        dir,
        "s",
        &meshes,
        &[
            MaterialSpec::diffuse("walls", 0.6),
            MaterialSpec::diffuse("closet_floor", 0.5),
        ],
    );
    let lights: Vec<String> = (0..12)
        .map(|i| {
            let (x, z) = (
                0.1 + 0.3 * (i % 4) as f32 / 3.0,
                -0.3 + 0.25 * (i / 4) as f32,
            );
            square_lamp(&format!("lamp{i}"), x, z)
        })
        .collect();
    let mirror_json = if mirror {
        format!(
            r#""materials": {{ "closet_floor": {MIRROR} }}, "reflectors": [{{ "mesh": "closet_floor", "kind": "planar" }}],"#
        )
    } else {
        String::new()
    };
    with_lights(dir, &mirror_json, &lights)
}

/// A 5 cm square area light of radiance 20 facing down just under the ceiling, its corner at
/// (`x`, `z`).
fn square_lamp(name: &str, x: f32, z: f32) -> String {
    format!(
        r#"{{ "name": "{name}", "corner": [{x}, 0.45, {z}], "edge_u": [0.05, 0, 0], "edge_v": [0, 0, 0.05], "radiance": [20, 20, 20] }}"#
    )
}

/// The scene of `dir`'s s.gltf with `lights` and the scene.json members `extra` (each ending
/// in a comma).
fn with_lights(dir: &Path, extra: &str, lights: &[String]) -> Scene {
    let json = format!(
        r#"{{ "version": 1, "geometry": "s.gltf", {extra} "lights": [{}] }}"#,
        lights.join(", ")
    );
    Scene::load(write_scene(dir, &json)).unwrap()
}

#[test]
fn points_that_see_no_mirror_cast_few_rays_towards_it() {
    // Every point of the room weighs the closet's mirror (the weights know no walls), but no
    // point sees a lamp in it. The mirror's samples then cost a pilot and, one time in eight,
    // the samples themselves: far fewer rays than one a sample.
    let dir = tempfile::tempdir().unwrap();
    let rays = |mirror: bool| {
        let sub = dir.path().join(if mirror { "mirror" } else { "plain" });
        std::fs::create_dir_all(&sub).unwrap();
        rays_and_light(&closet_box(&sub, mirror))
    };
    let ((with, d_with), (without, d_without)) = (rays(true), rays(false));
    // The mirror's samples a point draws: `light_samples` × 8 (more than 8 emitters).
    let samples = 4.0 * 8.0;
    let extra = with - without;
    eprintln!("rays an element: {without:.1} without the mirror, {with:.1} with it");
    assert!(
        extra < 0.35 * samples,
        "the mirror adds {extra:.1} rays an element for its {samples} samples"
    );
    // The mirror shows nothing, so D is the room's without it.
    assert!(
        (d_with / d_without - 1.0).abs() < 0.05,
        "Σ D {d_without:.2} without the mirror, {d_with:.2} with it"
    );
}

/// The box of [`lamps_box`] split floor to ceiling by a wall at x = 0.25: one lamp lights the
/// larger room (x < 0.25) from its far end, 11 lamps light the smaller one from just beyond
/// the wall, nearer than the big room's own lamp to most of its points.
fn two_rooms(dir: &Path) -> Scene {
    let mut meshes = box_faces(0);
    let (c, lo, hi) = (0.25f32, -0.5f32, 0.5f32);
    meshes.push(quads(
        "wall",
        0,
        &both_faces([[c, lo, lo], [c, lo, hi], [c, hi, hi], [c, hi, lo]]),
    ));
    write_gltf(dir, "s", &meshes, &[MaterialSpec::diffuse("walls", 0.2)]);
    let mut lights = vec![square_lamp("far", -0.45, -0.025)];
    lights
        .extend((0..11).map(|i| square_lamp(&format!("near{i}"), 0.27, -0.45 + 0.085 * i as f32)));
    with_lights(dir, "", &lights)
}

#[test]
fn emitters_behind_a_wall_get_few_of_a_points_samples() {
    // The weights know no walls: without a visibility test most of the big room's emitter
    // samples go to the lamps beyond the wall and are blocked, and its D is noisy. Each
    // element's test rays find them blocked, so its samples go to the lamp it sees. Cheap
    // solves (64 rays, 2 × 8 emitter samples) against a solve with many samples.
    let dir = tempfile::tempdir().unwrap();
    let scene = two_rooms(dir.path());
    let bvh = scene.build_bvh();
    let points: Vec<_> = diffuse_points(&scene, &bvh, 200, 7)
        .into_iter()
        .filter(|p| p.position[0] < 0.2)
        .collect();
    assert!(points.len() > 60, "{} points in the big room", points.len());
    let d = |rays, light_samples| {
        let (atlas, sol) = solve_box(&scene, 8.0, &settings(rays, light_samples));
        let map = RadiosityMap::from_texels(atlas, &sol.radiance);
        probe::probe(&scene, &bvh, &map, &points, 0.01).unwrap()
    };
    let (cheap, truth) = (d(64, 2), d(256, 64));
    let m = probe::compare_probes(&cheap, &truth).unwrap();
    eprintln!(
        "big room: D / many-sample D {:.4}, rel RMSE {:.4} over {} probes",
        m.mean_ratio, m.rel_rmse, m.probes
    );
    // Without the test (every weight kept): 1.0234, rel RMSE 0.1445; with it 0.9980, 0.1001.
    assert!(m.rel_rmse < 0.12, "rel RMSE {:.4}", m.rel_rmse);
    assert!(
        (m.mean_ratio - 1.0).abs() < 0.03,
        "D / truth {:.4}",
        m.mean_ratio
    );
}
