//! Reads a glTF 2.0 file (`.gltf` + buffers, or `.glb`) into world-space triangles,
//! objects (node instances), materials and cameras (as camera paths, [`super::gltf_cameras`]).

use std::path::{Path, PathBuf};

use glam::{Mat3, Mat4, Vec2, Vec3};
use gltf::{Semantic, buffer::Source, mesh::Mode};

use super::gltf_textures::Textures;
use super::gltf_uri::uri_path;
use super::material::{DEFAULT_IOR, Material};
use super::texture::Image;
use super::{CameraPath, Object, SceneError, gltf_cameras};
use crate::geometry::Triangle;

/// What a glTF file contributes to a scene.
pub struct Imported {
    /// Valid world-space triangles.
    pub triangles: Vec<Triangle>,
    /// One per (node, mesh) instance, in traversal order.
    pub objects: Vec<Object>,
    /// glTF materials in file order, then a default grey if some primitive has none.
    pub materials: Vec<Material>,
    /// The images the materials' textures use (decoded once each).
    pub textures: Vec<Image>,
    /// One one-keyframe path per perspective camera node, in traversal order, names unique.
    pub cameras: Vec<CameraPath>,
    /// Triangles dropped as degenerate or non-finite.
    pub dropped: usize,
    /// Every byte read (glTF and buffers), in order, for the content hash.
    pub hashed_bytes: Vec<Vec<u8>>,
}

/// Albedo of primitives without a material (glTF's own default is a white metal, which
/// would make such geometry black in a diffuse bake).
const DEFAULT_ALBEDO: f32 = 0.8;

/// Adds the camera of `node` (world transform `world`) to `cameras` as a camera path, or
/// says in the log why it is skipped (orthographic, a name already taken, an impossible pose).
fn read_camera(
    path: &Path,
    node: &gltf::Node,
    camera: &gltf::Camera,
    world: Mat4,
    cameras: &mut Vec<CameraPath>,
) {
    let name = gltf_cameras::path_name(node.name(), camera.name(), node.index());
    let skip = |why: &str| {
        log::warn!(
            "{}: camera node {name:?} (node {}) skipped: {why}",
            path.display(),
            node.index()
        );
    };
    let gltf::camera::Projection::Perspective(p) = camera.projection() else {
        return skip("orthographic cameras are not read (glint's cameras are perspective)");
    };
    if cameras.iter().any(|c| c.name == name) {
        return skip("an earlier camera node has that name");
    }
    match gltf_cameras::perspective_path(name.clone(), world, p.yfov()) {
        Ok(c) => {
            if let Some(aspect) = p.aspect_ratio() {
                log::info!(
                    "{}: camera {name:?}: aspect ratio {aspect} noted; frames take the aspect of their size",
                    path.display()
                );
            }
            cameras.push(c);
        }
        Err(why) => skip(&why),
    }
}

/// Imports `path`. Materials are mapped with [`Material::from_gltf`]; overrides come later.
/// Positions are multiplied by `scale` (metres per glTF unit).
pub fn import(path: &Path, scale: f32) -> Result<Imported, SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_owned(),
        source,
    })?;
    import_bytes(path, bytes, scale)
}

/// [`import`] of the file's contents `bytes`; `path` names the file in errors and locates
/// external buffers.
pub fn import_bytes(path: &Path, bytes: Vec<u8>, scale: f32) -> Result<Imported, SceneError> {
    let err = |message: String| SceneError::Gltf {
        path: path.to_owned(),
        message,
    };
    // The reader's own validation indexes a primitive's POSITION accessor before checking it
    // exists: check attribute references first, then validate.
    // A GLB's declared length must cover its 12-byte header (the reader subtracts it).
    if bytes.starts_with(b"glTF")
        && bytes
            .get(8..12)
            .is_some_and(|l| u32::from_le_bytes(l.try_into().expect("4 bytes")) < 12)
    {
        return Err(err(
            "GLB header: the declared length is shorter than the header".into(),
        ));
    }
    let unchecked =
        gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| err(e.to_string()))?;
    check_attribute_references(unchecked.document.as_json()).map_err(err)?;
    check_sources(unchecked.document.as_json()).map_err(err)?;
    let gltf = gltf::Gltf {
        document: gltf::Document::from_json(unchecked.document.into_json())
            .map_err(|e| err(e.to_string()))?,
        blob: unchecked.blob,
    };
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
                let file: PathBuf = dir.join(uri_path(uri));
                if file.exists() && !file.is_file() {
                    return Err(err(format!(
                        "buffer {}: {} is not a file",
                        buffer.index(),
                        file.display()
                    )));
                }
                let data = read_buffer(&file).map_err(|e| {
                    err(format!(
                        "buffer {}: {}: {e}",
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
    check_bounds(&gltf.document).map_err(err)?;

    let mut textures = Textures::default();
    let mut materials: Vec<Material> = Vec::new();
    for m in gltf.document.materials() {
        let pbr = m.pbr_metallic_roughness();
        let mut material = Material::from_gltf(
            m.name().unwrap_or("unnamed"),
            pbr.base_color_factor(),
            pbr.metallic_factor(),
            pbr.roughness_factor(),
            m.emissive_factor(),
            m.emissive_strength().unwrap_or(1.0),
        );
        let ior = m.ior().unwrap_or(DEFAULT_IOR);
        match m.transmission() {
            Some(t) => material.set_transmission(t.transmission_factor(), ior),
            None if ior != DEFAULT_IOR => material.set_transmission(0.0, ior),
            None => {}
        }
        textures
            .read_material(path, dir, &buffers, &m, &mut material)
            .map_err(err)?;
        materials.push(material);
    }
    let default_material = materials.len() as u32;
    let mut uses_default = false;

    let mut out = Imported {
        triangles: Vec::new(),
        objects: Vec::new(),
        materials: Vec::new(),
        textures: Vec::new(),
        cameras: Vec::new(),
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
    // glTF nodes form disjoint trees (glTF 2.0 §3.5.3): a node reached twice has two parents
    // or lies on a cycle, which would repeat its meshes or never end.
    let mut reached = vec![false; gltf.document.nodes().len()];
    while let Some((node, parent)) = stack.pop() {
        if std::mem::replace(&mut reached[node.index()], true) {
            return Err(err(format!(
                "node {} is reached twice from the scene: glTF nodes must form trees (no node with two parents, no cycles)",
                node.index()
            )));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        let children: Vec<gltf::Node> = node.children().collect();
        stack.extend(children.into_iter().rev().map(|c| (c, world)));
        if let Some(camera) = node.camera() {
            read_camera(path, &node, &camera, world, &mut out.cameras);
        }
        let Some(mesh) = node.mesh() else { continue };
        let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
        let flip = world.determinant() < 0.0;
        let first = out.triangles.len();
        let object = out.objects.len() as u32;
        for prim in mesh.primitives() {
            check_accessors(&prim).map_err(|m| err(format!("mesh {}: {m}", mesh_label(&mesh))))?;
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| d.as_slice()));
            let Some(positions) = reader.read_positions() else {
                log::warn!(
                    "{}: mesh {}: a primitive without POSITION was skipped",
                    path.display(),
                    mesh_label(&mesh)
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
            // Every attribute of a primitive has one value per vertex (glTF 2.0 §3.7.2.1).
            for (semantic, name, len) in [
                (Semantic::Normals, "NORMAL", normals.as_ref().map(Vec::len)),
                (
                    Semantic::TexCoords(0),
                    "TEXCOORD_0",
                    uv0.as_ref().map(Vec::len),
                ),
                (
                    Semantic::TexCoords(1),
                    "TEXCOORD_1",
                    uv1.as_ref().map(Vec::len),
                ),
            ] {
                if let (Some(len), Some(a)) = (len, prim.get(&semantic))
                    && len != positions.len()
                {
                    return Err(err(format!(
                        "mesh {}: {} ({name}) has {len} elements, POSITION has {}: each vertex needs one",
                        mesh_label(&mesh),
                        accessor_label(&a),
                        positions.len()
                    )));
                }
            }
            let indices: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..positions.len() as u32).collect(),
            };
            if let Some(&bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
                return Err(err(format!(
                    "mesh {}: index {bad} is out of range ({} vertices)",
                    mesh_label(&mesh),
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
            if uv1.is_none()
                && let Some(m) = materials.get(material as usize)
                && [m.base_texture, m.emissive_texture]
                    .iter()
                    .flatten()
                    .any(|t| t.tex_coord == 1)
            {
                return Err(err(format!(
                    "mesh {}: material {} \"{}\" samples a texture with texCoord 1, but the primitive has no TEXCOORD_1",
                    mesh_label(&mesh),
                    material,
                    m.name
                )));
            }
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
                    "{}: mesh {}: a primitive of {} (not triangles) was skipped",
                    path.display(),
                    mesh_label(&mesh),
                    match prim.mode() {
                        Mode::Points => "points",
                        Mode::Lines | Mode::LineLoop | Mode::LineStrip => "lines",
                        _ => "triangles",
                    }
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
    out.textures = std::mem::take(&mut textures.images);
    hashed_bytes.append(&mut textures.hashed_bytes);
    hashed_bytes.shrink_to_fit();
    out.hashed_bytes = hashed_bytes;
    Ok(out)
}

/// `3 "Name"` (the name only when there is one), for messages.
fn mesh_label(m: &gltf::Mesh) -> String {
    match m.name() {
        Some(n) => format!("{} \"{n}\"", m.index()),
        None => m.index().to_string(),
    }
}

/// `accessor 3 "Name"` (the name only when there is one), for messages.
fn accessor_label(a: &gltf::Accessor) -> String {
    match a.name() {
        Some(n) => format!("accessor {} \"{n}\"", a.index()),
        None => format!("accessor {}", a.index()),
    }
}

/// Bytes `count` elements of `elem` bytes, `stride` apart, starting at `offset`, reach up to
/// (`None` on overflow).
fn extent(offset: usize, count: usize, elem: usize, stride: usize) -> Option<usize> {
    match count {
        0 => Some(offset),
        _ => (count - 1)
            .checked_mul(stride)?
            .checked_add(elem)?
            .checked_add(offset),
    }
}

/// Checks that every buffer view lies inside its buffer (its declared `byteLength`, which
/// the data was checked to hold) and every accessor, dense part and sparse indices and
/// values, inside its buffer view: a count larger than the data is an error naming the
/// accessor rather than a primitive silently dropped.
fn check_bounds(doc: &gltf::Document) -> Result<(), String> {
    for v in doc.views() {
        let b = v.buffer();
        if v.offset()
            .checked_add(v.length())
            .is_none_or(|end| end > b.length())
        {
            return Err(format!(
                "buffer view {}: bytes {} to {} lie beyond the end of buffer {} ({} bytes)",
                v.index(),
                v.offset(),
                v.offset() as u128 + v.length() as u128,
                b.index(),
                b.length()
            ));
        }
    }
    for a in doc.accessors() {
        let label = accessor_label(&a);
        let fits = |what: &str,
                    view: gltf::buffer::View,
                    offset: usize,
                    count: usize,
                    elem: usize| {
            let stride = view.stride().unwrap_or(elem);
            if stride < elem {
                return Err(format!(
                    "{label}: buffer view {} has byteStride {stride}, less than the {elem}-byte elements{what}",
                    view.index()
                ));
            }
            match extent(offset, count, elem, stride) {
                Some(end) if end <= view.length() => Ok(()),
                _ => Err(format!(
                    "{label}: {count}{what} elements of {elem} bytes from byte {offset} need more than the {} bytes of buffer view {}",
                    view.length(),
                    view.index()
                )),
            }
        };
        if let Some(view) = a.view() {
            fits("", view, a.offset(), a.count(), a.size())?;
        }
        if let Some(sparse) = a.sparse() {
            if sparse.count() > a.count() {
                return Err(format!(
                    "{label}: {} sparse elements, but the accessor has only {}",
                    sparse.count(),
                    a.count()
                ));
            }
            let idx = sparse.indices();
            let index_size = match idx.index_type() {
                gltf::accessor::sparse::IndexType::U8 => 1,
                gltf::accessor::sparse::IndexType::U16 => 2,
                gltf::accessor::sparse::IndexType::U32 => 4,
            };
            fits(
                " sparse index",
                idx.view(),
                idx.offset(),
                sparse.count(),
                index_size,
            )?;
            let values = sparse.values();
            fits(
                " sparse value",
                values.view(),
                values.offset(),
                sparse.count(),
                a.size(),
            )?;
        }
    }
    Ok(())
}

/// Every primitive attribute names an existing accessor.
fn check_attribute_references(root: &gltf::json::Root) -> Result<(), String> {
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            for index in prim.attributes.values() {
                if index.value() >= root.accessors.len() {
                    return Err(format!(
                        "meshes[{m}].primitives[{p}]: an attribute names accessor {}, the file has {}",
                        index.value(),
                        root.accessors.len()
                    ));
                }
            }
        }
    }
    Ok(())
}

/// What the reader's accessors unwrap without its validation checking it: an image has a
/// `uri` or a `bufferView`, and a `mimeType` with a `bufferView` (`Image::source`); a camera
/// has the projection object its `type` names (`Camera::projection`). Checked for every image
/// and camera, used or not: the scene stage lists every image.
fn check_sources(root: &gltf::json::Root) -> Result<(), String> {
    for (i, image) in root.images.iter().enumerate() {
        match (&image.uri, &image.buffer_view, &image.mime_type) {
            (None, None, _) => {
                return Err(format!(
                    "images[{i}] has neither `uri` nor `bufferView`: one of them says where its data is"
                ));
            }
            (_, Some(_), None) => {
                return Err(format!(
                    "images[{i}] has a `bufferView` but no `mimeType` (glTF 2.0 §5.18: required with a bufferView)"
                ));
            }
            _ => {}
        }
    }
    for (i, camera) in root.cameras.iter().enumerate() {
        use gltf::json::camera::Type;
        use gltf::json::validation::Checked;
        let (missing, name) = match camera.type_ {
            Checked::Valid(Type::Perspective) => (camera.perspective.is_none(), "perspective"),
            Checked::Valid(Type::Orthographic) => (camera.orthographic.is_none(), "orthographic"),
            Checked::Invalid => (false, ""),
        };
        if missing {
            return Err(format!(
                "cameras[{i}] has type \"{name}\" but no `{name}` object"
            ));
        }
    }
    Ok(())
}

/// The accessors glint reads, checked before the reader's iterators assume them: types as
/// glTF 2.0 §3.7.2.1 allows (float VEC3 positions and normals, VEC2 texture coordinates of
/// float or normalized unsigned bytes or shorts, unsigned integer SCALAR indices), each
/// readable ([`check_accessor_readable`]).
fn check_accessors(prim: &gltf::Primitive) -> Result<(), String> {
    use gltf::Semantic;
    use gltf::accessor::{DataType as T, Dimensions as D};
    let attributes = [
        (Semantic::Positions, "POSITION"),
        (Semantic::Normals, "NORMAL"),
        (Semantic::TexCoords(0), "TEXCOORD_0"),
        (Semantic::TexCoords(1), "TEXCOORD_1"),
    ];
    for (semantic, name) in attributes {
        let Some(a) = prim.get(&semantic) else {
            continue;
        };
        let ok = match semantic {
            Semantic::TexCoords(_) => {
                a.dimensions() == D::Vec2 && matches!(a.data_type(), T::F32 | T::U8 | T::U16)
            }
            _ => a.dimensions() == D::Vec3 && a.data_type() == T::F32,
        };
        if !ok {
            return Err(format!(
                "attribute {name} ({}) is {} {}, which glTF does not allow",
                accessor_label(&a),
                component_name(a.data_type()),
                dimensions_name(a.dimensions())
            ));
        }
        check_accessor_readable(&a)?;
    }
    if let Some(a) = prim.indices()
        && !(a.dimensions() == D::Scalar && matches!(a.data_type(), T::U8 | T::U16 | T::U32))
    {
        return Err(format!(
            "indices ({}) are {} {}, not unsigned integer SCALAR",
            accessor_label(&a),
            component_name(a.data_type()),
            dimensions_name(a.dimensions())
        ));
    }
    if let Some(a) = prim.indices() {
        check_accessor_readable(&a)?;
    }
    Ok(())
}

/// glTF's name of a component type, for messages.
fn component_name(t: gltf::accessor::DataType) -> &'static str {
    use gltf::accessor::DataType as T;
    match t {
        T::I8 => "BYTE",
        T::U8 => "UNSIGNED_BYTE",
        T::I16 => "SHORT",
        T::U16 => "UNSIGNED_SHORT",
        T::U32 => "UNSIGNED_INT",
        T::F32 => "FLOAT",
    }
}

/// glTF's name of an accessor type, for messages.
fn dimensions_name(d: gltf::accessor::Dimensions) -> &'static str {
    use gltf::accessor::Dimensions as D;
    match d {
        D::Scalar => "SCALAR",
        D::Vec2 => "VEC2",
        D::Vec3 => "VEC3",
        D::Vec4 => "VEC4",
        D::Mat2 => "MAT2",
        D::Mat3 => "MAT3",
        D::Mat4 => "MAT4",
    }
}

/// What the reader needs of an accessor beyond its bounds (checked for every accessor by
/// [`check_bounds`]): a buffer view, at least one element, no sparse part (glint does not
/// read sparse accessors).
fn check_accessor_readable(a: &gltf::Accessor) -> Result<(), String> {
    let i = a.index();
    if a.sparse().is_some() {
        return Err(format!("accessor {i} is sparse, which glint does not read"));
    }
    if a.view().is_none() {
        return Err(format!("accessor {i} has no buffer view"));
    }
    if a.count() == 0 {
        return Err(format!("accessor {i} has count 0"));
    }
    Ok(())
}

/// Reads an external buffer; only a regular file (a device or a pipe could be endless).
fn read_buffer(file: &Path) -> std::io::Result<Vec<u8>> {
    let meta = std::fs::metadata(file)?;
    if !meta.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file",
        ));
    }
    std::fs::read(file)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The cornell box as a .gltf (buffer `fuzz.bin`) in a fresh folder, after `edit`.
    fn import_edited(edit: impl Fn(&mut serde_json::Value)) -> Result<Imported, SceneError> {
        let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
        let dir = tempfile::tempdir().unwrap();
        let glb = std::fs::read(repo.join("fuzz/corpus/gltf/cornell_box.glb")).unwrap();
        let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
        let bin = &glb[28 + json_len..];
        std::fs::write(dir.path().join("fuzz.bin"), bin).unwrap();
        let mut doc: serde_json::Value = serde_json::from_slice(
            &std::fs::read(repo.join("fuzz/corpus/gltf/cornell_box.gltf")).unwrap(),
        )
        .unwrap();
        edit(&mut doc);
        let path = dir.path().join("box.gltf");
        import_bytes(&path, serde_json::to_vec(&doc).unwrap(), 1.0)
    }

    #[test]
    fn the_unedited_box_imports() {
        let box_ = import_edited(|_| {}).unwrap();
        assert_eq!(box_.objects.len(), 1);
        assert!(!box_.triangles.is_empty());
    }

    #[test]
    fn a_node_cycle_or_shared_node_is_an_error_naming_the_node() {
        let e = import_edited(|d| d["nodes"][0]["children"] = serde_json::json!([0]))
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("box.gltf") && e.contains("node 0") && e.contains("trees"),
            "{e}"
        );
        let e = import_edited(|d| d["scenes"][0]["nodes"] = serde_json::json!([0, 0]))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("node 0 is reached twice"), "{e}");
    }

    #[test]
    fn attributes_with_fewer_values_than_positions_are_an_error() {
        let e = import_edited(|d| d["accessors"][1]["count"] = serde_json::json!(5))
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("(NORMAL) has 5 elements, POSITION has 6") && e.contains("cornell_box"),
            "{e}"
        );
    }

    #[test]
    fn a_buffer_that_is_not_a_regular_file_is_refused() {
        let e = import_edited(|d| d["buffers"][0]["uri"] = serde_json::json!("/dev/zero"))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("/dev/zero") && e.contains("not a file"), "{e}");
        let e = import_edited(|d| d["buffers"][0]["uri"] = serde_json::json!("."))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("not a file"), "{e}");
    }

    #[test]
    fn an_image_without_a_source_or_mime_type_is_an_error_naming_it_used_or_not() {
        let no_source = |d: &mut serde_json::Value| d["images"] = serde_json::json!([{}]);
        let no_mime = |d: &mut serde_json::Value| {
            d["images"] = serde_json::json!([{ "bufferView": 0 }]);
        };
        let textured = |d: &mut serde_json::Value| {
            d["textures"] = serde_json::json!([{ "source": 0 }]);
            d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] =
                serde_json::json!({ "index": 0 });
        };
        for (edit, missing) in [
            (
                &no_source as &dyn Fn(&mut serde_json::Value),
                "neither `uri` nor `bufferView`",
            ),
            (&no_mime, "no `mimeType`"),
        ] {
            for used in [false, true] {
                let e = import_edited(|d| {
                    edit(d);
                    if used {
                        textured(d);
                    }
                })
                .err()
                .unwrap_or_else(|| panic!("accepted ({missing}, used: {used})"))
                .to_string();
                assert!(
                    e.contains("box.gltf") && e.contains("images[0]") && e.contains(missing),
                    "{e}"
                );
            }
        }
    }

    #[test]
    fn a_camera_without_the_projection_its_type_names_is_an_error() {
        let e = import_edited(|d| {
            d["cameras"] = serde_json::json!([{ "type": "perspective",
                "orthographic": { "xmag": 1.0, "ymag": 1.0, "znear": 0.1, "zfar": 10.0 } }]);
            d["nodes"][0]["camera"] = serde_json::json!(0);
        })
        .err()
        .unwrap()
        .to_string();
        assert!(
            e.contains("box.gltf") && e.contains("cameras[0]") && e.contains("`perspective`"),
            "{e}"
        );
    }
}
