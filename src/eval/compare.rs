//! Image metrics between a test image A and a reference B: RMSE, relative RMSE, PSNR and
//! maximum error over the RGB channels of the pixels a mask keeps, and a false-colour
//! difference image.

use glam::Vec3;
use serde::Serialize;

use super::{Image, luminance};

/// Added to B² in the relative error so that black reference pixels do not dominate
/// (the "relMSE" of Rousselle et al. 2011 uses the same kind of regulariser).
pub const REL_EPSILON: f64 = 1e-2;

/// Error of A against the reference B.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Metrics {
    /// √(mean over kept pixels and channels of (A − B)²).
    pub rmse: f64,
    /// √(mean of (A − B)² / (B² + [`REL_EPSILON`])).
    pub rel_rmse: f64,
    /// 20 log₁₀(peak / RMSE) with peak the largest channel value of B (∞ when equal).
    pub psnr_db: f64,
    /// Largest |A − B| of any kept channel.
    pub max_error: f64,
    /// Number of pixels compared.
    pub pixels: u64,
}

/// Why two images cannot be compared.
#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    /// The sizes differ.
    #[error("image sizes differ: {0}×{1} vs {2}×{3}")]
    Size(usize, usize, usize, usize),
    /// The mask keeps no pixel.
    #[error("the mask keeps no pixel")]
    EmptyMask,
}

/// Compares `a` against the reference `b`; `mask` (one flag per pixel, true = compare)
/// must have the images' size when given.
pub fn compare(a: &Image, b: &Image, mask: Option<&[bool]>) -> Result<Metrics, CompareError> {
    if a.width != b.width || a.height != b.height {
        return Err(CompareError::Size(a.width, a.height, b.width, b.height));
    }
    if let Some(m) = mask
        && m.len() != a.rgb.len()
    {
        return Err(CompareError::Size(a.width, a.height, m.len(), 1));
    }
    let (mut se, mut rel, mut max, mut peak, mut n) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0u64);
    for (i, (pa, pb)) in a.rgb.iter().zip(&b.rgb).enumerate() {
        if mask.is_some_and(|m| !m[i]) {
            continue;
        }
        n += 1;
        for k in 0..3 {
            let (x, y) = (pa[k] as f64, pb[k] as f64);
            let d = x - y;
            se += d * d;
            rel += d * d / (y * y + REL_EPSILON);
            max = max.max(d.abs());
            peak = peak.max(y);
        }
    }
    if n == 0 {
        return Err(CompareError::EmptyMask);
    }
    let rmse = (se / (3 * n) as f64).sqrt();
    Ok(Metrics {
        rmse,
        rel_rmse: (rel / (3 * n) as f64).sqrt(),
        psnr_db: if rmse > 0.0 {
            20.0 * (peak / rmse).log10()
        } else {
            f64::INFINITY
        },
        max_error: max,
        pixels: n,
    })
}

/// A false-colour picture of |lum(A) − lum(B)| as 8-bit RGB: black (0) through blue, green
/// and yellow to red (at `scale`, or the largest difference when `scale` is None); pixels the
/// mask drops are grey.
pub fn diff_image(a: &Image, b: &Image, mask: Option<&[bool]>, scale: Option<f32>) -> Vec<u8> {
    let diffs: Vec<f32> = a
        .rgb
        .iter()
        .zip(&b.rgb)
        .map(|(x, y)| (luminance(*x) - luminance(*y)).abs())
        .collect();
    let top = scale
        .unwrap_or_else(|| diffs.iter().cloned().fold(0.0, f32::max))
        .max(f32::MIN_POSITIVE);
    let mut out = Vec::with_capacity(diffs.len() * 3);
    for (i, d) in diffs.iter().enumerate() {
        let c = if mask.is_some_and(|m| !m[i]) {
            Vec3::splat(0.5)
        } else {
            false_colour(d / top)
        };
        out.extend(
            c.to_array()
                .iter()
                .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8),
        );
    }
    out
}

/// Piecewise-linear ramp black → blue → green → yellow → red over t ∈ [0, 1].
pub fn false_colour(t: f32) -> Vec3 {
    const STOPS: [Vec3; 5] = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
    ];
    let x = t.clamp(0.0, 1.0) * 4.0;
    let i = (x.floor() as usize).min(3);
    STOPS[i].lerp(STOPS[i + 1], x - i as f32)
}

/// A mask from 8-bit pixels (`channels` per pixel): a pixel is kept when its first channel
/// is at least 128.
pub fn mask_from_pixels(pixels: &[u8], channels: usize) -> Vec<bool> {
    pixels
        .chunks(channels.max(1))
        .map(|p| p[0] >= 128)
        .collect()
}
