//! `srdm/index.json` (kind `srdm-index`), typed, and the reader of the `srdm` stage: the
//! stage ([`crate::bake::srdm_stage`]) writes these types, the viewer reads them through
//! [`load`], which reads every asset through the bundle's hash-checked reads.

use serde::{Deserialize, Serialize};

use super::Srdm;
use super::capture::{Capture, SrdmAssetError, decode_capture};
use crate::bundle::Bundle;
use crate::settings::srdm::SrdmSettings;

/// The stage's name in the bundle.
pub const STAGE: &str = "srdm";

/// The index's file name in the stage.
pub const INDEX_FILE: &str = "index.json";

/// `srdm/index.json`: what the stage holds, for the viewer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SrdmIndex {
    /// Index version, 1.
    pub version: u32,
    /// `albedo` or `radiosity`: what the captures' colour is.
    pub colour: String,
    /// Settings used.
    pub settings: SrdmSettings,
    /// Every view of every impostor, in scene.json order.
    pub views: Vec<IndexedView>,
}

/// One view in [`SrdmIndex`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IndexedView {
    /// Impostor name (the glTF mesh or node name from scene.json).
    pub impostor: String,
    /// View number, 0-based.
    pub view: u32,
    /// The `.srdm` file, relative to the stage folder.
    pub srdm: String,
    /// The capture EXR, relative to the stage folder.
    pub capture: String,
    /// Camera eye position.
    pub position: [f32; 3],
    /// Camera view direction.
    pub forward: [f32; 3],
}

/// One view read back from a bundle.
pub struct LoadedView {
    /// Its index entry.
    pub entry: IndexedView,
    /// The SRDM set (with the camera).
    pub srdm: Srdm,
    /// The capture.
    pub capture: Capture,
}

/// Reads every view of the bundle's `srdm` stage (what the viewer needs); `Ok(None)` when the
/// bundle has no such stage. Asset hashes are checked; errors name the asset.
pub fn load(bundle: &Bundle) -> Result<Option<(SrdmIndex, Vec<LoadedView>)>, SrdmAssetError> {
    if bundle.stage(STAGE).is_none() {
        return Ok(None);
    }
    let at = |rel: &str| format!("{}/{STAGE}/{rel}", bundle.dir().display());
    let index: SrdmIndex = serde_json::from_slice(&bundle.read_stage_file(STAGE, INDEX_FILE)?)
        .map_err(|e| SrdmAssetError::Inconsistent(format!("{}: {e}", at(INDEX_FILE))))?;
    let mut views = Vec::new();
    for entry in &index.views {
        let srdm =
            Srdm::from_bytes(&bundle.read_stage_file(STAGE, &entry.srdm)?).map_err(|source| {
                SrdmAssetError::Srdm {
                    path: at(&entry.srdm),
                    source,
                }
            })?;
        let capture = decode_capture(
            &bundle.read_stage_file(STAGE, &entry.capture)?,
            *srdm.camera(),
        )
        .map_err(|e| SrdmAssetError::Inconsistent(format!("{}: {e}", at(&entry.capture))))?;
        views.push(LoadedView {
            entry: entry.clone(),
            srdm,
            capture,
        });
    }
    Ok(Some((index, views)))
}
