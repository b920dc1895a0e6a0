//! The `scene.json` file as written by users: serde types and defaults.
//!
//! These types are the single source of `schemas/scene.schema.json` (generated with schemars;
//! `tests/schemas.rs` keeps the file current). Unknown keys are errors everywhere. The `bake`
//! section's per-stage overrides, camera paths and lobe models are defined in the lower
//! modules that use them ([`crate::settings`], [`crate::camera`], [`crate::brdf`]) and
//! re-exported here.

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

pub use super::probe::ProbeDesc;
pub use crate::brdf::LobeModel;
pub use crate::camera::{CameraPath, Keyframe};
pub use crate::settings::materials::MaterialsOverride;
pub use crate::settings::radiance::{RadianceOverride, RadianceStageOverride};
pub use crate::settings::radiosity::RadiosityOverride;
// The resolved settings keep the path tests and benches name them by.
pub use crate::settings::radiosity::RadiositySettings;
pub use crate::settings::srdm::SrdmOverride;
pub use crate::settings::{Quality, SettingError};

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
    /// Reflection probes added to (or moved from) those the bake places for glossy
    /// surfaces that no reflector declares.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub probes: Vec<ProbeDesc>,
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
    /// Glossy lobes, each of the model it names (`ggx`, glTF's lobe, when absent); `[]`
    /// makes the material purely diffuse.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lobes: Option<Vec<LobeDesc>>,
    /// Thin transmission in [0, 1] (glTF `KHR_materials_transmission` `transmissionFactor`):
    /// that fraction of the light passes straight through, tinted by the glTF base colour and
    /// less its Fresnel reflection; the glTF's diffuse albedo is scaled by (1 − transmission)
    /// (an `albedo` given here is taken as the scaled one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transmission: Option<f32>,
    /// Index of refraction ≥ 1 of a transmissive material (`KHR_materials_ior`; 1.5 when
    /// absent): sets the Fresnel reflectance of its transmission and of glTF's dielectric lobe.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ior: Option<f32>,
}

/// One glossy lobe: k_s times a reflection model (Luksch et al. Eq. 1). Every model takes
/// `ks`, `r0`, `mx` and `my`, which mean the same in each; `alpha` belongs to `kurt` alone,
/// which requires it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LobeDesc {
    /// Reflection model: `ggx` (the default: glTF's lobe, GGX D and Smith G), `beckmann`
    /// (Beckmann D, Smith G) or `kurt` (Beckmann D and Kurt's shadowing exponent `alpha`).
    /// A lobe with `alpha` and no `model` is `kurt`, the one model that takes `alpha`.
    #[serde(default, skip_serializing_if = "LobeModel::is_ggx")]
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
    /// `kurt` only, and required there: Kurt's shadowing exponent α in [0, 1], the power of
    /// ((n·ωᵢ)(n·ωₒ)) in the lobe's denominator, F D / (4 (ωₒ·h) ((n·ωᵢ)(n·ωₒ))^α), which
    /// stands in for a shadowing term (0 keeps the directional albedo ≤ 1; larger values
    /// brighten grazing reflection).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha: Option<f32>,
}

/// A lobe as scene.json writes it, before its model is settled.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LobeFields {
    #[serde(default)]
    model: Option<LobeModel>,
    ks: [f32; 3],
    r0: f32,
    mx: f32,
    my: f32,
    #[serde(default)]
    alpha: Option<f32>,
}

/// Read through `LobeFields` so that a lobe with `alpha` and no `model` stays `kurt`:
/// scene.json files, and the bundles' copies of them, written while `kurt` was the default
/// keep their look.
impl<'de> Deserialize<'de> for LobeDesc {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<LobeDesc, D::Error> {
        let f = LobeFields::deserialize(d)?;
        let model = f.model.unwrap_or(if f.alpha.is_some() {
            LobeModel::Kurt
        } else {
            LobeModel::Ggx
        });
        Ok(LobeDesc {
            model,
            ks: f.ks,
            r0: f.r0,
            mx: f.mx,
            my: f.my,
            alpha: f.alpha,
        })
    }
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

impl BakeDesc {
    /// Checks every stage's overrides with that stage's own `resolve`, for a scene
    /// `scene_size` metres across (its bounding-box diagonal), so that a bad setting is refused
    /// when the scene is loaded. `Err((field, why))` with the field as written in scene.json
    /// (`bake.radiosity.texel_density`).
    pub fn check(&self, scene_size: f32) -> Result<(), (String, String)> {
        use crate::settings::{materials, radiosity, srdm};
        fn at(stage: &'static str) -> impl Fn(SettingError) -> (String, String) {
            move |e| (format!("bake.{stage}.{}", e.field), e.message)
        }
        // Each check is per field, and every preset passes it: checking the scene's own preset
        // with its overrides checks the overrides under any preset.
        let q = self.quality;
        radiosity::RadiositySettings::resolve(q, &[&self.radiosity], Some(scene_size))
            .map_err(at("radiosity"))?;
        materials::MaterialsSettings::resolve(q, &[&self.materials]).map_err(at("materials"))?;
        srdm::SrdmSettings::resolve(q, &[&self.srdm]).map_err(at("srdm"))?;
        self.radiance.check().map_err(at("radiance"))?;
        Ok(())
    }
}
