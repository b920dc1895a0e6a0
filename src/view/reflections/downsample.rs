//! The reflected image M drawn at [`map_factor`] × the frame's resolution and box-filtered to
//! the frame's pixels (`shaders/map_downsample.wgsl`) before the gap fill, M's pyramid and
//! the composite read it.
//!
//! The frame's multisampling smooths the edges of what the scene pass draws, but the
//! composite reads M at one texel per pixel: a near-mirror's reflection, which the lobe
//! barely blurs, kept every reflected edge stair-stepped. M drawn at twice the resolution and
//! averaged over each pixel's 2 × 2 texels is supersampling of the mirrored view, as the
//! frame's 4 samples a pixel are of the direct one.
//!
//! [`downsample`] is the CPU form the shader follows; [`downsample_on_gpu`] runs the shader on
//! an image (for tests).

use glam::Vec4;

use crate::view::gpu::image_pass::{ImagePass, run_on_texels};
use crate::view::gpu::{Gpu, GpuError};

/// WGSL of the pass.
pub const DOWNSAMPLE_SHADER_SOURCE: &str = include_str!("../../../shaders/map_downsample.wgsl");

/// M's texels per frame pixel along each axis for a frame of `samples` samples a pixel: the
/// side of the square grid of that many (4 samples: 2 × 2 texels), 1 for a frame without
/// anti-aliasing.
pub fn map_factor(samples: u32) -> u32 {
    (1..=4).rev().find(|f| f * f <= samples.max(1)).unwrap_or(1)
}

/// M at `factor` × (`width` × `height`), row-major, box-filtered to `width` × `height`: the
/// mean of each pixel's `factor` × `factor` texels that something was drawn to (alpha > 0;
/// none: empty, zero).
pub fn downsample(width: u32, height: u32, factor: u32, texels: &[Vec4]) -> Vec<Vec4> {
    let (w, f) = (width * factor, factor);
    (0..width * height)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            let (sum, n) = (0..f * f)
                .map(|k| texels[((y * f + k / f) * w + x * f + k % f) as usize])
                .filter(|t| t.w > 0.0)
                .fold((Vec4::ZERO, 0u32), |(s, n), t| (s + t, n + 1));
            if n == 0 { Vec4::ZERO } else { sum / n as f32 }
        })
        .collect()
}

/// The pass reading `source` (M at `factor` × (`width` × `height`)) into M at the frame's
/// `width` × `height`.
pub(super) fn downsample_pass(
    device: &wgpu::Device,
    source: &wgpu::TextureView,
    width: u32,
    height: u32,
    factor: u32,
) -> ImagePass {
    ImagePass::new(
        device,
        "glint reflection downsample",
        DOWNSAMPLE_SHADER_SOURCE,
        "fs_downsample",
        source,
        (width, height),
        &[("FACTOR", f64::from(factor))],
    )
}

/// [`downsample`] by the shader: `texels` (`factor` × (`width` × `height`), row-major)
/// uploaded as M (`HDR_FORMAT`, so each value is first rounded to f16), filtered, read back.
pub fn downsample_on_gpu(
    gpu: &Gpu,
    width: u32,
    height: u32,
    factor: u32,
    texels: &[Vec4],
) -> Result<Vec<Vec4>, GpuError> {
    run_on_texels(
        gpu,
        (width * factor, height * factor),
        texels,
        |device, source| downsample_pass(device, source, width, height, factor),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_factor_is_the_side_of_the_sample_grid() {
        assert_eq!(
            [0, 1, 2, 3, 4, 8, 9, 16].map(map_factor),
            [1, 1, 1, 1, 2, 2, 3, 4]
        );
    }

    #[test]
    fn a_pixel_is_the_mean_of_the_texels_drawn_to() {
        // One 2 × 2 pixel: three texels drawn to and one empty.
        let t = [
            Vec4::new(1.0, 0.0, 0.0, 0.5),
            Vec4::new(0.0, 1.0, 0.0, 0.5),
            Vec4::new(0.0, 0.0, 1.0, 0.2),
            Vec4::ZERO,
        ];
        let mean = downsample(1, 1, 2, &t)[0];
        assert!(
            (mean - Vec4::new(1.0, 1.0, 1.0, 1.2) / 3.0)
                .abs()
                .max_element()
                < 1e-6
        );
        // None drawn to: empty; factor 1 leaves M as it is.
        assert_eq!(downsample(1, 1, 2, &[Vec4::ZERO; 4]), [Vec4::ZERO]);
        assert_eq!(downsample(2, 2, 1, &t), t);
    }

    #[test]
    fn texels_are_read_from_their_own_pixel() {
        // 2 × 1 pixels at factor 2: the left pixel's texels are 1, the right one's 3.
        let row = |a: f32, b: f32| [a, a, b, b].map(Vec4::splat);
        let t: Vec<Vec4> = [row(1.0, 3.0), row(1.0, 3.0)].concat();
        assert_eq!(downsample(2, 1, 2, &t), [Vec4::ONE, Vec4::splat(3.0)]);
    }
}
