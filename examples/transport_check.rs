use glint::eval::probe::{diffuse_points, probe};
use glint::eval::reference::{ProbeTraceOptions, trace_probes};
use glint::progress::Silent;
use glint::radiosity::{
    RadiosityMap, atlas,
    solve::{SolveSettings, solve},
};
use glint::scene::desc::RadiositySettings;
use glint::scene::{Quality, Scene};
use std::time::Instant;

fn lum(c: [f32; 3]) -> f64 {
    (0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]) as f64
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scene = Scene::load(std::path::Path::new(&args[1])).unwrap();
    let q = match args.get(2).map(|s| s.as_str()) {
        Some("draft") => Quality::Draft,
        Some("high") => Quality::High,
        _ => Quality::Default,
    };
    let paths: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1024);
    let bvh = scene.build_bvh();
    let pts = diffuse_points(&scene, &bvh, 400, 7);
    let reach = glint::eval::probe::default_reach(&scene);
    let t = Instant::now();
    let full = trace_probes(
        &scene,
        &bvh,
        &pts,
        reach,
        &ProbeTraceOptions {
            paths,
            ..Default::default()
        },
        &Silent,
    )
    .unwrap();
    let diff = trace_probes(
        &scene,
        &bvh,
        &pts,
        reach,
        &ProbeTraceOptions {
            paths,
            diffuse_only: true,
            ..Default::default()
        },
        &Silent,
    )
    .unwrap();
    eprintln!(
        "reference {} probes x {} paths x2: {:.1}s",
        pts.len(),
        paths,
        t.elapsed().as_secs_f64()
    );
    let rel_se: Vec<f64> = full
        .iter()
        .map(|v| lum(v.std_error.unwrap()) / lum(v.radiance).max(1e-9))
        .collect();
    let mut s = rel_se.clone();
    s.sort_by(f64::total_cmp);
    eprintln!(
        "reference rel SE median {:.4} p95 {:.4}",
        s[s.len() / 2],
        s[s.len() * 95 / 100]
    );
    for depth in [
        0u32,
        std::env::var("DEPTH")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(4),
    ] {
        let mut s0 = RadiositySettings::resolve(q, &scene.desc.bake.radiosity);
        let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f32>().ok());
        if let Some(v) = env("DENSITY") {
            s0.texel_density = v;
        }
        if let Some(v) = env("RAYS") {
            s0.rays = v as u32;
        }
        if let Some(v) = env("LIGHT") {
            s0.light_samples = v as u32;
        }
        let set = SolveSettings {
            rays: s0.rays,
            light_samples: s0.light_samples,
            bounces: s0.bounces,
            glossy_depth: depth,
            target_error: std::env::var("TARGET").ok().and_then(|v| v.parse().ok()),
            tolerance: s0.tolerance,
            seed: 0x6c69_6e74,
        };
        let t = Instant::now();
        let (at, samples) = atlas::build(&scene.triangles, s0.texel_density).unwrap();
        let sol = solve(&scene, &bvh, &at, &samples, &set, &Silent).unwrap();
        let secs = t.elapsed().as_secs_f64();
        eprintln!(
            "  stats: rounds {} refined {} err median {:.4} p95 {:.4} max {:.4}",
            sol.stats.rounds,
            sol.stats.refined,
            sol.stats.error_median,
            sol.stats.error_p95,
            sol.stats.error_max
        );
        let map = RadiosityMap::from_texels(at, &sol.radiance);
        let d = probe(&scene, &bvh, &map, &pts, reach).unwrap();
        if std::env::var("DUMP").is_ok() && depth > 0 {
            for (a, b) in d.iter().zip(full.iter()) {
                if (lum(a.radiance) / lum(b.radiance) - 1.0).abs() > 0.15 {
                    eprintln!(
                        "{:?} {:?} D {:.4} truth {:.4} ± {:.4}",
                        b.name,
                        b.position,
                        lum(a.radiance),
                        lum(b.radiance),
                        lum(b.std_error.unwrap())
                    );
                }
            }
        }
        for (name, refv) in [("full", &full), ("diffuse-only", &diff)] {
            let (mut se, mut n, mut ratio) = (0.0, 0.0, 0.0);
            let mean_ref: f64 =
                refv.iter().map(|v| lum(v.radiance)).sum::<f64>() / refv.len() as f64;
            for (a, b) in d.iter().zip(refv.iter()) {
                let (x, y) = (lum(a.radiance), lum(b.radiance));
                let den = y.max(0.05 * mean_ref);
                se += ((x - y) / den).powi(2);
                n += 1.0;
                ratio += x / den;
            }
            eprintln!(
                "glossy_depth {depth}: {secs:.1}s rays {} | vs {name}: rel RMSE {:.4}, mean ratio {:.4}",
                sol.stats.rays_cast,
                (se / n).sqrt(),
                ratio / n
            );
        }
    }
}
