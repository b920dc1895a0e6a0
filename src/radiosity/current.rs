//! Which D is current: the one answer every stage downstream of D (materials' environment
//! maps, radiance maps, impostor colour) and the viewer ask of a bundle before they read D.
//!
//! D is current when the bundle has a `radiosity` stage baked from the same scene (same
//! scene hash). Its identity is a BLAKE3 over the stage's asset hashes in manifest order:
//! it changes whenever any asset does, so a stage records it to fall out of date when D is
//! re-baked.

use std::path::Path;

use super::map::{MapError, RadiosityMap};
use crate::bundle::{Bundle, BundleError};

/// The stage that holds D.
pub const STAGE: &str = "radiosity";

/// What a bundle holds of D for a scene.
#[derive(Debug)]
pub enum CurrentD {
    /// No bundle yet (no manifest), or no `radiosity` stage.
    Missing,
    /// A `radiosity` stage baked from another scene.
    OtherScene,
    /// D baked from this scene: the opened bundle and D's identity.
    Current {
        /// The bundle, opened.
        bundle: Box<Bundle>,
        /// [`crate::bundle::StageRecord::identity`] of its radiosity stage.
        identity: String,
    },
}

impl CurrentD {
    /// D's identity, when current.
    pub fn identity(&self) -> Option<&str> {
        match self {
            CurrentD::Current { identity, .. } => Some(identity),
            _ => None,
        }
    }

    /// Loads the current D: the map with its identity; `Ok(None)` when there is none.
    pub fn load(&self) -> Result<Option<(RadiosityMap, String)>, MapError> {
        match self {
            CurrentD::Current { bundle, identity } => {
                Ok(RadiosityMap::load(bundle)?.map(|m| (m, identity.clone())))
            }
            _ => Ok(None),
        }
    }
}

/// Which D is current in an opened bundle for the scene with hash `scene_hash`.
pub fn current_in(bundle: Bundle, scene_hash: &str) -> CurrentD {
    match bundle.stage(STAGE) {
        None => CurrentD::Missing,
        Some(s) if s.scene_hash != scene_hash => CurrentD::OtherScene,
        Some(s) => {
            let identity = s.identity();
            CurrentD::Current {
                bundle: Box::new(bundle),
                identity,
            }
        }
    }
}

/// Which D is current in the bundle at `dir` for the scene with hash `scene_hash`. A folder
/// without a manifest (a bundle not yet baked) has none; other errors reading the manifest
/// are returned.
pub fn current_d(dir: &Path, scene_hash: &str) -> Result<CurrentD, BundleError> {
    match Bundle::open(dir) {
        Ok(b) => Ok(current_in(b, scene_hash)),
        Err(BundleError::MissingManifest { .. }) => Ok(CurrentD::Missing),
        Err(e) => Err(e),
    }
}

/// The identity of the current D of the bundle at `dir`, or `None` (no current D, or the
/// manifest cannot be read).
pub fn d_identity(dir: &Path, scene_hash: &str) -> Option<String> {
    current_d(dir, scene_hash)
        .ok()?
        .identity()
        .map(str::to_owned)
}
