//! Reflection probes given in scene.json (`probes`): each adds a probe, or moves the one the
//! bake places under the same name ([`crate::materials::probes::place`]).

use glam::Vec3;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::geometry::Aabb;

/// A reflection probe of scene.json: where the bake captures a prefiltered cube map of the
/// room that glossy surfaces without a declared reflector reflect.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ProbeDesc {
    /// Name in messages and the bundle; a placed probe of this name (a glossy material's
    /// name) is moved here instead of a new one added.
    pub name: String,
    /// Capture point, metres, inside the scene's bounds.
    pub position: [f32; 3],
    /// Reach, metres (> 0): a glossy material reads the nearest probe whose reach holds its
    /// surfaces' centre. Absent: a placed probe's own, a new one's the scene's diagonal.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f32>,
}

/// Checks scene.json's `probes` against the scene's `bounds`: names non-empty and unique,
/// positions finite and inside the bounds, radii finite and > 0. `Err((field, why))`.
pub fn check(probes: &[ProbeDesc], bounds: &Aabb) -> Result<(), (String, String)> {
    for (i, p) in probes.iter().enumerate() {
        let at = |f: &str| format!("probes[{i}].{f}");
        if p.name.trim().is_empty() {
            return Err((at("name"), "a probe needs a non-empty name".into()));
        }
        if probes[..i].iter().any(|q| q.name == p.name) {
            return Err((
                at("name"),
                format!("{:?} names two probes; each needs its own name", p.name),
            ));
        }
        let pos = Vec3::from_array(p.position);
        if !pos.is_finite() {
            return Err((
                at("position"),
                format!("{:?} is not three finite numbers", p.position),
            ));
        }
        if pos.cmplt(bounds.min).any() || pos.cmpgt(bounds.max).any() {
            return Err((
                at("position"),
                format!(
                    "{:?} lies outside the scene's bounds {:?}..{:?}: a probe captures the room from inside it",
                    p.position,
                    bounds.min.to_array(),
                    bounds.max.to_array()
                ),
            ));
        }
        if let Some(r) = p.radius
            && !(r.is_finite() && r > 0.0)
        {
            return Err((at("radius"), format!("{r} is not a finite number > 0")));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn probe(name: &str, position: [f32; 3], radius: Option<f32>) -> ProbeDesc {
        ProbeDesc {
            name: name.into(),
            position,
            radius,
        }
    }

    #[test]
    fn bad_probes_name_their_field() {
        let bounds = Aabb::from_points([Vec3::ZERO, Vec3::ONE].iter());
        assert!(check(&[probe("a", [0.5; 3], Some(1.0))], &bounds).is_ok());
        let cases = [
            (vec![probe(" ", [0.5; 3], None)], "probes[0].name"),
            (
                vec![probe("a", [0.5; 3], None), probe("a", [0.2; 3], None)],
                "probes[1].name",
            ),
            (
                vec![probe("a", [f32::NAN, 0.5, 0.5], None)],
                "probes[0].position",
            ),
            (
                vec![probe("a", [0.5, 2.0, 0.5], None)],
                "probes[0].position",
            ),
            (vec![probe("a", [0.5; 3], Some(0.0))], "probes[0].radius"),
            (
                vec![probe("a", [0.5; 3], Some(f32::INFINITY))],
                "probes[0].radius",
            ),
        ];
        for (probes, field) in cases {
            assert_eq!(check(&probes, &bounds).unwrap_err().0, field);
        }
    }
}
