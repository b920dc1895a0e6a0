//! What the materials stage reports: per material, per lobe and per environment map.

use serde::Serialize;

use crate::bundle::StageRecord;
use crate::scene::LobeModel;

/// What the stage did.
#[derive(Debug)]
pub enum Outcome {
    /// Nothing to bake: the reason.
    Skipped(String),
    /// Baked.
    Baked(Box<Report>),
}

/// One lobe's assets, for reports.
#[derive(Clone, Debug, Serialize)]
pub struct LobeReport {
    /// Lobe index within the material.
    pub lobe: usize,
    /// Reflection model (left out for `kurt`).
    #[serde(skip_serializing_if = "LobeModel::is_kurt")]
    pub model: LobeModel,
    /// Roughness along the tangent.
    pub mx: f32,
    /// Roughness along the bitangent.
    pub my: f32,
    /// Kernel width = height, texels (1: identity).
    pub kernel_size: u32,
    /// Angle per kernel texel, degrees.
    pub kernel_texel_deg: f32,
    /// Sphere-map size.
    pub sphere_map_size: u32,
    /// 1D-map size (isotropic lobes).
    pub map_1d_size: Option<u32>,
    /// Pattern samples.
    pub pattern_samples: usize,
    /// Pattern spacing (`s1`/`s2`).
    pub pattern_spacing: &'static str,
    /// Pattern circles.
    pub pattern_circles: u32,
}

/// One material's assets, for reports.
#[derive(Clone, Debug, Serialize)]
pub struct MaterialReport {
    /// Material name.
    pub name: String,
    /// Its folder in the stage.
    pub folder: String,
    /// Per lobe.
    pub lobes: Vec<LobeReport>,
    /// Files written.
    pub files: usize,
    /// Bytes written.
    pub bytes: u64,
}

/// One environment map, for reports.
#[derive(Clone, Debug, Serialize)]
pub struct EnvReport {
    /// Reflector name.
    pub reflector: String,
    /// Its material.
    pub material: String,
    /// Capture point (area-weighted centroid), metres.
    pub centre: [f32; 3],
    /// Face size of level 0.
    pub face_size: usize,
    /// MIP levels.
    pub levels: usize,
    /// Filter.
    pub filter: &'static str,
    /// Bytes written.
    pub bytes: u64,
}

/// What a bake wrote.
#[derive(Debug, Serialize)]
pub struct Report {
    /// The manifest record.
    #[serde(skip)]
    pub record: StageRecord,
    /// Why the stage is needed (the plan's reason).
    pub reason: String,
    /// Per material.
    pub materials: Vec<MaterialReport>,
    /// Per environment map.
    pub env_maps: Vec<EnvReport>,
    /// Why environment maps were not baked, if they were not.
    pub env_maps_skipped: Option<String>,
    /// Per reflection probe (`reflector`: `probe NAME`, no material).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub probes: Vec<EnvReport>,
    /// Why the probes the scene needs were not baked, if they were not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub probes_skipped: Option<String>,
}
