//! The kernel texture K (Bastos et al. §8.2.1): the lobe's D·G sampled over the reflected
//! image, normalized to sum 1, for the viewer to convolve mirror images with.
//!
//! # Geometry
//!
//! The kernel is the footprint of the lobe seen along the normal (ω_o = n): texel (i, j) at
//! offset (x, y) = (i − r, r − j) texels from the centre stands for the incident direction
//! through the point (x·tan Δ, y·tan Δ, 1) of an image plane at unit distance, as in a
//! pinhole reflected image whose pixels subtend Δ at its centre. Columns run along the
//! tangent (roughness m_x), rows along the bitangent (m_y), row 0 at +y. Each texel's weight
//! is the lobe's D(h)·G ([`Lobe::kernel_term`]: Cook–Torrance's for Kurt lobes as Bastos use
//! it, [`crate::brdf::cook_torrance`]; the model's own D and Smith G₂ for GGX and Beckmann
//! lobes) times the texel's solid angle
//! (cos³ of its angle off-axis), averaged over a 4×4 sub-grid, then all weights are divided
//! by their sum. As in Bastos the kernel is space-invariant: it ignores how the lobe
//! stretches at grazing views.
//!
//! # Size from roughness
//!
//! The lobe's angular radius in the reflected image is ρ = 2 atan(√(−ln ξ_K) m_max), where
//! q(h) = ξ_K = 10⁻³ (for an isotropic lobe q(h) is uniform under Eq. 7, so exactly 99.9 % of
//! D's mass lies inside). For GGX, whose tail is heavier, the same q(h) = ξ_K
//! ([`crate::brdf::Ndf::exponent_limit`]) gives ρ = 2 atan(√(ξ_K^(−1/2) − 1) α_max), inside
//! which 1 − √ξ_K ≈ 96.8 % of an isotropic lobe's D cos θ_h mass lies (its cumulative
//! distribution is e/(1 + e)). With the finest texel angle Δ_min of the quality preset:
//! - ρ ≤ Δ_min/2 (a mirror: the lobe fits inside one texel): the identity, a 1×1 kernel of 1;
//! - otherwise r = ⌈ρ/Δ_min⌉ texels; if that exceeds the preset's largest radius r_max, the
//!   radius is r_max and Δ grows to ρ/r_max — the reflected image for such a rough material
//!   should then be rendered at that coarser pitch, which the index records as
//!   `texel_angle_rad`.

use glam::Vec3;

use crate::brdf::Lobe;

/// Fraction of q(h) at which the kernel's support ends.
pub const KERNEL_CUTOFF: f32 = 1e-3;

/// Sub-samples per texel and axis.
const SUBSAMPLES: u32 = 4;

/// How kernels are sized.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KernelSettings {
    /// Finest angle one kernel texel may subtend (radians).
    pub min_texel_angle: f32,
    /// Largest radius in texels (the kernel is at most 2 r_max + 1 wide).
    pub max_radius: u32,
}

/// A normalized kernel texture.
#[derive(Clone, Debug, PartialEq)]
pub struct Kernel {
    /// Radius r in texels: the kernel is (2r + 1)².
    pub radius: u32,
    /// Angle one texel subtends at the centre (radians).
    pub texel_angle: f32,
    /// The lobe's angular radius ρ in the reflected image (radians).
    pub lobe_radius: f32,
    /// Whether this is the identity (a mirror).
    pub identity: bool,
    /// Weights, row-major, row 0 at +y; they sum to 1.
    pub weights: Vec<f32>,
}

impl Kernel {
    /// Width and height in texels.
    pub fn size(&self) -> u32 {
        2 * self.radius + 1
    }

    /// The weight at offset (x, y) ∈ [−r, r]² (x along the tangent, y along the bitangent).
    pub fn at(&self, x: i32, y: i32) -> f32 {
        let r = self.radius as i32;
        self.weights[((r - y) * (2 * r + 1) + (x + r)) as usize]
    }
}

/// The lobe's angular radius ρ = 2 atan(√e_K m_max) in the reflected image, e_K the
/// exponent where the lobe's q(h) falls to ξ_K (−ln ξ_K for Beckmann).
pub fn lobe_radius(lobe: &Lobe) -> f32 {
    let (mx, my) = lobe.roughness();
    2.0 * (lobe.ndf().exponent_limit(KERNEL_CUTOFF).sqrt() * mx.max(my)).atan()
}

/// The kernel of `lobe` (see the module documentation for size and layout).
pub fn kernel_for(lobe: &Lobe, settings: &KernelSettings) -> Kernel {
    let rho = lobe_radius(lobe);
    let min_angle = settings.min_texel_angle.max(1e-6);
    let identity = |texel_angle| Kernel {
        radius: 0,
        texel_angle,
        lobe_radius: rho,
        identity: true,
        weights: vec![1.0],
    };
    if rho <= 0.5 * min_angle {
        return identity(min_angle);
    }
    let wanted = (rho / min_angle).ceil() as u32;
    let (radius, texel_angle) = if wanted > settings.max_radius.max(1) {
        let r = settings.max_radius.max(1);
        (r, rho / r as f32)
    } else {
        (wanted, min_angle)
    };
    let tan = texel_angle.tan() as f64;
    let r = radius as i32;
    let n = (2 * r + 1) as usize;
    let mut w = vec![0.0f64; n * n];
    for j in 0..n {
        let y = (r - j as i32) as f64;
        for i in 0..n {
            let x = (i as i32 - r) as f64;
            let mut sum = 0.0f64;
            for b in 0..SUBSAMPLES {
                let sy = (y + (b as f64 + 0.5) / SUBSAMPLES as f64 - 0.5) * tan;
                for a in 0..SUBSAMPLES {
                    let sx = (x + (a as f64 + 0.5) / SUBSAMPLES as f64 - 0.5) * tan;
                    let len2 = 1.0 + sx * sx + sy * sy;
                    let inv = 1.0 / len2.sqrt();
                    let wi = Vec3::new((sx * inv) as f32, (sy * inv) as f32, inv as f32);
                    // Solid angle of an image-plane element at unit distance: cos³ dA.
                    sum += lobe.kernel_term(Vec3::Z, wi) as f64 * inv * inv * inv;
                }
            }
            w[j * n + i] = sum;
        }
    }
    let total: f64 = w.iter().sum();
    if !(total > 0.0 && total.is_finite()) {
        return identity(texel_angle);
    }
    Kernel {
        radius,
        texel_angle,
        lobe_radius: rho,
        identity: false,
        weights: w.iter().map(|&v| (v / total) as f32).collect(),
    }
}
