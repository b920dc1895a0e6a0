//! Emitters in image mode's M: drawn as geometry in the mirrored view, not splatted.
//!
//! A radiance map quantises every edge to its pixels: the splat of a map pixel whose centre
//! ray met a lamp covers that pixel's whole patch, so the lamp's image in a mirror spills up
//! to half a map pixel onto the ceiling beside it. Elsewhere that is a soft edge; on an
//! emitter, tens of times brighter than what surrounds it, it was most of glossy-room's
//! image-mode error (the `front` view's 10 worst pixels held 70% of it, all on the mirrored
//! lamp's edge). So map points that lie on an emissive triangle are left out of the splats,
//! and the emissive triangles themselves are drawn into M after the splats, exact to the
//! pixel; the neighbours' splats (and their gap fill) cover the ring the lamp's splats left.
//! Emitters are few triangles, so this costs next to nothing per frame.

use glam::Vec3;

use crate::scene::Scene;

/// The scene's emissive triangles, for testing whether a map point lies on one.
#[derive(Clone, Debug, Default)]
pub struct Emitters {
    /// Per triangle: a vertex, the two edges from it, the unit normal.
    triangles: Vec<[Vec3; 4]>,
    /// Their bounds, grown by `tolerance`.
    min: Vec3,
    max: Vec3,
    /// How far off a triangle's plane (metres) a point may lie and still be on it.
    tolerance: f32,
}

/// [`Emitters::tolerance`] as a fraction of the scene's diagonal: map points are stored as
/// 32-bit depths (relative error ~10⁻⁷), and a lamp hung a few millimetres below a ceiling
/// must not claim the ceiling's points.
pub const TOLERANCE_FRACTION: f32 = 1e-5;

impl Emitters {
    /// The emissive triangles of `scene` (by material emission; an emissive texture counts
    /// wherever its factor is non-zero).
    pub fn of_scene(scene: &Scene) -> Emitters {
        let tolerance = (scene.bounds.diagonal() * TOLERANCE_FRACTION).max(1e-6);
        let tris = scene.triangles.iter().filter(|t| {
            scene
                .materials
                .get(t.material as usize)
                .is_some_and(|m| m.is_emissive())
        });
        Emitters::new(tris.map(|t| t.p), tolerance)
    }

    /// Emitters of the given triangles (vertex positions); degenerate ones are skipped.
    pub fn new(triangles: impl IntoIterator<Item = [Vec3; 3]>, tolerance: f32) -> Emitters {
        let mut out = Emitters {
            triangles: Vec::new(),
            min: Vec3::splat(f32::INFINITY),
            max: Vec3::splat(f32::NEG_INFINITY),
            tolerance,
        };
        for p in triangles {
            let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
            let n = e1.cross(e2);
            if n.length_squared() <= 0.0 || !n.is_finite() {
                continue;
            }
            out.triangles.push([p[0], e1, e2, n.normalize()]);
            for v in p {
                out.min = out.min.min(v - Vec3::splat(tolerance));
                out.max = out.max.max(v + Vec3::splat(tolerance));
            }
        }
        out
    }

    /// How many emissive triangles there are.
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Whether `p` lies on an emissive triangle: within the tolerance of its plane and inside
    /// its edges (grown by the tolerance).
    pub fn contains(&self, p: Vec3) -> bool {
        if self.triangles.is_empty() || p.cmplt(self.min).any() || p.cmpgt(self.max).any() {
            return false;
        }
        self.triangles.iter().any(|&[a, e1, e2, n]| {
            let q = p - a;
            if q.dot(n).abs() > self.tolerance {
                return false;
            }
            // Barycentrics of q's projection onto the plane.
            let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
            let (q1, q2) = (q.dot(e1), q.dot(e2));
            let det = d11 * d22 - d12 * d12;
            let u = (d22 * q1 - d12 * q2) / det;
            let v = (d11 * q2 - d12 * q1) / det;
            // The tolerance as barycentric slack along each edge.
            let (su, sv) = (self.tolerance / d11.sqrt(), self.tolerance / d22.sqrt());
            u >= -su && v >= -sv && u + v <= 1.0 + su.max(sv)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 1 m² lamp at y = 2.99 under a ceiling at y = 3.
    fn lamp() -> Emitters {
        let (a, b, c, d) = (
            Vec3::new(0.0, 2.99, 0.0),
            Vec3::new(1.0, 2.99, 0.0),
            Vec3::new(1.0, 2.99, 1.0),
            Vec3::new(0.0, 2.99, 1.0),
        );
        Emitters::new([[a, b, c], [a, c, d]], 1e-4)
    }

    #[test]
    fn a_point_on_the_lamp_is_on_an_emitter() {
        let e = lamp();
        assert_eq!(e.len(), 2);
        for p in [
            Vec3::new(0.5, 2.99, 0.5),
            Vec3::new(0.01, 2.99, 0.99),
            // On the shared diagonal, and on the rim, up to float error.
            Vec3::new(0.3, 2.99, 0.3),
            Vec3::new(1.0, 2.99 + 5e-5, 0.2),
            Vec3::new(0.0, 2.99, 0.0),
        ] {
            assert!(e.contains(p), "{p}");
        }
    }

    #[test]
    fn the_ceiling_beside_and_above_the_lamp_is_not() {
        let e = lamp();
        for p in [
            // The ceiling 1 cm above, inside the lamp's outline and just outside it.
            Vec3::new(0.5, 3.0, 0.5),
            Vec3::new(1.001, 3.0, 0.5),
            // The lamp's plane, 1 mm beyond its edges.
            Vec3::new(1.001, 2.99, 0.5),
            Vec3::new(0.5, 2.99, -0.001),
            // Far away.
            Vec3::new(5.0, 0.0, 5.0),
        ] {
            assert!(!e.contains(p), "{p}");
        }
    }

    #[test]
    fn no_emitters_contain_nothing_and_degenerate_triangles_are_skipped() {
        let e = Emitters::new([[Vec3::ZERO, Vec3::X, 2.0 * Vec3::X]], 1e-3);
        assert!(e.is_empty());
        assert!(!e.contains(Vec3::ZERO) && !e.contains(Vec3::X));
    }
}
