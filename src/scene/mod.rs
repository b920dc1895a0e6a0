//! Scenes: `scene.json` plus its glTF geometry, resolved and validated.

pub mod desc;
pub(crate) mod gltf_import;
pub mod material;

use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::Vec3;

pub use desc::{
    AreaLightDesc, CameraPath, Keyframe, KurtLobe, Quality, ReflectorKind, SCENE_VERSION, SceneDesc,
};
pub use gltf_import::uri_path;
pub use material::Material;

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

/// A resolved quad light.
#[derive(Clone, Debug, PartialEq)]
pub struct AreaLight {
    /// Name from scene.json.
    pub name: String,
    /// A corner.
    pub corner: Vec3,
    /// First edge.
    pub edge_u: Vec3,
    /// Second edge.
    pub edge_v: Vec3,
    /// Unit normal `edge_u × edge_v`: the emitting side.
    pub normal: Vec3,
    /// Area, m².
    pub area: f32,
    /// Emitted radiance.
    pub radiance: Vec3,
    /// Emits from both faces.
    pub two_sided: bool,
}

/// A plane: points p with normal·p = offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// Unit normal (the side the reflector faces).
    pub normal: Vec3,
    /// A point on the plane (the area-weighted centroid of the reflector).
    pub point: Vec3,
}

/// A resolved reflector.
#[derive(Clone, Debug, PartialEq)]
pub struct Reflector {
    /// Name used in messages and the bundle.
    pub name: String,
    /// Planar or curved.
    pub kind: ReflectorKind,
    /// Its triangles (indices into [`Scene::triangles`]).
    pub triangles: Vec<u32>,
    /// The material covering most of its area.
    pub material: u32,
    /// The fitted plane of a planar reflector.
    pub plane: Option<Plane>,
    /// Bounds of its triangles.
    pub bounds: Aabb,
    /// Index of its entry in scene.json's `reflectors`.
    pub index: usize,
}

/// A resolved impostor object.
#[derive(Clone, Debug, PartialEq)]
pub struct Impostor {
    /// The selecting mesh or node name.
    pub name: String,
    /// Objects it covers.
    pub objects: Vec<u32>,
    /// Capture views.
    pub views: u32,
    /// Bounds of its triangles.
    pub bounds: Aabb,
    /// How its reflected billboards are made (Popescu et al. 2006 §3, §3.2).
    pub billboard: ImpostorBillboard,
}

/// The resolved `billboard` of an impostor.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImpostorBillboard {
    /// `placement: "surface"`: the object's own plane (normal: its triangles' side), the same
    /// for every reflector; `None`: through the centroid, facing each reflector (§3).
    pub surface: Option<Plane>,
    /// Transition wall height H of a billboard connected to the environment (§3.2), metres;
    /// 0: not connected.
    pub wall: f32,
}

/// Largest distance of a vertex from a `surface` billboard's fitted plane, relative to the
/// object's bounding-box diagonal.
pub const SURFACE_PLANARITY: f32 = 1e-2;

/// A loaded, validated scene.
pub struct Scene {
    /// Path of scene.json.
    pub path: PathBuf,
    /// Name (from scene.json, else the folder's name).
    pub name: String,
    /// The description as written.
    pub desc: SceneDesc,
    /// World-space triangles.
    pub triangles: Vec<Triangle>,
    /// glTF node instances.
    pub objects: Vec<Object>,
    /// Materials, indexed by [`Triangle::material`].
    pub materials: Vec<Material>,
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
            .map(|(i, l)| resolve_light(l).map_err(|m| field(format!("lights[{i}]"), m)))
            .collect::<Result<Vec<_>, _>>()?;

        let triangles = imported.triangles;
        let objects = imported.objects;
        let bounds = Aabb::from_points(triangles.iter().flat_map(|t| t.p.iter()));

        crate::bake::check_scene_settings(&desc.bake, bounds.diagonal())
            .map_err(|(f, m)| field(f, m))?;

        let mut reflectors = Vec::new();
        for (i, r) in desc.reflectors.iter().enumerate() {
            let at = |f: &str| format!("reflectors[{i}]{f}");
            let (selected, name) = match (&r.mesh, &r.material) {
                (Some(mesh), None) => {
                    let tris: Vec<u32> = objects
                        .iter()
                        .filter(|o| o.is_named(mesh))
                        .flat_map(|o| o.triangles.clone())
                        .collect();
                    if tris.is_empty() {
                        return Err(field(
                            at(".mesh"),
                            format!(
                                "{mesh:?} matches no glTF mesh or node; the glTF has meshes {}",
                                list(objects.iter().map(|o| o.mesh_name.as_str()))
                            ),
                        ));
                    }
                    (tris, mesh)
                }
                (None, Some(mat)) => {
                    let Some(id) = materials.iter().position(|m| &m.name == mat) else {
                        return Err(field(
                            at(".material"),
                            format!(
                                "{mat:?} matches no glTF material; the glTF has {}",
                                list(materials.iter().map(|m| m.name.as_str()))
                            ),
                        ));
                    };
                    let tris: Vec<u32> = (0..triangles.len() as u32)
                        .filter(|&t| triangles[t as usize].material == id as u32)
                        .collect();
                    if tris.is_empty() {
                        return Err(field(
                            at(".material"),
                            format!("no triangle uses material {mat:?}"),
                        ));
                    }
                    (tris, mat)
                }
                _ => {
                    return Err(field(
                        at(""),
                        "give exactly one of `mesh` and `material`".into(),
                    ));
                }
            };
            let name = r.name.clone().unwrap_or_else(|| name.clone());
            if reflectors.iter().any(|o: &Reflector| o.name == name) {
                return Err(field(
                    at(".name"),
                    format!("{name:?} names an earlier reflector too"),
                ));
            }
            if let Some(o) = &r.radiance {
                o.check()
                    .map_err(|e| field(at(&format!(".radiance.{}", e.field)), e.message))?;
            }
            let tol = r.planarity_tolerance;
            if !(tol.is_finite() && tol >= 0.0) {
                return Err(field(
                    at(".planarity_tolerance"),
                    format!("{tol} is not a finite number ≥ 0"),
                ));
            }
            let bounds = Aabb::from_points(
                selected
                    .iter()
                    .flat_map(|&t| triangles[t as usize].p.iter()),
            );
            let plane = match r.kind {
                ReflectorKind::Planar => Some(
                    fit_plane(&triangles, &selected, tol)
                        .map_err(|m| field(at(".kind"), format!("reflector {name:?}: {m}")))?,
                ),
                ReflectorKind::Curved => None,
            };
            reflectors.push(Reflector {
                name,
                kind: r.kind,
                material: dominant_material(&triangles, &selected),
                triangles: selected,
                plane,
                bounds,
                index: i,
            });
        }

        let mut impostors = Vec::new();
        for (i, imp) in desc.impostors.iter().enumerate() {
            let ids: Vec<u32> = (0..objects.len() as u32)
                .filter(|&o| objects[o as usize].is_named(&imp.mesh))
                .collect();
            if ids.is_empty() {
                return Err(field(
                    format!("impostors[{i}].mesh"),
                    format!(
                        "{:?} matches no glTF mesh or node; the glTF has meshes {}",
                        imp.mesh,
                        list(objects.iter().map(|o| o.mesh_name.as_str()))
                    ),
                ));
            }
            if impostors.iter().any(|o: &Impostor| o.name == imp.mesh) {
                return Err(field(
                    format!("impostors[{i}].mesh"),
                    format!("{:?} is listed twice", imp.mesh),
                ));
            }
            if imp.views == 0 {
                return Err(field(format!("impostors[{i}].views"), "must be ≥ 1".into()));
            }
            let bounds = Aabb::from_points(ids.iter().flat_map(|&o| {
                objects[o as usize]
                    .triangles
                    .clone()
                    .flat_map(|t| triangles[t as usize].p.iter())
            }));
            let billboard = match &imp.billboard {
                None => ImpostorBillboard::default(),
                Some(b) => {
                    let wall = match b.wall_height {
                        None => 0.0,
                        Some(h) if h.is_finite() && h > 0.0 => h,
                        Some(h) => {
                            return Err(field(
                                format!("impostors[{i}].billboard.wall_height"),
                                format!(
                                    "{h} is not a finite height > 0 in metres (leave it out for a billboard not connected to the environment)"
                                ),
                            ));
                        }
                    };
                    let surface = match b.placement {
                        desc::BillboardPlacement::Centroid => None,
                        desc::BillboardPlacement::Surface => {
                            let tris: Vec<u32> = ids
                                .iter()
                                .flat_map(|&o| objects[o as usize].triangles.clone())
                                .collect();
                            Some(fit_plane(&triangles, &tris, SURFACE_PLANARITY).map_err(|m| {
                                field(
                                    format!("impostors[{i}].billboard.placement"),
                                    format!(
                                        "\"surface\" needs a flat object, but {:?}: {}; use \"centroid\"",
                                        imp.mesh,
                                        m.replace("declared planar, but ", "")
                                            .replace("; declare it \"curved\" or raise planarity_tolerance", "")
                                            .replace("; declare it \"curved\"", "")
                                    ),
                                )
                            })?)
                        }
                    };
                    ImpostorBillboard { surface, wall }
                }
            };
            impostors.push(Impostor {
                name: imp.mesh.clone(),
                objects: ids,
                views: imp.views,
                bounds,
                billboard,
            });
        }

        let mut names = std::collections::BTreeSet::new();
        for (i, p) in desc.camera_paths.iter().enumerate() {
            if !names.insert(p.name.as_str()) {
                return Err(field(
                    format!("camera_paths[{i}].name"),
                    format!("{:?} is used by an earlier path", p.name),
                ));
            }
            check_path(p).map_err(|(f, m)| field(format!("camera_paths[{i}]{f}"), m))?;
        }

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
            triangles,
            objects,
            materials,
            lights,
            reflectors,
            impostors,
            bounds,
            content_hash,
            dropped_triangles: imported.dropped,
        })
    }

    /// Builds the ray-casting BVH over the scene's triangles.
    pub fn build_bvh(&self) -> Bvh {
        Bvh::build(&self.triangles)
    }

    /// Whether anything emits light (area lights or emissive triangles).
    pub fn has_emitters(&self) -> bool {
        !self.lights.is_empty()
            || self
                .triangles
                .iter()
                .any(|t| self.materials[t.material as usize].is_emissive())
    }

    /// The named camera path, or the first one when `name` is `None`.
    pub fn camera_path(&self, name: Option<&str>) -> Option<&CameraPath> {
        match name {
            Some(n) => self.desc.camera_paths.iter().find(|p| p.name == n),
            None => self.desc.camera_paths.first(),
        }
    }

    /// [`Scene::camera_path`], or an error naming scene.json and the paths it has.
    pub fn find_camera_path(&self, name: Option<&str>) -> Result<&CameraPath, SceneError> {
        self.camera_path(name).ok_or_else(|| SceneError::Field {
            path: self.path.clone(),
            field: "camera_paths".into(),
            message: match (name, self.desc.camera_paths.is_empty()) {
                (_, true) => "the scene has no camera paths; add one to scene.json".into(),
                (Some(n), false) => format!(
                    "no path is named {n:?}; the scene has {}",
                    list(self.desc.camera_paths.iter().map(|p| p.name.as_str()))
                ),
                (None, false) => unreachable!("the first path exists"),
            },
        })
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

fn resolve_light(l: &AreaLightDesc) -> Result<AreaLight, String> {
    let v = |a: [f32; 3]| Vec3::from_array(a);
    let (corner, eu, ev, radiance) = (v(l.corner), v(l.edge_u), v(l.edge_v), v(l.radiance));
    if ![corner, eu, ev, radiance].iter().all(|x| x.is_finite()) {
        return Err(format!("light {:?}: a value is not finite", l.name));
    }
    if radiance.min_element() < 0.0 {
        return Err(format!(
            "light {:?}: radiance {radiance} is negative",
            l.name
        ));
    }
    let cross = eu.cross(ev);
    let area = cross.length();
    if area <= 1e-12 * eu.length_squared().max(ev.length_squared()) || area == 0.0 {
        return Err(format!(
            "light {:?}: edges {eu} and {ev} are parallel or zero: the quad has no area",
            l.name
        ));
    }
    Ok(AreaLight {
        name: l.name.clone(),
        corner,
        edge_u: eu,
        edge_v: ev,
        normal: cross / area,
        area,
        radiance,
        two_sided: l.two_sided,
    })
}

/// Fits a plane to the triangles (area-weighted normal and centroid) and checks that every
/// vertex lies within `tol` × the bounding-box diagonal of it.
fn fit_plane(triangles: &[Triangle], selected: &[u32], tol: f32) -> Result<Plane, String> {
    let mut normal_sum = glam::DVec3::ZERO;
    let mut centroid = glam::DVec3::ZERO;
    let mut area = 0.0f64;
    for &t in selected {
        let t = &triangles[t as usize];
        let c = t.cross().as_dvec3();
        let a = 0.5 * c.length();
        normal_sum += c;
        centroid += a * (t.p[0] + t.p[1] + t.p[2]).as_dvec3() / 3.0;
        area += a;
    }
    let n = normal_sum.normalize_or_zero();
    if n == glam::DVec3::ZERO || normal_sum.length() < 0.5 * 2.0 * area {
        return Err(
            "declared planar, but its triangles face opposite ways (a closed or folded shape); declare it \"curved\""
                .into(),
        );
    }
    let centroid = centroid / area;
    let bounds = Aabb::from_points(
        selected
            .iter()
            .flat_map(|&t| triangles[t as usize].p.iter()),
    );
    let size = bounds.diagonal() as f64;
    let worst = selected
        .iter()
        .flat_map(|&t| triangles[t as usize].p.iter())
        .map(|p| (p.as_dvec3() - centroid).dot(n).abs())
        .fold(0.0f64, f64::max);
    if worst > tol as f64 * size {
        return Err(format!(
            "declared planar, but a vertex lies {worst:.4} m from the fitted plane, {:.2e} of its size {size:.3} m (tolerance {tol:.1e}); declare it \"curved\" or raise planarity_tolerance",
            worst / size
        ));
    }
    Ok(Plane {
        normal: n.as_vec3(),
        point: centroid.as_vec3(),
    })
}

fn dominant_material(triangles: &[Triangle], selected: &[u32]) -> u32 {
    let mut area = std::collections::BTreeMap::<u32, f64>::new();
    for &t in selected {
        let t = &triangles[t as usize];
        *area.entry(t.material).or_default() += t.area() as f64;
    }
    area.into_iter()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(m, _)| m)
        .unwrap_or(0)
}

/// Largest |time| of a keyframe, seconds (a day).
pub const MAX_KEYFRAME_TIME: f32 = 86_400.0;

/// Largest replay rate of a camera path, frames per second.
pub const MAX_FPS: f32 = 1000.0;

/// Largest |coordinate| of a keyframe's position, target or up, metres.
pub const MAX_CAMERA_COORD: f32 = 1e6;

/// Smallest and largest vertical field of view of a keyframe, degrees.
pub const FOV_RANGE_DEG: (f32, f32) = (0.1, 179.0);

/// Checks a camera path against sane bounds, so that replaying it cannot ask for absurd
/// frame counts ([`crate::camera::MAX_FRAMES`]) or degenerate projections. `Err((field, why))`
/// with the field relative to the path.
fn check_path(p: &CameraPath) -> Result<(), (String, String)> {
    if p.keyframes.is_empty() {
        return Err((".keyframes".into(), "needs at least one keyframe".into()));
    }
    if !(p.fps.is_finite() && p.fps > 0.0 && p.fps <= MAX_FPS) {
        return Err((
            ".fps".into(),
            format!("{} is not a frame rate in (0, {MAX_FPS}]", p.fps),
        ));
    }
    let mut last = f32::NEG_INFINITY;
    for (k, f) in p.keyframes.iter().enumerate() {
        let at = |s: &str| format!(".keyframes[{k}].{s}");
        if !(f.time.is_finite() && f.time.abs() <= MAX_KEYFRAME_TIME) {
            return Err((
                at("time"),
                format!(
                    "{} is not a time in seconds within ±{MAX_KEYFRAME_TIME}",
                    f.time
                ),
            ));
        }
        if f.time <= last {
            return Err((
                at("time"),
                format!(
                    "{} is not after the previous keyframe's {last}: times must increase",
                    f.time
                ),
            ));
        }
        last = f.time;
        let (lo, hi) = FOV_RANGE_DEG;
        if !(f.fov_y_deg >= lo && f.fov_y_deg <= hi) {
            return Err((
                at("fov_y_deg"),
                format!("{} is not in [{lo}, {hi}] degrees", f.fov_y_deg),
            ));
        }
        for (name, v) in [("position", f.position), ("target", f.target), ("up", f.up)] {
            if !v
                .iter()
                .all(|c| c.is_finite() && c.abs() <= MAX_CAMERA_COORD)
            {
                return Err((
                    at(name),
                    format!(
                        "[{}, {}, {}] is not finite or lies beyond ±{MAX_CAMERA_COORD:e} m",
                        v[0], v[1], v[2]
                    ),
                ));
            }
        }
        let (eye, target, up) = (
            Vec3::from(f.position),
            Vec3::from(f.target),
            Vec3::from(f.up),
        );
        let dir = target - eye;
        if dir.length_squared() == 0.0 {
            return Err((
                at("target"),
                "equals the position: no view direction".into(),
            ));
        }
        if dir.normalize().cross(up.normalize_or_zero()).length() < 1e-4 {
            return Err((
                at("up"),
                format!("{up} is zero or parallel to the view direction"),
            ));
        }
    }
    let frames = crate::camera::frame_count(p);
    if frames > crate::camera::MAX_FRAMES {
        return Err((
            ".fps".into(),
            format!(
                "{} fps over {} s of keyframes gives {frames} frames; a path may have at most {}",
                p.fps,
                last - p.keyframes[0].time,
                crate::camera::MAX_FRAMES
            ),
        ));
    }
    Ok(())
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
