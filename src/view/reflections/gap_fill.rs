//! Gaps between image-mode splats closed in the reflected image M (`shaders/gap_fill.wgsl`),
//! after the splat pass and before M's pyramid and the composite read it.
//!
//! Where rows of splats do not meet (a surface the radiance maps saw at a grazing angle, such
//! as a bunny's underside in the mirror it sits on), M shows what lies farther behind the
//! mirror through the gap: bunny-mirror's reflection came out striped. A texel is taken for a
//! gap when, along at least [`MIN_AXES`] of the 4 axes (horizontal, vertical, both diagonals),
//! a texel nearer the mirror ([`NEARER`]) lies within [`GAP_RADIUS`] on both sides; it then
//! takes the mean of those nearer texels. A background texel beside a silhouette has nearer
//! texels on one side only and is kept. This is image-space hole filling for point rendering
//! in the manner of Rosenthal and Linsen (2008), with M's alpha (the fraction a of the
//! reflected ray beyond the plane) as the depth: a / (1 − a) is the distance behind the plane
//! over the eye's height above it, increasing along every ray.
//!
//! [`fill`] is the CPU form the shader follows; [`fill_on_gpu`] runs the shader on an image
//! (for tests).

use glam::Vec4;

use super::splats::FILL_RING;
use crate::view::gpu::image_pass::{ImagePass, run_on_texels};
use crate::view::gpu::{Gpu, GpuError};

/// WGSL of the pass.
pub const GAP_FILL_SHADER_SOURCE: &str = include_str!("../../../shaders/gap_fill.wgsl");

/// Texels searched along each of the 8 directions: gaps up to 2·radius − 1 texels wide close.
pub const GAP_RADIUS: i32 = 3;
/// A texel is nearer when its distance behind the plane is below this fraction of the centre's.
pub const NEARER: f32 = 0.8;
/// Axes that must hold a nearer texel on both sides.
pub const MIN_AXES: u32 = 3;

fn behind(a: f32) -> f32 {
    a / (1.0 - a).max(1e-6)
}

/// M (`width` × `height`, row-major, alpha the beyond fraction, 0 where nothing was drawn)
/// with its splat gaps closed.
pub fn fill(width: u32, height: u32, texels: &[Vec4]) -> Vec<Vec4> {
    let (w, h) = (width as i32, height as i32);
    let at = |x: i32, y: i32| texels[(y * w + x) as usize];
    let mut out = texels.to_vec();
    for y in 0..h {
        for x in 0..w {
            let m = at(x, y);
            if m.w <= 0.0 {
                continue;
            }
            let limit = behind(m.w) * NEARER;
            // FILL_RING's k-th and (k + 4)-th directions are opposite: one axis.
            let found = FILL_RING.map(|(dx, dy)| {
                (1..=GAP_RADIUS)
                    .map(|r| (x + dx * r, y + dy * r))
                    .take_while(|&(qx, qy)| qx >= 0 && qy >= 0 && qx < w && qy < h)
                    .map(|(qx, qy)| at(qx, qy))
                    .find(|t| t.w > 0.0 && behind(t.w) < limit)
            });
            let (held, sum) = (0..4)
                .filter_map(|k| Some(found[k]? + found[k + 4]?))
                .fold((0, Vec4::ZERO), |(n, s), pair| (n + 1, s + pair));
            if held >= MIN_AXES {
                out[(y * w + x) as usize] = sum / (2 * held) as f32;
            }
        }
    }
    out
}

/// The pass reading `source` (M, `width` × `height`) into M with the gaps closed, which the
/// pyramid and the composite read in image mode instead of M.
pub(super) fn gap_fill_pass(
    device: &wgpu::Device,
    source: &wgpu::TextureView,
    width: u32,
    height: u32,
) -> ImagePass {
    ImagePass::new(
        device,
        "glint gap fill",
        GAP_FILL_SHADER_SOURCE,
        "fs_gap_fill",
        source,
        (width, height),
        &[],
    )
}

/// [`fill`] by the shader: `texels` (`width` × `height`, row-major) uploaded as M
/// (`HDR_FORMAT`, so each value is first rounded to f16), filled, read back.
pub fn fill_on_gpu(
    gpu: &Gpu,
    width: u32,
    height: u32,
    texels: &[Vec4],
) -> Result<Vec<Vec4>, GpuError> {
    run_on_texels(gpu, (width, height), texels, |device, source| {
        gap_fill_pass(device, source, width, height)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 9 × 9 image: a far background (beyond fraction 0.9) and a near surface (0.2).
    fn image(near: impl Fn(i32, i32) -> bool) -> Vec<Vec4> {
        (0..81)
            .map(|i| {
                if near(i % 9, i / 9) {
                    Vec4::new(1.0, 0.5, 0.25, 0.2)
                } else {
                    Vec4::new(0.0, 0.0, 1.0, 0.9)
                }
            })
            .collect()
    }

    #[test]
    fn a_one_texel_gap_between_rows_of_splats_closes() {
        let gap = |_: i32, y: i32| y != 4;
        let filled = fill(9, 9, &image(gap));
        // At the image's side only one axis sees both sides.
        for x in 1..8 {
            let t = filled[4 * 9 + x];
            assert!(
                (t - Vec4::new(1.0, 0.5, 0.25, 0.2)).length() < 1e-6,
                "{x}: {t}"
            );
        }
    }

    #[test]
    fn a_diagonal_gap_closes_too() {
        let filled = fill(9, 9, &image(|x, y| x != y));
        for k in 2..7 {
            assert!(filled[k * 9 + k].w < 0.25, "{k}: {}", filled[k * 9 + k]);
        }
    }

    #[test]
    fn a_silhouette_keeps_its_background() {
        // Near on the left half: the background beside it has nearer texels on one side.
        let src = image(|x, _| x < 4);
        assert_eq!(fill(9, 9, &src), src);
        // A near square in a far background: its corners and edges are kept too.
        let src = image(|x, y| (3..6).contains(&x) && (3..6).contains(&y));
        assert_eq!(fill(9, 9, &src), src);
    }

    #[test]
    fn a_gap_wider_than_the_radius_stays_and_empty_texels_stay_empty() {
        let wide = image(|_, y| !(2..8).contains(&y));
        assert_eq!(fill(9, 9, &wide), wide);
        let mut holes = image(|_, y| y != 4);
        holes[4 * 9 + 4] = Vec4::ZERO;
        assert_eq!(fill(9, 9, &holes)[4 * 9 + 4], Vec4::ZERO);
    }

    #[test]
    fn the_shader_constants_match() {
        let src = GAP_FILL_SHADER_SOURCE;
        assert!(src.contains(&format!("const GAP_RADIUS: i32 = {GAP_RADIUS};")));
        assert!(src.contains(&format!("const NEARER: f32 = {NEARER};")));
        assert!(src.contains(&format!("const MIN_AXES: i32 = {MIN_AXES};")));
    }
}
