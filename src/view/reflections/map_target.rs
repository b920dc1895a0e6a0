//! The reflected image M: a reflection map's render target (an HDR colour texture the
//! composite samples, and its reverse-Z depth), the pass that draws a mirrored view into it
//! and the sampler that reads it. One map per reflector in the single-level passes, one per
//! recursion level in the recursive ones (Nielsen Figure 3).

use crate::view::gpu::Gpu;
use crate::view::gpu::target::{HDR_FORMAT, clear_pass, depth_texture, overlay_pass, texture_2d};

/// A reflection map's textures and views.
pub(super) struct ReflectionMap {
    _color: wgpu::Texture,
    /// M ([`HDR_FORMAT`], linear radiance; alpha: the fraction of the reflected ray beyond the
    /// plane, 0 where nothing was drawn).
    pub(super) view: wgpu::TextureView,
    _depth: wgpu::Texture,
    pub(super) depth_view: wgpu::TextureView,
}

impl ReflectionMap {
    /// A `width` × `height` map.
    pub(super) fn new(gpu: &Gpu, label: &str, width: u32, height: u32) -> ReflectionMap {
        let color = texture_2d(
            &gpu.device,
            label,
            width,
            height,
            HDR_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let depth = depth_texture(gpu, width, height);
        ReflectionMap {
            view: color.create_view(&wgpu::TextureViewDescriptor::default()),
            _color: color,
            depth_view: depth.create_view(&wgpu::TextureViewDescriptor::default()),
            _depth: depth,
        }
    }

    /// Begins the pass drawing a mirrored view into this map: M cleared to transparent (alpha
    /// 0 marks texels nothing was drawn to), depth cleared and kept afterwards only when
    /// `keep_depth` (nested composites test against it).
    pub(super) fn begin_mirror<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        label: &str,
        keep_depth: bool,
    ) -> wgpu::RenderPass<'e> {
        clear_pass(
            encoder,
            label,
            &[Some(&self.view)],
            wgpu::Color::TRANSPARENT,
            Some((&self.depth_view, keep_depth)),
            None,
        )
    }

    /// Begins a pass drawing over this map's finished mirrored view (loading and keeping its
    /// colour and depth): a nested composite.
    pub(super) fn begin_over<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        label: &str,
    ) -> wgpu::RenderPass<'e> {
        overlay_pass(encoder, label, &self.view, &self.depth_view)
    }
}

/// The trilinear sampler the composite reads M's pyramid with.
pub(super) fn map_sampler(device: &wgpu::Device, label: &str) -> wgpu::Sampler {
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some(label),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Linear,
        ..Default::default()
    })
}
