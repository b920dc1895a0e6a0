//! `cargo bench --bench scale`: how a bake grows with the scene. Generates the building of
//! `scenes/tools/make_building.py` at each size, bakes it stage by stage (each stage a child
//! process: `glint-bake --unit scene`, then `glint-radiosity`, `glint-materials`,
//! `glint-radiance` and `glint-srdm` into one bundle) and prints one table: per stage and size
//! the bake time (wall clock of the child, and its CPU time, user + system: on a shared
//! machine the CPU time is the figure that does not depend on what else runs), its peak RSS (`wait4`'s `ru_maxrss`: the child's own
//! high-water mark) and the bytes of the stage's assets in the bundle (`glint-bundle stats`);
//! and per stage the growth exponent between consecutive sizes, log(cost ratio) / log(triangle
//! ratio). Every figure is measured; nothing is estimated.
//!
//! Environment:
//! - `GLINT_SCALE_SIZES`: comma-separated fractions of the full building (default `1/16,1/4`;
//!   `1/16,1/4,1` adds the full building, about 2M triangles and 96 glossy planar reflectors).
//! - `GLINT_SCALE_QUALITY`: `draft`, `default` (default) or `high`.
//! - `GLINT_SCALE_SEED`: the generator's seed (default 1).
//! - `GLINT_SCALE_DIR`: where scenes and bundles go (default: cargo's target tmp dir, `scale/`);
//!   a size whose bundle is there already is re-baked from scratch.
//! - `GLINT_SCALE_BIN`: a folder holding the `glint-*` binaries to measure (default: this
//!   build's), e.g. a copy taken before rebuilding, so that a long run is not changed under it.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

/// The stages in bake order, with the tool that bakes each (the scene stage through its work
/// unit, so that it runs alone).
const STAGES: [(&str, &str, &[&str]); 5] = [
    (
        "scene",
        env!("CARGO_BIN_EXE_glint-bake"),
        &["--unit", "scene"],
    ),
    ("radiosity", env!("CARGO_BIN_EXE_glint-radiosity"), &[]),
    ("materials", env!("CARGO_BIN_EXE_glint-materials"), &[]),
    ("radiance", env!("CARGO_BIN_EXE_glint-radiance"), &[]),
    ("srdm", env!("CARGO_BIN_EXE_glint-srdm"), &[]),
];

/// One stage's measurements at one size.
#[derive(Clone, Copy, Debug)]
struct Measured {
    seconds: f64,
    /// User + system CPU seconds of the child (all its threads).
    cpu_seconds: f64,
    peak_rss_bytes: u64,
    bundle_bytes: u64,
}

/// One size's bake.
struct SizeRun {
    size: String,
    triangles: u64,
    planar: u64,
    curved: u64,
    impostors: u64,
    lights: u64,
    elements: u64,
    generate_seconds: f64,
    glb_bytes: u64,
    stages: Vec<Option<Measured>>,
}

/// Runs `cmd` to its end; its wall time, CPU time and peak RSS, or its exit status as an error.
#[cfg(unix)]
fn run_measured(cmd: &mut Command) -> Result<(f64, f64, u64), String> {
    let start = Instant::now();
    let child = cmd.spawn().map_err(|e| format!("{cmd:?}: {e}"))?;
    let pid = child.id() as libc::pid_t;
    let mut status: libc::c_int = 0;
    // SAFETY: `rusage` is plain old data, and wait4 writes it; the child is ours and not
    // waited for anywhere else (`child` is dropped without waiting).
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let got = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    let seconds = start.elapsed().as_secs_f64();
    drop(child);
    if got != pid {
        return Err(format!(
            "{cmd:?}: wait4: {}",
            std::io::Error::last_os_error()
        ));
    }
    if !libc::WIFEXITED(status) || libc::WEXITSTATUS(status) != 0 {
        return Err(format!("{cmd:?}: exit status {status:#x}"));
    }
    // Linux and the BSDs give ru_maxrss in KiB; macOS in bytes.
    let unit = if cfg!(target_os = "macos") { 1 } else { 1024 };
    let secs = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    let cpu = secs(usage.ru_utime) + secs(usage.ru_stime);
    Ok((seconds, cpu, usage.ru_maxrss as u64 * unit))
}

/// The binary `built` (this build's path to it), from `GLINT_SCALE_BIN` when that is set.
fn binary(built: &str) -> PathBuf {
    match std::env::var_os("GLINT_SCALE_BIN") {
        Some(dir) => PathBuf::from(dir).join(Path::new(built).file_name().expect("binary name")),
        None => PathBuf::from(built),
    }
}

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn parse_fraction(s: &str) -> f64 {
    let bad = || panic!("GLINT_SCALE_SIZES: {s:?} is not a fraction such as 1/16, 1/4 or 1");
    let value = match s.split_once('/') {
        Some((a, b)) => {
            a.trim().parse::<f64>().unwrap_or_else(|_| bad())
                / b.trim().parse::<f64>().unwrap_or_else(|_| bad())
        }
        None => s.trim().parse::<f64>().unwrap_or_else(|_| bad()),
    };
    if !(value > 0.0 && value <= 1.0) {
        bad();
    }
    value
}

fn json_u64(v: &serde_json::Value, key: &str, what: &str) -> u64 {
    v[key]
        .as_u64()
        .unwrap_or_else(|| panic!("{what}: no integer {key:?} in {v}"))
}

/// Generates, then bakes one size stage by stage.
fn bake_size(size: &str, seed: &str, quality: &str, work: &Path) -> SizeRun {
    let dir = work.join(format!("building-{}", size.replace('/', "_")));
    let _ = std::fs::remove_dir_all(&dir);
    let start = Instant::now();
    let out = Command::new("python3")
        .arg(repo().join("scenes/tools/make_building.py"))
        .arg(&dir)
        .args(["--size", size, "--seed", seed])
        .output()
        .unwrap_or_else(|e| panic!("python3 make_building.py: {e}"));
    assert!(
        out.status.success(),
        "make_building.py --size {size}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let generate_seconds = start.elapsed().as_secs_f64();
    let counts: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("make_building.py prints one JSON line");
    eprintln!("scale {size}: generated in {generate_seconds:.1} s: {counts}");
    let scene = dir.join("scene.json");
    let bundle = dir.join("building.glint");
    let mut stages = Vec::new();
    for (stage, tool, extra) in STAGES {
        let log = std::fs::File::create(dir.join(format!("{stage}.log"))).expect("stage log");
        let mut cmd = Command::new(binary(tool));
        cmd.arg(&scene)
            .args(extra)
            .arg("--bundle")
            .arg(&bundle)
            .args(["--quality", quality])
            .stdin(Stdio::null())
            .stdout(log.try_clone().expect("log handle"))
            .stderr(log);
        eprintln!("scale {size}: stage {stage}…");
        match run_measured(&mut cmd) {
            Ok((seconds, cpu_seconds, rss)) => {
                eprintln!(
                    "scale {size}: stage {stage}: {seconds:.1} s ({cpu_seconds:.1} s CPU), peak RSS {:.0} MiB",
                    rss as f64 / 1048576.0
                );
                stages.push(Some(Measured {
                    seconds,
                    cpu_seconds,
                    peak_rss_bytes: rss,
                    bundle_bytes: 0,
                }));
            }
            Err(e) => {
                eprintln!(
                    "scale {size}: stage {stage} failed: {e} (log: {})",
                    dir.join(format!("{stage}.log")).display()
                );
                stages.push(None);
                break;
            }
        }
    }
    stages.resize(STAGES.len(), None);
    let stats = Command::new(binary(env!("CARGO_BIN_EXE_glint-bundle")))
        .args(["stats", "--json"])
        .arg(&bundle)
        .output()
        .expect("glint-bundle stats");
    let stats: serde_json::Value =
        serde_json::from_slice(&stats.stdout).expect("glint-bundle stats --json prints JSON");
    let stage_json = |name: &str| {
        stats["stages"]
            .as_array()
            .and_then(|a| a.iter().find(|s| s["name"] == name))
            .cloned()
    };
    for ((name, _, _), m) in STAGES.iter().zip(stages.iter_mut()) {
        if let (Some(m), Some(s)) = (m.as_mut(), stage_json(name)) {
            m.bundle_bytes = json_u64(&s["total"], "bytes", "glint-bundle stats");
        }
    }
    let scene_stats = stage_json("scene").map(|s| s["stats"].clone());
    let from_scene = |key: &str| {
        scene_stats
            .as_ref()
            .map_or(0, |s| json_u64(s, key, "scene stage"))
    };
    let elements =
        stage_json("radiosity").map_or(0, |s| json_u64(&s["stats"], "elements", "radiosity stage"));
    let reflectors = from_scene("reflectors");
    let planar = json_u64(&counts, "planar_reflectors", "make_building.py");
    SizeRun {
        size: size.to_string(),
        triangles: from_scene("triangles"),
        planar,
        curved: reflectors.saturating_sub(planar),
        impostors: from_scene("impostors"),
        lights: from_scene("area_lights"),
        elements,
        generate_seconds,
        glb_bytes: json_u64(&counts, "glb_bytes", "make_building.py"),
        stages,
    }
}

fn mib(b: u64) -> String {
    format!("{:.1}", b as f64 / 1048576.0)
}

/// log(b / a) / log(nb / na), or "—" where either cost is missing or zero.
fn exponent(a: Option<f64>, b: Option<f64>, na: u64, nb: u64) -> String {
    match (a, b) {
        (Some(a), Some(b)) if a > 0.0 && b > 0.0 && nb != na => {
            format!("{:.2}", (b / a).ln() / (nb as f64 / na as f64).ln())
        }
        _ => "—".into(),
    }
}

fn print_table(runs: &[SizeRun], quality: &str) {
    println!("\nscale bench ({quality} quality): the building of scenes/tools/make_building.py");
    println!(
        "{:<6} {:>10} {:>7} {:>7} {:>9} {:>7} {:>10} {:>9} {:>9}",
        "size",
        "triangles",
        "planar",
        "curved",
        "impostors",
        "lights",
        "elements",
        "glb MiB",
        "gen s"
    );
    for r in runs {
        println!(
            "{:<6} {:>10} {:>7} {:>7} {:>9} {:>7} {:>10} {:>9} {:>9.1}",
            r.size,
            r.triangles,
            r.planar,
            r.curved,
            r.impostors,
            r.lights,
            r.elements,
            mib(r.glb_bytes),
            r.generate_seconds
        );
    }
    println!(
        "\n{:<10} {:<6} {:>10} {:>10} {:>14} {:>12}",
        "stage", "size", "time s", "CPU s", "peak RSS MiB", "bundle MiB"
    );
    for (k, (stage, _, _)) in STAGES.iter().enumerate() {
        for r in runs {
            match r.stages[k] {
                Some(m) => println!(
                    "{:<10} {:<6} {:>10.1} {:>10.1} {:>14} {:>12}",
                    stage,
                    r.size,
                    m.seconds,
                    m.cpu_seconds,
                    mib(m.peak_rss_bytes),
                    mib(m.bundle_bytes)
                ),
                None => println!(
                    "{:<10} {:<6} {:>10} {:>10} {:>14} {:>12}",
                    stage, r.size, "failed", "—", "—", "—"
                ),
            }
        }
    }
    if runs.len() < 2 {
        return;
    }
    println!("\ngrowth exponent d log(cost) / d log(triangles) between consecutive sizes");
    println!(
        "{:<10} {:<11} {:>6} {:>6} {:>9} {:>7}",
        "stage", "sizes", "time", "CPU", "peak RSS", "bundle"
    );
    for (k, (stage, _, _)) in STAGES.iter().enumerate() {
        for w in runs.windows(2) {
            let (a, b) = (&w[0], &w[1]);
            let get = |r: &SizeRun, f: fn(&Measured) -> f64| r.stages[k].as_ref().map(f);
            println!(
                "{:<10} {:<11} {:>6} {:>6} {:>9} {:>7}",
                stage,
                format!("{}→{}", a.size, b.size),
                exponent(
                    get(a, |m| m.seconds),
                    get(b, |m| m.seconds),
                    a.triangles,
                    b.triangles
                ),
                exponent(
                    get(a, |m| m.cpu_seconds),
                    get(b, |m| m.cpu_seconds),
                    a.triangles,
                    b.triangles
                ),
                exponent(
                    get(a, |m| m.peak_rss_bytes as f64),
                    get(b, |m| m.peak_rss_bytes as f64),
                    a.triangles,
                    b.triangles
                ),
                exponent(
                    get(a, |m| m.bundle_bytes as f64),
                    get(b, |m| m.bundle_bytes as f64),
                    a.triangles,
                    b.triangles
                ),
            );
        }
    }
}

fn main() {
    // `cargo bench` passes `--bench`; a filter argument is not used.
    let sizes = std::env::var("GLINT_SCALE_SIZES").unwrap_or_else(|_| "1/16,1/4".into());
    let quality = std::env::var("GLINT_SCALE_QUALITY").unwrap_or_else(|_| "default".into());
    let seed = std::env::var("GLINT_SCALE_SEED").unwrap_or_else(|_| "1".into());
    let work = std::env::var_os("GLINT_SCALE_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("scale"));
    std::fs::create_dir_all(&work).unwrap_or_else(|e| panic!("{}: {e}", work.display()));
    let mut sizes: Vec<(f64, String)> = sizes
        .split(',')
        .map(|s| (parse_fraction(s), s.trim().to_string()))
        .collect();
    sizes.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut runs = Vec::new();
    for (_, size) in &sizes {
        runs.push(bake_size(size, &seed, &quality, &work));
        // Print as we go: the full building takes long.
        print_table(&runs, &quality);
    }
}
