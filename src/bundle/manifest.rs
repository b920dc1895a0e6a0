//! `manifest.json`: what a bundle holds, made by which glint from which scene.
//!
//! The types here generate `schemas/manifest.schema.json`. Unknown keys are errors, as is a
//! missing required field or an asset kind not in [`ASSET_KINDS`]: a typo must not read as an
//! empty bundle. Within a major format version fields and kinds are only ever added, so a
//! manifest of a newer minor version is read without the keys and kinds this glint does not
//! know; a newer major is refused.
//!
//! Version 2 names each stage's folder in the manifest (`dir`, e.g. `radiance.3`): a commit
//! writes a new folder and then renames the manifest, so the rename alone switches readers
//! to the new stage. Version 1 bundles (no `dir`: the folder is the stage's name) are still
//! read; a version 1 glint refuses a version 2 bundle as newer instead of looking for its
//! files in the wrong folder.
//!
//! Version 2.1 adds the glTF's external images to the scene stage (kind `gltf-image`), and
//! defines the radiosity textures of a material with a base colour texture as D over that
//! texture's texel mean (`scene::texturing`), which is what a 2.0 glint stored for such a
//! material (it read no textures): 2.0 bundles stay valid, except that a `.gltf` scene whose
//! textures are external files must have its scene stage re-baked for the viewer to find them.

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Value of `format`.
pub const FORMAT_NAME: &str = "glint-bundle";

/// The format version this build writes; it reads any 1.x.y and 2.x.y.
pub const FORMAT_VERSION: FormatVersion = FormatVersion {
    major: 2,
    minor: 1,
    patch: 0,
};

/// The oldest major version this build reads (version 1: stage folders named after their stage).
pub const OLDEST_READ_MAJOR: u64 = 1;

/// `generator`: the glint version that wrote a stage.
pub fn generator() -> String {
    format!("glint {}", env!("CARGO_PKG_VERSION"))
}

/// A semantic version `MAJOR.MINOR.PATCH`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct FormatVersion {
    /// Incompatible changes.
    pub major: u64,
    /// Added fields or asset kinds.
    pub minor: u64,
    /// Fixes.
    pub patch: u64,
}

impl std::fmt::Display for FormatVersion {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}.{}.{}", self.major, self.minor, self.patch)
    }
}

impl std::str::FromStr for FormatVersion {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let parts: Vec<&str> = s.split('.').collect();
        let num = |p: &str| {
            p.parse::<u64>()
                .map_err(|_| format!("{s:?} is not MAJOR.MINOR.PATCH"))
        };
        match parts.as_slice() {
            [a, b, c] => Ok(FormatVersion {
                major: num(a)?,
                minor: num(b)?,
                patch: num(c)?,
            }),
            _ => Err(format!("{s:?} is not MAJOR.MINOR.PATCH")),
        }
    }
}

/// Every asset kind a stage writes (`AssetRecord::kind`).
pub const ASSET_KINDS: &[&str] = &[
    // scene
    "scene-json",
    "gltf",
    "gltf-buffer",
    "gltf-image",
    // radiosity (and a unit shard's gathered elements)
    "atlas",
    "radiosity-exr",
    "radiosity-gather",
    "preview-png",
    // materials
    "materials-index",
    "kernel",
    "reflectance-sphere",
    "reflectance-1d",
    "sample-pattern",
    "env-mip",
    // radiance
    "radiance-cameras",
    "radiance-exr",
    "quadtree",
    // srdm
    "srdm-index",
    "srdm",
    "impostor-exr",
];

/// Root of `manifest.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// Always `glint-bundle`.
    pub format: String,
    /// Semantic version of the bundle format, `MAJOR.MINOR.PATCH`.
    pub format_version: String,
    /// glint version that last wrote the manifest.
    pub generator: String,
    /// Name of the scene the bundle was baked from.
    pub scene_name: String,
    /// BLAKE3 (hex) of the scene's files (scene.json, glTF, buffers).
    pub scene_hash: String,
    /// Stages by name (`radiosity`, `materials`, `radiance`, `srdm`).
    pub stages: BTreeMap<String, StageRecord>,
}

/// What one stage wrote.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StageRecord {
    /// glint version that baked the stage.
    pub generator: String,
    /// Scene hash the stage was baked from.
    pub scene_hash: String,
    /// Settings used (stage-specific object).
    pub settings: serde_json::Value,
    /// Wall-clock bake time, seconds.
    pub bake_seconds: f64,
    /// Stage-specific figures (texel counts, rays cast, …).
    #[serde(default)]
    pub stats: BTreeMap<String, serde_json::Value>,
    /// Files of the stage.
    pub assets: Vec<AssetRecord>,
    /// The stage's folder in the bundle (`NAME.N`, since format 2); absent in version 1
    /// bundles, whose folder is the stage's name. Asset `path`s stay logical
    /// (`NAME/…`): readers resolve them into this folder.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dir: Option<String>,
}

impl StageRecord {
    /// The folder holding the files of stage `name`: `dir`, or `name` in a version 1 bundle.
    pub fn folder<'a>(&'a self, name: &'a str) -> &'a str {
        self.dir.as_deref().unwrap_or(name)
    }

    /// The stage's identity: a BLAKE3 over its assets' hashes in manifest order, so it changes
    /// whenever any asset does. A stage that reads another records the identity it read.
    pub fn identity(&self) -> String {
        let mut hasher = blake3::Hasher::new();
        for a in &self.assets {
            hasher.update(a.blake3.as_bytes());
        }
        hasher.finalize().to_hex().to_string()
    }
}

/// One file of a stage.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AssetRecord {
    /// Logical path, `/`-separated: the stage's name, then the file's path inside the stage's
    /// folder (`radiance/Floor/cameras.json`). On disk the file lies in the folder the stage
    /// record names ([`StageRecord::dir`]).
    pub path: String,
    /// What the file is, one of [`ASSET_KINDS`] (e.g. `radiosity-exr`, `atlas`, `preview-png`).
    pub kind: String,
    /// Size in bytes.
    pub bytes: u64,
    /// BLAKE3 of the contents: 64 lowercase hex digits.
    pub blake3: String,
}

impl Manifest {
    /// An empty manifest for a scene.
    pub fn new(scene_name: &str, scene_hash: &str) -> Manifest {
        Manifest {
            format: FORMAT_NAME.into(),
            format_version: FORMAT_VERSION.to_string(),
            generator: generator(),
            scene_name: scene_name.into(),
            scene_hash: scene_hash.into(),
            stages: BTreeMap::new(),
        }
    }

    /// Every asset of every stage, in stage order.
    pub fn assets(&self) -> impl Iterator<Item = (&str, &AssetRecord)> {
        self.stages
            .iter()
            .flat_map(|(s, r)| r.assets.iter().map(move |a| (s.as_str(), a)))
    }
}
