//! Bicubic reconstruction of the radiosity textures, on the CPU.
//!
//! Bastos et al. 1999 (§7, after their \[2\]: Bastos, Goslin and Zhang 1997, "Efficient radiosity
//! rendering using textures and bicubic reconstruction") draw the radiosity textures with a
//! bicubic filter instead of the hardware's bilinear one, whose C0 kinks show as Mach bands on
//! smooth light gradients. The cubic chosen here is the **uniform cubic B-spline**:
//! - its weights are never negative, so the result never rings below zero or above the
//!   brightest texel next to a sharp shadow or an emitter's edge (Catmull-Rom would, and
//!   negative radiance would have to be clamped);
//! - it is C2 continuous, so no Mach bands at all;
//! - it costs four bilinear fetches on the GPU (Sigg and Hadwiger 2005, GPU Gems 2 ch. 20),
//!   against nine for a Catmull-Rom done the same way.
//!
//! Its price is that it approximates rather than interpolates: a texel's value is blurred with
//! its neighbours' (weights 1/6, 4/6, 1/6 at a texel centre). The atlas frames every chart with
//! [`BORDER`](crate::radiosity::atlas::BORDER) = 2 texels, exactly the reach of the 4×4
//! footprint, so a lookup inside a chart never reads another chart.
//!
//! [`bspline`] is the definition (16 texel reads). [`bspline_4tap`] is the same filter written
//! as the shader `shaders/view.wgsl` computes it, four bilinear lookups at shifted positions;
//! the unit tests hold the two equal and `tests/view.rs` holds the shader to the CPU.

use glam::{Vec2, Vec3};

use crate::radiosity::RadiosityMap;
use crate::radiosity::map::bilinear;

/// The filter's weights live with the bilinear one (the bake's seam stitching needs them
/// without the viewer).
pub use crate::radiosity::map::bspline_weights;

/// The texel at integer (x, y), clamped to the page (as a clamp-to-edge sampler does).
fn texel(texels: &[Vec3], width: u32, height: u32, x: i64, y: i64) -> Vec3 {
    let xi = x.clamp(0, width as i64 - 1) as usize;
    let yi = y.clamp(0, height as i64 - 1) as usize;
    texels[yi * width as usize + xi]
}

/// Cubic B-spline reconstruction of a `width` × `height` page at continuous texel
/// coordinates `p` (texel (i, j) spans [i, i+1) × [j, j+1), its centre at i + ½), reading the
/// 4×4 texels around `p`, clamped at the page's edges. Black for an empty page.
pub fn bspline(texels: &[Vec3], width: u32, height: u32, p: Vec2) -> Vec3 {
    if width == 0 || height == 0 || texels.len() < (width as usize * height as usize) {
        return Vec3::ZERO;
    }
    let q = p - Vec2::splat(0.5);
    let i = q.floor();
    let f = q - i;
    let (wx, wy) = (bspline_weights(f.x), bspline_weights(f.y));
    let (x0, y0) = (i.x as i64 - 1, i.y as i64 - 1);
    let mut sum = Vec3::ZERO;
    for (dy, wy) in wy.iter().enumerate() {
        let mut row = Vec3::ZERO;
        for (dx, wx) in wx.iter().enumerate() {
            row += *wx * texel(texels, width, height, x0 + dx as i64, y0 + dy as i64);
        }
        sum += *wy * row;
    }
    sum
}

/// The same filter as [`bspline`] as four bilinear lookups (Sigg and Hadwiger 2005): per axis,
/// the pairs of weights (w0, w1) and (w2, w3) become one bilinear tap each, at the position
/// between the pair's two texels where linear interpolation gives the pair's weighted mean.
/// This is what `sample_radiosity` in `shaders/view.wgsl` computes with the GPU's sampler.
pub fn bspline_4tap(texels: &[Vec3], width: u32, height: u32, p: Vec2) -> Vec3 {
    if width == 0 || height == 0 || texels.len() < (width as usize * height as usize) {
        return Vec3::ZERO;
    }
    let q = p - Vec2::splat(0.5);
    let i = q.floor();
    let f = q - i;
    let (wx, wy) = (bspline_weights(f.x), bspline_weights(f.y));
    // g0 = w0 + w1 ≥ 1/6 and g1 = w2 + w3 ≥ 1/6 on [0, 1]: no division by zero.
    let g0 = Vec2::new(wx[0] + wx[1], wy[0] + wy[1]);
    let g1 = Vec2::new(wx[2] + wx[3], wy[2] + wy[3]);
    // Centres of texels i − 1 and i + 1 are at i − ½ and i + 1½.
    let h0 = i - Vec2::splat(0.5) + Vec2::new(wx[1], wy[1]) / g0;
    let h1 = i + Vec2::splat(1.5) + Vec2::new(wx[3], wy[3]) / g1;
    let s = |x: f32, y: f32| bilinear(texels, width, height, Vec2::new(x, y));
    g0.y * (g0.x * s(h0.x, h0.y) + g1.x * s(h1.x, h0.y))
        + g1.y * (g0.x * s(h0.x, h1.y) + g1.x * s(h1.x, h1.y))
}

/// D at barycentrics `bary` of `triangle`, reconstructed with the cubic B-spline: the value
/// the viewer's fragment shader computes for that surface point.
pub fn radiance(map: &RadiosityMap, triangle: u32, bary: Vec2) -> Vec3 {
    let t = triangle as usize;
    let (Some(&page), Some(c)) = (map.atlas.tri_page.get(t), map.atlas.tri_coords.get(t)) else {
        return Vec3::ZERO;
    };
    let (Some(size), Some(texels)) = (
        map.atlas.pages.get(page as usize),
        map.pages.get(page as usize),
    ) else {
        return Vec3::ZERO;
    };
    let p = c[0] * (1.0 - bary.x - bary.y) + c[1] * bary.x + c[2] * bary.y;
    bspline(texels, size.width, size.height, p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic page of varied values (an LCG; no dependency on a random crate).
    fn page(width: u32, height: u32) -> Vec<Vec3> {
        let mut s = 0x2545_f491_u32;
        let mut next = || {
            s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (s >> 8) as f32 / (1u32 << 24) as f32 * 4.0
        };
        (0..width * height)
            .map(|_| Vec3::new(next(), next(), next()))
            .collect()
    }

    #[test]
    fn weights_sum_to_one_and_are_non_negative() {
        for k in 0..=64 {
            let f = k as f32 / 64.0;
            let w = bspline_weights(f);
            assert!(w.iter().all(|&x| x >= 0.0), "{f}: {w:?}");
            assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6, "{f}: {w:?}");
        }
        // At a texel centre: 1/6, 4/6, 1/6, 0.
        let w = bspline_weights(0.0);
        assert!((w[0] - 1.0 / 6.0).abs() < 1e-7 && (w[1] - 4.0 / 6.0).abs() < 1e-7);
        assert!((w[2] - 1.0 / 6.0).abs() < 1e-7 && w[3] == 0.0);
    }

    #[test]
    fn constant_page_is_reproduced_everywhere() {
        let (w, h) = (7, 5);
        let texels = vec![Vec3::new(0.25, 1.5, 3.0); (w * h) as usize];
        for p in [
            Vec2::new(0.0, 0.0),
            Vec2::new(3.3, 2.7),
            Vec2::new(7.0, 5.0),
        ] {
            let v = bspline(&texels, w, h, p);
            assert!((v - texels[0]).abs().max_element() < 1e-6, "{p}: {v}");
        }
    }

    #[test]
    fn linear_ramp_is_reproduced_inside() {
        // A B-spline reproduces linear functions exactly (away from the clamped edges).
        let (w, h) = (16, 8);
        let texels: Vec<Vec3> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
                Vec3::new(x, y, 2.0 * x - y)
            })
            .collect();
        for p in [
            Vec2::new(4.2, 3.9),
            Vec2::new(9.75, 4.5),
            Vec2::new(6.0, 3.0),
        ] {
            let v = bspline(&texels, w, h, p);
            let want = Vec3::new(p.x, p.y, 2.0 * p.x - p.y);
            assert!((v - want).abs().max_element() < 1e-4, "{p}: {v} vs {want}");
        }
    }

    #[test]
    fn four_bilinear_taps_equal_sixteen_texel_reads() {
        let (w, h) = (9, 6);
        let texels = page(w, h);
        for j in 0..=24 {
            for i in 0..=36 {
                // Inside, on texel centres and edges, and past the page (clamped).
                let p = Vec2::new(i as f32 * 0.3 - 0.9, j as f32 * 0.3 - 0.6);
                let a = bspline(&texels, w, h, p);
                let b = bspline_4tap(&texels, w, h, p);
                assert!(
                    (a - b).abs().max_element() < 1e-5,
                    "{p}: 16 reads {a}, 4 taps {b}"
                );
            }
        }
    }

    #[test]
    fn empty_or_short_pages_give_black_not_a_panic() {
        assert_eq!(bspline(&[], 0, 0, Vec2::ONE), Vec3::ZERO);
        assert_eq!(bspline(&[Vec3::ONE], 2, 2, Vec2::ONE), Vec3::ZERO);
        assert_eq!(bspline_4tap(&[], 0, 3, Vec2::ONE), Vec3::ZERO);
    }
}
