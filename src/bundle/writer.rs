//! Writing one stage into a bundle.
//!
//! Files go to a private temporary folder `.NAME.tmp-PID-N/`. The commit, under the bundle's
//! lock, renames that folder to a new versioned folder `NAME.K/` that no manifest names yet,
//! then writes a new manifest naming it beside `manifest.json` and renames it into place.
//! That last rename is the commit: before it readers (and a crash) see the old stage, after
//! it the new one. Concurrent bakers of different stages keep each other's entries because
//! each reads the manifest under the lock. Folders no manifest names any more are collected
//! at the end of a commit, still under the lock, unless a reader holds them (a shared lock,
//! [`super::Bundle::open`]) or, for a temporary folder, a live writer does (an exclusive
//! lock held from [`StageWriter::begin`] to the commit).
//!
//! A [`SceneCommit`] commits several stages the same way, under one lock: every folder is
//! renamed into place first, then one manifest naming them all, so that one rename switches
//! from the old bundle to the new one (a merge's stages, all or none).

use std::collections::{BTreeMap, BTreeSet};
use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::manifest::{AssetRecord, Manifest, StageRecord, generator};
use super::{BundleError, MANIFEST, check_folder, check_relative, read_manifest};

mod atomic;
pub use atomic::{write_atomic, write_atomic_with};

/// Name of the lock file inside a bundle.
const LOCK: &str = ".lock";

/// Most threads writing one stage's files at once ([`StageWriter::write_many`]).
pub const FLUSHERS: usize = 8;

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

/// Whether `name`, an entry of a bundle folder, is glint's own lock or scratch: the lock
/// file, a temporary stage folder or manifest (`.NAME.tmp-…`), or a version 1 writer's
/// replaced folder (`.NAME.old-…`).
pub(crate) fn is_own_scratch(name: &str) -> bool {
    name == LOCK || (name.starts_with('.') && (name.contains(".tmp-") || name.contains(".old-")))
}

/// Whether `folder` may hold stage `stage`: `stage` itself (format 1) or `stage.K`.
pub(crate) fn is_stage_folder(stage: &str, folder: &str) -> bool {
    folder == stage || version_of(stage, folder).is_some()
}

/// K of a versioned stage folder `stage.K`.
fn version_of(stage: &str, folder: &str) -> Option<u64> {
    let k = folder.strip_prefix(stage)?.strip_prefix('.')?;
    if k.is_empty() || !k.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    k.parse().ok()
}

/// Flushes a folder's entries (renames, new files) to disk. File systems that cannot sync a
/// folder are passed over.
fn sync_dir(dir: &Path) -> std::io::Result<()> {
    match File::open(dir).and_then(|d| d.sync_all()) {
        Err(e)
            if matches!(
                e.kind(),
                std::io::ErrorKind::InvalidInput | std::io::ErrorKind::Unsupported
            ) =>
        {
            Ok(())
        }
        r => r,
    }
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

/// A file-system step of [`StageWriter::commit`], in the order they run; a
/// [`FaultHook`] is called before each.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CommitStep {
    /// Opening (creating) the bundle's lock file.
    OpenLock,
    /// Taking the lock.
    Lock,
    /// Reading the manifest.
    ReadManifest,
    /// Listing the bundle folder for the next free folder version.
    ListBundle,
    /// Flushing the stage's folders (its files were flushed as written).
    SyncStage,
    /// Renaming the temporary folder to the stage's new versioned folder.
    RenameStage,
    /// Flushing the bundle folder (that rename).
    SyncBundle,
    /// Creating the new manifest's temporary file.
    CreateManifest,
    /// Writing and flushing it.
    WriteManifest,
    /// Renaming it over `manifest.json`: the commit.
    RenameManifest,
    /// Flushing the bundle folder (the commit's rename).
    SyncCommit,
    /// Removing one folder or file that no manifest names (after the commit).
    Collect,
}

/// Called before each [`CommitStep`]; an error makes that step fail as if the file system
/// had failed it (the step is not done). For fault-injection tests.
pub type FaultHook = Box<dyn FnMut(CommitStep) -> std::io::Result<()> + Send>;

/// Collects one stage's files in a temporary folder until [`StageWriter::commit`].
/// Dropped without a commit (an error, Ctrl-C unwinding), it removes its files and the
/// bundle stays as it was.
pub struct StageWriter {
    dir: PathBuf,
    stage: String,
    /// Where the stage's files are: the temporary folder, or after the commit's first
    /// rename the versioned folder.
    tmp: PathBuf,
    /// An exclusive lock on `tmp`, held until the commit: tells collectors it is in use.
    tmp_lock: Option<File>,
    /// Folders under `tmp` holding files, to flush at the commit.
    folders: BTreeSet<PathBuf>,
    assets: Vec<AssetRecord>,
    /// Earlier stages this one was computed from, with their identity when read.
    sources: Vec<(String, String)>,
    hook: Option<FaultHook>,
    committed: bool,
}

impl std::fmt::Debug for StageWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StageWriter")
            .field("dir", &self.dir)
            .field("stage", &self.stage)
            .field("tmp", &self.tmp)
            .field("assets", &self.assets.len())
            .field("sources", &self.sources)
            .finish_non_exhaustive()
    }
}

/// The bundle's lock, held while it lives.
struct BundleLock(#[allow(dead_code)] File);

impl StageWriter {
    /// Starts writing `stage` into the bundle at `dir`. `dir` must be new, empty or a bundle
    /// ([`check_folder`]); a new or empty folder becomes an empty bundle at once, so the
    /// folder is writable (checked here, before any compute) and stays a bundle whatever
    /// happens next.
    pub fn begin(dir: impl AsRef<Path>, stage: &str) -> Result<StageWriter, BundleError> {
        let dir = dir.as_ref().to_owned();
        check_relative(stage)?;
        if stage.contains(['/', '.']) {
            return Err(BundleError::BadAssetPath {
                path: stage.into(),
                why: "a stage name is one plain folder name without '.'",
            });
        }
        check_folder(&dir)?;
        fs::create_dir_all(&dir).map_err(io(&dir))?;
        let lock = lock_bundle(&dir, &mut None)?;
        // Again under the lock: another writer may have made the folder a bundle meanwhile.
        check_folder(&dir)?;
        if read_manifest(&dir)?.is_none() {
            let empty = Manifest::new("", "");
            let text = serde_json::to_string_pretty(&empty).expect("manifest serializes");
            write_atomic(&dir.join(MANIFEST), text.as_bytes())?;
        }
        let tmp = dir.join(format!(".{stage}.tmp-{}", unique_suffix()));
        fs::create_dir(&tmp).map_err(io(&tmp))?;
        // Locked before the bundle's lock is released, so no collector sees it unlocked.
        let tmp_lock = File::open(&tmp).ok().filter(|f| f.try_lock().is_ok());
        drop(lock);
        Ok(StageWriter {
            dir,
            stage: stage.into(),
            folders: BTreeSet::from([tmp.clone()]),
            tmp,
            tmp_lock,
            assets: Vec::new(),
            sources: Vec::new(),
            hook: None,
            committed: false,
        })
    }

    /// Installs a hook called before each file-system step of the commit (tests inject
    /// faults with it).
    pub fn with_fault_hook(mut self, hook: FaultHook) -> StageWriter {
        self.hook = Some(hook);
        self
    }

    /// Adds a file at `rel` (relative to the stage folder, `/`-separated) of the given kind.
    pub fn write(&mut self, rel: &str, kind: &str, bytes: &[u8]) -> Result<(), BundleError> {
        self.write_many(&[(rel, kind, bytes)])
    }

    /// [`StageWriter::write`] of several files (relative path, kind, bytes), recorded in the
    /// order given. Up to `FLUSHERS` threads write and flush them at once: each flush waits
    /// on the disk, and flushes under way together share the file system's journal commits.
    pub fn write_many<R, K, B>(&mut self, files: &[(R, K, B)]) -> Result<(), BundleError>
    where
        R: AsRef<str> + Sync,
        K: AsRef<str> + Sync,
        B: AsRef<[u8]> + Sync,
    {
        let mut paths = Vec::with_capacity(files.len());
        for (rel, _, _) in files {
            let rel = rel.as_ref();
            check_relative(rel)?;
            let path = format!("{}/{rel}", self.stage);
            if self.assets.iter().any(|a| a.path == path) || paths.contains(&path) {
                return Err(BundleError::BadAssetPath {
                    path,
                    why: "written twice",
                });
            }
            let file = self.tmp.join(rel);
            if let Some(parent) = file.parent() {
                fs::create_dir_all(parent).map_err(io(parent))?;
                let mut p = parent;
                while p != self.tmp && self.folders.insert(p.to_owned()) {
                    p = p.parent().unwrap_or(&self.tmp);
                }
            }
            paths.push(path);
        }
        let next = std::sync::atomic::AtomicUsize::new(0);
        let done: Vec<std::sync::OnceLock<Result<String, BundleError>>> =
            files.iter().map(|_| std::sync::OnceLock::new()).collect();
        let tmp = &self.tmp;
        let work = || {
            loop {
                let k = next.fetch_add(1, Ordering::Relaxed);
                let Some((rel, _, bytes)) = files.get(k) else {
                    break;
                };
                let (file, bytes) = (tmp.join(rel.as_ref()), bytes.as_ref());
                let written = (|| {
                    let mut f = File::create(&file)?;
                    f.write_all(bytes)?;
                    f.sync_all()
                })()
                .map_err(io(&file))
                .map(|()| blake3::hash(bytes).to_hex().to_string());
                let _ = done[k].set(written);
            }
        };
        let threads = files.len().clamp(1, FLUSHERS);
        std::thread::scope(|s| {
            for _ in 1..threads {
                s.spawn(work);
            }
            work();
        });
        for ((path, (_, kind, bytes)), hash) in paths.into_iter().zip(files).zip(done) {
            let blake3 = hash.into_inner().expect("every file is written")?;
            self.assets.push(AssetRecord {
                path,
                kind: kind.as_ref().into(),
                bytes: bytes.as_ref().len() as u64,
                blake3,
            });
        }
        Ok(())
    }

    /// The assets written so far.
    pub fn assets(&self) -> &[AssetRecord] {
        &self.assets
    }

    /// Records that this stage was computed from stage `stage` as it was when read, with
    /// `identity` ([`StageRecord::identity`] of the record read). The commit checks under
    /// the lock that the bundle still holds that version of `stage`, and refuses
    /// ([`BundleError::SourceChanged`]) if another baker replaced it meanwhile.
    pub fn read_from(&mut self, stage: &str, identity: &str) {
        self.sources.retain(|(s, _)| s != stage);
        self.sources.push((stage.into(), identity.into()));
    }

    /// Moves the stage's folder into place and records it in the manifest, under the
    /// bundle's lock; then collects folders no manifest names. Returns the record written.
    pub fn commit(mut self, info: StageInfo) -> Result<StageRecord, BundleError> {
        let mut hook = self.hook.take();
        let dir = self.dir.clone();
        let force = info.force;
        let mut records = commit_stages(
            &dir,
            &mut [(self, info)],
            &[],
            &mut hook,
            SceneGuard::Hash { force },
        )?;
        Ok(records.remove(0))
    }
}

/// Several stages of one scene committed together ([`SceneCommit::commit`]).
pub struct SceneCommit {
    dir: PathBuf,
    stages: Vec<(StageWriter, StageInfo)>,
    /// Stages the bundle holds already as they should be: (name, identity when read).
    keep: Vec<(String, String)>,
    force: bool,
    hook: Option<FaultHook>,
}

impl std::fmt::Debug for SceneCommit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SceneCommit")
            .field("dir", &self.dir)
            .field("stages", &self.stages.len())
            .field("force", &self.force)
            .finish_non_exhaustive()
    }
}

impl SceneCommit {
    /// A commit into the bundle at `dir` that replaces whatever the bundle holds of the same
    /// scene (by name: an earlier version of it). A bundle holding another scene is refused
    /// ([`BundleError::OtherScene`]) unless `force`.
    pub fn new(dir: impl AsRef<Path>, force: bool) -> SceneCommit {
        SceneCommit {
            dir: dir.as_ref().to_owned(),
            stages: Vec::new(),
            keep: Vec::new(),
            force,
            hook: None,
        }
    }

    /// Keeps stage `stage` of the bundle as it is (its folder and files), recorded as of
    /// this commit's scene: the commit checks under the lock that the bundle still holds it
    /// with `identity` ([`StageRecord::identity`]), and refuses
    /// ([`BundleError::SourceChanged`]) if another writer replaced it meanwhile.
    pub fn keep(&mut self, stage: &str, identity: &str) {
        self.keep.push((stage.into(), identity.into()));
    }

    /// Refuses early, before any file is written, what [`SceneCommit::commit`] would refuse
    /// for scene `scene_name` (`scene_hash`) at `dir`: a folder glint may not write into
    /// ([`check_folder`]), or a bundle of another scene without `force`.
    pub fn check(
        dir: &Path,
        scene_name: &str,
        scene_hash: &str,
        force: bool,
    ) -> Result<(), BundleError> {
        check_folder(dir)?;
        let Some(old) = read_manifest(dir)? else {
            return Ok(());
        };
        match other_scene(&old, scene_name, scene_hash) {
            Some((found_name, found_hash)) if !force => Err(BundleError::OtherScene {
                dir: dir.to_owned(),
                found_name: found_name.into(),
                found_hash: found_hash.into(),
                name: scene_name.into(),
                hash: scene_hash.into(),
            }),
            _ => Ok(()),
        }
    }

    /// Adds a stage written by `writer` (begun on the same bundle) with `info`.
    pub fn push(&mut self, writer: StageWriter, info: StageInfo) {
        self.stages.push((writer, info));
    }

    /// Installs a hook called before each file-system step of the commit (tests inject
    /// faults with it).
    pub fn with_fault_hook(mut self, hook: FaultHook) -> SceneCommit {
        self.hook = Some(hook);
        self
    }

    /// Moves every stage's folder into place and writes one manifest naming them all, under
    /// the bundle's lock: its rename switches readers (and a crash) from the old bundle to
    /// the new one at once. Stages of the scene's earlier versions that this commit does not
    /// write are dropped, so the bundle then holds this scene's stages only. Returns the
    /// records written, in the order pushed.
    pub fn commit(mut self) -> Result<Vec<StageRecord>, BundleError> {
        if self.stages.is_empty() {
            return Ok(Vec::new());
        }
        let guard = SceneGuard::Name { force: self.force };
        commit_stages(
            &self.dir,
            &mut self.stages,
            &self.keep,
            &mut self.hook,
            guard,
        )
    }
}

/// What a commit refuses among the stages of other scenes that the bundle holds.
#[derive(Clone, Copy, Debug)]
enum SceneGuard {
    /// A stage commit: any stage of another scene hash, unless `force` (then they are dropped).
    Hash { force: bool },
    /// A whole scene's commit (a merge): a bundle of another scene name, unless `force`; stages
    /// of another hash under the same name are an earlier version of the scene, dropped.
    Name { force: bool },
}

/// Calls the fault hook, if any, before `step` on `path`.
fn fault(hook: &mut Option<FaultHook>, step: CommitStep, path: &Path) -> Result<(), BundleError> {
    match hook.as_mut() {
        Some(hook) => hook(step).map_err(io(path)),
        None => Ok(()),
    }
}

/// The name and hash of the scene whose stages a commit of `name`/`hash` would drop from a
/// bundle with manifest `old`, when that is another scene (by name).
fn other_scene(old: &Manifest, name: &str, hash: &str) -> Option<(String, String)> {
    let stale = old.stages.values().find(|r| r.scene_hash != hash)?;
    (old.scene_name != name).then(|| (old.scene_name.clone(), stale.scene_hash.clone()))
}

/// Moves each writer's folder into place and records them all in one new manifest, under the
/// bundle's lock; then collects folders no manifest names. Every writer has begun on `dir`
/// and all are of one scene (the first's `info` names it). Returns the records written.
fn commit_stages(
    dir: &Path,
    stages: &mut [(StageWriter, StageInfo)],
    keep: &[(String, String)],
    hook: &mut Option<FaultHook>,
    guard: SceneGuard,
) -> Result<Vec<StageRecord>, BundleError> {
    let lock = lock_bundle(dir, hook)?;
    let (scene_name, scene_hash) = (
        stages[0].1.scene_name.clone(),
        stages[0].1.scene_hash.clone(),
    );

    let manifest_path = dir.join(MANIFEST);
    fault(hook, CommitStep::ReadManifest, &manifest_path)?;
    let old = read_manifest(dir)?.unwrap_or_else(|| Manifest::new(&scene_name, &scene_hash));
    for (w, _) in stages.iter() {
        for (stage, read) in &w.sources {
            let now = old.stages.get(stage).map(StageRecord::identity);
            if now.as_deref() != Some(read.as_str()) {
                return Err(BundleError::SourceChanged {
                    dir: dir.to_owned(),
                    stage: stage.clone(),
                    read: read.clone(),
                    now: now.unwrap_or_else(|| "none".into()),
                });
            }
        }
    }
    for (stage, read) in keep {
        let now = old.stages.get(stage).map(StageRecord::identity);
        if now.as_deref() != Some(read.as_str()) {
            return Err(BundleError::SourceChanged {
                dir: dir.to_owned(),
                stage: stage.clone(),
                read: read.clone(),
                now: now.unwrap_or_else(|| "none".into()),
            });
        }
    }
    let mut manifest = old.clone();
    let written: BTreeSet<String> = stages.iter().map(|(w, _)| w.stage.clone()).collect();
    let kept = |name: &str| keep.iter().any(|(k, _)| k == name);
    let foreign: Vec<String> = manifest
        .stages
        .iter()
        .filter(|(name, r)| {
            !written.contains(*name) && !kept(name.as_str()) && r.scene_hash != scene_hash
        })
        .map(|(name, _)| name.clone())
        .collect();
    match guard {
        SceneGuard::Hash { force } => {
            let replaced_scene = manifest.scene_hash != scene_hash
                && written.iter().any(|s| {
                    manifest
                        .stages
                        .get(s)
                        .is_some_and(|r| r.scene_hash != scene_hash)
                });
            if (!foreign.is_empty() || replaced_scene) && !force {
                let stage = foreign
                    .first()
                    .or_else(|| written.iter().next())
                    .cloned()
                    .unwrap_or_default();
                return Err(BundleError::SceneMismatch(Box::new(super::SceneMismatch {
                    dir: dir.to_owned(),
                    found: manifest
                        .stages
                        .get(&stage)
                        .map_or_else(|| manifest.scene_hash.clone(), |r| r.scene_hash.clone()),
                    stage,
                    bundle_scene: manifest.scene_name.clone(),
                    scene: scene_name,
                    expected: scene_hash,
                })));
            }
            for name in &foreign {
                // --force: stages of another scene are stale; their folders are collected below.
                log::warn!(
                    "{}: removing stage {name:?} baked from another scene",
                    dir.display()
                );
            }
        }
        SceneGuard::Name { force } => match other_scene(&old, &scene_name, &scene_hash) {
            Some((found_name, found_hash)) if !force => {
                return Err(BundleError::OtherScene {
                    dir: dir.to_owned(),
                    found_name: found_name.into(),
                    found_hash: found_hash.into(),
                    name: scene_name.into(),
                    hash: scene_hash.into(),
                });
            }
            Some((found_name, _)) => {
                for name in &foreign {
                    log::warn!(
                        "{}: removing stage {name:?} of scene {found_name:?} (--force)",
                        dir.display()
                    );
                }
            }
            None => {
                for name in &foreign {
                    log::info!(
                        "{}: removing stage {name:?} of an earlier version of the scene",
                        dir.display()
                    );
                }
            }
        },
    }
    for name in &foreign {
        manifest.stages.remove(name);
    }
    for (name, _) in keep {
        if let Some(r) = manifest.stages.get_mut(name) {
            r.scene_hash = scene_hash.clone();
        }
    }

    // The next free version of each stage: above every `stage.K` on disk or in the manifest.
    fault(hook, CommitStep::ListBundle, dir)?;
    let mut next: BTreeMap<&str, u64> = written.iter().map(|s| (s.as_str(), 1)).collect();
    for entry in fs::read_dir(dir).map_err(io(dir))? {
        let name = entry
            .map_err(io(dir))?
            .file_name()
            .to_string_lossy()
            .into_owned();
        for (stage, n) in next.iter_mut() {
            if let Some(k) = version_of(stage, &name) {
                *n = (*n).max(k + 1);
            }
        }
    }
    for (stage, n) in next.iter_mut() {
        if let Some(k) = old
            .stages
            .get(*stage)
            .and_then(|r| version_of(stage, r.folder(stage)))
        {
            *n = (*n).max(k + 1);
        }
    }
    let folders: Vec<String> = stages
        .iter()
        .map(|(w, _)| format!("{}.{}", w.stage, next[w.stage.as_str()]))
        .collect();

    for ((w, _), folder) in stages.iter_mut().zip(&folders) {
        let target = dir.join(folder);
        for f in w.folders.iter().rev() {
            fault(hook, CommitStep::SyncStage, f)?;
            sync_dir(f).map_err(io(f))?;
        }
        fault(hook, CommitStep::RenameStage, &target)?;
        fs::rename(&w.tmp, &target).map_err(io(&target))?;
        // From here until the manifest names it, a failure removes the new folder (Drop).
        w.tmp = target;
    }
    fault(hook, CommitStep::SyncBundle, dir)?;
    sync_dir(dir).map_err(io(dir))?;

    let mut records = Vec::with_capacity(stages.len());
    for ((w, info), folder) in stages.iter_mut().zip(folders) {
        let record = StageRecord {
            generator: generator(),
            scene_hash: scene_hash.clone(),
            settings: info.settings.clone(),
            bake_seconds: info.bake_seconds,
            stats: std::mem::take(&mut info.stats),
            assets: std::mem::take(&mut w.assets),
            dir: Some(folder),
        };
        manifest.stages.insert(w.stage.clone(), record.clone());
        records.push(record);
    }
    manifest.format_version = super::FORMAT_VERSION.to_string();
    manifest.scene_hash = scene_hash;
    manifest.scene_name = scene_name;
    manifest.generator = generator();
    let text = serde_json::to_string_pretty(&manifest).expect("manifest serializes");
    write_manifest(hook, &manifest_path, text.as_bytes())?;
    for (w, _) in stages.iter_mut() {
        w.committed = true;
        // The folder is the manifest's now: readers may lock it.
        w.tmp_lock = None;
    }
    fault(hook, CommitStep::SyncCommit, dir)?;
    sync_dir(dir).map_err(io(dir))?;

    collect(dir, &written, hook, &old, &manifest);
    drop(lock);
    Ok(records)
}

/// Writes the manifest to a temporary file beside it, flushed, and renames it over
/// `manifest.json` (the commit); on failure the temporary file is removed.
fn write_manifest(
    hook: &mut Option<FaultHook>,
    path: &Path,
    bytes: &[u8],
) -> Result<(), BundleError> {
    let tmp = path.with_file_name(format!(".{MANIFEST}.tmp-{}", unique_suffix()));
    let result = (|| {
        fault(hook, CommitStep::CreateManifest, &tmp)?;
        let mut f = File::create(&tmp).map_err(io(&tmp))?;
        fault(hook, CommitStep::WriteManifest, &tmp)?;
        f.write_all(bytes)
            .and_then(|_| f.sync_all())
            .map_err(io(&tmp))?;
        fault(hook, CommitStep::RenameManifest, path)?;
        fs::rename(&tmp, path).map_err(io(path))
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// Removes, under the lock, what no manifest names: folders the previous manifest named
/// and this one does not, versioned folders of known stages that no manifest names
/// (replaced versions a reader held, leftovers of killed commits), temporary folders of
/// writers that are gone, and temporary manifests. A folder someone holds is left for a
/// later commit. Failures are logged: the commit has happened.
fn collect(
    dir: &Path,
    written: &BTreeSet<String>,
    hook: &mut Option<FaultHook>,
    old: &Manifest,
    new: &Manifest,
) {
    let named: BTreeSet<&str> = new.stages.iter().map(|(n, r)| r.folder(n)).collect();
    let replaced: BTreeSet<&str> = old
        .stages
        .iter()
        .map(|(n, r)| r.folder(n))
        .filter(|f| !named.contains(f))
        .collect();
    let stages: BTreeSet<&str> = old
        .stages
        .keys()
        .chain(new.stages.keys())
        .chain(written)
        .map(String::as_str)
        .collect();
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    let mut garbage: Vec<String> = entries
        .filter_map(|e| Some(e.ok()?.file_name().to_string_lossy().into_owned()))
        .filter(|name| {
            !named.contains(name.as_str())
                && name != LOCK
                && (replaced.contains(name.as_str())
                    || is_own_scratch(name)
                    || stages.iter().any(|s| version_of(s, name).is_some()))
        })
        .collect();
    garbage.sort();
    for name in garbage {
        let path = dir.join(&name);
        if fault(hook, CommitStep::Collect, &path).is_err() {
            continue;
        }
        if let Err(e) = remove_unheld(&path) {
            log::warn!("{}: cannot remove: {e}", path.display());
        }
    }
}

/// Opens and takes the bundle's lock, with the fault hook's steps.
fn lock_bundle(dir: &Path, hook: &mut Option<FaultHook>) -> Result<BundleLock, BundleError> {
    let path = dir.join(LOCK);
    let mut fault = |step| match hook.as_mut() {
        Some(h) => h(step).map_err(io(&path)),
        None => Ok(()),
    };
    fault(CommitStep::OpenLock)?;
    let lock = OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
        .map_err(io(&path))?;
    fault(CommitStep::Lock)?;
    lock.lock().map_err(io(&path))?;
    Ok(BundleLock(lock))
}

/// Removes a file, or a folder nobody holds (an exclusive lock on it is free); a folder held
/// by a reader or a live writer is left.
fn remove_unheld(path: &Path) -> std::io::Result<()> {
    let meta = fs::symlink_metadata(path)?;
    if !meta.is_dir() {
        return fs::remove_file(path);
    }
    let folder = File::open(path)?;
    match folder.try_lock() {
        Ok(()) => fs::remove_dir_all(path),
        Err(fs::TryLockError::WouldBlock) => {
            log::debug!("{}: in use, left for a later commit", path.display());
            Ok(())
        }
        Err(fs::TryLockError::Error(e)) => Err(e),
    }
}

impl Drop for StageWriter {
    fn drop(&mut self) {
        if !self.committed {
            let _ = fs::remove_dir_all(&self.tmp);
        }
    }
}

#[cfg(test)]
mod tests;
