//! Evaluation: a CPU reference path tracer, the same view rendered from a bake's radiosity
//! (what the viewer shows), probes of D at world points, image metrics, and sweeps of bake
//! settings that trade speed for accuracy.
//!
//! Everything here is a library call; `bin/glint-eval.rs` only parses [`cli::Args`] and calls
//! [`cli::run`].

pub mod cli;
pub mod compare;
pub mod probe;
pub mod reference;
pub mod sweep;

use glam::Vec3;

/// A linear RGB image, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width × height` pixels, row-major.
    pub rgb: Vec<Vec3>,
}

impl Image {
    /// Mean of all pixels, accumulated in f64.
    pub fn mean(&self) -> Vec3 {
        let mut s = [0.0f64; 3];
        for p in &self.rgb {
            for k in 0..3 {
                s[k] += p[k] as f64;
            }
        }
        let n = self.rgb.len().max(1) as f64;
        Vec3::new((s[0] / n) as f32, (s[1] / n) as f32, (s[2] / n) as f32)
    }

    /// Encodes as an RGB EXR (f32 channels would be larger; half keeps ~3 digits).
    pub fn to_exr(&self) -> Result<Vec<u8>, crate::image_io::ImageError> {
        crate::image_io::encode_rgb_exr(self.width, self.height, &self.rgb)
    }

    /// Decodes the R, G, B channels of an EXR.
    pub fn from_exr(bytes: &[u8]) -> Result<Image, crate::image_io::ImageError> {
        let e = crate::image_io::decode_exr(bytes)?;
        Ok(Image {
            width: e.width,
            height: e.height,
            rgb: e.rgb()?,
        })
    }
}

pub use crate::colour::luminance;
