//! The wgpu viewer: a bundle's scene lit by its radiosity textures, in a window or headless.
//! Everything but [`options`], [`exposure`] and [`tonemap`] needs the `view` feature.
//!
//! What a frame shows and how it reaches the screen:
//! - [`options`]: [`options::ViewOptions`], what a frame shows, and its command-line form.
//! - [`exposure`], [`tonemap`]: how linear radiance becomes an 8-bit frame (`--exposure
//!   auto|EV`, Khronos PBR Neutral); [`passes::display`] is that mapping's GPU pass.
//! - [`load`]: bundle → scene + radiosity map, every check done first (clear errors, no panics);
//!   [`defaults`]: what it was baked for, the reflection modes a view starts with.
//! - [`frame`]: every pass of a frame built from the options, recorded in one fixed order.
//!
//! The passes, by what they draw:
//! - [`passes`]: the scene pass (kd·D), the composite every reflection draws through, the
//!   display pass, and [`passes::FramePass`], what the frame asks of a pass drawn over the scene.
//! - [`reflections`]: glossy planar reflections, geometry- and image-based, L = kd·D +
//!   ks·(M*K)·R (Bastos et al. 1999 Eq. 2), and the baked radiance maps they select from.
//! - [`impostors`]: reflections of depth-map impostors through their SRDM and of billboards
//!   (Popescu §3.1, §4.3): the CPU tables, their upload and the pass.
//! - [`curved`]: curved reflectors by cube maps (Nielsen §3.2) and glossy curved objects by
//!   regular sampling (Luksch §6–7).
//! - [`probes`]: reflection probes, the specular term of glossy surfaces no reflector declares.
//!
//! Plumbing and front ends:
//! - [`gpu`]: adapter and device selection, GPU errors, builders, targets, readback, the
//!   uploads of D and the surface textures, compute probes and the WGSL layout checks.
//! - [`window`]: the interactive winit viewer (fly camera, path playback and recording).
//! - [`headless`]: offscreen frames and headless replay of camera paths with timings.
//! - [`cli`]: `glint-view`'s command line, which opens one or the other.
//! - [`cpu`]: the CPU reference of a frame and the bicubic reconstruction of D, for tests.

#[cfg(feature = "view")]
pub mod cli;
#[cfg(feature = "view")]
pub mod cpu;
#[cfg(feature = "view")]
pub mod curved;
#[cfg(feature = "view")]
pub mod defaults;
pub mod exposure;
#[cfg(feature = "view")]
pub mod frame;
#[cfg(feature = "view")]
pub mod gpu;
#[cfg(feature = "view")]
pub mod headless;
#[cfg(feature = "view")]
pub mod impostors;
#[cfg(feature = "view")]
pub mod load;
pub mod options;
#[cfg(feature = "view")]
pub mod passes;
#[cfg(feature = "view")]
pub mod probes;
#[cfg(feature = "view")]
pub mod reflections;
pub mod tonemap;
#[cfg(feature = "view")]
pub mod window;
