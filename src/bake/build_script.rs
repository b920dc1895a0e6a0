//! Baking from a Cargo build script: a program that ships a bundle bakes it as part of its
//! own build, re-baked only when one of the scene's files changes, and the build fails on a
//! bake error. README's "Bake in build.rs" section is the recipe.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::{BakeError, BakeSettings, StageReport, bake_all};
use crate::progress::Silent;
use crate::scene::{Quality, Scene, SceneError, uri_path};

/// Why a build script's bake failed.
#[derive(Debug, thiserror::Error)]
pub enum BuildBakeError {
    /// The scene does not load (the message names the file and field).
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A stage failed.
    #[error(transparent)]
    Bake(#[from] BakeError),
    /// Cargo's instructions could not be written.
    #[error("writing Cargo's instructions: {0}")]
    Cargo(std::io::Error),
}

/// The files `scene` was loaded from: its scene.json, the glTF it names and every external
/// buffer and image that glTF names (`data:` URIs are inside the glTF). Of the scene, a bake
/// reads these files alone (and hashes them all into its scene hash), so they are what a
/// build script watches.
pub fn scene_files(scene: &Scene) -> Vec<PathBuf> {
    let gltf_path = scene
        .path
        .parent()
        .unwrap_or(Path::new("."))
        .join(&scene.desc.geometry);
    let gltf_dir = gltf_path.parent().unwrap_or(Path::new(".")).to_owned();
    let mut files = vec![scene.path.clone(), gltf_path.clone()];
    // The scene loaded, so its glTF parses; only its external files are listed here.
    if let Some(doc) = std::fs::read(&gltf_path)
        .ok()
        .and_then(|b| gltf::Gltf::from_slice(&b).ok())
    {
        let buffers = doc.document.buffers().filter_map(|b| match b.source() {
            gltf::buffer::Source::Uri(uri) => Some(uri),
            gltf::buffer::Source::Bin => None,
        });
        let images = doc.document.images().filter_map(|i| match i.source() {
            gltf::image::Source::Uri { uri, .. } => Some(uri),
            gltf::image::Source::View { .. } => None,
        });
        for uri in buffers.chain(images) {
            if !uri.starts_with("data:") {
                files.push(gltf_dir.join(uri_path(uri)));
            }
        }
    }
    files.sort();
    files.dedup();
    files
}

/// Bakes every stage the scene at `scene_json` needs into the bundle at `bundle` at preset
/// `quality` with the scene's overrides (what `glint-bake --quality Q` bakes), for a Cargo
/// build script: prints `cargo:rerun-if-changed=` for scene.json and each other file of
/// [`scene_files`], so Cargo runs the script again only when one of them changes. Stages
/// already up to date are left alone; a bundle of an earlier version of the scene is
/// replaced, as the build's own output. Returns what was done to each stage.
pub fn bake_in_build_script(
    scene_json: impl AsRef<Path>,
    bundle: impl AsRef<Path>,
    quality: Quality,
) -> Result<Vec<StageReport>, BuildBakeError> {
    bake_telling_cargo(
        scene_json.as_ref(),
        bundle.as_ref(),
        quality,
        &mut std::io::stdout(),
    )
}

/// [`bake_in_build_script`] with Cargo's instructions written to `cargo` instead of stdout.
pub fn bake_telling_cargo(
    scene_json: &Path,
    bundle: &Path,
    quality: Quality,
    cargo: &mut dyn Write,
) -> Result<Vec<StageReport>, BuildBakeError> {
    let mut watch = |file: &Path| {
        writeln!(cargo, "cargo:rerun-if-changed={}", file.display()).map_err(BuildBakeError::Cargo)
    };
    // Watched before loading: a scene.json that does not load is still watched.
    watch(scene_json)?;
    let scene = Scene::load(scene_json)?;
    for file in scene_files(&scene).iter().filter(|f| *f != scene_json) {
        watch(file)?;
    }
    let settings = BakeSettings::resolve(&scene, quality)?;
    Ok(bake_all(&scene, bundle, &settings, true, &Silent)?)
}
