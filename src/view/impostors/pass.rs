//! The impostor reflections pass (`shaders/impostors.wgsl`, `shaders/billboard_reflect.wgsl`):
//! per visible pixel of every selected glossy reflector, the reflected ray against the
//! impostors, the nearest hit's colour × ks·R(θ) × the attenuation of Figure 15.

use super::tables_gpu::{BillboardBuffers, SrdmBuffers};
use super::{
    BILLBOARD_REFLECT_SHADER_SOURCE, BILLBOARD_SHADER_SOURCE, IMPOSTOR_SHADER_SOURCE, ImpostorKind,
    ImpostorSettings, ReflectorSet, SRDM_SHADER_SOURCE, build_billboards, load_tables,
};
use crate::camera::Camera;
use crate::view::gpu::build::{bind_group_layout, buffer, buffer_init, render_pipeline, shader};
use crate::view::gpu::{Gpu, GpuError, error_scoped};
use crate::view::impostors::billboard_tables::BillboardTables;
use crate::view::impostors::srdm_tables::{
    ImpostorParams, ImpostorReflector, SrdmTables, impostor_reflectors,
};
use crate::view::load::ViewData;
use crate::view::passes::composite::Composite;
use crate::view::passes::renderer::{Renderer, SHADER_SOURCE, frame_bind_group_layout};
use crate::view::reflections::reflectors_with_reflectance;

struct ReflectorGpu {
    reflector: ImpostorReflector,
    params: wgpu::Buffer,
    group: wgpu::BindGroup,
    /// Three (position, normal) vertices per triangle.
    vertices: wgpu::Buffer,
    vertex_count: u32,
}

/// The impostor reflections pass of one [`Renderer`] (new / prepare / draw, like
/// [`crate::view::reflections::GeometryReflections`]).
pub struct ImpostorReflections {
    composite: Composite,
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
    ) -> Result<ImpostorReflections, crate::view::gpu::RenderError> {
        use crate::view::gpu::RenderError;
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
        error_scoped(device, "creating the impostor reflections pass", || {
            let source = if billboards.is_some() {
                format!(
                    "{SHADER_SOURCE}\n{SRDM_SHADER_SOURCE}\n{IMPOSTOR_SHADER_SOURCE}\n\
                     {BILLBOARD_SHADER_SOURCE}\n{BILLBOARD_REFLECT_SHADER_SOURCE}"
                )
            } else {
                format!("{SHADER_SOURCE}\n{SRDM_SHADER_SOURCE}\n{IMPOSTOR_SHADER_SOURCE}")
            };
            let shader = shader(device, "glint impostor reflections shader", &source);
            let frame_layout = frame_bind_group_layout(device);
            let params_layout = bind_group_layout()
                .uniform::<ImpostorParams>(0, wgpu::ShaderStages::FRAGMENT)
                .build(device, "glint impostor params layout");
            // Depth maps read the SRDM tables (group 1), billboards theirs (group 3).
            let (tables, fragment) = match &billboards {
                Some(b) => ([None, Some(&b.layout)], "fs_billboard"),
                None => ([Some(&buffers.layout), None], "fs_impostor"),
            };
            let composite = Composite::new(
                device,
                renderer,
                &frame_layout,
                render_pipeline(
                    "glint impostor reflections pipeline",
                    &shader,
                    "vs_impostor",
                    fragment,
                )
                .layout_slots(&[
                    Some(&frame_layout),
                    tables[0],
                    Some(&params_layout),
                    tables[1],
                ])
                // Position and vertex normal: curved reflectors reflect about the
                // interpolated normal, as the cube-map composite does.
                .vertex(crate::view::curved::gpu::CurvedVertex::layout()),
            );
            let reflectors = reflectors
                .into_iter()
                .map(|reflector| {
                    let vertices = crate::view::curved::gpu::reflector_vertices(
                        &data.scene,
                        &reflector.triangles,
                    );
                    let vertex_buffer = buffer_init(
                        gpu,
                        "glint impostor reflector vertices",
                        wgpu::BufferUsages::VERTEX,
                        bytemuck::cast_slice(&vertices),
                        4,
                    );
                    let params = buffer(
                        device,
                        "glint impostor reflector params",
                        std::mem::size_of::<ImpostorParams>() as u64,
                        wgpu::BufferUsages::UNIFORM,
                    );
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
                composite,
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

    /// Records, after the scene pass into `color`/`depth` (depth stored), one pass that
    /// draws every reflector's visible pixels with their impostor reflections added. The frame
    /// uniforms are those of the renderer the pass was built for.
    pub fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        color: &wgpu::TextureView,
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
        let mut pass =
            self.composite
                .begin(encoder, "glint impostor reflections pass", color, depth);
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
