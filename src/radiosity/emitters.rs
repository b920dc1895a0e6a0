//! The emissive triangles as the solver samples them, and the MIS weight it combines
//! strategies with.

use glam::{Vec2, Vec3};

use crate::scene::{AreaLight, Scene};

pub(super) use crate::colour::luminance;

/// Power heuristic weight of a strategy with `n_a` samples of density `p_a` against one with
/// `n_b` samples of density `p_b`.
pub(super) fn power(n_a: f32, p_a: f32, n_b: f32, p_b: f32) -> f32 {
    let (a, b) = ((n_a * p_a).powi(2), (n_b * p_b).powi(2));
    if a + b > 0.0 { a / (a + b) } else { 0.0 }
}

/// Point `k` of `grid × grid` stratified points on `light` (cell k mod grid, ⌊k/grid⌋ mod
/// grid), jittered by `u` in the cell.
pub(super) fn stratified_point(light: &AreaLight, k: u32, grid: u32, u: Vec2) -> Vec3 {
    let (i, j) = (k % grid, (k / grid) % grid);
    light.corner
        + light.edge_u * ((i as f32 + u.x) / grid as f32)
        + light.edge_v * ((j as f32 + u.y) / grid as f32)
}

/// Variance of the mean of `n` samples with sum `s` and sum of squares `s2`.
pub(super) fn var_of_mean(s: f64, s2: f64, n: u32) -> f64 {
    if n < 2 {
        return 0.0;
    }
    let n = n as f64;
    ((s2 - s * s / n) / (n - 1.0)).max(0.0) / n
}

/// The emissive triangles, chosen in proportion to area × luminance.
pub(super) struct Emitters {
    pub tris: Vec<u32>,
    cdf: Vec<f64>,
    /// Σ area × luminance.
    total: f64,
}

impl Emitters {
    pub fn new(scene: &Scene) -> Emitters {
        let mut tris = Vec::new();
        let mut cdf = Vec::new();
        let mut total = 0.0f64;
        for (i, t) in scene.triangles.iter().enumerate() {
            let e = scene.materials[t.material as usize].emission;
            let w = t.area() as f64 * luminance(e) as f64;
            if w > 0.0 {
                total += w;
                tris.push(i as u32);
                cdf.push(total);
            }
        }
        Emitters { tris, cdf, total }
    }

    /// The emissive triangle for `u` in [0, 1). There must be one.
    pub fn pick(&self, u: f32) -> u32 {
        let x = u as f64 * self.total;
        let k = self
            .cdf
            .partition_point(|&c| c <= x)
            .min(self.tris.len() - 1);
        self.tris[k]
    }

    /// Density (per unit area) of a point on an emissive triangle with emission `e`.
    pub fn area_pdf(&self, e: Vec3) -> f32 {
        (luminance(e) as f64 / self.total) as f32
    }
}
