//! The `scene.json` file as written by users: serde types, defaults and presets.
//!
//! These types are the single source of `schemas/scene.schema.json` (generated with schemars;
//! `tests/schemas.rs` keeps the file current). Unknown keys are errors everywhere.
//!
//! Kept in one file: the whole scene.json format in one place, the single source of its schema.

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// The scene-description version this build reads and writes.
pub const SCENE_VERSION: u32 = 1;

/// Root of `scene.json`.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SceneDesc {
    /// Scene-description version; this build reads version 1.
    pub version: u32,
    /// Human-readable name (defaults to the file's folder name).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Path of the glTF 2.0 file (`.gltf` or `.glb`), relative to scene.json.
    pub geometry: String,
    /// Metres per glTF unit, for files not modelled in metres (positions are multiplied by
    /// it; lights and camera paths in this file are already in metres).
    #[serde(default = "default_scale")]
    pub scale: f32,
    /// Per glTF material name: overrides of what is derived from the glTF material.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub materials: BTreeMap<String, MaterialOverride>,
    /// Explicit area lights, for scenes whose glTF has no emitters.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lights: Vec<AreaLightDesc>,
    /// Surfaces that reflect the scene: glossy planes and curved objects.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub reflectors: Vec<ReflectorDesc>,
    /// Objects replaced by depth-map impostors when seen in curved reflectors.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub impostors: Vec<ImpostorDesc>,
    /// Camera paths replayed by the viewer. Each perspective camera node of the glTF is added
    /// as a one-keyframe path named after its node; a path named here wins a name clash.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub camera_paths: Vec<CameraPath>,
    /// Bake settings: a quality preset and per-stage overrides.
    #[serde(default)]
    pub bake: BakeDesc,
}

/// Overrides for one material. Absent fields keep the value mapped from glTF.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MaterialOverride {
    /// Diffuse albedo (linear RGB, each in [0, 1)).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub albedo: Option<[f32; 3]>,
    /// Emitted radiance (linear RGB, W·sr⁻¹·m⁻², ≥ 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub emission: Option<[f32; 3]>,
    /// Glossy lobes, each of the model it names (`kurt` when absent); `[]` makes the
    /// material purely diffuse.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lobes: Option<Vec<LobeDesc>>,
}

/// The reflection model of a glossy lobe.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum LobeModel {
    /// Kurt et al. 2010 as the regular-sampling paper writes it (Luksch et al. Eq. 2):
    /// Beckmann D, shadowing exponent `alpha`, Schlick F. The default.
    #[default]
    Kurt,
    /// The glTF 2.0 specular lobe (specification Appendix B): GGX D with α = `mx`, `my`,
    /// height-correlated Smith G, Schlick F. glTF materials map to it.
    Ggx,
    /// Cook–Torrance with Beckmann D (m = `mx`, `my`), Smith G and Schlick F.
    Beckmann,
}

/// Read by hand so that a wrong name is an error naming the field and every choice.
impl<'de> Deserialize<'de> for LobeModel {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<LobeModel, D::Error> {
        let name = String::deserialize(d)?;
        LobeModel::ALL
            .into_iter()
            .find(|m| m.name() == name)
            .ok_or_else(|| {
                serde::de::Error::custom(format!(
                    "lobe `model` {name:?} is unknown: expected one of `kurt`, `ggx`, `beckmann`"
                ))
            })
    }
}

impl LobeModel {
    /// Every model.
    pub const ALL: [LobeModel; 3] = [LobeModel::Kurt, LobeModel::Ggx, LobeModel::Beckmann];

    /// Whether this is the default model (`kurt`): scene.json and the bundle leave it out.
    pub fn is_kurt(&self) -> bool {
        *self == LobeModel::Kurt
    }

    /// The name scene.json uses.
    pub fn name(self) -> &'static str {
        match self {
            LobeModel::Kurt => "kurt",
            LobeModel::Ggx => "ggx",
            LobeModel::Beckmann => "beckmann",
        }
    }
}

/// One glossy lobe: k_s times a reflection model (Luksch et al. Eq. 1). The parameters mean
/// the same in every model; `alpha` belongs to `kurt` alone.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LobeDesc {
    /// Reflection model: `kurt` (default), `ggx` or `beckmann`.
    #[serde(default, skip_serializing_if = "LobeModel::is_kurt")]
    pub model: LobeModel,
    /// Lobe reflectivity k_s (linear RGB; colour of metals lives here).
    pub ks: [f32; 3],
    /// Schlick Fresnel reflectance at normal incidence (F₀), in [0, 1].
    pub r0: f32,
    /// Width of the distribution along the tangent, > 0: Beckmann m (`kurt`, `beckmann`) or
    /// GGX α (`ggx`; glTF roughness r gives α = r²). 1e-4 is a mirror.
    pub mx: f32,
    /// Width of the distribution along the bitangent, > 0.
    pub my: f32,
    /// `kurt` only, and required there: the shadowing exponent α in [0, 1] (0 keeps the
    /// directional albedo ≤ 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha: Option<f32>,
}

/// The lobe type under its former name (every lobe was a Kurt lobe).
pub type KurtLobe = LobeDesc;

/// A one- or two-sided quad light: points `corner + s·edge_u + t·edge_v`, s, t ∈ [0, 1].
/// It emits towards `edge_u × edge_v`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AreaLightDesc {
    /// Name used in messages and the bundle.
    pub name: String,
    /// One corner of the quad, world metres.
    pub corner: [f32; 3],
    /// First edge from the corner.
    pub edge_u: [f32; 3],
    /// Second edge from the corner.
    pub edge_v: [f32; 3],
    /// Emitted radiance (linear RGB, W·sr⁻¹·m⁻²).
    pub radiance: [f32; 3],
    /// Emit from both faces.
    #[serde(default)]
    pub two_sided: bool,
}

/// How a reflector reflects.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum ReflectorKind {
    /// A plane: radiance maps with depth (Bastos) or recursive reflection maps (Nielsen).
    Planar,
    /// A curved object: cube/environment maps, regular sampling, impostor reflections.
    Curved,
}

/// A reflector, selected by glTF mesh (or node) name or by material name: exactly one of the two.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ReflectorDesc {
    /// Name in messages and the bundle (defaults to the selecting name).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Select the triangles of the glTF meshes (or nodes) of this name.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh: Option<String>,
    /// Select every triangle with this glTF material.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material: Option<String>,
    /// Planar or curved.
    pub kind: ReflectorKind,
    /// Largest distance of a vertex from the fitted plane, relative to the reflector's
    /// bounding-box diagonal, for a `planar` reflector to be accepted.
    #[serde(default = "default_planarity_tolerance")]
    pub planarity_tolerance: f32,
    /// Radiance-map overrides for this reflector (otherwise chosen from its glossiness).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radiance: Option<RadianceOverride>,
    /// The side a `planar` reflector reflects, for an object that is more than one plane (a
    /// slab mirror: front, back and bevelled edges): `"+x"`, `"-x"`, `"+y"`, `"-y"`, `"+z"`,
    /// `"-z"` or a direction `[x, y, z]`: the largest coplanar face set facing that side
    /// (normal · direction > 0) reflects; `"auto"` (the default): the largest one, or between
    /// sets within 10% in area (a slab's front and back) the one with more open space in
    /// front of it, said in the log. The rest of the object is drawn as an ordinary surface.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub face: Option<FaceDesc>,
}

/// Which side of its object a planar reflector faces: a name (`"auto"`, `"+x"` … `"-z"`) or
/// a direction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum FaceDesc {
    /// `"auto"` or a signed axis, `"+x"` … `"-z"`.
    Named(String),
    /// A direction (need not be unit length).
    Direction([f32; 3]),
}

fn default_scale() -> f32 {
    1.0
}

fn default_planarity_tolerance() -> f32 {
    1e-3
}

/// Per-reflector radiance-map sampling overrides (Bastos §8.1.3).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RadianceOverride {
    /// Reflector elements along each of the plane's two axes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub elements: Option<[u32; 2]>,
    /// Cameras per hemisphere.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cameras_per_hemisphere: Option<u32>,
    /// Square map resolution in pixels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolution: Option<u32>,
}

/// An object that gets a depth-map impostor, selected by glTF mesh (or node) name.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ImpostorDesc {
    /// glTF mesh or node name.
    pub mesh: String,
    /// Number of capture views around the object.
    #[serde(default = "default_views")]
    pub views: u32,
    /// How the object's reflected billboards are made (Popescu et al. 2006 §3, §3.2);
    /// absent: through the centroid, facing each reflector, not connected.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub billboard: Option<BillboardDesc>,
}

/// The reflected billboards of one impostor object (Popescu et al. 2006 §3, §3.2).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BillboardDesc {
    /// Where the billboard's plane lies.
    #[serde(default)]
    pub placement: BillboardPlacement,
    /// Connects the billboard to the reflector's environment map (§3.2) with transition
    /// walls of this height H, metres (finite, > 0), rising from its edges on the reflector's
    /// side. Absent: not connected.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wall_height: Option<f32>,
}

/// Where an impostor object's billboard plane lies.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum BillboardPlacement {
    /// §3: through the object's centroid, perpendicular to the line to each reflector (one
    /// billboard per reflector).
    #[default]
    Centroid,
    /// §3: in the object's own plane, for flat objects the billboard approximates tightly
    /// (a floor, a table top): one plane for every reflector, the object's outline as its
    /// rectangle. The object's triangles must lie in one plane.
    Surface,
}

fn default_views() -> u32 {
    1
}

/// A named camera path: keyframes interpolated in time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CameraPath {
    /// Name to pick the path with `--replay NAME`.
    pub name: String,
    /// Frames per second at which the path is replayed, in (0, 1000]; a path has at most
    /// 1,000,000 frames.
    #[serde(default = "default_fps")]
    pub fps: f32,
    /// At least one keyframe, times strictly increasing.
    pub keyframes: Vec<Keyframe>,
}

fn default_fps() -> f32 {
    30.0
}

/// One camera pose.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Keyframe {
    /// Seconds from the start of the path, within ±86400.
    pub time: f32,
    /// Eye position, world metres (each coordinate within ±1e6, as are `target` and `up`).
    pub position: [f32; 3],
    /// Point looked at.
    pub target: [f32; 3],
    /// Up vector (need not be orthogonal to the view direction).
    #[serde(default = "default_up")]
    pub up: [f32; 3],
    /// Vertical field of view in degrees, in [0.1, 179].
    pub fov_y_deg: f32,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

/// Quality preset: the speed-for-accuracy point of every stage.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Quality {
    /// Fast previews.
    Draft,
    /// Everyday bakes.
    #[default]
    Default,
    /// Final bakes.
    High,
}

impl Quality {
    /// All presets, fastest first.
    pub const ALL: [Quality; 3] = [Quality::Draft, Quality::Default, Quality::High];

    /// The preset's name as written in scene.json and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Quality::Draft => "draft",
            Quality::Default => "default",
            Quality::High => "high",
        }
    }
}

/// `bake` in scene.json: a preset and overrides of single settings per stage.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BakeDesc {
    /// Preset used when the command line names none.
    #[serde(default)]
    pub quality: Quality,
    /// Radiosity overrides.
    #[serde(default)]
    pub radiosity: RadiosityOverride,
    /// Radiance-map overrides (for every planar reflector).
    #[serde(default)]
    pub radiance: RadianceStageOverride,
    /// Material-stage overrides.
    #[serde(default)]
    pub materials: MaterialsOverride,
    /// SRDM overrides.
    #[serde(default)]
    pub srdm: SrdmOverride,
}

/// Radiosity settings that a scene may fix, whatever the preset.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RadiosityOverride {
    /// Lightmap texels per metre.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texel_density: Option<f32>,
    /// Texels across each chart's longer side, at least (0: `texel_density` everywhere).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_chart_texels: Option<u32>,
    /// Texels across the scene's longest side, at least: a small scene's density is raised
    /// above `texel_density` to meet it (0: off).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_scene_texels: Option<u32>,
    /// Largest factor by which a chart's density is raised where other geometry comes within
    /// two texels of it (contacts, near occluders); 0 or 1: off.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_boost: Option<f32>,
    /// Texels across a curved chart per radian its surface turns: a chart whose normals
    /// spread by θ gets at least θ × this many texels across (0: off).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texels_per_radian: Option<f32>,
    /// Gathering rays per texel and bounce.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rays: Option<u32>,
    /// Emitter samples per texel, per area light and for the emissive triangles (in a scene
    /// with more than 8 emitters, 8 × this many drawn from all of them by their weight).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub light_samples: Option<u32>,
    /// Largest number of bounces.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bounces: Option<u32>,
    /// Largest number of glossy reflections a gathering ray follows (0: diffuse transport only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub glossy_depth: Option<u32>,
    /// Stop when a bounce changes the total reflected radiance by less than this fraction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<f32>,
    /// Relative standard error each texel's D should reach (e.g. 0.02): texels above it get
    /// more rays and emitter samples; 0 turns refinement off.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_error: Option<f32>,
    /// Make D agree across chart seams of smooth surfaces (least-squares stitching).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stitch_seams: Option<bool>,
    /// MiB of refinement rays the gather cache holds at most (rays beyond it are read once
    /// and kept as sums: memory stops growing with rays × texels); 0: none cached.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cache_budget_mib: Option<u32>,
    /// Most elements the atlas may hold (estimated): a larger scene gets every density scaled
    /// down by one factor until it fits; 0: no limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_elements: Option<u64>,
}

impl RadiosityOverride {
    /// Sets every field that is given.
    pub fn apply(&self, s: &mut RadiositySettings) {
        let RadiosityOverride {
            texel_density,
            min_chart_texels,
            min_scene_texels,
            contact_boost,
            texels_per_radian,
            rays,
            light_samples,
            bounces,
            glossy_depth,
            tolerance,
            target_error,
            stitch_seams,
            cache_budget_mib,
            max_elements,
        } = *self;
        s.texel_density = texel_density.unwrap_or(s.texel_density);
        s.min_chart_texels = min_chart_texels.unwrap_or(s.min_chart_texels);
        s.min_scene_texels = min_scene_texels.unwrap_or(s.min_scene_texels);
        s.contact_boost = contact_boost.unwrap_or(s.contact_boost);
        s.texels_per_radian = texels_per_radian.unwrap_or(s.texels_per_radian);
        s.rays = rays.unwrap_or(s.rays);
        s.light_samples = light_samples.unwrap_or(s.light_samples);
        s.bounces = bounces.unwrap_or(s.bounces);
        s.glossy_depth = glossy_depth.unwrap_or(s.glossy_depth);
        s.tolerance = tolerance.unwrap_or(s.tolerance);
        s.cache_budget_mib = cache_budget_mib.unwrap_or(s.cache_budget_mib);
        s.max_elements = max_elements.unwrap_or(s.max_elements);
        match target_error {
            // 0 turns refinement off: one batch of `rays` and `light_samples`.
            Some(0.0) => s.target_error = None,
            Some(t) => s.target_error = Some(t),
            None => {}
        }
        s.stitch_seams = stitch_seams.unwrap_or(s.stitch_seams);
    }
}

/// Radiance-map stage settings that a scene may fix, whatever the preset.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RadianceStageOverride {
    /// Multiplies the resolution chosen from glossiness.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolution_scale: Option<f32>,
}

/// Material-stage settings that a scene may fix, whatever the preset.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MaterialsOverride {
    /// Samples of the regular pattern per pixel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sample_budget: Option<u32>,
    /// Cube-map face size of prefiltered environment maps.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub env_map_size: Option<u32>,
}

/// SRDM settings that a scene may fix, whatever the preset.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SrdmOverride {
    /// Number of rotated domains n.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub domains: Option<u32>,
    /// Points per row m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub points: Option<u32>,
    /// Depth-map resolution.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolution: Option<u32>,
}

/// A setting outside its range: the field, as named in the stage's settings (`texel_density`),
/// and what was expected. Callers say where the value came from: scene.json's
/// `bake.radiosity.texel_density`, a flag `--texel-density`, or a sweep's knob.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("`{field}`: {message}")]
pub struct SettingError {
    /// The field.
    pub field: &'static str,
    /// The value and what was expected.
    pub message: String,
}

impl SettingError {
    /// An error for `field`.
    pub fn new(field: &'static str, message: impl Into<String>) -> SettingError {
        SettingError {
            field,
            message: message.into(),
        }
    }

    /// The field as a command-line flag: `--texel-density`.
    pub fn flag(&self) -> String {
        format!("--{}", self.field.replace('_', "-"))
    }
}

/// Largest `bake.radiance.resolution_scale`.
pub const MAX_RESOLUTION_SCALE: f32 = 16.0;

impl RadianceStageOverride {
    /// Checks `resolution_scale`: finite, in (0, [`MAX_RESOLUTION_SCALE`]].
    pub fn check(&self) -> Result<(), SettingError> {
        match self.resolution_scale {
            Some(v) if !(v.is_finite() && v > 0.0 && v <= MAX_RESOLUTION_SCALE) => {
                Err(SettingError::new(
                    "resolution_scale",
                    format!("{v} is not in (0, {MAX_RESOLUTION_SCALE}]"),
                ))
            }
            _ => Ok(()),
        }
    }
}

/// Largest reflector elements per axis, and cameras per hemisphere, of a radiance override.
pub const MAX_RADIANCE_ELEMENTS: u32 = 64;

/// Largest radiance-map resolution of an override, pixels.
pub const MAX_RADIANCE_RESOLUTION: u32 = 4096;

impl RadianceOverride {
    /// Checks each value given: elements per axis and cameras in 1 ..= 64, resolution in
    /// 1 ..= 4096.
    pub fn check(&self) -> Result<(), SettingError> {
        if let Some([a, b]) = self.elements
            && !((1..=MAX_RADIANCE_ELEMENTS).contains(&a)
                && (1..=MAX_RADIANCE_ELEMENTS).contains(&b))
        {
            return Err(SettingError::new(
                "elements",
                format!("[{a}, {b}]: each must be in 1 ..= {MAX_RADIANCE_ELEMENTS}"),
            ));
        }
        if let Some(c) = self.cameras_per_hemisphere
            && !(1..=MAX_RADIANCE_ELEMENTS).contains(&c)
        {
            return Err(SettingError::new(
                "cameras_per_hemisphere",
                format!("{c} is not in 1 ..= {MAX_RADIANCE_ELEMENTS}"),
            ));
        }
        if let Some(r) = self.resolution
            && !(1..=MAX_RADIANCE_RESOLUTION).contains(&r)
        {
            return Err(SettingError::new(
                "resolution",
                format!("{r} is not in 1 ..= {MAX_RADIANCE_RESOLUTION}"),
            ));
        }
        Ok(())
    }
}

/// Largest `glossy_depth` of the radiosity stage.
pub const MAX_GLOSSY_DEPTH: u32 = 64;

/// Largest [`RadiositySettings::texels_per_radian`]: 256 texels across a hemisphere's
/// quarter turn is far past any shading a texel shows.
pub const MAX_TEXELS_PER_RADIAN: f32 = 160.0;

/// Resolved radiosity settings (preset, then scene overrides, then command line).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct RadiositySettings {
    /// Lightmap texels per metre.
    pub texel_density: f32,
    /// Texels across each chart's longer side, at least: small charts get a higher density
    /// than `texel_density` (by at most 16×), so that small scenes and small parts are not
    /// a handful of texels across. 0: `texel_density` everywhere.
    #[serde(default)]
    pub min_chart_texels: u32,
    /// Texels across the scene's longest side, at least: a scene smaller than
    /// `min_scene_texels / texel_density` metres gets a higher density everywhere, so that a
    /// model's shading does not depend on its units or its size. 0: off.
    #[serde(default)]
    pub min_scene_texels: u32,
    /// Largest factor by which a chart's density is raised where other geometry comes within
    /// two texels of it: contacts and near occluders, where D changes within a texel
    /// ([`crate::radiosity::contacts`]; the atlas grows by at most 2×). 0 or 1: off.
    #[serde(default)]
    pub contact_boost: f32,
    /// Texels across a curved chart per radian its surface turns: a chart whose face normals
    /// spread by θ ([`crate::radiosity::atlas::chart_turn`]) gets at least θ × this many
    /// texels across (by at most 16× `texel_density`), so that D follows the shading of a
    /// curved mesh; flat charts get nothing from it. 0: off. Records without it read as off.
    #[serde(default)]
    pub texels_per_radian: f32,
    /// Gathering rays per texel and bounce.
    pub rays: u32,
    /// Emitter samples per texel, per area light and for the emissive triangles (in a scene
    /// with more than 8 emitters, 8 × this many drawn from all of them by their weight).
    pub light_samples: u32,
    /// Largest number of bounces.
    pub bounces: u32,
    /// Largest number of glossy reflections a gathering ray follows, so that D holds the light
    /// that arrives via glossy and mirror surfaces; 0 gathers diffuse interreflection only.
    pub glossy_depth: u32,
    /// Stop when a bounce changes the total reflected radiance by less than this fraction.
    pub tolerance: f32,
    /// Relative standard error each texel's D should reach: texels whose estimate is above it
    /// get more rays and emitter samples (`rays` and `light_samples` are the first batch).
    /// `None`: one batch.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_error: Option<f32>,
    /// Stitch the solved texels so that D agrees across the chart seams of smooth surfaces
    /// ([`crate::radiosity::seams`]). On in the default and high presets (whose
    /// `min_chart_texels` keeps charts wide enough that stitching keeps their shading).
    #[serde(default)]
    pub stitch_seams: bool,
    /// MiB of refinement rays the gather cache holds at most
    /// ([`crate::radiosity::solve::SolveSettings::cache_budget`]): rays beyond it are read
    /// once, against the radiance of that moment, and kept as sums per element, so memory
    /// stops growing with rays × texels (they then do not follow later bounces). 0: no
    /// refinement ray cached. Records without it read as the default, 2048.
    #[serde(default = "default_cache_budget_mib")]
    pub cache_budget_mib: u32,
    /// Most elements (lightmap texels with a sample) the atlas may hold, as estimated before
    /// baking with the contact boosts' most: a scene that would have more at these densities
    /// gets every density (`texel_density`, `min_chart_texels`, `texels_per_radian`) scaled
    /// down by one factor until it fits, so that a building bakes in bounded time and memory
    /// with the proportions of a room. 0: no limit. Records without it read as no limit.
    #[serde(default)]
    pub max_elements: u64,
}

/// [`RadiositySettings::max_elements`] of the presets (estimated elements, an upper bound of
/// what the atlas gets). Every shipped scene is below them, so they change nothing there; a
/// building of 2M triangles is not: at default it would have about 8M elements (25,000 CPU
/// seconds of gathering) and is baked at about a third of the density instead.
pub const MAX_ELEMENTS_DRAFT: u64 = 1_000_000;
/// See [`MAX_ELEMENTS_DRAFT`].
pub const MAX_ELEMENTS_DEFAULT: u64 = 2_000_000;
/// See [`MAX_ELEMENTS_DRAFT`].
pub const MAX_ELEMENTS_HIGH: u64 = 8_000_000;

/// [`RadiositySettings::cache_budget_mib`] of every preset: 2 GiB
/// ([`crate::radiosity::solve::CACHE_BUDGET`]).
fn default_cache_budget_mib() -> u32 {
    (crate::radiosity::solve::CACHE_BUDGET >> 20) as u32
}

impl RadiositySettings {
    /// The preset's values.
    pub fn preset(quality: Quality) -> Self {
        // The target error is what a preset promises; rays and light samples are the first
        // batch, refined where a texel's estimate is above the target.
        // Density follows the surfaces' sizes too: each chart gets `min_chart_texels` across,
        // enough for seams to be stitched without flattening a curved mesh's shading (on
        // bunny-mirror at 16 texels/m the bunny's charts are 1–2 texels wide). Draft leaves
        // seams unstitched: it is the quick look. And a small scene gets `min_scene` texels
        // across its longest side: a 2 m Cornell box is 36 texels per metre at default (shadow
        // and contact edges are where D's error is; docs/tuning.md#min-scene-texels).
        #[rustfmt::skip]
        let (texel_density, min_chart, min_scene, rays, light_samples, bounces, glossy_depth, tolerance, target, stitch) =
            match quality {
                Quality::Draft => (8.0, 4, 32, 64, 8, 8, 2, 1e-2, 0.05, false),
                Quality::Default => (16.0, 8, 72, 256, 32, 16, 4, 3e-3, 0.02, true),
                Quality::High => (32.0, 12, 96, 1024, 128, 32, 8, 1e-3, 0.01, true),
            };
        RadiositySettings {
            texel_density,
            min_chart_texels: min_chart,
            min_scene_texels: min_scene,
            contact_boost: match quality {
                // Contacts and shadow edges a texel cannot resolve (see `contacts`): off at
                // draft, the quick look.
                Quality::Draft => 0.0,
                Quality::Default | Quality::High => 8.0,
            },
            // A curved mesh's shading changes with its normal, so its charts get texels per
            // radian of curvature (docs/tuning.md#texels-per-radian). Off at draft, the quick look.
            texels_per_radian: match quality {
                Quality::Draft => 0.0,
                Quality::Default => 24.0,
                Quality::High => 36.0,
            },
            rays,
            light_samples,
            bounces,
            glossy_depth,
            tolerance,
            target_error: Some(target),
            stitch_seams: stitch,
            cache_budget_mib: default_cache_budget_mib(),
            max_elements: match quality {
                Quality::Draft => MAX_ELEMENTS_DRAFT,
                Quality::Default => MAX_ELEMENTS_DEFAULT,
                Quality::High => MAX_ELEMENTS_HIGH,
            },
        }
    }

    /// [`Self::cache_budget_mib`] in bytes.
    pub fn cache_budget(&self) -> u64 {
        u64::from(self.cache_budget_mib) << 20
    }

    /// Checks every value: rays and light samples ≥ 1, tolerance in [0, 1), texel density
    /// finite and > 0 (how high it may go is a question of memory, which the radiosity stage
    /// estimates); with `scene_size` (the scene's bounding-box diagonal, metres), a density so
    /// low that the scene spans less than a thousandth of a texel (no element would be made,
    /// and D would be black) is refused too.
    pub fn check(&self, scene_size: Option<f32>) -> Result<(), SettingError> {
        let d = self.texel_density;
        if !(d.is_finite() && d > 0.0) {
            return Err(SettingError::new(
                "texel_density",
                format!("{d:?} is not a finite density > 0 in texels per metre"),
            ));
        }
        // Charts are projected to texel units: a scene spanning less than this many texels
        // collapses to a point in f32 and the atlas has no element (D would be black). Any
        // span above it gives every triangle its texel.
        const MIN_SPAN_TEXELS: f64 = 1e-3;
        if let Some(size) = scene_size
            && (size as f64) * (d as f64) < MIN_SPAN_TEXELS
        {
            return Err(SettingError::new(
                "texel_density",
                format!(
                    "{d:?} texels per metre gives no element: the scene, {size:.3} m across, spans less than {MIN_SPAN_TEXELS} texel; use at least {:.3e}",
                    MIN_SPAN_TEXELS / size as f64
                ),
            ));
        }
        let b = self.contact_boost;
        if !(b.is_finite() && (0.0..=16.0).contains(&b)) {
            return Err(SettingError::new(
                "contact_boost",
                format!("{b} is not a factor in [0, 16] (0 or 1: off)"),
            ));
        }
        let r = self.texels_per_radian;
        if !(r.is_finite() && (0.0..=MAX_TEXELS_PER_RADIAN).contains(&r)) {
            return Err(SettingError::new(
                "texels_per_radian",
                format!("{r} is not in [0, {MAX_TEXELS_PER_RADIAN}] (0: off)"),
            ));
        }
        if self.rays == 0 {
            return Err(SettingError::new("rays", "0 is not ≥ 1"));
        }
        if self.light_samples == 0 {
            return Err(SettingError::new("light_samples", "0 is not ≥ 1"));
        }
        if self.glossy_depth > MAX_GLOSSY_DEPTH {
            return Err(SettingError::new(
                "glossy_depth",
                format!(
                    "{} is more than {MAX_GLOSSY_DEPTH} (Russian roulette ends paths long before)",
                    self.glossy_depth
                ),
            ));
        }
        let t = self.tolerance;
        if !(t.is_finite() && (0.0..1.0).contains(&t)) {
            return Err(SettingError::new(
                "tolerance",
                format!("{t} is not a fraction in [0, 1)"),
            ));
        }
        if let Some(e) = self.target_error
            && !(e.is_finite() && e > 0.0 && e < 1.0)
        {
            return Err(SettingError::new(
                "target_error",
                format!("{e} is not a relative error in (0, 1), e.g. 0.02 for 2%"),
            ));
        }
        Ok(())
    }

    /// The density a scene whose bounding box's longest side is `scene_side` metres gets:
    /// `texel_density`, raised to `min_scene_texels` across that side.
    pub fn scene_density(&self, scene_side: f32) -> f32 {
        let raised = self.min_scene_texels as f32 / scene_side;
        if self.min_scene_texels > 0 && raised.is_finite() && raised > self.texel_density {
            raised
        } else {
            self.texel_density
        }
    }

    /// How the atlas sizes the charts of a scene whose longest side is `scene_side` metres.
    pub fn density_rule(&self, scene_side: f32) -> crate::radiosity::atlas::DensityRule {
        crate::radiosity::atlas::DensityRule {
            per_metre: self.scene_density(scene_side),
            min_across: self.min_chart_texels as f32,
            per_radian: self.texels_per_radian,
        }
    }

    /// The most by which contact boosts may multiply the atlas's texels.
    pub fn contact_texel_factor(&self) -> f64 {
        if self.contact_boost > 1.0 {
            crate::radiosity::contacts::TEXEL_BUDGET
        } else {
            1.0
        }
    }

    /// The preset with the scene's overrides applied.
    pub fn resolve(quality: Quality, over: &RadiosityOverride) -> Self {
        let mut s = Self::preset(quality);
        over.apply(&mut s);
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_radiosity_setting_can_be_overridden_and_is_checked() {
        let over: RadiosityOverride = serde_json::from_str(
            r#"{ "texel_density": 4, "rays": 9, "light_samples": 7, "bounces": 3,
                 "glossy_depth": 5, "tolerance": 0.5, "target_error": 0.03 }"#,
        )
        .unwrap();
        let s = RadiositySettings::resolve(Quality::Draft, &over);
        assert_eq!(
            (
                s.texel_density,
                s.rays,
                s.light_samples,
                s.bounces,
                s.glossy_depth
            ),
            (4.0, 9, 7, 3, 5)
        );
        assert_eq!((s.tolerance, s.target_error), (0.5, Some(0.03)));
        s.check(None).unwrap();
        // Presets promise an error; 0 turns refinement off.
        assert_eq!(
            RadiositySettings::preset(Quality::Default).target_error,
            Some(0.02)
        );
        let off = RadiosityOverride {
            target_error: Some(0.0),
            ..Default::default()
        };
        assert_eq!(
            RadiositySettings::resolve(Quality::High, &off).target_error,
            None
        );
        for (field, bad) in [
            (
                "target_error",
                RadiosityOverride {
                    target_error: Some(1.5),
                    ..Default::default()
                },
            ),
            (
                "target_error",
                RadiosityOverride {
                    target_error: Some(f32::NAN),
                    ..Default::default()
                },
            ),
            (
                "glossy_depth",
                RadiosityOverride {
                    glossy_depth: Some(65),
                    ..Default::default()
                },
            ),
            (
                "light_samples",
                RadiosityOverride {
                    light_samples: Some(0),
                    ..Default::default()
                },
            ),
        ] {
            let e = RadiositySettings::resolve(Quality::Draft, &bad)
                .check(None)
                .unwrap_err();
            assert_eq!(e.field, field, "{e:?}");
        }
    }
}
