//! One glossy lobe of any model behind one interface (eval, sample, pdf, weight, albedo,
//! kernel term, mirror limit), so that consumers need no match on the model, and the BRDF
//! f_r = k_d/π + Σ k_s f_lobe (Luksch et al. Eq. 1) they build from a material.
//!
//! | model      | f_lobe                                       | D        | shadowing                        | sampling            |
//! |------------|----------------------------------------------|----------|----------------------------------|---------------------|
//! | `kurt`     | F D / (4 (ω_o·h) ((n·ω_i)(n·ω_o))^α) (Eq. 2) | Beckmann | exponent α                       | D cos θ_h (Eq. 6–7) |
//! | `ggx`      | F D G₂ / (4 (n·ω_i)(n·ω_o))                  | GGX      | Smith G₂, height-correlated      | visible normals     |
//! | `beckmann` | F D G₂ / (4 (n·ω_i)(n·ω_o))                  | Beckmann | Smith G₂ (exact Beckmann Λ)      | D cos θ_h           |
//!
//! F is Schlick's with r0 in every model; `mx`, `my` are the distribution's width along the
//! tangent and bitangent (Beckmann m, GGX α). See [`super::ggx`] and [`super::beckmann`].
//! Every method returns a finite, non-negative value for every pair of unit directions.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::cook_torrance::CookTorrance;
use super::kurt::{beckmann_half_pdf, fresnel_schlick, invert_beckmann_half, sample_beckmann_half};
use super::ndf::Ndf;
use super::{COS_FLOOR, LobeModel, above, beckmann, clamp_roughness, ggx};

/// One glossy lobe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lobe {
    /// Reflectivity k_s (linear RGB); [`Lobe::eval`] leaves it out.
    pub ks: Vec3,
    /// Fresnel reflectance at normal incidence, in [0, 1].
    pub r0: f32,
    /// Width of the distribution along the tangent (Beckmann m or GGX α).
    pub mx: f32,
    /// Width of the distribution along the bitangent.
    pub my: f32,
    /// Kurt's shadowing exponent α in [0, 1] (unused by the other models).
    pub alpha: f32,
    /// Which model.
    pub model: LobeModel,
}

impl Lobe {
    /// A white (k_s = 1) Kurt lobe.
    pub fn new(r0: f32, mx: f32, my: f32, alpha: f32) -> Lobe {
        Lobe {
            ks: Vec3::ONE,
            r0,
            mx,
            my,
            alpha,
            model: LobeModel::Kurt,
        }
    }

    /// A white lobe of `model` with widths (m_x, m_y) (Kurt: α = 0).
    pub fn of_model(model: LobeModel, r0: f32, mx: f32, my: f32) -> Lobe {
        Lobe {
            model,
            ..Lobe::new(r0, mx, my, 0.0)
        }
    }

    /// The lobe's microfacet distribution.
    pub fn ndf(&self) -> Ndf {
        match self.model {
            LobeModel::Kurt | LobeModel::Beckmann => Ndf::Beckmann,
            LobeModel::Ggx => Ndf::Ggx,
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

    /// Smith's G₂ of the microfacet models (1 for Kurt, which has none).
    fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (mx, my) = self.roughness();
        match self.model {
            LobeModel::Kurt => 1.0,
            LobeModel::Ggx => ggx::g2(wo, wi, mx, my),
            LobeModel::Beckmann => beckmann::g2(wo, wi, mx, my),
        }
    }

    /// f_lobe(ω_i, ω_o) without k_s (per steradian): Eq. 2 for Kurt, F D G₂ / (4 (n·ω_i)(n·ω_o))
    /// for the microfacet models. 0 unless both directions are above the horizon.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(h) = Self::half(wo, wi) else {
            return 0.0;
        };
        let (mx, my) = self.roughness();
        let d = self.ndf().d(h, mx, my);
        if d == 0.0 {
            return 0.0;
        }
        let oh = wo.dot(h).max(COS_FLOOR);
        if self.model != LobeModel::Kurt {
            let g = self.g2(wo, wi);
            return fresnel_schlick(self.r0, oh) * d * g
                / (4.0 * wi.z.max(COS_FLOOR) * wo.z.max(COS_FLOOR));
        }
        let shadow = if self.alpha == 0.0 {
            1.0
        } else {
            (wi.z.max(COS_FLOOR) * wo.z.max(COS_FLOOR)).powf(self.alpha)
        };
        fresnel_schlick(self.r0, oh) * d / (4.0 * oh * shadow)
    }

    /// An incident direction for viewing direction `wo`: a half vector (Kurt and Beckmann:
    /// from D cos θ_h, Luksch Eq. 6–7; GGX: a visible normal), reflected
    /// (ω_i = 2(ω_o·h)h − ω_o). `None` when `wo` is not above the horizon or the reflection
    /// falls below it (that probability mass is missing from [`Lobe::pdf`]).
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        if !above(wo.z) {
            return None;
        }
        let (mx, my) = self.roughness();
        let h = match self.model {
            LobeModel::Kurt | LobeModel::Beckmann => sample_beckmann_half(mx, my, u),
            LobeModel::Ggx => ggx::sample_visible_normal(wo, mx, my, u),
        };
        let wi = super::reflect(wo, h);
        (wi.z > 0.0).then(|| wi.normalize())
    }

    /// Density of [`Lobe::sample`] w.r.t. solid angle of ω_i: the half-vector density over
    /// 4 (ω_o·h). Kurt and Beckmann: D(h) cos θ_h / (4 ω_o·h) (Luksch Eq. 10); GGX:
    /// G₁(ω_o) D(h) / (4 n·ω_o) (Heitz 2018 Eq. 17).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(h) = Self::half(wo, wi) else {
            return 0.0;
        };
        let (mx, my) = self.roughness();
        let ph = match self.model {
            LobeModel::Kurt | LobeModel::Beckmann => beckmann_half_pdf(mx, my, h),
            LobeModel::Ggx => ggx::visible_normal_pdf(wo, h, mx, my),
        };
        ph / (4.0 * wo.dot(h).max(COS_FLOOR))
    }

    /// The `u` that [`Lobe::sample`] maps to `wi` for `wo`, or `None` where the density is 0
    /// or the sampler has no inverse here (GGX's visible normals).
    pub fn invert(&self, wo: Vec3, wi: Vec3) -> Option<Vec2> {
        if self.model == LobeModel::Ggx {
            return None;
        }
        let h = Self::half(wo, wi)?;
        let (mx, my) = self.roughness();
        Some(invert_beckmann_half(mx, my, h))
    }

    /// f·cos θ_i / pdf for a sample of [`Lobe::sample`], with D cancelled so that it is exact
    /// even for a mirror-like lobe:
    /// - Kurt: F(ω_o·h) (cos θ_i)^(1−α) / ((cos θ_o)^α cos θ_h);
    /// - Beckmann: F(ω_o·h) G₂ (ω_o·h) / ((n·ω_o) cos θ_h);
    /// - GGX: F(ω_o·h) G₂ / G₁(ω_o) (Heitz 2018 §4).
    pub fn sample_weight(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(h) = Self::half(wo, wi) else {
            return 0.0;
        };
        let oh = wo.dot(h).max(COS_FLOOR);
        let ci = wi.z.max(COS_FLOOR);
        let co = wo.z.max(COS_FLOOR);
        let f = fresnel_schlick(self.r0, oh);
        match self.model {
            LobeModel::Kurt => {
                let shadow = if self.alpha == 0.0 {
                    ci
                } else {
                    ci.powf(1.0 - self.alpha) / co.powf(self.alpha)
                };
                f * shadow / h.z.max(COS_FLOOR)
            }
            LobeModel::Beckmann => f * self.g2(wo, wi) * oh / (co * h.z.max(COS_FLOOR)),
            LobeModel::Ggx => {
                let (mx, my) = self.roughness();
                // G₂/G₁(ω_o) = (1 + Λ_o) / (1 + Λ_o + Λ_i): finite even where Λ_o is large.
                let lo = ggx::lambda(wo, mx, my);
                let li = ggx::lambda(wi, mx, my);
                if !lo.is_finite() || !li.is_finite() {
                    return 0.0;
                }
                f * (1.0 + lo) / (1.0 + lo + li)
            }
        }
    }

    /// Directional albedo ∫ f_lobe cos θ_i dω_i for viewing direction `wo` (k_s left out),
    /// by importance sampling on a `n × n` midpoint grid of `u` (deterministic; accumulated
    /// in f64). ≤ 1 for Kurt with α = 0 and for the microfacet models (the white furnace).
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

    /// The kernel factor of Bastos et al. 1999 Eq. 4, D·G (per steradian of h): the part that
    /// spreads light over the lobe, which [`crate::materials::kernel`] tabulates.
    /// - Kurt: Beckmann D with Cook & Torrance's V-groove G ([`CookTorrance::kernel_term`]),
    ///   the Cook–Torrance form Bastos use;
    /// - GGX, Beckmann: the model's own D and Smith G₂, so that D G₂ · F/(4 (n·ω_i)(n·ω_o))
    ///   is the lobe.
    pub fn kernel_term(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (mx, my) = self.roughness();
        if self.model == LobeModel::Kurt {
            return CookTorrance {
                r0: self.r0,
                mx,
                my,
            }
            .kernel_term(wo, wi);
        }
        let Some(h) = Self::half(wo, wi) else {
            return 0.0;
        };
        self.ndf().d(h, mx, my) * self.g2(wo, wi)
    }

    /// The directional albedo in the mirror limit (m → 0) for a view at cos θ = `c` to the
    /// normal: Kurt: F(c) c^(1−2α) (Eq. 2 with h = n and ω_i the reflection of ω_o: the
    /// sample weight above); GGX and Beckmann: F(c) (G₂ → 1 as the roughness vanishes).
    pub fn mirror_reflectance(&self, c: f32) -> f32 {
        match self.model {
            LobeModel::Kurt => {
                fresnel_schlick(self.r0, c) * c.max(1e-4).powf(1.0 - 2.0 * self.alpha)
            }
            LobeModel::Ggx | LobeModel::Beckmann => fresnel_schlick(self.r0, c),
        }
    }
}

/// Eq. 1: f_r = k_d/π + Σ k_s f_lobe, lobes of any model.
#[derive(Clone, Debug, PartialEq)]
pub struct Brdf {
    /// Diffuse reflectivity k_d.
    pub kd: Vec3,
    /// Glossy lobes.
    pub lobes: Vec<Lobe>,
}

impl Brdf {
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
