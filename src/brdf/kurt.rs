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
//! or below the horizon give 0, and denominators are bounded by [`super::COS_FLOOR`]. The lobe itself (Eq. 2, 10) is
//! [`super::Lobe`] with model `kurt`.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::clamp_roughness;

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
