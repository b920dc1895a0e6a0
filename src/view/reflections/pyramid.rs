//! The MIP pyramid of a reflected image M on the GPU (`shaders/pyramid.wgsl`), which the
//! composite reads with the constant-cost filter of [`super::filter`] (the CPU form of both:
//! [`super::filter::Pyramid`]): level 0 (rgb·c, c) of M, each further level a 2×2 box of
//! the one below, one render pass per level, recorded after M is complete.

use crate::view::gpu::Gpu;
use crate::view::gpu::build::{bind_group_layout, render_pipeline, shader};
use crate::view::gpu::target::{HDR_FORMAT, clear_pass};

use super::filter::level_count;

/// WGSL of the pyramid passes.
pub const PYRAMID_SHADER_SOURCE: &str = include_str!("../../../shaders/pyramid.wgsl");

/// The pipelines that build pyramids.
pub(super) struct PyramidPasses {
    layout: wgpu::BindGroupLayout,
    base_covered: wgpu::RenderPipeline,
    base_all: wgpu::RenderPipeline,
    down: wgpu::RenderPipeline,
    sampler: wgpu::Sampler,
}

/// A pyramid of one reflection map: its texture, the view the composite samples (every
/// level), and per level the target view and the group reading its source.
pub(super) struct Pyramid {
    _texture: wgpu::Texture,
    /// Every level, for the composite.
    pub(super) view: wgpu::TextureView,
    levels: Vec<(wgpu::TextureView, wgpu::BindGroup)>,
}

impl PyramidPasses {
    /// The pipelines on `device`.
    pub(super) fn new(device: &wgpu::Device) -> PyramidPasses {
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let layout = bind_group_layout()
            .texture(0, fragment, wgpu::TextureViewDimension::D2, true)
            .sampler(1, fragment)
            .build(device, "glint pyramid layout");
        let module = shader(device, "glint pyramid shader", PYRAMID_SHADER_SOURCE);
        let pipeline = |label, fs| {
            render_pipeline(label, &module, "vs_full", fs)
                .layouts(&[&layout])
                .color(HDR_FORMAT, None)
                .build(device)
        };
        PyramidPasses {
            base_covered: pipeline("glint pyramid base (covered)", "fs_base_covered"),
            base_all: pipeline("glint pyramid base", "fs_base_all"),
            down: pipeline("glint pyramid level", "fs_down"),
            sampler: device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("glint pyramid sampler"),
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                ..Default::default()
            }),
            layout,
        }
    }

    /// A pyramid for the `width` × `height` map whose colour view is `source`.
    pub(super) fn pyramid(
        &self,
        gpu: &Gpu,
        source: &wgpu::TextureView,
        width: u32,
        height: u32,
    ) -> Pyramid {
        let device = &gpu.device;
        let count = level_count(width, height);
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("glint reflection pyramid"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: count,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: HDR_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let level_view = |k: u32| {
            texture.create_view(&wgpu::TextureViewDescriptor {
                base_mip_level: k,
                mip_level_count: Some(1),
                ..Default::default()
            })
        };
        let group = |view: &wgpu::TextureView| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("glint pyramid source"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::Sampler(&self.sampler),
                    },
                ],
            })
        };
        let views: Vec<wgpu::TextureView> = (0..count).map(level_view).collect();
        let levels = (0..count as usize)
            .map(|k| {
                let source = if k == 0 { source } else { &views[k - 1] };
                (views[k].clone(), group(source))
            })
            .collect();
        Pyramid {
            view: texture.create_view(&wgpu::TextureViewDescriptor::default()),
            _texture: texture,
            levels,
        }
    }

    /// Records the passes that fill `pyramid` from its map: with `covered`, texels of M with
    /// alpha 0 are holes (image mode); otherwise every texel counts.
    pub(super) fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        pyramid: &Pyramid,
        covered: bool,
    ) {
        for (k, (target, group)) in pyramid.levels.iter().enumerate() {
            let mut pass = clear_pass(
                encoder,
                "glint pyramid pass",
                &[Some(target)],
                wgpu::Color::TRANSPARENT,
                None,
                None,
            );
            pass.set_pipeline(match (k, covered) {
                (0, true) => &self.base_covered,
                (0, false) => &self.base_all,
                _ => &self.down,
            });
            pass.set_bind_group(0, group, &[]);
            pass.draw(0..3, 0..1);
        }
    }
}
