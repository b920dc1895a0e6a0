//! The passes that draw into a frame: the scene pass ([`renderer`], kd·D, which clears the
//! frame), the [`composite`] every pass over the finished scene draws through, and the display
//! pass ([`display`]) that maps the frame's radiance to its 8-bit target.

pub mod composite;
pub mod display;
pub mod renderer;
