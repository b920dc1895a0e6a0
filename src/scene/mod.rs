//! Scenes: `scene.json` plus its glTF geometry, resolved and validated.
//!
//! [`Scene::load`] reads and checks everything, in this order: [`desc`] (the file's schema and
//! version), the glTF (`gltf_import`), [`material`] overrides, lights (`light`), the bake
//! settings, reflectors (`reflector`, with `plane` fits and, for a planar face of a solid, the
//! coplanar face sets of [`faces`]), impostors (`impostor`) and camera paths (`camera_path`,
//! then the glTF's cameras, `gltf_cameras`). Each part's types are re-exported here.

mod camera_path;
pub mod desc;
pub mod faces;
mod gltf_cameras;
pub(crate) mod gltf_import;
pub mod gltf_textures;
pub(crate) mod gltf_uri;
mod impostor;
mod light;
pub mod material;
mod plane;
pub mod probe;
mod reflector;
pub mod texture;
pub mod texturing;

use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::Vec3;

pub use camera_path::{FOV_RANGE_DEG, MAX_CAMERA_COORD, MAX_FPS, MAX_KEYFRAME_TIME};
pub use desc::{
    AreaLightDesc, CameraPath, Keyframe, KurtLobe, LobeDesc, LobeModel, Quality, ReflectorKind,
    SCENE_VERSION, SceneDesc,
};
pub use gltf_uri::uri_path;
pub use impostor::{Impostor, ImpostorBillboard, SURFACE_PLANARITY};
pub use light::AreaLight;
pub use material::Material;
pub use plane::Plane;
pub use reflector::Reflector;

use crate::geometry::{Aabb, Bvh, Triangle};

/// Why a scene could not be loaded. Every variant names the file; field errors name the field.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// scene.json is not valid JSON or does not fit the schema.
    #[error("{}:{line}:{column}: {message}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What serde said.
        message: String,
    },
    /// scene.json is of a version this build does not read.
    #[error(
        "{}: field `version`: found {found}, this build of glint reads scene version {SCENE_VERSION}",
        path.display()
    )]
    Version {
        /// The file.
        path: PathBuf,
        /// The version in the file.
        found: String,
    },
    /// The glTF file is malformed or incomplete.
    #[error("{}: {message}", path.display())]
    Gltf {
        /// The glTF file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A field has a value glint cannot use.
    #[error("{}: field `{field}`: {message}", path.display())]
    Field {
        /// The file.
        path: PathBuf,
        /// Dotted path of the field, e.g. `reflectors[1].mesh`.
        field: String,
        /// What is wrong and what was expected.
        message: String,
    },
    /// Nothing is left to render.
    #[error("{}: the scene has no valid triangles ({dropped} degenerate or non-finite triangles were dropped)", path.display())]
    Empty {
        /// The glTF file.
        path: PathBuf,
        /// Triangles dropped at load.
        dropped: usize,
    },
}

/// A glTF node instance of a mesh: a contiguous range of the scene's triangles.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// glTF node name ("" when unnamed).
    pub node_name: String,
    /// glTF mesh name ("" when unnamed).
    pub mesh_name: String,
    /// Its triangles in [`Scene::triangles`].
    pub triangles: Range<u32>,
}

impl Object {
    /// Whether `name` selects this object (its mesh or its node name).
    pub fn is_named(&self, name: &str) -> bool {
        self.mesh_name == name || self.node_name == name
    }
}

/// A loaded, validated scene.
#[derive(Clone)]
pub struct Scene {
    /// Path of scene.json.
    pub path: PathBuf,
    /// Name (from scene.json, else the folder's name).
    pub name: String,
    /// The description as written.
    pub desc: SceneDesc,
    /// The camera paths to replay: scene.json's, then one per perspective camera node of the
    /// glTF (one keyframe, named after its node; scene.json's paths win a name clash).
    pub camera_paths: Vec<CameraPath>,
    /// World-space triangles.
    pub triangles: Vec<Triangle>,
    /// glTF node instances.
    pub objects: Vec<Object>,
    /// Materials, indexed by [`Triangle::material`].
    pub materials: Vec<Material>,
    /// The images materials' textures sample ([`material::TextureRef::image`]), one copy
    /// each, shared with the ray-casting filter of cut-outs.
    pub textures: std::sync::Arc<Vec<texture::Image>>,
    /// Explicit area lights.
    pub lights: Vec<AreaLight>,
    /// Reflectors, in scene.json order.
    pub reflectors: Vec<Reflector>,
    /// Impostor objects, in scene.json order.
    pub impostors: Vec<Impostor>,
    /// Bounds of all triangles.
    pub bounds: Aabb,
    /// BLAKE3 (hex) of scene.json, the glTF and its buffers: what a bake was made from.
    pub content_hash: String,
    /// BLAKE3 (hex) of the glTF and its buffers with `scale`: what the triangles were made
    /// from (scene.json's other fields left out), for work units that read geometry only.
    pub geometry_hash: String,
    /// Triangles dropped as degenerate or non-finite.
    pub dropped_triangles: usize,
}

impl std::fmt::Debug for Scene {
    /// A summary: the triangle list is too long to print.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scene")
            .field("path", &self.path)
            .field("name", &self.name)
            .field("triangles", &self.triangles.len())
            .field("objects", &self.objects.len())
            .field("materials", &self.materials.len())
            .field("lights", &self.lights.len())
            .field("reflectors", &self.reflectors.len())
            .field("impostors", &self.impostors.len())
            .field("content_hash", &self.content_hash)
            .finish()
    }
}

impl Scene {
    /// Loads and validates `path` (a scene.json).
    pub fn load(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
        let path = path.as_ref().to_owned();
        let text = std::fs::read_to_string(&path).map_err(|source| SceneError::Io {
            path: path.clone(),
            source,
        })?;
        let desc = parse_desc(&path, &text)?;
        let field = |field: String, message: String| SceneError::Field {
            path: path.clone(),
            field,
            message,
        };

        let gltf_path = path.parent().unwrap_or(Path::new(".")).join(&desc.geometry);
        if !gltf_path.is_file() {
            return Err(field(
                "geometry".into(),
                format!("{} does not exist", gltf_path.display()),
            ));
        }
        if !(desc.scale.is_finite() && desc.scale > 0.0) {
            return Err(field(
                "scale".into(),
                format!("{} is not a finite number > 0", desc.scale),
            ));
        }
        let imported = gltf_import::import(&gltf_path, desc.scale)?;
        if imported.dropped > 0 {
            log::warn!(
                "{}: dropped {} degenerate or non-finite triangles",
                gltf_path.display(),
                imported.dropped
            );
        }
        if imported.triangles.is_empty() {
            return Err(SceneError::Empty {
                path: gltf_path,
                dropped: imported.dropped,
            });
        }

        let mut hasher = blake3::Hasher::new();
        hasher.update(text.as_bytes());
        for bytes in &imported.hashed_bytes {
            hasher.update(&(bytes.len() as u64).to_le_bytes());
            hasher.update(bytes);
        }
        let content_hash = hasher.finalize().to_hex().to_string();
        let mut hasher = blake3::Hasher::new();
        hasher.update(&desc.scale.to_le_bytes());
        for bytes in &imported.hashed_bytes {
            hasher.update(&(bytes.len() as u64).to_le_bytes());
            hasher.update(bytes);
        }
        let geometry_hash = hasher.finalize().to_hex().to_string();

        let mut materials = imported.materials;
        for m in &mut materials {
            // glTF white (base colour 1) is common and would never converge: clamp it.
            if m.albedo.max_element() >= 1.0 {
                log::warn!(
                    "{}: material {:?}: albedo {} clamped to 0.99 (albedo ≥ 1 cannot converge)",
                    gltf_path.display(),
                    m.name,
                    m.albedo
                );
                m.albedo = m.albedo.min(Vec3::splat(0.99));
            }
        }
        for (name, over) in &desc.materials {
            let Some(m) = materials.iter_mut().find(|m| &m.name == name) else {
                return Err(field(
                    format!("materials.{name}"),
                    format!(
                        "no glTF material is named {name:?}; the glTF has {}",
                        list(materials.iter().map(|m| m.name.as_str()))
                    ),
                ));
            };
            m.apply(over);
        }
        for m in &materials {
            if let Err((f, message)) = m.check() {
                return Err(field(format!("materials.{}.{f}", m.name), message));
            }
        }

        let lights = desc
            .lights
            .iter()
            .enumerate()
            .map(|(i, l)| light::resolve(l).map_err(|m| field(format!("lights[{i}]"), m)))
            .collect::<Result<Vec<_>, _>>()?;

        let triangles = imported.triangles;
        let objects = imported.objects;
        let textures = imported.textures;
        let bounds = Aabb::from_points(triangles.iter().flat_map(|t| t.p.iter()));

        desc.bake
            .check(bounds.diagonal())
            .map_err(|(f, m)| field(f, m))?;

        let reflectors = reflector::resolve(&desc.reflectors, &objects, &materials, &triangles)
            .map_err(|(f, m)| field(f, m))?;
        let impostors = impostor::resolve(&desc.impostors, &objects, &triangles)
            .map_err(|(f, m)| field(f, m))?;
        probe::check(&desc.probes, &bounds).map_err(|(f, m)| field(f, m))?;
        camera_path::check_paths(&desc.camera_paths).map_err(|(f, m)| field(f, m))?;
        let mut camera_paths = desc.camera_paths.clone();
        gltf_cameras::merge(&mut camera_paths, imported.cameras, &gltf_path);
        let name = desc.name.clone().unwrap_or_else(|| {
            path.canonicalize()
                .ok()
                .and_then(|p| {
                    p.parent()?
                        .file_name()
                        .map(|n| n.to_string_lossy().into_owned())
                })
                .unwrap_or_else(|| "scene".into())
        });
        Ok(Scene {
            path,
            name,
            desc,
            camera_paths,
            triangles,
            objects,
            materials,
            textures: std::sync::Arc::new(textures),
            lights,
            reflectors,
            impostors,
            bounds,
            content_hash,
            geometry_hash,
            dropped_triangles: imported.dropped,
        })
    }

    /// Builds the ray-casting BVH over the scene's triangles; rays pass through alpha-masked
    /// cut-outs ([`Scene::cutout_filter`]).
    pub fn build_bvh(&self) -> Bvh {
        let bvh = Bvh::build(&self.triangles);
        match self.cutout_filter() {
            Some(f) => bvh.with_filter(f),
            None => bvh,
        }
    }

    /// The ray-casting BVH over a subset of the scene's triangles (`ids`, indices into
    /// [`Scene::triangles`]; hits name positions in `ids`), with the scene's cut-out filter
    /// ([`Scene::cutout_filter`]) read through `ids`: an object's own captures see through
    /// its alpha-masked texels as every other ray caster does.
    pub fn build_bvh_of(&self, ids: &[u32]) -> Bvh {
        let tris: Vec<crate::geometry::Triangle> =
            ids.iter().map(|&t| self.triangles[t as usize]).collect();
        let bvh = Bvh::build(&tris);
        match self.cutout_filter() {
            Some(f) => {
                let ids = ids.to_vec();
                bvh.with_filter(std::sync::Arc::new(move |t: u32, b| f(ids[t as usize], b)))
            }
            None => bvh,
        }
    }

    /// Whether anything emits light (area lights or emissive triangles).
    pub fn has_emitters(&self) -> bool {
        !self.lights.is_empty()
            || self
                .triangles
                .iter()
                .any(|t| self.materials[t.material as usize].is_emissive())
    }

    /// The radiance of every area light that a ray from `origin` along unit `dir` crosses
    /// before `t_max` ([`AreaLight::seen_along`]): what a reflected ray collects from them on
    /// its way to its hit, lights not being geometry.
    pub fn lights_along(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Vec3 {
        self.lights
            .iter()
            .map(|l| l.seen_along(origin, dir, t_max))
            .sum()
    }
}

/// Parses scene.json text: syntax first (with line and column), then the version, then the
/// schema, so a file from a newer glint gets a version error rather than an unknown-field one.
fn parse_desc(path: &Path, text: &str) -> Result<SceneDesc, SceneError> {
    let json_err = |e: serde_json::Error| SceneError::Json {
        path: path.to_owned(),
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
    };
    let value: serde_json::Value = serde_json::from_str(text).map_err(json_err)?;
    match value.get("version") {
        None => {
            return Err(SceneError::Field {
                path: path.to_owned(),
                field: "version".into(),
                message: format!("missing; write \"version\": {SCENE_VERSION}"),
            });
        }
        Some(v) if v.as_u64() != Some(SCENE_VERSION as u64) => {
            return Err(SceneError::Version {
                path: path.to_owned(),
                found: v.to_string(),
            });
        }
        Some(_) => {}
    }
    serde_json::from_str(text).map_err(json_err)
}

/// A short list of distinct names for messages.
fn list<'a>(names: impl Iterator<Item = &'a str>) -> String {
    let mut v: Vec<&str> = names.filter(|n| !n.is_empty()).collect();
    v.sort_unstable();
    v.dedup();
    let more = v.len().saturating_sub(12);
    v.truncate(12);
    let mut s = v
        .iter()
        .map(|n| format!("{n:?}"))
        .collect::<Vec<_>>()
        .join(", ");
    if more > 0 {
        s += &format!(" and {more} more");
    }
    if s.is_empty() { "none".into() } else { s }
}
