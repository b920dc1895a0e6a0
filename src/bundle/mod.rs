//! The asset bundle: a folder `NAME.glint/` with `manifest.json` and one folder per stage.
//!
//! Layout (format version 1):
//! ```text
//! NAME.glint/
//!   manifest.json      format, version, generator, scene hash, stages → settings, time, assets
//!   .lock              held while a stage commits (two bakers may share a bundle)
//!   radiosity/ …       one folder per stage, replaced whole when the stage is re-baked
//! ```
//! Every file is written to a temporary name and renamed into place, so an interrupted bake
//! leaves the bundle as it was.

pub mod manifest;
mod names;
pub mod stats;
mod writer;

use std::fs::File;
use std::path::{Path, PathBuf};

use rayon::prelude::*;

pub use manifest::{
    AssetRecord, FORMAT_NAME, FORMAT_VERSION, FormatVersion, Manifest, StageRecord,
};
pub use names::{folder_name, unique_folders};
pub use writer::{StageInfo, StageWriter, write_atomic};

/// File name of the manifest inside a bundle.
pub const MANIFEST: &str = "manifest.json";

/// Why a bundle cannot be read or written. Messages name the bundle or file.
#[derive(Debug, thiserror::Error)]
pub enum BundleError {
    /// A file operation failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// No manifest: not a bundle (or never finished).
    #[error("{}: not a glint bundle: {MANIFEST} is missing", dir.display())]
    MissingManifest {
        /// The bundle folder.
        dir: PathBuf,
    },
    /// The manifest is not valid JSON or lacks required fields.
    #[error("{}: corrupt manifest: {message}", path.display())]
    Corrupt {
        /// The manifest.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The bundle was written by a newer, incompatible glint.
    #[error(
        "{}: bundle format version {found} is newer than this glint reads ({supported}); update glint or re-bake",
        path.display()
    )]
    NewerVersion {
        /// The manifest.
        path: PathBuf,
        /// Version in the manifest.
        found: String,
        /// Version this build writes.
        supported: String,
    },
    /// A baker would mix stages of two different scenes.
    #[error(
        "{}: holds stages baked from another scene (hash {found:.12}…, this scene {expected:.12}…); pass --force to replace them",
        dir.display()
    )]
    SceneMismatch {
        /// The bundle folder.
        dir: PathBuf,
        /// The bundle's scene hash.
        found: String,
        /// The scene being baked.
        expected: String,
    },
    /// A stage name or asset path that would leave its folder.
    #[error("invalid asset path {path:?}: {why}")]
    BadAssetPath {
        /// The path as given.
        path: String,
        /// Why.
        why: &'static str,
    },
    /// An asset listed in the manifest is missing or differs from its record.
    #[error("{}: {problem}", path.display())]
    Asset {
        /// The asset file.
        path: PathBuf,
        /// Missing, or which of size and hash differ.
        problem: String,
    },
}

/// An opened bundle whose manifest was read and checked.
#[derive(Debug)]
pub struct Bundle {
    dir: PathBuf,
    manifest: Manifest,
}

impl Bundle {
    /// Opens a bundle: reads the manifest and checks its format and version.
    /// Asset hashes are checked by [`Bundle::verify`].
    pub fn open(dir: impl AsRef<Path>) -> Result<Bundle, BundleError> {
        let dir = dir.as_ref().to_owned();
        let manifest = read_manifest(&dir)?
            .ok_or_else(|| BundleError::MissingManifest { dir: dir.clone() })?;
        Ok(Bundle { dir, manifest })
    }

    /// The bundle folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The manifest.
    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    /// A stage's record, if the bundle has that stage.
    pub fn stage(&self, name: &str) -> Option<&StageRecord> {
        self.manifest.stages.get(name)
    }

    /// The file system path of an asset.
    pub fn asset_path(&self, asset: &AssetRecord) -> PathBuf {
        self.dir.join(&asset.path)
    }

    /// Checks that every asset exists with its recorded size and BLAKE3 hash.
    /// Returns every problem found (empty: the bundle is intact).
    pub fn verify(&self) -> Vec<BundleError> {
        let assets: Vec<&AssetRecord> = self.manifest.assets().map(|(_, a)| a).collect();
        assets
            .par_iter()
            .filter_map(|a| self.verify_asset(a).err())
            .collect()
    }

    /// Checks one asset against its record.
    pub fn verify_asset(&self, asset: &AssetRecord) -> Result<(), BundleError> {
        let path = self.asset_path(asset);
        let problem = |problem: String| BundleError::Asset {
            path: path.clone(),
            problem,
        };
        check_relative(&asset.path)?;
        let file = File::open(&path).map_err(|e| problem(format!("cannot be read: {e}")))?;
        let bytes = file.metadata().map(|m| m.len()).unwrap_or(0);
        if bytes != asset.bytes {
            return Err(problem(format!(
                "size is {bytes} bytes, the manifest records {}",
                asset.bytes
            )));
        }
        let mut hasher = blake3::Hasher::new();
        hasher
            .update_reader(file)
            .map_err(|e| problem(format!("cannot be read: {e}")))?;
        let found = hasher.finalize().to_hex();
        if found.as_str() != asset.blake3 {
            return Err(problem(format!(
                "BLAKE3 is {}, the manifest records {} (the file changed after the bake)",
                found, asset.blake3
            )));
        }
        Ok(())
    }

    /// The record of stage `stage`'s asset `rel` (a path inside the stage's folder, e.g.
    /// `Floor/cameras.json`). Readers find assets through this and [`Bundle::read_asset`],
    /// never by joining paths onto [`Bundle::dir`]: where a stage's files lie on disk is
    /// the bundle's business.
    pub fn stage_asset(&self, stage: &str, rel: &str) -> Result<&AssetRecord, BundleError> {
        let logical = format!("{stage}/{rel}");
        let record = self.stage(stage).ok_or_else(|| BundleError::Asset {
            path: self.dir.join(&logical),
            problem: format!("the bundle has no `{stage}` stage"),
        })?;
        record
            .assets
            .iter()
            .find(|a| a.path == logical)
            .ok_or_else(|| BundleError::Asset {
                path: self.dir.join(&logical),
                problem: format!("not listed in the manifest's `{stage}` stage"),
            })
    }

    /// Reads stage `stage`'s asset `rel`, checking it against the manifest
    /// ([`Bundle::stage_asset`] then [`Bundle::read_asset`]).
    pub fn read_stage_file(&self, stage: &str, rel: &str) -> Result<Vec<u8>, BundleError> {
        let asset = self.stage_asset(stage, rel)?;
        self.read_asset(asset)
    }

    /// Reads an asset, checking its hash.
    pub fn read_asset(&self, asset: &AssetRecord) -> Result<Vec<u8>, BundleError> {
        let path = self.asset_path(asset);
        let bytes = std::fs::read(&path).map_err(|source| BundleError::Io {
            path: path.clone(),
            source,
        })?;
        let found = blake3::hash(&bytes).to_hex();
        if found.as_str() != asset.blake3 {
            return Err(BundleError::Asset {
                path,
                problem: format!("BLAKE3 is {found}, the manifest records {}", asset.blake3),
            });
        }
        Ok(bytes)
    }
}

/// Refuses early (before a long bake) when the bundle at `dir` holds stages of another
/// scene and `force` is not set. A missing bundle is fine.
pub fn check_scene(dir: &Path, scene_hash: &str, force: bool) -> Result<(), BundleError> {
    let Some(m) = read_manifest(dir)? else {
        return Ok(());
    };
    if !force && m.stages.values().any(|s| s.scene_hash != scene_hash) {
        return Err(BundleError::SceneMismatch {
            dir: dir.to_owned(),
            found: m.scene_hash,
            expected: scene_hash.to_owned(),
        });
    }
    Ok(())
}

/// Reads and checks `dir/manifest.json`; `Ok(None)` when there is none.
pub(crate) fn read_manifest(dir: &Path) -> Result<Option<Manifest>, BundleError> {
    let path = dir.join(MANIFEST);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => return Err(BundleError::Io { path, source }),
    };
    let corrupt = |message: String| BundleError::Corrupt {
        path: path.clone(),
        message,
    };
    // Check format and version before the full parse: a newer major may have changed fields.
    let value: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| corrupt(e.to_string()))?;
    let format = value.get("format").and_then(|v| v.as_str());
    if format != Some(FORMAT_NAME) {
        return Err(corrupt(format!(
            "field `format` is {}, expected {FORMAT_NAME:?}",
            format.map_or("missing".to_string(), |f| format!("{f:?}"))
        )));
    }
    let version_text = value
        .get("format_version")
        .and_then(|v| v.as_str())
        .ok_or_else(|| corrupt("field `format_version` is missing".into()))?;
    let version: FormatVersion = version_text
        .parse()
        .map_err(|e| corrupt(format!("field `format_version`: {e}")))?;
    if version.major > FORMAT_VERSION.major {
        return Err(BundleError::NewerVersion {
            path,
            found: version_text.into(),
            supported: FORMAT_VERSION.to_string(),
        });
    }
    if version.major < FORMAT_VERSION.major {
        return Err(corrupt(format!(
            "format version {version} predates {FORMAT_VERSION}; re-bake the bundle"
        )));
    }
    let manifest: Manifest = serde_json::from_value(value).map_err(|e| corrupt(e.to_string()))?;
    for (_, a) in manifest.assets() {
        check_relative(&a.path).map_err(|e| corrupt(e.to_string()))?;
    }
    Ok(Some(manifest))
}

/// An asset path must be relative, `/`-separated and stay inside the bundle.
fn check_relative(path: &str) -> Result<(), BundleError> {
    let bad = |why| {
        Err(BundleError::BadAssetPath {
            path: path.into(),
            why,
        })
    };
    if path.is_empty() {
        return bad("empty");
    }
    if path.starts_with('/') || path.contains('\\') || path.contains(':') {
        return bad("must be relative and /-separated");
    }
    if path
        .split('/')
        .any(|c| c.is_empty() || c == "." || c == "..")
    {
        return bad("has an empty, '.' or '..' component");
    }
    Ok(())
}
