//! The two microfacet distributions glint's lobe models use, behind one interface: the
//! normalized anisotropic Beckmann distribution (Kurt and Beckmann lobes; Luksch et al.
//! Eq. 4–5) and Trowbridge–Reitz/GGX (glTF 2.0 Appendix B, Walter et al. 2007 Eq. 33).
//!
//! Both are functions of one slope-space quantity, the exponent of Luksch Eq. 5,
//! e(h) = ((h_x/m_x)² + (h_y/m_y)²) / h_z² = tan²θ_h (cos²φ_h/m_x² + sin²φ_h/m_y²):
//!
//! - Beckmann: D = exp(−e) / (π m_x m_y cos⁴θ_h), falloff q(h) = exp(−e) (Eq. 5);
//! - GGX: D = 1 / (π α_x α_y cos⁴θ_h (1 + e)²), falloff q(h) = 1/(1 + e)².
//!
//! q(h) = D(h) cos⁴θ_h / D(n) is 1 at the normal and falls towards the horizon; the regular
//! patterns (Eq. 11), the kernel's support and the lobe footprint (Eq. 14–15) cut both
//! distributions where q(h) = ξ, i.e. at e = [`Ndf::exponent_limit`]`(ξ)`.

use std::f32::consts::PI;

use glam::Vec3;

use super::clamp_roughness;
use super::kurt::{beckmann_d, beckmann_exponent, beckmann_q};

/// A microfacet normal distribution.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Ndf {
    /// The normalized anisotropic Beckmann distribution (Luksch Eq. 4).
    Beckmann,
    /// Trowbridge–Reitz/GGX.
    Ggx,
}

impl Ndf {
    /// D(h), per steradian of h, with ∫ D(h) cos θ_h dω_h = 1; 0 at or below the horizon.
    /// Roughness is clamped by [`clamp_roughness`].
    pub fn d(self, h: Vec3, mx: f32, my: f32) -> f32 {
        match self {
            Ndf::Beckmann => beckmann_d(h, mx, my),
            Ndf::Ggx => super::ggx::d(h, mx, my),
        }
    }

    /// The falloff q(h) ∈ [0, 1] (1 at the normal, 0 at or below the horizon).
    pub fn q(self, h: Vec3, mx: f32, my: f32) -> f32 {
        match self {
            Ndf::Beckmann => beckmann_q(h, mx, my),
            Ndf::Ggx => {
                let e = beckmann_exponent(h, clamp_roughness(mx), clamp_roughness(my));
                self.q_of_exponent(e)
            }
        }
    }

    /// q as a function of the exponent e (0 for e = +∞ or NaN).
    pub fn q_of_exponent(self, e: f32) -> f32 {
        if !(e >= 0.0 && e.is_finite()) {
            return if e < 0.0 { 1.0 } else { 0.0 };
        }
        match self {
            Ndf::Beckmann => (-e).exp(),
            Ndf::Ggx => {
                let s = 1.0 + e;
                1.0 / (s * s)
            }
        }
    }

    /// The exponent e at which q(h) = ξ (ξ clamped to (0, 1]): −ln ξ for Beckmann (Luksch
    /// Eq. 11), ξ^(−1/2) − 1 for GGX. tan θ_h = √e · m there along an axis of roughness m.
    pub fn exponent_limit(self, xi: f32) -> f32 {
        let xi = xi.clamp(f32::MIN_POSITIVE, 1.0);
        match self {
            Ndf::Beckmann => (-xi.ln()).max(0.0),
            Ndf::Ggx => (1.0 / xi.sqrt() - 1.0).max(0.0),
        }
    }

    /// Short name (`beckmann`, `ggx`).
    pub fn name(self) -> &'static str {
        match self {
            Ndf::Beckmann => "beckmann",
            Ndf::Ggx => "ggx",
        }
    }
}

/// D(n) of either distribution: 1/(π m_x m_y).
pub fn peak(mx: f32, my: f32) -> f32 {
    1.0 / (PI * clamp_roughness(mx) * clamp_roughness(my))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn q_is_d_cos4_over_peak_and_the_limit_inverts_q() {
        let h = Vec3::new(0.2, -0.1, 0.9).normalize();
        for ndf in [Ndf::Beckmann, Ndf::Ggx] {
            let (mx, my) = (0.3, 0.15);
            let c4 = h.z.powi(4);
            let want = ndf.d(h, mx, my) * c4 / peak(mx, my);
            assert!((ndf.q(h, mx, my) - want).abs() < 1e-5, "{ndf:?}");
            for xi in [1e-3f32, 0.1, 0.5] {
                let q = ndf.q_of_exponent(ndf.exponent_limit(xi));
                assert!((q - xi).abs() < 1e-5 * xi.max(1e-2), "{ndf:?} ξ={xi}: {q}");
            }
        }
    }
}
