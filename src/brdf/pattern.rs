//! Regular sample patterns for glossy lobes (Luksch et al. §5–7): half vectors on equally
//! spaced concentric circles around the normal, thinned by q(h) for anisotropic lobes, with
//! the per-sample MIP level of a prefiltered environment map (Eq. 14–16) and the constant
//! half-vector density that turns them into a Monte Carlo estimator (Eq. 17–18).
//!
//! # Layout of the circles
//!
//! θ_max is where q(h) of the wider axis falls to ξ₀ (Eq. 11); the circles are spaced by
//! s₁ = θ_max/(n_c+1) or s₂ = θ_max/(n_c+2) (Eq. 12). glint reads §5 as follows:
//!
//! - spacing s₁: the first of the n_c circles is the pole itself (one sample at θ = 0), then
//!   circles at θ_k = k·s₁, k = 1 … n_c−1, the first of them with 6 samples;
//! - spacing s₂: n_c circles at θ_k = k·s₂, k = 1 … n_c, the first with 4 samples;
//! - circle k holds n_k = 2⌊n₁ sin θ_k / (2 sin θ₁) + ½⌋ samples (Eq. 13, n₁ the first
//!   circle's count), starting at φ = 0 (the tangent).
//!
//! With n_c = 3, ξ₀ = 0.1 this gives the paper's 19 samples for s₁ (1 + 6 + 12). For s₂ it
//! gives 24 (4 + 8 + 12); the paper's Fig. 4 caption says 30, which no reading of Eq. 12–13
//! produces (three circles at k·s₂ hold at most 4 + 8 + 12, four hold 34–40 for any θ_max
//! below 90°), so glint keeps the equations and reports the difference.
//!
//! Patterns are built for either distribution ([`Ndf`]): the Beckmann one of Kurt and
//! Beckmann lobes as the paper does (the functions without `_for`), or GGX, with q(h) and the
//! cut-off of [`Ndf`] in place of Eq. 5 and 11 (θ_max where GGX's q(h) = 1/(1+e)² falls to ξ₀).
//!
//! For anisotropic lobes every sample with q(h) < ξ₀ is rejected, and each circle is also
//! tried rotated by half a sample (φ offset π/n_k); the variant with the larger Σ q of its
//! kept samples wins (ties: the unrotated one).

use std::f32::consts::PI;

use glam::Vec3;

use super::kurt::beckmann_exponent;
use super::ndf::Ndf;
use super::{COS_FLOOR, clamp_roughness, reflect};

/// Which of the two spacings of Eq. 12.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Spacing {
    /// s₁ = θ_max/(n_c+1): a sample at the pole, then circles (6 samples on the first).
    S1,
    /// s₂ = θ_max/(n_c+2): circles around the pole only (4 samples on the first).
    S2,
}

impl Spacing {
    /// `"s1"` or `"s2"`.
    pub fn name(self) -> &'static str {
        match self {
            Spacing::S1 => "s1",
            Spacing::S2 => "s2",
        }
    }

    /// Samples on the first circle (n₀ in the paper).
    pub fn first_circle_samples(self) -> u32 {
        match self {
            Spacing::S1 => 6,
            Spacing::S2 => 4,
        }
    }
}

/// θ_max of Eq. 11: atan(√(−ln ξ₀) · max(m_x, m_y)), where q(h) of the wider axis is ξ₀.
pub fn theta_max(xi0: f32, mx: f32, my: f32) -> f32 {
    theta_max_for(Ndf::Beckmann, xi0, mx, my)
}

/// θ_max of Eq. 11 for distribution `ndf`: atan(√e_ξ₀ · max(m_x, m_y)) with
/// e_ξ₀ = [`Ndf::exponent_limit`]`(ξ₀)`.
pub fn theta_max_for(ndf: Ndf, xi0: f32, mx: f32, my: f32) -> f32 {
    let m = clamp_roughness(mx).max(clamp_roughness(my));
    (ndf.exponent_limit(xi0).sqrt() * m).atan()
}

/// Circle spacing of Eq. 12: θ_max/(n_c+1) for s₁, θ_max/(n_c+2) for s₂.
pub fn circle_spacing(theta_max: f32, circles: u32, spacing: Spacing) -> f32 {
    let extra = match spacing {
        Spacing::S1 => 1,
        Spacing::S2 => 2,
    };
    theta_max / (circles + extra) as f32
}

/// Samples on a circle at θ_i (Eq. 13): 2⌊n₀ sin θ_i / (2 sin θ₀) + ½⌋, the circumference
/// ratio to the first circle (θ₀, n₀ samples) rounded to an even count so that patterns stay
/// point-symmetric.
pub fn circle_count(n0: u32, theta_i: f32, theta_0: f32) -> u32 {
    let ratio = (theta_i as f64).sin() / (theta_0 as f64).sin();
    2 * (n0 as f64 * ratio / 2.0 + 0.5).floor() as u32
}

/// A regular pattern of half vectors for one lobe.
#[derive(Clone, Debug, PartialEq)]
pub struct Pattern {
    /// The distribution the pattern is built for.
    pub ndf: Ndf,
    /// Spacing used.
    pub spacing: Spacing,
    /// Number of circles n_c (for s₁ the pole counts as the first).
    pub circles: u32,
    /// Density threshold ξ₀.
    pub xi0: f32,
    /// Roughness along the tangent (as used: clamped).
    pub mx: f32,
    /// Roughness along the bitangent (as used: clamped).
    pub my: f32,
    /// θ_max (Eq. 11), radians.
    pub theta_max: f32,
    /// Circle spacing (Eq. 12), radians.
    pub step: f32,
    /// Unit half vectors in the tangent frame, circle by circle, φ increasing.
    pub half_vectors: Vec<Vec3>,
    /// p_h = (1/N) Σ D(h_i) (Eq. 18): the constant half-vector density, per steradian.
    pub pdf_constant: f32,
}

impl Pattern {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.half_vectors.len()
    }

    /// Whether the pattern has no sample (never: the pole or a circle is always kept).
    pub fn is_empty(&self) -> bool {
        self.half_vectors.is_empty()
    }

    /// Density of incident directions ω_i = reflect(ω_o, h) for this pattern (Eq. 17):
    /// p_h / (4 (h·ω_i)), per steradian of ω_i.
    pub fn incident_pdf(&self, h: Vec3, wi: Vec3) -> f32 {
        self.pdf_constant / (4.0 * h.dot(wi).max(COS_FLOOR))
    }
}

fn half_vector(theta: f32, phi: f32) -> Vec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Vec3::new(st * cp, st * sp, ct)
}

/// Builds the pattern with `circles` circles (≥ 1) and the given spacing for roughness
/// (m_x, m_y) and threshold ξ₀ ∈ (0, 1), for the Beckmann distribution.
pub fn regular_pattern(mx: f32, my: f32, xi0: f32, circles: u32, spacing: Spacing) -> Pattern {
    regular_pattern_for(Ndf::Beckmann, mx, my, xi0, circles, spacing)
}

/// [`regular_pattern`] for distribution `ndf`.
pub fn regular_pattern_for(
    ndf: Ndf,
    mx: f32,
    my: f32,
    xi0: f32,
    circles: u32,
    spacing: Spacing,
) -> Pattern {
    let (mx, my) = (clamp_roughness(mx), clamp_roughness(my));
    let circles = circles.max(1);
    let tmax = theta_max_for(ndf, xi0, mx, my);
    let step = circle_spacing(tmax, circles, spacing);
    // q(h) ≥ ξ₀ ⇔ exponent ≤ its limit (compared on the exponent: no exp rounding).
    let limit = ndf.exponent_limit(xi0);
    let isotropic = mx == my;
    let mut hs = Vec::new();
    let rings: Vec<f32> = match spacing {
        Spacing::S1 => {
            hs.push(Vec3::Z); // the pole: q = 1, always kept
            (1..circles).map(|k| k as f32 * step).collect()
        }
        Spacing::S2 => (1..=circles).map(|k| k as f32 * step).collect(),
    };
    let n1 = spacing.first_circle_samples();
    for &theta in &rings {
        let n = circle_count(n1, theta, rings[0]).max(2);
        let ring = |offset: f32| -> (Vec<Vec3>, f64) {
            let mut kept = Vec::with_capacity(n as usize);
            let mut score = 0.0f64;
            for j in 0..n {
                let h = half_vector(theta, 2.0 * PI * (j as f32 + offset) / n as f32);
                let e = beckmann_exponent(h, mx, my);
                if e <= limit {
                    kept.push(h);
                    score += match ndf {
                        Ndf::Beckmann => (-e as f64).exp(),
                        Ndf::Ggx => ndf.q_of_exponent(e) as f64,
                    };
                }
            }
            (kept, score)
        };
        let (a, score_a) = ring(0.0);
        if isotropic {
            hs.extend(a);
        } else {
            let (b, score_b) = ring(0.5);
            hs.extend(if score_b > score_a { b } else { a });
        }
    }
    let pdf_constant =
        (hs.iter().map(|&h| ndf.d(h, mx, my) as f64).sum::<f64>() / hs.len() as f64) as f32;
    Pattern {
        ndf,
        spacing,
        circles,
        xi0,
        mx,
        my,
        theta_max: tmax,
        step,
        half_vectors: hs,
        pdf_constant,
    }
}

/// The pattern whose sample count is closest to `budget`, over both spacings and
/// 1 … `max_circles` circles. Ties go to fewer samples, then s₁, then fewer circles.
/// For the Beckmann distribution.
pub fn closest_pattern(mx: f32, my: f32, xi0: f32, budget: u32, max_circles: u32) -> Pattern {
    closest_pattern_for(Ndf::Beckmann, mx, my, xi0, budget, max_circles)
}

/// [`closest_pattern`] for distribution `ndf`.
pub fn closest_pattern_for(
    ndf: Ndf,
    mx: f32,
    my: f32,
    xi0: f32,
    budget: u32,
    max_circles: u32,
) -> Pattern {
    let mut best: Option<(u32, usize, Spacing, u32)> = None;
    for spacing in [Spacing::S1, Spacing::S2] {
        for circles in 1..=max_circles.max(1) {
            let n = regular_pattern_for(ndf, mx, my, xi0, circles, spacing).len();
            let key = (n.abs_diff(budget as usize) as u32, n, spacing, circles);
            if best.is_none_or(|b| key < b) {
                best = Some(key);
            }
            // Counts grow with the number of circles: far past the budget, stop.
            if n > 2 * budget as usize + 8 {
                break;
            }
        }
    }
    let (_, _, spacing, circles) = best.expect("at least one pattern is built");
    regular_pattern_for(ndf, mx, my, xi0, circles, spacing)
}

/// Largest angle fed to `tan` in [`lobe_area`]: the ellipse's semi-axis stays ≤ ~1000.
const ALPHA_MAX: f32 = PI / 2.0 - 1e-3;

/// The area A = π u v of the lobe's elliptical cross-section at unit distance (Eq. 14–15),
/// for viewing direction `wo` (tangent frame). The extreme half vectors at the ξ₀ border
/// along x and y are reflected into ω_U, ω_V; α_U, α_V are their angles to the mirror
/// direction ω_C, and u = tan α_U, v = tan α_V. For the Beckmann distribution.
pub fn lobe_area(mx: f32, my: f32, xi0: f32, wo: Vec3) -> f32 {
    lobe_area_for(Ndf::Beckmann, mx, my, xi0, wo)
}

/// [`lobe_area`] for distribution `ndf` (the ξ₀ border at e = [`Ndf::exponent_limit`]).
pub fn lobe_area_for(ndf: Ndf, mx: f32, my: f32, xi0: f32, wo: Vec3) -> f32 {
    let (mx, my) = (clamp_roughness(mx), clamp_roughness(my));
    let r = ndf.exponent_limit(xi0).sqrt();
    let hu = Vec3::new(r * mx, 0.0, 1.0).normalize();
    let hv = Vec3::new(0.0, r * my, 1.0).normalize();
    let wc = Vec3::new(-wo.x, -wo.y, wo.z);
    let angle = |h: Vec3| -> f32 {
        let w = reflect(wo, h);
        wc.dot(w).clamp(-1.0, 1.0).acos().min(ALPHA_MAX)
    };
    let (u, v) = (angle(hu).tan(), angle(hv).tan()); // Eq. 14, 15
    PI * u * v
}

/// The MIP level of one sample (Eq. 16): pixels = A N / (4 n) · ‖ω_i/‖ω_i‖_∞‖ · 1/(ω_i·h),
/// level = log₄(pixels), clamped at 0. `face_size`² = N is the pixel count of a cube face
/// (face area 4 at unit distance), `samples` = n, `area` = A from [`lobe_area`].
///
/// As in the paper the cube-projection factor is the distance ‖ω/‖ω‖_∞‖ ∈ [1, √3] to the
/// cube along ω (the exact texel-density ratio would be its cube), and 1/(ω_i·h) widens
/// samples whose half-vector-to-direction map stretches them (Eq. 17 without its 1/4).
pub fn mip_level(area: f32, face_size: u32, samples: u32, wi: Vec3, h: Vec3) -> f32 {
    let n_pix = face_size as f32 * face_size as f32;
    let to_cube = wi.length() / wi.abs().max_element().max(f32::MIN_POSITIVE);
    let pixels = area * n_pix / (4.0 * samples.max(1) as f32) * to_cube / wi.dot(h).max(COS_FLOOR);
    (0.5 * pixels.max(1.0).log2()).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq13_counts_of_the_first_circles() {
        let s = 0.01;
        assert_eq!(circle_count(6, 2.0 * s, s), 12);
        assert_eq!(circle_count(6, 3.0 * s, s), 18);
        assert_eq!(circle_count(4, 2.0 * s, s), 8);
    }

    #[test]
    fn theta_max_matches_eq11() {
        let t = theta_max(0.1, 0.2, 0.05);
        assert!((t - (0.1f32.ln().abs().sqrt() * 0.2).atan()).abs() < 1e-6);
    }
}
