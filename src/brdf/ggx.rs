//! The specular lobe of the glTF 2.0 metallic-roughness BRDF (glTF 2.0 specification,
//! Appendix B "BRDF Implementation"):
//!
//! ```text
//! f_spec = F(V·H) · D(H) · V(L, V),   V = G₂ / (4 (N·L)(N·V))
//! D      = α² / (π ((N·H)² (α² − 1) + 1)²)                          Trowbridge–Reitz/GGX
//! V      = 0.5 / (N·L √((N·V)²(1 − α²) + α²) + N·V √((N·L)²(1 − α²) + α²))   height-correlated Smith
//! F      = F₀ + (1 − F₀)(1 − V·H)⁵                                 Schlick
//! ```
//!
//! with α = roughness². Here D and Smith's G are written in their anisotropic form (Heitz 2014,
//! "Understanding the masking-shadowing function", Eq. 72 and 86; α_x along the tangent,
//! α_y along the bitangent), which reduces to the specification's for α_x = α_y:
//! G₂ = 1 / (1 + Λ(ω_o) + Λ(ω_i)) with Λ(ω) = (−1 + √(1 + a²)) / 2,
//! a² = ((ω_x α_x)² + (ω_y α_y)²) / ω_z².
//!
//! Sampling draws visible normals (Heitz 2018, "Sampling the GGX distribution of visible
//! normals", JCGT 7(4)), whose density is D_ω_o(h) = G₁(ω_o) max(0, ω_o·h) D(h) / (ω_o·n).
//! Pure functions in the tangent frame of [`super`]; roughness is clamped by
//! [`clamp_roughness`].

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::{above, clamp_roughness};

/// The anisotropic GGX distribution D(h) = 1 / (π α_x α_y ((h_x/α_x)² + (h_y/α_y)² + h_z²)²)
/// (Heitz 2014 Eq. 72): ∫ D(h) cos θ_h dω_h = 1. 0 at or below the horizon.
pub fn d(h: Vec3, ax: f32, ay: f32) -> f32 {
    if !above(h.z) {
        return 0.0;
    }
    let (ax, ay) = (clamp_roughness(ax), clamp_roughness(ay));
    let (x, y) = (h.x / ax, h.y / ay);
    let s = x * x + y * y + h.z * h.z;
    1.0 / (PI * ax * ay * s * s)
}

/// Smith's Λ(ω) for GGX (Heitz 2014 Eq. 86), written as a² / (2 (1 + √(1 + a²))) so that it
/// keeps its precision near the normal; +∞ at or below the horizon.
pub fn lambda(w: Vec3, ax: f32, ay: f32) -> f32 {
    if !above(w.z) {
        return f32::INFINITY;
    }
    let (ax, ay) = (clamp_roughness(ax), clamp_roughness(ay));
    let (x, y) = (w.x * ax, w.y * ay);
    let a2 = (x * x + y * y) / (w.z * w.z);
    if !a2.is_finite() {
        return f32::INFINITY;
    }
    a2 / (2.0 * (1.0 + (1.0 + a2).sqrt()))
}

/// Smith's masking G₁(ω) = 1 / (1 + Λ(ω)).
pub fn g1(w: Vec3, ax: f32, ay: f32) -> f32 {
    1.0 / (1.0 + lambda(w, ax, ay))
}

/// Height-correlated masking-shadowing G₂ = 1 / (1 + Λ(ω_o) + Λ(ω_i)) (Heitz 2014 Eq. 99).
pub fn g2(wo: Vec3, wi: Vec3, ax: f32, ay: f32) -> f32 {
    1.0 / (1.0 + lambda(wo, ax, ay) + lambda(wi, ax, ay))
}

/// The visibility term V of glTF 2.0 Appendix B exactly as the specification writes it
/// (isotropic α): 0.5 / (N·L √((N·V)²(1 − α²) + α²) + N·V √((N·L)²(1 − α²) + α²)).
/// Equal to G₂ / (4 (N·L)(N·V)); kept as an independent check of [`g2`].
pub fn visibility_gltf(n_l: f32, n_v: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let v = n_l * (n_v * n_v * (1.0 - a2) + a2).sqrt();
    let l = n_v * (n_l * n_l * (1.0 - a2) + a2).sqrt();
    let s = v + l;
    if s > 0.0 { 0.5 / s } else { 0.0 }
}

/// A visible normal for the view direction `wo` (above the horizon) from `u` ∈ [0, 1)²
/// (Heitz 2018, Listing 1): the view is stretched to the α = 1 configuration, a point is
/// drawn on the projected hemisphere, and the normal is unstretched.
pub fn sample_visible_normal(wo: Vec3, ax: f32, ay: f32, u: Vec2) -> Vec3 {
    let (ax, ay) = (clamp_roughness(ax), clamp_roughness(ay));
    let vh = Vec3::new(ax * wo.x, ay * wo.y, wo.z).normalize();
    let len2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = if len2 > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / len2.sqrt()
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    let r = u.x.sqrt();
    let (s, c) = (2.0 * PI * u.y).sin_cos();
    let p1 = r * c;
    let mut p2 = r * s;
    let k = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - k) * (1.0 - p1 * p1).max(0.0).sqrt() + k * p2;
    let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    Vec3::new(ax * nh.x, ay * nh.y, nh.z.max(0.0)).normalize()
}

/// Density of [`sample_visible_normal`] w.r.t. solid angle of h:
/// D_ω_o(h) = G₁(ω_o) max(0, ω_o·h) D(h) / (ω_o·n) (Heitz 2018 Eq. 1).
pub fn visible_normal_pdf(wo: Vec3, h: Vec3, ax: f32, ay: f32) -> f32 {
    if !above(wo.z) {
        return 0.0;
    }
    g1(wo, ax, ay) * wo.dot(h).max(0.0) * d(h, ax, ay) / wo.z
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn d_matches_the_gltf_form_and_g2_the_gltf_visibility() {
        let alpha = 0.3f32;
        let wo = Vec3::new(0.5, 0.2, 0.6).normalize();
        let wi = Vec3::new(-0.3, 0.1, 0.8).normalize();
        let h = (wo + wi).normalize();
        let a2 = alpha * alpha;
        let t = h.z * h.z * (a2 - 1.0) + 1.0;
        let d_gltf = a2 / (PI * t * t);
        assert!((d(h, alpha, alpha) - d_gltf).abs() < 1e-5 * d_gltf);
        let v = g2(wo, wi, alpha, alpha) / (4.0 * wo.z * wi.z);
        let v_gltf = visibility_gltf(wi.z, wo.z, alpha);
        assert!((v - v_gltf).abs() < 1e-5 * v_gltf, "{v} vs {v_gltf}");
    }

    #[test]
    fn visible_normals_face_the_viewer() {
        let wo = Vec3::new(0.9, 0.1, 0.05).normalize();
        for j in 0..8 {
            for i in 0..8 {
                let u = Vec2::new((i as f32 + 0.5) / 8.0, (j as f32 + 0.5) / 8.0);
                let h = sample_visible_normal(wo, 0.4, 0.2, u);
                assert!((h.length() - 1.0).abs() < 1e-5 && h.z >= 0.0 && wo.dot(h) >= -1e-6);
            }
        }
    }
}
