//! Planes fitted to triangles: of planar reflectors and of `surface` billboards.

use glam::Vec3;

use crate::geometry::{Aabb, Triangle};

/// A plane: points p with normal·p = offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// Unit normal (the side the reflector faces).
    pub normal: Vec3,
    /// A point on the plane (the area-weighted centroid of the reflector).
    pub point: Vec3,
}

/// Fits a plane to the triangles (area-weighted normal and centroid) and checks that every
/// vertex lies within `tol` × the bounding-box diagonal of it.
pub(super) fn fit_plane(
    triangles: &[Triangle],
    selected: &[u32],
    tol: f32,
) -> Result<Plane, String> {
    let bounds = Aabb::from_points(
        selected
            .iter()
            .flat_map(|&t| triangles[t as usize].p.iter()),
    );
    fit_plane_sized(triangles, selected, tol, bounds.diagonal())
}

/// [`fit_plane`] with the vertices' distances measured against `tol` × `size` (metres): the
/// size of the object a face set belongs to rather than of the face set itself.
pub(super) fn fit_plane_sized(
    triangles: &[Triangle],
    selected: &[u32],
    tol: f32,
    size: f32,
) -> Result<Plane, String> {
    let mut normal_sum = glam::DVec3::ZERO;
    let mut centroid = glam::DVec3::ZERO;
    let mut area = 0.0f64;
    for &t in selected {
        let t = &triangles[t as usize];
        let c = t.cross().as_dvec3();
        let a = 0.5 * c.length();
        normal_sum += c;
        centroid += a * (t.p[0] + t.p[1] + t.p[2]).as_dvec3() / 3.0;
        area += a;
    }
    let n = normal_sum.normalize_or_zero();
    if n == glam::DVec3::ZERO || normal_sum.length() < 0.5 * 2.0 * area {
        return Err(
            "declared planar, but its triangles face opposite ways (a closed or folded shape); declare it \"curved\""
                .into(),
        );
    }
    let centroid = centroid / area;
    let size = size as f64;
    let worst = selected
        .iter()
        .flat_map(|&t| triangles[t as usize].p.iter())
        .map(|p| (p.as_dvec3() - centroid).dot(n).abs())
        .fold(0.0f64, f64::max);
    if worst > tol as f64 * size {
        return Err(format!(
            "declared planar, but a vertex lies {worst:.4} m from the fitted plane, {:.2e} of its size {size:.3} m (tolerance {tol:.1e}); declare it \"curved\" or raise planarity_tolerance",
            worst / size
        ));
    }
    Ok(Plane {
        normal: n.as_vec3(),
        point: centroid.as_vec3(),
    })
}
