//! Writing one stage into a bundle: files go to a private temporary folder, and the commit
//! swaps the stage folder and updates the manifest under a lock, so concurrent bakers of
//! different stages keep each other's entries and an interrupted bake changes nothing.

use std::collections::BTreeMap;
use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::manifest::{AssetRecord, Manifest, StageRecord, generator};
use super::{BundleError, MANIFEST, check_relative, read_manifest};

/// Name of the lock file inside a bundle.
const LOCK: &str = ".lock";

static UNIQUE: AtomicU64 = AtomicU64::new(0);

/// A name no other writer (thread or process) uses at the same time.
fn unique_suffix() -> String {
    format!(
        "{}-{}",
        std::process::id(),
        UNIQUE.fetch_add(1, Ordering::Relaxed)
    )
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> BundleError + '_ {
    move |source| BundleError::Io {
        path: path.to_owned(),
        source,
    }
}

/// Writes `bytes` to `path` atomically: a temporary file beside it, flushed, then renamed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), BundleError> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp-{}", unique_suffix()));
    let result = (|| {
        let mut f = File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result.map_err(io(path))
}

/// What a stage records besides its files.
#[derive(Clone, Debug)]
pub struct StageInfo {
    /// Name of the scene baked.
    pub scene_name: String,
    /// Content hash of the scene baked.
    pub scene_hash: String,
    /// Settings used.
    pub settings: serde_json::Value,
    /// Stage-specific figures.
    pub stats: BTreeMap<String, serde_json::Value>,
    /// Wall-clock bake time.
    pub bake_seconds: f64,
    /// Replace stages baked from another scene instead of refusing.
    pub force: bool,
}

/// Collects one stage's files in a temporary folder until [`StageWriter::commit`].
/// Dropped without a commit (an error, Ctrl-C unwinding), it removes its files and the
/// bundle stays as it was.
pub struct StageWriter {
    dir: PathBuf,
    stage: String,
    tmp: PathBuf,
    assets: Vec<AssetRecord>,
    committed: bool,
}

impl StageWriter {
    /// Starts writing `stage` into the bundle at `dir` (created if needed).
    pub fn begin(dir: impl AsRef<Path>, stage: &str) -> Result<StageWriter, BundleError> {
        let dir = dir.as_ref().to_owned();
        check_relative(stage)?;
        if stage.contains('/') || stage.starts_with('.') || stage == MANIFEST {
            return Err(BundleError::BadAssetPath {
                path: stage.into(),
                why: "a stage name is one plain folder name",
            });
        }
        fs::create_dir_all(&dir).map_err(io(&dir))?;
        let tmp = dir.join(format!(".{stage}.tmp-{}", unique_suffix()));
        fs::create_dir(&tmp).map_err(io(&tmp))?;
        Ok(StageWriter {
            dir,
            stage: stage.into(),
            tmp,
            assets: Vec::new(),
            committed: false,
        })
    }

    /// Adds a file at `rel` (relative to the stage folder, `/`-separated) of the given kind.
    pub fn write(&mut self, rel: &str, kind: &str, bytes: &[u8]) -> Result<(), BundleError> {
        check_relative(rel)?;
        let path = format!("{}/{rel}", self.stage);
        if self.assets.iter().any(|a| a.path == path) {
            return Err(BundleError::BadAssetPath {
                path,
                why: "written twice",
            });
        }
        let file = self.tmp.join(rel);
        if let Some(parent) = file.parent() {
            fs::create_dir_all(parent).map_err(io(parent))?;
        }
        fs::write(&file, bytes).map_err(io(&file))?;
        self.assets.push(AssetRecord {
            path,
            kind: kind.into(),
            bytes: bytes.len() as u64,
            blake3: blake3::hash(bytes).to_hex().to_string(),
        });
        Ok(())
    }

    /// The assets written so far.
    pub fn assets(&self) -> &[AssetRecord] {
        &self.assets
    }

    /// Moves the stage's folder into place and records it in the manifest, under the
    /// bundle's lock. Returns the record written.
    pub fn commit(mut self, info: StageInfo) -> Result<StageRecord, BundleError> {
        let lock_path = self.dir.join(LOCK);
        let lock = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&lock_path)
            .map_err(io(&lock_path))?;
        lock.lock().map_err(io(&lock_path))?;

        let mut manifest = match read_manifest(&self.dir)? {
            Some(m) => m,
            None => Manifest::new(&info.scene_name, &info.scene_hash),
        };
        let foreign: Vec<String> = manifest
            .stages
            .iter()
            .filter(|(name, r)| **name != self.stage && r.scene_hash != info.scene_hash)
            .map(|(name, _)| name.clone())
            .collect();
        let replaced_scene = manifest.scene_hash != info.scene_hash
            && manifest
                .stages
                .get(&self.stage)
                .is_some_and(|r| r.scene_hash != info.scene_hash);
        if (!foreign.is_empty() || replaced_scene) && !info.force {
            return Err(BundleError::SceneMismatch {
                dir: self.dir.clone(),
                found: manifest.scene_hash.clone(),
                expected: info.scene_hash.clone(),
            });
        }
        for name in &foreign {
            // --force: stages of another scene are stale; drop them with their files.
            log::warn!(
                "{}: removing stage {name:?} baked from another scene",
                self.dir.display()
            );
            manifest.stages.remove(name);
            let _ = fs::remove_dir_all(self.dir.join(name));
        }

        let target = self.dir.join(&self.stage);
        let old = self
            .dir
            .join(format!(".{}.old-{}", self.stage, unique_suffix()));
        let had_old = target.exists();
        if had_old {
            fs::rename(&target, &old).map_err(io(&target))?;
        }
        if let Err(e) = fs::rename(&self.tmp, &target) {
            if had_old {
                let _ = fs::rename(&old, &target);
            }
            return Err(io(&target)(e));
        }
        self.committed = true;

        let record = StageRecord {
            generator: generator(),
            scene_hash: info.scene_hash.clone(),
            settings: info.settings,
            bake_seconds: info.bake_seconds,
            stats: info.stats,
            assets: std::mem::take(&mut self.assets),
        };
        manifest.stages.insert(self.stage.clone(), record.clone());
        manifest.scene_hash = info.scene_hash;
        manifest.scene_name = info.scene_name;
        manifest.generator = generator();
        let text = serde_json::to_string_pretty(&manifest).expect("manifest serializes");
        if let Err(e) = write_atomic(&self.dir.join(MANIFEST), text.as_bytes()) {
            // Roll back: the old folder goes back with the old manifest.
            let _ = fs::rename(&target, &self.tmp);
            self.committed = false;
            if had_old {
                let _ = fs::rename(&old, &target);
            }
            return Err(e);
        }
        if had_old {
            let _ = fs::remove_dir_all(&old);
        }
        drop(lock);
        Ok(record)
    }
}

impl Drop for StageWriter {
    fn drop(&mut self) {
        if !self.committed {
            let _ = fs::remove_dir_all(&self.tmp);
        }
    }
}
