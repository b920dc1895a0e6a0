//! SRDM benchmark (Popescu et al. 2006 §5.1–5.2): construction time, average relative z error
//! and bytes of the SRDM set of a 256² depth map of the bunny, n = 60, for m = 8 … 64, beside
//! the paper's figures; then ray–SRDM intersection against the bunny's triangles.
//!
//! `cargo bench --no-default-features --bench srdm [-- SCENE.json]` (default:
//! scenes/bunny-mirror/scene.json, its first impostor). Times are medians of several runs;
//! single-thread CPU time (Linux schedstat) is shown beside the wall time because a shared
//! machine inflates the latter. `SRDM_PROFILE=m` only builds, for 5 s, to run under a profiler.

use std::time::Instant;

use glam::Vec3;
use glint::bake::srdm_stage::{self, ColourSource};
use glint::bundle::stats::{format_table, human_bytes};
use glint::geometry::{Bvh, Triangle};
use glint::progress::Silent;
use glint::sampling::Rng;
use glint::scene::Scene;
use glint::srdm::{DepthMap, ImpostorCamera, Srdm, SrdmParams, error_stats, march};
use rayon::prelude::*;

const RESOLUTION: u32 = 256;
const DOMAINS: u32 = 60;
const RUNS: usize = 9;
/// Popescu et al. 2006 §5.1 (construction, ms) and §5.2 (average relative z error, %).
const PAPER: [(u32, Option<f64>, Option<f64>); 7] = [
    (8, Some(210.0), Some(1.43)),
    (10, None, Some(0.9)),
    (12, None, Some(0.7)),
    (14, None, Some(0.5)),
    (16, Some(300.0), Some(0.4)),
    (32, Some(480.0), None),
    (64, Some(980.0), None),
];

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// CPU time of the calling thread (Linux schedstat, ns): unlike wall time, it does not count
/// the time a busy machine keeps the thread waiting.
fn thread_cpu_ms() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = text.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-6)
}

/// Median wall time of a build on `threads` threads, and (on one thread) its median CPU time.
fn build_ms(map: &DepthMap, cam: ImpostorCamera, m: u32, threads: usize) -> (f64, Option<f64>) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    let params = SrdmParams {
        domains: DOMAINS,
        points: m,
    };
    pool.install(|| {
        let (wall, cpu): (Vec<f64>, Vec<Option<f64>>) = (0..RUNS)
            .map(|_| {
                let c = thread_cpu_ms();
                let t = Instant::now();
                let s = Srdm::build(map, cam, params, &Silent).expect("build");
                std::hint::black_box(&s);
                let wall = t.elapsed().as_secs_f64() * 1e3;
                let cpu = c.zip(thread_cpu_ms()).map(|(a, b)| b - a);
                (wall, cpu.filter(|_| threads == 1))
            })
            .unzip();
        let cpu: Option<Vec<f64>> = cpu.into_iter().collect();
        (median(wall), cpu.map(median))
    })
}

fn main() {
    glint::cli::init_logging();
    let path = std::env::args()
        .skip(1)
        .find(|a| !a.starts_with("--"))
        .unwrap_or_else(|| "scenes/bunny-mirror/scene.json".into());
    let scene = match Scene::load(&path) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let Some(imp) = scene.impostors.first() else {
        eprintln!("error: {path}: the scene declares no impostor");
        std::process::exit(1);
    };
    let cam = srdm_stage::view_camera(&scene, imp, 0, RESOLUTION);
    let t = Instant::now();
    let cap =
        srdm_stage::capture(&scene, imp, &cam, &ColourSource::Albedo, &Silent).expect("capture");
    let capture_ms = t.elapsed().as_secs_f64() * 1e3;
    let threads = rayon::current_num_threads();
    if let Ok(m) = std::env::var("SRDM_PROFILE") {
        // Builds only, for a profiler: SRDM_PROFILE=8 perf record … srdm
        let m: u32 = m.parse().expect("SRDM_PROFILE=m");
        let t = Instant::now();
        let mut k = 0;
        while t.elapsed().as_secs_f64() < 5.0 {
            std::hint::black_box(build_ms(&cap.depth, cam, m, 1));
            k += 1;
        }
        println!("{k} × {RUNS} builds");
        return;
    }
    println!(
        "SRDM benchmark: {} impostor {:?}, {RESOLUTION}² depth map ({:.1} % covered, captured in {capture_ms:.1} ms; \
         eye {:.2} object radii from its centre, depth range {:.3}–{:.3} m), n = {DOMAINS}; medians of {RUNS} builds; {threads} threads available\n",
        scene.name,
        imp.name,
        100.0 * cap.depth.coverage(),
        (cam.view.position - imp.bounds.center()).length() / (0.5 * imp.bounds.diagonal()),
        cam.hither,
        cam.yon,
    );

    let mut rows = vec![[
        "m".to_string(),
        "paper ms".into(),
        "ours ms, 1 thread (CPU)".into(),
        format!("ours ms, {threads} threads"),
        "speed-up (1 thread CPU)".into(),
        format!("speed-up ({threads} threads)"),
        "paper rel. z error".into(),
        "ours rel. z error".into(),
        "ours |Δz| / depth range".into(),
        "max row error (1/z)".into(),
        "points in use".into(),
        "bytes (points)".into(),
        "bytes (.srdm file)".into(),
    ]];
    let mut sets = Vec::new();
    for (m, paper_ms, paper_err) in PAPER {
        let (one_wall, one_cpu) = build_ms(&cap.depth, cam, m, 1);
        let one = one_cpu.unwrap_or(one_wall);
        let (all, _) = build_ms(&cap.depth, cam, m, threads);
        let srdm = Srdm::build(
            &cap.depth,
            cam,
            SrdmParams {
                domains: DOMAINS,
                points: m,
            },
            &Silent,
        )
        .expect("build");
        let e = error_stats(&cap.depth, &srdm);
        let opt = |v: Option<f64>, f: &dyn Fn(f64) -> String| v.map_or("–".into(), f);
        rows.push([
            m.to_string(),
            opt(paper_ms, &|v| format!("{v:.0}")),
            match one_cpu {
                Some(c) => format!("{one_wall:.1} ({c:.1})"),
                None => format!("{one_wall:.1}"),
            },
            format!("{all:.1}"),
            opt(paper_ms, &|v| format!("{:.0}×", v / one)),
            opt(paper_ms, &|v| format!("{:.0}×", v / all)),
            opt(paper_err, &|v| format!("{v:.2} %")),
            format!("{:.3} %", 100.0 * e.mean_relative_z_error),
            format!("{:.3} %", 100.0 * e.mean_range_error),
            format!("{:.2e}", e.max_row_error),
            format!(
                "{:.1} %",
                100.0 * e.points_used as f64 / srdm.points().len() as f64
            ),
            format!(
                "{} ({})",
                srdm.point_bytes(),
                human_bytes(srdm.point_bytes())
            ),
            Srdm::file_bytes(DOMAINS, RESOLUTION, m).to_string(),
        ]);
        sets.push((m, srdm));
    }
    print!(
        "{}",
        format_table(
            &rows,
            &[
                true, true, true, true, true, true, true, true, true, true, true, true, true
            ]
        )
    );
    println!(
        "\nrel. z error: mean |z' − z| / z over every covered sample of every row of every domain (§5.2); \
         it scales with the capture distance, so the error relative to the object's depth range is given too.\n"
    );

    // Intersection: rays from the capture's side at the bunny, against its triangles.
    let ids = srdm_stage::impostor_triangles(&scene, imp);
    let tris: Vec<Triangle> = ids.iter().map(|&t| scene.triangles[t as usize]).collect();
    let bvh = Bvh::build(&tris);
    let centre = imp.bounds.center();
    let radius = 0.5 * imp.bounds.diagonal();
    let mut rng = Rng::new(5, 0);
    let mut rays = Vec::new();
    while rays.len() < 200_000 {
        // Origins on a cap within 25° of the capture direction, 2 radii out; targets in the box.
        let axis = -cam.view.forward;
        let (u, v) = (rng.uniform(), rng.uniform());
        let cos = 1.0 - u * (1.0 - 25f32.to_radians().cos());
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * v;
        let (t, b) = glint::sampling::basis(axis);
        let dir_out = axis * cos + (t * phi.cos() + b * phi.sin()) * sin;
        let o = centre + dir_out * 2.0 * radius;
        let target = imp.bounds.min
            + (imp.bounds.max - imp.bounds.min)
                * Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
        rays.push((o, (target - o).normalize()));
    }
    let truth: Vec<Option<f32>> = rays
        .par_iter()
        .map(|&(o, d)| bvh.closest_hit(o, d, f32::INFINITY).map(|h| h.t))
        .collect();
    let rate = |f: &(dyn Fn(Vec3, Vec3) -> Option<f32> + Sync)| {
        let times: Vec<f64> = (0..3)
            .map(|_| {
                let t = Instant::now();
                let n = rays.iter().filter(|&&(o, d)| f(o, d).is_some()).count();
                std::hint::black_box(n);
                rays.len() as f64 / t.elapsed().as_secs_f64() / 1e6
            })
            .collect();
        let hits: Vec<Option<f32>> = rays.iter().map(|&(o, d)| f(o, d)).collect();
        let agree = hits
            .iter()
            .zip(&truth)
            .filter(|(a, b)| a.is_some() == b.is_some())
            .count();
        let mut rel: Vec<f64> = hits
            .iter()
            .zip(&truth)
            .filter_map(|(a, b)| Some(((a.as_ref()? - b.as_ref()?) / b.as_ref()?).abs() as f64))
            .collect();
        rel.sort_by(f64::total_cmp);
        let q = |p: f64| {
            rel.get((p * rel.len() as f64) as usize)
                .copied()
                .unwrap_or(0.0)
        };
        (
            median(times),
            agree as f64 / rays.len() as f64,
            q(0.5),
            q(0.9),
        )
    };
    let mut rows = vec![[
        "method".to_string(),
        "Mrays/s (1 thread)".into(),
        "hit/miss agrees with triangles".into(),
        "median |Δt|/t".into(),
        "90th pct |Δt|/t".into(),
    ]];
    let mut push = |name: String, r: (f64, f64, f64, f64)| {
        rows.push([
            name,
            format!("{:.2}", r.0),
            format!("{:.1} %", 100.0 * r.1),
            format!("{:.3} %", 100.0 * r.2),
            format!("{:.3} %", 100.0 * r.3),
        ])
    };
    for (m, srdm) in sets.iter().filter(|(m, _)| [8, 16, 64].contains(m)) {
        push(
            format!("SRDM n = {DOMAINS}, m = {m} (§4.3)"),
            rate(&|o, d| srdm.intersect(o, d, f32::INFINITY).map(|h| h.t)),
        );
    }
    push(
        "depth-map march, ½-texel steps".into(),
        rate(&|o, d| march(&cap.depth, &cam, o, d, f32::INFINITY, 0.5).map(|h| h.t)),
    );
    push(
        format!("BVH over the {} triangles", tris.len()),
        rate(&|o, d| bvh.closest_hit(o, d, f32::INFINITY).map(|h| h.t)),
    );
    println!(
        "Intersection: {} rays from within 25° of the capture direction at random points of the bunny's box; \
         a depth map holds only the side it sees, so some disagreement with the triangles is the impostor's, not the search's.\n",
        rays.len()
    );
    print!("{}", format_table(&rows, &[false, true, true, true, true]));
}
