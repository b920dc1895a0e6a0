//! Probes: D (exitant radiance from a radiosity bake) looked up at given world points, so a
//! bake can be checked against measurements or another renderer's numbers.
//!
//! The surface of a probe is found by a short ray: from `position + reach · normal` towards
//! `−normal`, over at most `2 · reach`; the first front face (whose face normal points to the
//! probe's side) it meets is the probed surface. The reach is bounded by the scene: no
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
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ProbeValue {
    /// The probe's label.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The probe's position.
    pub position: [f32; 3],
    /// Whether a surface was found within reach.
    pub found: bool,
    /// The triangle found (scene order), if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub triangle: Option<u32>,
    /// Signed distance of the probe above the surface found, along the normal (metres).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub offset: Option<f32>,
    /// Exitant radiance D there (linear RGB, emission included); zero when not found.
    pub radiance: [f32; 3],
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

/// Looks D up at every probe (`reach` in metres, bounded by [`bounded_reach`]; see the
/// module comment). Probes and reach are checked first ([`check_points`]).
pub fn probe(
    scene: &Scene,
    bvh: &Bvh,
    map: &RadiosityMap,
    points: &[ProbePoint],
    reach: f32,
) -> Result<Vec<ProbeValue>, ProbeError> {
    if !(reach.is_finite() && reach > 0.0) {
        return Err(ProbeError::Reach(reach));
    }
    check_points(points)?;
    Ok(points
        .iter()
        .map(|pt| {
            let p = Vec3::from_array(pt.position);
            let n = Vec3::from_array(pt.normal).normalize_or_zero();
            let reach = bounded_reach(scene, p, reach);
            let mut v = ProbeValue {
                name: pt.name.clone(),
                position: pt.position,
                found: false,
                triangle: None,
                offset: None,
                radiance: [0.0; 3],
            };
            let origin = p + n * reach;
            let mut start = origin;
            let mut travelled = 0.0;
            // Skip back faces (e.g. the far side of a thin wall) until a front face.
            while travelled < 2.0 * reach {
                let Some(h) = bvh.closest_hit(start, -n, 2.0 * reach - travelled) else {
                    break;
                };
                travelled += h.t;
                let tri = &scene.triangles[h.triangle as usize];
                if tri.face_normal().dot(n) > 0.0 {
                    v.found = true;
                    v.triangle = Some(h.triangle);
                    v.offset = Some(travelled - reach);
                    v.radiance = map.radiance(h.triangle, h.bary).to_array();
                    break;
                }
                start = origin - n * (travelled + bvh.epsilon());
                travelled += bvh.epsilon();
            }
            v
        })
        .collect())
}
