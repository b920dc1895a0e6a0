//! Shipped scenes baked once and kept: [`shipped_bundle`] bakes a scene of `scenes/` by a
//! [`Recipe`] into `target/tmp/shipped-bakes/SCENE-SOURCE-KEY/`, where SOURCE hashes glint's
//! source (`src/`, `shaders/`, `Cargo.toml`, `Cargo.lock`) and KEY that, the recipe (stages and
//! their settings, camera paths added), the scene folder's files and the build profile. A
//! change to any of them bakes afresh, so a stale bundle is never reused (and a bake removes
//! what earlier sources left); a kept bundle is verified (every asset's hash) before it is
//! handed out, and baked again if a test damaged it.
//!
//! Within one test binary a recipe is baked or verified once. Across processes a lock file
//! per key lets one bake while the others wait, and the bake goes into a temporary folder
//! renamed into place when complete, so a killed bake never leaves a half bundle behind.
//! Benches include this file by path.

use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

use glint::bake::materials::MaterialsSettings;
use glint::bake::srdm_stage::SrdmSettings;
use glint::bake::{
    BakeSettings, bake_all, materials, radiance_stage, radiosity_stage, scene_stage, srdm_stage,
};
use glint::bundle::Bundle;
use glint::progress::Silent;
use glint::scene::Scene;
use glint::scene::desc::{Quality, RadiositySettings};

/// One stage of a [`Recipe`], with its settings, baked in the order given.
#[derive(Clone, Debug)]
pub enum Step {
    /// The scene stage.
    Scene,
    /// The radiosity stage with these settings.
    Radiosity(RadiositySettings),
    /// The materials stage with these settings.
    Materials(MaterialsSettings),
    /// The radiance stage at this preset.
    Radiance(Quality),
    /// The SRDM stage with these settings.
    Srdm(SrdmSettings),
    /// Every stage the scene needs, at this preset with the scene's overrides: what
    /// `glint-bake --quality Q` bakes.
    EveryNeededStage(Quality),
}

/// How to bake a shipped scene: which one, camera paths to add, and the stages.
#[derive(Clone, Debug)]
pub struct Recipe {
    /// The folder under `scenes/`.
    pub scene: &'static str,
    /// Camera paths appended to scene.json's `camera_paths` (a JSON array; `Null`: none). With
    /// some, the scene folder is copied beside the bundle and the copy edited.
    pub extra_camera_paths: serde_json::Value,
    /// The stages, in order.
    pub steps: Vec<Step>,
}

impl Recipe {
    /// `scene` with no stage yet.
    pub fn new(scene: &'static str) -> Recipe {
        Recipe {
            scene,
            extra_camera_paths: serde_json::Value::Null,
            steps: Vec::new(),
        }
    }

    /// What `glint-bake --quality quality` bakes.
    pub fn every_needed_stage(scene: &'static str, quality: Quality) -> Recipe {
        Recipe::new(scene).then(Step::EveryNeededStage(quality))
    }

    /// Adds `step`.
    pub fn then(mut self, step: Step) -> Recipe {
        self.steps.push(step);
        self
    }

    /// Adds camera paths (a JSON array) to the scene.
    pub fn with_camera_paths(mut self, paths: serde_json::Value) -> Recipe {
        self.extra_camera_paths = paths;
        self
    }

    /// The cache key: BLAKE3 of everything the bundle depends on.
    fn key(&self) -> String {
        let mut h = blake3::Hasher::new();
        h.update(b"glint shipped bake 1\n");
        h.update(format!("{self:?}\nrelease: {}\n", !cfg!(debug_assertions)).as_bytes());
        hash_tree(
            &mut h,
            &super::repo(&format!("scenes/{}", self.scene)),
            false,
        );
        h.update(source_hash().as_bytes());
        h.finalize().to_hex().to_string()
    }
}

/// The bundle `recipe` bakes, baked at most once per test binary run and kept across runs
/// while nothing it depends on changes. Treat it as read-only: copy it to change it.
pub fn shipped_bundle(recipe: &Recipe) -> PathBuf {
    type Cells = Mutex<BTreeMap<String, Arc<OnceLock<PathBuf>>>>;
    static DONE: OnceLock<Cells> = OnceLock::new();
    let key = recipe.key();
    let cell = DONE
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .entry(key.clone())
        .or_default()
        .clone();
    cell.get_or_init(|| bake_or_reuse(recipe, &key)).clone()
}

fn bake_or_reuse(recipe: &Recipe, key: &str) -> PathBuf {
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("shipped-bakes");
    std::fs::create_dir_all(&root).unwrap_or_else(|e| panic!("{}: {e}", root.display()));
    let source = &source_hash()[..8];
    let name = format!("{}-{source}-{}", recipe.scene, &key[..12]);
    let dir = root.join(&name);
    let bundle_name = format!("{}.glint", recipe.scene);
    let lock_path = root.join(format!("{name}.lock"));
    let lock = File::create(&lock_path).unwrap_or_else(|e| panic!("{}: {e}", lock_path.display()));
    lock.lock()
        .unwrap_or_else(|e| panic!("{}: {e}", lock_path.display()));
    let bundle = dir.join(&bundle_name);
    if dir.exists() {
        match Bundle::open(&bundle).map(|b| b.verify()) {
            Ok(problems) if problems.is_empty() => return bundle,
            Ok(problems) => eprintln!(
                "{}: damaged ({}), baking it again",
                bundle.display(),
                problems[0]
            ),
            Err(e) => eprintln!("{}: {e}; baking it again", bundle.display()),
        }
        std::fs::remove_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    }
    prune_stale(&root, source);
    let tmp = root.join(format!("{name}.tmp-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).unwrap_or_else(|e| panic!("{}: {e}", tmp.display()));
    let scene_json = scene_json(recipe, &tmp);
    let scene = Scene::load(&scene_json).unwrap_or_else(|e| panic!("{e}"));
    let start = Instant::now();
    let tmp_bundle = tmp.join(&bundle_name);
    for step in &recipe.steps {
        bake_step(&scene, &tmp_bundle, step)
            .unwrap_or_else(|e| panic!("{}: baking {step:?}: {e}", recipe.scene));
    }
    std::fs::rename(&tmp, &dir)
        .unwrap_or_else(|e| panic!("{} → {}: {e}", tmp.display(), dir.display()));
    eprintln!(
        "baked {} in {:.1} s: {}",
        recipe.scene,
        start.elapsed().as_secs_f64(),
        bundle.display()
    );
    bundle
}

/// Removes what earlier sources baked into `root` (every entry whose name lacks `-SOURCE-`),
/// so the cache does not grow with each change to glint.
fn prune_stale(root: &Path, source: &str) {
    let Ok(entries) = std::fs::read_dir(root) else {
        return;
    };
    for p in entries.flatten().map(|e| e.path()) {
        let name = p.file_name().unwrap_or_default().to_string_lossy();
        if !name.contains(&format!("-{source}-")) {
            let _ = if p.is_dir() {
                std::fs::remove_dir_all(&p)
            } else {
                std::fs::remove_file(&p)
            };
        }
    }
}

/// The shipped scene.json, or an edited copy of the scene folder in `tmp/SCENE/` when the
/// recipe adds camera paths.
fn scene_json(recipe: &Recipe, tmp: &Path) -> PathBuf {
    let src = super::repo(&format!("scenes/{}", recipe.scene));
    let Some(extra) = recipe.extra_camera_paths.as_array() else {
        return src.join("scene.json");
    };
    let copy = tmp.join(recipe.scene);
    std::fs::create_dir_all(&copy).unwrap();
    for entry in std::fs::read_dir(&src).unwrap_or_else(|e| panic!("{}: {e}", src.display())) {
        let p = entry.unwrap().path();
        if p.is_file() {
            std::fs::copy(&p, copy.join(p.file_name().unwrap()))
                .unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        }
    }
    let json_path = copy.join("scene.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json_path).unwrap()).unwrap();
    v["camera_paths"]
        .as_array_mut()
        .unwrap_or_else(|| panic!("{}: no `camera_paths` array", json_path.display()))
        .extend(extra.iter().cloned());
    std::fs::write(&json_path, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    json_path
}

fn bake_step(
    scene: &Scene,
    bundle: &Path,
    step: &Step,
) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    match step {
        Step::Scene => {
            scene_stage::bake(scene, bundle, false)?;
        }
        Step::Radiosity(s) => {
            radiosity_stage::bake(scene, bundle, s, false, &Silent)?;
        }
        Step::Materials(s) => {
            materials::bake(scene, bundle, s, false, &Silent)?;
        }
        Step::Radiance(q) => {
            radiance_stage::bake(scene, bundle, *q, false, &Silent)?;
        }
        Step::Srdm(s) => {
            srdm_stage::bake(scene, bundle, s, false, &Silent)?;
        }
        Step::EveryNeededStage(q) => {
            let settings = BakeSettings::resolve(scene, *q)?;
            bake_all(scene, bundle, &settings, false, &Silent)?;
        }
    }
    Ok(())
}

/// BLAKE3 of glint's source: `src/` and `shaders/` (every file, by path), `Cargo.toml` and
/// `Cargo.lock`. Hashed once per process.
fn source_hash() -> &'static str {
    static HASH: OnceLock<String> = OnceLock::new();
    HASH.get_or_init(|| {
        let mut h = blake3::Hasher::new();
        for rel in ["src", "shaders", "Cargo.toml", "Cargo.lock"] {
            hash_tree(&mut h, &super::repo(rel), true);
        }
        h.finalize().to_hex().to_string()
    })
}

/// Feeds `path` (a file, or a folder's files by sorted name, into subfolders when `recurse`)
/// into `h`: each file's name relative to the repository, its length and its bytes.
fn hash_tree(h: &mut blake3::Hasher, path: &Path, recurse: bool) {
    if path.is_file() {
        let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let rel = path.strip_prefix(super::repo("")).unwrap_or(path);
        h.update(rel.to_string_lossy().as_bytes());
        h.update(&(bytes.len() as u64).to_le_bytes());
        h.update(&bytes);
        return;
    }
    let mut entries: Vec<PathBuf> = std::fs::read_dir(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_file() || (recurse && p.is_dir()) {
            hash_tree(h, &p, recurse);
        }
    }
}
