//! What the tests share: their scaffolding ([`scaffold`]: paths, the adapter, skips, the
//! golden-update switch), shipped scenes baked once ([`shipped`]), and fixtures: tiny glTF
//! files and scene.json files written into temporary folders.

#![allow(dead_code)] // each test binary uses a different part of the fixtures

pub mod scaffold;
pub mod shipped;

#[allow(unused_imports)] // each test binary uses a different part
pub use scaffold::*;
#[allow(unused_imports)]
pub use shipped::{Recipe, Step, shipped_bundle};

use std::path::{Path, PathBuf};

/// A mesh for [`write_gltf`]: a name (used for both the node and the mesh), a material index,
/// positions and triangle indices.
pub struct MeshSpec {
    pub name: &'static str,
    pub material: usize,
    pub positions: Vec<[f32; 3]>,
    pub indices: Vec<u32>,
    /// Vertex normals; empty: none in the glTF (the loader takes face normals).
    pub normals: Vec<[f32; 3]>,
}

/// A glTF material: name, base colour, metallic, roughness, emissive, emissive strength.
pub struct MaterialSpec {
    pub name: &'static str,
    pub base: [f32; 4],
    pub metallic: f32,
    pub roughness: f32,
    pub emissive: [f32; 3],
    pub strength: f32,
}

impl MaterialSpec {
    pub fn diffuse(name: &'static str, albedo: f32) -> Self {
        MaterialSpec {
            name,
            base: [albedo, albedo, albedo, 1.0],
            metallic: 0.0,
            roughness: 1.0,
            emissive: [0.0; 3],
            strength: 1.0,
        }
    }

    /// A black, rough emitter of colour `emissive` × `strength`.
    pub fn emitter(name: &'static str, emissive: [f32; 3], strength: f32) -> Self {
        MaterialSpec {
            emissive,
            strength,
            ..Self::diffuse(name, 0.0)
        }
    }
}

/// The same mesh with every triangle's winding reversed (it faces the other way).
pub fn flip(mut m: MeshSpec) -> MeshSpec {
    for t in m.indices.chunks_mut(3) {
        t.swap(1, 2);
    }
    m
}

/// An axis-aligned quad in the plane `axis = offset`, spanning [-h, h] on the other two axes,
/// with counter-clockwise winding seen from +axis.
pub fn quad(name: &'static str, material: usize, axis: usize, offset: f32, h: f32) -> MeshSpec {
    let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
    let corner = |s: f32, t: f32| {
        let mut p = [0.0; 3];
        p[axis] = offset;
        p[a] = s * h;
        p[b] = t * h;
        p
    };
    MeshSpec {
        normals: Vec::new(),
        name,
        material,
        positions: vec![
            corner(-1.0, -1.0),
            corner(1.0, -1.0),
            corner(1.0, 1.0),
            corner(-1.0, 1.0),
        ],
        indices: vec![0, 1, 2, 0, 2, 3],
    }
}

/// A slab mirror as real assets model one: a `w` × `h` box `d` thick whose front face is
/// bevelled at 45° by `bevel` on every side (front inset by `bevel`, 20 triangles: front 2,
/// back 2, bevels 8, sides 8), wound counter-clockwise seen from outside. The front's centre
/// is `centre`, its normal `right` × `up` (both unit, perpendicular); the back lies `d` behind.
pub fn slab(
    name: &'static str,
    material: usize,
    centre: [f32; 3],
    right: [f32; 3],
    up: [f32; 3],
    size: (f32, f32, f32),
    bevel: f32,
) -> MeshSpec {
    use glam::Vec3;
    let (w, h, d) = size;
    let (c, r, u) = (Vec3::from(centre), Vec3::from(right), Vec3::from(up));
    let n = r.cross(u);
    // Local (x right, y up, z out of the front) to world.
    let at = |x: f32, y: f32, z: f32| (c + r * x + u * y + n * z).to_array();
    let (hw, hh) = (0.5 * w, 0.5 * h);
    let (iw, ih) = (hw - bevel, hh - bevel);
    let ring = |x: f32, y: f32, z: f32| [at(-x, -y, z), at(x, -y, z), at(x, y, z), at(-x, y, z)];
    let front = ring(iw, ih, 0.0);
    let rim = ring(hw, hh, -bevel);
    let back = ring(hw, hh, -d);
    let mut faces = vec![front, [back[0], back[3], back[2], back[1]]];
    for k in 0..4 {
        let j = (k + 1) % 4;
        faces.push([rim[k], rim[j], front[j], front[k]]);
        faces.push([back[k], back[j], rim[j], rim[k]]);
    }
    quads(name, material, &faces)
}

/// A mesh of quads, each four corners counter-clockwise seen from the side it faces (two
/// triangles: corners 0 1 2 and 0 2 3).
pub fn quads(name: &'static str, material: usize, faces: &[[[f32; 3]; 4]]) -> MeshSpec {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for q in faces {
        let base = positions.len() as u32;
        positions.extend(q);
        indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }
    MeshSpec {
        name,
        material,
        positions,
        indices,
        normals: Vec::new(),
    }
}

/// The reduced radiosity settings of the reflection tests (texel density 8, 32 rays, 4 light
/// samples, `bounces`, no glossy transport, no refinement).
pub fn quick_radiosity(bounces: u32) -> glint::scene::desc::RadiositySettings {
    glint::scene::desc::RadiositySettings {
        texel_density: 8.0,
        min_chart_texels: 0,
        min_scene_texels: 0,
        contact_boost: 0.0,
        texels_per_radian: 0.0,
        rays: 32,
        light_samples: 4,
        bounces,
        tolerance: 1e-2,
        glossy_depth: 0,
        target_error: None,
        stitch_seams: false,
        cache_budget_mib: 2048,
        max_elements: 0,
    }
}

/// Bakes `scene` into `bundle`: the scene stage and radiosity with `settings`. Panics with
/// the error.
#[cfg(feature = "view")]
fn bake_d(
    scene: &glint::scene::Scene,
    bundle: &Path,
    settings: &glint::scene::desc::RadiositySettings,
) {
    use glint::bake::{radiosity_stage, scene_stage};
    scene_stage::bake(scene, bundle, false).unwrap_or_else(|e| panic!("{e}"));
    radiosity_stage::bake(scene, bundle, settings, false, &glint::progress::Silent)
        .unwrap_or_else(|e| panic!("{e}"));
}

/// Bakes `scene` into `bundle`: the scene stage, radiosity with `settings` and the radiance
/// maps at draft quality. Panics with the error.
#[cfg(feature = "view")]
pub fn bake_with_radiance(
    scene: &glint::scene::Scene,
    bundle: &Path,
    settings: &glint::scene::desc::RadiositySettings,
) {
    use glint::bake::radiance_stage;
    use glint::progress::Silent;
    bake_d(scene, bundle, settings);
    radiance_stage::bake(
        scene,
        bundle,
        glint::scene::desc::Quality::Draft,
        false,
        &Silent,
    )
    .unwrap_or_else(|e| panic!("{e}"));
}

/// Bakes `scene` into `bundle`: the scene stage, radiosity with `settings` and the materials
/// stage (kernels, environment maps, probes) at draft quality. Panics with the error.
#[cfg(feature = "view")]
pub fn bake_with_materials(
    scene: &glint::scene::Scene,
    bundle: &Path,
    settings: &glint::scene::desc::RadiositySettings,
) {
    use glint::bake::materials::{self, MaterialsSettings};
    use glint::progress::Silent;
    bake_d(scene, bundle, settings);
    let draft = MaterialsSettings::preset(glint::scene::desc::Quality::Draft);
    materials::bake(scene, bundle, &draft, false, &Silent).unwrap_or_else(|e| panic!("{e}"));
}

/// Writes `NAME.gltf` + `NAME.bin` into `dir` and returns the .gltf path.
pub fn write_gltf(
    dir: &Path,
    name: &str,
    meshes: &[MeshSpec],
    materials: &[MaterialSpec],
) -> PathBuf {
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut json_meshes = Vec::new();
    let mut nodes = Vec::new();
    for (i, m) in meshes.iter().enumerate() {
        let pos_off = bin.len();
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in &m.positions {
            for k in 0..3 {
                bin.extend_from_slice(&p[k].to_le_bytes());
                if p[k].is_finite() {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        let idx_off = bin.len();
        for ix in &m.indices {
            bin.extend_from_slice(&ix.to_le_bytes());
        }
        let (pos, idx) = (views.len(), views.len() + 1);
        views.push(serde_json::json!({"buffer": 0, "byteOffset": pos_off, "byteLength": idx_off - pos_off}));
        views.push(serde_json::json!({"buffer": 0, "byteOffset": idx_off, "byteLength": bin.len() - idx_off}));
        accessors.push(serde_json::json!({"bufferView": pos, "componentType": 5126, "count": m.positions.len(), "type": "VEC3", "min": lo, "max": hi}));
        accessors.push(serde_json::json!({"bufferView": idx, "componentType": 5125, "count": m.indices.len(), "type": "SCALAR"}));
        let mut attributes = serde_json::json!({"POSITION": pos});
        if !m.normals.is_empty() {
            assert_eq!(
                m.normals.len(),
                m.positions.len(),
                "{}: a normal per vertex",
                m.name
            );
            let off = bin.len();
            for n in &m.normals {
                for c in n {
                    bin.extend_from_slice(&c.to_le_bytes());
                }
            }
            attributes["NORMAL"] = accessors.len().into();
            views.push(
                serde_json::json!({"buffer": 0, "byteOffset": off, "byteLength": bin.len() - off}),
            );
            accessors.push(serde_json::json!({"bufferView": views.len() - 1, "componentType": 5126, "count": m.normals.len(), "type": "VEC3"}));
        }
        json_meshes.push(serde_json::json!({"name": m.name, "primitives": [{"attributes": attributes, "indices": idx, "material": m.material}]}));
        nodes.push(serde_json::json!({"name": m.name, "mesh": i}));
    }
    let mats: Vec<_> = materials
        .iter()
        .map(|m| {
            serde_json::json!({
                "name": m.name,
                "pbrMetallicRoughness": {"baseColorFactor": m.base, "metallicFactor": m.metallic, "roughnessFactor": m.roughness},
                "emissiveFactor": m.emissive,
                "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": m.strength}}
            })
        })
        .collect();
    let doc = serde_json::json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"nodes": (0..meshes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": json_meshes,
        "materials": mats,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"uri": format!("{name}.bin"), "byteLength": bin.len()}],
    });
    std::fs::write(dir.join(format!("{name}.bin")), &bin).unwrap();
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, serde_json::to_string_pretty(&doc).unwrap()).unwrap();
    path
}

/// Makes material `index` of the glTF at `gltf` thin glass: `KHR_materials_transmission` with
/// `transmissionFactor` `factor`.
pub fn add_transmission(gltf: &Path, index: usize, factor: f32) {
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(gltf).unwrap()).unwrap();
    doc["materials"][index]["extensions"]["KHR_materials_transmission"] =
        serde_json::json!({ "transmissionFactor": factor });
    doc["extensionsUsed"]
        .as_array_mut()
        .unwrap()
        .push("KHR_materials_transmission".into());
    std::fs::write(gltf, serde_json::to_string_pretty(&doc).unwrap()).unwrap();
}

/// The room of [`write_room`]: floor (material 0), a glossy-capable panel (material 1) and
/// an emissive ceiling (material 2), as meshes and materials to extend.
pub fn room() -> (Vec<MeshSpec>, Vec<MaterialSpec>) {
    let meshes = vec![
        quad("Floor", 0, 1, 0.0, 1.0),
        quad("Panel", 1, 0, -0.9, 0.5),
        quad("Ceiling", 2, 1, 2.0, 1.0),
    ];
    let materials = vec![
        MaterialSpec::diffuse("FloorMat", 0.5),
        MaterialSpec {
            name: "PanelMat",
            base: [0.9, 0.9, 0.9, 1.0],
            metallic: 1.0,
            roughness: 0.05,
            emissive: [0.0; 3],
            strength: 1.0,
        },
        MaterialSpec {
            name: "LightMat",
            base: [0.0, 0.0, 0.0, 1.0],
            metallic: 0.0,
            roughness: 1.0,
            emissive: [1.0, 1.0, 1.0],
            strength: 10.0,
        },
    ];
    (meshes, materials)
}

/// Writes [`room`] as `room.gltf` + `room.bin` into `dir`. Returns the glTF path.
pub fn write_room(dir: &Path) -> PathBuf {
    let (meshes, materials) = room();
    write_gltf(dir, "room", &meshes, &materials)
}

/// A lit floor (`box.gltf` and its scene.json in `dir`): a scene with no glossy material,
/// quick to bake whole. Returns the scene.json's path.
pub fn lit_floor(dir: &Path) -> PathBuf {
    write_gltf(
        dir,
        "box",
        &[quad("Floor", 0, 1, 0.0, 1.0), quad("Light", 1, 1, 1.0, 0.2)],
        &[
            MaterialSpec::diffuse("white", 0.7),
            MaterialSpec::emitter("lamp", [1.0; 3], 5.0),
        ],
    );
    write_scene(dir, r#"{ "version": 1, "geometry": "box.gltf" }"#)
}

/// Runs the executable `exe` with `args`: its exit code (-1 when killed), stdout and stderr.
pub fn run_exe<S: AsRef<std::ffi::OsStr>>(exe: &str, args: &[S]) -> (i32, String, String) {
    let out = std::process::Command::new(exe).args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Writes `scene.json` with the given JSON text into `dir` and returns its path.
pub fn write_scene(dir: &Path, json: &str) -> PathBuf {
    let path = dir.join("scene.json");
    std::fs::write(&path, json).unwrap();
    path
}

/// A UV sphere (24 rings × 48 segments) of `radius` about `centre`, with its exact vertex
/// normals when `smooth` (else none: the loader's face normals).
pub fn uv_sphere(
    name: &'static str,
    material: usize,
    centre: [f32; 3],
    radius: f32,
    smooth: bool,
) -> MeshSpec {
    let (rings, segments) = (24u32, 48u32);
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for i in 0..=rings {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..segments {
            let phi = 2.0 * std::f32::consts::PI * j as f32 / segments as f32;
            let d = [
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ];
            positions.push([
                centre[0] + d[0] * radius,
                centre[1] + d[1] * radius,
                centre[2] + d[2] * radius,
            ]);
            normals.push(d);
        }
    }
    let mut indices = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            let a = i * segments + j;
            let b = i * segments + (j + 1) % segments;
            let (c, d) = (a + segments, b + segments);
            if i > 0 {
                indices.extend([a, b, c]);
            }
            if i + 1 < rings {
                indices.extend([b, d, c]);
            }
        }
    }
    MeshSpec {
        name,
        material,
        positions,
        indices,
        normals: if smooth { normals } else { Vec::new() },
    }
}

/// A diffuse material of base colour `c` (glTF roughness 0.5).
pub fn coloured(name: &'static str, c: [f32; 3]) -> MaterialSpec {
    MaterialSpec {
        base: [c[0], c[1], c[2], 1.0],
        ..MaterialSpec::diffuse(name, 0.5)
    }
}

/// The coloured rooms' walls, materials 0–3: grey, red, green and blue.
pub fn coloured_walls() -> Vec<MaterialSpec> {
    vec![
        coloured("Grey", [0.6, 0.6, 0.6]),
        coloured("Red", [0.7, 0.25, 0.2]),
        coloured("Green", [0.25, 0.65, 0.3]),
        coloured("Blue", [0.3, 0.35, 0.7]),
    ]
}

/// A closed 4 × 3 × 4 m room of [`coloured_walls`] (grey floor, ceiling and front, red left,
/// green right, blue back), a 1 × 1 m ceiling lamp (material 4) and a 1 × 1 m pane of tint
/// `glass` (material 5; the caller makes it transmissive with [`add_transmission`]) at z = 0,
/// its lower edge `pane_y` above the floor. The floor takes material `floor`, so a caller may
/// append its own.
pub fn pane_room(glass: [f32; 3], floor: usize, pane_y: f32) -> (Vec<MeshSpec>, Vec<MaterialSpec>) {
    use glam::Vec3;
    let mut materials = coloured_walls();
    materials.push(MaterialSpec::emitter("Light", [1.0, 1.0, 1.0], 6.0));
    materials.push(coloured("Glass", glass));
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    let meshes = vec![
        rect("Floor", floor, Vec3::new(-2.0, 0.0, 2.0), 4.0 * x, -4.0 * z),
        rect("Ceiling", 0, Vec3::new(-2.0, 3.0, -2.0), 4.0 * x, 4.0 * z),
        rect("Back", 3, Vec3::new(-2.0, 0.0, -2.0), 4.0 * x, 3.0 * y),
        rect("Front", 0, Vec3::new(2.0, 0.0, 2.0), -4.0 * x, 3.0 * y),
        rect("Left", 1, Vec3::new(-2.0, 0.0, 2.0), -4.0 * z, 3.0 * y),
        rect("Right", 2, Vec3::new(2.0, 0.0, -2.0), 4.0 * z, 3.0 * y),
        rect("Lamp", 4, Vec3::new(-0.5, 2.99, -0.5), x, z),
        rect("Pane", 5, Vec3::new(-0.5, pane_y, 0.0), x, y),
    ];
    (meshes, materials)
}

/// A rectangle corner, corner + u, corner + u + v, corner + v: facing u × v.
pub fn rect(
    name: &'static str,
    material: usize,
    corner: glam::Vec3,
    u: glam::Vec3,
    v: glam::Vec3,
) -> MeshSpec {
    let q = [corner, corner + u, corner + u + v, corner + v].map(|p| p.to_array());
    quads(name, material, &[q])
}

/// Pixels whose primary ray (as `cpu_reference` and the reference path tracer cast it) hits
/// the reflecting face of reflector `reflector` and whose 8 neighbours do too (rasterisation
/// and ray casting disagree on edge pixels).
#[cfg(feature = "view")]
pub fn reflector_mask(
    data: &glint::view::load::ViewData,
    reflector: usize,
    camera: &glint::camera::Camera,
    w: u32,
    h: u32,
) -> Vec<bool> {
    use glint::camera::Camera;
    let r = &data.scene.reflectors[reflector];
    let bvh = glint::geometry::Bvh::build(&data.scene.triangles);
    let aspect = w as f32 / h as f32;
    let hits: Vec<bool> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let dir = camera.ray_direction(Camera::pixel_ndc(x, y, w, h), aspect);
            bvh.closest_hit(camera.position, dir, f32::INFINITY)
                .is_some_and(|hit| r.triangles.contains(&hit.triangle))
        })
        .collect();
    let at = |x: i64, y: i64| {
        x >= 0 && y >= 0 && x < w as i64 && y < h as i64 && hits[(y * w as i64 + x) as usize]
    };
    (0..h as i64)
        .flat_map(|y| (0..w as i64).map(move |x| (x, y)))
        .map(|(x, y)| (-1..=1).all(|dy| (-1..=1).all(|dx| at(x + dx, y + dy))))
        .collect()
}

/// Linear HDR frames of `data` from `camera` in each reflection mode.
#[cfg(feature = "view")]
pub fn hdr_frames(
    data: &glint::view::load::ViewData,
    camera: &glint::camera::Camera,
    size: (u32, u32),
    modes: &[glint::view::reflections::ReflectionMode],
) -> Vec<Vec<glam::Vec3>> {
    let gpu = gpu();
    let mut off = glint::view::headless::Offscreen::new(&gpu, data, size.0, size.1).unwrap();
    modes
        .iter()
        .map(|&mode| {
            off.set_reflections(&gpu, data, mode).unwrap();
            off.render(&gpu, camera).unwrap();
            off.read_hdr(&gpu).unwrap()
        })
        .collect()
}

/// Copies a folder recursively (a bundle, to damage the copy).
pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let p = entry.unwrap().path();
        let dest = to.join(p.file_name().unwrap());
        if p.is_dir() {
            copy_dir(&p, &dest);
        } else {
            std::fs::copy(&p, &dest).unwrap();
        }
    }
}

/// The path tracer's frame (64 spp) of `scene` with only the `kept` materials' glossy lobes,
/// every other material diffuse (none kept: all diffuse): the viewer's D is the diffuse
/// solution, so that is the light its specular term reflects. With the BVH it traced, for
/// masks of what each pixel sees.
pub fn traced_with_lobes_of(
    scene: &mut glint::scene::Scene,
    kept: &[u32],
    camera: &glint::camera::Camera,
    (width, height): (u32, u32),
) -> (glint::geometry::Bvh, glint::eval::reference::Rendered) {
    for (i, m) in scene.materials.iter_mut().enumerate() {
        if !kept.contains(&(i as u32)) {
            m.lobes.clear();
        }
    }
    let bvh = scene.build_bvh();
    let options = glint::eval::reference::RenderOptions {
        width,
        height,
        spp: 64,
        ..Default::default()
    };
    let rendered =
        glint::eval::reference::render(scene, &bvh, camera, &options, &glint::progress::Silent)
            .unwrap();
    (bvh, rendered)
}

/// A label per triangle: `label` for each triangle of each group, 0 for the rest of `count`.
pub fn label_triangles(count: usize, groups: &[(&[u32], u8)]) -> Vec<u8> {
    let mut of = vec![0u8; count];
    for (triangles, label) in groups {
        for &t in *triangles {
            of[t as usize] = *label;
        }
    }
    of
}

/// The index of `scene`'s material called `name` (panics, naming it, if there is none).
pub fn material_id(scene: &glint::scene::Scene, name: &str) -> u32 {
    scene
        .materials
        .iter()
        .position(|m| m.name == name)
        .unwrap_or_else(|| panic!("no material {name}")) as u32
}

/// Mean luminance of `rgb` over the pixels `mask` keeps (0 where it keeps none).
pub fn masked_luminance(rgb: &[glam::Vec3], mask: &[bool]) -> f64 {
    let count = mask.iter().filter(|m| **m).count();
    mask.iter()
        .zip(rgb)
        .filter(|(m, _)| **m)
        .map(|(_, c)| f64::from(glint::colour::luminance(*c)))
        .sum::<f64>()
        / count.max(1) as f64
}

/// The pixels of a `width` × `height` frame from `camera` all of whose `sub` × `sub`
/// sub-pixel rays (their directions) `sees` accepts.
pub fn covered_pixels(
    camera: &glint::camera::Camera,
    (width, height): (u32, u32),
    sub: u32,
    sees: impl Fn(glam::Vec3) -> bool,
) -> Vec<bool> {
    use glint::camera::Camera;
    let (sw, sh) = (width * sub, height * sub);
    let ray = |x: u32, y: u32| {
        camera.ray_direction(Camera::pixel_ndc(x, y, sw, sh), sw as f32 / sh as f32)
    };
    (0..width * height)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            (0..sub * sub).all(|k| sees(ray(x * sub + k % sub, y * sub + k / sub)))
        })
        .collect()
}
