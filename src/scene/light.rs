//! Area lights: a quad of scene.json's `lights`, resolved and checked.

use glam::Vec3;

use super::AreaLightDesc;

/// A resolved quad light.
#[derive(Clone, Debug, PartialEq)]
pub struct AreaLight {
    /// Name from scene.json.
    pub name: String,
    /// A corner.
    pub corner: Vec3,
    /// First edge.
    pub edge_u: Vec3,
    /// Second edge.
    pub edge_v: Vec3,
    /// Unit normal `edge_u × edge_v`: the emitting side.
    pub normal: Vec3,
    /// Area, m².
    pub area: f32,
    /// Emitted radiance.
    pub radiance: Vec3,
    /// Emits from both faces.
    pub two_sided: bool,
}

/// Resolves and checks a light of scene.json: finite values, radiance ≥ 0, a quad with area.
/// `Err` says what is wrong, naming the light.
pub(super) fn resolve(l: &AreaLightDesc) -> Result<AreaLight, String> {
    let v = |a: [f32; 3]| Vec3::from_array(a);
    let (corner, eu, ev, radiance) = (v(l.corner), v(l.edge_u), v(l.edge_v), v(l.radiance));
    if ![corner, eu, ev, radiance].iter().all(|x| x.is_finite()) {
        return Err(format!("light {:?}: a value is not finite", l.name));
    }
    if radiance.min_element() < 0.0 {
        return Err(format!(
            "light {:?}: radiance {radiance} is negative",
            l.name
        ));
    }
    let cross = eu.cross(ev);
    let area = cross.length();
    if area <= 1e-12 * eu.length_squared().max(ev.length_squared()) || area == 0.0 {
        return Err(format!(
            "light {:?}: edges {eu} and {ev} are parallel or zero: the quad has no area",
            l.name
        ));
    }
    Ok(AreaLight {
        name: l.name.clone(),
        corner,
        edge_u: eu,
        edge_v: ev,
        normal: cross / area,
        area,
        radiance,
        two_sided: l.two_sided,
    })
}

impl AreaLight {
    /// What a ray from `origin` along unit `dir` receives from this light where it crosses
    /// it before `t_max`: its radiance from the emitting side (either side when two-sided),
    /// nothing from behind or where it passes by. The light is not geometry: the ray goes on
    /// to whatever lies behind it, as the path tracer's BRDF-sampled rays do.
    pub fn seen_along(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Vec3 {
        let facing = -dir.dot(self.normal);
        if !(facing > 0.0 || (self.two_sided && facing < 0.0)) {
            return Vec3::ZERO;
        }
        let crossed =
            crate::geometry::ray_quad(origin, dir, self.corner, self.edge_u, self.edge_v, t_max);
        if crossed.is_some() {
            self.radiance
        } else {
            Vec3::ZERO
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn light(two_sided: bool) -> AreaLight {
        // A 1 m square in the plane z = 2, emitting towards −z.
        AreaLight {
            name: "l".into(),
            corner: Vec3::new(-0.5, -0.5, 2.0),
            edge_u: Vec3::Y,
            edge_v: Vec3::X,
            normal: Vec3::NEG_Z,
            area: 1.0,
            radiance: Vec3::new(3.0, 2.0, 1.0),
            two_sided,
        }
    }

    #[test]
    fn a_ray_sees_a_light_from_its_emitting_side_before_its_hit() {
        let l = light(false);
        assert_eq!(l.normal, l.edge_u.cross(l.edge_v));
        assert_eq!(l.seen_along(Vec3::ZERO, Vec3::Z, f32::INFINITY), l.radiance);
        // Something in front of the light hides it; one behind it does not.
        assert_eq!(l.seen_along(Vec3::ZERO, Vec3::Z, 1.5), Vec3::ZERO);
        assert_eq!(l.seen_along(Vec3::ZERO, Vec3::Z, 2.5), l.radiance);
        // Past its edge, or from behind.
        let aside = Vec3::new(0.4, 0.0, 1.0).normalize();
        assert_eq!(l.seen_along(Vec3::ZERO, aside, f32::INFINITY), Vec3::ZERO);
        let behind = Vec3::new(0.0, 0.0, 4.0);
        assert_eq!(l.seen_along(behind, Vec3::NEG_Z, f32::INFINITY), Vec3::ZERO);
        assert_eq!(
            light(true).seen_along(behind, Vec3::NEG_Z, f32::INFINITY),
            l.radiance
        );
    }
}
