//! The display mapping of the viewer's 8-bit frames: linear radiance × 2^EV, then a tone curve,
//! then sRGB. `shaders/display.wgsl` is the same mapping on the GPU (a test holds the two
//! together); HDR output is the radiance before any of it.
//!
//! The curve is the Khronos PBR Neutral tone mapper (Khronos Group, "PBR Neutral
//! Specification", KhronosGroup/ToneMapping, 2024). Chosen over ACES and AgX because glint is
//! for lighting designers checking materials under baked light: below its compression knee it
//! only subtracts a small offset (F90 = 0.04, the specular floor of dielectrics), so a
//! white-lit surface of base colour c is shown as c − 0.04 for every channel up to 0.8, hue
//! and saturation kept; ACES and AgX bend the whole range (contrast and hue shifts even at
//! mid-grey), which would misreport albedos. Above the knee it compresses highlights
//! smoothly to 1 and desaturates them towards white, so windows and emitters no longer clip
//! to flat colour.

use glam::Vec3;
use serde::Serialize;

/// F90 of the specification: Fresnel reflectance at normal incidence of IoR 1.5 materials.
pub const F90: f32 = 0.04;

/// K_s = 0.8 − F90: where highlight compression starts.
pub const START_COMPRESSION: f32 = 0.8 - F90;

/// K_d: how fast compressed highlights desaturate.
pub const DESATURATION: f32 = 0.15;

/// The tone curve applied after exposure (`--tonemap`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Tonemap {
    /// Khronos PBR Neutral ([`neutral`]).
    #[default]
    Neutral,
    /// None: exposed radiance clamped to [0, 1].
    None,
}

impl Tonemap {
    /// The curve applied to exposed linear RGB; the result is in [0, 1].
    pub fn apply(self, c: Vec3) -> Vec3 {
        match self {
            Tonemap::Neutral => neutral(c),
            Tonemap::None => c.clamp(Vec3::ZERO, Vec3::ONE),
        }
    }

    /// The value of `mode` in `shaders/display.wgsl`.
    pub fn shader_mode(self) -> u32 {
        match self {
            Tonemap::None => 0,
            Tonemap::Neutral => 1,
        }
    }

    /// The other curve (the window's M key).
    pub fn other(self) -> Tonemap {
        match self {
            Tonemap::Neutral => Tonemap::None,
            Tonemap::None => Tonemap::Neutral,
        }
    }
}

impl std::str::FromStr for Tonemap {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "neutral" => Ok(Tonemap::Neutral),
            "none" => Ok(Tonemap::None),
            _ => Err(format!("{s:?} is not one of neutral, none")),
        }
    }
}

impl std::fmt::Display for Tonemap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Tonemap::Neutral => "neutral",
            Tonemap::None => "none",
        })
    }
}

/// Khronos PBR Neutral of non-negative linear Rec. 709 `c` (negative channels are taken as
/// 0): x = min(R, G, B); offset f = x − x²/(4·F90) for x ≤ 2·F90, else F90; p = max(c − f);
/// below K_s the output is c − f; above, c − f is scaled to the compressed peak
/// p_n = 1 − (1 − K_s)²/(p + 1 − 2K_s) and mixed towards grey p_n by 1 − g,
/// g = 1/(K_d (p − p_n) + 1).
pub fn neutral(c: Vec3) -> Vec3 {
    let c = c.max(Vec3::ZERO);
    let x = c.min_element();
    let offset = if x < 2.0 * F90 {
        x - x * x / (4.0 * F90)
    } else {
        F90
    };
    let c = c - Vec3::splat(offset);
    let peak = c.max_element();
    if peak < START_COMPRESSION {
        return c;
    }
    let d = 1.0 - START_COMPRESSION;
    let new_peak = 1.0 - d * d / (peak + d - START_COMPRESSION);
    let g = 1.0 / (DESATURATION * (peak - new_peak) + 1.0);
    (c * (new_peak / peak)) * g + Vec3::splat(new_peak * (1.0 - g))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey(v: f32) -> f32 {
        neutral(Vec3::splat(v)).x
    }

    #[test]
    fn neutral_meets_its_published_anchor_points() {
        assert_eq!(neutral(Vec3::ZERO), Vec3::ZERO);
        // The toe: x²/(4·F90) up to 2·F90 = 0.08, where it meets the offset F90.
        assert!((grey(0.04) - 0.01).abs() < 1e-7);
        assert!((grey(0.08) - 0.04).abs() < 1e-6);
        // The linear part: base colours shown as c − F90 up to 0.8 (K_s + F90).
        for v in [0.1, 0.18, 0.5, 0.79] {
            assert!((grey(v) - (v - F90)).abs() < 1e-6, "{v}: {}", grey(v));
        }
        // The knee is continuous: p = K_s gives p_n = K_s.
        assert!((grey(0.8) - START_COMPRESSION).abs() < 1e-6);
        // Compression: 1.0 → 1 − 0.24²/0.44 = 0.869; towards 1 and never past it.
        assert!((grey(1.0) - (1.0 - 0.24 * 0.24 / 0.44)).abs() < 1e-6);
        assert!(grey(1e3) > 0.999 && grey(1e6) <= 1.0);
        // A colour below the knee keeps its chroma: every channel drops by the same offset.
        let c = Vec3::new(0.6, 0.3, 0.1);
        assert!((neutral(c) - (c - Vec3::splat(F90))).length() < 1e-6);
        // A saturated highlight desaturates towards white.
        let hot = neutral(Vec3::new(30.0, 3.0, 0.3));
        assert!(hot.max_element() <= 1.0 && hot.min_element() > 0.3, "{hot}");
    }

    #[test]
    fn neutral_is_monotone_and_continuous() {
        let mut last = -1.0;
        for i in 0..=20_000 {
            let v = i as f32 * 1e-3; // 0 ..= 20
            let y = grey(v);
            assert!(y >= last, "{v}: {y} < {last}");
            assert!(y - last.max(0.0) < 2e-3, "jump at {v}");
            last = y;
        }
    }

    #[test]
    fn none_clamps() {
        let c = Tonemap::None.apply(Vec3::new(-1.0, 0.5, 7.0));
        assert_eq!(c, Vec3::new(0.0, 0.5, 1.0));
        for t in [Tonemap::Neutral, Tonemap::None] {
            assert_eq!(t.to_string().parse::<Tonemap>().unwrap(), t);
            assert_eq!(t.other().other(), t);
        }
    }
}
