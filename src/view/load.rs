//! A bundle opened for viewing: its scene (reloaded from the bundle's `scene/` stage, in the
//! triangle order the atlas uses) and its radiosity textures, with every check the viewer needs
//! done first, so that a bad bundle gives one clear message naming the bundle and never a panic.
//!
//! Checked, in order: the folder exists and is a bundle; the manifest's format and version
//! (a newer major is refused naming both versions); the `scene` and `radiosity` stages are
//! present and were baked from the same scene; every asset of those stages and of the
//! `materials`, `radiance` and `srdm` stages (when present) has its recorded size and BLAKE3
//! hash, and the scene's files name only assets of the scene stage
//! ([`Bundle::check_scene_references`]); the scene loads; the atlas covers exactly the scene's triangles with
//! finite coordinates; the radiosity pages match the atlas and hold finite values.

use std::path::{Path, PathBuf};

use crate::bundle::{Bundle, BundleError};
use crate::radiosity::RadiosityMap;
use crate::radiosity::map::MapError;
use crate::scene::{Scene, SceneError};

/// Stages the viewer needs.
pub const REQUIRED_STAGES: [&str; 2] = ["scene", "radiosity"];

/// Every stage the viewer reads when the bundle has it: each of their assets is checked
/// against the manifest at load.
pub const READ_STAGES: [&str; 5] = ["scene", "radiosity", "materials", "radiance", "srdm"];

/// Why a bundle cannot be viewed. Every message starts with the bundle's path.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The folder does not exist.
    #[error("bundle {}: no such folder", bundle.display())]
    NotFound {
        /// The bundle path given.
        bundle: PathBuf,
    },
    /// The manifest is missing, unreadable, corrupt or of another format version.
    #[error("bundle {}: {source}", bundle.display())]
    Bundle {
        /// The bundle.
        bundle: PathBuf,
        /// What [`Bundle::open`] reported.
        #[source]
        source: BundleError,
    },
    /// A stage the viewer needs was never baked.
    #[error(
        "bundle {}: has no `{stage}` stage (it has: {present}); bake it with `glint-bake SCENE.json --bundle {}`",
        bundle.display(), bundle.display()
    )]
    MissingStage {
        /// The bundle.
        bundle: PathBuf,
        /// The missing stage.
        stage: &'static str,
        /// The stages it has, comma-separated (or `none`).
        present: String,
    },
    /// Two stages were baked from different scenes.
    #[error(
        "bundle {}: stage `{stage}` was baked from scene {found:.12}…, stage `scene` holds scene {expected:.12}…; re-bake with `glint-bake SCENE.json --bundle {} --force`",
        bundle.display(), bundle.display()
    )]
    StaleStage {
        /// The bundle.
        bundle: PathBuf,
        /// The stage that disagrees.
        stage: &'static str,
        /// Its scene hash.
        found: String,
        /// The scene stage's hash.
        expected: String,
    },
    /// Assets differ from their manifest records (size or hash) or are missing.
    #[error("bundle {}: {} asset(s) damaged:\n  {}", bundle.display(), problems.len(), problems.join("\n  "))]
    Damaged {
        /// The bundle.
        bundle: PathBuf,
        /// One line per damaged asset, naming its file and what differs.
        problems: Vec<String>,
    },
    /// The bundle's scene does not load.
    #[error("bundle {}: its scene does not load: {source}", bundle.display())]
    Scene {
        /// The bundle.
        bundle: PathBuf,
        /// The scene loader's error (it names the file and field).
        #[source]
        source: SceneError,
    },
    /// The bundle's scene names texture files its scene stage did not copy (baked before
    /// bundle format 2.1).
    #[error("bundle {}: its scene does not load: {source}; its scene stage holds no texture images (it was baked before bundle format 2.1 carried them): re-bake it with `glint-bake --force`", bundle.display())]
    SceneWithoutImages {
        /// The bundle.
        bundle: PathBuf,
        /// The scene loader's error.
        #[source]
        source: SceneError,
    },
    /// The radiosity stage cannot be read.
    #[error("bundle {}: radiosity stage: {source}", bundle.display())]
    Radiosity {
        /// The bundle.
        bundle: PathBuf,
        /// The cause.
        #[source]
        source: MapError,
    },
    /// Assets are intact but disagree with each other.
    #[error("bundle {}: {message}", bundle.display())]
    Inconsistent {
        /// The bundle.
        bundle: PathBuf,
        /// What disagrees.
        message: String,
    },
}

/// What the viewer draws: the scene and its diffuse light D.
pub struct ViewData {
    /// The opened bundle.
    pub bundle: Bundle,
    /// The scene as the bundle's `scene/` stage holds it.
    pub scene: Scene,
    /// The radiosity textures and their atlas (one entry per scene triangle).
    pub map: RadiosityMap,
}

impl std::fmt::Debug for ViewData {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ViewData")
            .field("bundle", &self.bundle.dir())
            .field("scene", &self.scene)
            .field("pages", &self.map.pages.len())
            .finish()
    }
}

/// Opens and checks the bundle at `dir` for viewing.
pub fn load(dir: &Path) -> Result<ViewData, LoadError> {
    let bundle_path = dir.to_owned();
    if !dir.is_dir() {
        return Err(LoadError::NotFound {
            bundle: bundle_path,
        });
    }
    let bundle = Bundle::open(dir).map_err(|source| LoadError::Bundle {
        bundle: bundle_path.clone(),
        source,
    })?;
    let inconsistent = |message: String| LoadError::Inconsistent {
        bundle: bundle_path.clone(),
        message,
    };

    // Stages present, from one scene.
    let present = {
        let names: Vec<&str> = bundle
            .manifest()
            .stages
            .keys()
            .map(String::as_str)
            .collect();
        if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        }
    };
    for stage in REQUIRED_STAGES {
        if bundle.stage(stage).is_none() {
            return Err(LoadError::MissingStage {
                bundle: bundle_path.clone(),
                stage,
                present: present.clone(),
            });
        }
    }
    let scene_stage = bundle.stage("scene").expect("checked above");
    let radiosity_stage = bundle.stage("radiosity").expect("checked above");
    if radiosity_stage.scene_hash != scene_stage.scene_hash {
        return Err(LoadError::StaleStage {
            bundle: bundle_path.clone(),
            stage: "radiosity",
            found: radiosity_stage.scene_hash.clone(),
            expected: scene_stage.scene_hash.clone(),
        });
    }

    // Every asset the viewer reads, against its size and hash, and the scene's references to
    // its files: the check `verify` makes, before the scene is read.
    let problems: Vec<String> = bundle
        .verify_stages(&READ_STAGES)
        .iter()
        .map(|e| e.to_string())
        .collect();
    if !problems.is_empty() {
        return Err(LoadError::Damaged {
            bundle: bundle_path.clone(),
            problems,
        });
    }

    // The scene, from the bundle's own copy.
    let scene_json = scene_stage
        .assets
        .iter()
        .find(|a| a.kind == "scene-json")
        .ok_or_else(|| inconsistent("stage `scene` has no scene-json asset".into()))?;
    let has_images = scene_stage.assets.iter().any(|a| a.kind == "gltf-image");
    let mut scene = Scene::load(bundle.asset_path(scene_json)).map_err(|source| {
        // A scene stage from before format 2.1 did not copy the glTF's image files.
        if !has_images && source.to_string().contains("image") {
            LoadError::SceneWithoutImages {
                bundle: bundle_path.clone(),
                source,
            }
        } else {
            LoadError::Scene {
                bundle: bundle_path.clone(),
                source,
            }
        }
    })?;
    // The copy is scene.json re-serialized (geometry renamed, name filled in), so its text,
    // and with it `content_hash`, differ from the source's. Its assets were verified above:
    // it is the scene every stage recorded as `scene_hash`, so it takes that identity, and
    // the stages' own freshness checks (e.g. [`crate::radiosity::current_d`] choosing D) agree
    // with what the viewer loaded.
    scene.content_hash = scene_stage.scene_hash.clone();

    let map = RadiosityMap::load(&bundle)
        .map_err(|source| LoadError::Radiosity {
            bundle: bundle_path.clone(),
            source,
        })?
        .ok_or_else(|| inconsistent("stage `radiosity` disappeared while loading".into()))?;
    check_map(&scene, &map).map_err(inconsistent)?;
    Ok(ViewData { bundle, scene, map })
}

/// The atlas must cover the scene's triangles one for one, with finite coordinates on
/// existing pages, and the pages must hold finite radiance.
fn check_map(scene: &Scene, map: &RadiosityMap) -> Result<(), String> {
    let atlas = &map.atlas;
    if atlas.tri_coords.len() != atlas.tri_page.len()
        || atlas.tri_page.len() < atlas.backs.len()
        || atlas.scene_triangles() != scene.triangles.len()
    {
        return Err(format!(
            "the radiosity atlas has {} triangles, the scene {}: the stages come from different geometry; re-bake",
            atlas.tri_page.len().saturating_sub(atlas.backs.len()),
            scene.triangles.len()
        ));
    }
    if atlas.pages.is_empty() {
        return Err("the radiosity atlas has no pages".into());
    }
    if let Some(p) = atlas.pages.iter().find(|p| p.width == 0 || p.height == 0) {
        return Err(format!(
            "a radiosity page is {}×{} texels",
            p.width, p.height
        ));
    }
    if let Some(t) = atlas
        .tri_coords
        .iter()
        .position(|c| !c.iter().all(|v| v.is_finite()))
    {
        return Err(format!("triangle {t} has non-finite lightmap coordinates"));
    }
    if let Some(t) = atlas
        .tri_page
        .iter()
        .position(|&p| p as usize >= atlas.pages.len())
    {
        return Err(format!(
            "triangle {t} refers to page {} of {}",
            atlas.tri_page[t],
            atlas.pages.len()
        ));
    }
    for (i, page) in map.pages.iter().enumerate() {
        if let Some(k) = page.iter().position(|v| !v.is_finite()) {
            return Err(format!(
                "radiosity page {i} has a non-finite value at texel {k}"
            ));
        }
    }
    Ok(())
}
