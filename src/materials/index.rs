//! `materials/index.json` (kind `materials-index`): what the materials stage holds, written by
//! the stage ([`crate::bake::materials`]) and read by the viewer through [`MaterialsIndex::load`]
//! and [`MaterialsIndex::read_image`], which go through the bundle's hash-checked reads.
//!
//! Field order is the file's: the stage serializes these types as they are declared.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::envmap::{CubeMap, MipFilter, MipPyramid};
use crate::bundle::{Bundle, BundleError};
use crate::image_io::{ExrImage, ImageError, decode_exr};
use crate::scene::LobeModel;
use crate::settings::materials::MaterialsSettings;

/// The stage's name in the bundle.
pub const STAGE: &str = "materials";

/// The index's file name in the stage.
pub const INDEX_FILE: &str = "index.json";

/// Value of `format`.
pub const INDEX_FORMAT: &str = "glint-materials-index";

/// Layout of every environment-map level (see [`super::envmap`]).
pub const ENV_LAYOUT: &str = "faces +x -x +y -y +z -z side by side, row 0 at the top";

/// Root of `materials/index.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MaterialsIndex {
    /// Always [`INDEX_FORMAT`].
    pub format: String,
    /// Index version, 1.
    pub version: u32,
    /// Settings of the bake.
    pub settings: MaterialsSettings,
    /// Every glossy material that covers a triangle, in scene order.
    pub materials: Vec<IndexedMaterial>,
    /// Environment maps of glossy curved reflectors.
    pub env_maps: Vec<IndexedEnvMap>,
    /// Why environment maps were not baked, if they were not.
    pub env_maps_skipped: Option<String>,
    /// Reflection probes for glossy surfaces that no reflector declares
    /// ([`super::probes`]); absent when the scene needs none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub probes: Vec<IndexedProbe>,
    /// Why the probes the scene needs were not baked, if they were not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub probes_skipped: Option<String>,
}

/// One material of [`MaterialsIndex`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IndexedMaterial {
    /// Material name (scene.json).
    pub name: String,
    /// Its folder in the stage.
    pub folder: String,
    /// Diffuse albedo.
    pub albedo: [f32; 3],
    /// Per lobe, in scene order.
    pub lobes: Vec<IndexedLobe>,
}

/// One lobe of an [`IndexedMaterial`]: its parameters and files.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IndexedLobe {
    /// Reflection model (absent: `kurt`, as in bundles written before the other models).
    #[serde(default = "kurt", skip_serializing_if = "LobeModel::is_kurt")]
    pub model: LobeModel,
    /// Specular colour k_s.
    pub ks: [f32; 3],
    /// Fresnel reflectance at normal incidence.
    pub r0: f32,
    /// Roughness along the tangent.
    pub mx: f32,
    /// Roughness along the bitangent.
    pub my: f32,
    /// Kurt's α (0 for the other models).
    pub alpha: f32,
    /// Whether m_x = m_y.
    pub isotropic: bool,
    /// The kernel K ([`super::kernel`]).
    pub kernel: IndexedKernel,
    /// R and A as a sphere map ([`super::reflectance`]).
    pub reflectance_sphere: IndexedMap,
    /// R and A as a 1D map (isotropic lobes).
    pub reflectance_1d: Option<IndexedMap1d>,
    /// The bound on cos θ of both maps ([`super::reflectance::C_GRAZING`]).
    pub reflectance_grazing_cos: f32,
    /// The regular sample pattern ([`super::pattern_format`]).
    pub pattern: IndexedPattern,
}

/// The index's `model` when absent.
fn kurt() -> LobeModel {
    LobeModel::Kurt
}

/// The kernel file of a lobe.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IndexedKernel {
    /// Path in the stage.
    pub path: String,
    /// Width = height, texels.
    pub size: u32,
    /// A mirror: the 1×1 identity.
    pub identity: bool,
    /// Angle per texel, radians.
    pub texel_angle_rad: f32,
    /// The lobe's angular radius, radians.
    pub lobe_radius_rad: f32,
    /// Fraction of q(h) where the support ends.
    pub cutoff_q: f32,
}

/// A square reflectance map.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IndexedMap {
    /// Path in the stage.
    pub path: String,
    /// Width = height, texels.
    pub size: u32,
}

/// A 1D reflectance map.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IndexedMap1d {
    /// Path in the stage.
    pub path: String,
    /// Texels.
    pub size: Option<u32>,
}

/// The pattern file of a lobe.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IndexedPattern {
    /// Path in the stage.
    pub path: String,
    /// Sample count.
    pub samples: usize,
    /// `s1` or `s2`.
    pub spacing: String,
    /// Circles.
    pub circles: u32,
    /// ξ₀.
    pub xi0: f32,
    /// θ_max, radians.
    pub theta_max_rad: f32,
    /// p_h.
    pub pdf_constant: f32,
}

/// One environment map of [`MaterialsIndex`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IndexedEnvMap {
    /// Reflector name (scene.json).
    pub reflector: String,
    /// Its material.
    pub material: String,
    /// Capture point, metres.
    pub centre: [f32; 3],
    /// Face size of level 0.
    pub face_size: usize,
    /// MIP filter.
    pub filter: MipFilter,
    /// Paths of the levels in the stage, finest first.
    pub levels: Vec<String>,
    /// [`ENV_LAYOUT`].
    pub layout: String,
}

/// One reflection probe of [`MaterialsIndex`]: a prefiltered radiance cube map whose level 0
/// also holds, in channel `Z`, the distance from the centre to what each texel sees (0:
/// nothing).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IndexedProbe {
    /// Probe name (a glossy material's, or scene.json's).
    pub name: String,
    /// Capture point, metres.
    pub centre: [f32; 3],
    /// Reach, metres.
    pub radius: f32,
    /// Face size of level 0.
    pub face_size: usize,
    /// MIP filter.
    pub filter: MipFilter,
    /// Paths of the levels in the stage, finest first.
    pub levels: Vec<String>,
    /// [`ENV_LAYOUT`].
    pub layout: String,
}

/// Why the materials stage cannot be read. Messages name the file.
#[derive(Debug, thiserror::Error)]
pub enum MaterialsReadError {
    /// Finding or reading an asset (missing, or its hash differs from the manifest's).
    #[error(transparent)]
    Bundle(#[from] BundleError),
    /// The index does not parse.
    #[error("{path}: {message}")]
    Index {
        /// The index file.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// An image does not decode.
    #[error("{path}: {source}")]
    Image {
        /// The asset.
        path: String,
        /// Cause.
        source: ImageError,
    },
}

impl MaterialsIndex {
    /// The index as the stage writes it: pretty JSON, one trailing newline. Serialized through
    /// a `serde_json::Value` so numbers print as they always have (f32 widened to f64).
    pub fn to_bytes(&self) -> Vec<u8> {
        let value = serde_json::to_value(self).expect("the index serializes");
        let text = serde_json::to_string_pretty(&value).expect("the index serializes");
        (text + "\n").into_bytes()
    }

    /// Reads the index of the bundle's materials stage (hash-checked); `Ok(None)` when the
    /// bundle has no such stage.
    pub fn load(bundle: &Bundle) -> Result<Option<MaterialsIndex>, MaterialsReadError> {
        if bundle.stage(STAGE).is_none() {
            return Ok(None);
        }
        let bytes = bundle.read_stage_file(STAGE, INDEX_FILE)?;
        Self::parse(&bytes).map(Some)
    }

    /// Parses the bytes of `index.json` and checks its format name.
    pub fn parse(bytes: &[u8]) -> Result<MaterialsIndex, MaterialsReadError> {
        let index: MaterialsIndex =
            serde_json::from_slice(bytes).map_err(|e| MaterialsReadError::Index {
                path: format!("{STAGE}/{INDEX_FILE}"),
                message: e.to_string(),
            })?;
        if index.format != INDEX_FORMAT {
            return Err(MaterialsReadError::Index {
                path: format!("{STAGE}/{INDEX_FILE}"),
                message: format!(
                    "field `format` is {:?}, expected {INDEX_FORMAT:?}",
                    index.format
                ),
            });
        }
        Ok(index)
    }

    /// The entry of material `name`.
    pub fn material(&self, name: &str) -> Option<&IndexedMaterial> {
        self.materials.iter().find(|m| m.name == name)
    }

    /// The environment map of reflector `name`.
    pub fn env_map(&self, reflector: &str) -> Option<&IndexedEnvMap> {
        self.env_maps.iter().find(|e| e.reflector == reflector)
    }

    /// Reads and decodes the EXR at `path` (a path in the stage, as the index lists it),
    /// hash-checked.
    pub fn read_image(bundle: &Bundle, path: &str) -> Result<ExrImage, MaterialsReadError> {
        let bytes = bundle.read_stage_file(STAGE, path)?;
        decode_exr(&bytes).map_err(|source| MaterialsReadError::Image {
            path: format!("{STAGE}/{path}"),
            source,
        })
    }

    /// Reads the environment map of `reflector` as a MIP pyramid (every level hash-checked);
    /// `Ok(None)` when the index lists none for it.
    pub fn read_env_pyramid(
        &self,
        bundle: &Bundle,
        reflector: &str,
    ) -> Result<Option<MipPyramid>, MaterialsReadError> {
        let Some(entry) = self.env_map(reflector) else {
            return Ok(None);
        };
        let (pyramid, _) = read_pyramid(bundle, &entry.levels, entry.filter, reflector)?;
        Ok(Some(pyramid))
    }

    /// Reads probe `index` ([`MaterialsIndex::probes`]): its MIP pyramid and the distances of
    /// its level 0 (every level hash-checked).
    pub fn read_probe(
        &self,
        bundle: &Bundle,
        index: usize,
    ) -> Result<(MipPyramid, CubeMap), MaterialsReadError> {
        let entry = &self.probes[index];
        let (pyramid, distances) = read_pyramid(bundle, &entry.levels, entry.filter, &entry.name)?;
        let distances = distances.ok_or_else(|| MaterialsReadError::Index {
            path: format!("{STAGE}/{}", entry.levels[0]),
            message: format!(
                "probe {}: level 0 has no `Z` channel (distances)",
                entry.name
            ),
        })?;
        Ok((pyramid, distances))
    }
}

/// Reads the cube-map levels at `paths` (strips of six faces, finest first, a power-of-two
/// level 0) and level 0's `Z` channel, if any, as a cube map of distances (in every channel).
fn read_pyramid(
    bundle: &Bundle,
    paths: &[String],
    filter: MipFilter,
    name: &str,
) -> Result<(MipPyramid, Option<CubeMap>), MaterialsReadError> {
    let bad = |path: &str, message: String| MaterialsReadError::Index {
        path: format!("{STAGE}/{path}"),
        message,
    };
    let mut levels = Vec::new();
    let mut distances = None;
    for path in paths {
        let image = MaterialsIndex::read_image(bundle, path)?;
        let n = image.height;
        if image.width != 6 * n || n == 0 {
            return Err(bad(
                path,
                format!("{}×{n} is not a strip of six faces", image.width),
            ));
        }
        let ch = |c: &str| {
            image
                .channel(c)
                .map_err(|source| MaterialsReadError::Image {
                    path: format!("{STAGE}/{path}"),
                    source,
                })
        };
        let unstrip = |r: &[f32], g: &[f32], b: &[f32]| {
            let mut map = CubeMap::new(n);
            for face in 0..6 {
                for y in 0..n {
                    for x in 0..n {
                        let s = y * 6 * n + face * n + x; // the strip: faces side by side
                        let i = map.index(face, x, y);
                        map.texels[i] = Vec3::new(r[s], g[s], b[s]);
                    }
                }
            }
            map
        };
        if levels.is_empty()
            && let Ok(z) = image.channel("Z")
        {
            distances = Some(unstrip(z, z, z));
        }
        let (r, g, b) = (ch("R")?, ch("G")?, ch("B")?);
        levels.push(unstrip(r, g, b));
    }
    if levels.is_empty() || !levels[0].size.is_power_of_two() {
        return Err(bad(
            INDEX_FILE,
            format!("env maps of {name}: no power-of-two level 0"),
        ));
    }
    Ok((MipPyramid { filter, levels }, distances))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_index_lobe_without_model_is_kurt_although_scene_json_defaults_to_ggx() {
        let text = include_str!("../../fuzz/corpus/materials_index/index.json");
        let index: MaterialsIndex = serde_json::from_str(text).unwrap();
        let lobe = &index.materials[0].lobes[0];
        assert_eq!(lobe.model, LobeModel::Kurt);
        // Written back the same way: kurt left out, another model named.
        assert!(serde_json::to_value(lobe).unwrap().get("model").is_none());
        let mut ggx = lobe.clone();
        ggx.model = LobeModel::Ggx;
        assert_eq!(serde_json::to_value(&ggx).unwrap()["model"], "ggx");
    }
}
