//! The Kurt et al. 2010 BRDF as written in the regular-sampling paper (Luksch et al.,
//! Eq. 1–10): a diffuse term plus lobes of
//!
//! ```text
//! f_lobe(ω_i, ω_o) = F(ω_o·h) D(h) / (4 (ω_o·h) ((ω_i·n)(ω_o·n))^α)      (Eq. 2)
//! ```
//!
//! with Schlick's Fresnel (Eq. 3) and an anisotropic, normalized Beckmann distribution
//! (Eq. 4–5), importance sampled through half vectors (Eq. 6–7) with density Eq. 10.
//!
//! Samplers come in threes (`sample_*`, `*_pdf`, `invert_*`). Every function returns a finite,
//! non-negative value for every pair of unit directions, grazing ones included: directions at
//! or below the horizon give 0, and denominators are bounded by [`COS_FLOOR`].

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::{COS_FLOOR, above, clamp_roughness};
use crate::scene::{KurtLobe, Material};

/// Beyond this exponent `exp(−e)` is below the smallest normal f32: D is 0 there. Testing it
/// first also keeps `q / cos⁴θ` from becoming 0/0 at the horizon.
const EXP_CUTOFF: f32 = 87.0;

/// Schlick's Fresnel approximation (Eq. 3): r0 + (1 − r0)(1 − u)⁵, `u` clamped to [0, 1].
pub fn fresnel_schlick(r0: f32, u: f32) -> f32 {
    let c = 1.0 - u.clamp(0.0, 1.0);
    let c2 = c * c;
    r0 + (1.0 - r0) * c2 * c2 * c
}

/// The exponent of Eq. 5, tan²θ_h (cos²φ_h / m_x² + sin²φ_h / m_y²), written in Cartesian
/// form ((h_x/m_x)² + (h_y/m_y)²) / h_z² (no trigonometry, exact at θ_h = 0).
/// +∞ for `h` on or below the horizon.
pub fn beckmann_exponent(h: Vec3, mx: f32, my: f32) -> f32 {
    if h.z <= 0.0 {
        return f32::INFINITY;
    }
    let (a, b) = (h.x / mx, h.y / my);
    (a * a + b * b) / (h.z * h.z)
}

/// q(h) of Eq. 5 (1 at the normal, falling towards the horizon). Roughness is clamped by
/// [`clamp_roughness`].
pub fn beckmann_q(h: Vec3, mx: f32, my: f32) -> f32 {
    let e = beckmann_exponent(h, clamp_roughness(mx), clamp_roughness(my));
    if e < EXP_CUTOFF { (-e).exp() } else { 0.0 }
}

/// The normalized anisotropic Beckmann distribution D(h) = q(h) / (π m_x m_y cos⁴θ_h)
/// (Eq. 4): ∫ D(h) cos θ_h dω_h = 1 over the hemisphere. 0 below the horizon.
pub fn beckmann_d(h: Vec3, mx: f32, my: f32) -> f32 {
    let (mx, my) = (clamp_roughness(mx), clamp_roughness(my));
    let e = beckmann_exponent(h, mx, my);
    if e.is_nan() || e >= EXP_CUTOFF {
        return 0.0;
    }
    let c2 = h.z * h.z;
    (-e).exp() / (PI * mx * my * c2 * c2)
}

/// A half vector distributed as D(h) cos θ_h (Eq. 6–7), from `u` ∈ [0, 1)²: ξ₁ = 1 − u.x
/// (so ξ₁ ∈ (0, 1] as Eq. 7 needs), ξ₂ = u.y.
///
/// Eq. 6 picks φ_h with tan φ_h = (m_y/m_x) tan 2πξ₂ and Eq. 7 gives
/// tan²θ_h = −ln ξ₁ / (cos²φ_h/m_x² + sin²φ_h/m_y²). Both collapse to one vector:
/// h ∝ (√(−ln ξ₁) m_x cos 2πξ₂, √(−ln ξ₁) m_y sin 2πξ₂, 1), which keeps φ_h in the quadrant of
/// 2πξ₂ (the arctangent of Eq. 6 alone would not).
pub fn sample_beckmann_half(mx: f32, my: f32, u: Vec2) -> Vec3 {
    let (mx, my) = (clamp_roughness(mx), clamp_roughness(my));
    // −ln(1 − u.x) through ln_1p: exact for small u.x.
    let r = (-(-u.x).ln_1p()).max(0.0).sqrt();
    let (s, c) = (2.0 * PI * u.y).sin_cos();
    Vec3::new(r * mx * c, r * my * s, 1.0).normalize()
}

/// Density of [`sample_beckmann_half`] w.r.t. solid angle of h: D(h) cos θ_h.
pub fn beckmann_half_pdf(mx: f32, my: f32, h: Vec3) -> f32 {
    beckmann_d(h, mx, my) * h.z.max(0.0)
}

/// The `u` that [`sample_beckmann_half`] maps to `h` (h.z > 0): u.x = 1 − q(h)
/// (Eq. 7 solved for ξ₁ gives ξ₁ = q(h)), u.y from φ: 2πξ₂ = atan2(h_y/m_y, h_x/m_x).
pub fn invert_beckmann_half(mx: f32, my: f32, h: Vec3) -> Vec2 {
    let (mx, my) = (clamp_roughness(mx), clamp_roughness(my));
    let e = beckmann_exponent(h, mx, my);
    // 1 − exp(−e) through exp_m1: exact for small e.
    let ux = if e.is_finite() { -(-e).exp_m1() } else { 1.0 };
    let mut phi = (h.y / my).atan2(h.x / mx);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let uy = phi / (2.0 * PI);
    Vec2::new(
        ux.min(1.0 - f32::EPSILON / 2.0),
        if uy >= 1.0 { 0.0 } else { uy },
    )
}

/// One glossy lobe of the Kurt et al. model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lobe {
    /// Reflectivity k_s (linear RGB); [`Lobe::eval`] leaves it out.
    pub ks: Vec3,
    /// Fresnel reflectance at normal incidence, in [0, 1].
    pub r0: f32,
    /// Beckmann roughness along the tangent.
    pub mx: f32,
    /// Beckmann roughness along the bitangent.
    pub my: f32,
    /// Shadowing exponent α in [0, 1].
    pub alpha: f32,
}

impl From<&KurtLobe> for Lobe {
    fn from(l: &KurtLobe) -> Lobe {
        Lobe {
            ks: Vec3::from_array(l.ks),
            r0: l.r0,
            mx: l.mx,
            my: l.my,
            alpha: l.alpha,
        }
    }
}

impl Lobe {
    /// A white lobe (k_s = 1).
    pub fn new(r0: f32, mx: f32, my: f32, alpha: f32) -> Lobe {
        Lobe {
            ks: Vec3::ONE,
            r0,
            mx,
            my,
            alpha,
        }
    }

    /// (m_x, m_y) as the kernels use them (clamped by [`clamp_roughness`]).
    pub fn roughness(&self) -> (f32, f32) {
        (clamp_roughness(self.mx), clamp_roughness(self.my))
    }

    /// Whether m_x = m_y.
    pub fn is_isotropic(&self) -> bool {
        self.mx == self.my
    }

    /// The half vector of (ω_o, ω_i) when both lie strictly above the horizon.
    fn half(wo: Vec3, wi: Vec3) -> Option<Vec3> {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return None;
        }
        let s = wo + wi;
        let len2 = s.length_squared();
        // Only ω_i ≈ −ω_o with both at the horizon gets here; a measure-zero set.
        if len2.is_nan() || len2 <= 1e-30 {
            return None;
        }
        Some(s / len2.sqrt())
    }

    /// f_lobe(ω_i, ω_o) of Eq. 2, without k_s (per steradian). 0 unless both directions
    /// are above the horizon.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(h) = Self::half(wo, wi) else {
            return 0.0;
        };
        let (mx, my) = self.roughness();
        let d = beckmann_d(h, mx, my);
        if d == 0.0 {
            return 0.0;
        }
        let oh = wo.dot(h).max(COS_FLOOR);
        let shadow = if self.alpha == 0.0 {
            1.0
        } else {
            (wi.z.max(COS_FLOOR) * wo.z.max(COS_FLOOR)).powf(self.alpha)
        };
        fresnel_schlick(self.r0, oh) * d / (4.0 * oh * shadow)
    }

    /// An incident direction for viewing direction `wo`: a half vector from Eq. 6–7,
    /// reflected (ω_i = 2(ω_o·h)h − ω_o). `None` when `wo` is not above the horizon or the
    /// reflection falls below it (that probability mass is missing from [`Lobe::pdf`]).
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        if !above(wo.z) {
            return None;
        }
        let (mx, my) = self.roughness();
        let h = sample_beckmann_half(mx, my, u);
        let wi = super::reflect(wo, h);
        (wi.z > 0.0).then(|| wi.normalize())
    }

    /// Density of [`Lobe::sample`] w.r.t. solid angle of ω_i (Eq. 10):
    /// q(h) / (4π m_x m_y cos³θ_h (ω_o·h)) = D(h) cos θ_h / (4 ω_o·h).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(h) = Self::half(wo, wi) else {
            return 0.0;
        };
        let (mx, my) = self.roughness();
        beckmann_half_pdf(mx, my, h) / (4.0 * wo.dot(h).max(COS_FLOOR))
    }

    /// The `u` that [`Lobe::sample`] maps to `wi` for `wo`, or `None` where the density is 0.
    pub fn invert(&self, wo: Vec3, wi: Vec3) -> Option<Vec2> {
        let h = Self::half(wo, wi)?;
        let (mx, my) = self.roughness();
        Some(invert_beckmann_half(mx, my, h))
    }

    /// f·cos θ_i / pdf for a sample of [`Lobe::sample`]: F(ω_o·h) (cos θ_i)^(1−α) /
    /// ((cos θ_o)^α cos θ_h). D cancels, so this is exact even for a mirror-like lobe.
    pub fn sample_weight(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(h) = Self::half(wo, wi) else {
            return 0.0;
        };
        let oh = wo.dot(h).max(COS_FLOOR);
        let ci = wi.z.max(COS_FLOOR);
        let co = wo.z.max(COS_FLOOR);
        let shadow = if self.alpha == 0.0 {
            ci
        } else {
            ci.powf(1.0 - self.alpha) / co.powf(self.alpha)
        };
        fresnel_schlick(self.r0, oh) * shadow / h.z.max(COS_FLOOR)
    }

    /// Directional albedo ∫ f_lobe cos θ_i dω_i for viewing direction `wo` (k_s left out),
    /// by importance sampling on a `n × n` midpoint grid of `u` (deterministic; accumulated
    /// in f64). ≤ 1 for α = 0 (the white furnace).
    pub fn albedo(&self, wo: Vec3, n: u32) -> f32 {
        let n = n.max(1);
        let mut sum = 0.0f64;
        for j in 0..n {
            for i in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                if let Some(wi) = self.sample(wo, u) {
                    sum += self.sample_weight(wo, wi) as f64;
                }
            }
        }
        (sum / (n as f64 * n as f64)) as f32
    }
}

/// Eq. 1: f_r = k_d/π + Σ k_s f_lobe.
#[derive(Clone, Debug, PartialEq)]
pub struct KurtBrdf {
    /// Diffuse reflectivity k_d.
    pub kd: Vec3,
    /// Glossy lobes.
    pub lobes: Vec<Lobe>,
}

impl From<&Material> for KurtBrdf {
    fn from(m: &Material) -> KurtBrdf {
        KurtBrdf {
            kd: m.albedo,
            lobes: m.lobes.iter().map(Lobe::from).collect(),
        }
    }
}

impl KurtBrdf {
    /// f_r(ω_i, ω_o) (Eq. 1), per steradian; 0 unless both directions are above the horizon.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return Vec3::ZERO;
        }
        self.lobes
            .iter()
            .fold(self.kd / PI, |acc, l| acc + l.ks * l.eval(wo, wi))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_ends() {
        assert_eq!(fresnel_schlick(0.04, 1.0), 0.04);
        assert_eq!(fresnel_schlick(0.04, 0.0), 1.0);
        assert_eq!(fresnel_schlick(0.3, -5.0), 1.0);
    }

    #[test]
    fn d_at_the_normal_is_one_over_pi_mx_my() {
        let d = beckmann_d(Vec3::Z, 0.1, 0.2);
        assert!((d - 1.0 / (PI * 0.02)).abs() < 1e-3 * d);
        assert_eq!(beckmann_d(Vec3::X, 0.1, 0.2), 0.0);
        assert_eq!(beckmann_d(-Vec3::Z, 0.1, 0.2), 0.0);
    }

    #[test]
    fn half_vector_round_trip_at_grid_points() {
        for (mx, my) in [(0.1, 0.1), (0.5, 0.05), (1e-4, 1e-2), (1.0, 1.0)] {
            for j in 0..9 {
                for i in 0..9 {
                    let u = Vec2::new(0.05 + 0.1 * i as f32, 0.05 + 0.1 * j as f32);
                    let h = sample_beckmann_half(mx, my, u);
                    let back = invert_beckmann_half(mx, my, h);
                    assert!(
                        (back - u).abs().max_element() < 2e-4,
                        "m=({mx},{my}) u={u} -> h={h} -> {back}"
                    );
                }
            }
        }
    }
}
