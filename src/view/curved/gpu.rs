//! The GPU half of curved reflectors: live cube maps (generated once, double-buffered across
//! generations), their MIP levels, baked MIP pyramids as cube textures, and the composite
//! pass that shades the reflectors' pixels (see [`super`] for the equations).

use std::sync::Mutex;

use exr::prelude::f16;
use glam::{Vec3, Vec4};

use super::{
    CurvedParams, CurvedReflector, CurvedSettings, DEFAULT_XI0, curved_reflectors, face_camera,
    generation_plan, pack_patterns, patterns_for, shader_source,
};
use crate::camera::Camera;
use crate::materials::MaterialsIndex;
use crate::materials::envmap::MipPyramid;
use crate::view::gpu::{Gpu, GpuError, error_scoped, probe_io_layout, run_probe};
use crate::view::load::ViewData;
use crate::view::renderer::{
    HDR_FORMAT, RenderError, Renderer, SceneMesh, frame_bind_group, frame_bind_group_layout,
    reverse_z_depth, uniform_buffer,
};

/// One vertex of a curved reflector (24 bytes): `CurvedVertexIn` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CurvedVertex {
    /// World position.
    pub position: [f32; 3],
    /// Vertex normal (interpolated, normalized in the shader).
    pub normal: [f32; 3],
}

const CURVED_ATTRIBUTES: [wgpu::VertexAttribute; 2] =
    wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];

impl CurvedVertex {
    /// The vertex buffer layout of `CurvedVertexIn` (and of the impostor pass's `ImpostorIn`).
    pub fn layout() -> wgpu::VertexBufferLayout<'static> {
        wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<CurvedVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &CURVED_ATTRIBUTES,
        }
    }
}

/// A cube texture with every MIP level, and the views the passes need.
pub struct CubeTexture {
    /// The texture (6 layers).
    pub texture: wgpu::Texture,
    /// All levels as a cube.
    pub cube: wgpu::TextureView,
    /// `faces[level][face]`: one face of one level as a 2D view (render target or source).
    faces: Vec<Vec<wgpu::TextureView>>,
    /// Face size of level 0.
    pub size: u32,
}

impl CubeTexture {
    fn new(gpu: &Gpu, size: u32, levels: u32, label: &str) -> CubeTexture {
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: size,
                height: size,
                depth_or_array_layers: 6,
            },
            mip_level_count: levels,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: HDR_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let cube = texture.create_view(&wgpu::TextureViewDescriptor {
            label: Some("glint cube map"),
            dimension: Some(wgpu::TextureViewDimension::Cube),
            ..Default::default()
        });
        let faces = (0..levels)
            .map(|level| {
                (0..6)
                    .map(|face| {
                        texture.create_view(&wgpu::TextureViewDescriptor {
                            label: Some("glint cube face"),
                            dimension: Some(wgpu::TextureViewDimension::D2),
                            base_mip_level: level,
                            mip_level_count: Some(1),
                            base_array_layer: face,
                            array_layer_count: Some(1),
                            ..Default::default()
                        })
                    })
                    .collect()
            })
            .collect();
        CubeTexture {
            texture,
            cube,
            faces,
            size,
        }
    }

    /// Levels of a full chain down to 1×1 for face size `size`.
    fn full_chain(size: u32) -> u32 {
        32 - size.max(1).leading_zeros()
    }

    /// Uploads a MIP pyramid (level sizes halving exactly: a power-of-two base).
    pub fn from_pyramid(gpu: &Gpu, pyramid: &MipPyramid) -> Result<CubeTexture, GpuError> {
        let size = pyramid.base_size() as u32;
        error_scoped(&gpu.device, "uploading an environment map", || {
            let t = CubeTexture::new(gpu, size, pyramid.levels.len() as u32, "glint baked env");
            for (level, map) in pyramid.levels.iter().enumerate() {
                let n = map.size as u32;
                let halves: Vec<u16> = map
                    .texels
                    .iter()
                    .flat_map(|v| [v.x, v.y, v.z, 1.0])
                    .map(|c| f16::from_f32(c).to_bits())
                    .collect();
                gpu.queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &t.texture,
                        mip_level: level as u32,
                        origin: wgpu::Origin3d::ZERO,
                        aspect: wgpu::TextureAspect::All,
                    },
                    bytemuck::cast_slice(&halves),
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(n * 8),
                        rows_per_image: Some(n),
                    },
                    wgpu::Extent3d {
                        width: n,
                        height: n,
                        depth_or_array_layers: 6,
                    },
                );
            }
            t
        })
    }
}

/// Reads the baked MIP pyramid of `reflector` from the bundle's materials stage, if any.
pub fn load_baked_pyramid(data: &ViewData, reflector: &str) -> Result<Option<MipPyramid>, String> {
    MaterialsIndex::load(&data.bundle)
        .and_then(|index| match index {
            Some(index) => index.read_env_pyramid(&data.bundle, reflector),
            None => Ok(None),
        })
        .map_err(|e| e.to_string())
}

/// ξ₀ of the bundle's materials stage (its patterns' threshold), else [`DEFAULT_XI0`].
fn baked_xi0(data: &ViewData) -> f32 {
    MaterialsIndex::load(&data.bundle)
        .ok()
        .flatten()
        .map_or(DEFAULT_XI0, |index| index.settings.xi0)
}

/// Where a reflector's glossy term reads its environment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EnvSource {
    /// The live cube map (rendered by the viewer, with interreflections).
    Live,
    /// The materials stage's baked MIP pyramid.
    Baked,
}

struct ReflectorGpu {
    reflector: CurvedReflector,
    vertices: wgpu::Buffer,
    vertex_count: u32,
    /// The scene without this reflector (its cube map's draw).
    others: wgpu::Buffer,
    others_count: u32,
    /// Frame uniforms of its six face cameras.
    face_groups: Vec<wgpu::BindGroup>,
    _face_uniforms: Vec<wgpu::Buffer>,
    params: wgpu::Buffer,
    base_params: CurvedParams,
    composite_group: wgpu::BindGroup,
    source: EnvSource,
    _baked: Option<CubeTexture>,
    patterns: wgpu::Buffer,
}

/// One mirrored view of the curved reflectors (a planar mirror's pass): its frame uniforms
/// and, per reflector, its parameters (mirrored eye, the mirror's clip plane).
struct MirrorView {
    uniforms: wgpu::Buffer,
    frame_group: wgpu::BindGroup,
    /// Per reflector: parameters and the composite group reading them.
    reflectors: Vec<(wgpu::Buffer, wgpu::BindGroup)>,
}

/// The curved-reflector passes of one [`Renderer`]: cube maps made at construction, the
/// composite recorded per frame ([`CurvedReflections::prepare`], [`CurvedReflections::draw`])
/// and inside planar mirrors' passes ([`CurvedReflections::prepare_mirror`],
/// [`CurvedReflections::draw_mirror`]).
pub struct CurvedReflections {
    settings: CurvedSettings,
    reflectors: Vec<ReflectorGpu>,
    /// `maps[set][reflector]`.
    maps: [Vec<CubeTexture>; 2],
    final_set: usize,
    composite_pipeline: wgpu::RenderPipeline,
    composite_frame_group: wgpu::BindGroup,
    /// The composite inside a planar mirror's pass (`fs_curved_mirror`, the HDR map M).
    mirror_pipeline: wgpu::RenderPipeline,
    /// Mirrored views, by the slot the planar passes give them (grown as needed).
    mirror_views: Mutex<Vec<MirrorView>>,
    frame_layout: wgpu::BindGroupLayout,
    curved_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    /// Seconds the cube maps took (all generations, submit to complete).
    pub generation_seconds: f64,
}

fn curved_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let all =
        wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("glint curved layout"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 4,
                visibility: all,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: wgpu::BufferSize::new(
                        std::mem::size_of::<CurvedParams>() as u64
                    ),
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 5,
                visibility: wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: true },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 6,
                visibility: wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: true },
                    view_dimension: wgpu::TextureViewDimension::Cube,
                    multisampled: false,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 7,
                visibility: wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
        ],
    })
}

fn trilinear_sampler(device: &wgpu::Device) -> wgpu::Sampler {
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("glint cube sampler"),
        address_mode_u: wgpu::AddressMode::ClampToEdge,
        address_mode_v: wgpu::AddressMode::ClampToEdge,
        address_mode_w: wgpu::AddressMode::ClampToEdge,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Linear,
        ..Default::default()
    })
}

fn curved_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    params: &wgpu::Buffer,
    patterns: &wgpu::Buffer,
    env: &wgpu::TextureView,
    sampler: &wgpu::Sampler,
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("glint curved group"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 4,
                resource: params.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 5,
                resource: patterns.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 6,
                resource: wgpu::BindingResource::TextureView(env),
            },
            wgpu::BindGroupEntry {
                binding: 7,
                resource: wgpu::BindingResource::Sampler(sampler),
            },
        ],
    })
}

fn buffer_with(gpu: &Gpu, label: &str, usage: wgpu::BufferUsages, bytes: &[u8]) -> wgpu::Buffer {
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: (bytes.len() as u64).max(16).next_multiple_of(4),
        usage: usage | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    gpu.queue.write_buffer(&buffer, 0, bytes);
    buffer
}

/// The vertices (position, normal) of `triangles`, three per triangle.
pub fn reflector_vertices(scene: &crate::scene::Scene, triangles: &[u32]) -> Vec<CurvedVertex> {
    triangles
        .iter()
        .flat_map(|&t| {
            let tri = &scene.triangles[t as usize];
            (0..3).map(move |k| CurvedVertex {
                position: tri.p[k].to_array(),
                normal: tri.n[k].to_array(),
            })
        })
        .collect()
}

#[allow(clippy::too_many_arguments)]
fn pipeline(
    device: &wgpu::Device,
    shader: &wgpu::ShaderModule,
    label: &str,
    layouts: &[Option<&wgpu::BindGroupLayout>],
    vs: &str,
    fs: &str,
    buffers: &[Option<wgpu::VertexBufferLayout<'_>>],
    targets: &[Option<wgpu::ColorTargetState>],
    depth: Option<wgpu::DepthStencilState>,
) -> wgpu::RenderPipeline {
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: layouts,
        immediate_size: 0,
    });
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: shader,
            entry_point: Some(vs),
            compilation_options: wgpu::PipelineCompilationOptions::default(),
            buffers,
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: depth,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: shader,
            entry_point: Some(fs),
            compilation_options: wgpu::PipelineCompilationOptions::default(),
            targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

impl CurvedReflections {
    /// The passes for `renderer` drawing `data`, with every generation of cube maps rendered
    /// (this blocks until the GPU has finished them).
    pub fn new(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        settings: CurvedSettings,
    ) -> Result<CurvedReflections, RenderError> {
        let reflectors = curved_reflectors(&data.scene);
        let mut baked = Vec::new();
        for r in &reflectors {
            let pyramid = if settings.glossy_samples > 0 {
                load_baked_pyramid(data, &r.name).map_err(RenderError::Reflections)?
            } else {
                None
            };
            baked.push(match pyramid {
                Some(p) => Some(CubeTexture::from_pyramid(gpu, &p)?),
                None => None,
            });
        }
        let face_size = settings
            .face_size
            .clamp(1, gpu.device.limits().max_texture_dimension_2d);
        let built = Self::build(gpu, renderer, data, settings, face_size, reflectors, baked)?;
        let start = std::time::Instant::now();
        let submission = error_scoped(&gpu.device, "rendering the cube maps", || {
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("glint cube maps"),
                });
            built
                .0
                .record_generations(gpu, &built.1, renderer.vertex_buffer(), &mut encoder);
            gpu.queue.submit([encoder.finish()])
        })?;
        gpu.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(submission),
                timeout: None,
            })
            .map_err(GpuError::from)?;
        let mut passes = built.0;
        passes.generation_seconds = start.elapsed().as_secs_f64();
        Ok(passes)
    }

    #[allow(clippy::too_many_arguments)]
    fn build(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        settings: CurvedSettings,
        face_size: u32,
        reflectors: Vec<CurvedReflector>,
        baked: Vec<Option<CubeTexture>>,
    ) -> Result<(CurvedReflections, GenerationPipelines), GpuError> {
        let device = &gpu.device;
        let scene = &data.scene;
        let mesh = SceneMesh::new(scene, &data.map.atlas);
        let xi0 = baked_xi0(data);
        error_scoped(device, "creating the curved-reflector passes", || {
            let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("glint curved shader"),
                source: wgpu::ShaderSource::Wgsl(shader_source().into()),
            });
            let frame_layout = frame_bind_group_layout(device);
            let curved_layout = curved_layout(device);
            let sampler = trilinear_sampler(device);
            let levels = CubeTexture::full_chain(face_size);
            let maps = [0, 1].map(|_| {
                reflectors
                    .iter()
                    .map(|_| CubeTexture::new(gpu, face_size, levels, "glint live cube map"))
                    .collect::<Vec<_>>()
            });
            let plan = generation_plan(settings.generations);
            let final_set = plan.last().expect("at least one generation").write;
            let formats = renderer.formats();
            let curved_buffers = [Some(CurvedVertex::layout())];
            let additive = |format| {
                Some(wgpu::ColorTargetState {
                    format,
                    blend: Some(crate::view::renderer::ADDITIVE_KEEP_ALPHA),
                    write_mask: wgpu::ColorWrites::ALL,
                })
            };
            let composite_pipeline = pipeline(
                device,
                &shader,
                "glint curved composite",
                &[Some(&frame_layout), Some(&curved_layout)],
                "vs_curved",
                "fs_curved",
                &curved_buffers,
                &[
                    additive(formats.color),
                    if formats.hdr {
                        additive(HDR_FORMAT)
                    } else {
                        None
                    },
                ],
                Some(reverse_z_depth(false, wgpu::CompareFunction::GreaterEqual)),
            );
            // Inside a mirror pass: one linear HDR target (M), depth tested, not written.
            let mirror_pipeline = pipeline(
                device,
                &shader,
                "glint curved composite in a mirror",
                &[Some(&frame_layout), Some(&curved_layout)],
                "vs_curved",
                "fs_curved_mirror",
                &curved_buffers,
                &[additive(HDR_FORMAT)],
                Some(reverse_z_depth(false, wgpu::CompareFunction::GreaterEqual)),
            );
            let generation = GenerationPipelines::new(
                device,
                &shader,
                &frame_layout,
                &curved_layout,
                &curved_buffers,
                face_size,
                gpu,
            );
            let composite_frame_group = frame_bind_group(
                device,
                &frame_layout,
                renderer.frame_uniform_buffer(),
                renderer.textures(),
            );
            let in_reflector = {
                let mut v = vec![usize::MAX; scene.triangles.len()];
                for (i, r) in reflectors.iter().enumerate() {
                    for &t in &r.triangles {
                        v[t as usize] = i;
                    }
                }
                v
            };
            let gpus = reflectors
                .into_iter()
                .zip(baked)
                .enumerate()
                .map(|(i, (reflector, baked))| {
                    let verts = reflector_vertices(scene, &reflector.triangles);
                    let vertices = buffer_with(
                        gpu,
                        "glint curved vertices",
                        wgpu::BufferUsages::VERTEX,
                        bytemuck::cast_slice(&verts),
                    );
                    let others: Vec<u32> = (0..scene.triangles.len())
                        .filter(|&t| in_reflector[t] != i)
                        .flat_map(|t| mesh.indices[3 * t..3 * t + 3].iter().copied())
                        .collect();
                    let others_buffer = buffer_with(
                        gpu,
                        "glint cube map indices",
                        wgpu::BufferUsages::INDEX,
                        bytemuck::cast_slice(&others),
                    );
                    let mut face_uniforms = Vec::new();
                    let mut face_groups = Vec::new();
                    for face in 0..6 {
                        let mut u = renderer.uniforms(
                            &face_camera(reflector.centre, face),
                            face_size,
                            face_size,
                        );
                        u.exposure = 1.0; // the maps hold radiance; the frame applies exposure
                        u.encode_srgb = 0;
                        let b = uniform_buffer(device);
                        gpu.queue.write_buffer(&b, 0, bytemuck::bytes_of(&u));
                        face_groups.push(frame_bind_group(
                            device,
                            &frame_layout,
                            &b,
                            renderer.textures(),
                        ));
                        face_uniforms.push(b);
                    }
                    let regular = settings.glossy_samples > 0;
                    let patterns = if regular {
                        patterns_for(&reflector.lobes, settings.glossy_samples, xi0)
                    } else {
                        Vec::new()
                    };
                    let (packed, offsets) = pack_patterns(&patterns);
                    let pattern_buffer = buffer_with(
                        gpu,
                        "glint curved patterns",
                        wgpu::BufferUsages::STORAGE,
                        bytemuck::cast_slice(&packed),
                    );
                    let (source, env_view, env_size) = match &baked {
                        Some(t) => (EnvSource::Baked, &t.cube, t.size),
                        None => (EnvSource::Live, &maps[final_set][i].cube, face_size),
                    };
                    let base_params = CurvedParams::new(
                        &reflector,
                        regular.then_some((patterns.as_slice(), offsets.as_slice())),
                        reflector.centre,
                        env_size,
                    );
                    let params = buffer_with(
                        gpu,
                        "glint curved params",
                        wgpu::BufferUsages::UNIFORM,
                        bytemuck::bytes_of(&base_params),
                    );
                    let composite_group = curved_group(
                        device,
                        &curved_layout,
                        &params,
                        &pattern_buffer,
                        env_view,
                        &sampler,
                    );
                    ReflectorGpu {
                        vertex_count: verts.len() as u32,
                        vertices,
                        others_count: others.len() as u32,
                        others: others_buffer,
                        face_groups,
                        _face_uniforms: face_uniforms,
                        params,
                        base_params,
                        composite_group,
                        source,
                        _baked: baked,
                        patterns: pattern_buffer,
                        reflector,
                    }
                })
                .collect();
            (
                CurvedReflections {
                    settings,
                    reflectors: gpus,
                    maps,
                    final_set,
                    composite_pipeline,
                    composite_frame_group,
                    mirror_pipeline,
                    mirror_views: Mutex::new(Vec::new()),
                    frame_layout,
                    curved_layout,
                    sampler,
                    generation_seconds: 0.0,
                },
                generation,
            )
        })
    }

    /// Records every generation: per generation (written set `w`, read set `r`, never equal)
    /// and reflector i, each face of `maps[w][i]` gets the scene without reflector i (D) and
    /// every other curved reflector's mirror term from `maps[r]`; then its MIP levels.
    fn record_generations(
        &self,
        gpu: &Gpu,
        pipes: &GenerationPipelines,
        scene_vertices: &wgpu::Buffer,
        encoder: &mut wgpu::CommandEncoder,
    ) {
        let device = &gpu.device;
        // Interreflection parameters per ordered pair (i sees j): j's lobes seen from i's centre.
        let mut pair_params: Vec<Vec<Option<wgpu::Buffer>>> = Vec::new();
        for (i, ri) in self.reflectors.iter().enumerate() {
            let row = self
                .reflectors
                .iter()
                .enumerate()
                .map(|(j, rj)| {
                    (i != j).then(|| {
                        let mut p = rj.base_params;
                        p.eye = ri.reflector.centre.extend(0.0).to_array();
                        p.info[1] = 0; // mirror lookups
                        buffer_with(
                            gpu,
                            "glint interreflection params",
                            wgpu::BufferUsages::UNIFORM,
                            bytemuck::bytes_of(&p),
                        )
                    })
                })
                .collect();
            pair_params.push(row);
        }
        for step in generation_plan(self.settings.generations) {
            assert_ne!(step.write, step.read, "a cube map never reads its own set");
            for (i, ri) in self.reflectors.iter().enumerate() {
                let target = &self.maps[step.write][i];
                let groups: Vec<Option<wgpu::BindGroup>> = self
                    .reflectors
                    .iter()
                    .enumerate()
                    .map(|(j, rj)| {
                        pair_params[i][j].as_ref().map(|params| {
                            curved_group(
                                device,
                                &self.curved_layout,
                                params,
                                &rj.patterns,
                                &self.maps[step.read][j].cube,
                                &self.sampler,
                            )
                        })
                    })
                    .collect();
                for face in 0..6 {
                    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                        label: Some("glint cube face pass"),
                        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                            view: &target.faces[0][face],
                            depth_slice: None,
                            resolve_target: None,
                            ops: wgpu::Operations {
                                load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                                store: wgpu::StoreOp::Store,
                            },
                        })],
                        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                            view: &pipes.depth_view,
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
                    pass.set_pipeline(&pipes.env);
                    pass.set_bind_group(0, &ri.face_groups[face], &[]);
                    pass.set_vertex_buffer(0, scene_vertices.slice(..));
                    pass.set_index_buffer(ri.others.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..ri.others_count, 0, 0..1);
                    pass.set_pipeline(&pipes.interreflect);
                    for (j, rj) in self.reflectors.iter().enumerate() {
                        if let Some(group) = &groups[j] {
                            pass.set_bind_group(1, group, &[]);
                            pass.set_vertex_buffer(0, rj.vertices.slice(..));
                            pass.draw(0..rj.vertex_count, 0..1);
                        }
                    }
                }
                pipes.record_mips(device, target, encoder);
            }
        }
    }

    /// How many reflectors it draws.
    pub fn reflector_count(&self) -> usize {
        self.reflectors.len()
    }

    /// The settings it was built with.
    pub fn settings(&self) -> CurvedSettings {
        self.settings
    }

    /// Per reflector: its name and where its glossy term reads the environment.
    pub fn sources(&self) -> Vec<(String, EnvSource)> {
        self.reflectors
            .iter()
            .map(|r| (r.reflector.name.clone(), r.source))
            .collect()
    }

    /// Per reflector, the regular samples per lobe (empty with mirror lookups).
    pub fn pattern_samples(&self) -> Vec<Vec<u32>> {
        self.reflectors
            .iter()
            .map(|r| {
                let p = &r.base_params;
                if p.info[1] == 0 {
                    return Vec::new();
                }
                p.lobes[..p.info[0] as usize]
                    .iter()
                    .map(|l| l.samples[1])
                    .collect()
            })
            .collect()
    }

    /// Bytes of the live cube maps (both sets, every level).
    pub fn live_map_bytes(&self) -> u64 {
        let per_map: u64 = (0..CubeTexture::full_chain(self.settings.face_size))
            .map(|l| {
                let n = (self.settings.face_size >> l).max(1) as u64;
                6 * n * n * 8
            })
            .sum();
        2 * per_map * self.reflectors.len() as u64
    }

    /// Writes each reflector's parameters for `camera` (lands before the next submission).
    pub fn prepare(&self, gpu: &Gpu, camera: &Camera) {
        for r in &self.reflectors {
            let mut p = r.base_params;
            p.eye = camera.position.extend(0.0).to_array();
            gpu.queue.write_buffer(&r.params, 0, bytemuck::bytes_of(&p));
        }
    }

    /// Records, after the scene pass into `color`/`hdr`/`depth` (depth stored), the
    /// reflectors' specular term, depth-tested against the scene so only their visible pixels
    /// get it, added to kd·D.
    pub fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        color: &wgpu::TextureView,
        hdr: Option<&wgpu::TextureView>,
        depth: &wgpu::TextureView,
    ) {
        if self.reflectors.is_empty() {
            return;
        }
        let mut pass = crate::view::renderer::overlay_pass(
            encoder,
            "glint curved composite pass",
            color,
            hdr,
            depth,
            None,
        );
        pass.set_pipeline(&self.composite_pipeline);
        pass.set_bind_group(0, &self.composite_frame_group, &[]);
        for r in &self.reflectors {
            pass.set_bind_group(1, &r.composite_group, &[]);
            pass.set_vertex_buffer(0, r.vertices.slice(..));
            pass.draw(0..r.vertex_count, 0..1);
        }
    }

    /// The environment reflector `index` reads (the baked pyramid, else the final live map).
    fn env_view(&self, index: usize) -> &wgpu::TextureView {
        match &self.reflectors[index]._baked {
            Some(t) => &t.cube,
            None => &self.maps[self.final_set][index].cube,
        }
    }

    fn new_mirror_view(&self, gpu: &Gpu, renderer: &Renderer) -> MirrorView {
        let device = &gpu.device;
        let uniforms = uniform_buffer(device);
        let frame_group =
            frame_bind_group(device, &self.frame_layout, &uniforms, renderer.textures());
        let reflectors = self
            .reflectors
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let params = buffer_with(
                    gpu,
                    "glint curved params in a mirror",
                    wgpu::BufferUsages::UNIFORM,
                    bytemuck::bytes_of(&r.base_params),
                );
                let group = curved_group(
                    device,
                    &self.curved_layout,
                    &params,
                    &r.patterns,
                    self.env_view(i),
                    &self.sampler,
                );
                (params, group)
            })
            .collect();
        MirrorView {
            uniforms,
            frame_group,
            reflectors,
        }
    }

    /// Writes mirrored view `slot` (the planar passes number their mirror passes): `mirrored`
    /// is the camera mirrored about a planar reflector (its frame uniforms at `width` ×
    /// `height`, and the eye of every curved reflector's term), `clip` that reflector's plane
    /// (normal xyz, w = normal · point + clip distance): fragments behind it are discarded.
    /// The writes land before the next submission.
    #[allow(clippy::too_many_arguments)]
    pub fn prepare_mirror(
        &self,
        gpu: &Gpu,
        renderer: &Renderer,
        slot: usize,
        mirrored: &Camera,
        width: u32,
        height: u32,
        clip: Vec4,
    ) {
        if self.reflectors.is_empty() {
            return;
        }
        let Ok(mut views) = self.mirror_views.lock() else {
            return;
        };
        while views.len() <= slot {
            let view = self.new_mirror_view(gpu, renderer);
            views.push(view);
        }
        let view = &views[slot];
        let mut u = renderer.uniforms(mirrored, width, height);
        u.encode_srgb = 0; // M holds linear radiance
        gpu.queue
            .write_buffer(&view.uniforms, 0, bytemuck::bytes_of(&u));
        for (r, (params, _)) in self.reflectors.iter().zip(&view.reflectors) {
            let mut p = r.base_params;
            p.eye = mirrored.position.extend(0.0).to_array();
            p.clip = clip.to_array();
            gpu.queue.write_buffer(params, 0, bytemuck::bytes_of(&p));
        }
    }

    /// Records, inside a planar mirror's pass (its HDR map M bound as the only colour target,
    /// the mirrored scene's depth), the curved reflectors' specular term of mirrored view
    /// `slot` ([`CurvedReflections::prepare_mirror`]), added to their kd·D there.
    pub fn draw_mirror(&self, pass: &mut wgpu::RenderPass<'_>, slot: usize) {
        let Ok(views) = self.mirror_views.lock() else {
            return;
        };
        let Some(view) = views.get(slot) else {
            return;
        };
        pass.set_pipeline(&self.mirror_pipeline);
        pass.set_bind_group(0, &view.frame_group, &[]);
        for (r, (_, group)) in self.reflectors.iter().zip(&view.reflectors) {
            pass.set_bind_group(1, group, &[]);
            pass.set_vertex_buffer(0, r.vertices.slice(..));
            pass.draw(0..r.vertex_count, 0..1);
        }
    }

    /// The live cube map of reflector `index` (final generation) sampled at `dirs` (xyz,
    /// w = MIP level), in a compute pass: what the composite reads. For tests.
    pub fn probe_live_map(
        &self,
        gpu: &Gpu,
        index: usize,
        dirs: &[[f32; 4]],
    ) -> Result<Vec<Vec3>, RenderError> {
        let r = &self.reflectors[index];
        let inputs: Vec<[f32; 8]> = dirs
            .iter()
            .map(|d| [d[0], d[1], d[2], d[3], 0.0, 0.0, 0.0, 0.0])
            .collect();
        curved_probe(
            gpu,
            "cs_env_probe",
            &r.base_params,
            &r.patterns,
            &self.maps[self.final_set][index].cube,
            &inputs,
        )
    }
}

/// The pipelines and scratch targets that render the cube maps.
struct GenerationPipelines {
    env: wgpu::RenderPipeline,
    interreflect: wgpu::RenderPipeline,
    downsample: wgpu::RenderPipeline,
    mip_layout: wgpu::BindGroupLayout,
    depth_view: wgpu::TextureView,
    _depth: wgpu::Texture,
}

impl GenerationPipelines {
    fn new(
        device: &wgpu::Device,
        shader: &wgpu::ShaderModule,
        frame_layout: &wgpu::BindGroupLayout,
        curved_layout: &wgpu::BindGroupLayout,
        curved_buffers: &[Option<wgpu::VertexBufferLayout<'_>>],
        face_size: u32,
        gpu: &Gpu,
    ) -> GenerationPipelines {
        let hdr = |blend| {
            Some(wgpu::ColorTargetState {
                format: HDR_FORMAT,
                blend,
                write_mask: wgpu::ColorWrites::ALL,
            })
        };
        let scene_buffers = [Some(crate::view::renderer::scene_vertex_layout())];
        let env = pipeline(
            device,
            shader,
            "glint cube env",
            &[Some(frame_layout)],
            "vs_main",
            "fs_env",
            &scene_buffers,
            &[hdr(None)],
            Some(reverse_z_depth(true, wgpu::CompareFunction::Greater)),
        );
        let interreflect = pipeline(
            device,
            shader,
            "glint cube interreflection",
            &[Some(frame_layout), Some(curved_layout)],
            "vs_curved",
            "fs_curved_env",
            curved_buffers,
            &[hdr(Some(crate::view::renderer::ADDITIVE_KEEP_ALPHA))],
            Some(reverse_z_depth(false, wgpu::CompareFunction::GreaterEqual)),
        );
        let mip_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("glint mip layout"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 8,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            }],
        });
        let empty = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("glint empty layout"),
            entries: &[],
        });
        let downsample = pipeline(
            device,
            shader,
            "glint cube downsample",
            &[Some(&empty), Some(&mip_layout)],
            "vs_fullscreen",
            "fs_downsample",
            &[],
            &[hdr(None)],
            None,
        );
        let depth = crate::view::renderer::depth_texture(gpu, face_size, face_size);
        let depth_view = depth.create_view(&wgpu::TextureViewDescriptor::default());
        GenerationPipelines {
            env,
            interreflect,
            downsample,
            mip_layout,
            depth_view,
            _depth: depth,
        }
    }

    /// Levels 1 … of `target` from level 0, face by face (2×2 box).
    fn record_mips(
        &self,
        device: &wgpu::Device,
        target: &CubeTexture,
        encoder: &mut wgpu::CommandEncoder,
    ) {
        for level in 1..target.faces.len() {
            for face in 0..6 {
                let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("glint mip source"),
                    layout: &self.mip_layout,
                    entries: &[wgpu::BindGroupEntry {
                        binding: 8,
                        resource: wgpu::BindingResource::TextureView(
                            &target.faces[level - 1][face],
                        ),
                    }],
                });
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("glint cube mip pass"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &target.faces[level][face],
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(&self.downsample);
                pass.set_bind_group(1, &group, &[]);
                pass.draw(0..3, 0..1);
            }
        }
    }
}

/// Runs `entry` (`cs_glossy_probe` or `cs_env_probe`) of `shaders/curved.wgsl` over `inputs`
/// (normal or direction xyzw, ω_o xyzw) with `params`, `patterns` and environment `env`.
fn curved_probe(
    gpu: &Gpu,
    entry: &'static str,
    params: &CurvedParams,
    patterns: &wgpu::Buffer,
    env: &wgpu::TextureView,
    inputs: &[[f32; 8]],
) -> Result<Vec<Vec3>, RenderError> {
    if inputs.is_empty() {
        return Ok(Vec::new());
    }
    let device = &gpu.device;
    let (pipeline, probe_layout, group0, group1) =
        error_scoped(device, "creating a curved-shader probe", || {
            let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("glint curved probe"),
                source: wgpu::ShaderSource::Wgsl(shader_source().into()),
            });
            let curved_layout = curved_layout(device);
            let probe_layout = probe_io_layout(device, "glint curved probe layout");
            let empty = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("glint empty layout"),
                entries: &[],
            });
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("glint curved probe pipeline layout"),
                bind_group_layouts: &[Some(&empty), Some(&curved_layout), Some(&probe_layout)],
                immediate_size: 0,
            });
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("glint curved probe"),
                layout: Some(&layout),
                module: &shader,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions::default(),
                cache: None,
            });
            let sampler = trilinear_sampler(device);
            let params = buffer_with(
                gpu,
                "glint probe params",
                wgpu::BufferUsages::UNIFORM,
                bytemuck::bytes_of(params),
            );
            let group1 = curved_group(device, &curved_layout, &params, patterns, env, &sampler);
            let group0 = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("glint empty group"),
                layout: &empty,
                entries: &[],
            });
            (pipeline, probe_layout, group0, group1)
        })?;
    let bytes = run_probe(
        gpu,
        "running a curved-shader probe",
        &pipeline,
        &probe_layout,
        2,
        &[(0, &group0), (1, &group1)],
        bytemuck::cast_slice(inputs),
        inputs.len(),
        (inputs.len() * 16) as u64,
    )?;
    let values: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
    Ok(values.iter().map(|v| Vec3::new(v[0], v[1], v[2])).collect())
}

/// The shader's specular term of `reflector` (its lobes; regular sampling with `patterns`
/// when given, else the mirror lookup) against the environment `pyramid`, at each
/// (world normal, ω_o towards the eye) of `inputs`: what `fs_curved` computes, in a compute
/// pass. For tests against [`crate::materials::envmap::specular_regular`].
pub fn glossy_probe(
    gpu: &Gpu,
    reflector: &CurvedReflector,
    patterns: Option<&[crate::brdf::pattern::Pattern]>,
    pyramid: &MipPyramid,
    inputs: &[(Vec3, Vec3)],
) -> Result<Vec<Vec3>, RenderError> {
    let env = CubeTexture::from_pyramid(gpu, pyramid)?;
    let (packed, offsets) = pack_patterns(patterns.unwrap_or_default());
    let pattern_buffer = buffer_with(
        gpu,
        "glint probe patterns",
        wgpu::BufferUsages::STORAGE,
        bytemuck::cast_slice(&packed),
    );
    let params = CurvedParams::new(
        reflector,
        patterns.map(|p| (p, offsets.as_slice())),
        Vec3::ZERO,
        env.size,
    );
    let inputs: Vec<[f32; 8]> = inputs
        .iter()
        .map(|(n, wo)| [n.x, n.y, n.z, 0.0, wo.x, wo.y, wo.z, 0.0])
        .collect();
    curved_probe(
        gpu,
        "cs_glossy_probe",
        &params,
        &pattern_buffer,
        &env.cube,
        &inputs,
    )
}
