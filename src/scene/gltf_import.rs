//! Reads a glTF 2.0 file (`.gltf` + buffers, or `.glb`) into world-space triangles,
//! objects (node instances) and materials.

use std::path::{Path, PathBuf};

use glam::{Mat3, Mat4, Vec2, Vec3};
use gltf::{buffer::Source, mesh::Mode};

use super::{Object, SceneError, material::Material};
use crate::geometry::Triangle;

/// What a glTF file contributes to a scene.
pub struct Imported {
    /// Valid world-space triangles.
    pub triangles: Vec<Triangle>,
    /// One per (node, mesh) instance, in traversal order.
    pub objects: Vec<Object>,
    /// glTF materials in file order, then a default grey if some primitive has none.
    pub materials: Vec<Material>,
    /// Triangles dropped as degenerate or non-finite.
    pub dropped: usize,
    /// Every byte read (glTF and buffers), in order, for the content hash.
    pub hashed_bytes: Vec<Vec<u8>>,
}

/// Albedo of primitives without a material (glTF's own default is a white metal, which
/// would make such geometry black in a diffuse bake).
const DEFAULT_ALBEDO: f32 = 0.8;

/// Imports `path`. Materials are mapped with [`Material::from_gltf`]; overrides come later.
/// Positions are multiplied by `scale` (metres per glTF unit).
pub fn import(path: &Path, scale: f32) -> Result<Imported, SceneError> {
    let err = |message: String| SceneError::Gltf {
        path: path.to_owned(),
        message,
    };
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_owned(),
        source,
    })?;
    let gltf = gltf::Gltf::from_slice(&bytes).map_err(|e| err(e.to_string()))?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut hashed_bytes = vec![bytes.clone()];

    let mut buffers = Vec::new();
    for buffer in gltf.document.buffers() {
        let data = match buffer.source() {
            Source::Bin => gltf.blob.clone().ok_or_else(|| {
                err("buffer 0 refers to the GLB binary chunk, which is missing".into())
            })?,
            Source::Uri(uri) if uri.starts_with("data:") => {
                return Err(err(format!(
                    "buffer {} is an embedded data: URI; glint reads .glb or external .bin buffers",
                    buffer.index()
                )));
            }
            Source::Uri(uri) => {
                let file: PathBuf = dir.join(uri);
                let data = std::fs::read(&file).map_err(|e| {
                    err(format!(
                        "buffer {} ({}): {e}",
                        buffer.index(),
                        file.display()
                    ))
                })?;
                hashed_bytes.push(data.clone());
                data
            }
        };
        if data.len() < buffer.length() {
            return Err(err(format!(
                "buffer {} holds {} bytes, the file declares {}",
                buffer.index(),
                data.len(),
                buffer.length()
            )));
        }
        buffers.push(data);
    }

    let mut materials: Vec<Material> = gltf
        .document
        .materials()
        .map(|m| {
            let pbr = m.pbr_metallic_roughness();
            Material::from_gltf(
                m.name().unwrap_or("unnamed"),
                pbr.base_color_factor(),
                pbr.metallic_factor(),
                pbr.roughness_factor(),
                m.emissive_factor(),
                m.emissive_strength().unwrap_or(1.0),
            )
        })
        .collect();
    let default_material = materials.len() as u32;
    let mut uses_default = false;

    let mut out = Imported {
        triangles: Vec::new(),
        objects: Vec::new(),
        materials: Vec::new(),
        dropped: 0,
        hashed_bytes: Vec::new(),
    };
    let roots: Vec<gltf::Node> = match gltf
        .document
        .default_scene()
        .or_else(|| gltf.document.scenes().next())
    {
        Some(scene) => scene.nodes().collect(),
        None => gltf.document.nodes().collect(),
    };
    // Depth-first in document order (the stack holds siblings reversed).
    let mut stack: Vec<(gltf::Node, Mat4)> = roots
        .into_iter()
        .rev()
        .map(|n| (n, Mat4::from_scale(Vec3::splat(scale))))
        .collect();
    while let Some((node, parent)) = stack.pop() {
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        let children: Vec<gltf::Node> = node.children().collect();
        stack.extend(children.into_iter().rev().map(|c| (c, world)));
        let Some(mesh) = node.mesh() else { continue };
        let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
        let flip = world.determinant() < 0.0;
        let first = out.triangles.len();
        let object = out.objects.len() as u32;
        for prim in mesh.primitives() {
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| d.as_slice()));
            let Some(positions) = reader.read_positions() else {
                log::warn!(
                    "{}: mesh {:?}: a primitive without POSITION was skipped",
                    path.display(),
                    mesh.name()
                );
                continue;
            };
            let positions: Vec<Vec3> = positions
                .map(|p| world.transform_point3(Vec3::from(p)))
                .collect();
            let normals: Option<Vec<Vec3>> = reader.read_normals().map(|it| {
                it.map(|n| (normal_matrix * Vec3::from(n)).normalize_or_zero())
                    .collect()
            });
            let uv0: Option<Vec<Vec2>> = reader
                .read_tex_coords(0)
                .map(|it| it.into_f32().map(Vec2::from).collect());
            let uv1: Option<Vec<Vec2>> = reader
                .read_tex_coords(1)
                .map(|it| it.into_f32().map(Vec2::from).collect());
            let indices: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..positions.len() as u32).collect(),
            };
            if let Some(&bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
                return Err(err(format!(
                    "mesh {:?}: index {bad} is out of range ({} vertices)",
                    mesh.name().unwrap_or(""),
                    positions.len()
                )));
            }
            let material = match prim.material().index() {
                Some(i) => i as u32,
                None => {
                    uses_default = true;
                    default_material
                }
            };
            for [a, b, c] in triangle_indices(prim.mode(), &indices) {
                let (a, b, c) = if flip { (a, c, b) } else { (a, b, c) };
                let idx = [a as usize, b as usize, c as usize];
                let p = idx.map(|i| positions[i]);
                let mut tri = Triangle {
                    p,
                    n: [Vec3::ZERO; 3],
                    uv: uv0
                        .as_ref()
                        .map_or([Vec2::ZERO; 3], |uv| idx.map(|i| uv[i])),
                    uv1: uv1.as_ref().map(|uv| idx.map(|i| uv[i])),
                    material,
                    object,
                };
                if !tri.is_valid() {
                    out.dropped += 1;
                    continue;
                }
                let face = tri.face_normal();
                tri.n = match &normals {
                    Some(n) => idx.map(|i| {
                        if n[i].is_finite() && n[i] != Vec3::ZERO {
                            n[i]
                        } else {
                            face
                        }
                    }),
                    None => [face; 3],
                };
                out.triangles.push(tri);
            }
            if !matches!(
                prim.mode(),
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                log::warn!(
                    "{}: mesh {:?}: a {:?} primitive (not triangles) was skipped",
                    path.display(),
                    mesh.name(),
                    prim.mode()
                );
            }
        }
        let mesh_name = mesh.name().unwrap_or("").to_owned();
        out.objects.push(Object {
            node_name: node.name().unwrap_or("").to_owned(),
            mesh_name,
            triangles: first as u32..out.triangles.len() as u32,
        });
    }
    if uses_default {
        materials.push(Material::from_gltf(
            "default",
            [DEFAULT_ALBEDO, DEFAULT_ALBEDO, DEFAULT_ALBEDO, 1.0],
            0.0,
            1.0,
            [0.0; 3],
            1.0,
        ));
    }
    out.materials = materials;
    hashed_bytes.shrink_to_fit();
    out.hashed_bytes = hashed_bytes;
    Ok(out)
}

/// Index triples of a primitive's triangles; other modes give none.
fn triangle_indices(mode: Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::Triangles => idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        Mode::TriangleStrip => (2..idx.len())
            .map(|i| {
                // Every other triangle of a strip is wound the other way.
                if i % 2 == 0 {
                    [idx[i - 2], idx[i - 1], idx[i]]
                } else {
                    [idx[i - 1], idx[i - 2], idx[i]]
                }
            })
            .collect(),
        Mode::TriangleFan => (2..idx.len())
            .map(|i| [idx[0], idx[i - 1], idx[i]])
            .collect(),
        _ => Vec::new(),
    }
}
