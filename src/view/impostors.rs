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
//! - With [`ImpostorKind::Billboard`], the same pass intersects reflected billboards instead
//!   (§3.1, `shaders/billboards.wgsl`, tables from [`super::billboard_tables`], made at load
//!   time): second-order reflections through reflective billboards, the §3.2 morph for
//!   billboards connected to the environment, and misses reading the reflector's baked MIP
//!   environment map (level 0, materials stage) where the bundle has one.
//! - [`BillboardProbe`]: a compute pass tracing a batch of rays through `bb_trace`, held to
//!   [`BillboardTables::trace`] by the tests.
//!
//! With depth maps a ray that misses every impostor adds nothing (no environment lookup).

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::billboard_tables::{self, BillboardTables};
use super::gpu::{Gpu, GpuError, error_scoped, probe_io_layout, run_probe};
use super::impostor_tables::{
    ImpostorParams, ImpostorReflector, SrdmTables, ViewSource, impostor_reflectors,
};
use super::load::ViewData;
use super::reflections::reflectors_with_reflectance;
use super::renderer::{
    HDR_FORMAT, Renderer, SHADER_SOURCE, frame_bind_group, frame_bind_group_layout, reverse_z_depth,
};
use crate::bake::srdm_stage;
use crate::camera::Camera;

/// WGSL of the SRDM intersection.
pub const SRDM_SHADER_SOURCE: &str = include_str!("../../shaders/srdm.wgsl");
/// WGSL of the ray-batch compute entry (appended to [`SRDM_SHADER_SOURCE`]).
pub const SRDM_PROBE_SHADER_SOURCE: &str = include_str!("../../shaders/srdm_probe.wgsl");
/// WGSL of the reflections pass (appended to the view and SRDM shaders).
pub const IMPOSTOR_SHADER_SOURCE: &str = include_str!("../../shaders/impostors.wgsl");
/// WGSL of the billboard tables and `bb_trace` (§3.1, §3.2).
pub const BILLBOARD_SHADER_SOURCE: &str = include_str!("../../shaders/billboards.wgsl");
/// WGSL of the billboard fragment entry (appended after [`BILLBOARD_SHADER_SOURCE`]).
pub const BILLBOARD_REFLECT_SHADER_SOURCE: &str =
    include_str!("../../shaders/billboard_reflect.wgsl");
/// WGSL of the billboard ray-batch compute entry.
pub const BILLBOARD_PROBE_SHADER_SOURCE: &str = include_str!("../../shaders/billboard_probe.wgsl");

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

/// A compute pipeline running `entry` of `source` over bind groups `layouts`.
fn probe_pipeline(
    device: &wgpu::Device,
    label: &str,
    source: &str,
    layouts: &[Option<&wgpu::BindGroupLayout>],
    entry: &str,
) -> wgpu::ComputePipeline {
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: layouts,
        immediate_size: 0,
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&layout),
        module: &shader,
        entry_point: Some(entry),
        compilation_options: wgpu::PipelineCompilationOptions::default(),
        cache: None,
    })
}

/// One ray of a compute probe batch (`ProbeRay` in `shaders/srdm_probe.wgsl`, `BbProbeRay`
/// in `shaders/billboard_probe.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct ProbeRay {
    /// xyz: origin; w: t_max.
    pub origin: [f32; 4],
    /// xyz: direction; w: the bits of `tag` (SRDM: the view index; billboards: the group).
    pub dir: [f32; 4],
}

impl ProbeRay {
    /// The ray `origin + t dir`, t ∈ [0, t_max], tagged with `tag`.
    pub fn new(origin: Vec3, dir: Vec3, t_max: f32, tag: u32) -> ProbeRay {
        ProbeRay {
            origin: origin.extend(t_max).to_array(),
            dir: dir.extend(f32::from_bits(tag)).to_array(),
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
            let rays_layout = probe_io_layout(device, "glint SRDM probe rays layout");
            let pipeline = probe_pipeline(
                device,
                "glint SRDM probe",
                &format!("{SRDM_SHADER_SOURCE}\n{SRDM_PROBE_SHADER_SOURCE}"),
                &[None, Some(&buffers.layout), Some(&rays_layout)],
                "cs_srdm_probe",
            );
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
        let bytes = run_probe(
            gpu,
            "intersecting rays with the SRDM",
            &self.pipeline,
            &self.rays_layout,
            2,
            &[(1, &self.buffers.group)],
            bytemuck::cast_slice(rays),
            rays.len(),
            (rays.len() * std::mem::size_of::<ProbeHit>()) as u64,
        )?;
        Ok(bytemuck::pod_collect_to_vec(&bytes))
    }
}

pub use crate::view::options::ImpostorKind;

/// Which reflectors the pass draws.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ReflectorSet {
    /// Every glossy reflector.
    #[default]
    All,
    /// Planar reflectors only (`--impostors on`).
    Planar,
    /// Curved reflectors only (`--curved impostor`).
    Curved,
}

/// Settings of the impostor reflections pass.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImpostorSettings {
    /// Figure 15's attenuation with distance: reflections fade as exp(−t / distance) with the
    /// reflected ray's length t (metres); `None` (the default, as the reference has no such
    /// term): off.
    pub attenuation_distance: Option<f32>,
    /// Depth maps or billboards.
    pub kind: ImpostorKind,
    /// Which reflectors.
    pub reflectors: ReflectorSet,
    /// Billboard resolution (0: [`billboard_tables::DEFAULT_RESOLUTION`]).
    pub billboard_resolution: u32,
}

/// The billboard tables on the GPU (group 3 of `billboards.wgsl`).
pub struct BillboardBuffers {
    layout: wgpu::BindGroupLayout,
    group: wgpu::BindGroup,
    billboards: usize,
    _buffers: Vec<wgpu::Buffer>,
}

impl BillboardBuffers {
    /// Uploads `tables`.
    pub fn new(gpu: &Gpu, tables: &BillboardTables) -> Result<BillboardBuffers, GpuError> {
        let device = &gpu.device;
        error_scoped(device, "uploading the billboard tables", || {
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("glint billboard tables layout"),
                entries: &(0..5).map(|b| storage_entry(b, true)).collect::<Vec<_>>(),
            });
            let buffers = vec![
                storage_buffer(
                    gpu,
                    "glint billboards",
                    bytemuck::cast_slice(&tables.billboards),
                ),
                storage_buffer(
                    gpu,
                    "glint billboard groups",
                    bytemuck::cast_slice(&tables.groups),
                ),
                storage_buffer(
                    gpu,
                    "glint billboard texels",
                    bytemuck::cast_slice(&tables.texels),
                ),
                storage_buffer(
                    gpu,
                    "glint billboard normals",
                    bytemuck::cast_slice(&tables.normals),
                ),
                storage_buffer(
                    gpu,
                    "glint billboard env",
                    bytemuck::cast_slice(&tables.env),
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
                label: Some("glint billboard tables"),
                layout: &layout,
                entries: &entries,
            });
            BillboardBuffers {
                layout,
                group,
                billboards: tables.billboards.len(),
                _buffers: buffers,
            }
        })
    }

    /// Number of billboards.
    pub fn billboards(&self) -> usize {
        self.billboards
    }
}

/// One ray of a [`BillboardProbe`] batch (`BbProbeRay`): the same layout as [`ProbeRay`],
/// w of `dir` holding the billboard group.
pub type BillboardRay = ProbeRay;

/// What `bb_trace` returned for one ray (`BbProbeHit`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct BillboardProbeHit {
    /// rgb: colour; w: t.
    pub colour: [f32; 4],
    /// kind, billboard, 0, 0 (kinds as [`billboard_tables::BillboardShade::kind`]).
    pub kind: [u32; 4],
}

/// The compute pass tracing a batch of rays through the billboards.
pub struct BillboardProbe {
    pipeline: wgpu::ComputePipeline,
    rays_layout: wgpu::BindGroupLayout,
    buffers: BillboardBuffers,
}

impl BillboardProbe {
    /// The pass over `tables`.
    pub fn new(gpu: &Gpu, tables: &BillboardTables) -> Result<BillboardProbe, GpuError> {
        let buffers = BillboardBuffers::new(gpu, tables)?;
        let device = &gpu.device;
        let (pipeline, rays_layout) = error_scoped(device, "creating the billboard probe", || {
            let rays_layout = probe_io_layout(device, "glint billboard probe rays layout");
            let pipeline = probe_pipeline(
                device,
                "glint billboard probe",
                &format!("{BILLBOARD_SHADER_SOURCE}\n{BILLBOARD_PROBE_SHADER_SOURCE}"),
                &[None, None, Some(&rays_layout), Some(&buffers.layout)],
                "cs_billboard_probe",
            );
            (pipeline, rays_layout)
        })?;
        Ok(BillboardProbe {
            pipeline,
            rays_layout,
            buffers,
        })
    }

    /// Traces every ray; one [`BillboardProbeHit`] per ray, in order.
    pub fn trace(
        &self,
        gpu: &Gpu,
        rays: &[BillboardRay],
    ) -> Result<Vec<BillboardProbeHit>, GpuError> {
        if rays.is_empty() {
            return Ok(Vec::new());
        }
        let bytes = run_probe(
            gpu,
            "tracing rays through the billboards",
            &self.pipeline,
            &self.rays_layout,
            2,
            &[(3, &self.buffers.group)],
            bytemuck::cast_slice(rays),
            rays.len(),
            (rays.len() * std::mem::size_of::<BillboardProbeHit>()) as u64,
        )?;
        Ok(bytemuck::pod_collect_to_vec(&bytes))
    }
}

/// The impostor pass for `set` of reflectors with `kind` (`--impostors on` draws the planar
/// ones, `--curved impostor` the curved ones).
pub fn impostor_pass(
    gpu: &Gpu,
    renderer: &Renderer,
    data: &ViewData,
    kind: ImpostorKind,
    set: ReflectorSet,
) -> Result<ImpostorReflections, super::renderer::RenderError> {
    ImpostorReflections::new(
        gpu,
        renderer,
        data,
        ImpostorSettings {
            kind,
            reflectors: set,
            ..ImpostorSettings::default()
        },
    )
}

/// The billboards of `data`'s impostor objects for `reflectors` (§3), with each reflector's
/// baked MIP environment map (level 0) where the materials stage has one.
pub fn build_billboards(
    data: &ViewData,
    reflectors: &[ImpostorReflector],
    resolution: u32,
) -> Result<BillboardTables, String> {
    // D where the bundle's radiosity stage was baked from this scene, as the SRDM stage's
    // captures (the one place that choice is made); the albedo otherwise.
    let colour = srdm_stage::colour_source(data.bundle.dir(), &data.scene)
        .map_err(|e| format!("billboard colour: {e}"))?;
    let mut env = Vec::new();
    for r in reflectors {
        let map = super::curved::gpu::load_baked_pyramid(data, &r.name)?;
        let tris: Vec<_> = r
            .triangles
            .iter()
            .map(|&t| data.scene.triangles[t as usize])
            .collect();
        env.push(
            map.and_then(|p| p.levels.into_iter().next())
                .map(|m| (m, billboard_tables::centroid(&tris))),
        );
    }
    let w = if resolution == 0 {
        billboard_tables::DEFAULT_RESOLUTION
    } else {
        resolution
    };
    Ok(billboard_tables::build(
        &data.scene,
        reflectors,
        w,
        &colour,
        &env,
    ))
}

struct ReflectorGpu {
    reflector: ImpostorReflector,
    params: wgpu::Buffer,
    group: wgpu::BindGroup,
    /// Three (position, normal) vertices per triangle.
    vertices: wgpu::Buffer,
    vertex_count: u32,
}

/// The impostor reflections pass of one [`Renderer`] (new / prepare / draw, like
/// [`super::reflections::GeometryReflections`]).
pub struct ImpostorReflections {
    pipeline: wgpu::RenderPipeline,
    frame_group: wgpu::BindGroup,
    buffers: SrdmBuffers,
    billboards: Option<BillboardBuffers>,
    reflectors: Vec<ReflectorGpu>,
    settings: ImpostorSettings,
}

impl ImpostorReflections {
    /// The pass for `renderer` drawing `data` over the glossy reflectors `settings.reflectors`
    /// selects (R from the materials stage where baked). Depth maps: the bundle's `srdm`
    /// stage; errors when it is missing but the scene declares impostors (a scene without
    /// impostors gets a pass that draws nothing). Billboards: made here from the scene and D
    /// (§3), with each reflector's baked environment map for misses.
    pub fn new(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        settings: ImpostorSettings,
    ) -> Result<ImpostorReflections, super::renderer::RenderError> {
        use super::renderer::RenderError;
        let reflectors: Vec<ImpostorReflector> =
            impostor_reflectors(&data.scene, &reflectors_with_reflectance(data))
                .into_iter()
                .filter(|r| match settings.reflectors {
                    ReflectorSet::All => true,
                    ReflectorSet::Planar => r.normal.is_some(),
                    ReflectorSet::Curved => r.normal.is_none(),
                })
                .collect();
        if settings.kind == ImpostorKind::Billboard {
            let bb = build_billboards(data, &reflectors, settings.billboard_resolution)
                .map_err(RenderError::Reflections)?;
            return Ok(Self::with_billboards(
                gpu, renderer, data, &bb, reflectors, settings,
            )?);
        }
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
        Ok(Self::with(
            gpu, renderer, data, &tables, reflectors, settings,
        )?)
    }

    /// The billboard pass over given tables (group g of `tables` for `reflectors[g]`).
    pub fn with_billboards(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        tables: &BillboardTables,
        reflectors: Vec<ImpostorReflector>,
        settings: ImpostorSettings,
    ) -> Result<ImpostorReflections, GpuError> {
        let bb = BillboardBuffers::new(gpu, tables)?;
        let settings = ImpostorSettings {
            kind: ImpostorKind::Billboard,
            ..settings
        };
        Self::build(
            gpu,
            renderer,
            data,
            SrdmBuffers::new(gpu, &SrdmTables::default())?,
            Some(bb),
            reflectors,
            settings,
        )
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
        let settings = ImpostorSettings {
            kind: ImpostorKind::Srdm,
            ..settings
        };
        Self::build(gpu, renderer, data, buffers, None, reflectors, settings)
    }

    fn build(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        buffers: SrdmBuffers,
        billboards: Option<BillboardBuffers>,
        reflectors: Vec<ImpostorReflector>,
        settings: ImpostorSettings,
    ) -> Result<ImpostorReflections, GpuError> {
        let device = &gpu.device;
        let formats = renderer.formats();
        error_scoped(device, "creating the impostor reflections pass", || {
            let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("glint impostor reflections shader"),
                source: wgpu::ShaderSource::Wgsl(
                    if billboards.is_some() {
                        format!(
                            "{SHADER_SOURCE}\n{SRDM_SHADER_SOURCE}\n{IMPOSTOR_SHADER_SOURCE}\n\
                             {BILLBOARD_SHADER_SOURCE}\n{BILLBOARD_REFLECT_SHADER_SOURCE}"
                        )
                    } else {
                        format!("{SHADER_SOURCE}\n{SRDM_SHADER_SOURCE}\n{IMPOSTOR_SHADER_SOURCE}")
                    }
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
                bind_group_layouts: &match &billboards {
                    Some(b) => [
                        Some(&frame_layout),
                        None,
                        Some(&params_layout),
                        Some(&b.layout),
                    ],
                    None => [
                        Some(&frame_layout),
                        Some(&buffers.layout),
                        Some(&params_layout),
                        None,
                    ],
                },
                immediate_size: 0,
            });
            let additive = crate::view::renderer::ADDITIVE_KEEP_ALPHA;
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
                    // Position and vertex normal: curved reflectors reflect about the
                    // interpolated normal, as the cube-map composite does.
                    buffers: &[Some(crate::view::curved::gpu::CurvedVertex::layout())],
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
                    entry_point: Some(if billboards.is_some() {
                        "fs_billboard"
                    } else {
                        "fs_impostor"
                    }),
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
            let frame_group = frame_bind_group(
                device,
                &frame_layout,
                renderer.frame_uniform_buffer(),
                renderer.textures(),
            );
            let reflectors = reflectors
                .into_iter()
                .map(|reflector| {
                    let vertices = crate::view::curved::gpu::reflector_vertices(
                        &data.scene,
                        &reflector.triangles,
                    );
                    let vertex_buffer = device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("glint impostor reflector vertices"),
                        size: (std::mem::size_of_val(vertices.as_slice()) as u64).max(4),
                        usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    });
                    gpu.queue
                        .write_buffer(&vertex_buffer, 0, bytemuck::cast_slice(&vertices));
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
                        vertex_count: vertices.len() as u32,
                        reflector,
                        params,
                        group,
                        vertices: vertex_buffer,
                    }
                })
                .collect();
            ImpostorReflections {
                pipeline,
                frame_group,
                buffers,
                billboards,
                reflectors,
                settings,
            }
        })
    }

    /// Number of billboards drawn (0 with depth maps).
    pub fn billboard_count(&self) -> usize {
        self.billboards.as_ref().map_or(0, |b| b.billboards())
    }

    /// Depth maps or billboards.
    pub fn kind(&self) -> ImpostorKind {
        self.settings.kind
    }

    /// How many reflectors it draws.
    pub fn reflector_count(&self) -> usize {
        self.reflectors.len()
    }

    /// Writes each reflector's parameters for `camera` (lands before the next submission).
    pub fn prepare(&self, gpu: &Gpu, camera: &Camera) {
        for (g, r) in self.reflectors.iter().enumerate() {
            let mut p = ImpostorParams::new(
                &r.reflector,
                camera.position,
                self.buffers.objects(),
                self.settings.attenuation_distance,
            );
            // Billboards: the reflector's group (groups are in reflector order).
            p.settings[3] = g as f32;
            gpu.queue.write_buffer(&r.params, 0, bytemuck::bytes_of(&p));
        }
    }

    /// Records, after the scene pass into `color`/`hdr`/`depth` (depth stored), one pass that
    /// draws every reflector's visible pixels with their impostor reflections added. The frame
    /// uniforms are those of the renderer the pass was built for.
    pub fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        color: &wgpu::TextureView,
        hdr: Option<&wgpu::TextureView>,
        depth: &wgpu::TextureView,
    ) {
        let nothing = match &self.billboards {
            // Billboard misses still read the environment maps.
            Some(_) => false,
            None => self.buffers.objects() == 0,
        };
        if nothing || self.reflectors.iter().all(|r| r.vertex_count == 0) {
            return;
        }
        let mut pass = crate::view::renderer::overlay_pass(
            encoder,
            "glint impostor reflections pass",
            color,
            hdr,
            depth,
            None,
        );
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.frame_group, &[]);
        match &self.billboards {
            Some(b) => pass.set_bind_group(3, &b.group, &[]),
            None => pass.set_bind_group(1, &self.buffers.group, &[]),
        }
        for r in &self.reflectors {
            if r.vertex_count == 0 {
                continue;
            }
            pass.set_bind_group(2, &r.group, &[]);
            pass.set_vertex_buffer(0, r.vertices.slice(..));
            pass.draw(0..r.vertex_count, 0..1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_parse_and_print() {
        assert_eq!("srdm".parse(), Ok(ImpostorKind::Srdm));
        assert_eq!("billboard".parse(), Ok(ImpostorKind::Billboard));
        assert!("depth".parse::<ImpostorKind>().is_err());
        assert_eq!(ImpostorKind::Billboard.to_string(), "billboard");
        assert_eq!(ImpostorSettings::default().reflectors, ReflectorSet::All);
    }
}
