//! The long fuzz run: `cargo bench --bench fuzz -- [TARGET…] [--execs N] [--seed S]
//! [--timeout SECS] [--max-minutes M]`. Runs the named targets (all by default) one after
//! another, prints a table of executions, distinct crashes and executions per second, and
//! writes each crash's input to `target/fuzz-crashes/<target>/`. Exits 1 when anything
//! crashed.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use glint::fuzz::{RunConfig, driver};

#[global_allocator]
static ALLOC: glint::fuzz::LimitAlloc = glint::fuzz::LimitAlloc;

fn main() {
    let mut names = Vec::new();
    let mut config = RunConfig {
        execs: 1_000_000,
        max_time: Duration::from_secs(24 * 3600),
        input_timeout: Duration::from_secs(5),
        seed: 0x5eed_f022,
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = |flag: &str| -> f64 {
            args.next()
                .and_then(|v| v.parse().ok())
                .unwrap_or_else(|| usage(&format!("{flag} needs a number")))
        };
        match a.as_str() {
            "--bench" => {}
            "--execs" => config.execs = value("--execs") as u64,
            "--seed" => config.seed = value("--seed") as u64,
            "--timeout" => config.input_timeout = Duration::from_secs_f64(value("--timeout")),
            "--max-minutes" => {
                config.max_time = Duration::from_secs_f64(60.0 * value("--max-minutes"))
            }
            "-h" | "--help" => usage(""),
            s if s.starts_with('-') => usage(&format!("unknown flag {s}")),
            s => names.push(s.to_string()),
        }
    }
    let targets: Vec<_> = if names.is_empty() {
        glint::fuzz::TARGETS.iter().collect()
    } else {
        names
            .iter()
            .map(|n| glint::fuzz::target(n).unwrap_or_else(|| usage(&format!("no target {n}"))))
            .collect()
    };
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let crash_dir = repo.join("target").join("fuzz-crashes");
    println!(
        "{:<16} {:>10} {:>10} {:>8} {:>10}",
        "target", "execs", "rejected", "crashes", "execs/s"
    );
    let mut crashed = false;
    for t in targets {
        // A memory file system when there is one: some targets write their input to a file.
        let shm = Path::new("/dev/shm");
        let tmp = if shm.is_dir() {
            shm.to_owned()
        } else {
            std::env::temp_dir()
        };
        let scratch = tmp.join(format!("glint-fuzz-{}-{}", std::process::id(), t.name));
        let ctx = (t.prepare)(repo, &scratch).unwrap_or_else(|e| fail(t.name, &e));
        let seeds = glint::fuzz::seeds(repo, t).unwrap_or_else(|e| fail(t.name, &e));
        let report = driver::run(t, Arc::new(ctx), &seeds, &config);
        let _ = std::fs::remove_dir_all(&scratch);
        println!(
            "{:<16} {:>10} {:>10} {:>8} {:>10.0}",
            t.name,
            report.execs,
            report.rejected,
            report.crashes.len(),
            report.execs_per_sec()
        );
        for c in &report.crashes {
            crashed = true;
            let path = save(&crash_dir.join(t.name), &c.input);
            println!("  {} ({} hits) → {}", c.message, c.hits, path.display());
        }
    }
    if crashed {
        std::process::exit(1);
    }
}

/// Writes a crash input under `dir`, named by its BLAKE3.
fn save(dir: &Path, input: &[u8]) -> PathBuf {
    let path = dir.join(format!("{}.bin", &blake3::hash(input).to_hex()[..16]));
    let _ = std::fs::create_dir_all(dir);
    let _ = std::fs::write(&path, input);
    path
}

fn fail(target: &str, e: &str) -> ! {
    eprintln!("error: target {target}: {e}");
    std::process::exit(2)
}

fn usage(problem: &str) -> ! {
    if !problem.is_empty() {
        eprintln!("error: {problem}");
    }
    eprintln!(
        "usage: cargo bench --bench fuzz -- [TARGET…] [--execs N] [--seed S] [--timeout SECS] [--max-minutes M]"
    );
    eprintln!("targets:");
    for t in glint::fuzz::TARGETS {
        eprintln!("  {:<16} {}", t.name, t.about);
    }
    std::process::exit(if problem.is_empty() { 0 } else { 2 })
}
