//! The scene a bundle carries, read back: the typed reader of the `scene` stage that
//! [`crate::bake::scene_stage`] writes, for `glint-eval probe` and library programs. Each later
//! stage's reader lies next to its format: [`crate::radiosity::RadiosityMap::load`],
//! [`crate::materials::index::MaterialsIndex::load`], [`crate::radiance::index::load_cameras`],
//! [`crate::srdm::index::load`].

use std::path::PathBuf;

use crate::bundle::{Bundle, BundleError};
use crate::scene::{Scene, SceneError};

/// Why a bundle's scene cannot be read. Messages name the bundle or the file.
#[derive(Debug, thiserror::Error)]
pub enum SceneReadError {
    /// The bundle has no `scene` stage.
    #[error("{}: no scene stage (bake it with glint-bake)", dir.display())]
    NoSceneStage {
        /// The bundle folder.
        dir: PathBuf,
    },
    /// A file of the scene stage is missing, damaged, or names a file outside the stage.
    #[error("{}: {source}", dir.display())]
    Damaged {
        /// The bundle folder.
        dir: PathBuf,
        /// The first problem found.
        source: BundleError,
    },
    /// The bundle's copy of the scene does not load.
    #[error(transparent)]
    Scene(#[from] SceneError),
}

impl Bundle {
    /// The scene of the bundle's `scene` stage, loaded from the bundle's own copy after its
    /// files were hash-checked ([`Bundle::verify_stages`]). Its `content_hash` is the stage's
    /// recorded scene hash: the copy is scene.json re-serialized, so hashing its text would
    /// not name the scene every stage was baked from.
    pub fn load_scene(&self) -> Result<Scene, SceneReadError> {
        let no_stage = || SceneReadError::NoSceneStage {
            dir: self.dir().to_owned(),
        };
        let stage = self.stage("scene").ok_or_else(no_stage)?;
        let scene_json = self
            .stage_asset("scene", "scene.json")
            .map_err(|_| no_stage())?;
        if let Some(source) = self.verify_stages(&["scene"]).into_iter().next() {
            return Err(SceneReadError::Damaged {
                dir: self.dir().to_owned(),
                source,
            });
        }
        let mut scene = Scene::load(self.asset_path(scene_json))?;
        scene.content_hash = stage.scene_hash.clone();
        Ok(scene)
    }
}
