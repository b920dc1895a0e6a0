//! The wgpu viewer: GPU setup, offscreen rendering and frame readback.

pub mod gpu;
