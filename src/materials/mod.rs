//! How glossy materials reflect (Bastos et al. §8.2, Luksch et al. §3–7): the math and file
//! formats the `materials` stage bakes and the viewer reads. No bundle writing here; the stage
//! orchestration is [`crate::bake::materials`].
//!
//! - [`kernel`]: K, D·G over the reflected image, sums to 1;
//! - [`reflectance`]: R and the albedo A as a sphere map and a grazing-dense 1D map;
//! - [`pattern_format`]: the sample-pattern table file;
//! - [`envmap`]: cube-map environment maps, their MIP pyramids and the §8 estimators;
//! - [`settings`](crate::settings::materials): the stage's settings; [`index`]: `materials/index.json`, typed, and its
//!   hash-checked reader.

pub mod capture_reads;
pub mod envmap;
pub mod index;
pub mod kernel;
pub mod pattern_format;
pub mod probes;
pub mod reflectance;
pub mod sight;

pub use crate::settings::materials::{MaterialsOverride, MaterialsSettings};
pub use index::{MaterialsIndex, MaterialsReadError};
