//! What every pass draws into and how it meets the frame: the target formats, the offscreen
//! target, the reverse-Z depth state, the additive blend of passes drawn over the scene, and
//! how a pass begins: clearing its targets, or loading a finished frame (the overlay).

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
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
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
