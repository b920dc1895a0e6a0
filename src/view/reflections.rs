//! Glossy planar reflections in the viewer (issue 9): L = kd·D + ks·R·M per glossy planar
//! reflector, M the radiance reflected about the reflector's plane, D the baked radiosity
//! (exitant radiance, kd already in it).
//!
//! Per reflector seen from its reflecting side and frame, two passes:
//! 1. M into an offscreen Rgba16Float texture in the reflected view (the viewpoint and its
//!    axes mirrored about the plane, [`mirror_camera`]), from one of two [`Source`]s:
//!    - geometry-based ([`ReflectionMode::Geometry`], Bastos §6's comparison baseline): the
//!      scene re-rendered, a clip plane discarding what lies behind the mirror;
//!    - image-based ([`ReflectionMode::Image`], §8.1.3): per reflector element, the `count`
//!      baked radiance maps closest to the mirrored eye ([`super::radiance_maps::select`],
//!      by angle or distance) reprojected as splats: every hit pixel's scene point
//!      ([`MapCamera::unproject`]) a camera-facing square (instanced triangle strip, WebGPU has
//!      no point size) sized by the map pixel's footprint at its depth ([`map_splats`]),
//!      depth-tested, nearest wins.
//! 2. The composite: the reflector drawn again over the frame, depth-tested against the scene
//!    pass (the mask), adding ks·R(θ) × M at the same pixel; R from the bundle's materials
//!    stage (1D map, [`reflectors_with_reflectance`]), else 1.
//!
//! Not yet (issue 9 stays open): the convolution with the material's kernel K (here K is the
//! identity), the sphere-map R and its switch, Eq. 3 splat sizes per quadtree node with node
//! culling and minification skipping (splats are per pixel, sized per point, not culled).
//!
//! [`cpu_reference`] is the same equation ray traced on the CPU, for the golden-image tests.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use rayon::prelude::*;

use super::gpu::{Gpu, GpuError, error_scoped};
use super::load::ViewData;
use super::radiance_maps::{MapEntry, Selection, load_cameras, select};
use super::renderer::RenderError;
use super::renderer::{
    HDR_FORMAT, Renderer, SceneMesh, Vertex, frame_bind_group, frame_bind_group_layout,
    reverse_z_depth, uniform_buffer,
};
use crate::bake::materials::reflectance;
use crate::camera::Camera;
use crate::geometry::Bvh;
use crate::radiance::sampling::MapCamera;
use crate::radiosity::RadiosityMap;
use crate::scene::desc::ReflectorKind;
use crate::scene::{Plane, Scene};

/// WGSL of the reflection passes (appended to [`super::renderer::SHADER_SOURCE`]).
pub const REFLECT_SHADER_SOURCE: &str = include_str!("../../shaders/reflect.wgsl");

/// Clip distance of the mirrored view as a fraction of the scene's bounding-box diagonal:
/// geometry closer to the plane than this (the reflector itself) is not reflected.
pub const CLIP_FRACTION: f32 = 1e-3;

/// How the viewer draws glossy reflections.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ReflectionMode {
    /// Diffuse D only.
    #[default]
    Off,
    /// The mirrored scene re-rendered per reflector (render to texture).
    Geometry,
    /// From the baked radiance maps (Bastos §8.1.3), splatted.
    Image,
}

impl std::str::FromStr for ReflectionMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "off" => Ok(ReflectionMode::Off),
            "geometry" => Ok(ReflectionMode::Geometry),
            "image" => Ok(ReflectionMode::Image),
            _ => Err(format!("{s:?} is not one of image, geometry, off")),
        }
    }
}

impl std::fmt::Display for ReflectionMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ReflectionMode::Off => "off",
            ReflectionMode::Geometry => "geometry",
            ReflectionMode::Image => "image",
        })
    }
}

/// A glossy planar reflector as the viewer draws it.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanarReflector {
    /// Name from the scene.
    pub name: String,
    /// Its plane (normal: the reflecting side).
    pub plane: Plane,
    /// Its material (index into the scene's materials).
    pub material: u32,
    /// ks: the sum of its material's lobes' ks.
    pub ks: Vec3,
    /// ks·R per view cosine: [`MODULATION_SIZE`] entries at the 1D map's cosines
    /// ([`reflectance::map_1d_cos`]), Σ over lobes of ks × the baked 1D reflectance map's `A`
    /// channel (the directional albedo: the modulation for a kernel normalized to 1); every
    /// entry ks (R = 1) when the bundle has no materials stage or a lobe has no 1D map.
    pub modulation: Vec<Vec3>,
    /// Its triangles (indices into the scene's triangles).
    pub triangles: Vec<u32>,
}

/// The scene's planar reflectors whose material has a glossy lobe, in scene order.
pub fn glossy_planar_reflectors(scene: &Scene) -> Vec<PlanarReflector> {
    scene
        .reflectors
        .iter()
        .filter(|r| r.kind == ReflectorKind::Planar)
        .filter_map(|r| {
            let plane = r.plane?;
            let material = scene.materials.get(r.material as usize)?;
            let ks = material
                .lobes
                .iter()
                .fold(Vec3::ZERO, |a, l| a + Vec3::from_array(l.ks));
            (ks.max_element() > 0.0).then(|| PlanarReflector {
                name: r.name.clone(),
                plane,
                material: r.material,
                ks,
                modulation: vec![ks; MODULATION_SIZE],
                triangles: r.triangles.clone(),
            })
        })
        .collect()
}

/// Entries of [`PlanarReflector::modulation`].
pub const MODULATION_SIZE: usize = 64;

/// Linear lookup of a modulation table at view cosine `cos_theta`, as the 1D map is read
/// ([`reflectance::sample_1d`]; the shader's `modulation` is the same).
pub fn sample_modulation(table: &[Vec3], cos_theta: f32) -> Vec3 {
    let channel = |k: usize| -> Vec<f32> { table.iter().map(|v| v[k]).collect() };
    Vec3::new(
        reflectance::sample_1d(&channel(0), cos_theta),
        reflectance::sample_1d(&channel(1), cos_theta),
        reflectance::sample_1d(&channel(2), cos_theta),
    )
}

/// The scene's glossy planar reflectors with R from the bundle's `materials` stage when it
/// has one (see [`PlanarReflector::modulation`]); problems reading it are logged and leave
/// R = 1 for that reflector.
pub fn reflectors_with_reflectance(data: &ViewData) -> Vec<PlanarReflector> {
    let mut reflectors = glossy_planar_reflectors(&data.scene);
    if data.bundle.stage("materials").is_none() {
        log::info!("no materials stage: reflections use R = 1 (ks only)");
        return reflectors;
    }
    let dir = data.bundle.dir().join("materials");
    let index: serde_json::Value = match std::fs::read(dir.join("index.json"))
        .map_err(|e| e.to_string())
        .and_then(|b| serde_json::from_slice(&b).map_err(|e| e.to_string()))
    {
        Ok(v) => v,
        Err(e) => {
            log::warn!("materials/index.json: {e}; reflections use R = 1");
            return reflectors;
        }
    };
    for r in &mut reflectors {
        let name = &data.scene.materials[r.material as usize].name;
        match load_modulation(&dir, &index, name) {
            Ok(table) => r.modulation = table,
            Err(e) => log::warn!("reflector {}: {e}; R = 1", r.name),
        }
    }
    reflectors
}

/// Σ_lobes ks × A(cos θ) of material `name` from the materials stage's index and 1D maps.
fn load_modulation(
    dir: &std::path::Path,
    index: &serde_json::Value,
    name: &str,
) -> Result<Vec<Vec3>, String> {
    let material = index["materials"]
        .as_array()
        .and_then(|m| m.iter().find(|m| m["name"] == name))
        .ok_or_else(|| format!("material {name:?} is not in materials/index.json"))?;
    let lobes = material["lobes"]
        .as_array()
        .ok_or_else(|| format!("material {name:?} has no lobes"))?;
    let mut table = vec![Vec3::ZERO; MODULATION_SIZE];
    for lobe in lobes {
        let ks: Vec<f32> = lobe["ks"]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|v| v.as_f64())
                    .map(|v| v as f32)
                    .collect()
            })
            .unwrap_or_default();
        let ks = match ks.as_slice() {
            [r, g, b] => Vec3::new(*r, *g, *b),
            _ => return Err(format!("material {name:?}: a lobe without ks")),
        };
        let path = lobe["reflectance_1d"]["path"]
            .as_str()
            .ok_or_else(|| format!("material {name:?}: a lobe has no 1D reflectance map"))?;
        let bytes = std::fs::read(dir.join(path)).map_err(|e| format!("{path}: {e}"))?;
        let image = crate::image_io::decode_exr(&bytes).map_err(|e| format!("{path}: {e}"))?;
        let a = image.channel("A").map_err(|e| format!("{path}: {e}"))?;
        if a.is_empty() || !a.iter().all(|v| v.is_finite()) {
            return Err(format!("{path}: empty or non-finite"));
        }
        for (k, t) in table.iter_mut().enumerate() {
            let c = reflectance::map_1d_cos(k as u32, MODULATION_SIZE as u32);
            *t += ks * reflectance::sample_1d(a, c);
        }
    }
    Ok(table)
}

/// Signed distance of `p` from `plane` (positive on the normal's side).
pub fn signed_distance(plane: &Plane, p: Vec3) -> f32 {
    plane.normal.dot(p - plane.point)
}

/// `p` mirrored about `plane`.
pub fn mirror_point(plane: &Plane, p: Vec3) -> Vec3 {
    p - 2.0 * signed_distance(plane, p) * plane.normal
}

/// Direction `d` mirrored about a plane of unit normal `n`.
pub fn mirror_direction(n: Vec3, d: Vec3) -> Vec3 {
    d - 2.0 * n.dot(d) * n
}

/// The reflected view: position and all three axes mirrored about `plane`. The mirrored frame
/// is left-handed, which makes pixel (x, y) of the mirrored view show what the real view sees
/// at (x, y) in the mirror: a point P projects in the mirrored view where its mirror image
/// projects in the real one.
pub fn mirror_camera(camera: &Camera, plane: &Plane) -> Camera {
    let n = plane.normal;
    Camera {
        position: mirror_point(plane, camera.position),
        forward: mirror_direction(n, camera.forward),
        right: mirror_direction(n, camera.right),
        up: mirror_direction(n, camera.up),
        fov_y: camera.fov_y,
    }
}

/// Mirrors `ReflectParams` in `shaders/reflect.wgsl` (1104 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct ReflectParams {
    /// Normal xyz, w = normal · point.
    pub plane: [f32; 4],
    /// ks rgb, a = clip distance.
    pub ks: [f32; 4],
    /// The eye xyz (written per frame), w = the 1D map's grazing bound C.
    pub eye: [f32; 4],
    /// The mirrored camera's right axis (per frame; splats are billboards on it).
    pub right: [f32; 4],
    /// The mirrored camera's up axis (per frame).
    pub up: [f32; 4],
    /// ks·R at the 1D map's cosines (rgb; a unused).
    pub modulation: [[f32; 4]; MODULATION_SIZE],
}

impl ReflectParams {
    /// The parameters of `reflector` with clip distance `clip`, seen from `eye`.
    pub fn new(reflector: &PlanarReflector, clip: f32, eye: Vec3) -> ReflectParams {
        let n = reflector.plane.normal;
        let mut modulation = [[0.0; 4]; MODULATION_SIZE];
        for (m, v) in modulation.iter_mut().zip(&reflector.modulation) {
            *m = v.extend(0.0).to_array();
        }
        ReflectParams {
            plane: n.extend(n.dot(reflector.plane.point)).to_array(),
            ks: reflector.ks.extend(clip).to_array(),
            eye: eye.extend(reflectance::C_GRAZING).to_array(),
            right: [0.0; 4],
            up: [0.0; 4],
            modulation,
        }
    }
}

/// The full WGSL module of the reflection passes.
pub fn shader_source() -> String {
    format!(
        "{}\n{}",
        super::renderer::SHADER_SOURCE,
        REFLECT_SHADER_SOURCE
    )
}

/// Where the reflected image M comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// The mirrored scene re-rendered (geometry-based mode).
    Geometry,
    /// The baked radiance maps splatted into the reflected view (image-based mode): per
    /// element, the `count` maps closest to the mirrored eye by `selection`.
    Image {
        /// Angle (Bastos's default) or distance.
        selection: Selection,
        /// Maps per reflector element.
        count: usize,
    },
}

/// One splat (32 bytes): a point of a radiance map, `@location(3..=5)` of `SplatIn`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Splat {
    /// Scene point.
    pub position: [f32; 3],
    /// Half the side of its square, metres: half the map pixel's footprint at the point's
    /// depth (the pixel's edge scaled by depth / image-plane depth) × [`SPLAT_OVERLAP`].
    pub radius: f32,
    /// Radiance (D at the point).
    pub color: [f32; 3],
    /// Padding.
    pub _pad: f32,
}

/// Splat size over the map pixel's footprint: > 1 so neighbouring splats overlap and leave
/// no holes when the reflected view sees the maps at an angle.
pub const SPLAT_OVERLAP: f32 = 1.5;

/// The splats of one map (hit pixels only), from its decoded EXR (R, G, B, A = hit, Z).
pub fn map_splats(
    view: &MapCamera,
    image: &crate::image_io::ExrImage,
) -> Result<Vec<Splat>, String> {
    let ch = |n: &str| image.channel(n).map_err(|e| e.to_string());
    let (r, g, b, a, z) = (ch("R")?, ch("G")?, ch("B")?, ch("A")?, ch("Z")?);
    let res = view.resolution as usize;
    if image.width != res || image.height != res {
        return Err(format!(
            "map is {}×{}, its camera says {res}²",
            image.width, image.height
        ));
    }
    let h = view.depth(view.corner);
    let pixel = view.edge_u.length().max(view.edge_v.length()) / view.resolution as f32;
    let mut out = Vec::new();
    for y in 0..res {
        for x in 0..res {
            let i = y * res + x;
            if a[i] < 0.5 || z[i].is_nan() || z[i] <= 0.0 || h <= 0.0 {
                continue;
            }
            let p = view.unproject(x as f32 + 0.5, y as f32 + 0.5, z[i]);
            out.push(Splat {
                position: p.to_array(),
                radius: 0.5 * pixel * (z[i] / h) * SPLAT_OVERLAP,
                color: [r[i].max(0.0), g[i].max(0.0), b[i].max(0.0)],
                _pad: 0.0,
            });
        }
    }
    Ok(out)
}

/// A reflector's maps on the GPU: every map's splats in one instance buffer.
struct SplatMaps {
    maps: Vec<MapEntry>,
    ranges: Vec<std::ops::Range<u32>>,
    instances: wgpu::Buffer,
}

fn load_splat_maps(gpu: &Gpu, data: &ViewData, reflector: &str) -> Result<SplatMaps, String> {
    let cams = load_cameras(data.bundle.dir(), reflector)?;
    let dir = data.bundle.dir().join("radiance").join(reflector);
    let mut all = Vec::new();
    let mut ranges = Vec::new();
    for m in &cams.maps {
        let path = dir.join(format!("{}.exr", m.file));
        let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let image =
            crate::image_io::decode_exr(&bytes).map_err(|e| format!("{}: {e}", path.display()))?;
        let splats = map_splats(&m.view, &image).map_err(|e| format!("{}: {e}", path.display()))?;
        let start = all.len() as u32;
        all.extend(splats);
        ranges.push(start..all.len() as u32);
    }
    let instances = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("glint radiance-map splats"),
        size: (std::mem::size_of_val(all.as_slice()) as u64).max(32),
        usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    gpu.queue
        .write_buffer(&instances, 0, bytemuck::cast_slice(&all));
    Ok(SplatMaps {
        maps: cams.maps,
        ranges,
        instances,
    })
}

struct ReflectorGpu {
    splats: Option<SplatMaps>,
    reflector: PlanarReflector,
    params: wgpu::Buffer,
    mirror_uniforms: wgpu::Buffer,
    mirror_frame_group: wgpu::BindGroup,
    mirror_params_group: wgpu::BindGroup,
    composite_params_group: wgpu::BindGroup,
    indices: wgpu::Buffer,
    index_count: u32,
}

/// The geometry-based reflection passes of one [`Renderer`] at one frame size.
pub struct GeometryReflections {
    source: Source,
    splat_pipeline: wgpu::RenderPipeline,
    mirror_pipeline: wgpu::RenderPipeline,
    composite_pipeline: wgpu::RenderPipeline,
    composite_frame_group: wgpu::BindGroup,
    reflectors: Vec<ReflectorGpu>,
    clip: f32,
    _texture: wgpu::Texture,
    texture_view: wgpu::TextureView,
    _depth: wgpu::Texture,
    depth_view: wgpu::TextureView,
    width: u32,
    height: u32,
}

impl GeometryReflections {
    /// The passes for `renderer` (drawing `data`) on `width` × `height` targets, with R from
    /// the bundle's materials stage ([`reflectors_with_reflectance`]).
    pub fn new(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        width: u32,
        height: u32,
        source: Source,
    ) -> Result<GeometryReflections, RenderError> {
        let mut splats = Vec::new();
        if let Source::Image { .. } = source
            && !glossy_planar_reflectors(&data.scene).is_empty()
        {
            if data.bundle.stage("radiance").is_none() {
                return Err(RenderError::Reflections(format!(
                    "bundle {}: image-based reflections need the `radiance` stage; bake it with glint-bake",
                    data.bundle.dir().display()
                )));
            }
            for r in glossy_planar_reflectors(&data.scene) {
                splats.push(Some(
                    load_splat_maps(gpu, data, &r.name).map_err(RenderError::Reflections)?,
                ));
            }
        }
        let mut splats = splats.into_iter();
        let built = Self::build(gpu, renderer, data, width, height, source, &mut splats)?;
        Ok(built)
    }

    #[allow(clippy::too_many_arguments)]
    fn build(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        width: u32,
        height: u32,
        source: Source,
        splats: &mut dyn Iterator<Item = Option<SplatMaps>>,
    ) -> Result<GeometryReflections, GpuError> {
        let (scene, map) = (&data.scene, &data.map);
        let planar = reflectors_with_reflectance(data);
        let device = &gpu.device;
        let mesh = SceneMesh::new(scene, &map.atlas);
        let clip = (scene.bounds.diagonal() * CLIP_FRACTION).max(1e-5);
        let formats = renderer.formats();
        error_scoped(device, "creating the reflection passes", || {
            let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("glint reflection shader"),
                source: wgpu::ShaderSource::Wgsl(shader_source().into()),
            });
            let frame_layout = frame_bind_group_layout(device);
            let params_entry = wgpu::BindGroupLayoutEntry {
                binding: 2,
                visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: wgpu::BufferSize::new(
                        std::mem::size_of::<ReflectParams>() as u64
                    ),
                },
                count: None,
            };
            let mirror_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("glint mirror params layout"),
                entries: &[params_entry],
            });
            let composite_layout =
                device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some("glint composite params layout"),
                    entries: &[
                        params_entry,
                        wgpu::BindGroupLayoutEntry {
                            binding: 3,
                            visibility: wgpu::ShaderStages::FRAGMENT,
                            ty: wgpu::BindingType::Texture {
                                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                                view_dimension: wgpu::TextureViewDimension::D2,
                                multisampled: false,
                            },
                            count: None,
                        },
                    ],
                });
            let pipeline_layout = |params: &wgpu::BindGroupLayout, label| {
                device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some(label),
                    bind_group_layouts: &[Some(&frame_layout), Some(params)],
                    immediate_size: 0,
                })
            };
            let vertex_buffers = [Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<Vertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x2, 2 => Uint32],
            })];
            let primitive = wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                ..Default::default()
            };
            let mirror_layout_p = pipeline_layout(&mirror_layout, "glint mirror pipeline layout");
            let mirror_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("glint mirror pipeline"),
                layout: Some(&mirror_layout_p),
                vertex: wgpu::VertexState {
                    module: &shader,
                    entry_point: Some("vs_mirror"),
                    compilation_options: wgpu::PipelineCompilationOptions::default(),
                    buffers: &vertex_buffers,
                },
                primitive,
                depth_stencil: Some(reverse_z_depth(true, wgpu::CompareFunction::Greater)),
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &shader,
                    entry_point: Some("fs_mirror"),
                    compilation_options: wgpu::PipelineCompilationOptions::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: HDR_FORMAT,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            });
            let splat_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("glint splat pipeline"),
                layout: Some(&mirror_layout_p),
                vertex: wgpu::VertexState {
                    module: &shader,
                    entry_point: Some("vs_splat"),
                    compilation_options: wgpu::PipelineCompilationOptions::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: std::mem::size_of::<Splat>() as u64,
                        step_mode: wgpu::VertexStepMode::Instance,
                        attributes: &wgpu::vertex_attr_array![3 => Float32x3, 4 => Float32, 5 => Float32x3],
                    })],
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleStrip,
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: Some(reverse_z_depth(true, wgpu::CompareFunction::Greater)),
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &shader,
                    entry_point: Some("fs_splat"),
                    compilation_options: wgpu::PipelineCompilationOptions::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: HDR_FORMAT,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            });
            let additive = wgpu::BlendState {
                color: wgpu::BlendComponent {
                    src_factor: wgpu::BlendFactor::One,
                    dst_factor: wgpu::BlendFactor::One,
                    operation: wgpu::BlendOperation::Add,
                },
                alpha: wgpu::BlendComponent {
                    src_factor: wgpu::BlendFactor::Zero,
                    dst_factor: wgpu::BlendFactor::One,
                    operation: wgpu::BlendOperation::Add,
                },
            };
            let target = |format| {
                Some(wgpu::ColorTargetState {
                    format,
                    blend: Some(additive),
                    write_mask: wgpu::ColorWrites::ALL,
                })
            };
            let composite_layout_p =
                pipeline_layout(&composite_layout, "glint composite pipeline layout");
            let composite_pipeline =
                device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some("glint reflection composite pipeline"),
                    layout: Some(&composite_layout_p),
                    vertex: wgpu::VertexState {
                        module: &shader,
                        entry_point: Some("vs_mirror"),
                        compilation_options: wgpu::PipelineCompilationOptions::default(),
                        buffers: &vertex_buffers,
                    },
                    primitive,
                    depth_stencil: Some(reverse_z_depth(
                        false,
                        wgpu::CompareFunction::GreaterEqual,
                    )),
                    multisample: wgpu::MultisampleState::default(),
                    fragment: Some(wgpu::FragmentState {
                        module: &shader,
                        entry_point: Some("fs_composite"),
                        compilation_options: wgpu::PipelineCompilationOptions::default(),
                        targets: &[
                            target(formats.color),
                            if formats.hdr {
                                target(HDR_FORMAT)
                            } else {
                                None
                            },
                        ],
                    }),
                    multiview_mask: None,
                    cache: None,
                });
            let size = wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            };
            let texture = device.create_texture(&wgpu::TextureDescriptor {
                label: Some("glint reflection texture"),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: HDR_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            });
            let texture_view = texture.create_view(&wgpu::TextureViewDescriptor::default());
            let depth = super::renderer::depth_texture(gpu, width, height);
            let depth_view = depth.create_view(&wgpu::TextureViewDescriptor::default());
            let composite_frame_group = frame_bind_group(
                device,
                &frame_layout,
                renderer.frame_uniform_buffer(),
                renderer.textures(),
            );
            let reflectors = planar
                .into_iter()
                .map(|reflector| {
                    let indices: Vec<u32> = reflector
                        .triangles
                        .iter()
                        .flat_map(|&t| {
                            let t = t as usize * 3;
                            mesh.indices[t..t + 3].iter().copied()
                        })
                        .collect();
                    let index_buffer = device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("glint reflector indices"),
                        size: (indices.len() as u64 * 4).max(4),
                        usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    });
                    gpu.queue
                        .write_buffer(&index_buffer, 0, bytemuck::cast_slice(&indices));
                    let params = device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("glint reflector params"),
                        size: std::mem::size_of::<ReflectParams>() as u64,
                        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    });
                    gpu.queue.write_buffer(
                        &params,
                        0,
                        bytemuck::bytes_of(&ReflectParams::new(&reflector, clip, Vec3::ZERO)),
                    );
                    let mirror_uniforms = uniform_buffer(device);
                    let mirror_frame_group = frame_bind_group(
                        device,
                        &frame_layout,
                        &mirror_uniforms,
                        renderer.textures(),
                    );
                    let params_entry = wgpu::BindGroupEntry {
                        binding: 2,
                        resource: params.as_entire_binding(),
                    };
                    let mirror_params_group =
                        device.create_bind_group(&wgpu::BindGroupDescriptor {
                            label: Some("glint mirror params"),
                            layout: &mirror_layout,
                            entries: std::slice::from_ref(&params_entry),
                        });
                    let composite_params_group =
                        device.create_bind_group(&wgpu::BindGroupDescriptor {
                            label: Some("glint composite params"),
                            layout: &composite_layout,
                            entries: &[
                                params_entry,
                                wgpu::BindGroupEntry {
                                    binding: 3,
                                    resource: wgpu::BindingResource::TextureView(&texture_view),
                                },
                            ],
                        });
                    ReflectorGpu {
                        splats: splats.next().flatten(),
                        index_count: indices.len() as u32,
                        reflector,
                        params,
                        mirror_uniforms,
                        mirror_frame_group,
                        mirror_params_group,
                        composite_params_group,
                        indices: index_buffer,
                    }
                })
                .collect();
            GeometryReflections {
                source,
                splat_pipeline,
                mirror_pipeline,
                composite_pipeline,
                composite_frame_group,
                reflectors,
                clip,
                _texture: texture,
                texture_view,
                _depth: depth,
                depth_view,
                width,
                height,
            }
        })
    }

    /// How many reflectors it draws.
    pub fn reflector_count(&self) -> usize {
        self.reflectors.len()
    }

    /// Writes each reflector's mirrored-view uniforms for `camera` (lands before the next
    /// submission).
    pub fn prepare(&self, gpu: &Gpu, renderer: &Renderer, camera: &Camera) {
        for r in &self.reflectors {
            let mirrored = mirror_camera(camera, &r.reflector.plane);
            let u = renderer.uniforms(&mirrored, self.width, self.height);
            gpu.queue
                .write_buffer(&r.mirror_uniforms, 0, bytemuck::bytes_of(&u));
            let mut p = ReflectParams::new(&r.reflector, self.clip, camera.position);
            p.right = mirrored.right.extend(0.0).to_array();
            p.up = mirrored.up.extend(0.0).to_array();
            gpu.queue.write_buffer(&r.params, 0, bytemuck::bytes_of(&p));
        }
    }

    /// Records, after the scene pass into `color`/`hdr`/`depth` (depth stored), each visible
    /// reflector's mirror pass and composite. Reflectors seen from behind are skipped.
    pub fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        renderer: &Renderer,
        camera: &Camera,
        color: &wgpu::TextureView,
        hdr: Option<&wgpu::TextureView>,
        depth: &wgpu::TextureView,
    ) {
        for r in &self.reflectors {
            if r.index_count == 0 || signed_distance(&r.reflector.plane, camera.position) <= 0.0 {
                continue;
            }
            {
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("glint mirror pass"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &self.texture_view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view: &self.depth_view,
                        depth_ops: Some(wgpu::Operations {
                            load: wgpu::LoadOp::Clear(0.0),
                            store: wgpu::StoreOp::Discard,
                        }),
                        stencil_ops: None,
                    }),
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                match (self.source, &r.splats) {
                    (Source::Image { selection, count }, Some(maps)) => {
                        pass.set_pipeline(&self.splat_pipeline);
                        pass.set_bind_group(0, &r.mirror_frame_group, &[]);
                        pass.set_bind_group(1, &r.mirror_params_group, &[]);
                        pass.set_vertex_buffer(0, maps.instances.slice(..));
                        let eye = mirror_point(&r.reflector.plane, camera.position);
                        for i in select(&maps.maps, eye, selection, count) {
                            pass.draw(0..4, maps.ranges[i].clone());
                        }
                    }
                    _ => {
                        pass.set_pipeline(&self.mirror_pipeline);
                        pass.set_bind_group(0, &r.mirror_frame_group, &[]);
                        pass.set_bind_group(1, &r.mirror_params_group, &[]);
                        pass.set_vertex_buffer(0, renderer.vertex_buffer().slice(..));
                        pass.set_index_buffer(
                            renderer.index_buffer().slice(..),
                            wgpu::IndexFormat::Uint32,
                        );
                        pass.draw_indexed(0..renderer.index_count(), 0, 0..1);
                    }
                }
            }
            let load = |view| {
                Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Store,
                    },
                })
            };
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("glint reflection composite pass"),
                color_attachments: &[load(color), hdr.and_then(load)],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: depth,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.composite_pipeline);
            pass.set_bind_group(0, &self.composite_frame_group, &[]);
            pass.set_bind_group(1, &r.composite_params_group, &[]);
            pass.set_vertex_buffer(0, renderer.vertex_buffer().slice(..));
            pass.set_index_buffer(r.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..r.index_count, 0, 0..1);
        }
    }
}

/// The CPU reference of the geometry-based mode: per pixel, the view ray's nearest hit gives
/// D; where it is a glossy planar reflector seen from its reflecting side, the ray mirrored
/// about the reflector's plane (from the hit, ignoring hits within `clip` of the plane, as the
/// GPU's clip plane does) adds ks·R(cos θ) × D at its nearest hit ([`sample_modulation`],
/// θ between the plane's normal and the direction to the eye). Linear × `exposure`, row 0 at the
/// top, black where nothing is hit.
#[allow(clippy::too_many_arguments)]
pub fn cpu_reference(
    scene: &Scene,
    reflectors: &[PlanarReflector],
    bvh: &Bvh,
    map: &RadiosityMap,
    camera: &Camera,
    width: u32,
    height: u32,
    exposure: f32,
) -> Vec<Vec3> {
    let mut of_triangle = vec![usize::MAX; scene.triangles.len()];
    for (i, r) in reflectors.iter().enumerate() {
        for &t in &r.triangles {
            of_triangle[t as usize] = i;
        }
    }
    let clip = (scene.bounds.diagonal() * CLIP_FRACTION).max(1e-5);
    let aspect = width.max(1) as f32 / height.max(1) as f32;
    let d = |t: u32, bary| super::bicubic::radiance(map, t, bary).max(Vec3::ZERO);
    (0..height)
        .into_par_iter()
        .flat_map_iter(|y| {
            let of_triangle = &of_triangle;
            (0..width).map(move |x| {
                let dir = camera.ray_direction(Camera::pixel_ndc(x, y, width, height), aspect);
                let Some(hit) = bvh.closest_hit(camera.position, dir, f32::INFINITY) else {
                    return Vec3::ZERO;
                };
                let mut l = d(hit.triangle, hit.bary);
                let r = of_triangle[hit.triangle as usize];
                if r != usize::MAX {
                    let refl = &reflectors[r];
                    let plane = &refl.plane;
                    if signed_distance(plane, camera.position) > 0.0 {
                        // The mirrored eye's ray through the hit: from the eye's image through
                        // the hit point, continued past the plane.
                        let p = camera.position + dir * hit.t;
                        let eye = mirror_point(plane, camera.position);
                        let rdir = (p - eye).normalize();
                        let mut origin = eye;
                        let mut travelled = 0.0f32;
                        for _ in 0..64 {
                            let Some(h) = bvh.closest_hit(origin, rdir, f32::INFINITY) else {
                                break;
                            };
                            let q = origin + rdir * h.t;
                            if signed_distance(plane, q) > clip {
                                let cos = plane.normal.dot(-dir);
                                l += sample_modulation(&refl.modulation, cos)
                                    * d(h.triangle, h.bary);
                                break;
                            }
                            let step = h.t + 1e-4 * (1.0 + travelled);
                            travelled += step;
                            origin += rdir * step;
                        }
                    }
                }
                l * exposure
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use wgpu::naga;

    #[test]
    fn reflect_params_match_the_wgsl_struct() {
        let module = naga::front::wgsl::parse_str(&shader_source()).expect("reflect.wgsl parses");
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        let (handle, ty) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some("ReflectParams"))
            .unwrap();
        let naga::TypeInner::Struct { members, .. } = &ty.inner else {
            panic!()
        };
        assert_eq!(
            layouter[handle].size as usize,
            std::mem::size_of::<ReflectParams>()
        );
        assert_eq!(
            members[0].offset as usize,
            std::mem::offset_of!(ReflectParams, plane)
        );
        assert_eq!(
            members[1].offset as usize,
            std::mem::offset_of!(ReflectParams, ks)
        );
    }

    #[test]
    fn mirrored_camera_sees_the_mirror_image_at_the_same_pixel() {
        let plane = Plane {
            normal: Vec3::new(0.2, 1.0, -0.1).normalize(),
            point: Vec3::new(0.1, -0.3, 0.2),
        };
        let cam = Camera::look_at(
            Vec3::new(0.3, 1.2, 4.0),
            Vec3::new(-0.2, 0.0, 0.0),
            Vec3::Y,
            50f32.to_radians(),
        );
        let m = mirror_camera(&cam, &plane);
        let (w, h) = (64.0f32, 48.0f32);
        let a = super::super::renderer::view_projection(&cam, w / h, 1e-3);
        let b = super::super::renderer::view_projection(&m, w / h, 1e-3);
        for p in [
            Vec3::new(0.5, 1.0, -1.0),
            Vec3::new(-1.0, 2.0, 0.5),
            Vec3::new(0.0, 0.3, -3.0),
        ] {
            let ca = a * mirror_point(&plane, p).extend(1.0);
            let cb = b * p.extend(1.0);
            assert!(((ca / ca.w) - (cb / cb.w)).length() < 1e-4, "{ca} vs {cb}");
        }
        assert!(
            (mirror_point(&plane, mirror_point(&plane, cam.position)) - cam.position).length()
                < 1e-5
        );
    }

    #[test]
    fn modes_parse() {
        assert_eq!("geometry".parse(), Ok(ReflectionMode::Geometry));
        assert_eq!("off".parse(), Ok(ReflectionMode::Off));
        assert!("mirror".parse::<ReflectionMode>().is_err());
    }
}
