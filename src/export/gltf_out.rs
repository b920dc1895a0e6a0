//! The exported glTF: the scene's triangles, world-space, one node per object, one primitive
//! per (material, lightmap page), each vertex with its lightmap coordinates as `TEXCOORD_1`
//! (vertices are welded only where position, normal, UVs and lightmap coordinates all agree,
//! so a chart seam splits them); the source glTF's materials, textures and images kept, each
//! material bound to its page's lightmap by `MSFT_lightmap` and the same binding in `extras`;
//! every camera path's first keyframe as a camera node. A double-sided sheet whose back side
//! has texels of its own ([`crate::radiosity::back_sides`]) is written as two one-sided layers,
//! the front and its twin, each with its own lightmap coordinates, under a one-sided copy of its
//! material: an engine culls the layer it sees from behind and shows each side its light. Pure:
//! bytes in, bytes out.

use std::collections::HashMap;

use glam::{Mat3, Quat, Vec2, Vec3};
use serde_json::{Value, json};

use crate::radiosity::atlas::Atlas;
use crate::radiosity::sides::twin;
use crate::scene::Scene;

/// How the lightmaps are bound and what reproduces glint's frame, recorded in `extras`.
#[derive(Clone, Debug)]
pub struct Binding {
    /// Encoding name ([`super::lightmap::LightmapFormat::name`]).
    pub encoding: &'static str,
    /// Decoded texel × `scale` = L.
    pub scale: f32,
    /// glint-view's `auto` exposure for the bundle (radiance × 2^EV before the tone curve).
    pub exposure_ev: f32,
}

/// An image to embed: its bytes and MIME type.
pub struct Embedded {
    /// The encoded file.
    pub bytes: Vec<u8>,
    /// `image/png` or `image/jpeg`.
    pub mime: String,
}

/// The JSON and binary chunk under construction.
struct Out {
    json: Value,
    bin: Vec<u8>,
}

impl Out {
    fn array(&mut self, key: &str) -> &mut Vec<Value> {
        let root = self.json.as_object_mut().expect("root is an object");
        root.entry(key)
            .or_insert_with(|| Value::Array(Vec::new()))
            .as_array_mut()
            .expect("top-level lists are arrays")
    }

    fn push(&mut self, key: &str, v: Value) -> usize {
        let a = self.array(key);
        a.push(v);
        a.len() - 1
    }

    /// Appends `bytes` as a buffer view (4-byte aligned); its index.
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut v = json!({ "buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len() });
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.bin.extend_from_slice(bytes);
        self.push("bufferViews", v)
    }

    /// A float accessor of `n`-component vectors.
    fn floats(&mut self, data: &[f32], n: usize, kind: &str, bounds: bool) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(34962));
        let mut a = json!({ "bufferView": view, "componentType": 5126, "count": data.len() / n, "type": kind });
        if bounds {
            let (mut lo, mut hi) = (vec![f32::INFINITY; n], vec![f32::NEG_INFINITY; n]);
            for c in data.chunks(n) {
                for k in 0..n {
                    lo[k] = lo[k].min(c[k]);
                    hi[k] = hi[k].max(c[k]);
                }
            }
            a["min"] = json!(lo);
            a["max"] = json!(hi);
        }
        self.push("accessors", a)
    }

    fn indices(&mut self, data: &[u32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(34963));
        self.push(
            "accessors",
            json!({ "bufferView": view, "componentType": 5125, "count": data.len(), "type": "SCALAR" }),
        )
    }
}

/// One primitive's welded vertices.
#[derive(Default)]
struct Prim {
    key: HashMap<[u32; 12], u32>,
    pos: Vec<f32>,
    nrm: Vec<f32>,
    uv0: Vec<f32>,
    uv1: Vec<f32>,
    /// The source's own TEXCOORD_1, written as TEXCOORD_2 for materials that sample it.
    uv2: Vec<f32>,
    idx: Vec<u32>,
}

impl Prim {
    fn vertex(&mut self, p: Vec3, n: Vec3, uv0: Vec2, lm: Vec2, uv2: Vec2) -> u32 {
        let k = [
            p.x, p.y, p.z, n.x, n.y, n.z, uv0.x, uv0.y, lm.x, lm.y, uv2.x, uv2.y,
        ]
        .map(f32::to_bits);
        let next = self.key.len() as u32;
        *self.key.entry(k).or_insert_with(|| {
            self.pos.extend([p.x, p.y, p.z]);
            self.nrm.extend([n.x, n.y, n.z]);
            self.uv0.extend([uv0.x, uv0.y]);
            self.uv1.extend([lm.x, lm.y]);
            self.uv2.extend([uv2.x, uv2.y]);
            next
        })
    }
}

/// `m` with every `texCoord` 1 made 2: the lightmap takes set 1, the source's set 1 moves to 2.
pub fn move_texcoord_1(m: &mut Value) {
    match m {
        Value::Object(o) => {
            if o.get("texCoord").and_then(Value::as_u64) == Some(1) {
                o.insert("texCoord".into(), json!(2));
            }
            o.values_mut().for_each(move_texcoord_1);
        }
        Value::Array(a) => a.iter_mut().for_each(move_texcoord_1),
        _ => {}
    }
}

/// A glTF material's base colour factor, linear RGB (`[1, 1, 1]` when absent).
pub fn base_colour_factor(m: &Value) -> Vec3 {
    let f = m
        .pointer("/pbrMetallicRoughness/baseColorFactor")
        .and_then(Value::as_array);
    match f {
        Some(f) if f.len() >= 3 => Vec3::new(
            f[0].as_f64().unwrap_or(1.0) as f32,
            f[1].as_f64().unwrap_or(1.0) as f32,
            f[2].as_f64().unwrap_or(1.0) as f32,
        ),
        _ => Vec3::ONE,
    }
}

/// The material glint gives primitives without one ([`crate::scene`]'s default albedo),
/// written out so that engines do not fall back to glTF's white metal.
pub fn default_material() -> Value {
    json!({
        "name": "default",
        "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0 }
    })
}

/// Where a source material samples a texture with `texCoord` 1, which the lightmap takes.
pub fn uses_texcoord_1(m: &Value) -> bool {
    match m {
        Value::Object(o) => {
            o.get("texCoord").and_then(Value::as_u64) == Some(1) || o.values().any(uses_texcoord_1)
        }
        Value::Array(a) => a.iter().any(uses_texcoord_1),
        _ => false,
    }
}

/// Translation and rotation of a glTF camera (looking down −Z, +Y up) at `eye` looking at
/// `target` with `up`.
fn camera_pose(eye: Vec3, target: Vec3, up: Vec3) -> Quat {
    let f = (target - eye).normalize();
    let r = f.cross(up).normalize();
    let u = r.cross(f);
    Quat::from_mat3(&Mat3::from_cols(r, u, -f)).normalize()
}

/// The glTF (JSON and binary chunk) of `scene` lit by `atlas`'s pages, whose encoded lightmap
/// images are `pages`. `source` is the scene's glTF JSON, `materials` its materials (with the
/// default appended when glint added one), `images` its images' bytes in order.
pub fn build(
    scene: &Scene,
    atlas: &Atlas,
    source: &Value,
    materials: &[Value],
    images: Vec<Embedded>,
    pages: &[Vec<u8>],
    binding: &Binding,
) -> (Value, Vec<u8>) {
    let mut used = vec!["MSFT_lightmap".to_string()];
    if let Some(u) = source.get("extensionsUsed").and_then(Value::as_array) {
        used.extend(u.iter().filter_map(Value::as_str).map(str::to_owned));
    }
    used.sort();
    used.dedup();
    let formula = "display = baseColor(x) * L(x) + emissive(x), L = scale * decode(lightmap at TEXCOORD_1); then x 2^exposure_ev, Khronos PBR Neutral, sRGB";
    let mut out = Out {
        json: json!({
            "asset": { "version": "2.0", "generator": format!("glint-bundle export {}", env!("CARGO_PKG_VERSION")) },
            "extensionsUsed": used,
            "extras": { "glint_lightmaps": {
                "encoding": binding.encoding,
                "scale": binding.scale,
                "texCoord": 1,
                "quantity": "L = (D - E) / baseColorFactor: reflected exitant radiance over the base colour factor",
                "exposure_ev": binding.exposure_ev,
                "tonemap": "khr_pbr_neutral",
                "formula": formula,
            }},
        }),
        bin: Vec::new(),
    };
    if let Some(r) = source.get("extensionsRequired") {
        out.json["extensionsRequired"] = r.clone();
    }
    // Source images, samplers and textures, same indices.
    for img in images {
        let view = out.view(&img.bytes, None);
        out.push(
            "images",
            json!({ "bufferView": view, "mimeType": img.mime }),
        );
    }
    for key in ["samplers", "textures"] {
        if let Some(a) = source.get(key).and_then(Value::as_array) {
            for v in a {
                out.push(key, v.clone());
            }
        }
    }
    let lightmap_sampler = out.push(
        "samplers",
        json!({ "magFilter": 9729, "minFilter": 9729, "wrapS": 33071, "wrapT": 33071 }),
    );
    let mut page_texture = Vec::new();
    for (p, png) in pages.iter().enumerate() {
        let view = out.view(png, None);
        let image = out.push(
            "images",
            json!({ "bufferView": view, "mimeType": "image/png", "name": format!("lightmap {p}") }),
        );
        page_texture.push(out.push(
            "textures",
            json!({ "sampler": lightmap_sampler, "source": image, "name": format!("lightmap {p}") }),
        ));
    }

    // One material per (source material, page, one-sided): a double-sided sheet with a back
    // side is written as two one-sided layers, each with its own lightmap place.
    let mut material_of: HashMap<(u32, u32, bool), usize> = HashMap::new();
    let mut material_for = |out: &mut Out, (m, page, one_sided): (u32, u32, bool)| -> usize {
        if let Some(&i) = material_of.get(&(m, page, one_sided)) {
            return i;
        }
        let mut v = materials[m as usize].clone();
        move_texcoord_1(&mut v);
        let tex = page_texture[page as usize];
        let mut name = v
            .get("name")
            .and_then(Value::as_str)
            .unwrap_or("material")
            .to_string();
        if material_of.keys().any(|&(mm, p, _)| mm == m && p != page) {
            name = format!("{name} (lightmap page {page})");
            v["name"] = json!(name);
        }
        if one_sided {
            v["name"] = json!(format!("{name} (one side)"));
            v["doubleSided"] = json!(false);
        }
        let info = json!({ "index": tex, "texCoord": 1 });
        v.as_object_mut()
            .expect("materials are objects")
            .entry("extensions")
            .or_insert_with(|| json!({}))["MSFT_lightmap"] = json!({ "lightmapTexture": info });
        let extras = v
            .as_object_mut()
            .expect("materials are objects")
            .entry("extras")
            .or_insert_with(|| json!({}));
        if !extras.is_object() {
            *extras = json!({ "value": extras.clone() });
        }
        extras["glint_lightmap"] = json!({
            "texture": tex, "texCoord": 1, "encoding": binding.encoding, "scale": binding.scale, "source_material": m
        });
        let i = out.push("materials", v);
        material_of.insert((m, page, one_sided), i);
        i
    };

    let mut nodes = Vec::new();
    for (o, object) in scene.objects.iter().enumerate() {
        let mut prims: Vec<((u32, u32, bool), Prim)> = Vec::new();
        // Each scene triangle, and after one with a back side its twin (atlas triangle).
        let layers = object.triangles.clone().flat_map(|t| {
            let back = atlas.back_of(t);
            let front = (t, scene.triangles[t as usize], back.is_some());
            let twin = back.map(|b| (b, twin(&scene.triangles[t as usize]), true));
            std::iter::once(front).chain(twin)
        });
        for (t, tri, one_sided) in layers {
            let page = atlas.tri_page[t as usize];
            let size = atlas.pages[page as usize];
            let inv = Vec2::new(1.0 / size.width as f32, 1.0 / size.height as f32);
            let key = (tri.material, page, one_sided);
            let k = match prims.iter().position(|(k, _)| *k == key) {
                Some(k) => k,
                None => {
                    prims.push((key, Prim::default()));
                    prims.len() - 1
                }
            };
            let prim = &mut prims[k].1;
            let face = tri.face_normal();
            for v in 0..3 {
                let n = tri.n[v].normalize_or_zero();
                let n = if n == Vec3::ZERO { face } else { n };
                let lm = atlas.tri_coords[t as usize][v] * inv;
                let uv2 = tri.uv1.map_or(Vec2::ZERO, |uv| uv[v]);
                let i = prim.vertex(tri.p[v], n, tri.uv[v], lm, uv2);
                prim.idx.push(i);
            }
        }
        if prims.is_empty() {
            continue;
        }
        let mut primitives = Vec::new();
        for ((m, page, one_sided), p) in prims {
            let material = material_for(&mut out, (m, page, one_sided));
            let pos = out.floats(&p.pos, 3, "VEC3", true);
            let nrm = out.floats(&p.nrm, 3, "VEC3", false);
            // TEXCOORD_0 always: glTF numbers a semantic's sets from 0 without gaps.
            let uv0 = out.floats(&p.uv0, 2, "VEC2", false);
            let uv1 = out.floats(&p.uv1, 2, "VEC2", false);
            let mut attributes =
                json!({ "POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": uv0, "TEXCOORD_1": uv1 });
            if uses_texcoord_1(&materials[m as usize]) {
                attributes["TEXCOORD_2"] = json!(out.floats(&p.uv2, 2, "VEC2", false));
            }
            let indices = out.indices(&p.idx);
            primitives.push(
                json!({ "attributes": attributes, "indices": indices, "material": material }),
            );
        }
        let mut mesh = json!({ "primitives": primitives });
        if !object.mesh_name.is_empty() {
            mesh["name"] = json!(object.mesh_name);
        }
        let mesh = out.push("meshes", mesh);
        let name = if object.node_name.is_empty() {
            format!("object {o}")
        } else {
            object.node_name.clone()
        };
        nodes.push(out.push("nodes", json!({ "name": name, "mesh": mesh })));
    }
    for path in &scene.camera_paths {
        let Some(k) = path.keyframes.first() else {
            continue;
        };
        let (eye, target, up) = (
            Vec3::from(k.position),
            Vec3::from(k.target),
            Vec3::from(k.up),
        );
        let q = camera_pose(eye, target, up);
        let camera = out.push(
            "cameras",
            json!({ "name": path.name, "type": "perspective",
                    "perspective": { "yfov": k.fov_y_deg.to_radians(), "znear": 0.01 } }),
        );
        nodes.push(out.push(
            "nodes",
            json!({ "name": path.name, "camera": camera, "translation": eye.to_array(), "rotation": q.to_array(),
                    "extras": { "glint_camera": { "position": k.position, "target": k.target, "up": k.up, "fov_y_deg": k.fov_y_deg } } }),
        ));
    }
    out.json["scenes"] = json!([{ "nodes": nodes }]);
    out.json["scene"] = json!(0);
    while !out.bin.len().is_multiple_of(4) {
        out.bin.push(0);
    }
    out.json["buffers"] = json!([{ "byteLength": out.bin.len() }]);
    (out.json, out.bin)
}

/// A binary glTF (GLB 2) of `json` and `bin`.
pub fn glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut j = serde_json::to_vec(json).expect("JSON values serialize");
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let total = 12 + 8 + j.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_camera_looks_down_its_negative_z() {
        let q = camera_pose(Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0), Vec3::Y);
        assert!((q * Vec3::NEG_Z - Vec3::X).length() < 1e-6);
        assert!((q * Vec3::Y - Vec3::Y).length() < 1e-6);
    }

    #[test]
    fn vertices_split_where_lightmap_coordinates_differ() {
        let mut p = Prim::default();
        let a = p.vertex(Vec3::ZERO, Vec3::Y, Vec2::ZERO, Vec2::ZERO, Vec2::ZERO);
        let b = p.vertex(Vec3::ZERO, Vec3::Y, Vec2::ZERO, Vec2::ZERO, Vec2::ZERO);
        let c = p.vertex(
            Vec3::ZERO,
            Vec3::Y,
            Vec2::ZERO,
            Vec2::new(0.5, 0.0),
            Vec2::ZERO,
        );
        assert_eq!((a, b, c), (0, 0, 1));
        assert_eq!(p.uv1, vec![0.0, 0.0, 0.5, 0.0]);
    }

    #[test]
    fn a_material_sampling_set_1_moves_to_set_2() {
        let mut m = json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0, "texCoord": 1 } },
                            "emissiveTexture": { "index": 1 } });
        assert!(uses_texcoord_1(&m));
        move_texcoord_1(&mut m);
        assert_eq!(m["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"], 2);
        assert_eq!(m["emissiveTexture"].get("texCoord"), None);
        assert!(!uses_texcoord_1(&m));
    }

    #[test]
    fn glb_chunks_are_aligned_and_sized() {
        let g = glb(&json!({"a": 1}), &[1, 2, 3, 4]);
        assert_eq!(&g[0..4], b"glTF");
        assert_eq!(
            u32::from_le_bytes(g[8..12].try_into().unwrap()) as usize,
            g.len()
        );
        let jl = u32::from_le_bytes(g[12..16].try_into().unwrap()) as usize;
        assert_eq!(jl % 4, 0);
        assert_eq!(&g[20 + jl + 4..20 + jl + 8], b"BIN\0");
    }
}
