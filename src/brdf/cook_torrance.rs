//! The Cook–Torrance specular term in the form Bastos et al. 1999 use it (§8.2, Eq. 4):
//!
//! ```text
//! R_s = {D G} · {F / (π (N·L)(N·V))}
//! ```
//!
//! The first factor spreads light over the lobe: sampled over the reflected image it becomes
//! the convolution kernel K. The second factor is the directional amplitude: sampled over
//! view directions it becomes the reflectance-modulation map R. D is the anisotropic Beckmann
//! distribution of [`super::kurt::beckmann_d`] (so one material description drives both
//! models), G is Cook & Torrance's V-groove shadowing/masking, F is Schlick's with r0.
//!
//! The 1/π is the 1982 paper's constant; a normalized D with the modern 1/4 would be brighter
//! by 4/π. Only R carries it, and only its shape survives once K is normalized (see
//! `materials::reflectance`, whose albedo channel is the energy-consistent alternative).

use std::f32::consts::PI;

use glam::Vec3;

use super::COS_FLOOR;
use super::kurt::{beckmann_d, fresnel_schlick};

/// Cook & Torrance's geometric attenuation min(1, 2(n·h)(n·v)/(v·h), 2(n·h)(n·l)/(v·h)),
/// in [0, 1]; 0 when a direction is not above the horizon.
pub fn geometry_term(wo: Vec3, wi: Vec3, h: Vec3) -> f32 {
    if !(wo.z > 0.0 && wi.z > 0.0 && h.z > 0.0) {
        return 0.0;
    }
    let vh = wo.dot(h).max(COS_FLOOR);
    let g = (2.0 * h.z * wo.z / vh).min(2.0 * h.z * wi.z / vh);
    g.clamp(0.0, 1.0)
}

/// One Cook–Torrance specular lobe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CookTorrance {
    /// Fresnel reflectance at normal incidence.
    pub r0: f32,
    /// Beckmann roughness along the tangent.
    pub mx: f32,
    /// Beckmann roughness along the bitangent.
    pub my: f32,
}

impl CookTorrance {
    fn half(wo: Vec3, wi: Vec3) -> Option<Vec3> {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return None;
        }
        let s = wo + wi;
        let len2 = s.length_squared();
        (len2 > 1e-30).then(|| s / len2.sqrt())
    }

    /// The kernel factor D(h)·G (per steradian of h).
    pub fn kernel_term(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(h) = Self::half(wo, wi) else {
            return 0.0;
        };
        beckmann_d(h, self.mx, self.my) * geometry_term(wo, wi, h)
    }

    /// The reflectance-modulation factor F(ω_o·h) / (π (N·L)(N·V)); the cosines are bounded
    /// below by [`COS_FLOOR`] (callers that tabulate it bound them further).
    pub fn reflectance_term(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(h) = Self::half(wo, wi) else {
            return 0.0;
        };
        fresnel_schlick(self.r0, wo.dot(h)) / (PI * wi.z.max(COS_FLOOR) * wo.z.max(COS_FLOOR))
    }

    /// The whole specular term R_s = (D G)(F / (π (N·L)(N·V))) of Eq. 4.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.kernel_term(wo, wi) * self.reflectance_term(wo, wi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometry_is_one_at_the_mirror_direction_and_falls_at_grazing() {
        let wo = Vec3::new(0.3, 0.0, 0.95).normalize();
        let wi = Vec3::new(-wo.x, -wo.y, wo.z);
        assert_eq!(geometry_term(wo, wi, Vec3::Z), 1.0);
        // A grazing view masks: 2 (n·h)(n·v)/(v·h) ≈ 0.09.
        let wo = Vec3::new(0.999, 0.0, 0.0447).normalize();
        let h = (wo + Vec3::Z).normalize();
        let g = geometry_term(wo, Vec3::Z, h);
        assert!((0.05..0.15).contains(&g), "{g}");
    }

    #[test]
    fn eval_is_the_product_of_its_parts() {
        let ct = CookTorrance {
            r0: 0.5,
            mx: 0.2,
            my: 0.1,
        };
        let wo = Vec3::new(0.2, 0.1, 0.9).normalize();
        let wi = Vec3::new(-0.25, -0.05, 0.9).normalize();
        let p = ct.kernel_term(wo, wi) * ct.reflectance_term(wo, wi);
        assert!((ct.eval(wo, wi) - p).abs() <= 1e-6 * p);
        assert_eq!(ct.eval(wo, -wi), 0.0);
    }
}
