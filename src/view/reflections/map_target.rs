//! The reflected image M: a reflection map's render target (an HDR colour texture the
//! composite samples, and its reverse-Z depth), the pass that draws a mirrored view into it
//! and the sampler that reads it. One map per reflector in the single-level passes, one per
//! recursion level in the recursive ones (Nielsen Figure 3). In an anti-aliased frame the
//! single-level maps are drawn multisampled and resolved into M, so an edge seen in a
//! near-mirror (whose composite reads M almost unfiltered) is anti-aliased like the frame's.

use crate::view::gpu::Gpu;
use crate::view::gpu::build::{render_pipeline, shader};
use crate::view::gpu::target::{
    DEPTH_FORMAT, HDR_FORMAT, clear_pass, depth_texture, multisampled_2d, overlay_pass, texture_2d,
};

/// WGSL of the multisampled map's resolve.
pub const MAP_RESOLVE_SHADER_SOURCE: &str = include_str!("../../../shaders/map_resolve.wgsl");

/// A reflection map's textures and views.
pub(super) struct ReflectionMap {
    _color: wgpu::Texture,
    /// M ([`HDR_FORMAT`], linear radiance; alpha: the fraction of the reflected ray beyond the
    /// plane, 0 where nothing was drawn).
    pub(super) view: wgpu::TextureView,
    _depth: wgpu::Texture,
    pub(super) depth_view: wgpu::TextureView,
    /// With more than one sample a pixel: what the mirror pass draws into instead.
    multisampled: Option<MultisampledMap>,
}

/// The multisampled colour and depth a map's mirror pass draws into, and the pass resolving
/// them into M.
struct MultisampledMap {
    _color: wgpu::Texture,
    color_view: wgpu::TextureView,
    _depth: wgpu::Texture,
    depth_view: wgpu::TextureView,
    resolve: wgpu::RenderPipeline,
    group: wgpu::BindGroup,
}

impl MultisampledMap {
    /// `samples` samples a texel of a `width` × `height` map; with `covered`, alpha-0 samples
    /// are holes left out of the mean (image mode), else every sample counts.
    fn new(gpu: &Gpu, (width, height): (u32, u32), samples: u32, covered: bool) -> Self {
        let device = &gpu.device;
        let texture = |label, format, usage| {
            multisampled_2d(device, label, (width, height), samples, format, usage)
        };
        let attachment = wgpu::TextureUsages::RENDER_ATTACHMENT;
        let color = texture(
            "glint multisampled reflection map",
            HDR_FORMAT,
            attachment | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let depth = texture("glint multisampled map depth", DEPTH_FORMAT, attachment);
        let color_view = color.create_view(&wgpu::TextureViewDescriptor::default());
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("glint map resolve layout"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: true,
                },
                count: None,
            }],
        });
        let module = shader(
            device,
            "glint map resolve shader",
            MAP_RESOLVE_SHADER_SOURCE,
        );
        let fs = if covered {
            "fs_resolve_covered"
        } else {
            "fs_resolve_all"
        };
        let resolve = render_pipeline("glint map resolve", &module, "vs_full", fs)
            .layouts(&[&layout])
            .color(HDR_FORMAT, None)
            .build(device);
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("glint map resolve source"),
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&color_view),
            }],
        });
        MultisampledMap {
            depth_view: depth.create_view(&wgpu::TextureViewDescriptor::default()),
            _depth: depth,
            color_view,
            _color: color,
            resolve,
            group,
        }
    }
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
            multisampled: None,
        }
    }

    /// A `width` × `height` map whose mirror pass draws `samples` samples a texel, resolved
    /// into M by [`ReflectionMap::resolve`] (with `covered`, alpha-0 samples are holes; see
    /// `shaders/map_resolve.wgsl`); with 1 sample, [`ReflectionMap::new`]'s.
    pub(super) fn multisampled(
        gpu: &Gpu,
        label: &str,
        (width, height): (u32, u32),
        samples: u32,
        covered: bool,
    ) -> ReflectionMap {
        let mut map = ReflectionMap::new(gpu, label, width, height);
        map.multisampled =
            (samples > 1).then(|| MultisampledMap::new(gpu, (width, height), samples, covered));
        map
    }

    /// Whether the mirror pass draws multisampled, so needs [`ReflectionMap::resolve`].
    pub(super) fn is_multisampled(&self) -> bool {
        self.multisampled.is_some()
    }

    /// Records the resolve of a multisampled mirror pass into M (nothing when single-sampled).
    pub(super) fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        let Some(ms) = &self.multisampled else {
            return;
        };
        let mut pass = clear_pass(
            encoder,
            "glint map resolve pass",
            &[Some(&self.view)],
            wgpu::Color::TRANSPARENT,
            None,
            None,
        );
        pass.set_pipeline(&ms.resolve);
        pass.set_bind_group(0, &ms.group, &[]);
        pass.draw(0..3, 0..1);
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
        let (color, depth) = self
            .multisampled
            .as_ref()
            .map_or((&self.view, &self.depth_view), |m| {
                (&m.color_view, &m.depth_view)
            });
        clear_pass(
            encoder,
            label,
            &[Some(color)],
            wgpu::Color::TRANSPARENT,
            Some((depth, keep_depth)),
            None,
        )
    }

    /// Begins a pass drawing over this map's finished mirrored view (loading and keeping its
    /// colour and depth): a nested composite. Single-sampled maps only.
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
