//! Radiosity presets on the speed-for-accuracy curve: per scene and preset, the target error, bake
//! time (atlas with its contact boosts + solve + seam stitching) in wall and CPU seconds (the CPU
//! seconds compare runs on a shared machine), rays, peak memory, the solver's own error estimate,
//! and the error of D against ground truth: D path-traced at 400 probes on the diffuse faces with
//! every transport path (`glint::eval::reference::trace_probes`; `GLINT_BENCH_PATHS` paths each,
//! default 4096), whose own noise is printed beside it, taken out, and the same error over the
//! probes at least half a default texel away from other surfaces. With `--converged`, also the RMS
//! relative error of the texels against a converged solve of the same texels (4096 rays, 1024 light
//! samples, 64 bounces, another seed).
//!
//! After the presets, where the default preset's bake time goes per scene: the atlas, the
//! contact probes that boost its charts, the first gathering, the refinement rounds, the
//! Jacobi bounces, seam stitching and the stage's I/O (encoding and writing its pages).
//!
//! With `--anchors FILE.json` (from `benches/anchors/cycles_bake.py`: another renderer's D at
//! the same probes, with its seconds), each anchor run is scored against the same truth and
//! the two error-against-seconds curves are printed side by side.
//!
//! `cargo bench --bench radiosity [-- [--converged] [--presets draft,default,high]
//! [--anchors FILE.json ...] SCENE.json ...]` (default: the four shipped scenes, every preset).

#[path = "common/cpu_time.rs"]
mod cpu_time;

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use glam::Vec3;
use glint::bundle::stats::{format_table, human_bytes};
use glint::eval::probe::{
    ProbeValue, clearance, compare_probes, default_reach, diffuse_points, probe,
};
use glint::eval::reference::{ProbeTraceOptions, trace_probes};
use glint::progress::{Progress, Silent};
use glint::radiosity::solve::{SolveSettings, solve};
use glint::radiosity::{RadiosityMap, atlas, contacts, seams};
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

/// Wall time per solver phase, from the phases the solver announces: each lasts until the
/// next one begins (or [`PhaseClock::stop`]), and phases of one name add up.
#[derive(Default)]
struct PhaseClock {
    state: Mutex<ClockState>,
}

/// (phase, seconds, times entered) in first-seen order.
type Phases = Vec<(String, f64, u32)>;

/// The current phase and when it began, and the phases closed so far.
type ClockState = (Option<(String, Instant)>, Phases);

impl PhaseClock {
    fn close(state: &mut ClockState) {
        if let Some((name, since)) = state.0.take() {
            let secs = since.elapsed().as_secs_f64();
            match state.1.iter_mut().find(|(n, _, _)| *n == name) {
                Some(e) => {
                    e.1 += secs;
                    e.2 += 1;
                }
                None => state.1.push((name, secs, 1)),
            }
        }
    }

    /// Ends the current phase; returns (phase, seconds, times entered) in first-seen order.
    fn stop(&self) -> Phases {
        let mut state = self.state.lock().unwrap();
        Self::close(&mut state);
        state.1.clone()
    }
}

impl Progress for PhaseClock {
    fn phase(&self, name: &str, _total: u64) {
        let mut state = self.state.lock().unwrap();
        Self::close(&mut state);
        state.0 = Some((name.to_string(), Instant::now()));
    }
    fn advance(&self, _n: u64) {}
}

/// Seconds to encode the stage's files for `radiance` (EXR and preview PNG per page, the
/// atlas) and write them to a temporary folder, as the radiosity stage does.
fn write_stage(atlas: &atlas::Atlas, radiance: &[Vec3]) -> f64 {
    let t = Instant::now();
    let dir = tempfile::tempdir().unwrap();
    let mut offset = 0usize;
    for (i, page) in atlas.pages.iter().enumerate() {
        let n = (page.width * page.height) as usize;
        let texels = &radiance[offset..offset + n];
        offset += n;
        let exr =
            glint::image_io::encode_rgb_exr(page.width as usize, page.height as usize, texels)
                .unwrap();
        std::fs::write(dir.path().join(format!("page{i}.exr")), exr).unwrap();
        let png = glint::image_io::encode_png(
            page.width,
            page.height,
            &glint::image_io::tonemap_preview(texels),
            false,
        )
        .unwrap();
        std::fs::write(dir.path().join(format!("page{i}.png")), png).unwrap();
    }
    std::fs::write(
        dir.path().join("atlas.bin"),
        glint::radiosity::format::encode(atlas),
    )
    .unwrap();
    t.elapsed().as_secs_f64()
}

/// Another renderer's bakes of one scene, scored on the bench's probes
/// (`benches/anchors/cycles_bake.py` writes them).
#[derive(serde::Deserialize)]
struct Anchors {
    scene: String,
    renderer: String,
    threads: u32,
    runs: Vec<AnchorRun>,
}

/// One bake of an anchor: its lightmap's density (texels per scene unit) and texel count,
/// samples per texel, wall and CPU seconds, and D at the probes.
#[derive(serde::Deserialize)]
struct AnchorRun {
    density: f64,
    texels: u64,
    samples: u32,
    seconds: f64,
    cpu_seconds: f64,
    probes: Vec<ProbeValue>,
}

fn read_anchors(path: &str) -> Anchors {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("--anchors {path}: {e}"));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("--anchors {path}: {e}"))
}

/// The anchor's seconds at relative error `error`: log-log interpolation between the runs on
/// its fastest-for-error front; beyond its ends, seconds ∝ error⁻² (a path tracer's noise
/// falls as 1/√samples), marked "≈".
fn anchor_seconds_at(front: &[(f64, f64)], error: f64) -> Option<(f64, bool)> {
    let (first, last) = (front.first()?, front.last()?);
    if error >= first.0 {
        return Some((first.1 * (first.0 / error).powi(2), error > first.0));
    }
    if error <= last.0 {
        return Some((last.1 * (last.0 / error).powi(2), error < last.0));
    }
    let k = front
        .windows(2)
        .position(|w| error <= w[0].0 && error >= w[1].0)?;
    let ((e0, s0), (e1, s1)) = (front[k], front[k + 1]);
    let t = (error.ln() - e0.ln()) / (e1.ln() - e0.ln());
    Some(((s0.ln() + t * (s1.ln() - s0.ln())).exp(), false))
}

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
    let mut presets: Vec<Quality> = Quality::ALL.to_vec();
    let mut anchors: Vec<(String, Anchors)> = Vec::new();
    let mut scenes: Vec<String> = Vec::new();
    let mut it = args.into_iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--converged" => {}
            "--presets" => {
                let list = it
                    .next()
                    .expect("--presets needs a list, e.g. draft,default");
                presets = list
                    .split(',')
                    .map(|p| {
                        Quality::ALL
                            .into_iter()
                            .find(|q| q.name() == p)
                            .unwrap_or_else(|| panic!("--presets: unknown preset {p:?}"))
                    })
                    .collect();
            }
            "--anchors" => {
                let file = it.next().expect("--anchors needs a JSON file");
                let a = read_anchors(&file);
                anchors.push((file, a));
            }
            flag if flag.starts_with("--") => panic!("unknown flag {flag}"),
            _ => scenes.push(a),
        }
    }
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
        "CPU s".into(),
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
    let breakdown_header = [
        "scene".to_string(),
        "atlas".into(),
        "contact probes".into(),
        "gathering".into(),
        "refinement (rounds)".into(),
        "bounces (runs)".into(),
        "seams".into(),
        "I/O".into(),
        "total s".into(),
        "seams share".into(),
    ];
    let mut breakdown = vec![breakdown_header];
    let curve_header = [
        "scene".to_string(),
        "renderer".into(),
        "setting".into(),
        "vs truth RMSE".into(),
        "seconds".into(),
        "CPU s".into(),
        "anchor CPU s at this error".into(),
        "glint faster".into(),
    ];
    let mut curves = vec![curve_header];
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
        // This scene's glint points (error, seconds) for the anchor curves.
        let mut glint_curve: Vec<(String, f64, f64, f64)> = Vec::new();
        for &q in &presets {
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
            let cpu = cpu_time::cpu_seconds();
            // The stage's atlas: the rule's, with the preset's contact boosts (as
            // `contacts::build`, a step at a time for the breakdown).
            let rule = glint::bake::radiosity_stage::density_rule(&scene, &s)
                .unwrap()
                .rule;
            let (first, first_samples) = atlas::build_with(&scene.triangles, rule).unwrap();
            let t_atlas = t.elapsed().as_secs_f64();
            let boosts = contacts::boosts(&scene, &bvh, &first, &first_samples, s.contact_boost);
            let t_probes = t.elapsed().as_secs_f64() - t_atlas;
            let (atlas, samples) = if boosts.charts == 0 {
                (first, first_samples)
            } else {
                drop((first, first_samples));
                atlas::build_boosted(&scene.triangles, rule, &boosts.per_chart).unwrap()
            };
            let t_atlas = t.elapsed().as_secs_f64() - t_probes;
            let clock = PhaseClock::default();
            let mut sol = solve(&scene, &bvh, &atlas, &samples, &set, &clock).unwrap();
            let phases = clock.stop();
            let t_seams = Instant::now();
            if s.stitch_seams {
                seams::stitch_seams(&scene.triangles, &atlas, &samples, &mut sol.radiance);
            }
            let t_seams = t_seams.elapsed().as_secs_f64();
            let secs = t.elapsed().as_secs_f64();
            let cpu = cpu_time::cpu_seconds() - cpu;
            let t_io = write_stage(&atlas, &sol.radiance);
            if q == Quality::Default {
                let phase = |name: &str| {
                    phases
                        .iter()
                        .find(|(n, _, _)| n == name)
                        .map_or((0.0, 0), |(_, s, k)| (*s, *k))
                };
                let (refine, rounds) = phase("refining");
                let (bounce, runs) = phase("bouncing");
                let total = secs + t_io;
                let row = [
                    scene.name.clone(),
                    format!("{t_atlas:.2}"),
                    format!("{t_probes:.2}"),
                    format!("{:.2}", phase("gathering").0),
                    format!("{refine:.2} ({rounds})"),
                    format!("{bounce:.2} ({runs})"),
                    format!("{t_seams:.2}"),
                    format!("{t_io:.2}"),
                    format!("{total:.2}"),
                    format!("{:.1}%", 100.0 * t_seams / total),
                ];
                eprintln!("breakdown: {}", row.join(" | "));
                breakdown.push(row);
            }
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
            glint_curve.push((q.name().into(), m.rel_rmse, secs, cpu));
            let row = [
                scene.name.clone(),
                q.name().into(),
                s.target_error.map_or("-".into(), |t| pct(t as f64)),
                st.elements.to_string(),
                s.rays.to_string(),
                format!("{:.1}", st.rays_cast as f64 / 1e6),
                format!("{secs:.2}"),
                format!("{cpu:.2}"),
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
        for (file, a) in anchors.iter().filter(|(_, a)| a.scene == scene.name) {
            let mut scored: Vec<(String, f64, f64, f64)> = a
                .runs
                .iter()
                .map(|run| {
                    assert_eq!(
                        run.probes.len(),
                        points.len(),
                        "--anchors {file}: probes are not the bench's (make them with `glint-eval probe-points {path} --count 400 --seed 1`)"
                    );
                    for (k, (v, p)) in run.probes.iter().zip(&points).enumerate() {
                        assert_eq!(
                            v.position, p.position,
                            "--anchors {file}: probe {k} is not the bench's (make them with `glint-eval probe-points {path} --count 400 --seed 1`)"
                        );
                    }
                    let m = compare_probes(&run.probes, &truth).unwrap();
                    let setting = format!(
                        "{} texels/unit ({} texels), {} samples",
                        run.density, run.texels, run.samples
                    );
                    (setting, m.rel_rmse, run.seconds, run.cpu_seconds)
                })
                .collect();
            // CPU seconds, both sides: on a shared machine the load moves wall time more.
            scored.sort_by(|x, y| x.3.total_cmp(&y.3));
            // The fastest-for-error front, by falling error.
            let mut front: Vec<(f64, f64)> = Vec::new();
            for &(_, e, _, cpu) in &scored {
                if front.last().is_none_or(|l| e < l.0) {
                    front.push((e, cpu));
                }
            }
            let renderer = format!("{} ({} threads)", a.renderer, a.threads);
            for (setting, e, secs, cpu) in &glint_curve {
                let at = anchor_seconds_at(&front, *e);
                curves.push([
                    scene.name.clone(),
                    "glint".into(),
                    setting.clone(),
                    format!("{:.2}%", 100.0 * e),
                    format!("{secs:.2}"),
                    format!("{cpu:.2}"),
                    at.map_or("-".into(), |(s, guess)| {
                        format!("{}{s:.1}", if guess { "≈" } else { "" })
                    }),
                    at.map_or("-".into(), |(s, _)| format!("{:.1}×", s / cpu)),
                ]);
            }
            for (setting, e, secs, cpu) in scored {
                curves.push([
                    scene.name.clone(),
                    renderer.clone(),
                    setting,
                    format!("{:.2}%", 100.0 * e),
                    format!("{secs:.2}"),
                    format!("{cpu:.2}"),
                    "-".into(),
                    "-".into(),
                ]);
            }
        }
    }
    println!(
        "Radiosity presets ({} threads): D against path-traced probes (400 per scene on diffuse faces, {paths} paths each, every transport path).\n\
         noise-free: the RMSE with the probes' own noise taken out in quadrature; off edges: the RMSE over the probes (count) at least half a default texel from any other surface\n",
        rayon::current_num_threads(),
    );
    let right = std::array::from_fn(|i| i >= 2);
    print!("{}", format_table(&rows, &right));
    if breakdown.len() > 1 {
        println!(
            "\nWhere the default preset's time goes (seconds; a solver phase runs until the next begins: gathering includes packing the rays into links, bounces include the error estimate after each run):\n"
        );
        let right = std::array::from_fn(|i| i >= 1);
        print!("{}", format_table(&breakdown, &right));
    }
    if curves.len() > 1 {
        println!(
            "\nError against seconds, glint's presets beside the anchors' bakes (same probes, same truth; glint's seconds: atlas, solve and seams; the anchor's CPU seconds at glint's error interpolated log-log on its front, ≈ extrapolated as error⁻², and the ratio taken on CPU seconds):\n"
        );
        let right = std::array::from_fn(|i| i >= 3);
        print!("{}", format_table(&curves, &right));
    }
}
