//! The wgpu viewer: a bundle's scene lit by its radiosity textures, in a window or headless.
//!
//! - [`load`]: bundle → scene + radiosity map, every check done first (clear errors, no panics).
//! - [`bicubic`]: the cubic B-spline reconstruction of D, on the CPU (mirrored in the shader).
//! - [`renderer`]: the wgpu pipeline (`shaders/view.wgsl`) and offscreen targets.
//! - [`headless`]: offscreen frames, headless replay of camera paths with timings.
//! - [`replay`]: frame scheduling and timing statistics (pure).
//! - [`cpu_render`]: the CPU reference of a frame, for golden-image tests.
//! - [`radiance_maps`]: the baked radiance maps of planar reflectors and their selection for
//!   the reflected view (image-based mode, Bastos §8.1.3).
//! - [`reflections`]: glossy planar reflections, geometry- and image-based, L = kd·D +
//!   ks·(M*K)·R (issue 9).
//! - [`impostors`], [`impostor_tables`]: reflections of depth-map impostors through their SRDM
//!   (Popescu §3.1, §4.3; issue 10), the WGSL intersection and its packed tables.
//! - [`curved`]: curved reflectors by cube maps (Nielsen §3.2) and glossy curved objects by
//!   regular sampling (Luksch §6–7) (issue 10).
//! - [`window`]: the interactive winit viewer (fly camera, path playback and recording).
//! - [`gpu`]: adapter and device selection, readback.
//! - [`wgsl_layout`]: the test that a `repr(C)` struct has its WGSL twin's layout (naga).

pub mod bicubic;
pub mod billboard_tables;
pub mod cpu_render;
pub mod curved;
pub mod gpu;
pub mod headless;
pub mod impostor_tables;
pub mod impostors;
pub mod load;
pub mod radiance_maps;
pub mod reflections;
pub mod renderer;
pub mod replay;
pub mod wgsl_layout;
pub mod window;
