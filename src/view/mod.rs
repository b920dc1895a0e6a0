//! The wgpu viewer: a bundle's scene lit by its radiosity textures, in a window or headless.
//! Everything but [`options`], [`exposure`] and [`tonemap`] needs the `view` feature.
//!
//! - [`options`]: [`options::ViewOptions`], what a frame shows, and its command-line form.
//! - [`exposure`], [`tonemap`]: how linear radiance becomes an 8-bit frame (`--exposure
//!   auto|EV`, Khronos PBR Neutral); [`display`] is that mapping's GPU pass.
//! - [`frame`]: every pass of a frame built from the options, recorded in one fixed order.
//! - [`load`]: bundle → scene + radiosity map, every check done first (clear errors, no panics).
//! - [`bicubic`]: the cubic B-spline reconstruction of D, on the CPU (mirrored in the shader).
//! - [`renderer`]: the scene pass (`shaders/view.wgsl`): kd·D from the radiosity textures.
//! - [`radiosity_textures`]: D's atlas pages as a GPU texture array.
//! - [`target`]: target formats, the offscreen target, depth and blend state every pass shares.
//! - [`build`]: builders of shader modules, render and compute pipelines, bind-group layouts
//!   and buffers.
//! - [`composite`]: the pass that adds a reflected term over the finished frame (planar,
//!   curved, impostor and recursive reflections share it).
//! - [`offscreen`]: a frame's passes drawn offscreen, timed and read back.
//! - [`headless`]: headless replay of camera paths with timings.
//! - [`replay`]: frame scheduling and timing statistics (pure).
//! - [`cpu_render`]: the CPU reference of a frame, for golden-image tests.
//! - [`radiance_maps`]: the baked radiance maps of planar reflectors and their selection for
//!   the reflected view (image-based mode, Bastos §8.1.3).
//! - [`reflections`]: glossy planar reflections, geometry- and image-based, L = kd·D +
//!   ks·(M*K)·R (Bastos et al. 1999 Eq. 2).
//! - [`impostors`], [`impostor_tables`]: reflections of depth-map impostors through their SRDM
//!   (Popescu §3.1, §4.3), the WGSL intersection and its packed tables.
//! - [`curved`]: curved reflectors by cube maps (Nielsen §3.2) and glossy curved objects by
//!   regular sampling (Luksch §6–7).
//! - [`window`]: the interactive winit viewer (fly camera, path playback and recording).
//! - [`gpu`]: adapter and device selection, GPU errors, the smoke-test triangle.
//! - [`readback`]: textures and buffers copied back to the CPU.
//! - [`probe`]: compute probes of the shaders, for tests against the CPU.
//! - [`wgsl_layout`]: the tests that a `repr(C)` struct has its WGSL twin's layout and a vertex
//!   buffer its WGSL input's locations (naga).

#[cfg(feature = "view")]
pub mod bicubic;
#[cfg(feature = "view")]
pub mod billboard_tables;
#[cfg(feature = "view")]
pub mod build;
#[cfg(feature = "view")]
pub mod cli;
#[cfg(feature = "view")]
pub mod composite;
#[cfg(feature = "view")]
pub mod cpu_render;
#[cfg(feature = "view")]
pub mod curved;
#[cfg(feature = "view")]
pub mod display;
pub mod exposure;
#[cfg(feature = "view")]
pub mod frame;
#[cfg(feature = "view")]
pub mod gpu;
#[cfg(feature = "view")]
pub mod headless;
#[cfg(feature = "view")]
pub mod impostor_tables;
#[cfg(feature = "view")]
pub mod impostors;
#[cfg(feature = "view")]
pub mod load;
#[cfg(feature = "view")]
pub mod offscreen;
pub mod options;
#[cfg(feature = "view")]
pub mod probe;
#[cfg(feature = "view")]
pub mod radiance_maps;
#[cfg(feature = "view")]
pub mod radiosity_textures;
#[cfg(feature = "view")]
pub mod readback;
#[cfg(feature = "view")]
pub mod reflections;
#[cfg(feature = "view")]
pub mod renderer;
#[cfg(feature = "view")]
pub mod replay;
#[cfg(feature = "view")]
pub mod surface_textures;
#[cfg(feature = "view")]
pub mod target;
pub mod tonemap;
#[cfg(feature = "view")]
pub mod wgsl_layout;
#[cfg(feature = "view")]
pub mod window;
