//! How a lobe's reflected directions spread at each view angle, relative to how they spread
//! at normal incidence (where K is baked, Bastos §8.2.1's space-invariant kernel). No wgpu.
//!
//! Seen at θ from the normal, the reflected lobe f·cos θ_i over ω_i is not K turned towards
//! the mirror direction: a half vector tilted by δ across the plane of incidence turns the
//! reflected ray by about 2δ cos θ, one tilted within it by 2δ (ω_i = 2(ω_o·h)h − ω_o
//! differentiated at h = n), and towards the horizon the weight D G₂ (ω_o·h) / (n·ω_o) per
//! steradian of h (the lobe's f cos θ_i dω_i with dω_i = 4 (ω_o·h) dω_h, Walter et al. 2007
//! Eq. 14) falls with ω_o·h and with Smith's shadowing G₂ of ω_i, and reflections below the
//! horizon are lost: the lobe leans away from the horizon (the off-specular peak) and its
//! spread along the plane of incidence changes.
//!
//! [`LobeShape`] measures this per view cosine: the lobe's reflected directions, drawn by
//! its own sampler on a deterministic grid and weighted by [`Lobe::sample_weight`]
//! (f cos θ_i / pdf), in gnomonic coordinates about the mirror direction r (u along the plane
//! of incidence, towards higher elevation; w across it), as K's image plane is
//! ([`crate::materials::kernel`]): the weighted median of u (the lean), and the half-widths
//! (q₈₄ − q₁₆)/2 of u and w over those at normal incidence. Quantiles, not moments: GGX's
//! tails (D ∝ tan⁻⁴ θ_h) make the variance grow with the support and carry the mean with
//! them, while K keeps its central 99 % ([`super::material::KERNEL_MASS`]). For GGX α = 0.04
//! at 80° the mean of u is 1.6 times its median; on the floor of `tests/view_gltf_grazing.rs`
//! (relative RMSE against a 256-path reference) a lean of the full mean gave 0.124 and none
//! 0.123 (4 reads per tap), half the mean 0.049 and the median 0.046 (6 reads).
//!
//! The composite maps K's taps by them ([`super::filter::Grazing`]): K's offsets scaled along
//! and across the plane of incidence's trace on screen and shifted along it by the lean.

use glam::{Vec2, Vec3};

use crate::brdf::Lobe;

/// Entries of a shape table: view cosines k / (SHAPE_SIZE − 1), k = 0 … SHAPE_SIZE − 1.
pub const SHAPE_SIZE: usize = 16;

/// The smallest view cosine measured (the table's first entry is measured here).
const MIN_COS: f32 = 0.02;

/// Samples per axis of the grid the lobe is measured on.
const GRID: u32 = 96;

/// The lobe's shape at one view cosine, relative to normal incidence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeAt {
    /// Median of u (radians, towards higher elevation than the mirror direction).
    pub lean: f32,
    /// Half-width along the plane of incidence over that at normal incidence.
    pub along: f32,
    /// Half-width across the plane of incidence over that at normal incidence.
    pub across: f32,
}

impl ShapeAt {
    /// K as baked: no lean, no scaling.
    pub const NONE: ShapeAt = ShapeAt {
        lean: 0.0,
        along: 1.0,
        across: 1.0,
    };
}

/// Per view cosine, the lobe's shape ([`ShapeAt`]).
#[derive(Clone, Debug, PartialEq)]
pub struct LobeShape {
    /// [`SHAPE_SIZE`] entries at cosines k / (SHAPE_SIZE − 1).
    pub table: Vec<ShapeAt>,
}

/// Weighted statistics of the reflected directions of `lobe` seen at cosine `c`: (median of
/// u, half-width of u, half-width of w), radians; `None` when no sample reflects.
fn measure(lobe: &Lobe, c: f32) -> Option<(f64, f64, f64)> {
    let s = (1.0 - c * c).max(0.0).sqrt();
    let wo = Vec3::new(s, 0.0, c);
    let r = Vec3::new(-s, 0.0, c);
    let along = Vec3::new(c, 0.0, s);
    let mut us = Vec::with_capacity((GRID * GRID) as usize);
    let mut ws = Vec::with_capacity((GRID * GRID) as usize);
    let mut total = 0.0f64;
    for j in 0..GRID {
        for i in 0..GRID {
            let q = Vec2::new(
                (i as f32 + 0.5) / GRID as f32,
                (j as f32 + 0.5) / GRID as f32,
            );
            let Some(wi) = lobe.sample(wo, q) else {
                continue;
            };
            let weight = f64::from(lobe.sample_weight(wo, wi));
            let z = wi.dot(r);
            if weight.is_nan() || weight <= 0.0 || z <= 1e-3 {
                continue;
            }
            let u = f64::from((wi.dot(along) / z).atan());
            let w = f64::from((wi.y / z).atan());
            total += weight;
            us.push((u, weight));
            ws.push((w, weight));
        }
    }
    if total <= 0.0 {
        return None;
    }
    let quantiles = |v: &mut Vec<(f64, f64)>| {
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        let quantile = |p: f64| {
            let mut acc = 0.0;
            for (x, w) in v.iter() {
                acc += w;
                if acc >= p * total {
                    return *x;
                }
            }
            v.last().map_or(0.0, |l| l.0)
        };
        [quantile(0.16), quantile(0.5), quantile(0.84)]
    };
    let [u16, u50, u84] = quantiles(&mut us);
    let [w16, _, w84] = quantiles(&mut ws);
    Some((u50, 0.5 * (u84 - u16), 0.5 * (w84 - w16)))
}

impl LobeShape {
    /// The mirror limit of any lobe (m → 0): no lean, the same width along the plane of
    /// incidence and cos θ of it across.
    pub fn mirror_limit() -> LobeShape {
        LobeShape {
            table: (0..SHAPE_SIZE)
                .map(|k| ShapeAt {
                    lean: 0.0,
                    along: 1.0,
                    across: Self::cos_of(k).max(MIN_COS),
                })
                .collect(),
        }
    }

    /// The cosine of entry `k`.
    pub fn cos_of(k: usize) -> f32 {
        k as f32 / (SHAPE_SIZE - 1) as f32
    }

    /// The shape of `lobe` (see the module documentation); the mirror limit where the lobe
    /// is too narrow to measure (a half-width at normal incidence under 10⁻⁵ rad).
    pub fn of_lobe(lobe: &Lobe) -> LobeShape {
        let Some((_, u0, w0)) = measure(lobe, 1.0) else {
            return Self::mirror_limit();
        };
        let reference = 0.5 * (u0 + w0);
        if reference.is_nan() || reference <= 1e-5 {
            return Self::mirror_limit();
        }
        let table = (0..SHAPE_SIZE)
            .map(|k| {
                let c = Self::cos_of(k).max(MIN_COS);
                measure(lobe, c).map_or(ShapeAt::NONE, |(lean, u, w)| ShapeAt {
                    lean: lean as f32,
                    along: (u / reference) as f32,
                    across: (w / reference) as f32,
                })
            })
            .collect();
        LobeShape { table }
    }

    /// The shape at view cosine `c`, linear between entries.
    pub fn at(&self, c: f32) -> ShapeAt {
        let x = c.clamp(0.0, 1.0) * (SHAPE_SIZE - 1) as f32;
        let i = (x.floor() as usize).min(SHAPE_SIZE - 1);
        let j = (i + 1).min(SHAPE_SIZE - 1);
        let f = x - i as f32;
        let (a, b) = (self.table[i], self.table[j]);
        ShapeAt {
            lean: a.lean + (b.lean - a.lean) * f,
            along: a.along + (b.along - a.along) * f,
            across: a.across + (b.across - a.across) * f,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::desc::LobeModel;

    /// At normal incidence a lobe is K. At 80° a GGX lobe leans away from the horizon, more so
    /// the rougher it is (measured: α = 0.01 0.0012 rad, α = 0.04 0.020, α = 0.2 0.30); a
    /// narrow one narrows across the plane of incidence as cos θ (the mirror limit's Jacobian;
    /// measured 0.174 and 0.185 against cos 80° = 0.174) and keeps its width along it; a rough
    /// one narrows less (0.47: its reflected directions wrap around the mirror direction).
    #[test]
    fn a_lobe_narrows_across_and_leans_away_from_the_horizon_at_grazing() {
        let c = 80f32.to_radians().cos();
        let mut leans = Vec::new();
        for alpha in [0.01f32, 0.04, 0.2] {
            let lobe = Lobe::of_model(LobeModel::Ggx, 1.0, alpha, alpha);
            let shape = LobeShape::of_lobe(&lobe);
            let head_on = shape.at(1.0);
            assert!(head_on.lean.abs() < 0.05 * alpha, "{head_on:?}");
            assert!((head_on.along - 1.0).abs() < 0.05, "{head_on:?}");
            assert!((head_on.across - 1.0).abs() < 0.05, "{head_on:?}");
            let g = shape.at(c);
            eprintln!("GGX α = {alpha}: at 80° {g:?}");
            assert!(g.lean > 0.0 && g.lean < 2.0 * alpha, "α = {alpha}: {g:?}");
            assert!((g.along - 1.0).abs() < 0.05, "α = {alpha}: {g:?}");
            if alpha <= 0.04 {
                assert!((g.across - c).abs() < 0.1 * c, "α = {alpha}: {g:?}");
            } else {
                assert!(g.across > 1.5 * c && g.across < 1.0, "α = {alpha}: {g:?}");
            }
            leans.push(g.lean);
        }
        assert!(
            leans[0] < 0.1 * leans[1] && leans[1] < 0.1 * leans[2],
            "{leans:?}"
        );
        let m = LobeShape::mirror_limit();
        assert_eq!(m.at(1.0), ShapeAt::NONE);
        assert!((m.at(0.5).across - 0.5).abs() < 1e-6);
    }
}
