//! The asset bundle: a folder `NAME.glint/` with `manifest.json` and one folder per stage.
//!
//! Layout (format version 2):
//! ```text
//! NAME.glint/
//!   manifest.json      format, version, generator, scene hash, stages → folder, settings,
//!                      time, assets (logical paths `radiance/Floor/…`)
//!   .lock              held while a stage commits (two bakers may share a bundle)
//!   radiance.3/ …      one folder per stage version, named by the manifest (`dir`)
//! ```
//! A stage is written into a private temporary folder, renamed to a new versioned folder
//! that no manifest names yet, and committed by renaming a new manifest into place: that
//! rename is the one step that switches readers and survives a crash, so a bundle always
//! holds the old stage or the new one. Folders no manifest names (replaced versions,
//! leftovers of killed bakes) are collected by later commits under the lock, except those a
//! reader still holds ([`Bundle::open`] takes a shared lock on each folder it resolves
//! into). Version 1 bundles (folder = stage name) are read as they are.

pub mod manifest;
mod names;
pub mod stats;
mod writer;

use std::fs::File;
use std::path::{Path, PathBuf};
use std::time::Duration;

use rayon::prelude::*;

pub use manifest::{
    AssetRecord, FORMAT_NAME, FORMAT_VERSION, FormatVersion, Manifest, OLDEST_READ_MAJOR,
    StageRecord,
};
pub use names::{folder_name, unique_folders};
pub use writer::{CommitStep, FaultHook, StageInfo, StageWriter, write_atomic};

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
    /// The folder exists but is neither empty nor a bundle: glint never writes into it.
    #[error(
        "{}: not a glint bundle: {why}; glint writes only into a new folder, an empty one or a bundle, and changes nothing else: choose another bundle folder",
        dir.display()
    )]
    NotABundle {
        /// The folder.
        dir: PathBuf,
        /// What it is instead (a file, or a folder without a manifest and what it holds).
        why: String,
    },
    /// A stage read an earlier stage that another baker replaced before this one committed.
    #[error(
        "{}: stage `{stage}` was re-baked while this stage was being baked from it (read {read:.12}…, now {now:.12}…); nothing was committed: bake again",
        dir.display()
    )]
    SourceChanged {
        /// The bundle folder.
        dir: PathBuf,
        /// The stage read.
        stage: String,
        /// Its identity when read ([`StageRecord::identity`]).
        read: String,
        /// Its identity at commit (`none` when it was removed).
        now: String,
    },
    /// The manifest kept changing while the bundle was being opened.
    #[error(
        "{}: the manifest changed on every one of {attempts} attempts to open the bundle (other bakers are committing); try again",
        dir.display()
    )]
    Busy {
        /// The bundle folder.
        dir: PathBuf,
        /// Attempts made.
        attempts: usize,
    },
}

/// An opened bundle whose manifest was read and checked: one consistent view of the bundle
/// for as long as it lives. Every read resolves into the folders this manifest names, and
/// those folders are held (a shared lock on each) so no writer collects them meanwhile.
#[derive(Debug)]
pub struct Bundle {
    dir: PathBuf,
    manifest: Manifest,
    /// Shared locks on the stage folders the manifest names.
    _pins: Vec<File>,
}

/// How many times [`Bundle::open`] reads the manifest before giving up on a bundle whose
/// manifest changes under it every time.
const OPEN_ATTEMPTS: usize = 100;

impl Bundle {
    /// Opens a bundle: reads the manifest once, checks its format and version, and holds the
    /// stage folders it names. Asset hashes are checked by [`Bundle::verify`].
    pub fn open(dir: impl AsRef<Path>) -> Result<Bundle, BundleError> {
        let dir = dir.as_ref().to_owned();
        for attempt in 0..OPEN_ATTEMPTS {
            let text = read_manifest_text(&dir)?
                .ok_or_else(|| BundleError::MissingManifest { dir: dir.clone() })?;
            let manifest = parse_manifest(&dir, &text)?;
            let pins = pin_folders(&dir, &manifest);
            // A commit may have replaced the manifest, and collected the folders it named,
            // before the locks took hold: then read it again.
            if read_manifest_text(&dir)?.as_deref() == Some(text.as_str()) {
                return Ok(Bundle {
                    dir,
                    manifest,
                    _pins: pins,
                });
            }
            drop(pins);
            std::thread::sleep(Duration::from_millis(1 << attempt.min(5)));
        }
        Err(BundleError::Busy {
            dir,
            attempts: OPEN_ATTEMPTS,
        })
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

    /// The file system path of an asset: its logical path resolved into the folder its
    /// stage's record names.
    pub fn asset_path(&self, asset: &AssetRecord) -> PathBuf {
        self.resolve(&asset.path)
    }

    /// The file system path of a logical path `STAGE/REST`.
    fn resolve(&self, logical: &str) -> PathBuf {
        match logical
            .split_once('/')
            .and_then(|(stage, rest)| Some((self.stage(stage)?.folder(stage), rest)))
        {
            Some((folder, rest)) => self.dir.join(folder).join(rest),
            None => self.dir.join(logical),
        }
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
                path: self.resolve(&logical),
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

/// Takes a shared lock on each stage folder the manifest names (what is missing or cannot
/// be opened is left: [`Bundle::verify`] reports missing files).
fn pin_folders(dir: &Path, manifest: &Manifest) -> Vec<File> {
    manifest
        .stages
        .iter()
        .filter_map(|(name, rec)| {
            let folder = File::open(dir.join(rec.folder(name))).ok()?;
            folder.lock_shared().ok()?;
            Some(folder)
        })
        .collect()
}

/// Refuses early (before a long bake) when `dir` is not a folder glint may write into
/// ([`check_folder`]), or when the bundle there holds stages of another scene and `force` is
/// not set. A missing bundle is fine.
pub fn check_scene(dir: &Path, scene_hash: &str, force: bool) -> Result<(), BundleError> {
    check_folder(dir)?;
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

/// Whether glint may write a bundle at `dir`: it does not exist, it is an empty folder, or it
/// carries a readable manifest. Anything else (a file, a folder of someone else's files, a
/// corrupt manifest) is refused with an error naming it, so no writer ever removes or
/// replaces files that are not its own. A folder holding only glint's own lock and
/// temporary entries (left by a bake killed before its first commit) counts as empty.
pub fn check_folder(dir: &Path) -> Result<(), BundleError> {
    let meta = match std::fs::metadata(dir) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(source) => {
            return Err(BundleError::Io {
                path: dir.to_owned(),
                source,
            });
        }
    };
    if !meta.is_dir() {
        return Err(BundleError::NotABundle {
            dir: dir.to_owned(),
            why: "it is a file, not a folder".into(),
        });
    }
    if read_manifest(dir)?.is_some() {
        return Ok(());
    }
    let entries = std::fs::read_dir(dir).map_err(|source| BundleError::Io {
        path: dir.to_owned(),
        source,
    })?;
    let mut foreign = Vec::new();
    let mut manifest_appeared = false;
    for e in entries {
        let e = e.map_err(|source| BundleError::Io {
            path: dir.to_owned(),
            source,
        })?;
        let name = e.file_name().to_string_lossy().into_owned();
        if name == MANIFEST {
            manifest_appeared = true;
        } else if !writer::is_own_scratch(&name) {
            foreign.push(name);
        }
    }
    // Another process made the folder a bundle between the two reads (a writer's first step
    // under the lock is an empty manifest, written atomically).
    if manifest_appeared && read_manifest(dir)?.is_some() {
        return Ok(());
    }
    if foreign.is_empty() {
        return Ok(());
    }
    foreign.sort();
    let more = foreign.len().saturating_sub(3);
    let mut found: Vec<String> = foreign.iter().take(3).map(|n| format!("`{n}`")).collect();
    if more > 0 {
        found.push(format!("{more} more"));
    }
    Err(BundleError::NotABundle {
        dir: dir.to_owned(),
        why: format!("it has no {MANIFEST} and holds {}", found.join(", ")),
    })
}

/// Reads and checks `dir/manifest.json`; `Ok(None)` when there is none.
pub(crate) fn read_manifest(dir: &Path) -> Result<Option<Manifest>, BundleError> {
    match read_manifest_text(dir)? {
        Some(text) => parse_manifest(dir, &text).map(Some),
        None => Ok(None),
    }
}

/// The text of `dir/manifest.json`; `Ok(None)` when there is none.
fn read_manifest_text(dir: &Path) -> Result<Option<String>, BundleError> {
    let path = dir.join(MANIFEST);
    match std::fs::read_to_string(&path) {
        Ok(t) => Ok(Some(t)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(source) => Err(BundleError::Io { path, source }),
    }
}

/// Parses and checks the manifest text of the bundle at `dir`.
fn parse_manifest(dir: &Path, text: &str) -> Result<Manifest, BundleError> {
    let path = dir.join(MANIFEST);
    let corrupt = |message: String| BundleError::Corrupt {
        path: path.clone(),
        message,
    };
    // Check format and version before the full parse: a newer major may have changed fields.
    let value: serde_json::Value =
        serde_json::from_str(text).map_err(|e| corrupt(e.to_string()))?;
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
    if version.major < OLDEST_READ_MAJOR {
        return Err(corrupt(format!(
            "format version {version} predates {OLDEST_READ_MAJOR}.0.0; re-bake the bundle"
        )));
    }
    let manifest: Manifest = serde_json::from_value(value).map_err(|e| corrupt(e.to_string()))?;
    for (name, stage) in &manifest.stages {
        if let Some(folder) = &stage.dir
            && !writer::is_stage_folder(name, folder)
        {
            return Err(corrupt(format!(
                "stage `{name}`: field `dir` is {folder:?}, expected `{name}` or `{name}.N`"
            )));
        }
        for a in &stage.assets {
            check_relative(&a.path).map_err(|e| corrupt(e.to_string()))?;
            if a.path.split_once('/').map(|(s, _)| s) != Some(name.as_str()) {
                return Err(corrupt(format!(
                    "stage `{name}`: asset path {:?} does not start with `{name}/`",
                    a.path
                )));
            }
        }
    }
    Ok(manifest)
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
