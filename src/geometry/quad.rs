//! Ray–parallelogram intersection, for area lights (quads that are not part of the BVH).

use glam::Vec3;

/// Distance along `dir` (unit) from `origin` to the parallelogram `corner + s·edge_u + t·edge_v`,
/// s, t ∈ [0, 1], when the ray crosses it at a distance in (0, `t_max`); either face counts.
pub fn ray_quad(
    origin: Vec3,
    dir: Vec3,
    corner: Vec3,
    edge_u: Vec3,
    edge_v: Vec3,
    t_max: f32,
) -> Option<f32> {
    let n = edge_u.cross(edge_v);
    let denom = dir.dot(n);
    if denom == 0.0 || !denom.is_finite() {
        return None;
    }
    let t = (corner - origin).dot(n) / denom;
    if !(t > 0.0 && t < t_max) {
        return None;
    }
    // Coordinates of the crossing in the (edge_u, edge_v) basis, by Cramer's rule with n.
    let w = origin + dir * t - corner;
    let nn = n.length_squared();
    let s = w.cross(edge_v).dot(n) / nn;
    let r = edge_u.cross(w).dot(n) / nn;
    ((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&r)).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    const C: Vec3 = Vec3::new(-1.0, 2.0, -1.0);
    const U: Vec3 = Vec3::new(2.0, 0.0, 0.0);
    const V: Vec3 = Vec3::new(0.0, 0.0, 2.0);

    #[test]
    fn hits_inside_from_either_side_and_misses_outside() {
        let up = ray_quad(Vec3::ZERO, Vec3::Y, C, U, V, f32::INFINITY);
        assert_eq!(up, Some(2.0));
        let down = ray_quad(Vec3::new(0.5, 5.0, 0.5), -Vec3::Y, C, U, V, f32::INFINITY);
        assert_eq!(down, Some(3.0));
        // Just past an edge, and behind the origin.
        assert_eq!(
            ray_quad(Vec3::new(1.01, 0.0, 0.0), Vec3::Y, C, U, V, f32::INFINITY),
            None
        );
        assert_eq!(ray_quad(Vec3::ZERO, -Vec3::Y, C, U, V, f32::INFINITY), None);
        // Parallel to the plane, and beyond t_max.
        assert_eq!(
            ray_quad(Vec3::new(0.0, 2.0, 0.0), Vec3::X, C, U, V, f32::INFINITY),
            None
        );
        assert_eq!(ray_quad(Vec3::ZERO, Vec3::Y, C, U, V, 1.5), None);
    }

    #[test]
    fn an_oblique_ray_lands_where_the_plane_equation_says() {
        let d = Vec3::new(0.3, 1.0, -0.2).normalize();
        let t = ray_quad(Vec3::ZERO, d, C, U, V, f32::INFINITY).unwrap();
        let p = d * t;
        assert!((p.y - 2.0).abs() < 1e-5, "{p}");
        // A skewed parallelogram: its far corner is inside, a point past it is not.
        let (u, v) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 1.0));
        let far = C + u + v - Vec3::new(1e-3, 0.0, 1e-3);
        let dir = (far - Vec3::ZERO).normalize();
        assert!(ray_quad(Vec3::ZERO, dir, C, u, v, f32::INFINITY).is_some());
        let out = C + u * 1.1 + v;
        let dir = (out - Vec3::ZERO).normalize();
        assert_eq!(ray_quad(Vec3::ZERO, dir, C, u, v, f32::INFINITY), None);
    }
}
