//! Cook–Torrance with the Beckmann distribution and Smith's masking-shadowing (Walter et al.
//! 2007, "Microfacet models for refraction through rough surfaces", Eq. 20, 25–27):
//!
//! ```text
//! f(ω_i, ω_o) = F(ω_o·h) D(h) G₂(ω_o, ω_i) / (4 (n·ω_i)(n·ω_o))
//! ```
//!
//! - D: the normalized anisotropic Beckmann distribution of [`super::kurt::beckmann_d`]
//!   (the same D as the Kurt lobe: one roughness means the same micro-geometry in both);
//! - G₂ = 1 / (1 + Λ(ω_o) + Λ(ω_i)), Smith's height-correlated form (Heitz 2014 Eq. 99),
//!   with Beckmann's Λ in its exact form (Walter Eq. 27 solved for Λ; Heitz 2014 Eq. 84):
//!   Λ(a) = (erf(a) − 1)/2 + e^(−a²)/(2a√π), a = 1 / (α_ω tan θ), α_ω the roughness in the
//!   azimuth of ω, i.e. a = ω_z / √((ω_x m_x)² + (ω_y m_y)²);
//! - F: Schlick's approximation with r0.
//!
//! Sampling draws half vectors from D cos θ_h ([`super::kurt::sample_beckmann_half`],
//! Walter Eq. 28–29; Luksch Eq. 6–7), so the density is Kurt's (Luksch Eq. 10).

use glam::Vec3;

use super::{above, clamp_roughness};

/// erfc(x) for x ≥ 0 with fractional error below 1.2·10⁻⁷ (the Chebyshev fit of Press et
/// al., Numerical Recipes 2nd ed. §6.2, `erfcc`), in f64.
fn erfc(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.5 * x);
    let poly = -x * x - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    t * poly.exp()
}

/// Smith's Λ(ω) for Beckmann (exact form); 0 along the normal, +∞ at or below the horizon.
pub fn lambda(w: Vec3, mx: f32, my: f32) -> f32 {
    if !above(w.z) {
        return f32::INFINITY;
    }
    let (mx, my) = (clamp_roughness(mx) as f64, clamp_roughness(my) as f64);
    let (x, y) = (w.x as f64 * mx, w.y as f64 * my);
    let s = (x * x + y * y).sqrt();
    if s == 0.0 {
        return 0.0;
    }
    let a = w.z as f64 / s;
    // e^(−a²)/(a√π) − erfc(a), halved: both terms are e^(−a²)·O(1/a), so the difference
    // keeps the fit's relative precision of erfc.
    let l = 0.5 * ((-a * a).exp() / (a * std::f64::consts::PI.sqrt()) - erfc(a));
    l.max(0.0) as f32
}

/// Smith's masking G₁(ω) = 1 / (1 + Λ(ω)).
pub fn g1(w: Vec3, mx: f32, my: f32) -> f32 {
    1.0 / (1.0 + lambda(w, mx, my))
}

/// Height-correlated masking-shadowing G₂ = 1 / (1 + Λ(ω_o) + Λ(ω_i)).
pub fn g2(wo: Vec3, wi: Vec3, mx: f32, my: f32) -> f32 {
    1.0 / (1.0 + lambda(wo, mx, my) + lambda(wi, mx, my))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erfc_and_lambda_known_values() {
        // erfc(0.5) = 0.4795001222, erfc(2) = 0.004677734981 (Abramowitz & Stegun Table 7.1).
        assert!((erfc(0.5) - 0.479_500_122_2).abs() < 1e-7);
        assert!((erfc(2.0) - 0.004_677_734_981).abs() < 1e-9);
        // Λ(a = 1) = (erf(1) − 1)/2 + e^(−1)/(2√π) = −0.0786496 + 0.1037769 = 0.0251273.
        let w = Vec3::new(
            std::f32::consts::FRAC_1_SQRT_2,
            0.0,
            std::f32::consts::FRAC_1_SQRT_2,
        );
        assert!(
            (lambda(w, 1.0, 1.0) - 0.025_127_3).abs() < 1e-6,
            "{}",
            lambda(w, 1.0, 1.0)
        );
        assert_eq!(lambda(Vec3::Z, 0.3, 0.3), 0.0);
        assert_eq!(g1(-Vec3::Z, 0.3, 0.3), 0.0);
    }
}
