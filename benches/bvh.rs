//! BVH benchmark: build time and closest-hit / occlusion rays per second, for camera rays and
//! for cosine-distributed rays leaving surfaces, single-threaded and on every core.
//!
//! `cargo bench --bench bvh [-- SCENE.json]` (default: scenes/breakfast-room/scene.json).
//! Prints a table; figures are medians of several runs.

use std::time::Instant;

use glam::Vec3;
use glint::bundle::stats::format_table;
use glint::camera::{Camera, pose_at};
use glint::geometry::Bvh;
use glint::sampling::{Rng, basis, sample_cosine_hemisphere, sample_triangle};
use glint::scene::Scene;
use rayon::prelude::*;

const CAMERA_W: u32 = 1024;
const CAMERA_H: u32 = 768;
const DIFFUSE_RAYS: usize = 786_432;
const RUNS: usize = 5;

struct RaySet {
    origins: Vec<Vec3>,
    dirs: Vec<Vec3>,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn camera_rays(scene: &Scene) -> RaySet {
    let cam = match scene.camera_path(None) {
        Some(p) => pose_at(p, p.keyframes[0].time),
        None => {
            let c = scene.bounds.center();
            let eye = c + Vec3::new(0.0, 0.0, scene.bounds.diagonal());
            Camera::look_at(eye, c, Vec3::Y, 50f32.to_radians())
        }
    };
    let aspect = CAMERA_W as f32 / CAMERA_H as f32;
    let mut set = RaySet {
        origins: Vec::new(),
        dirs: Vec::new(),
    };
    for y in 0..CAMERA_H {
        for x in 0..CAMERA_W {
            set.origins.push(cam.position);
            set.dirs
                .push(cam.ray_direction(Camera::pixel_ndc(x, y, CAMERA_W, CAMERA_H), aspect));
        }
    }
    set
}

/// Rays from area-uniform surface points, cosine-distributed about the face normal.
fn diffuse_rays(scene: &Scene, bvh: &Bvh) -> RaySet {
    let mut cdf = Vec::with_capacity(scene.triangles.len());
    let mut total = 0.0f64;
    for t in &scene.triangles {
        total += t.area() as f64;
        cdf.push(total);
    }
    let mut rng = Rng::new(42, 0);
    let mut set = RaySet {
        origins: Vec::new(),
        dirs: Vec::new(),
    };
    for _ in 0..DIFFUSE_RAYS {
        let target = rng.uniform() as f64 * total;
        let i = cdf.partition_point(|&c| c <= target).min(cdf.len() - 1);
        let tri = &scene.triangles[i];
        let n = tri.face_normal();
        let p = tri.point(sample_triangle(rng.uniform2()));
        let (t, b) = basis(n);
        let l = sample_cosine_hemisphere(rng.uniform2());
        set.origins.push(bvh.offset_origin(p, n));
        set.dirs.push(t * l.x + b * l.y + n * l.z);
    }
    set
}

/// Million rays per second for `query` over `rays`, on one thread or on rayon's pool.
fn measure(
    rays: &RaySet,
    parallel: bool,
    query: &(dyn Fn(Vec3, Vec3) -> bool + Sync),
) -> (f64, f64) {
    let mut rates = Vec::new();
    let mut hits = 0usize;
    for _ in 0..RUNS {
        let start = Instant::now();
        hits = if parallel {
            (0..rays.dirs.len())
                .into_par_iter()
                .with_min_len(4096)
                .filter(|&i| query(rays.origins[i], rays.dirs[i]))
                .count()
        } else {
            (0..rays.dirs.len())
                .filter(|&i| query(rays.origins[i], rays.dirs[i]))
                .count()
        };
        rates.push(rays.dirs.len() as f64 / start.elapsed().as_secs_f64() / 1e6);
    }
    (median(rates), hits as f64 / rays.dirs.len() as f64)
}

fn main() {
    glint::cli::init_logging();
    let path = std::env::args()
        .skip(1)
        .find(|a| !a.starts_with("--"))
        .unwrap_or_else(|| "scenes/breakfast-room/scene.json".into());
    let t = Instant::now();
    let scene = match Scene::load(&path) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let load_s = t.elapsed().as_secs_f64();

    let builds: Vec<f64> = (0..RUNS)
        .map(|_| {
            let t = Instant::now();
            let bvh = scene.build_bvh();
            std::hint::black_box(&bvh);
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    let bvh = scene.build_bvh();
    let threads = rayon::current_num_threads();

    println!(
        "BVH benchmark: {} ({} triangles), scene load {:.2} s, BVH build median {:.1} ms ({} threads), medians of {RUNS} runs\n",
        scene.name,
        scene.triangles.len(),
        load_s,
        median(builds),
        threads
    );
    let sets = [
        ("camera", camera_rays(&scene)),
        ("diffuse", diffuse_rays(&scene, &bvh)),
    ];
    let mut rows = vec![[
        "rays".to_string(),
        "query".to_string(),
        "threads".to_string(),
        "Mrays/s".to_string(),
        "hit fraction".to_string(),
    ]];
    let closest = |o: Vec3, d: Vec3| bvh.closest_hit(o, d, f32::INFINITY).is_some();
    let occluded = |o: Vec3, d: Vec3| bvh.occluded(o, d, f32::INFINITY);
    for (name, rays) in &sets {
        for (qname, q) in [
            (
                "closest-hit",
                &closest as &(dyn Fn(Vec3, Vec3) -> bool + Sync),
            ),
            ("occlusion", &occluded),
        ] {
            for parallel in [false, true] {
                let (rate, frac) = measure(rays, parallel, q);
                rows.push([
                    format!("{name} ({})", rays.dirs.len()),
                    qname.to_string(),
                    if parallel {
                        threads.to_string()
                    } else {
                        "1".into()
                    },
                    format!("{rate:.2}"),
                    format!("{frac:.3}"),
                ]);
            }
        }
    }
    print!("{}", format_table(&rows, &[false, false, true, true, true]));
}
