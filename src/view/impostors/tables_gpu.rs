//! The impostor tables in GPU storage buffers: the SRDM tables (bind group 1 of
//! `shaders/srdm.wgsl`) and the billboard tables (group 3 of `shaders/billboards.wgsl`).

use super::super::billboard_tables::BillboardTables;
use super::super::gpu::{Gpu, GpuError, error_scoped};
use super::super::impostor_tables::SrdmTables;

/// The SRDM tables on the GPU and their bind group layout (group 1 of `srdm.wgsl`).
pub struct SrdmBuffers {
    pub(super) layout: wgpu::BindGroupLayout,
    pub(super) group: wgpu::BindGroup,
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

/// Read-only storage tables as one bind group: a buffer per `(label, bytes)`, bound in order
/// from binding 0. Returns the layout, the group and the buffers (kept alive with it).
fn storage_tables(
    gpu: &Gpu,
    label: &str,
    tables: &[(&str, &[u8])],
) -> (wgpu::BindGroupLayout, wgpu::BindGroup, Vec<wgpu::Buffer>) {
    let device = &gpu.device;
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(&format!("{label} layout")),
        entries: &(0..tables.len() as u32)
            .map(|b| storage_entry(b, true))
            .collect::<Vec<_>>(),
    });
    let buffers: Vec<wgpu::Buffer> = tables
        .iter()
        .map(|(name, bytes)| storage_buffer(gpu, name, bytes))
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
