//! Compute probes: a batch of rays through the SRDM tables (`cs_srdm_probe`, held to the CPU
//! intersection [`crate::srdm::Srdm::intersect`] by the tests) or the billboards
//! (`cs_billboard_probe`, held to [`BillboardTables::trace`]).

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::super::gpu::{Gpu, GpuError, error_scoped};
use super::tables_gpu::{BillboardBuffers, SrdmBuffers};
use super::{
    BILLBOARD_PROBE_SHADER_SOURCE, BILLBOARD_SHADER_SOURCE, SRDM_PROBE_SHADER_SOURCE,
    SRDM_SHADER_SOURCE,
};
use crate::view::gpu::build::{compute_pipeline, shader};
use crate::view::gpu::probe::{probe_io_layout, run_probe};
use crate::view::impostors::billboard_tables::BillboardTables;
use crate::view::impostors::srdm_tables::SrdmTables;

/// A compute pipeline running `entry` of the WGSL `source` over bind groups `layouts`.
fn probe_pipeline(
    device: &wgpu::Device,
    label: &str,
    source: &str,
    layouts: &[Option<&wgpu::BindGroupLayout>],
    entry: &str,
) -> wgpu::ComputePipeline {
    compute_pipeline(
        device,
        label,
        &shader(device, label, source),
        layouts,
        entry,
    )
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

/// One ray of a [`BillboardProbe`] batch (`BbProbeRay`): the same layout as [`ProbeRay`],
/// w of `dir` holding the billboard group.
pub type BillboardRay = ProbeRay;

/// What `bb_trace` returned for one ray (`BbProbeHit`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct BillboardProbeHit {
    /// rgb: colour; w: t.
    pub colour: [f32; 4],
    /// kind, billboard, 0, 0 (kinds as [`super::billboard_tables::BillboardShade::kind`]).
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
