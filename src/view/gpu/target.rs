//! What every pass draws into and how it meets the frame: the target formats, the offscreen
//! target, the multisampled target of an anti-aliased frame, the reverse-Z depth state, the
//! additive blend of passes drawn over the scene, and how a pass begins: clearing its
//! targets, or loading a finished frame (the overlay).
//!
//! Anti-aliasing multisamples the main frame's geometry passes only: the scene pass and every
//! composite drawn over it (planar, recursive, impostor and curved reflections) draw into a
//! [`MultisampleTarget`] of the frame's sample count, resolved into the single-sampled
//! radiance the display pass reads. The passes that draw reflection maps, their pyramids and
//! cube maps stay single-sampled: cube maps and the deeper levels of a pyramid are filtered
//! before the frame reads them, and a planar reflector's map, which a near-mirror reads at
//! one texel a pixel, is drawn at 2 × 2 texels a pixel in a multisampled frame and
//! box-filtered instead (`reflections::downsample`).

use crate::view::gpu::{Gpu, GpuError, error_scoped};

/// Offscreen colour target format: the hardware encodes linear output to sRGB.
pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// Format of the radiance target (linear radiance) and of the radiosity textures.
pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// Depth buffer format.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Target formats of a [`Renderer`](crate::view::passes::renderer::Renderer)'s pipeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TargetFormats {
    /// The colour target. When it is not an sRGB format the shader encodes sRGB.
    pub color: wgpu::TextureFormat,
    /// Samples per pixel of the colour and depth targets (1: single-sampled).
    pub samples: u32,
}

/// The optional device features that let a frame multisample at every count the adapter
/// offers for its formats (without them: WebGPU's guaranteed counts, 1 and 4).
pub const MULTISAMPLE_FEATURES: wgpu::Features =
    wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES;

/// The sample count a frame asked to draw with `requested` samples a pixel gets on `gpu`: the
/// largest count up to `requested` at which the device can multisample the frame's radiance
/// ([`HDR_FORMAT`], resolvable) and depth ([`DEPTH_FORMAT`]), with a warning when that is
/// fewer than asked (1: no multisampling).
pub fn frame_samples(gpu: &Gpu, requested: u32) -> u32 {
    let features = gpu.device.features();
    let supports = |format: wgpu::TextureFormat, count: u32, resolve: bool| {
        let adapter = gpu.adapter.get_texture_format_features(format).flags;
        // Without these features the device validates against WebGPU's guaranteed counts.
        let device = if features.contains(MULTISAMPLE_FEATURES) {
            adapter
        } else {
            format.guaranteed_format_features(features).flags
        };
        [adapter, device].iter().all(|f| {
            f.sample_count_supported(count)
                && (!resolve || f.contains(wgpu::TextureFormatFeatureFlags::MULTISAMPLE_RESOLVE))
        })
    };
    let samples = (1..=requested.max(1))
        .rev()
        .find(|&n| n == 1 || (supports(HDR_FORMAT, n, true) && supports(DEPTH_FORMAT, n, false)))
        .unwrap_or(1);
    if samples != requested {
        log::warn!(
            "{} cannot multisample the frame ({HDR_FORMAT:?} and {DEPTH_FORMAT:?}) {requested} times; \
             drawing {samples} sample(s) a pixel{}",
            gpu.adapter.get_info().name,
            if samples == 1 {
                " (no anti-aliasing)"
            } else {
                ""
            }
        );
    }
    samples
}

/// Depth state of every pass: reverse-Z (nearer is greater) on [`DEPTH_FORMAT`].
pub fn reverse_z_depth(write: bool, compare: wgpu::CompareFunction) -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format: DEPTH_FORMAT,
        depth_write_enabled: Some(write),
        depth_compare: Some(compare),
        stencil: wgpu::StencilState::default(),
        bias: wgpu::DepthBiasState::default(),
    }
}

/// Adds a pass's colour to the target and keeps the target's alpha (reflections, curved and
/// impostor passes drawn over the scene; a reflection map's alpha is read by its composite).
pub const ADDITIVE_KEEP_ALPHA: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
};

/// Records a pass that only resolves the multisampled `color` into `into` (each pixel the
/// mean of its samples; the multisampled contents are not needed afterwards).
fn resolve_pass(
    encoder: &mut wgpu::CommandEncoder,
    color: &wgpu::TextureView,
    into: &wgpu::TextureView,
) {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("glint multisample resolve"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: color,
            depth_slice: None,
            resolve_target: Some(into),
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Load,
                store: wgpu::StoreOp::Discard,
            },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    });
}

/// Begins a pass that draws over a finished frame: it loads and keeps `color` and `depth`, so
/// its fragments add to the scene and are depth tested against it.
pub fn overlay_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    color: &wgpu::TextureView,
    depth: &wgpu::TextureView,
) -> wgpu::RenderPass<'e> {
    begin_pass(
        encoder,
        label,
        &[Some(color)],
        wgpu::LoadOp::Load,
        Some((depth, wgpu::LoadOp::Load, wgpu::StoreOp::Store)),
        None,
    )
}

/// Begins a pass that draws afresh: each of `colors` (`None`: an empty slot) cleared to
/// `clear` and kept, `depth` (when given) cleared to 0 (reverse Z: infinitely far) and kept
/// afterwards only when its flag says so (a later pass tests against it).
pub fn clear_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    colors: &[Option<&wgpu::TextureView>],
    clear: wgpu::Color,
    depth: Option<(&wgpu::TextureView, bool)>,
    timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
) -> wgpu::RenderPass<'e> {
    let depth = depth.map(|(view, keep)| {
        let store = if keep {
            wgpu::StoreOp::Store
        } else {
            wgpu::StoreOp::Discard
        };
        (view, wgpu::LoadOp::Clear(0.0), store)
    });
    begin_pass(
        encoder,
        label,
        colors,
        wgpu::LoadOp::Clear(clear),
        depth,
        timestamps,
    )
}

/// Begins a render pass: `colors` loaded by `load` and kept, `depth` with its load and store.
fn begin_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    colors: &[Option<&wgpu::TextureView>],
    load: wgpu::LoadOp<wgpu::Color>,
    depth: Option<(&wgpu::TextureView, wgpu::LoadOp<f32>, wgpu::StoreOp)>,
    timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
) -> wgpu::RenderPass<'e> {
    let attachment = |view| wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load,
            store: wgpu::StoreOp::Store,
        },
    };
    let color_attachments: Vec<_> = colors.iter().map(|v| v.map(attachment)).collect();
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &color_attachments,
        depth_stencil_attachment: depth.map(|(view, load, store)| {
            wgpu::RenderPassDepthStencilAttachment {
                view,
                depth_ops: Some(wgpu::Operations { load, store }),
                stencil_ops: None,
            }
        }),
        timestamp_writes: timestamps,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// A `width` × `height` 2D texture of `format` for `usage`: one MIP level, one sample.
pub fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    width: u32,
    height: u32,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    multisampled_2d(device, label, (width, height), 1, format, usage)
}

/// A `width` × `height` 2D texture of `format` for `usage` with `samples` samples a texel: one
/// MIP level.
fn multisampled_2d(
    device: &wgpu::Device,
    label: &str,
    (width, height): (u32, u32),
    samples: u32,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: samples,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// Refuses a target side of 0 or over the device's `max_texture_dimension_2d`.
pub(crate) fn check_target_size(
    device: &wgpu::Device,
    width: u32,
    height: u32,
) -> Result<(), GpuError> {
    let max = device.limits().max_texture_dimension_2d;
    if width == 0 || height == 0 || width > max || height > max {
        return Err(GpuError::InvalidSize { width, height, max });
    }
    Ok(())
}

/// A depth buffer for a `width` × `height` target.
pub fn depth_texture(gpu: &Gpu, width: u32, height: u32) -> wgpu::Texture {
    texture_2d(
        &gpu.device,
        "glint depth",
        width,
        height,
        DEPTH_FORMAT,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    )
}

/// The views a frame is drawn into, all of one size: linear radiance, the 8-bit display
/// target and depth.
#[derive(Clone, Copy)]
pub struct FrameViews<'a> {
    /// The linear radiance target ([`HDR_FORMAT`]; also sampled by the display pass).
    pub radiance: &'a wgpu::TextureView,
    /// The display target (the format the passes were built for).
    pub display: &'a wgpu::TextureView,
    /// The depth buffer (reverse Z).
    pub depth: &'a wgpu::TextureView,
}

/// The multisampled radiance and depth an anti-aliased frame's geometry passes draw into (see
/// the module documentation for which), resolved into the frame's radiance before the display
/// pass.
pub struct MultisampleTarget {
    /// Samples per pixel.
    pub samples: u32,
    _color: wgpu::Texture,
    _depth: wgpu::Texture,
    color_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
}

impl MultisampleTarget {
    /// Radiance ([`HDR_FORMAT`]) and depth of `samples` samples a pixel for a `width` ×
    /// `height` frame; `samples` must be one [`frame_samples`] returned.
    pub fn new(
        gpu: &Gpu,
        width: u32,
        height: u32,
        samples: u32,
    ) -> Result<MultisampleTarget, GpuError> {
        check_target_size(&gpu.device, width, height)?;
        error_scoped(
            &gpu.device,
            "creating the multisampled frame target",
            || {
                let texture = |label, format| {
                    multisampled_2d(
                        &gpu.device,
                        label,
                        (width, height),
                        samples,
                        format,
                        wgpu::TextureUsages::RENDER_ATTACHMENT,
                    )
                };
                let color = texture("glint multisampled radiance", HDR_FORMAT);
                let depth = texture("glint multisampled depth", DEPTH_FORMAT);
                let view =
                    |t: &wgpu::Texture| t.create_view(&wgpu::TextureViewDescriptor::default());
                MultisampleTarget {
                    samples,
                    color_view: view(&color),
                    depth_view: view(&depth),
                    _color: color,
                    _depth: depth,
                }
            },
        )
    }

    /// `frame` with its radiance and depth replaced by this target's: what the geometry
    /// passes draw into.
    pub fn views<'a>(&'a self, frame: FrameViews<'a>) -> FrameViews<'a> {
        FrameViews {
            radiance: &self.color_view,
            depth: &self.depth_view,
            ..frame
        }
    }

    /// Records the resolve of the drawn radiance into `radiance` (single-sampled, the frame's
    /// own), each pixel the mean of its samples.
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder, radiance: &wgpu::TextureView) {
        resolve_pass(encoder, &self.color_view, radiance);
    }
}

/// An offscreen target: linear radiance (readable: the HDR output), the 8-bit colour the
/// display pass maps it to (readable) and depth.
pub struct OffscreenTarget {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// [`COLOR_FORMAT`] colour: the displayed frame.
    pub color: wgpu::Texture,
    /// [`HDR_FORMAT`] linear radiance every pass draws into.
    pub radiance: wgpu::Texture,
    /// The depth buffer (drawn through `depth_view`; held so the target owns what it uses).
    _depth: wgpu::Texture,
    color_view: wgpu::TextureView,
    radiance_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
}

impl OffscreenTarget {
    /// Creates the textures; checks the size against the device's limit.
    pub fn new(gpu: &Gpu, width: u32, height: u32) -> Result<OffscreenTarget, GpuError> {
        check_target_size(&gpu.device, width, height)?;
        error_scoped(&gpu.device, "creating the offscreen target", || {
            let readable = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
            let color = texture_2d(
                &gpu.device,
                "glint offscreen colour",
                width,
                height,
                COLOR_FORMAT,
                readable,
            );
            let radiance = texture_2d(
                &gpu.device,
                "glint offscreen radiance",
                width,
                height,
                HDR_FORMAT,
                readable | wgpu::TextureUsages::TEXTURE_BINDING,
            );
            let depth = depth_texture(gpu, width, height);
            let view = |t: &wgpu::Texture| t.create_view(&wgpu::TextureViewDescriptor::default());
            OffscreenTarget {
                width,
                height,
                color_view: view(&color),
                radiance_view: view(&radiance),
                depth_view: view(&depth),
                color,
                radiance,
                _depth: depth,
            }
        })
    }

    /// The radiance, display colour and depth views, as a frame is drawn into them.
    pub fn views(&self) -> FrameViews<'_> {
        FrameViews {
            radiance: &self.radiance_view,
            display: &self.color_view,
            depth: &self.depth_view,
        }
    }
}
