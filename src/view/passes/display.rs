//! The display pass: the frame's linear radiance, which every other pass draws into
//! ([`RADIANCE_FORMAT`]), mapped to the 8-bit target (the offscreen colour texture or the
//! window's surface): × 2^EV ([`crate::view::exposure`]), the tone curve
//! ([`crate::view::tonemap`]), sRGB (`shaders/display.wgsl`). The radiance target itself is
//! never exposed: it is the HDR output.

use bytemuck::{Pod, Zeroable};

use crate::view::gpu::build::{bind_group_layout, buffer, render_pipeline, shader};
use crate::view::gpu::target::HDR_FORMAT;
use crate::view::options::{Exposure, Tonemap};

/// Format of the radiance target every pass of a frame draws into.
pub const RADIANCE_FORMAT: wgpu::TextureFormat = HDR_FORMAT;

/// WGSL of the display pass.
pub const DISPLAY_SHADER_SOURCE: &str = include_str!("../../../shaders/display.wgsl");

/// Mirrors `DisplayUniforms` in `shaders/display.wgsl` (16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct DisplayUniforms {
    /// 2^EV.
    pub scale: f32,
    /// [`Tonemap::shader_mode`].
    pub mode: u32,
    /// 1 when the target is not an sRGB format (the shader encodes), else 0.
    pub encode_srgb: u32,
    /// Padding to 16 bytes.
    pub _pad: u32,
}

/// How the 8-bit frame is made from radiance: the exposure (with the bundle's auto value)
/// and the curve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DisplayMapping {
    /// `auto` or a fixed EV.
    pub exposure: Exposure,
    /// The EV `auto` stands for ([`crate::view::exposure::auto_ev`] of the bundle's D).
    pub auto_ev: f32,
    /// The tone curve.
    pub tonemap: Tonemap,
}

impl DisplayMapping {
    /// The mapping of one linear RGB value to display-linear [0, 1] (before sRGB encoding):
    /// the CPU twin of `fs_display`.
    pub fn apply(&self, c: glam::Vec3) -> glam::Vec3 {
        self.tonemap
            .apply(c.max(glam::Vec3::ZERO) * self.exposure.scale(self.auto_ev))
    }
}

/// The display pass's pipeline for one target format, and its uniforms.
pub struct DisplayPass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    uniforms: wgpu::Buffer,
    encode_srgb: bool,
}

impl DisplayPass {
    /// The pass writing `format` (sRGB formats encode in hardware, others in the shader).
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> DisplayPass {
        let module = shader(device, "glint display shader", DISPLAY_SHADER_SOURCE);
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let layout = bind_group_layout()
            .uniform::<DisplayUniforms>(0, fragment)
            .texture(1, fragment, wgpu::TextureViewDimension::D2, false)
            .build(device, "glint display bind group layout");
        let pipeline = render_pipeline(
            "glint display pipeline",
            &module,
            "vs_display",
            "fs_display",
        )
        .layouts(&[&layout])
        .color(format, None)
        .build(device);
        DisplayPass {
            pipeline,
            layout,
            uniforms: buffer(
                device,
                "glint display uniforms",
                std::mem::size_of::<DisplayUniforms>() as u64,
                wgpu::BufferUsages::UNIFORM,
            ),
            encode_srgb: !format.is_srgb(),
        }
    }

    /// The uniforms for `mapping`.
    pub fn uniforms(&self, mapping: &DisplayMapping) -> DisplayUniforms {
        DisplayUniforms {
            scale: mapping.exposure.scale(mapping.auto_ev),
            mode: mapping.tonemap.shader_mode(),
            encode_srgb: u32::from(self.encode_srgb),
            _pad: 0,
        }
    }

    /// Writes the uniforms of `mapping` (the write lands before the next submission).
    pub fn prepare(&self, queue: &wgpu::Queue, mapping: &DisplayMapping) {
        queue.write_buffer(
            &self.uniforms,
            0,
            bytemuck::bytes_of(&self.uniforms(mapping)),
        );
    }

    /// Records the pass: `radiance` (a [`RADIANCE_FORMAT`] view of the target's size) mapped
    /// into `target`, every pixel written, with `timestamps` when given.
    pub fn record(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        radiance: &wgpu::TextureView,
        target: &wgpu::TextureView,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("glint display bind group"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.uniforms.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(radiance),
                },
            ],
        });
        let mut pass = crate::view::gpu::target::clear_pass(
            encoder,
            "glint display pass",
            &[Some(target)],
            wgpu::Color::BLACK,
            None,
            timestamps,
        );
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.draw(0..3, 0..1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_uniforms_match_the_wgsl_struct() {
        crate::assert_wgsl_layout!(
            DISPLAY_SHADER_SOURCE,
            "DisplayUniforms",
            DisplayUniforms {
                scale,
                mode,
                encode_srgb,
                _pad
            }
        );
    }

    #[test]
    fn the_mapping_exposes_then_tone_maps() {
        let m = DisplayMapping {
            exposure: Exposure::Ev(1.0),
            auto_ev: -5.0,
            tonemap: Tonemap::None,
        };
        assert_eq!(
            m.apply(glam::Vec3::new(0.25, 2.0, -1.0)),
            glam::Vec3::new(0.5, 1.0, 0.0)
        );
        let auto = DisplayMapping {
            exposure: Exposure::Auto,
            tonemap: Tonemap::Neutral,
            ..m
        };
        let c = auto.apply(glam::Vec3::splat(32.0 * 0.5));
        assert!(
            (c.x - (0.5 - crate::view::tonemap::F90)).abs() < 1e-6,
            "{c}"
        );
    }
}
