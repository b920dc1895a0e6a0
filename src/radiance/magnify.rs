//! How much a mirror's radiance maps magnify what the scene's camera paths see in it: a map
//! pixel seen from its camera on the element's hemisphere against the eye's pixel, both at
//! the reflected point. Where the maps' pixels come out many eye pixels wide, image mode's
//! splats tear at silhouettes; finer maps shrink them (docs/tuning.md#mirror-map-resolution).

/// Frame height (pixels) at which the eye's angle per pixel is taken: the viewer's default
/// size (720×486).
pub const EYE_HEIGHT: f32 = 486.0;

/// Magnification above which a mirror's maps are doubled, met by the quantile
/// [`MAGNIFIED_QUANTILE`] of the looks into it (docs/tuning.md#mirror-map-resolution).
pub const MAGNIFIED: f32 = 5.0;

/// Which quantile of the looks decides: a torn silhouette shows wherever it falls, so the
/// most magnified looks count, not the typical one.
pub const MAGNIFIED_QUANTILE: f32 = 0.9;

/// Most a mirror's map resolution is multiplied by: bytes and bake time grow with its square,
/// and matching the eye's pixel everywhere would take maps near a thousand pixels wide.
pub const MAX_FACTOR: u32 = 2;

/// One eye ray that meets the mirror and, reflected, the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Look {
    /// Distance from the eye to the mirror point.
    pub to_mirror: f32,
    /// Distance from the mirror point to the reflected point.
    pub beyond: f32,
    /// The eye's angle per pixel (radians).
    pub eye_pixel: f32,
}

/// A map camera's pixel: its angle (radians) from the pole camera at `resolution`, and the
/// pole camera's distance behind the element, for an element with edges `edge_u`, `edge_v`
/// (lengths): the hemisphere's radius is half the element's diagonal.
pub fn map_pixel(edge_u: f32, edge_v: f32, resolution: u32) -> (f32, f32) {
    let radius = 0.5 * (edge_u * edge_u + edge_v * edge_v).sqrt();
    let angle = edge_u.max(edge_v) / resolution as f32 / radius.max(1e-9);
    (angle, radius)
}

/// How many eye pixels one map pixel spans at the reflected point of `look`: the map pixel's
/// footprint there (its camera lies `radius` behind the mirror) over the eye pixel's.
pub fn magnification(look: &Look, map_angle: f32, radius: f32) -> f32 {
    map_angle * (radius + look.beyond)
        / (look.eye_pixel * (look.to_mirror + look.beyond)).max(1e-12)
}

/// The `q` quantile (in [0, 1], nearest rank) of `values`; `None` when empty.
pub fn quantile(values: &[f32], q: f32) -> Option<f32> {
    let mut v: Vec<f32> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f32::total_cmp);
    let i = ((q.clamp(0.0, 1.0) * (v.len() - 1) as f32).round() as usize).min(v.len() - 1);
    Some(v[i])
}

/// The factor (a power of two, 1 to [`MAX_FACTOR`]) by which a mirror's maps of `resolution`
/// are refined for `looks` into it: doubled while the [`MAGNIFIED_QUANTILE`] of their
/// magnification exceeds [`MAGNIFIED`]. No looks (no camera path sees the mirror): 1.
pub fn factor(looks: &[Look], edge_u: f32, edge_v: f32, resolution: u32) -> u32 {
    let mut f = 1;
    while f < MAX_FACTOR {
        let (angle, radius) = map_pixel(edge_u, edge_v, resolution * f);
        let m: Vec<f32> = looks
            .iter()
            .map(|l| magnification(l, angle, radius))
            .collect();
        match quantile(&m, MAGNIFIED_QUANTILE) {
            Some(q) if q > MAGNIFIED => f *= 2,
            _ => break,
        }
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_far_point_is_magnified_by_the_map_pixel_over_the_eye_pixel() {
        let (angle, radius) = map_pixel(1.0, 1.0, 128);
        assert!((angle - 2f32.sqrt() / 128.0).abs() < 1e-6);
        let far = Look {
            to_mirror: 1.0,
            beyond: 1e6,
            eye_pixel: 1e-3,
        };
        assert!((magnification(&far, angle, radius) - angle / 1e-3).abs() < 1e-2);
        // At the mirror itself the two cameras' distances decide.
        let near = Look { beyond: 0.0, ..far };
        let m = magnification(&near, angle, radius);
        assert!((m - angle * radius / 1e-3).abs() < 1e-3, "{m}");
    }

    #[test]
    fn maps_double_only_where_the_looks_are_magnified_and_at_most_once() {
        let look = |eye_pixel| Look {
            to_mirror: 1.0,
            beyond: 1.0,
            eye_pixel,
        };
        // 1 m elements at 128²: a map pixel spans about 11 mrad at the pole camera.
        assert_eq!(factor(&[look(5e-3); 10], 1.0, 1.0, 128), 1);
        assert_eq!(factor(&[look(1e-3); 10], 1.0, 1.0, 128), 2);
        assert_eq!(factor(&[look(1e-5); 10], 1.0, 1.0, 128), MAX_FACTOR);
        assert_eq!(factor(&[], 1.0, 1.0, 128), 1);
        // One magnified look in ten is not the quantile.
        let mut few = vec![look(5e-3); 9];
        few.push(look(1e-3));
        assert_eq!(factor(&few, 1.0, 1.0, 128), 1);
    }

    #[test]
    fn the_quantile_is_a_nearest_rank() {
        assert_eq!(quantile(&[], 0.5), None);
        assert_eq!(quantile(&[3.0, 1.0, 2.0], 0.5), Some(2.0));
        assert_eq!(quantile(&[3.0, 1.0, 2.0, f32::NAN], 1.0), Some(3.0));
    }
}
