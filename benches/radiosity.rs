//! Radiosity presets on the speed-for-accuracy curve: per scene and preset, bake time
//! (atlas + solve), rays per second, peak memory, and the RMS relative error of the texels
//! against a converged solution of the same texels (same atlas, 4096 rays, 1024 light
//! samples, 64 bounces, another seed).
//!
//! `cargo bench --bench radiosity [-- SCENE.json ...]`
//! (default: scenes/cornell-box and scenes/breakfast-room).

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use glam::Vec3;
use glint::bundle::stats::{format_table, human_bytes};
use glint::progress::Silent;
use glint::radiosity::atlas;
use glint::radiosity::solve::{SolveSettings, solve};
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
};

fn luminance(c: Vec3) -> f64 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722)) as f64
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
    let mut scenes: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    if scenes.is_empty() {
        scenes = vec![
            "scenes/cornell-box/scene.json".into(),
            "scenes/breakfast-room/scene.json".into(),
        ];
    }
    let mut rows = vec![[
        "scene".to_string(),
        "preset".into(),
        "elements".into(),
        "rays/texel".into(),
        "bake s".into(),
        "Mrays/s".into(),
        "peak mem".into(),
        "RMS rel err".into(),
        "ref s".into(),
    ]];
    for path in &scenes {
        let scene = Scene::load(path).unwrap_or_else(|e| panic!("{e}"));
        let bvh = scene.build_bvh();
        for q in Quality::ALL {
            let s = RadiositySettings::resolve(q, &scene.desc.bake.radiosity);
            let set = SolveSettings {
                rays: s.rays,
                light_samples: s.light_samples,
                bounces: s.bounces,
                glossy_depth: s.glossy_depth,
                target_error: None,
                tolerance: s.tolerance,
                seed: glint::bake::radiosity_stage::SEED,
            };
            let base = LIVE.load(Ordering::Relaxed);
            PEAK.store(base, Ordering::Relaxed);
            let t = Instant::now();
            let (atlas, samples) = atlas::build(&scene.triangles, s.texel_density).unwrap();
            let sol = solve(&scene, &bvh, &atlas, &samples, &set, &Silent).unwrap();
            let secs = t.elapsed().as_secs_f64();
            let peak = PEAK.load(Ordering::Relaxed) - base;
            let t = Instant::now();
            let reference = solve(&scene, &bvh, &atlas, &samples, &REFERENCE, &Silent).unwrap();
            let ref_secs = t.elapsed().as_secs_f64();
            rows.push([
                scene.name.clone(),
                q.name().into(),
                sol.stats.elements.to_string(),
                s.rays.to_string(),
                format!("{secs:.2}"),
                format!("{:.2}", sol.stats.rays_cast as f64 / secs / 1e6),
                human_bytes(peak as u64),
                format!("{:.4}", rms_relative(&sol.radiance, &reference.radiance)),
                format!("{ref_secs:.1}"),
            ]);
            eprintln!("{} {} done", scene.name, q.name());
        }
    }
    println!(
        "Radiosity presets ({} threads); error against {} rays, {} light samples, {} bounces on the same texels\n",
        rayon::current_num_threads(),
        REFERENCE.rays,
        REFERENCE.light_samples,
        REFERENCE.bounces
    );
    print!(
        "{}",
        format_table(
            &rows,
            &[false, false, true, true, true, true, true, true, true]
        )
    );
}
