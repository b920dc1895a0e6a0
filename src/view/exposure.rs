//! Exposure of the viewer's 8-bit frames: a fixed EV (`--exposure EV`: radiance × 2^EV) or
//! `auto`, and the window's exposure keys as a pure state update ([`Exposure::step`]).
//!
//! `auto` is computed once per bundle from D, not per frame: the log-average luminance
//! (Reinhard et al. 2002, "Photographic tone reproduction", Eq. 1) of D over the scene's
//! surfaces, area-weighted, mapped to the key 0.18 (mid-grey). Each triangle is sampled on a
//! barycentric lattice of about one point per lightmap texel it covers ([`surface_samples`]),
//! so unused atlas space and padding never count. Computed at load, it costs nothing per
//! frame, is deterministic
//! (f64 sum in texel order), is the same in the window, in headless replay and in every
//! frame of a camera path (0 EV of flicker by construction), and is the same for a bake with
//! all emitters × k up to −log2(k) EV, so a blown-out scene lands at the same picture. What it
//! does not do is adapt to the view: a frame looking into a dark corner stays dark (the
//! window's keys change it).

use glam::{Vec2, Vec3};
use serde::{Serialize, Serializer};

use crate::colour::luminance;
use crate::geometry::Triangle;
use crate::radiosity::RadiosityMap;

/// Mid-grey: the exposed log-average luminance `auto` aims at (Reinhard et al.'s key a).
pub const KEY: f32 = 0.18;

/// δ of the log-average: luminances below it count as it, so black texels do not send the
/// average to zero.
pub const LUMINANCE_FLOOR: f64 = 1e-4;

/// Largest |EV| accepted.
pub const MAX_EV: f32 = 32.0;

/// EV change of one press of the window's exposure keys.
pub const KEY_STEP_EV: f32 = 0.5;

/// How the 8-bit frames are exposed (`--exposure auto|EV`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Exposure {
    /// From D's log-average luminance ([`auto_ev`]).
    #[default]
    Auto,
    /// A fixed exposure value: radiance × 2^EV (0: radiance as baked).
    Ev(f32),
}

/// A window key's change of exposure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExposureKey {
    /// One [`KEY_STEP_EV`] brighter.
    Raise,
    /// One [`KEY_STEP_EV`] darker.
    Lower,
    /// Back to `auto`.
    Auto,
}

impl Exposure {
    /// The exposure value in effect, with `auto_ev` standing for `Auto`.
    pub fn ev(self, auto_ev: f32) -> f32 {
        match self {
            Exposure::Auto => auto_ev,
            Exposure::Ev(ev) => ev,
        }
    }

    /// The factor radiance is multiplied by: 2^EV.
    pub fn scale(self, auto_ev: f32) -> f32 {
        self.ev(auto_ev).exp2()
    }

    /// The exposure after `key`: a step from the EV in effect (so the first step from `auto`
    /// starts at the auto value), clamped to ±[`MAX_EV`]; `ExposureKey::Auto` returns to auto.
    pub fn step(self, key: ExposureKey, auto_ev: f32) -> Exposure {
        let by = |d: f32| Exposure::Ev((self.ev(auto_ev) + d).clamp(-MAX_EV, MAX_EV));
        match key {
            ExposureKey::Raise => by(KEY_STEP_EV),
            ExposureKey::Lower => by(-KEY_STEP_EV),
            ExposureKey::Auto => Exposure::Auto,
        }
    }
}

impl std::str::FromStr for Exposure {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "auto" {
            return Ok(Exposure::Auto);
        }
        match s.parse::<f32>() {
            Ok(ev) if ev.is_finite() && ev.abs() <= MAX_EV => Ok(Exposure::Ev(ev)),
            _ => Err(format!(
                "{s:?} is neither `auto` nor an exposure value in stops within ±{MAX_EV}"
            )),
        }
    }
}

impl std::fmt::Display for Exposure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Exposure::Auto => f.write_str("auto"),
            Exposure::Ev(ev) => write!(f, "{ev}"),
        }
    }
}

/// `"auto"` or the EV as a number.
impl Serialize for Exposure {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Exposure::Auto => s.serialize_str("auto"),
            Exposure::Ev(ev) => s.serialize_f32(*ev),
        }
    }
}

/// exp(mean ln(max(L, δ))) over `colours` (L their luminance, δ [`LUMINANCE_FLOOR`]),
/// summed in f64 in the given order; `None` when there are none with finite luminance.
pub fn log_average_luminance(colours: impl IntoIterator<Item = Vec3>) -> Option<f32> {
    weighted_log_average_luminance(colours.into_iter().map(|c| (c, 1.0)))
}

/// [`log_average_luminance`] with a weight per colour (e.g. the area it stands for):
/// exp(Σ w ln(max(L, δ)) / Σ w); `None` when the weights of finite luminances sum to 0.
pub fn weighted_log_average_luminance(
    colours: impl IntoIterator<Item = (Vec3, f64)>,
) -> Option<f32> {
    let (mut sum, mut weight) = (0.0f64, 0.0f64);
    for (c, w) in colours {
        let l = f64::from(luminance(c));
        if l.is_finite() && w > 0.0 {
            sum += w * l.max(LUMINANCE_FLOOR).ln();
            weight += w;
        }
    }
    (weight > 0.0).then(|| (sum / weight).exp() as f32)
}

/// The EV that maps `log_average` to [`KEY`]: log2(KEY / log_average).
pub fn ev_for(log_average: f32) -> f32 {
    (KEY / log_average).log2().clamp(-MAX_EV, MAX_EV)
}

/// Largest lattice side per triangle in [`surface_samples`] (at most 8·9/2 = 36 points).
const MAX_LATTICE: u32 = 8;

/// Barycentric sample points of one triangle and its lattice side k: the centroids of the k²
/// sub-triangles' upward half, (i + ⅓, j + ⅓)/k for i + j < k, k(k + 1)/2 points spread
/// evenly over it; k ≈ √(texels covered) so there is about one point per texel (at least
/// one point, at most [`MAX_LATTICE`] per side).
fn lattice(texels: f32) -> impl Iterator<Item = Vec2> {
    let k = (texels.max(0.0).sqrt().ceil() as u32).clamp(1, MAX_LATTICE);
    (0..k).flat_map(move |i| {
        (0..k - i).map(move |j| Vec2::new(i as f32 + 1.0 / 3.0, j as f32 + 1.0 / 3.0) / k as f32)
    })
}

/// D at points spread over every triangle, each with the world area it stands for
/// (triangle area / its points): the area measure of the scene's surfaces, read through the
/// atlas (nearest texel). Black texels are left out: they hold no element (faces inside
/// geometry, such as a box's bottom on the floor, which no view shows) or no light at all, and
/// would pull the average to the luminance floor whatever the emitters' strength.
pub fn surface_samples<'a>(
    triangles: &'a [Triangle],
    map: &'a RadiosityMap,
) -> impl Iterator<Item = (Vec3, f64)> + 'a {
    let atlas = &map.atlas;
    let offsets = atlas.page_offsets();
    let texels: Vec<&Vec3> = map.pages.iter().flatten().collect();
    triangles
        .iter()
        .enumerate()
        .filter(move |(t, _)| *t < atlas.tri_coords.len())
        .flat_map(move |(t, tri)| {
            let [a, b, c] = atlas.tri_coords[t];
            let covered = 0.5 * (b - a).perp_dot(c - a).abs();
            let points: Vec<Vec2> = lattice(covered).collect();
            let weight = f64::from(tri.area()) / points.len() as f64;
            let samples: Vec<(Vec3, f64)> = points
                .into_iter()
                .filter_map(|bary| {
                    let i = atlas.texel_at(&offsets, t as u32, bary) as usize;
                    texels
                        .get(i)
                        .filter(|c| c.max_element() > 0.0)
                        .map(|&&c| (c, weight))
                })
                .collect();
            samples
        })
}

/// `auto`'s exposure value for the scene's `triangles` lit by `map`: [`ev_for`] the
/// area-weighted log-average luminance of D over the surfaces ([`surface_samples`]); 0 when
/// there is nothing to average.
pub fn auto_ev(triangles: &[Triangle], map: &RadiosityMap) -> f32 {
    weighted_log_average_luminance(surface_samples(triangles, map)).map_or(0.0, ev_for)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_step_from_the_exposure_in_effect() {
        let auto = -3.25;
        let up = Exposure::Auto.step(ExposureKey::Raise, auto);
        assert_eq!(up, Exposure::Ev(-2.75));
        assert_eq!(up.step(ExposureKey::Lower, auto), Exposure::Ev(-3.25));
        let down = Exposure::Ev(1.0).step(ExposureKey::Lower, auto);
        assert_eq!(down, Exposure::Ev(0.5));
        assert_eq!(down.step(ExposureKey::Auto, auto), Exposure::Auto);
        assert_eq!(
            Exposure::Ev(MAX_EV).step(ExposureKey::Raise, auto),
            Exposure::Ev(MAX_EV)
        );
        assert_eq!(Exposure::Ev(2.0).scale(auto), 4.0);
        assert_eq!(Exposure::Auto.scale(-1.0), 0.5);
    }

    #[test]
    fn exposure_parses_auto_or_stops() {
        assert_eq!("auto".parse::<Exposure>().unwrap(), Exposure::Auto);
        assert_eq!("-1.5".parse::<Exposure>().unwrap(), Exposure::Ev(-1.5));
        let e = "bright".parse::<Exposure>().unwrap_err();
        assert!(e.contains("auto") && e.contains("stops"), "{e}");
        assert!("40".parse::<Exposure>().is_err());
        assert_eq!(serde_json::to_string(&Exposure::Auto).unwrap(), "\"auto\"");
        assert_eq!(serde_json::to_string(&Exposure::Ev(2.0)).unwrap(), "2.0");
    }

    #[test]
    fn log_average_maps_to_mid_grey_whatever_the_emitters_strength() {
        // Half the texels at luminance 0.02, half at 2: log-average 0.2.
        let lit: Vec<Vec3> = (0..100)
            .map(|i| Vec3::splat(if i % 2 == 0 { 0.02 } else { 2.0 }))
            .collect();
        let avg = log_average_luminance(lit.iter().copied()).unwrap();
        assert!((avg - 0.2).abs() < 1e-5, "{avg}");
        assert!((avg * ev_for(avg).exp2() - KEY).abs() < 1e-5);
        // Emitters × 30 (D is linear in emission): 30× the average, log2(30) EV less.
        let hot = log_average_luminance(lit.iter().map(|c| *c * 30.0)).unwrap();
        assert!((ev_for(avg) - ev_for(hot) - 30f32.log2()).abs() < 1e-4);
        // Black texels count as the floor, not as −∞.
        let dark = log_average_luminance([Vec3::ZERO, Vec3::ONE]).unwrap();
        assert!(
            (dark - (LUMINANCE_FLOOR as f32).sqrt()).abs() < 1e-6,
            "{dark}"
        );
        assert_eq!(log_average_luminance([]), None);
        // Weights are areas: a colour standing for 3× the area counts 3×.
        let w = weighted_log_average_luminance([(Vec3::splat(0.1), 3.0), (Vec3::ONE, 1.0)]);
        let expected = (0.75 * 0.1f64.ln()).exp() as f32;
        assert!((w.unwrap() - expected).abs() < 1e-6);
    }

    #[test]
    fn the_lattice_spreads_about_one_point_per_texel_inside_the_triangle() {
        for (texels, k) in [(0.2, 1), (1.0, 1), (9.0, 3), (10.0, 4), (1e6, MAX_LATTICE)] {
            let points: Vec<Vec2> = lattice(texels).collect();
            assert_eq!(points.len() as u32, k * (k + 1) / 2, "{texels}");
            for p in &points {
                assert!(p.x > 0.0 && p.y > 0.0 && p.x + p.y < 1.0, "{p}");
            }
            // Their mean is the triangle's centroid (a uniform spread).
            let mean = points.iter().sum::<Vec2>() / points.len() as f32;
            assert!((mean - Vec2::splat(1.0 / 3.0)).length() < 1e-5, "{mean}");
        }
    }
}
