//! Fuzz targets for every loader, and a stable, dependency-free fuzz loop to drive them.
//!
//! A target takes bytes as a file would hold them and runs the loader that reads that file
//! (plus, when the loader accepts, the first use a reader makes of the result). The contract
//! under test: a loader returns an error on a bad file; it never panics, hangs or asks for an
//! absurd allocation.
//!
//! - [`TARGETS`]: the targets, by name.
//! - [`driver`]: the loop (seeds first, then stacked mutations from [`mutate`]; each input
//!   under `catch_unwind`, a watchdog for hangs).
//! - [`alloc_limit`]: a global allocator for fuzz binaries that stops at an absurd allocation
//!   with the input saved.
//!
//! Seeds live in `fuzz/corpus/<target>/`, crashers once fixed in `fuzz/regressions/<target>/`.
//! `tests/fuzz.rs` runs every target briefly (all seeds and regressions, then a few thousand
//! mutants); `cargo bench --bench fuzz -- [TARGET] [--execs N]` is the long run.

pub mod alloc_limit;
pub mod driver;
pub mod mutate;
mod targets;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub use alloc_limit::LimitAlloc;
pub use driver::{Crash, RunConfig, RunReport};
pub use targets::TARGETS;

/// What a target reads besides its input: a scratch folder of its own and fixture files.
#[derive(Debug, Default)]
pub struct TargetContext {
    /// A folder the target may write (for loaders that read from disk).
    pub scratch: PathBuf,
    /// Fixture files by name (e.g. the EXR files a materials index points at).
    pub files: BTreeMap<String, Vec<u8>>,
}

/// One fuzz target.
pub struct Target {
    /// Name: the corpus folder `fuzz/corpus/<name>/`.
    pub name: &'static str,
    /// The loader it exercises.
    pub about: &'static str,
    /// Makes the context from the repository root and a fresh scratch folder.
    pub prepare: fn(repo: &Path, scratch: &Path) -> Result<TargetContext, String>,
    /// Runs one input: `Err` when the loader rejects it (fine), a panic is a crash.
    pub run: fn(&TargetContext, &[u8]) -> Result<(), String>,
}

/// The target named `name`.
pub fn target(name: &str) -> Option<&'static Target> {
    TARGETS.iter().find(|t| t.name == name)
}

/// Every file of `dir`, sorted by name (none when it does not exist).
pub fn read_dir_files(dir: &Path) -> Result<Vec<(PathBuf, Vec<u8>)>, String> {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(format!("{}: {e}", dir.display())),
    };
    let mut paths: Vec<PathBuf> = entries
        .map(|e| e.map(|e| e.path()))
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{}: {e}", dir.display()))?;
    paths.retain(|p| p.is_file());
    paths.sort();
    paths
        .into_iter()
        .map(|p| {
            let bytes = std::fs::read(&p).map_err(|e| format!("{}: {e}", p.display()))?;
            Ok((p, bytes))
        })
        .collect()
}

/// The seeds of `target`: its corpus, then its regression inputs (`fuzz/corpus/<name>/`,
/// `fuzz/regressions/<name>/` under `repo`).
pub fn seeds(repo: &Path, target: &Target) -> Result<Vec<Vec<u8>>, String> {
    let fuzz = repo.join("fuzz");
    let mut out: Vec<Vec<u8>> = read_dir_files(&fuzz.join("corpus").join(target.name))?
        .into_iter()
        .map(|(_, b)| b)
        .collect();
    out.extend(
        read_dir_files(&fuzz.join("regressions").join(target.name))?
            .into_iter()
            .map(|(_, b)| b),
    );
    if out.is_empty() {
        return Err(format!(
            "{}: no seed inputs for target {}",
            fuzz.join("corpus").join(target.name).display(),
            target.name
        ));
    }
    Ok(out)
}
