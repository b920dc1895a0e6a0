//! Compute probes: what a shader computes for a batch of inputs, read back for tests against
//! the CPU (the bicubic reconstruction, the curved reflectors' glossy term, the SRDM and
//! billboard intersections).

use super::build::{bind_group_layout, buffer, buffer_init};
use super::gpu::{Gpu, GpuError, error_scoped};
use super::readback::read_buffer;

/// The bind-group layout of a compute probe's own buffers: binding 0 the input items
/// (read-only storage), binding 1 one output item per input (storage).
pub(crate) fn probe_io_layout(device: &wgpu::Device, label: &str) -> wgpu::BindGroupLayout {
    let compute = wgpu::ShaderStages::COMPUTE;
    bind_group_layout()
        .storage(0, compute)
        .storage_rw(1, compute)
        .build(device, label)
}

/// Runs a compute probe (what a shader computes, for tests against the CPU): uploads
/// `input` (`count` items), binds it with an output buffer of `output_size` bytes as group
/// `io_group` (layout [`probe_io_layout`]) beside `groups`, dispatches one invocation per
/// item in workgroups of 64 and returns the output's bytes.
#[allow(clippy::too_many_arguments)]
pub(crate) fn run_probe(
    gpu: &Gpu,
    context: &'static str,
    pipeline: &wgpu::ComputePipeline,
    io_layout: &wgpu::BindGroupLayout,
    io_group: u32,
    groups: &[(u32, &wgpu::BindGroup)],
    input: &[u8],
    count: usize,
    output_size: u64,
) -> Result<Vec<u8>, GpuError> {
    let device = &gpu.device;
    let output = error_scoped(device, context, || {
        // A binding must not be empty; pad to one 16-byte element.
        let input_buffer = buffer_init(
            gpu,
            "glint probe input",
            wgpu::BufferUsages::STORAGE,
            input,
            16,
        );
        let output = buffer(
            device,
            "glint probe output",
            output_size.max(16),
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let io = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("glint probe buffers"),
            layout: io_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: input_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: output.as_entire_binding(),
                },
            ],
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("glint probe encoder"),
        });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(context),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            for (index, group) in groups {
                pass.set_bind_group(*index, *group, &[]);
            }
            pass.set_bind_group(io_group, &io, &[]);
            pass.dispatch_workgroups((count as u32).div_ceil(64), 1, 1);
        }
        gpu.queue.submit([encoder.finish()]);
        output
    })?;
    let mut bytes = read_buffer(gpu, &output)?;
    bytes.truncate(output_size as usize);
    Ok(bytes)
}
