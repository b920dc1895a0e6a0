//! Compute probes: what a shader computes for a batch of inputs, read back for tests against
//! the CPU (the bicubic reconstruction, the curved reflectors' glossy term, the SRDM and
//! billboard intersections).

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec2, Vec3};

use super::build::{bind_group_layout, buffer, buffer_init, compute_pipeline, shader};
use super::radiosity_textures::RadiosityTextures;
use super::readback::read_buffer;
use crate::radiosity::RadiosityMap;
use crate::view::gpu::RenderError;
use crate::view::gpu::{Gpu, GpuError, error_scoped};
use crate::view::passes::renderer::{
    FrameUniforms, SHADER_SOURCE, frame_bind_group, frame_bind_group_layout, uniform_buffer,
};

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

/// A compute probe's group 0 ([`frame_bind_group_layout`]): `textures` as D, frame uniforms
/// with an identity view and exposure 1 (probes read D, never project).
pub(crate) fn probe_frame_group(
    gpu: &Gpu,
    layout: &wgpu::BindGroupLayout,
    textures: &RadiosityTextures,
) -> wgpu::BindGroup {
    let uniforms = uniform_buffer(&gpu.device);
    let u = FrameUniforms {
        view_proj: Mat4::IDENTITY.to_cols_array_2d(),
        atlas_size: textures.layer_size.map(|v| v as f32),
        exposure: 1.0,
        encode_srgb: 0,
        eye: [0.0; 4],
    };
    gpu.queue.write_buffer(&uniforms, 0, bytemuck::bytes_of(&u));
    frame_bind_group(&gpu.device, layout, &uniforms, textures)
}

/// Mirrors `ProbeInput` in `shaders/view.wgsl` (16 bytes): one lookup for [`bicubic_probe`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct ProbeInput {
    /// Lightmap coordinates in texels.
    pub lightmap: [f32; 2],
    /// Page.
    pub page: u32,
    /// Padding to the WGSL struct's 8-byte alignment.
    pub _pad: u32,
}

/// Reconstructs D at each of `points` (lightmap coordinates in texels, page) with the shader's
/// `sample_radiosity`, in a compute pass: what the fragment shader sees. For tests that hold
/// the WGSL filter to [`crate::view::cpu::bicubic::bspline`].
pub fn bicubic_probe(
    gpu: &Gpu,
    map: &RadiosityMap,
    points: &[(Vec2, u32)],
) -> Result<Vec<Vec3>, RenderError> {
    if points.is_empty() {
        return Ok(Vec::new());
    }
    let textures = RadiosityTextures::upload(gpu, map)?;
    let device = &gpu.device;
    let inputs: Vec<ProbeInput> = points
        .iter()
        .map(|(p, page)| ProbeInput {
            lightmap: p.to_array(),
            page: *page,
            _pad: 0,
        })
        .collect();
    let out_size = (points.len() * 16) as u64;
    let (pipeline, probe_layout, frame_group) =
        error_scoped(device, "creating the bicubic probe", || {
            let shader = shader(device, "glint view shader (probe)", SHADER_SOURCE);
            let frame_layout = frame_bind_group_layout(device);
            let probe_layout = probe_io_layout(device, "glint probe bind group layout");
            let pipeline = compute_pipeline(
                device,
                "glint probe pipeline",
                &shader,
                &[Some(&frame_layout), Some(&probe_layout)],
                "cs_probe",
            );
            let frame_group = probe_frame_group(gpu, &frame_layout, &textures);
            (pipeline, probe_layout, frame_group)
        })?;
    let bytes = run_probe(
        gpu,
        "running the bicubic probe",
        &pipeline,
        &probe_layout,
        1,
        &[(0, &frame_group)],
        bytemuck::cast_slice(&inputs),
        inputs.len(),
        out_size,
    )?;
    let values: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
    Ok(values.iter().map(|v| Vec3::new(v[0], v[1], v[2])).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn probe_input_matches_the_wgsl_struct() {
        crate::assert_wgsl_layout!(
            SHADER_SOURCE,
            "ProbeInput",
            ProbeInput {
                lightmap,
                page,
                _pad
            }
        );
    }
}
