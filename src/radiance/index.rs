//! `radiance/<reflector>/cameras.json` (kind `radiance-cameras`), typed, and the reader of a
//! reflector's maps: the stage ([`crate::bake::radiance_stage`]) writes these types, the viewer
//! reads them through [`load_cameras`] and [`read_map`], which find the reflector's folder as
//! the stage names it ([`reflector_folder`]) and read through the bundle's hash-checked reads.

use serde::{Deserialize, Serialize};

use super::MapPlan;
use super::quadtree::{self, Node};
use super::sampling::MapCamera;
use crate::bundle::{Bundle, BundleError, folder_name};
use crate::image_io::{ExrImage, ImageError, decode_exr};

/// The stage's name in the bundle.
pub const STAGE: &str = "radiance";

/// One map of `cameras.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MapEntry {
    /// File stem in the reflector's folder (`e{i}_{j}_c{k}`: `.exr`, `.qtree`).
    pub file: String,
    /// Reflector element (i, j).
    pub element: [u32; 2],
    /// Camera index on the element's hemisphere.
    pub camera: u32,
    /// Quadtree nodes.
    pub nodes: usize,
    /// The map's camera.
    pub view: MapCamera,
}

/// `radiance/<reflector>/cameras.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CamerasFile {
    /// Reflector name (scene.json).
    pub reflector: String,
    /// The sampling plan.
    pub plan: MapPlan,
    /// Every map, elements row by row, cameras in hemisphere order.
    pub maps: Vec<MapEntry>,
}

impl CamerasFile {
    /// The file as the stage writes it: pretty JSON, serialized through a `serde_json::Value`
    /// so numbers print as they always have (f32 widened to f64).
    pub fn to_bytes(&self) -> Vec<u8> {
        let value = serde_json::to_value(self).expect("cameras serialize");
        serde_json::to_vec_pretty(&value).expect("cameras serialize")
    }
}

/// The folder of reflector `name` in the stage (a file-name-safe form of the name).
pub fn reflector_folder(name: &str) -> String {
    folder_name(name)
}

/// Path of the cameras file of reflector `name`, in the stage.
pub fn cameras_path(name: &str) -> String {
    format!("{}/cameras.json", reflector_folder(name))
}

/// Path of map `stem`'s file with extension `ext` (`exr`, `qtree`) of reflector `name`, in
/// the stage.
pub fn map_path(name: &str, stem: &str, ext: &str) -> String {
    format!("{}/{stem}.{ext}", reflector_folder(name))
}

/// Why a reflector's maps cannot be read. Messages name the file.
#[derive(Debug, thiserror::Error)]
pub enum RadianceReadError {
    /// Finding or reading an asset (missing, or its hash differs from the manifest's).
    #[error(transparent)]
    Bundle(#[from] BundleError),
    /// A file does not parse or decode.
    #[error("{path}: {message}")]
    Format {
        /// The asset, `radiance/…`.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// An image does not decode.
    #[error("{path}: {source}")]
    Image {
        /// The asset, `radiance/…`.
        path: String,
        /// Cause.
        source: ImageError,
    },
}

/// Reads the cameras file of reflector `name` (hash-checked).
pub fn load_cameras(bundle: &Bundle, name: &str) -> Result<CamerasFile, RadianceReadError> {
    let rel = cameras_path(name);
    let bytes = bundle.read_stage_file(STAGE, &rel)?;
    serde_json::from_slice(&bytes).map_err(|e| RadianceReadError::Format {
        path: format!("{STAGE}/{rel}"),
        message: e.to_string(),
    })
}

/// One map read back: its image (R G B, A hit mask, Z depth) and quadtree.
pub struct StoredMap {
    /// The EXR, `resolution`² texels.
    pub image: ExrImage,
    /// The quadtree's nodes.
    pub nodes: Vec<Node>,
}

/// Reads map `entry` of reflector `name` and its quadtree (hash-checked), checking that the
/// image, the quadtree and the camera agree on the resolution.
pub fn read_map(
    bundle: &Bundle,
    name: &str,
    entry: &MapEntry,
) -> Result<StoredMap, RadianceReadError> {
    let exr = map_path(name, &entry.file, "exr");
    let qtree = map_path(name, &entry.file, "qtree");
    let image = decode_exr(&bundle.read_stage_file(STAGE, &exr)?).map_err(|source| {
        RadianceReadError::Image {
            path: format!("{STAGE}/{exr}"),
            source,
        }
    })?;
    let (res, nodes) =
        quadtree::decode(&bundle.read_stage_file(STAGE, &qtree)?).map_err(|message| {
            RadianceReadError::Format {
                path: format!("{STAGE}/{qtree}"),
                message,
            }
        })?;
    let r = entry.view.resolution;
    if res != r || image.width != r as usize || image.height != r as usize {
        return Err(RadianceReadError::Format {
            path: format!("{STAGE}/{exr}"),
            message: format!(
                "map is {}×{}, its quadtree {res}², its camera {r}²",
                image.width, image.height
            ),
        });
    }
    Ok(StoredMap { image, nodes })
}
