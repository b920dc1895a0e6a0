//! A square depth map of normalized 1/z with background texels, and the continuous height
//! field the SRDM rows are read from.

use glam::Vec2;

use super::SrdmError;

/// Depth of a background texel (nothing was hit). Foreground depths are ≥ [`MIN_DEPTH`].
pub const BACKGROUND: f32 = -1.0;

/// Smallest foreground depth. Normalized 1/z is 0 on the yon plane; the capture keeps the
/// object strictly in front of it, and values read from the field are clamped to
/// [`MIN_DEPTH`, 1] so a stored depth is always > 0 (the SRDM marks span starts by sign).
pub const MIN_DEPTH: f32 = 1e-6;

pub use crate::settings::srdm::MAX_RESOLUTION;

/// A `w × w` depth map, row-major, row 0 at the top (see the module docs for coordinates).
#[derive(Clone, Debug, PartialEq)]
pub struct DepthMap {
    size: u32,
    depth: Vec<f32>,
    /// Per 2×2 block of texel centres ((w − 1)², block (x, y) has corners x…x+1, y…y+1):
    /// the bilinear coefficients [a, b − a, c − a, a − b − c + d] of its corners a b / c d when
    /// all four are foreground, else [`QUAD_MIXED`] or [`QUAD_BACKGROUND`] first. One 16-byte
    /// record per sample decides most samples.
    quads: Vec<[f32; 4]>,
    /// Centres (image coordinates) of the foreground texels with a background or off-map
    /// 8-neighbour: where a run of foreground samples along any line can start or end.
    boundary: Vec<Vec2>,
}

/// Fixed-point scale of sample positions: texel-centre coordinates (image position − ½) with
/// 32 fractional bits, so a row's samples are exact integer steps.
pub(crate) const FIX: f64 = 4_294_967_296.0;

/// First coefficient of a block with background and foreground corners.
const QUAD_MIXED: f32 = -1.0;
/// First coefficient of a block with four background corners.
const QUAD_BACKGROUND: f32 = -2.0;

impl DepthMap {
    /// A map from its texels: each is [`BACKGROUND`] or a depth in [[`MIN_DEPTH`], 1].
    pub fn new(size: u32, depth: Vec<f32>) -> Result<DepthMap, SrdmError> {
        if !(2..=MAX_RESOLUTION).contains(&size) {
            return Err(SrdmError::Invalid(format!(
                "a depth map of {size}×{size} texels is outside 2…{MAX_RESOLUTION}"
            )));
        }
        let n = size as usize * size as usize;
        if depth.len() != n {
            return Err(SrdmError::Invalid(format!(
                "a {size}×{size} depth map needs {n} texels, got {}",
                depth.len()
            )));
        }
        if let Some((i, d)) = depth
            .iter()
            .enumerate()
            .find(|(_, d)| **d != BACKGROUND && !(MIN_DEPTH..=1.0).contains(*d))
        {
            return Err(SrdmError::Invalid(format!(
                "texel ({}, {}) has depth {d}: not background ({BACKGROUND}) and not in [{MIN_DEPTH}, 1]",
                i % size as usize,
                i / size as usize
            )));
        }
        let w = size as usize;
        let quads = (0..(w - 1) * (w - 1))
            .map(|q| {
                let i = (q / (w - 1)) * w + q % (w - 1);
                let (a, b, c, d) = (depth[i], depth[i + 1], depth[i + w], depth[i + w + 1]);
                let covered = [a, b, c, d].iter().filter(|v| **v >= 0.0).count();
                match covered {
                    4 => [a, b - a, c - a, a - b - c + d],
                    0 => [QUAD_BACKGROUND, 0.0, 0.0, 0.0],
                    _ => [QUAD_MIXED, 0.0, 0.0, 0.0],
                }
            })
            .collect();
        let fg = |x: i64, y: i64| {
            x >= 0
                && y >= 0
                && x < w as i64
                && y < w as i64
                && depth[y as usize * w + x as usize] >= 0.0
        };
        let mut boundary = Vec::new();
        for y in 0..w as i64 {
            for x in 0..w as i64 {
                let edge = (-1..=1).any(|dy| (-1..=1).any(|dx| !fg(x + dx, y + dy)));
                if fg(x, y) && edge {
                    boundary.push(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                }
            }
        }
        Ok(DepthMap {
            size,
            depth,
            quads,
            boundary,
        })
    }

    /// A map from a function of the texel: `None` is background.
    pub fn from_fn(size: u32, f: impl Fn(u32, u32) -> Option<f32>) -> Result<DepthMap, SrdmError> {
        let depth = (0..size)
            .flat_map(|y| (0..size).map(move |x| (x, y)))
            .map(|(x, y)| f(x, y).unwrap_or(BACKGROUND))
            .collect();
        DepthMap::new(size, depth)
    }

    /// Width and height in texels.
    pub fn size(&self) -> u32 {
        self.size
    }

    /// The texels, row-major ([`BACKGROUND`] where nothing was hit).
    pub fn texels(&self) -> &[f32] {
        &self.depth
    }

    /// The depth of texel (x, y), `None` for background or outside the map.
    pub fn at(&self, x: i64, y: i64) -> Option<f32> {
        let w = self.size as i64;
        if x < 0 || y < 0 || x >= w || y >= w {
            return None;
        }
        let d = self.depth[(y * w + x) as usize];
        (d >= 0.0).then_some(d)
    }

    /// Fraction of texels that are foreground.
    pub fn coverage(&self) -> f64 {
        let fg = self.depth.iter().filter(|d| **d >= 0.0).count();
        fg as f64 / self.depth.len() as f64
    }

    /// Centres of the foreground texels that touch background or the map's edge.
    pub(crate) fn boundary(&self) -> &[Vec2] {
        &self.boundary
    }

    /// Texel bounds [x0, x1) × [y0, y1) of the foreground, `None` when all is background.
    pub fn foreground_bounds(&self) -> Option<[u32; 4]> {
        let w = self.size as usize;
        let mut b: Option<[u32; 4]> = None;
        for (i, d) in self.depth.iter().enumerate() {
            if *d >= 0.0 {
                let (x, y) = ((i % w) as u32, (i / w) as u32);
                b = Some(match b {
                    None => [x, x + 1, y, y + 1],
                    Some([x0, x1, y0, y1]) => [x0.min(x), x1.max(x + 1), y0.min(y), y1.max(y + 1)],
                });
            }
        }
        b
    }

    /// The continuous height field at image position `p`, `None` over background.
    ///
    /// Coverage is that of the texel containing p (nearest neighbour), so silhouettes are
    /// where the capture put them. The value is bilinear in the 2×2 block of texel centres
    /// around p; in the half texel along the map's border the block is the nearest one inside
    /// and the value is extrapolated, so a planar map gives a planar field everywhere. Where
    /// the block straddles a silhouette, only its foreground corners are weighted.
    /// Positions are taken in fixed point with 32 fractional bits (2.3e-10 texel), the grid a
    /// row's samples step on exactly.
    pub fn sample(&self, p: Vec2) -> Option<f32> {
        let d = self.sample_raw(p.x, p.y);
        (d >= 0.0).then_some(d)
    }

    /// [`DepthMap::sample`] without the `Option`: [`BACKGROUND`] over background.
    pub(crate) fn sample_raw(&self, px: f32, py: f32) -> f32 {
        if !(px.is_finite() && py.is_finite()) {
            return BACKGROUND;
        }
        let fixed = |v: f32| ((v as f64 - 0.5) * FIX) as i64;
        self.sample_fixed(fixed(px), fixed(py))
    }

    /// The field at texel-centre coordinates (x, y) in [`FIX`] units: the one definition,
    /// shared by construction, error statistics and the march.
    #[inline(always)]
    pub(crate) fn sample_fixed(&self, x: i64, y: i64) -> f32 {
        let limit = ((self.size - 1) as u64) << 32;
        // Inside the square of texel centres (negative values wrap to large ones).
        if (x as u64) < limit && (y as u64) < limit {
            let (bx, by) = ((x >> 32) as usize, (y >> 32) as usize);
            let [a, dx, dy, dxy] = self.quads[by * (self.size as usize - 1) + bx];
            if a >= 0.0 {
                // 24 bits of the fraction: exact in f32, so a texel centre reads its texel.
                let fx = ((x as u32) >> 8) as i32 as f32 * (1.0 / 16_777_216.0);
                let fy = ((y as u32) >> 8) as i32 as f32 * (1.0 / 16_777_216.0);
                return (a + fx * dx + fy * (dy + fx * dxy)).clamp(MIN_DEPTH, 1.0);
            }
            if a == QUAD_BACKGROUND {
                return BACKGROUND;
            }
        }
        self.sample_slow((x as f64 / FIX + 0.5) as f32, (y as f64 / FIX + 0.5) as f32)
    }

    /// The general case of the field: the map's border and silhouettes.
    #[cold]
    #[inline(never)]
    fn sample_slow(&self, px: f32, py: f32) -> f32 {
        let w = self.size as i32;
        if !(px >= 0.0 && py >= 0.0) {
            return BACKGROUND; // also NaN
        }
        // Truncation is floor for non-negative values (and avoids a libm call).
        let (tx, ty) = (px as i32, py as i32);
        if tx >= w || ty >= w || self.depth[(ty * w + tx) as usize] < 0.0 {
            return BACKGROUND;
        }
        // Texel-centre coordinates, ≥ −½ here: floor(x) = (x + 1) as i32 − 1.
        let (x, y) = (px - 0.5, py - 0.5);
        let bx = (((x + 1.0) as i32) - 1).clamp(0, w - 2);
        let by = (((y + 1.0) as i32) - 1).clamp(0, w - 2);
        let (fx, fy) = (x - bx as f32, y - by as f32);
        let i = (by * w + bx) as usize;
        let wu = w as usize;
        let (a, b, c, d) = (
            self.depth[i],
            self.depth[i + 1],
            self.depth[i + wu],
            self.depth[i + wu + 1],
        );
        let v = if a >= 0.0 && b >= 0.0 && c >= 0.0 && d >= 0.0 {
            // (1 − f)·a + f·b: exact at f = 0 and f = 1, so texel centres read back exactly.
            let top = a * (1.0 - fx) + b * fx;
            let bottom = c * (1.0 - fx) + d * fx;
            top * (1.0 - fy) + bottom * fy
        } else {
            // A silhouette: renormalized weights over the covered corners. The texel holding p
            // is a corner with weight ≥ ¼, so the sum is positive.
            let (fx, fy) = (fx.clamp(0.0, 1.0), fy.clamp(0.0, 1.0));
            let corners = [
                (a, (1.0 - fx) * (1.0 - fy)),
                (b, fx * (1.0 - fy)),
                (c, (1.0 - fx) * fy),
                (d, fx * fy),
            ];
            let (mut sum, mut weight) = (0.0f32, 0.0f32);
            for (v, wt) in corners {
                if v >= 0.0 {
                    sum += v * wt;
                    weight += wt;
                }
            }
            sum / weight
        };
        v.clamp(MIN_DEPTH, 1.0)
    }
}
