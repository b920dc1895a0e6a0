//! How glossy surfaces reflect: pure functions, no I/O.
//!
//! - [`lobe`]: one glossy lobe of any model ([`Lobe`], eval/sample/pdf/albedo behind one
//!   interface) and the BRDF f_r = k_d/π + Σ k_s f_lobe ([`Brdf`]). The models:
//!   - [`kurt`]: the Kurt et al. 2010 multi-lobe BRDF as the regular-sampling paper states it
//!     (Luksch et al., Eq. 1–10): Schlick Fresnel, anisotropic normalized Beckmann D,
//!     shadowing exponent α, and importance sampling of half vectors and incident directions;
//!   - [`ggx`]: the glTF 2.0 specular lobe (Appendix B): GGX D, height-correlated Smith G,
//!     Schlick F, visible-normal sampling;
//!   - [`beckmann`]: Cook–Torrance with Beckmann D, Smith G and Schlick F (Walter et al. 2007).
//! - [`ndf`]: the Beckmann and GGX distributions behind one interface (D, falloff, cut-off).
//! - [`cook_torrance`]: the Cook–Torrance specular term as Bastos et al. 1999 split it into a
//!   kernel part D·G and a reflectance-modulation part F / (π (N·L)(N·V)) (Eq. 4).
//! - [`pattern`]: regular sample patterns in half-vector space (Luksch §5–7, Eq. 11–18).
//! - [`chi2`]: a reusable chi-square goodness-of-fit harness for direction samplers.
//!
//! Directions are unit vectors in the local tangent frame: x along the tangent (the axis of
//! roughness `mx`), y along the bitangent (`my`), z along the normal. Both ω_o (towards the
//! viewer) and ω_i (towards the light) point away from the surface.

pub mod beckmann;
pub mod chi2;
pub mod cook_torrance;
pub mod ggx;
pub mod kurt;
pub mod lobe;
mod model;
pub mod ndf;
pub mod pattern;

use glam::Vec3;

pub use lobe::{Brdf, Lobe};
pub use model::LobeModel;
pub use ndf::Ndf;

/// The BRDF of Luksch et al. Eq. 1 under its former name; its lobes may be of any model.
pub type KurtBrdf = Brdf;

/// Smallest roughness the kernels use. Smaller values (including 0) are raised to it: the
/// lobe is then far narrower than the precision of an f32 direction (6e-8 rad) permits
/// resolving anyway, and `1/m²` stays finite. Everything degrades to the mirror smoothly.
pub const M_FLOOR: f32 = 1e-6;

/// Largest roughness the kernels use (`tan² θ / m²` and `m_x m_y` stay finite above it).
pub const M_CEIL: f32 = 1e2;

/// Floor of cosines that appear in denominators (ω_o·h, N·L, N·V). A configuration that
/// reaches it is within 1e-6 rad of the horizon: a set of measure zero for every integral,
/// but the floor keeps values finite there (at most ~1e29 for m ≥ [`M_FLOOR`]).
pub const COS_FLOOR: f32 = 1e-6;

/// Clamps a roughness into [[`M_FLOOR`], [`M_CEIL`]] (NaN becomes [`M_FLOOR`]).
pub fn clamp_roughness(m: f32) -> f32 {
    if m.is_nan() {
        M_FLOOR
    } else {
        m.clamp(M_FLOOR, M_CEIL)
    }
}

/// Whether a local direction's z (its cosine to the normal) is strictly above the horizon;
/// false for NaN, so corrupt input gives 0 rather than garbage.
pub fn above(z: f32) -> bool {
    z > 0.0
}

/// Mirror reflection of `w` about the unit vector `h`: 2 (w·h) h − w.
pub fn reflect(w: Vec3, h: Vec3) -> Vec3 {
    2.0 * w.dot(h) * h - w
}

/// A right-handed shading frame (tangent, bitangent, normal) in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Tangent: the direction of roughness `mx`.
    pub t: Vec3,
    /// Bitangent: the direction of roughness `my`.
    pub b: Vec3,
    /// Normal.
    pub n: Vec3,
}

impl Frame {
    /// A frame around unit `n` with the tangent chosen by [`crate::sampling::basis`]
    /// (fine for isotropic lobes, whose value does not depend on the tangent).
    pub fn from_normal(n: Vec3) -> Frame {
        let (t, b) = crate::sampling::basis(n);
        Frame { t, b, n }
    }

    /// A frame around unit `n` whose tangent is `tangent` made orthogonal to `n`
    /// (Gram–Schmidt); falls back to [`Frame::from_normal`] when they are parallel.
    pub fn with_tangent(n: Vec3, tangent: Vec3) -> Frame {
        let t = tangent - n * n.dot(tangent);
        // Parallel up to rounding: what is left is noise, not a direction.
        let len2 = t.length_squared();
        if len2.is_nan() || len2 <= 1e-10 * tangent.length_squared() {
            return Frame::from_normal(n);
        }
        let t = t.normalize();
        Frame {
            t,
            b: n.cross(t),
            n,
        }
    }

    /// World → local coordinates.
    pub fn to_local(&self, w: Vec3) -> Vec3 {
        Vec3::new(w.dot(self.t), w.dot(self.b), w.dot(self.n))
    }

    /// Local → world coordinates.
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_round_trip_and_handedness() {
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        for f in [
            Frame::from_normal(n),
            Frame::with_tangent(n, Vec3::X),
            Frame::with_tangent(n, n),
        ] {
            assert!((f.t.cross(f.b) - f.n).length() < 1e-5);
            let w = Vec3::new(0.1, 0.7, -0.2).normalize();
            assert!((f.to_world(f.to_local(w)) - w).length() < 1e-5);
        }
    }

    #[test]
    fn roughness_clamp_handles_zero_and_nan() {
        assert_eq!(clamp_roughness(0.0), M_FLOOR);
        assert_eq!(clamp_roughness(f32::NAN), M_FLOOR);
        assert_eq!(clamp_roughness(0.25), 0.25);
        assert_eq!(clamp_roughness(f32::INFINITY), M_CEIL);
    }
}
