//! The reflected image M drawn at [`map_factor`] × the frame's resolution and box-filtered to
//! the frame's pixels (`shaders/map_downsample.wgsl`) before the gap fill, M's pyramid and
//! the composite read it.
//!
//! The frame's multisampling smooths the edges of what the scene pass draws, but the
//! composite reads M at one texel per pixel: a near-mirror's reflection, which the lobe
//! barely blurs, kept every reflected edge stair-stepped. M drawn at twice the resolution and
//! averaged over each pixel's 2 × 2 texels is supersampling of the mirrored view, as the
//! frame's 4 samples a pixel are of the direct one.
//!
//! [`downsample`] is the CPU form the shader follows; [`downsample_on_gpu`] runs the shader on
//! an image (for tests).

use exr::prelude::f16;
use glam::Vec4;

use crate::view::gpu::build::{bind_group_layout, render_pipeline, shader};
use crate::view::gpu::readback::read_texture_rgba16f;
use crate::view::gpu::target::{HDR_FORMAT, clear_pass, texture_2d};
use crate::view::gpu::{Gpu, GpuError};

/// WGSL of the pass.
pub const DOWNSAMPLE_SHADER_SOURCE: &str = include_str!("../../../shaders/map_downsample.wgsl");

/// M's texels per frame pixel along each axis for a frame of `samples` samples a pixel: the
/// side of the square grid of that many (4 samples: 2 × 2 texels), 1 for a frame without
/// anti-aliasing.
pub fn map_factor(samples: u32) -> u32 {
    (1..=4).rev().find(|f| f * f <= samples.max(1)).unwrap_or(1)
}

/// M at `factor` × (`width` × `height`), row-major, box-filtered to `width` × `height`: the
/// mean of each pixel's `factor` × `factor` texels that something was drawn to (alpha > 0;
/// none: empty, zero).
pub fn downsample(width: u32, height: u32, factor: u32, texels: &[Vec4]) -> Vec<Vec4> {
    let (w, f) = (width * factor, factor);
    (0..width * height)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            let (sum, n) = (0..f * f)
                .map(|k| texels[((y * f + k / f) * w + x * f + k % f) as usize])
                .filter(|t| t.w > 0.0)
                .fold((Vec4::ZERO, 0u32), |(s, n), t| (s + t, n + 1));
            if n == 0 { Vec4::ZERO } else { sum / n as f32 }
        })
        .collect()
}

/// The pass and its target: M at the frame's resolution.
pub(super) struct Downsample {
    pipeline: wgpu::RenderPipeline,
    group: wgpu::BindGroup,
    texture: wgpu::Texture,
    /// M box-filtered to the frame's pixels.
    pub(super) view: wgpu::TextureView,
}

impl Downsample {
    /// The pass reading `source` (M at `factor` × (`width` × `height`)) into a `width` ×
    /// `height` target.
    pub(super) fn new(
        device: &wgpu::Device,
        source: &wgpu::TextureView,
        width: u32,
        height: u32,
        factor: u32,
    ) -> Downsample {
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let layout = bind_group_layout()
            .texture(0, fragment, wgpu::TextureViewDimension::D2, false)
            .build(device, "glint reflection downsample layout");
        let module = shader(
            device,
            "glint reflection downsample shader",
            DOWNSAMPLE_SHADER_SOURCE,
        );
        let pipeline = render_pipeline(
            "glint reflection downsample",
            &module,
            "vs_full",
            "fs_downsample",
        )
        .layouts(&[&layout])
        .color(HDR_FORMAT, None)
        .override_number("FACTOR", f64::from(factor))
        .build(device);
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("glint reflection downsample source"),
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(source),
            }],
        });
        let texture = texture_2d(
            device,
            "glint downsampled reflection",
            width,
            height,
            HDR_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
        );
        Downsample {
            pipeline,
            group,
            view: texture.create_view(&wgpu::TextureViewDescriptor::default()),
            texture,
        }
    }

    /// Records the pass (after M is complete).
    pub(super) fn record(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = clear_pass(
            encoder,
            "glint reflection downsample pass",
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

/// [`downsample`] by the shader: `texels` (`factor` × (`width` × `height`), row-major)
/// uploaded as M ([`HDR_FORMAT`], so each value is first rounded to f16), filtered, read back.
pub fn downsample_on_gpu(
    gpu: &Gpu,
    width: u32,
    height: u32,
    factor: u32,
    texels: &[Vec4],
) -> Result<Vec<Vec4>, GpuError> {
    let (sw, sh) = (width * factor, height * factor);
    assert_eq!(texels.len(), (sw * sh) as usize, "factor² texels a pixel");
    let source = texture_2d(
        &gpu.device,
        "glint downsample probe source",
        sw,
        sh,
        HDR_FORMAT,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
    );
    let bits: Vec<u16> = texels
        .iter()
        .flat_map(|v| v.to_array().map(|c| f16::from_f32(c).to_bits()))
        .collect();
    gpu.queue.write_texture(
        source.as_image_copy(),
        bytemuck::cast_slice(&bits),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(sw * 8),
            rows_per_image: None,
        },
        source.size(),
    );
    let view = source.create_view(&wgpu::TextureViewDescriptor::default());
    let pass = Downsample::new(&gpu.device, &view, width, height, factor);
    let mut encoder = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("glint downsample probe"),
        });
    pass.record(&mut encoder);
    gpu.queue.submit([encoder.finish()]);
    read_texture_rgba16f(gpu, &pass.texture)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_factor_is_the_side_of_the_sample_grid() {
        assert_eq!(
            [0, 1, 2, 3, 4, 8, 9, 16].map(map_factor),
            [1, 1, 1, 1, 2, 2, 3, 4]
        );
    }

    #[test]
    fn a_pixel_is_the_mean_of_the_texels_drawn_to() {
        // One 2 × 2 pixel: three texels drawn to and one empty.
        let t = [
            Vec4::new(1.0, 0.0, 0.0, 0.5),
            Vec4::new(0.0, 1.0, 0.0, 0.5),
            Vec4::new(0.0, 0.0, 1.0, 0.2),
            Vec4::ZERO,
        ];
        let mean = downsample(1, 1, 2, &t)[0];
        assert!(
            (mean - Vec4::new(1.0, 1.0, 1.0, 1.2) / 3.0)
                .abs()
                .max_element()
                < 1e-6
        );
        // None drawn to: empty; factor 1 leaves M as it is.
        assert_eq!(downsample(1, 1, 2, &[Vec4::ZERO; 4]), [Vec4::ZERO]);
        assert_eq!(downsample(2, 2, 1, &t), t);
    }

    #[test]
    fn texels_are_read_from_their_own_pixel() {
        // 2 × 1 pixels at factor 2: the left pixel's texels are 1, the right one's 3.
        let row = |a: f32, b: f32| [a, a, b, b].map(Vec4::splat);
        let t: Vec<Vec4> = [row(1.0, 3.0), row(1.0, 3.0)].concat();
        assert_eq!(downsample(2, 1, 2, &t), [Vec4::ONE, Vec4::splat(3.0)]);
    }
}
