//! A full-screen pass reading one texture into a new [`HDR_FORMAT`] target of its own: the
//! image-space filters run over a planar reflector's map (`reflections::gap_fill`,
//! `reflections::downsample`). Its shader has a `vs_full` vertex entry drawing one triangle
//! over the target and reads the source at binding 0 of group 0.

use glam::Vec4;

use super::build::{bind_group_layout, render_pipeline, shader};
use super::readback::read_texture_rgba16f;
use super::target::{HDR_FORMAT, clear_pass, texture_2d};
use super::{Gpu, GpuError};

/// The pass and its target.
pub struct ImagePass {
    pipeline: wgpu::RenderPipeline,
    group: wgpu::BindGroup,
    texture: wgpu::Texture,
    /// The pass's output.
    pub view: wgpu::TextureView,
}

impl ImagePass {
    /// The pass `label` drawing `source` through `wgsl`'s fragment entry `fs` into a
    /// `width` × `height` target, with the shader's overridable `constants` set.
    pub fn new(
        device: &wgpu::Device,
        label: &str,
        wgsl: &str,
        fs: &str,
        source: &wgpu::TextureView,
        (width, height): (u32, u32),
        constants: &[(&str, f64)],
    ) -> ImagePass {
        let layout = bind_group_layout()
            .texture(
                0,
                wgpu::ShaderStages::FRAGMENT,
                wgpu::TextureViewDimension::D2,
                false,
            )
            .build(device, label);
        let module = shader(device, label, wgsl);
        let mut pipeline = render_pipeline(label, &module, "vs_full", fs)
            .layouts(&[&layout])
            .color(HDR_FORMAT, None);
        for &(name, value) in constants {
            pipeline = pipeline.override_number(name, value);
        }
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(source),
            }],
        });
        let texture = texture_2d(
            device,
            label,
            width,
            height,
            HDR_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
        );
        ImagePass {
            pipeline: pipeline.build(device),
            group,
            view: texture.create_view(&wgpu::TextureViewDescriptor::default()),
            texture,
        }
    }

    /// Records the pass (after its source is complete).
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = clear_pass(
            encoder,
            "glint image pass",
            &[Some(&self.view)],
            wgpu::Color::TRANSPARENT,
            None,
            None,
        );
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.draw(0..3, 0..1);
    }
}

/// The pass `make` builds over `texels` (`width` × `height`, row-major) uploaded as an
/// [`HDR_FORMAT`] texture (so each value is first rounded to f16), run once and read back: a
/// filter's shader against its CPU form in tests.
pub fn run_on_texels(
    gpu: &Gpu,
    (width, height): (u32, u32),
    texels: &[Vec4],
    make: impl FnOnce(&wgpu::Device, &wgpu::TextureView) -> ImagePass,
) -> Result<Vec<Vec4>, GpuError> {
    assert_eq!(
        texels.len(),
        (width * height) as usize,
        "one texel per pixel"
    );
    let source = texture_2d(
        &gpu.device,
        "glint image pass source",
        width,
        height,
        HDR_FORMAT,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
    );
    let bits: Vec<u16> = texels
        .iter()
        .flat_map(|v| {
            v.to_array()
                .map(|c| exr::prelude::f16::from_f32(c).to_bits())
        })
        .collect();
    gpu.queue.write_texture(
        source.as_image_copy(),
        bytemuck::cast_slice(&bits),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(width * 8),
            rows_per_image: None,
        },
        source.size(),
    );
    let view = source.create_view(&wgpu::TextureViewDescriptor::default());
    let pass = make(&gpu.device, &view);
    let mut encoder = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("glint image pass run"),
        });
    pass.record(&mut encoder);
    gpu.queue.submit([encoder.finish()]);
    read_texture_rgba16f(gpu, &pass.texture)
}
