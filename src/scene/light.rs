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
