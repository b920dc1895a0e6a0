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
pub mod scene_read;
mod scene_refs;
pub mod stats;
pub(crate) mod writer;

use std::fs::File;
use std::path::{Path, PathBuf};
use std::time::Duration;

use rayon::prelude::*;

pub use manifest::{
    ASSET_KINDS, AssetRecord, FORMAT_NAME, FORMAT_VERSION, FormatVersion, Manifest,
    OLDEST_READ_MAJOR, StageRecord,
};
pub use names::{folder_name, unique_folders};
pub use writer::{CommitStep, FaultHook, SceneCommit, StageInfo, StageWriter, write_atomic};

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
    /// A baker would mix stages of two different scenes (or two versions of one).
    #[error(transparent)]
    SceneMismatch(Box<SceneMismatch>),
    /// A merge or a whole bake would replace a bundle of another scene (by name).
    #[error(
        "{}: holds scene `{found_name}` (hash {found_hash:.12}…), not `{name}` (hash {hash:.12}…) being written; pass --force to replace it",
        dir.display()
    )]
    OtherScene {
        /// The bundle folder.
        dir: PathBuf,
        /// The scene the bundle holds (`str`s keep the error small).
        found_name: Box<str>,
        /// The hash of that scene's stages.
        found_hash: Box<str>,
        /// The scene being written (baked or merged).
        name: Box<str>,
        /// Its hash.
        hash: Box<str>,
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
    /// A file of the bundle names a file that is not an asset of its stage: outside the
    /// bundle, or not listed in the manifest and so never hash-checked.
    #[error("{}: field `{field}` is {reference:?}: {why}", file.display())]
    BadReference {
        /// The bundle file holding the reference (boxed: keeps the error no larger than its
        /// largest other variant).
        file: Box<Path>,
        /// The field, e.g. `images[0].uri`.
        field: String,
        /// The reference as written.
        reference: String,
        /// What is wrong with it.
        why: String,
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

/// [`BundleError::SceneMismatch`]: a stage of the bundle baked from other scene files.
#[derive(Debug, thiserror::Error)]
#[error(
    "{}: stage `{stage}` was baked from other scene files (hash {}…; the bundle's scene is {bundle_scene:?}) than this scene {scene:?} (hash {}…); pass --force to replace the bundle's stages",
    dir.display(), distinct_prefix(found, expected), distinct_prefix(expected, found)
)]
pub struct SceneMismatch {
    /// The bundle folder.
    pub dir: PathBuf,
    /// A stage baked from the other scene.
    pub stage: String,
    /// Its scene hash.
    pub found: String,
    /// The scene name in the bundle's manifest.
    pub bundle_scene: String,
    /// The scene being baked: its name and hash.
    pub scene: String,
    pub expected: String,
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

    /// Checks that every asset exists with its recorded size and BLAKE3 hash, and that the
    /// scene stage's files name only assets of their stage ([`Bundle::check_scene_references`]).
    /// Returns every problem found (empty: the bundle is intact).
    pub fn verify(&self) -> Vec<BundleError> {
        let stages: Vec<&str> = self.manifest.stages.keys().map(String::as_str).collect();
        self.verify_stages(&stages)
    }

    /// [`Bundle::verify`] of the stages named `stages` (those the bundle lacks are passed over):
    /// what a reader of only those stages needs intact.
    pub fn verify_stages(&self, stages: &[&str]) -> Vec<BundleError> {
        let assets: Vec<&AssetRecord> = self
            .manifest
            .assets()
            .filter(|(s, _)| stages.contains(s))
            .map(|(_, a)| a)
            .collect();
        let mut problems: Vec<BundleError> = assets
            .par_iter()
            .filter_map(|a| self.verify_asset(a).err())
            .collect();
        if problems.is_empty() && stages.contains(&"scene") {
            problems.extend(self.check_scene_references());
        }
        problems
    }

    /// Checks one asset against its record.
    pub fn verify_asset(&self, asset: &AssetRecord) -> Result<(), BundleError> {
        check_relative(&asset.path)?;
        let (path, file) = self.open_asset(asset)?;
        let problem = |problem: String| BundleError::Asset {
            path: path.clone(),
            problem,
        };
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

    /// The metadata of an asset's file, found as [`Bundle::open_asset`] finds it (no symbolic
    /// link on the way, a regular file at the end), without opening it; `None` when it is
    /// missing.
    pub fn asset_metadata(
        &self,
        asset: &AssetRecord,
    ) -> Result<Option<std::fs::Metadata>, BundleError> {
        match self.inside(asset) {
            Ok((_, meta)) => Ok(Some(meta)),
            Err(BundleError::Io { source, .. })
                if source.kind() == std::io::ErrorKind::NotFound =>
            {
                Ok(None)
            }
            Err(BundleError::Io { path, source }) => Err(BundleError::Asset {
                path,
                problem: format!("cannot be read: {source}"),
            }),
            Err(e) => Err(e),
        }
    }

    /// Opens an asset's file for reading. Every step below the bundle folder must be a folder
    /// and the last a regular file, none of them a symbolic link: whatever a bundle holds, a
    /// reader opens no file outside it (nor a FIFO or device, which could block or never end).
    pub fn open_asset(&self, asset: &AssetRecord) -> Result<(PathBuf, File), BundleError> {
        let (path, meta) = self.inside(asset).map_err(|e| match e {
            BundleError::Io { path, source } => BundleError::Asset {
                path,
                problem: format!("cannot be read: {source}"),
            },
            e => e,
        })?;
        let file = File::open(&path).map_err(|e| BundleError::Asset {
            path: path.clone(),
            problem: format!("cannot be read: {e}"),
        })?;
        // The entry checked must be the file opened (not swapped for a link meanwhile).
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            let opened = file.metadata().map_err(|source| BundleError::Io {
                path: path.clone(),
                source,
            })?;
            if (opened.dev(), opened.ino()) != (meta.dev(), meta.ino()) {
                return Err(BundleError::Asset {
                    path,
                    problem: "changed while it was being opened".into(),
                });
            }
        }
        #[cfg(not(unix))]
        let _ = meta;
        Ok((path, file))
    }

    /// The path of `asset` and its metadata, after checking each step from the bundle folder
    /// down without following symbolic links (`Io` when a step cannot be looked at).
    fn inside(&self, asset: &AssetRecord) -> Result<(PathBuf, std::fs::Metadata), BundleError> {
        check_relative(&asset.path)?;
        let path = self.asset_path(asset);
        let rel = path.strip_prefix(&self.dir).unwrap_or(&path).to_owned();
        let mut at = self.dir.clone();
        let steps: Vec<_> = rel.components().collect();
        for (i, step) in steps.iter().enumerate() {
            at.push(step);
            let last = i + 1 == steps.len();
            let meta = std::fs::symlink_metadata(&at).map_err(|source| BundleError::Io {
                path: path.clone(),
                source,
            })?;
            let t = meta.file_type();
            let why = if t.is_symlink() {
                Some("is a symbolic link; glint reads only files inside the bundle folder")
            } else if last && !t.is_file() {
                Some("is not a regular file")
            } else if !last && !t.is_dir() {
                Some("is not a folder")
            } else {
                None
            };
            if let Some(why) = why {
                return Err(BundleError::Asset {
                    path: path.clone(),
                    problem: if last {
                        why.to_string()
                    } else {
                        format!("{} {why}", at.display())
                    },
                });
            }
            if last {
                return Ok((path, meta));
            }
        }
        Err(BundleError::Asset {
            path,
            problem: "names no file".into(),
        })
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

    /// Reads an asset ([`Bundle::open_asset`]), checking its hash.
    pub fn read_asset(&self, asset: &AssetRecord) -> Result<Vec<u8>, BundleError> {
        let (path, mut file) = self.open_asset(asset)?;
        let mut bytes = Vec::new();
        std::io::Read::read_to_end(&mut file, &mut bytes).map_err(|source| BundleError::Io {
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

/// Takes a shared lock on each stage folder the manifest names (what is missing, cannot be
/// opened or is a symbolic link is left: [`Bundle::verify`] reports its files).
fn pin_folders(dir: &Path, manifest: &Manifest) -> Vec<File> {
    manifest
        .stages
        .iter()
        .filter_map(|(name, rec)| {
            let path = dir.join(rec.folder(name));
            if !std::fs::symlink_metadata(&path).ok()?.is_dir() {
                return None;
            }
            let folder = File::open(path).ok()?;
            folder.lock_shared().ok()?;
            Some(folder)
        })
        .collect()
}

/// Refuses early (before a long bake) when `dir` is not a folder glint may write into
/// ([`check_folder`]), or when the bundle there holds stages of another scene and `force` is
/// not set. A missing bundle is fine.
pub fn check_scene(
    dir: &Path,
    scene_name: &str,
    scene_hash: &str,
    force: bool,
) -> Result<(), BundleError> {
    check_folder(dir)?;
    let Some(m) = read_manifest(dir)? else {
        return Ok(());
    };
    let other = m.stages.iter().find(|(_, s)| s.scene_hash != scene_hash);
    if let (false, Some((stage, s))) = (force, other) {
        return Err(BundleError::SceneMismatch(Box::new(SceneMismatch {
            dir: dir.to_owned(),
            stage: stage.clone(),
            found: s.scene_hash.clone(),
            bundle_scene: m.scene_name.clone(),
            scene: scene_name.to_owned(),
            expected: scene_hash.to_owned(),
        })));
    }
    Ok(())
}

/// The start of hash `a`, 12 characters or as many more as it takes to differ from `b`.
fn distinct_prefix<'a>(a: &'a str, b: &str) -> &'a str {
    let same = a.bytes().zip(b.bytes()).take_while(|(x, y)| x == y).count();
    a.get(..(same + 1).max(12)).unwrap_or(a)
}

/// Whether glint may write a bundle at `dir`: it does not exist, it is an empty folder, or it
/// carries a readable manifest. Anything else (a file, a folder of someone else's files, a
/// corrupt manifest) is refused with an error naming it, so no writer ever removes or
/// replaces files that are not its own. A folder holding only glint's own lock and
/// temporary entries (left by a bake killed before its first commit) counts as empty.
pub fn check_folder(dir: &Path) -> Result<(), BundleError> {
    use std::io::ErrorKind;
    let meta = match std::fs::metadata(dir) {
        Ok(m) => m,
        Err(e) if matches!(e.kind(), ErrorKind::NotFound | ErrorKind::NotADirectory) => {
            return match crate::out_dir::in_the_way(dir) {
                Some(why) => Err(BundleError::NotABundle {
                    dir: dir.to_owned(),
                    why,
                }),
                None => Ok(()),
            };
        }
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
    read_top_file(dir, MANIFEST).map_err(|e| match e {
        BundleError::Asset { path, problem } => BundleError::Corrupt {
            path,
            message: problem,
        },
        e => e,
    })
}

/// The text of the file `name` directly in the bundle folder `dir` (the manifest, a shard's
/// unit marker); `Ok(None)` when there is none. One that is a symbolic link or not a regular
/// file is refused unread: glint reads nothing outside a bundle, and nothing that could block.
pub fn read_top_file(dir: &Path, name: &str) -> Result<Option<String>, BundleError> {
    let path = dir.join(name);
    if let Ok(meta) = std::fs::symlink_metadata(&path) {
        let why = if meta.file_type().is_symlink() {
            "it is a symbolic link; glint reads only files inside the bundle folder"
        } else if !meta.is_file() {
            "it is not a regular file"
        } else {
            ""
        };
        if !why.is_empty() {
            return Err(BundleError::Asset {
                path,
                problem: why.into(),
            });
        }
    }
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
    // A newer minor version may add fields: those this glint does not know are passed over.
    let newer = version > FORMAT_VERSION;
    let mut value = value;
    if newer {
        drop_unknown_keys(&mut value);
    }
    let manifest: Manifest = serde_json::from_value(value).map_err(|e| corrupt(e.to_string()))?;
    check_manifest(&manifest, newer).map_err(corrupt)?;
    Ok(manifest)
}

/// Removes from a manifest's JSON the keys [`Manifest`], [`StageRecord`] and [`AssetRecord`]
/// do not have (their schema lists the keys), so that the types' refusal of unknown keys
/// applies only to manifests of this glint's version or older.
fn drop_unknown_keys(value: &mut serde_json::Value) {
    let schema = serde_json::to_value(schemars::schema_for!(Manifest)).unwrap_or_default();
    let keys = |s: &serde_json::Value| -> Vec<String> {
        s.get("properties")
            .and_then(|p| p.as_object())
            .map(|p| p.keys().cloned().collect())
            .unwrap_or_default()
    };
    let root = keys(&schema);
    let stage = keys(&schema["$defs"]["StageRecord"]);
    let asset = keys(&schema["$defs"]["AssetRecord"]);
    let keep = |v: &mut serde_json::Value, known: &[String]| {
        if let Some(o) = v.as_object_mut() {
            o.retain(|k, _| known.contains(k));
        }
    };
    keep(value, &root);
    let stages = value.get_mut("stages").and_then(|s| s.as_object_mut());
    for record in stages.into_iter().flat_map(|s| s.values_mut()) {
        keep(record, &stage);
        let assets = record.get_mut("assets").and_then(|a| a.as_array_mut());
        for a in assets.into_iter().flatten() {
            keep(a, &asset);
        }
    }
}

/// What [`Bundle::open`] requires of a parsed manifest, beyond its types: stage names and
/// folders that stay inside the bundle, asset paths inside their stage and each listed once,
/// known asset kinds (unless `newer`: the manifest's version is newer than this glint's, so a
/// kind may be one added since) and BLAKE3 hex digests. Every reader of a bundle
/// goes through this one check: `verify` refuses what the viewer refuses.
pub fn check_manifest(manifest: &Manifest, newer: bool) -> Result<(), String> {
    let mut paths = std::collections::HashSet::new();
    for (name, stage) in &manifest.stages {
        if !is_plain_name(name) {
            return Err(format!(
                "stage name {name:?} is not a plain folder name (no `/`, `\\`, `:`, `.` or `..`)"
            ));
        }
        if let Some(folder) = &stage.dir
            && !writer::is_stage_folder(name, folder)
        {
            return Err(format!(
                "stage `{name}`: field `dir` is {folder:?}, expected `{name}` or `{name}.N`"
            ));
        }
        for (i, a) in stage.assets.iter().enumerate() {
            let at = format!("stage `{name}`: assets[{i}]");
            check_relative(&a.path).map_err(|e| format!("{at}: {e}"))?;
            if a.path.split_once('/').map(|(s, _)| s) != Some(name.as_str()) {
                return Err(format!(
                    "{at}: path {:?} does not start with `{name}/`",
                    a.path
                ));
            }
            if !paths.insert(a.path.as_str()) {
                return Err(format!(
                    "{at}: path {:?} is listed twice (each file is one asset)",
                    a.path
                ));
            }
            // A newer minor version may add kinds; readers find assets by the kinds they know.
            if !newer && !ASSET_KINDS.contains(&a.kind.as_str()) {
                return Err(format!(
                    "{at}: field `kind` is {:?}, not an asset kind glint knows; known kinds: {}",
                    a.kind,
                    ASSET_KINDS.join(", ")
                ));
            }
            if !is_blake3_hex(&a.blake3) {
                return Err(format!(
                    "{at}: field `blake3` is {:?}, not a valid BLAKE3 hex digest (64 lowercase hex digits)",
                    a.blake3
                ));
            }
        }
    }
    Ok(())
}

/// A BLAKE3 digest as glint writes it: 64 lowercase hex digits.
fn is_blake3_hex(s: &str) -> bool {
    s.len() == 64 && s.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f'))
}

/// One path component that names an entry of its folder: not empty, `.` or `..`, and
/// without separators or drive letters.
fn is_plain_name(name: &str) -> bool {
    !name.is_empty() && name != "." && name != ".." && !name.contains(['/', '\\', ':', '\0'])
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
