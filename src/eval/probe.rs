//! Probes: D (exitant radiance from a radiosity bake) looked up at given world points, so a
//! bake can be checked against measurements or another renderer's numbers.
//!
//! The surface of a probe is found by a short ray: from `position + reach · normal` towards
//! `−normal`, over at most `2 · reach`; the first front face (whose face normal points to the
//! probe's side) it meets is the probed surface.

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

/// The default reach: 1% of the scene's bounding-box diagonal.
pub fn default_reach(scene: &Scene) -> f32 {
    0.01 * scene.bounds.diagonal()
}

/// Looks D up at every probe (`reach` in metres; see the module comment).
pub fn probe(
    scene: &Scene,
    bvh: &Bvh,
    map: &RadiosityMap,
    points: &[ProbePoint],
    reach: f32,
) -> Vec<ProbeValue> {
    points
        .iter()
        .map(|pt| {
            let p = Vec3::from_array(pt.position);
            let n = Vec3::from_array(pt.normal).normalize_or_zero();
            let mut v = ProbeValue {
                name: pt.name.clone(),
                position: pt.position,
                found: false,
                triangle: None,
                offset: None,
                radiance: [0.0; 3],
            };
            if n == Vec3::ZERO {
                return v;
            }
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
        .collect()
}
