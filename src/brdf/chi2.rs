//! A chi-square goodness-of-fit harness for direction samplers: does `sample(u)` draw
//! directions with the density `pdf(ω)` claims?
//!
//! The sphere is split into `theta_bins × phi_bins` cells of equal cos θ and φ extent (odd
//! counts avoid cell borders on symmetry planes), observed counts come from `samples` draws
//! with a fixed seed, expected counts from integrating the PDF over each cell (two-point
//! Gauss–Legendre on a sub-grid). Samples the sampler rejects (`None`) form one more cell whose expectation
//! is the PDF's missing mass. Cells expecting fewer than `min_expected` samples are pooled.
//! The p-value is that of the chi-square distribution with (cells − 1) degrees of freedom;
//! [`Chi2Outcome::table`] dumps both histograms for a failure report.

use std::f64::consts::PI;

use glam::{Vec2, Vec3};

use crate::sampling::Rng;

/// Settings of one chi-square test.
#[derive(Clone, Debug)]
pub struct Chi2Test {
    /// Cells along cos θ ∈ [−1, 1] (odd is best).
    pub theta_bins: usize,
    /// Cells along φ ∈ [0, 2π) (odd is best).
    pub phi_bins: usize,
    /// Number of draws.
    pub samples: usize,
    /// Seed of the draws' random numbers.
    pub seed: u64,
    /// Cells expecting fewer draws than this are pooled into one.
    pub min_expected: f64,
    /// Sub-steps per cell and axis for integrating the PDF (two nodes each).
    pub integration_steps: usize,
}

impl Default for Chi2Test {
    fn default() -> Self {
        Chi2Test {
            theta_bins: 21,
            phi_bins: 41,
            samples: 400_000,
            seed: 0x5eed,
            min_expected: 5.0,
            integration_steps: 8,
        }
    }
}

/// The result of [`Chi2Test::run`].
#[derive(Clone, Debug)]
pub struct Chi2Outcome {
    /// The chi-square statistic over the pooled cells.
    pub statistic: f64,
    /// Degrees of freedom (pooled cells − 1).
    pub dof: usize,
    /// Probability of a statistic at least this large if the sampler matches the PDF.
    pub p_value: f64,
    /// Observed counts per cell (θ-major), then the rejected-sample cell.
    pub observed: Vec<f64>,
    /// Expected counts per cell, then the PDF's missing mass × samples.
    pub expected: Vec<f64>,
    /// Set when a cell with zero expectation received samples: the test fails outright.
    pub impossible: Option<String>,
    theta_bins: usize,
    phi_bins: usize,
}

impl Chi2Outcome {
    /// Whether the sampler passes at significance `alpha` (after any multiple-test correction
    /// the caller applies).
    pub fn passes(&self, alpha: f64) -> bool {
        self.impossible.is_none() && self.p_value >= alpha
    }

    /// Both histograms as text (rows: cos θ cells from −1 up; columns: φ cells), with the
    /// statistic: what a failing test prints.
    pub fn table(&self) -> String {
        let mut s = format!(
            "chi2 = {:.3}, dof = {}, p = {:.3e}{}\n",
            self.statistic,
            self.dof,
            self.p_value,
            self.impossible
                .as_ref()
                .map(|m| format!(" ({m})"))
                .unwrap_or_default()
        );
        for (name, v) in [("observed", &self.observed), ("expected", &self.expected)] {
            s += &format!("{name} (rejected/missing: {:.1}):\n", v[v.len() - 1]);
            for r in 0..self.theta_bins {
                let row = &v[r * self.phi_bins..(r + 1) * self.phi_bins];
                s += &row
                    .iter()
                    .map(|x| format!("{x:8.1}"))
                    .collect::<Vec<_>>()
                    .join("");
                s.push('\n');
            }
        }
        s
    }
}

impl Chi2Test {
    fn cell(&self, d: Vec3) -> usize {
        let c = (d.z as f64).clamp(-1.0, 1.0);
        let row = (((c + 1.0) / 2.0 * self.theta_bins as f64) as usize).min(self.theta_bins - 1);
        let mut phi = (d.y as f64).atan2(d.x as f64);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let col = ((phi / (2.0 * PI) * self.phi_bins as f64) as usize).min(self.phi_bins - 1);
        row * self.phi_bins + col
    }

    /// Draws `samples` directions from `sample` (given uniform numbers in [0, 1)²) and
    /// compares their histogram with `pdf` (density w.r.t. solid angle on the sphere).
    pub fn run(
        &self,
        mut sample: impl FnMut(Vec2) -> Option<Vec3>,
        pdf: impl Fn(Vec3) -> f64,
    ) -> Chi2Outcome {
        let cells = self.theta_bins * self.phi_bins;
        let mut observed = vec![0.0f64; cells + 1];
        let mut rng = Rng::new(self.seed, 0);
        for _ in 0..self.samples {
            match sample(rng.uniform2()) {
                Some(d) if d.is_finite() => observed[self.cell(d)] += 1.0,
                _ => observed[cells] += 1.0,
            }
        }
        let mut expected = vec![0.0f64; cells + 1];
        let k = self.integration_steps.max(1);
        let dc = 2.0 / self.theta_bins as f64;
        let dphi = 2.0 * PI / self.phi_bins as f64;
        // Two-point Gauss–Legendre nodes in each of the k sub-steps per axis: fourth-order
        // accurate, so sharp lobes do not leak a systematic error into the statistic.
        let gl = [0.5 - 0.5 / 3f64.sqrt(), 0.5 + 0.5 / 3f64.sqrt()];
        let nodes: Vec<f64> = (0..k)
            .flat_map(|a| gl.iter().map(move |g| (a as f64 + g) / k as f64))
            .collect();
        let mut total = 0.0;
        for r in 0..self.theta_bins {
            for c in 0..self.phi_bins {
                let mut sum = 0.0;
                for &na in &nodes {
                    let z = -1.0 + dc * (r as f64 + na);
                    let s = (1.0 - z * z).max(0.0).sqrt();
                    for &nb in &nodes {
                        let phi = dphi * (c as f64 + nb);
                        let d = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, z as f32);
                        sum += pdf(d).max(0.0);
                    }
                }
                let mass = sum * dc * dphi / (nodes.len() * nodes.len()) as f64;
                total += mass;
                expected[r * self.phi_bins + c] = mass * self.samples as f64;
            }
        }
        expected[cells] = (1.0 - total).max(0.0) * self.samples as f64;

        let mut impossible = None;
        for (i, (&o, &e)) in observed.iter().zip(&expected).enumerate() {
            if o > 0.0 && e == 0.0 {
                impossible = Some(format!("cell {i} received {o} samples but expects none"));
                break;
            }
        }
        // Pool the low cells (lowest expectation first) until the pool is large enough.
        let mut order: Vec<usize> = (0..=cells).collect();
        order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
        let (mut pool_o, mut pool_e) = (0.0, 0.0);
        let mut statistic = 0.0;
        let mut used = 0usize;
        for &i in &order {
            if expected[i] == 0.0 && observed[i] == 0.0 {
                continue;
            }
            if expected[i] < self.min_expected || pool_e > 0.0 && pool_e < self.min_expected {
                pool_o += observed[i];
                pool_e += expected[i];
                continue;
            }
            let d = observed[i] - expected[i];
            statistic += d * d / expected[i];
            used += 1;
        }
        if pool_e > 0.0 {
            let d = pool_o - pool_e;
            statistic += d * d / pool_e;
            used += 1;
        }
        let dof = used.saturating_sub(1).max(1);
        let p_value = if impossible.is_some() {
            0.0
        } else {
            gamma_q(dof as f64 / 2.0, statistic / 2.0)
        };
        Chi2Outcome {
            statistic,
            dof,
            p_value,
            observed,
            expected,
            impossible,
            theta_bins: self.theta_bins,
            phi_bins: self.phi_bins,
        }
    }
}

/// ln Γ(x) for x > 0 (Lanczos approximation, g = 7, 9 terms; |error| < 1e-13 here).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x)Γ(1−x) = π / sin(πx).
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// The regularized upper incomplete gamma function Q(a, x) = Γ(a, x)/Γ(a): the chi-square
/// survival function is Q(k/2, χ²/2). Series below a + 1, continued fraction above.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let ln_front = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        // P(a, x) = e^{−x} x^a / Γ(a+1) Σ x^n / ((a+1)…(a+n)).
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..1000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        (1.0 - sum * ln_front.exp()).clamp(0.0, 1.0)
    } else {
        // Modified Lentz evaluation of the continued fraction for Q.
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..1000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (ln_front.exp() * h).clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gamma_functions_match_known_values() {
        // Γ(5) = 24, Γ(0.5) = √π.
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - PI.sqrt().ln()).abs() < 1e-12);
        // Q(1, x) = e^{−x}; chi-square with 2 dof at 5.991 has p = 0.05.
        assert!((gamma_q(1.0, 2.0) - (-2f64).exp()).abs() < 1e-12);
        assert!((gamma_q(1.0, 5.991_464_547 / 2.0) - 0.05).abs() < 1e-9);
        // Chi-square 10 dof at 18.307 has p = 0.05 (both branches).
        assert!((gamma_q(5.0, 18.307_038 / 2.0) - 0.05).abs() < 1e-6);
        assert!((gamma_q(5.0, 3.940_299 / 2.0) - 0.95).abs() < 1e-6);
    }

    #[test]
    fn uniform_sphere_sampler_passes_and_a_biased_one_fails() {
        let test = Chi2Test {
            samples: 100_000,
            ..Chi2Test::default()
        };
        let uniform = |u: Vec2| {
            let z = 1.0 - 2.0 * u.x;
            let s = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * std::f32::consts::PI * u.y;
            Some(Vec3::new(s * phi.cos(), s * phi.sin(), z))
        };
        let pdf = |_: Vec3| 1.0 / (4.0 * PI);
        let ok = test.run(uniform, pdf);
        assert!(ok.passes(0.01), "{}", ok.table());
        let biased = |u: Vec2| uniform(Vec2::new(u.x * u.x, u.y));
        let bad = test.run(biased, pdf);
        assert!(!bad.passes(0.01), "{}", bad.table());
    }
}
