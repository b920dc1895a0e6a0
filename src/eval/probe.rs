//! Probes: D (exitant radiance from a radiosity bake) looked up at given world points, so a
//! bake can be checked against measurements, another renderer's numbers or the path-traced
//! ground truth at the same points ([`super::reference::trace_probes`]).
//!
//! The surface of a probe is found by a short ray: from `position + reach · normal` towards
//! `−normal`, over at most `2 · reach`; the first front face (whose face normal points to the
//! probe's side) it meets is the probed surface, or the back face of a sheet whose back side
//! is a surface of its own ([`crate::radiosity::back_sides`]). The reach is bounded by the scene: no
//! surface lies farther from the probe than the farthest corner of the scene's bounding box,
//! so a larger reach finds nothing more and would only lose the precision of the ray's origin.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::geometry::Bvh;
use crate::radiosity::RadiosityMap;
use crate::scene::Scene;

/// One probe of `points.json` (a JSON array of these).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProbePoint {
    /// Optional label, copied to the output.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// World position (metres).
    pub position: [f32; 3],
    /// Normal of the surface at the probe (need not be unit length; not zero).
    pub normal: [f32; 3],
}

/// One probe's answer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProbeValue {
    /// The probe's label.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The probe's position.
    pub position: [f32; 3],
    /// Whether a surface was found within reach.
    pub found: bool,
    /// The triangle found (scene order), if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub triangle: Option<u32>,
    /// Signed distance of the probe above the surface found, along the normal (metres).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset: Option<f32>,
    /// Exitant radiance D there (linear RGB, emission included); zero when not found.
    pub radiance: [f32; 3],
    /// Standard error of `radiance` per channel, when it is a Monte Carlo estimate.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub std_error: Option<[f32; 3]>,
}

/// A probe or reach that cannot be looked up.
#[derive(Debug, thiserror::Error)]
pub enum ProbeError {
    /// A probe's position or normal is unusable.
    #[error("probe {index}{}: {message}", name.as_deref().map(|n| format!(" ({n})")).unwrap_or_default())]
    Point {
        /// Index in the probe array.
        index: usize,
        /// The probe's label.
        name: Option<String>,
        /// What is wrong.
        message: String,
    },
    /// The reach is not a finite distance > 0.
    #[error("reach {0} is not a finite distance > 0 in metres")]
    Reach(f32),
}

/// The default reach: 1% of the scene's bounding-box diagonal.
pub fn default_reach(scene: &Scene) -> f32 {
    0.01 * scene.bounds.diagonal()
}

/// The reach actually used at `p`: `reach`, but no farther than the farthest corner of the
/// scene's bounds (plus a margin for the ray's end), beyond which there is no surface.
pub fn bounded_reach(scene: &Scene, p: Vec3, reach: f32) -> f32 {
    let b = &scene.bounds;
    let far = (p - b.min).abs().max((p - b.max).abs()).length();
    reach.min(far * 1.01 + 1e-3)
}

/// Checks every probe: finite position, finite non-zero normal.
pub fn check_points(points: &[ProbePoint]) -> Result<(), ProbeError> {
    for (index, pt) in points.iter().enumerate() {
        let bad = |message: String| ProbeError::Point {
            index,
            name: pt.name.clone(),
            message,
        };
        let [x, y, z] = pt.position;
        if !Vec3::from_array(pt.position).is_finite() {
            return Err(bad(format!("position [{x}, {y}, {z}] is not finite")));
        }
        let [x, y, z] = pt.normal;
        let n = Vec3::from_array(pt.normal);
        if !n.is_finite() || n.normalize_or_zero() == Vec3::ZERO {
            return Err(bad(format!(
                "normal [{x}, {y}, {z}] is zero or not finite: it must point away from the surface"
            )));
        }
    }
    Ok(())
}

/// Where a probe's surface was found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    /// Triangle (scene order).
    pub triangle: u32,
    /// Barycentrics on it.
    pub bary: glam::Vec2,
    /// Signed distance of the probe above it, along the normal (metres).
    pub offset: f32,
    /// Whether it is the triangle's back side (one of `backs` in [`find_surface`]).
    pub back: bool,
}

/// The surface under a probe at `p` with unit normal `n` (see the module comment): the first
/// front face a ray from `p + reach·n` towards `−n` meets within `2·reach`, or back face of
/// one of `backs` (ascending triangle indices: the sheets whose back sides have D of their
/// own, [`crate::radiosity::atlas::Atlas::backs`]).
pub fn find_surface(
    scene: &Scene,
    bvh: &Bvh,
    p: Vec3,
    n: Vec3,
    reach: f32,
    backs: &[u32],
) -> Option<Surface> {
    let reach = bounded_reach(scene, p, reach);
    let origin = p + n * reach;
    let mut start = origin;
    let mut travelled = 0.0;
    // Skip back faces (e.g. the far side of a thin wall) until a front face.
    while travelled < 2.0 * reach {
        let h = bvh.closest_hit(start, -n, 2.0 * reach - travelled)?;
        travelled += h.t;
        let tri = &scene.triangles[h.triangle as usize];
        let front = tri.face_normal().dot(n) > 0.0;
        if front || backs.binary_search(&h.triangle).is_ok() {
            return Some(Surface {
                triangle: h.triangle,
                bary: h.bary,
                offset: travelled - reach,
                back: !front,
            });
        }
        start = origin - n * (travelled + bvh.epsilon());
        travelled += bvh.epsilon();
    }
    None
}

/// Checks the reach and every probe ([`check_points`]).
pub fn check(points: &[ProbePoint], reach: f32) -> Result<(), ProbeError> {
    if !(reach.is_finite() && reach > 0.0) {
        return Err(ProbeError::Reach(reach));
    }
    check_points(points)
}

/// The answer for probe `pt` with `value` computed on the surface found (zero when none).
pub fn answer(
    pt: &ProbePoint,
    surface: Option<Surface>,
    value: impl FnOnce(Surface) -> Vec3,
) -> ProbeValue {
    ProbeValue {
        name: pt.name.clone(),
        position: pt.position,
        found: surface.is_some(),
        triangle: surface.map(|s| s.triangle),
        offset: surface.map(|s| s.offset),
        radiance: surface.map_or(Vec3::ZERO, value).to_array(),
        std_error: None,
    }
}

/// A probe's unit normal (checked by [`check_points`]).
pub fn unit_normal(pt: &ProbePoint) -> Vec3 {
    Vec3::from_array(pt.normal).normalize_or_zero()
}

/// Looks D up at every probe (`reach` in metres, bounded by [`bounded_reach`]; see the
/// module comment). Probes and reach are checked first ([`check_points`]).
pub fn probe(
    scene: &Scene,
    bvh: &Bvh,
    map: &RadiosityMap,
    points: &[ProbePoint],
    reach: f32,
) -> Result<Vec<ProbeValue>, ProbeError> {
    check(points, reach)?;
    Ok(points
        .iter()
        .map(|pt| {
            let p = Vec3::from_array(pt.position);
            let surface = find_surface(scene, bvh, p, unit_normal(pt), reach, &map.atlas.backs);
            answer(pt, surface, |s| {
                let (t, b) = map.atlas.side(s.triangle, s.bary, s.back);
                scene.d_at(s.triangle, s.bary, map.radiance(t, b))
            })
        })
        .collect())
}

/// `count` probes on the scene's diffuse faces (materials with albedo and no glossy lobe;
/// emitters included: D holds their emission), area-weighted, at points whose surroundings are open: fewer than a quarter of
/// 32 cosine-distributed rays from the point hit back faces (points under a box or inside a
/// wall show D filled from a neighbour, not their own light) and none hits a surface closer
/// than 10⁻⁴ of the scene's diagonal. Deterministic for `seed`.
/// Probes are named `p0`, `p1`, …; fewer than `count` come back only when such points are too
/// rare (after 64 × `count` attempts).
pub fn diffuse_points(scene: &Scene, bvh: &Bvh, count: usize, seed: u64) -> Vec<ProbePoint> {
    diffuse_points_clear_of(scene, bvh, count, seed, 0.0)
}

/// [`diffuse_points`] at least `clearance` metres (and 10⁻⁴ of the scene's diagonal) from
/// any other surface, as [`clearance`] measures it.
pub fn diffuse_points_clear_of(
    scene: &Scene,
    bvh: &Bvh,
    count: usize,
    seed: u64,
    clearance_m: f32,
) -> Vec<ProbePoint> {
    use crate::sampling::{Rng, basis, sample_cosine_hemisphere, sample_triangle};
    let mut cdf = Vec::new();
    let mut tris = Vec::new();
    let mut total = 0.0f64;
    for (i, t) in scene.triangles.iter().enumerate() {
        let m = &scene.materials[t.material as usize];
        if m.albedo.max_element() > 0.0 && !m.is_glossy() {
            total += t.area() as f64;
            tris.push(i);
            cdf.push(total);
        }
    }
    let mut out = Vec::with_capacity(count);
    if tris.is_empty() || total.is_nan() || total <= 0.0 {
        return out;
    }
    // Points within a hair of another surface (a concave edge) are left out: there the
    // reference's ray origins, moved off the surface by the scene's epsilon, can land beyond
    // the other surface, and D changes faster than any texel resolves. (Before `Bvh` moved
    // its rays' origins back, rays lost walls within 0.1 mm and such probes read 0.155
    // against 0.196 a little further out, on glossy-room.)
    let min_clearance = clearance_m.max(1e-4 * scene.bounds.diagonal());
    let mut rng = Rng::new(seed, 0);
    for _ in 0..64 * count {
        if out.len() == count {
            break;
        }
        let x = rng.uniform() as f64 * total;
        let k = cdf.partition_point(|&c| c <= x).min(tris.len() - 1);
        let tri = &scene.triangles[tris[k]];
        let p = tri.point(sample_triangle(rng.uniform2()));
        let n = tri.face_normal();
        let origin = bvh.offset_origin(p, n);
        let (t, b) = basis(n);
        let mut back = 0;
        for _ in 0..32 {
            let l = sample_cosine_hemisphere(rng.uniform2());
            let d = t * l.x + b * l.y + n * l.z;
            if let Some(h) = bvh.closest_hit(origin, d, f32::INFINITY)
                && scene.triangles[h.triangle as usize].face_normal().dot(d) > 0.0
            {
                back += 1;
            }
        }
        if back * 4 < 32 && clearance(bvh, p, n) >= min_clearance {
            out.push(ProbePoint {
                name: Some(format!("p{}", out.len())),
                position: p.to_array(),
                normal: n.to_array(),
            });
        }
    }
    out
}

/// Directions in the tangent plane along which [`clearance`] looks for neighbours.
const CLEARANCE_DIRECTIONS: usize = 16;

/// Distance from surface point `p` (unit normal `n`) to the nearest other surface in front of
/// it, looked for along `CLEARANCE_DIRECTIONS` directions just above the tangent plane
/// (where a wall meeting this surface at a concave edge, or an object standing on it, is
/// nearest) and along the normal; infinite when none is hit.
///
/// Near a concave edge D changes within millimetres (the form factor between the two faces
/// is singular at their edge), faster than any texel resolves: probes closer to an edge than
/// half a texel measure that, not the solve.
pub fn clearance(bvh: &Bvh, p: Vec3, n: Vec3) -> f32 {
    let (t, b) = crate::sampling::basis(n);
    let origin = bvh.offset_origin(p, n);
    // Each ray starts `back` behind the point, so that a surface the point lies just beyond
    // (a triangle poking through the other one at the edge) is found too: a first hit closer
    // than `back` is such a surface, clearance 0.
    let back = 10.0 * bvh.epsilon().max(f32::MIN_POSITIVE);
    // 1° above the plane: the ray leaves the surface it starts on.
    let (lift_sin, lift_cos) = 1f32.to_radians().sin_cos();
    let dirs = (0..CLEARANCE_DIRECTIONS).map(|k| {
        let a = k as f32 * std::f32::consts::TAU / CLEARANCE_DIRECTIONS as f32;
        (t * a.cos() + b * a.sin()) * lift_cos + n * lift_sin
    });
    // Along the normal the ray cannot start behind the point (that is the surface itself).
    let mut nearest = bvh
        .closest_hit(origin, n, f32::INFINITY)
        .map_or(f32::INFINITY, |h| h.t);
    for d in dirs {
        if let Some(h) = bvh.closest_hit(origin - d * back, d, nearest + back) {
            nearest = nearest.min((h.t - back).max(0.0));
        }
    }
    nearest
}

/// How far probe values are from reference values at the same probes (relative luminance
/// errors, the denominator floored at 5% of the reference's mean so that near-black probes do
/// not dominate).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ProbeMetrics {
    /// Probes compared (found in both).
    pub probes: usize,
    /// Root mean square relative error.
    pub rel_rmse: f64,
    /// Mean of value / reference.
    pub mean_ratio: f64,
    /// Median |relative error|.
    pub median: f64,
    /// 95th percentile of |relative error|.
    pub p95: f64,
    /// Largest |relative error|, and the probe it is at.
    pub max: f64,
    /// Name (or index) of the probe with the largest error.
    pub worst: String,
    /// Median relative standard error of the reference (its own noise), when it has one.
    pub reference_noise: Option<f64>,
    /// Root mean square of the reference's relative standard errors, when it has them.
    pub reference_noise_rms: Option<f64>,
    /// The relative RMSE with the reference's noise taken out, √max(0, rmse² − noise_rms²):
    /// an estimate of the values' own error against the converged truth (the reference's
    /// noise is independent of them and adds in quadrature).
    pub rel_rmse_denoised: Option<f64>,
}

/// Compares `values` with `reference`, probe by probe (same order, same probes).
pub fn compare_probes(
    values: &[ProbeValue],
    reference: &[ProbeValue],
) -> Result<ProbeMetrics, String> {
    if values.len() != reference.len() {
        return Err(format!(
            "{} probes against {} reference probes: they must be the same probes",
            values.len(),
            reference.len()
        ));
    }
    let lum = |c: [f32; 3]| crate::eval::luminance(Vec3::from_array(c)) as f64;
    let pairs: Vec<(usize, &ProbeValue, &ProbeValue)> = values
        .iter()
        .zip(reference)
        .enumerate()
        .filter(|(_, (a, b))| a.found && b.found)
        .map(|(i, (a, b))| (i, a, b))
        .collect();
    if pairs.is_empty() {
        return Err("no probe found a surface in both".into());
    }
    let n = pairs.len() as f64;
    let mean = pairs.iter().map(|(_, _, b)| lum(b.radiance)).sum::<f64>() / n;
    let floor = (0.05 * mean).max(f64::MIN_POSITIVE);
    let mut errors = Vec::with_capacity(pairs.len());
    let (mut ratio, mut sq, mut max, mut worst) = (0.0, 0.0, -1.0, String::new());
    for (i, a, b) in &pairs {
        let den = lum(b.radiance).max(floor);
        let e = (lum(a.radiance) - lum(b.radiance)) / den;
        ratio += lum(a.radiance) / den;
        sq += e * e;
        if e.abs() > max {
            max = e.abs();
            worst = a.name.clone().unwrap_or_else(|| format!("#{i}"));
        }
        errors.push(e.abs());
    }
    errors.sort_by(f64::total_cmp);
    let pick = |q: f64| errors[((errors.len() - 1) as f64 * q).round() as usize];
    let mut noise: Vec<f64> = pairs
        .iter()
        .filter_map(|(_, _, b)| b.std_error.map(|s| lum(s) / lum(b.radiance).max(floor)))
        .collect();
    let noise_rms = (!noise.is_empty())
        .then(|| (noise.iter().map(|x| x * x).sum::<f64>() / noise.len() as f64).sqrt());
    noise.sort_by(f64::total_cmp);
    Ok(ProbeMetrics {
        probes: pairs.len(),
        rel_rmse: (sq / n).sqrt(),
        reference_noise_rms: noise_rms,
        rel_rmse_denoised: noise_rms.map(|r| (sq / n - r * r).max(0.0).sqrt()),
        mean_ratio: ratio / n,
        median: pick(0.5),
        p95: pick(0.95),
        max,
        worst,
        reference_noise: (!noise.is_empty()).then(|| noise[noise.len() / 2]),
    })
}
