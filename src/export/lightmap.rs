//! What an exported lightmap texel holds and how it is encoded.
//!
//! **The quantity.** An engine shows a lightmapped surface as `base colour(x) × L(x) +
//! emissive(x)` (Babylon.js's `useLightmapAsShadowmap` on an unlit material, three.js's
//! `lightMap` up to its 1/π); glint shows D. So a texel stores L = (D − E) / f, the reflected
//! part of D over the glTF base colour factor f of the texel's material: for a material with a
//! base colour texture the stored Q (D over the texture's mean) over f, so that f · t(x) · L =
//! Q · t(x) is glint's reflected radiance at full texture resolution. A channel with f = 0
//! shows black whatever L is, and stores 0.
//!
//! **The encoding.** RGBD in an 8-bit RGBA PNG (Babylon.js's own HDR texture encoding, read
//! natively when the texture's `isRGBD` is set): with v = L / scale (scale chosen so that the
//! largest channel of every page is at most 255, nothing clips), m = max(v.r, v.g, v.b),
//! d = clamp(floor(255 / m), 1, 255) / 255 (stored in alpha), rgb = sRGB(v · d); decoding is
//! L = scale · sRGB⁻¹(rgb) / d.

use glam::{Vec2, Vec3};

use crate::image_io::linear_to_srgb;
use crate::radiosity::atlas::{Atlas, BORDER, closest_point};

/// Largest value RGBD holds: alpha 1/255 divides the decoded colour by 1/255.
pub const RGBD_MAX: f32 = 255.0;

/// How the pages are written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightmapFormat {
    /// RGBD in an RGBA PNG ([`encode_rgbd`]): HDR, decoded by Babylon.js natively.
    #[default]
    Rgbd,
    /// Plain sRGB RGB PNG of L / scale clamped to 1: LDR, for engines that read only colour
    /// lightmaps (values above `scale` clip).
    Srgb,
}

impl std::str::FromStr for LightmapFormat {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "rgbd" => Ok(LightmapFormat::Rgbd),
            "srgb" => Ok(LightmapFormat::Srgb),
            _ => Err(format!("{s:?} is not one of rgbd, srgb")),
        }
    }
}

impl LightmapFormat {
    /// The name recorded in the glTF's extras.
    pub fn name(self) -> &'static str {
        match self {
            LightmapFormat::Rgbd => "rgbd",
            LightmapFormat::Srgb => "srgb",
        }
    }

    /// The largest value of L / scale the format holds.
    pub fn range(self) -> f32 {
        match self {
            LightmapFormat::Rgbd => RGBD_MAX,
            LightmapFormat::Srgb => 1.0,
        }
    }
}

/// What divides a texel's D: its material's base colour factor and the emission to subtract
/// (none for a textured material, whose stored value already excludes it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexelDivisor {
    /// The glTF base colour factor (linear RGB).
    pub factor: Vec3,
    /// Emission to subtract from the stored value first.
    pub emission: Vec3,
}

impl TexelDivisor {
    /// L of a stored texel value.
    pub fn lightmap(&self, stored: Vec3) -> Vec3 {
        let reflected = (stored - self.emission).max(Vec3::ZERO);
        Vec3::select(
            self.factor.cmpgt(Vec3::ZERO),
            reflected / self.factor.max(Vec3::splat(f32::MIN_POSITIVE)),
            Vec3::ZERO,
        )
    }
}

/// Per texel of page `page` (row-major): the triangle it belongs to, or `u32::MAX`. A texel
/// belongs to the first triangle (in scene order) whose closest point to the texel's centre
/// lies inside the texel, passing over those `shown` rejects (a black base colour shows no L,
/// so a texel shared with a lit neighbour takes the neighbour's divisor); the padding around
/// charts takes a neighbour's triangle, as the radiosity stage dilates D from the chart itself.
pub fn texel_owners(atlas: &Atlas, page: usize, shown: &dyn Fn(u32) -> bool) -> Vec<u32> {
    let size = atlas.pages[page];
    let (w, h) = (size.width as usize, size.height as usize);
    let mut owner = vec![u32::MAX; w * h];
    // Back sides ([`Atlas::backs`]) are not exported: a glTF triangle has one lightmap
    // place for both its sides.
    for (t, c) in atlas.tri_coords[..atlas.scene_triangles()]
        .iter()
        .enumerate()
    {
        if atlas.tri_page[t] as usize != page {
            continue;
        }
        let lo = c[0].min(c[1]).min(c[2]).floor().max(Vec2::ZERO);
        let hi = c[0].max(c[1]).max(c[2]).ceil();
        let (x1, y1) = ((hi.x as usize).min(w), (hi.y as usize).min(h));
        for y in lo.y as usize..y1 {
            for x in lo.x as usize..x1 {
                let i = y * w + x;
                if owner[i] != u32::MAX && shown(owner[i]) {
                    continue;
                }
                let centre = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                let (_, b) = closest_point(*c, centre);
                let p = c[0] * (1.0 - b.x - b.y) + c[1] * b.x + c[2] * b.y;
                if (p - centre).abs().max_element() < 0.5 {
                    owner[i] = t as u32;
                }
            }
        }
    }
    // Padding: BORDER rings and one more, each from the previous ring's owners.
    for _ in 0..=BORDER {
        let prev = owner.clone();
        for y in 0..h {
            for x in 0..w {
                if prev[y * w + x] != u32::MAX {
                    continue;
                }
                let neighbours = [
                    (x > 0).then(|| y * w + x - 1),
                    (x + 1 < w).then(|| y * w + x + 1),
                    (y > 0).then(|| (y - 1) * w + x),
                    (y + 1 < h).then(|| (y + 1) * w + x),
                ];
                if let Some(o) = neighbours
                    .into_iter()
                    .flatten()
                    .map(|n| prev[n])
                    .find(|&o| o != u32::MAX)
                {
                    owner[y * w + x] = o;
                }
            }
        }
    }
    owner
}

/// glint's cubic B-spline reconstruction of `rgb` (`w` × `h`, row-major) at every texel centre:
/// the separable kernel [1, 4, 1] / 6 (the uniform cubic B-spline at −1, 0, 1), edges clamped.
/// An engine's bilinear filter between these values follows the viewer's bicubic D, where the
/// raw texels would show each one as a facet.
pub fn bspline_at_centres(rgb: &[Vec3], w: usize, h: usize) -> Vec<Vec3> {
    let pass = |src: &[Vec3], step: usize, n: usize, at: &dyn Fn(usize) -> (usize, usize)| {
        let mut out = vec![Vec3::ZERO; src.len()];
        for (i, o) in out.iter_mut().enumerate() {
            let (k, _) = at(i);
            let prev = if k > 0 { i - step } else { i };
            let next = if k + 1 < n { i + step } else { i };
            *o = (src[prev] + 4.0 * src[i] + src[next]) / 6.0;
        }
        out
    };
    let rows = pass(rgb, 1, w, &|i| (i % w, i / w));
    pass(&rows, w, h, &|i| (i / w, i % w))
}

/// The barycentrics on triangle coordinates `c` of the point closest to texel (x, y)'s centre.
pub fn texel_bary(c: [Vec2; 3], x: usize, y: usize) -> Vec2 {
    closest_point(c, Vec2::new(x as f32 + 0.5, y as f32 + 0.5)).1
}

/// The scale that maps the largest channel of `pages` to `range` (1 when all are 0).
pub fn scale_for(pages: &[Vec<Vec3>], range: f32) -> f32 {
    let max = pages
        .iter()
        .flatten()
        .map(|c| c.max_element())
        .filter(|m| m.is_finite())
        .fold(0.0f32, f32::max);
    if max > 0.0 { max / range } else { 1.0 }
}

/// RGBD of linear `v` (see the module comment); channels above [`RGBD_MAX`] clip.
pub fn encode_rgbd(v: Vec3) -> [u8; 4] {
    let v = v.clamp(Vec3::ZERO, Vec3::splat(RGBD_MAX));
    let m = v.max_element().max(1e-6);
    let d = ((RGBD_MAX / m).floor().clamp(1.0, 255.0)) / 255.0;
    let q = |x: f32| (linear_to_srgb(x) * 255.0 + 0.5) as u8;
    let c = v * d;
    [q(c.x), q(c.y), q(c.z), (d * 255.0).round() as u8]
}

/// The linear value RGBD `p` stands for.
pub fn decode_rgbd(p: [u8; 4]) -> Vec3 {
    let lin = |b: u8| crate::scene::texture::srgb_to_linear(f32::from(b) / 255.0);
    Vec3::new(lin(p[0]), lin(p[1]), lin(p[2])) / (f32::from(p[3]).max(1.0) / 255.0)
}

/// 8-bit sRGB of linear `v` clamped to [0, 1].
pub fn encode_srgb(v: Vec3) -> [u8; 3] {
    v.to_array()
        .map(|x| (linear_to_srgb(x) * 255.0 + 0.5) as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rgbd_round_trips_within_its_stated_precision() {
        // Within 255:1 of the range the brightest channel keeps an 8-bit sRGB step at ≥ 0.5.
        for v in [1.0f32, 1.7, 3.0, 10.0, 77.0, 128.0, 200.0, 255.0] {
            let c = Vec3::new(v, v * 0.5, v * 0.25);
            let back = decode_rgbd(encode_rgbd(c));
            let err = (back.x - c.x).abs() / c.x;
            assert!(err < 0.006, "{v}: {back} vs {c} ({err})");
        }
        assert_eq!(decode_rgbd(encode_rgbd(Vec3::ZERO)), Vec3::ZERO);
        // Above the range it clips at 255, never wraps.
        assert!((decode_rgbd(encode_rgbd(Vec3::splat(1e4))).x - 255.0).abs() < 2.0);
    }

    #[test]
    fn the_divisor_removes_emission_and_divides_by_the_factor() {
        let d = TexelDivisor {
            factor: Vec3::new(0.5, 0.25, 0.0),
            emission: Vec3::splat(1.0),
        };
        assert_eq!(
            d.lightmap(Vec3::new(2.0, 1.5, 9.0)),
            Vec3::new(2.0, 2.0, 0.0)
        );
        // Less than the emission (filtering) stores 0, not a negative value.
        assert_eq!(d.lightmap(Vec3::splat(0.5)), Vec3::ZERO);
    }

    #[test]
    fn the_scale_maps_the_largest_channel_to_the_range() {
        let pages = vec![vec![Vec3::new(1.0, 510.0, 3.0)], vec![Vec3::splat(2.0)]];
        assert_eq!(scale_for(&pages, RGBD_MAX), 2.0);
        assert_eq!(scale_for(&[vec![Vec3::ZERO]], RGBD_MAX), 1.0);
    }

    #[test]
    fn the_bspline_keeps_constants_and_spreads_an_impulse_by_its_weights() {
        let flat = vec![Vec3::splat(2.0); 12];
        assert!(
            bspline_at_centres(&flat, 4, 3)
                .iter()
                .all(|c| (*c - Vec3::splat(2.0)).abs().max_element() < 1e-6)
        );
        let mut one = vec![Vec3::ZERO; 25];
        one[12] = Vec3::splat(36.0);
        let f = bspline_at_centres(&one, 5, 5);
        assert_eq!(
            (f[12].x, f[11].x, f[7].x, f[6].x, f[0].x),
            (16.0, 4.0, 4.0, 1.0, 0.0)
        );
    }
}
