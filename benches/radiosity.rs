//! Radiosity presets on the speed-for-accuracy curve: per scene and preset, the target error,
//! bake time (atlas with its contact boosts + solve + seam stitching), rays, peak memory, the solver's own error estimate, and the error
//! of D against ground truth: D path-traced at 400 probes on the diffuse faces with every
//! transport path (`glint::eval::reference::trace_probes`; `GLINT_BENCH_PATHS` paths each,
//! default 4096), whose own noise is printed beside it, taken out, and the same error over the
//! probes at least half a default texel away from other surfaces. With `--converged`, also the RMS
//! relative error of the texels against a converged solve of the same texels (4096 rays, 1024
//! light samples, 64 bounces, another seed).
//!
//! `cargo bench --bench radiosity [-- [--converged] SCENE.json ...]`
//! (default: the four shipped scenes).

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use glam::Vec3;
use glint::bundle::stats::{format_table, human_bytes};
use glint::eval::probe::{clearance, compare_probes, default_reach, diffuse_points, probe};
use glint::eval::reference::{ProbeTraceOptions, trace_probes};
use glint::progress::Silent;
use glint::radiosity::solve::{SolveSettings, solve};
use glint::radiosity::{RadiosityMap, contacts, seams};
use glint::scene::desc::RadiositySettings;
use glint::scene::{Quality, Scene};

/// Counts live heap bytes and their peak, so each preset's peak can be measured in-process.
struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let now = LIVE.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(now, Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        unsafe { System.dealloc(p, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

const REFERENCE: SolveSettings = SolveSettings {
    rays: 4096,
    light_samples: 1024,
    bounces: 64,
    glossy_depth: 64,
    target_error: None,
    tolerance: 0.0,
    seed: 99,
    cache_budget: glint::radiosity::solve::CACHE_BUDGET,
};

fn luminance(c: Vec3) -> f64 {
    glint::colour::luminance(c) as f64
}

/// RMS of (value − reference) / reference over texels the reference lights, with the
/// denominator floored at 5% of the mean so near-black texels do not dominate.
fn rms_relative(values: &[Vec3], reference: &[Vec3]) -> f64 {
    let lit: Vec<(f64, f64)> = values
        .iter()
        .zip(reference)
        .map(|(v, r)| (luminance(*v), luminance(*r)))
        .filter(|(_, r)| *r > 0.0)
        .collect();
    let mean = lit.iter().map(|(_, r)| r).sum::<f64>() / lit.len().max(1) as f64;
    let floor = 0.05 * mean;
    let sum: f64 = lit
        .iter()
        .map(|(v, r)| ((v - r) / r.max(floor)).powi(2))
        .sum();
    (sum / lit.len().max(1) as f64).sqrt()
}

fn main() {
    glint::cli::init_logging();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let converged = args.iter().any(|a| a == "--converged");
    let mut scenes: Vec<String> = args.into_iter().filter(|a| !a.starts_with("--")).collect();
    if scenes.is_empty() {
        scenes = [
            "cornell-box",
            "glossy-room",
            "bunny-mirror",
            "breakfast-room",
        ]
        .iter()
        .map(|s| format!("scenes/{s}/scene.json"))
        .collect();
    }
    let paths: u32 = std::env::var("GLINT_BENCH_PATHS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(4096);
    let header = [
        "scene".to_string(),
        "preset".into(),
        "target".into(),
        "elements".into(),
        "rays/texel".into(),
        "Mrays".into(),
        "bake s".into(),
        "peak mem".into(),
        "est. err med/p95".into(),
        "vs truth RMSE".into(),
        "noise-free".into(),
        "off edges".into(),
        "ratio".into(),
        "truth noise".into(),
        "vs converged".into(),
    ];
    let mut rows = vec![header];
    for path in &scenes {
        let scene = Scene::load(path).unwrap_or_else(|e| panic!("{e}"));
        let bvh = scene.build_bvh();
        // Ground truth: D path-traced at probes on the diffuse faces, every transport path.
        let points = diffuse_points(&scene, &bvh, 400, 1);
        let reach = default_reach(&scene);
        let opts = ProbeTraceOptions {
            paths,
            ..Default::default()
        };
        let truth = trace_probes(&scene, &bvh, &points, reach, &opts, &Silent).unwrap();
        // Probes at least half a default-preset texel from any other surface: nearer a concave
        // edge D changes within millimetres, which no lightmap texel resolves.
        let half_texel = 0.5 / RadiositySettings::preset(Quality::Default).texel_density;
        let open: Vec<bool> = points
            .iter()
            .map(|p| clearance(&bvh, Vec3::from(p.position), Vec3::from(p.normal)) >= half_texel)
            .collect();
        let keep = |v: &[glint::eval::probe::ProbeValue]| -> Vec<_> {
            v.iter()
                .zip(&open)
                .filter(|(_, o)| **o)
                .map(|(x, _)| x.clone())
                .collect()
        };
        let truth_open = keep(&truth);
        for q in Quality::ALL {
            let s = RadiositySettings::resolve(q, &[&scene.desc.bake.radiosity], None).unwrap();
            let set = SolveSettings {
                rays: s.rays,
                light_samples: s.light_samples,
                bounces: s.bounces,
                glossy_depth: s.glossy_depth,
                target_error: s.target_error,
                tolerance: s.tolerance,
                seed: glint::bake::radiosity_stage::SEED,
                cache_budget: s.cache_budget(),
            };
            let base = LIVE.load(Ordering::Relaxed);
            PEAK.store(base, Ordering::Relaxed);
            let t = Instant::now();
            // The stage's atlas: the rule's, with the preset's contact boosts.
            let (atlas, samples, _) = contacts::build(
                &scene,
                &bvh,
                glint::bake::radiosity_stage::density_rule(&scene, &s)
                    .unwrap()
                    .rule,
                s.contact_boost,
            )
            .unwrap();
            let mut sol = solve(&scene, &bvh, &atlas, &samples, &set, &Silent).unwrap();
            if s.stitch_seams {
                seams::stitch_seams(&scene.triangles, &atlas, &samples, &mut sol.radiance);
            }
            let secs = t.elapsed().as_secs_f64();
            let peak = PEAK.load(Ordering::Relaxed) - base;
            let st = sol.stats.clone();
            let radiance = sol.radiance;
            let vs_converged = converged.then(|| {
                let reference = solve(&scene, &bvh, &atlas, &samples, &REFERENCE, &Silent).unwrap();
                format!("{:.4}", rms_relative(&radiance, &reference.radiance))
            });
            let map = RadiosityMap::from_texels(atlas, &radiance);
            let d = probe(&scene, &bvh, &map, &points, reach).unwrap();
            let m = compare_probes(&d, &truth).unwrap();
            let m_open = compare_probes(&keep(&d), &truth_open).unwrap();
            let pct = |x: f64| format!("{:.1}%", 100.0 * x);
            let row = [
                scene.name.clone(),
                q.name().into(),
                s.target_error.map_or("-".into(), |t| pct(t as f64)),
                st.elements.to_string(),
                s.rays.to_string(),
                format!("{:.1}", st.rays_cast as f64 / 1e6),
                format!("{secs:.2}"),
                human_bytes(peak as u64),
                format!("{}/{}", pct(st.error_median), pct(st.error_p95)),
                pct(m.rel_rmse),
                m.rel_rmse_denoised.map_or("-".into(), pct),
                format!("{} ({})", pct(m_open.rel_rmse), m_open.probes),
                format!("{:.3}", m.mean_ratio),
                m.reference_noise.map_or("-".into(), pct),
                vs_converged.unwrap_or_else(|| "-".into()),
            ];
            // Each row as it is measured: a long run (breakfast-room at high takes about an
            // hour on 2 cores) leaves what it measured even when stopped.
            eprintln!("row: {}", row.join(" | "));
            rows.push(row);
        }
    }
    println!(
        "Radiosity presets ({} threads): D against path-traced probes (400 per scene on diffuse faces, {paths} paths each, every transport path).\n\
         noise-free: the RMSE with the probes' own noise taken out in quadrature; off edges: the RMSE over the probes (count) at least half a default texel from any other surface\n",
        rayon::current_num_threads(),
    );
    let right = std::array::from_fn(|i| i >= 2);
    print!("{}", format_table(&rows, &right));
}
