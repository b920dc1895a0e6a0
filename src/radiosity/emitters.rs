//! The emissive triangles as the solver samples them, and the MIS weight it combines
//! strategies with.

use glam::{Vec2, Vec3};

use crate::sampling::r2;
use crate::scene::{AreaLight, Scene};

pub(super) use crate::colour::luminance;

/// Power heuristic weight of a strategy with `n_a` samples of density `p_a` against one with
/// `n_b` samples of density `p_b`.
pub(super) fn power(n_a: f32, p_a: f32, n_b: f32, p_b: f32) -> f32 {
    let (a, b) = ((n_a * p_a).powi(2), (n_b * p_b).powi(2));
    if a + b > 0.0 { a / (a + b) } else { 0.0 }
}

/// Point `k` of the R2 set shifted by `shift` on `light`: any number of points spread evenly
/// over the whole light (a ⌈√n⌉² grid's first n cells leave part of it unsampled when n is no
/// square, and weight the rest up).
pub(super) fn spread_point(light: &AreaLight, k: u32, shift: Vec2) -> Vec3 {
    let u = r2(k, shift);
    light.corner + light.edge_u * u.x + light.edge_v * u.y
}

/// Variance of the mean of `n` samples with sum `s` and sum of squares `s2`.
pub(super) fn var_of_mean(s: f64, s2: f64, n: u32) -> f64 {
    if n < 2 {
        return 0.0;
    }
    let n = n as f64;
    ((s2 - s * s / n) / (n - 1.0)).max(0.0) / n
}

/// Variance of the mean of `n` points of one shifted low-discrepancy set with sum `s` and sum of
/// squares `s2`: [`var_of_mean`] times 2.5/√n (at most 1). The set's error falls as n^-3/2
/// where the light has edges (shadows); the factor 2.5 keeps the estimate near the real spread
/// of a shadowed floor's points at the counts a bake draws
/// (`next_event::tests::the_spread_points_variance_estimate_follows_their_real_spread`).
pub(super) fn spread_var_of_mean(s: f64, s2: f64, n: u32) -> f64 {
    var_of_mean(s, s2, n) * (2.5 / (n.max(1) as f64).sqrt()).min(1.0)
}

/// The emissive triangles, chosen in proportion to area × luminance.
pub(super) struct Emitters {
    pub tris: Vec<u32>,
    /// The face normal of each of `tris`, kept: every emitter sample reads one.
    pub normals: Vec<Vec3>,
    cdf: Vec<f64>,
    /// Σ area × luminance.
    total: f64,
}

impl Emitters {
    pub fn new(scene: &Scene) -> Emitters {
        let mut tris = Vec::new();
        let mut normals = Vec::new();
        let mut cdf = Vec::new();
        let mut total = 0.0f64;
        for (i, t) in scene.triangles.iter().enumerate() {
            let e = scene.materials[t.material as usize].emission;
            let w = t.area() as f64 * luminance(e) as f64;
            if w > 0.0 {
                total += w;
                tris.push(i as u32);
                normals.push(t.face_normal());
                cdf.push(total);
            }
        }
        Emitters {
            tris,
            normals,
            cdf,
            total,
        }
    }

    /// The emissive triangle for `u` in [0, 1). There must be one.
    pub fn pick(&self, u: f32) -> u32 {
        self.tris[self.pick_spread(u).0]
    }

    /// [`Emitters::pick`] as the triangle's place in `tris`, with where `u` falls inside the
    /// triangle's share of [0, 1), as a fraction in [0, 1): a well-spread `u` then also spreads
    /// the points within each triangle.
    pub fn pick_spread(&self, u: f32) -> (usize, f32) {
        let x = u as f64 * self.total;
        let k = self
            .cdf
            .partition_point(|&c| c <= x)
            .min(self.tris.len() - 1);
        let lo = if k == 0 { 0.0 } else { self.cdf[k - 1] };
        let rest = ((x - lo) / (self.cdf[k] - lo)) as f32;
        (k, rest.clamp(0.0, 1.0 - f32::EPSILON / 2.0))
    }

    /// Density (per unit area) of a point on an emissive triangle with emission `e`.
    pub fn area_pdf(&self, e: Vec3) -> f32 {
        (luminance(e) as f64 / self.total) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::Emitters;

    #[test]
    fn a_spread_pick_is_the_pick_with_its_place_in_the_triangles_share() {
        // Triangles 4 and 9 with weights 1 and 3: [0, 0.25) picks 4, [0.25, 1) picks 9.
        let e = Emitters {
            tris: vec![4, 9],
            normals: Vec::new(),
            cdf: vec![1.0, 4.0],
            total: 4.0,
        };
        for (u, tri, along) in [
            (0.0, 4, 0.0),
            (0.125, 4, 0.5),
            (0.25, 9, 0.0),
            (0.625, 9, 0.5),
            (0.999_999, 9, 0.999_998_7),
        ] {
            let (k, a) = e.pick_spread(u);
            assert_eq!((e.tris[k], e.pick(u)), (tri, tri), "u {u}");
            assert!((a - along).abs() < 1e-5, "u {u}: {a} vs {along}");
            assert!((0.0..1.0).contains(&a));
        }
    }
}
