//! Reflections of depth-map impostors (Popescu et al. 2006 §3.1, §4.3) in the viewer.
//!
//! - [`SrdmBuffers`]: a bundle's SRDM tables ([`SrdmTables`]) in GPU storage buffers, bind
//!   group 1 of `shaders/srdm.wgsl`.
//! - [`SrdmProbe`]: a compute pass intersecting a batch of rays with them (`cs_srdm_probe`),
//!   what the tests hold to the CPU intersection ([`crate::srdm::Srdm::intersect`]).
//! - [`ImpostorReflections`]: the per-pixel pass (`shaders/impostors.wgsl`): for every visible
//!   pixel of every glossy reflector, the reflected ray against each impostor object's SRDM
//!   rows, the nearest hit's captured colour × ks·R(θ) (the Fresnel modulation) × the
//!   distance attenuation of Figure 15, added to the frame like the planar composite.
//!
//! What the bake holds decides what is drawn: the `srdm` stage bakes depth-map impostors
//! only, so there are no billboards to intersect (§3), no billboard-to-environment morph
//! (§3.2) and no reflective billboards for second-order reflections; no environment map is
//! baked either, so a ray that misses every impostor adds nothing.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::gpu::{Gpu, GpuError, error_scoped, read_buffer};
use super::impostor_tables::{
    ImpostorParams, ImpostorReflector, SrdmTables, ViewSource, impostor_reflectors,
};
use super::load::ViewData;
use super::reflections::reflectors_with_reflectance;
use super::renderer::{
    HDR_FORMAT, Renderer, SHADER_SOURCE, SceneMesh, Vertex, frame_bind_group,
    frame_bind_group_layout, reverse_z_depth,
};
use crate::bake::srdm_stage;
use crate::camera::Camera;

/// WGSL of the SRDM intersection.
pub const SRDM_SHADER_SOURCE: &str = include_str!("../../shaders/srdm.wgsl");
/// WGSL of the ray-batch compute entry (appended to [`SRDM_SHADER_SOURCE`]).
pub const SRDM_PROBE_SHADER_SOURCE: &str = include_str!("../../shaders/srdm_probe.wgsl");
/// WGSL of the reflections pass (appended to the view and SRDM shaders).
pub const IMPOSTOR_SHADER_SOURCE: &str = include_str!("../../shaders/impostors.wgsl");

/// Reads the bundle's `srdm` stage and packs every view, objects in scene order. `Ok(None)`
/// when the bundle has no such stage.
pub fn load_tables(data: &ViewData) -> Result<Option<SrdmTables>, String> {
    let loaded = srdm_stage::load(&data.bundle)
        .map_err(|e| format!("bundle {}: {e}", data.bundle.dir().display()))?;
    let Some((_, views)) = loaded else {
        return Ok(None);
    };
    let mut names: Vec<&str> = Vec::new();
    let sources: Vec<ViewSource<'_>> = views
        .iter()
        .map(|v| {
            let k = match names.iter().position(|n| *n == v.entry.impostor) {
                Some(k) => k,
                None => {
                    names.push(&v.entry.impostor);
                    names.len() - 1
                }
            };
            ViewSource {
                impostor: k as u32,
                srdm: &v.srdm,
                colour: &v.capture.colour,
            }
        })
        .collect();
    Ok(Some(SrdmTables::pack(&sources)))
}

/// The SRDM tables on the GPU and their bind group layout (group 1 of `srdm.wgsl`).
pub struct SrdmBuffers {
    layout: wgpu::BindGroupLayout,
    group: wgpu::BindGroup,
    objects: usize,
    _buffers: Vec<wgpu::Buffer>,
}

fn storage_buffer(gpu: &Gpu, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        // A binding must not be empty; pad to one 16-byte element.
        size: (bytes.len() as u64).max(16).next_multiple_of(4),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    gpu.queue.write_buffer(&buffer, 0, bytes);
    buffer
}

fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

impl SrdmBuffers {
    /// Uploads `tables`.
    pub fn new(gpu: &Gpu, tables: &SrdmTables) -> Result<SrdmBuffers, GpuError> {
        let device = &gpu.device;
        error_scoped(device, "uploading the SRDM tables", || {
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("glint SRDM tables layout"),
                entries: &(0..6).map(|b| storage_entry(b, true)).collect::<Vec<_>>(),
            });
            let buffers = vec![
                storage_buffer(gpu, "glint SRDM views", bytemuck::cast_slice(&tables.views)),
                storage_buffer(
                    gpu,
                    "glint SRDM points",
                    bytemuck::cast_slice(&tables.points),
                ),
                storage_buffer(
                    gpu,
                    "glint SRDM counts",
                    bytemuck::cast_slice(&tables.counts),
                ),
                storage_buffer(
                    gpu,
                    "glint SRDM domains",
                    bytemuck::cast_slice(&tables.domains),
                ),
                storage_buffer(
                    gpu,
                    "glint SRDM colours",
                    bytemuck::cast_slice(&tables.colours),
                ),
                storage_buffer(
                    gpu,
                    "glint SRDM impostors",
                    bytemuck::cast_slice(&tables.impostors),
                ),
            ];
            let entries: Vec<wgpu::BindGroupEntry> = buffers
                .iter()
                .enumerate()
                .map(|(i, b)| wgpu::BindGroupEntry {
                    binding: i as u32,
                    resource: b.as_entire_binding(),
                })
                .collect();
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("glint SRDM tables"),
                layout: &layout,
                entries: &entries,
            });
            SrdmBuffers {
                layout,
                group,
                objects: tables.impostors.len(),
                _buffers: buffers,
            }
        })
    }

    /// Number of impostor objects.
    pub fn objects(&self) -> usize {
        self.objects
    }
}

/// One ray of a [`SrdmProbe`] batch (`ProbeRay` in `shaders/srdm_probe.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct ProbeRay {
    /// xyz: origin; w: t_max.
    pub origin: [f32; 4],
    /// xyz: direction; w: the view index's bits.
    pub dir: [f32; 4],
}

impl ProbeRay {
    /// The ray `origin + t dir`, t ∈ [0, t_max], against view `view`.
    pub fn new(origin: Vec3, dir: Vec3, t_max: f32, view: u32) -> ProbeRay {
        ProbeRay {
            origin: origin.extend(t_max).to_array(),
            dir: dir.extend(f32::from_bits(view)).to_array(),
        }
    }
}

/// What the shader found for one ray (`ProbeHit`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct ProbeHit {
    /// t, pixel x, pixel y, depth.
    pub t_pixel_depth: [f32; 4],
    /// 1 on a hit, domain, row, 0.
    pub found: [u32; 4],
    /// Captured colour at the hit (rgb).
    pub colour: [f32; 4],
}

/// The compute pass that intersects a batch of rays with the SRDM tables.
pub struct SrdmProbe {
    pipeline: wgpu::ComputePipeline,
    rays_layout: wgpu::BindGroupLayout,
    buffers: SrdmBuffers,
}

impl SrdmProbe {
    /// The pass over `tables`.
    pub fn new(gpu: &Gpu, tables: &SrdmTables) -> Result<SrdmProbe, GpuError> {
        let buffers = SrdmBuffers::new(gpu, tables)?;
        let device = &gpu.device;
        let (pipeline, rays_layout) = error_scoped(device, "creating the SRDM probe", || {
            let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("glint SRDM probe shader"),
                source: wgpu::ShaderSource::Wgsl(
                    format!("{SRDM_SHADER_SOURCE}\n{SRDM_PROBE_SHADER_SOURCE}").into(),
                ),
            });
            let rays_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("glint SRDM probe rays layout"),
                entries: &[storage_entry(0, true), storage_entry(1, false)],
            });
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("glint SRDM probe layout"),
                bind_group_layouts: &[None, Some(&buffers.layout), Some(&rays_layout)],
                immediate_size: 0,
            });
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("glint SRDM probe pipeline"),
                layout: Some(&layout),
                module: &shader,
                entry_point: Some("cs_srdm_probe"),
                compilation_options: wgpu::PipelineCompilationOptions::default(),
                cache: None,
            });
            (pipeline, rays_layout)
        })?;
        Ok(SrdmProbe {
            pipeline,
            rays_layout,
            buffers,
        })
    }

    /// Intersects every ray; one [`ProbeHit`] per ray, in order.
    pub fn intersect(&self, gpu: &Gpu, rays: &[ProbeRay]) -> Result<Vec<ProbeHit>, GpuError> {
        if rays.is_empty() {
            return Ok(Vec::new());
        }
        let device = &gpu.device;
        let out = error_scoped(device, "intersecting rays with the SRDM", || {
            let input = storage_buffer(gpu, "glint SRDM probe rays", bytemuck::cast_slice(rays));
            let out = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("glint SRDM probe hits"),
                size: (rays.len() * std::mem::size_of::<ProbeHit>()) as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("glint SRDM probe rays"),
                layout: &self.rays_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: input.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: out.as_entire_binding(),
                    },
                ],
            });
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("glint SRDM probe encoder"),
            });
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("glint SRDM probe pass"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(1, &self.buffers.group, &[]);
                pass.set_bind_group(2, &group, &[]);
                pass.dispatch_workgroups((rays.len() as u32).div_ceil(64), 1, 1);
            }
            gpu.queue.submit([encoder.finish()]);
            out
        })?;
        let bytes = read_buffer(gpu, &out)?;
        Ok(bytemuck::pod_collect_to_vec(&bytes))
    }
}

/// Settings of the impostor reflections pass.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImpostorSettings {
    /// Figure 15's attenuation with distance: reflections fade as exp(−t / distance) with the
    /// reflected ray's length t (metres); `None` (the default, as the reference has no such
    /// term): off.
    pub attenuation_distance: Option<f32>,
}

struct ReflectorGpu {
    reflector: ImpostorReflector,
    params: wgpu::Buffer,
    group: wgpu::BindGroup,
    indices: wgpu::Buffer,
    index_count: u32,
}

/// The impostor reflections pass of one [`Renderer`] (new / prepare / draw, like
/// [`super::reflections::GeometryReflections`]).
pub struct ImpostorReflections {
    pipeline: wgpu::RenderPipeline,
    frame_group: wgpu::BindGroup,
    buffers: SrdmBuffers,
    reflectors: Vec<ReflectorGpu>,
    settings: ImpostorSettings,
}

impl ImpostorReflections {
    /// The pass for `renderer` drawing `data`, with the bundle's `srdm` stage and every glossy
    /// reflector of the scene (R from the materials stage where baked). Errors when the
    /// bundle has no `srdm` stage but the scene declares impostors; a scene without impostors
    /// gets a pass that draws nothing.
    pub fn new(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        settings: ImpostorSettings,
    ) -> Result<ImpostorReflections, super::renderer::RenderError> {
        use super::renderer::RenderError;
        let tables = match load_tables(data).map_err(RenderError::Reflections)? {
            Some(t) => t,
            None if data.scene.impostors.is_empty() => SrdmTables::default(),
            None => {
                return Err(RenderError::Reflections(format!(
                    "bundle {}: impostor reflections need the `srdm` stage; bake it with glint-bake",
                    data.bundle.dir().display()
                )));
            }
        };
        let reflectors = impostor_reflectors(&data.scene, &reflectors_with_reflectance(data));
        Ok(Self::with(
            gpu, renderer, data, &tables, reflectors, settings,
        )?)
    }

    /// The pass over given tables and reflectors (benchmarks re-build the SRDM with other m
    /// and split reflectors).
    pub fn with(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        tables: &SrdmTables,
        reflectors: Vec<ImpostorReflector>,
        settings: ImpostorSettings,
    ) -> Result<ImpostorReflections, GpuError> {
        let buffers = SrdmBuffers::new(gpu, tables)?;
        let device = &gpu.device;
        let mesh = SceneMesh::new(&data.scene, &data.map.atlas);
        let formats = renderer.formats();
        error_scoped(device, "creating the impostor reflections pass", || {
            let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("glint impostor reflections shader"),
                source: wgpu::ShaderSource::Wgsl(
                    format!("{SHADER_SOURCE}\n{SRDM_SHADER_SOURCE}\n{IMPOSTOR_SHADER_SOURCE}")
                        .into(),
                ),
            });
            let frame_layout = frame_bind_group_layout(device);
            let params_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("glint impostor params layout"),
                entries: &[wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: wgpu::BufferSize::new(
                            std::mem::size_of::<ImpostorParams>() as u64,
                        ),
                    },
                    count: None,
                }],
            });
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("glint impostor reflections layout"),
                bind_group_layouts: &[
                    Some(&frame_layout),
                    Some(&buffers.layout),
                    Some(&params_layout),
                ],
                immediate_size: 0,
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
            let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("glint impostor reflections pipeline"),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &shader,
                    entry_point: Some("vs_impostor"),
                    compilation_options: wgpu::PipelineCompilationOptions::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: std::mem::size_of::<Vertex>() as u64,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x2, 2 => Uint32],
                    })],
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: Some(reverse_z_depth(false, wgpu::CompareFunction::GreaterEqual)),
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &shader,
                    entry_point: Some("fs_impostor"),
                    compilation_options: wgpu::PipelineCompilationOptions::default(),
                    targets: &[
                        target(formats.color),
                        if formats.hdr { target(HDR_FORMAT) } else { None },
                    ],
                }),
                multiview_mask: None,
                cache: None,
            });
            let frame_group = frame_bind_group(
                device,
                &frame_layout,
                renderer.frame_uniform_buffer(),
                renderer.textures(),
            );
            let reflectors = reflectors
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
                        label: Some("glint impostor reflector indices"),
                        size: (indices.len() as u64 * 4).max(4),
                        usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    });
                    gpu.queue
                        .write_buffer(&index_buffer, 0, bytemuck::cast_slice(&indices));
                    let params = device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("glint impostor reflector params"),
                        size: std::mem::size_of::<ImpostorParams>() as u64,
                        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    });
                    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("glint impostor reflector params"),
                        layout: &params_layout,
                        entries: &[wgpu::BindGroupEntry {
                            binding: 0,
                            resource: params.as_entire_binding(),
                        }],
                    });
                    ReflectorGpu {
                        index_count: indices.len() as u32,
                        reflector,
                        params,
                        group,
                        indices: index_buffer,
                    }
                })
                .collect();
            ImpostorReflections {
                pipeline,
                frame_group,
                buffers,
                reflectors,
                settings,
            }
        })
    }

    /// How many reflectors it draws.
    pub fn reflector_count(&self) -> usize {
        self.reflectors.len()
    }

    /// Writes each reflector's parameters for `camera` (lands before the next submission).
    pub fn prepare(&self, gpu: &Gpu, camera: &Camera) {
        for r in &self.reflectors {
            let p = ImpostorParams::new(
                &r.reflector,
                camera.position,
                self.buffers.objects(),
                self.settings.attenuation_distance,
            );
            gpu.queue.write_buffer(&r.params, 0, bytemuck::bytes_of(&p));
        }
    }

    /// Records, after the scene pass into `color`/`hdr`/`depth` (depth stored), one pass that
    /// draws every reflector's visible pixels with their impostor reflections added.
    /// `renderer` must be the one the pass was built for (its frame uniforms are used).
    pub fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        renderer: &Renderer,
        color: &wgpu::TextureView,
        hdr: Option<&wgpu::TextureView>,
        depth: &wgpu::TextureView,
    ) {
        if self.buffers.objects() == 0 || self.reflectors.iter().all(|r| r.index_count == 0) {
            return;
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
            label: Some("glint impostor reflections pass"),
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
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.frame_group, &[]);
        pass.set_bind_group(1, &self.buffers.group, &[]);
        pass.set_vertex_buffer(0, renderer.vertex_buffer().slice(..));
        for r in &self.reflectors {
            if r.index_count == 0 {
                continue;
            }
            pass.set_bind_group(2, &r.group, &[]);
            pass.set_index_buffer(r.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..r.index_count, 0, 0..1);
        }
    }
}
