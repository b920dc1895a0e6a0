//! The passes that draw into a frame: the scene pass ([`renderer`], kd·D, which clears the
//! frame), the [`composite`] every pass over the finished scene draws through, and the display
//! pass ([`display`]) that maps the frame's radiance to its 8-bit target. The passes drawn over
//! the scene (planar, recursive, impostor and curved reflections) live with their technique;
//! [`FramePass`] is what the frame asks of each.

pub mod composite;
pub mod display;
pub mod glass;
pub mod renderer;

use crate::camera::Camera;
use crate::view::curved::gpu::CurvedReflections;
use crate::view::gpu::Gpu;
use crate::view::gpu::target::FrameViews;
use renderer::Renderer;

/// What a pass drawn over the scene is given for one frame.
#[derive(Clone, Copy)]
pub struct FrameContext<'a> {
    /// The scene pass the frame's passes were built for (its uniforms, vertices and indices).
    pub renderer: &'a Renderer,
    /// The frame's camera.
    pub camera: &'a Camera,
    /// The curved reflectors' cube maps when the frame has them: the planar passes draw the
    /// curved reflectors seen in their maps with them.
    pub curved: Option<&'a CurvedReflections>,
}

/// A pass that adds to the finished scene of a frame: it writes its uniforms for the frame's
/// camera, then records its passes into the frame's radiance target, depth tested against the
/// scene's depth.
pub trait FramePass {
    /// Writes the pass's uniforms for `frame` (the writes land before the next submission).
    fn prepare(&self, gpu: &Gpu, frame: &FrameContext<'_>);

    /// Records the pass into `views` after the scene pass (depth stored).
    fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &FrameContext<'_>,
        views: FrameViews<'_>,
    );
}
