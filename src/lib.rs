//! glint: precompute toolchain and viewer for globally illuminated walkthroughs with glossy
//! reflections.
//!
//! The library holds everything; each binary in `bin/` is a thin command line over it.
//! - [`scene`]: scene.json + glTF, validated; materials; camera paths.
//! - [`settings`]: each bake stage's settings, defined once (the layering is in its docs).
//! - [`geometry`]: world-space triangles and BVH ray casting (obvhs).
//! - [`bundle`]: the versioned asset bundle (`NAME.glint/`) and its manifest.
//! - [`fuzz`]: fuzz targets for every loader and the loop that drives them.
//! - [`view`]: the wgpu viewer (feature `view`); its [`view::options`] are always built.

pub mod bake;
pub mod brdf;
pub mod bundle;
pub mod camera;
pub mod cli;
pub mod colour;
pub mod eval;
pub mod export;
pub mod fuzz;
pub mod geometry;
pub mod image_io;
pub mod lossy_path;
pub mod materials;
pub mod out_dir;
pub mod progress;
pub mod radiance;
pub mod radiosity;
pub mod sampling;
pub mod scene;
pub mod settings;
pub mod srdm;

pub mod view;
