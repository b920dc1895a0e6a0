//! The reflectance-modulation texture R (Bastos et al. §8.2.2): the directional amplitude
//! F / (π (N·L)(N·V)) of Eq. 4, tabulated over view directions, as a sphere map and, for
//! isotropic lobes, as a 1D map with its texels packed towards grazing angles (Bastos §9).
//!
//! Both maps are evaluated at the mirror configuration (L the reflection of V, so N·L = N·V
//! = cos θ and h = n): R(θ) = F(cos θ) / (π cos²θ).
//!
//! # Bounding the grazing singularity
//!
//! R grows as 1/cos²θ towards the horizon (and its texel integral diverges too, so texel
//! averaging cannot bound it). Every value is computed with cos θ replaced by
//! max(cos θ, [`C_GRAZING`]), C_GRAZING = 1/32 (θ ≈ 88.2°): R ≤ 1024 F/π ≈ 326 F. Beyond
//! that angle a surface is seen within 1.8° of edge-on, where a screen pixel spans a strip
//! of reflector too thin for the amplitude to matter against filtering. The 1D map's
//! parameter starts exactly at C_GRAZING, so clamp-to-edge addressing applies the same bound.
//!
//! # Channels
//!
//! - `R`: Bastos's modulation, as above (per steradian; combine with a kernel normalized to 1).
//! - `A`: the directional albedo ∫ f_lobe cos θ_i dω_i of the lobe (any model,
//!   [`Lobe::albedo`]) for the same view
//!   (k_s left out, view cosine bounded the same way): the energy-consistent modulation for a
//!   kernel normalized to 1, which is what a reference path tracer of the same BRDF reproduces.
//!   It depends on the azimuth for anisotropic lobes (the reason for the 2D map).
//!
//! # Layouts
//!
//! - Sphere map, S×S: texel (x, y) has disk point d = (2(x+½)/S − 1, 1 − 2(y+½)/S) (row 0 at
//!   +y, the bitangent); inside the unit disk the reflected direction is
//!   r = (d_x, d_y, √(1 − |d|²)) in the tangent frame (centre: along the normal; rim:
//!   grazing), the view direction is ω_o = (−d_x, −d_y, r_z). Texels outside the disk are 0.
//! - 1D map, N×1: texel k has s = k/(N−1) and cos θ = C + (1 − C) s², C = C_GRAZING: texels
//!   are densest at grazing angles, where R varies fastest, and the first and last texel
//!   centres sit exactly at the bound and at normal incidence. Look up with
//!   s = √((cos θ − C)/(1 − C)) ([`map_1d_coordinate`]) at texture coordinate
//!   (s (N−1) + ½)/N, clamped to the edge ([`sample_1d`] does this on the CPU).

use std::f32::consts::PI;

use glam::Vec3;
use rayon::prelude::*;

use crate::brdf::Lobe;
use crate::brdf::kurt::fresnel_schlick;

/// Smallest cosine the reflectance maps evaluate (θ ≈ 88.2°).
pub const C_GRAZING: f32 = 1.0 / 32.0;

/// R(θ) = F(cos θ) / (π cos²θ) with cos θ bounded below by [`C_GRAZING`].
pub fn bastos_modulation(r0: f32, cos_theta: f32) -> f32 {
    // A NaN cosine becomes the grazing bound.
    let c = if cos_theta >= C_GRAZING {
        cos_theta.min(1.0)
    } else {
        C_GRAZING
    };
    fresnel_schlick(r0, c) / (PI * c * c)
}

/// A tabulated reflectance map: `R` and `A` channels, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct ReflectanceMap {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Bastos's modulation per texel.
    pub r: Vec<f32>,
    /// Directional albedo per texel.
    pub albedo: Vec<f32>,
}

/// A view direction with its cosine bounded below by [`C_GRAZING`] (azimuth kept).
fn bounded_view(wo: Vec3) -> Vec3 {
    if wo.z >= C_GRAZING {
        return wo;
    }
    let xy = glam::Vec2::new(wo.x, wo.y).normalize_or(glam::Vec2::X);
    let s = (1.0 - C_GRAZING * C_GRAZING).sqrt();
    Vec3::new(xy.x * s, xy.y * s, C_GRAZING)
}

/// The sphere map of `lobe`, `size`×`size`; albedo by an `albedo_steps`² sample grid.
///
/// An isotropic lobe's albedo depends on the view's polar angle alone, so it is evaluated once
/// per distinct bounded view cosine, at azimuth 0 (as [`map_1d`] does), and shared by every
/// texel with that cosine: on a 128² map 1,083 evaluations instead of 12,892. Its azimuth only
/// turned the quadrature grid against the lobe, a difference within the grid's own error.
pub fn sphere_map(lobe: &Lobe, size: u32, albedo_steps: u32) -> ReflectanceMap {
    let s = size.max(1) as usize;
    // Each texel's view direction (bounded), or None outside the disk.
    let view = |x: usize, y: usize| -> Option<(f32, Vec3)> {
        let dx = 2.0 * (x as f32 + 0.5) / s as f32 - 1.0;
        let dy = 1.0 - 2.0 * (y as f32 + 0.5) / s as f32;
        let d2 = dx * dx + dy * dy;
        if d2 > 1.0 {
            return None;
        }
        let z = (1.0 - d2).max(0.0).sqrt();
        Some((z, bounded_view(Vec3::new(-dx, -dy, z))))
    };
    // Isotropic: the albedo of each distinct bounded cosine, sorted by its bits.
    let shared: Vec<(u32, f32)> = if lobe.is_isotropic() {
        let mut cosines: Vec<u32> = (0..s)
            .into_par_iter()
            .flat_map_iter(|y| (0..s).filter_map(move |x| view(x, y).map(|(_, wo)| wo.z.to_bits())))
            .collect();
        cosines.par_sort_unstable();
        cosines.dedup();
        cosines
            .into_par_iter()
            .map(|bits| {
                let c = f32::from_bits(bits);
                let wo = Vec3::new((1.0 - c * c).max(0.0).sqrt(), 0.0, c);
                (bits, lobe.albedo(wo, albedo_steps))
            })
            .collect()
    } else {
        Vec::new()
    };
    let albedo_of = |wo: Vec3| -> f32 {
        if shared.is_empty() {
            return lobe.albedo(wo, albedo_steps);
        }
        let bits = wo.z.to_bits();
        let k = shared
            .binary_search_by_key(&bits, |e| e.0)
            .expect("every texel's cosine was evaluated");
        shared[k].1
    };
    let rows: Vec<(Vec<f32>, Vec<f32>)> = (0..s)
        .into_par_iter()
        .map(|y| {
            let mut r = vec![0.0f32; s];
            let mut a = vec![0.0f32; s];
            for x in 0..s {
                let Some((z, wo)) = view(x, y) else {
                    continue;
                };
                r[x] = bastos_modulation(lobe.r0, z);
                a[x] = albedo_of(wo);
            }
            (r, a)
        })
        .collect();
    let (r, albedo) = rows.into_iter().fold(
        (Vec::with_capacity(s * s), Vec::with_capacity(s * s)),
        |(mut r, mut a), (rr, aa)| {
            r.extend(rr);
            a.extend(aa);
            (r, a)
        },
    );
    ReflectanceMap {
        width: s as u32,
        height: s as u32,
        r,
        albedo,
    }
}

/// cos θ at the centre of texel `k` of an `n`-texel 1D map.
pub fn map_1d_cos(k: u32, n: u32) -> f32 {
    let s = if n > 1 {
        k as f32 / (n - 1) as f32
    } else {
        1.0
    };
    C_GRAZING + (1.0 - C_GRAZING) * s * s
}

/// The 1D map's texture coordinate s ∈ [0, 1] of a view cosine (clamped to the map).
pub fn map_1d_coordinate(cos_theta: f32) -> f32 {
    ((cos_theta - C_GRAZING) / (1.0 - C_GRAZING))
        .clamp(0.0, 1.0)
        .sqrt()
}

/// The 1D map of an isotropic `lobe` (`size` texels); albedo by an `albedo_steps`² grid.
pub fn map_1d(lobe: &Lobe, size: u32, albedo_steps: u32) -> ReflectanceMap {
    let n = size.max(1);
    let (r, albedo): (Vec<f32>, Vec<f32>) = (0..n)
        .into_par_iter()
        .map(|k| {
            let c = map_1d_cos(k, n);
            let wo = Vec3::new((1.0 - c * c).max(0.0).sqrt(), 0.0, c);
            (bastos_modulation(lobe.r0, c), lobe.albedo(wo, albedo_steps))
        })
        .unzip();
    ReflectanceMap {
        width: n,
        height: 1,
        r,
        albedo,
    }
}

/// Linear lookup of a 1D map channel at view cosine `cos_theta` (clamp-to-edge).
pub fn sample_1d(values: &[f32], cos_theta: f32) -> f32 {
    let n = values.len();
    if n == 0 {
        return 0.0;
    }
    let x = map_1d_coordinate(cos_theta) * (n - 1) as f32;
    let i = (x.floor() as usize).min(n - 1);
    let j = (i + 1).min(n - 1);
    let f = x - i as f32;
    values[i] * (1.0 - f) + values[j] * f
}
