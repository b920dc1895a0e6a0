//! The composite: a pass drawn over the finished frame that adds a reflector's reflected term
//! to its visible pixels (planar reflections' ks·(M*K)·R, the curved reflectors' specular term,
//! the impostor reflections, the recursive tree's level-0 maps). Its pipeline writes the
//! frame's colour target with [`ADDITIVE_KEEP_ALPHA`], depth tested against the scene (reverse Z, `GreaterEqual`) and not
//! written, at the frame's sample count (multisampled like the scene pass when the frame is
//! anti-aliased); bind group 0 is the renderer's frame uniforms.

use super::renderer::{Renderer, frame_bind_group};
use crate::view::gpu::build::RenderPipelineBuilder;
use crate::view::gpu::target::{ADDITIVE_KEEP_ALPHA, TargetFormats, overlay_pass, reverse_z_depth};

/// A composite's pipeline and its group 0 (the frame uniforms of the renderer it was built for).
pub(crate) struct Composite {
    pipeline: wgpu::RenderPipeline,
    frame_group: wgpu::BindGroup,
}

/// `pipeline` (entry points, layouts, vertex buffers) with the composite's colour targets for
/// `formats` and its depth state.
fn over_frame<'a>(
    pipeline: RenderPipelineBuilder<'a>,
    formats: TargetFormats,
) -> RenderPipelineBuilder<'a> {
    pipeline
        .color(formats.color, Some(ADDITIVE_KEEP_ALPHA))
        .samples(formats.samples)
        .depth(reverse_z_depth(false, wgpu::CompareFunction::GreaterEqual))
}

impl Composite {
    /// The composite `pipeline` (its group 0 layout `frame_layout`, the frame bind group
    /// layout) drawing over `renderer`'s frames.
    pub(crate) fn new(
        device: &wgpu::Device,
        renderer: &Renderer,
        frame_layout: &wgpu::BindGroupLayout,
        pipeline: RenderPipelineBuilder<'_>,
    ) -> Composite {
        Composite {
            pipeline: over_frame(pipeline, renderer.formats()).build(device),
            frame_group: frame_bind_group(
                device,
                frame_layout,
                renderer.frame_uniform_buffer(),
                renderer.textures(),
            ),
        }
    }

    /// Begins the composite pass over the finished frame's `color` and `depth`
    /// ([`overlay_pass`]), with the pipeline and group 0 set.
    pub(crate) fn begin<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        label: &str,
        color: &wgpu::TextureView,
        depth: &wgpu::TextureView,
    ) -> wgpu::RenderPass<'e> {
        let mut pass = overlay_pass(encoder, label, color, depth);
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.frame_group, &[]);
        pass
    }
}
