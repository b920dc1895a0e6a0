//! The impostor tables in GPU storage buffers: the SRDM tables (bind group 1 of
//! `shaders/srdm.wgsl`) and the billboard tables (group 3 of `shaders/billboards.wgsl`).

use super::super::gpu::{Gpu, GpuError, error_scoped};
use crate::view::gpu::build::{bind_group_layout, buffer_init};
use crate::view::impostors::billboard_tables::BillboardTables;
use crate::view::impostors::srdm_tables::SrdmTables;

/// The SRDM tables on the GPU and their bind group layout (group 1 of `srdm.wgsl`).
pub struct SrdmBuffers {
    pub(super) layout: wgpu::BindGroupLayout,
    pub(super) group: wgpu::BindGroup,
    objects: usize,
    _buffers: Vec<wgpu::Buffer>,
}

/// Read-only storage tables as one bind group: a buffer per `(label, bytes)`, bound in order
/// from binding 0 (fragment and compute stages). Returns the layout, the group and the
/// buffers (kept alive with it).
fn storage_tables(
    gpu: &Gpu,
    label: &str,
    tables: &[(&str, &[u8])],
) -> (wgpu::BindGroupLayout, wgpu::BindGroup, Vec<wgpu::Buffer>) {
    let device = &gpu.device;
    let visibility = wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
    let layout = (0..tables.len() as u32)
        .fold(bind_group_layout(), |l, b| l.storage(b, visibility))
        .build(device, &format!("{label} layout"));
    // A binding must not be empty; pad to one 16-byte element.
    let buffers: Vec<wgpu::Buffer> = tables
        .iter()
        .map(|(name, bytes)| buffer_init(gpu, name, wgpu::BufferUsages::STORAGE, bytes, 16))
        .collect();
    let entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout: &layout,
        entries: &entries,
    });
    (layout, group, buffers)
}

impl SrdmBuffers {
    /// Uploads `tables`.
    pub fn new(gpu: &Gpu, tables: &SrdmTables) -> Result<SrdmBuffers, GpuError> {
        error_scoped(&gpu.device, "uploading the SRDM tables", || {
            let (layout, group, buffers) = storage_tables(
                gpu,
                "glint SRDM tables",
                &[
                    ("glint SRDM views", bytemuck::cast_slice(&tables.views)),
                    ("glint SRDM points", bytemuck::cast_slice(&tables.points)),
                    ("glint SRDM counts", bytemuck::cast_slice(&tables.counts)),
                    ("glint SRDM domains", bytemuck::cast_slice(&tables.domains)),
                    ("glint SRDM colours", bytemuck::cast_slice(&tables.colours)),
                    (
                        "glint SRDM impostors",
                        bytemuck::cast_slice(&tables.impostors),
                    ),
                ],
            );
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

/// The billboard tables on the GPU (group 3 of `billboards.wgsl`).
pub struct BillboardBuffers {
    pub(super) layout: wgpu::BindGroupLayout,
    pub(super) group: wgpu::BindGroup,
    billboards: usize,
    _buffers: Vec<wgpu::Buffer>,
}

impl BillboardBuffers {
    /// Uploads `tables`.
    pub fn new(gpu: &Gpu, tables: &BillboardTables) -> Result<BillboardBuffers, GpuError> {
        error_scoped(&gpu.device, "uploading the billboard tables", || {
            let (layout, group, buffers) = storage_tables(
                gpu,
                "glint billboard tables",
                &[
                    ("glint billboards", bytemuck::cast_slice(&tables.billboards)),
                    (
                        "glint billboard groups",
                        bytemuck::cast_slice(&tables.groups),
                    ),
                    (
                        "glint billboard texels",
                        bytemuck::cast_slice(&tables.texels),
                    ),
                    (
                        "glint billboard normals",
                        bytemuck::cast_slice(&tables.normals),
                    ),
                    ("glint billboard env", bytemuck::cast_slice(&tables.env)),
                ],
            );
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
