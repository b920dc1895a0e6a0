//! Surfaces image mode draws into M as geometry, not as splats: emitters, curved
//! reflectors, and near-mirrors when they have terminal cube maps ([`super::terminal`]).
//!
//! A radiance map quantises every edge to its pixels: the splat of a map pixel whose centre
//! ray met a lamp covers that pixel's whole patch, so the lamp's image in a mirror spilled up
//! to half a map pixel onto the ceiling beside it. Elsewhere that is a soft edge; on an
//! emitter, tens of times brighter than what surrounds it, it is most of the error
//! (docs/tuning.md#exact-surfaces). A curved reflector's map points hold what it reflects
//! towards the map's centre of projection (`radiance::shading`), so a splatted teapot shows
//! its highlights where the map's camera saw them, not where the mirrored eye does.
//!
//! So map points that lie on these triangles are left out of the splats, and the triangles
//! themselves are drawn into M after the splats, exact to the pixel: kd·D (and emission) by
//! the mirror pipeline, then a curved reflector's specular term by its cube map, as geometry
//! mode does. The neighbours' splats (and their gap fill) cover the ring the left-out splats
//! leave. These are few triangles, so they cost little per frame.

use glam::Vec3;

use crate::geometry::{Aabb, Bvh, Triangle};
use crate::scene::{ReflectorKind, Scene};

/// The emissive triangles of `scene` (by material emission; an emissive texture counts
/// wherever its factor is non-zero) and those of its curved reflectors, in scene order.
pub fn exact_triangles(scene: &Scene) -> Vec<u32> {
    let mut exact: Vec<bool> = (0..scene.triangles.len() as u32)
        .map(|t| scene.material_of(t).is_emissive())
        .collect();
    for r in scene
        .reflectors
        .iter()
        .filter(|r| r.kind == ReflectorKind::Curved)
    {
        for &t in &r.triangles {
            if let Some(e) = exact.get_mut(t as usize) {
                *e = true;
            }
        }
    }
    (0..scene.triangles.len() as u32)
        .filter(|&i| exact[i as usize])
        .collect()
}

/// The triangles image mode draws exactly, for testing whether a map point lies on one.
pub struct ExactSurfaces {
    /// Their indices into the scene's triangles, in scene order.
    indices: Vec<u32>,
    bvh: Bvh,
    /// Their bounds, grown by `reach`.
    bounds: Aabb,
    /// Half the length of the probe ray through a point ([`ExactSurfaces::contains`]).
    reach: f32,
    /// How far along that ray (metres) a hit may lie from the point and still be it.
    tolerance: f32,
}

/// [`ExactSurfaces`]' tolerance as a fraction of the scene's diagonal: map points are stored
/// as 32-bit depths (relative error ~10⁻⁷), and a lamp hung a few millimetres below a ceiling
/// must not claim the ceiling's points.
pub const TOLERANCE_FRACTION: f32 = 1e-5;

/// The probe ray's half length as a fraction of the scene's diagonal.
pub const REACH_FRACTION: f32 = 1e-3;

impl ExactSurfaces {
    /// The [`exact_triangles`] of `scene` and `extra` ones (near-mirrors drawn with their
    /// terminal cube maps).
    pub fn of_scene(scene: &Scene, extra: &[u32]) -> ExactSurfaces {
        let diagonal = scene.bounds.diagonal();
        let mut all = exact_triangles(scene);
        all.extend_from_slice(extra);
        all.sort_unstable();
        all.dedup();
        ExactSurfaces::new(
            &scene.triangles,
            all,
            (diagonal * TOLERANCE_FRACTION).max(1e-6),
            (diagonal * REACH_FRACTION).max(1e-4),
        )
    }

    /// The surfaces of `triangles[indices]`, a point on one being within `tolerance` of it
    /// along a probe ray of half length `reach`.
    pub fn new(triangles: &[Triangle], indices: Vec<u32>, tolerance: f32, reach: f32) -> Self {
        let tris: Vec<Triangle> = indices.iter().map(|&i| triangles[i as usize]).collect();
        let bvh = Bvh::build(&tris);
        let mut bounds = bvh.bounds();
        bounds.min -= Vec3::splat(reach);
        bounds.max += Vec3::splat(reach);
        ExactSurfaces {
            indices,
            bvh,
            bounds,
            reach,
            tolerance,
        }
    }

    /// Their indices into the scene's triangles.
    pub fn triangles(&self) -> &[u32] {
        &self.indices
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// Whether `p`, seen from `from` (a map's centre of projection), lies on one of the
    /// triangles: a ray along the line of sight, from `reach` before `p` to `reach` past it,
    /// first meets one within the tolerance of `p`.
    pub fn contains(&self, from: Vec3, p: Vec3) -> bool {
        if self.indices.is_empty()
            || p.cmplt(self.bounds.min).any()
            || p.cmpgt(self.bounds.max).any()
        {
            return false;
        }
        let dir = (p - from).normalize_or_zero();
        if dir == Vec3::ZERO {
            return false;
        }
        self.bvh
            .closest_hit(p - dir * self.reach, dir, 2.0 * self.reach)
            .is_some_and(|h| (h.t - self.reach).abs() <= self.tolerance)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    fn tri(p: [Vec3; 3]) -> Triangle {
        Triangle {
            p,
            n: [Vec3::Y; 3],
            uv: [Vec2::ZERO; 3],
            uv1: None,
            material: 0,
            object: 0,
        }
    }

    /// A 1 m² lamp at y = 2.99 under a ceiling at y = 3 (triangles 2 and 3, after the
    /// ceiling's 0 and 1), seen from a map camera below.
    fn lamp() -> (ExactSurfaces, Vec3) {
        let y = |h: f32| {
            let (a, b, c, d) = (
                Vec3::new(0.0, h, 0.0),
                Vec3::new(1.0, h, 0.0),
                Vec3::new(1.0, h, 1.0),
                Vec3::new(0.0, h, 1.0),
            );
            [tri([a, b, c]), tri([a, c, d])]
        };
        let mut all = y(3.0).to_vec();
        all.extend(y(2.99));
        (
            ExactSurfaces::new(&all, vec![2, 3], 1e-4, 1e-2),
            Vec3::new(0.3, 0.0, -2.0),
        )
    }

    #[test]
    fn a_point_on_the_lamp_is_exact() {
        let (e, from) = lamp();
        assert_eq!(e.triangles(), [2, 3]);
        for p in [
            Vec3::new(0.5, 2.99, 0.5),
            Vec3::new(0.01, 2.99, 0.99),
            // On the shared diagonal, and on the rim, up to float error.
            Vec3::new(0.3, 2.99, 0.3),
            Vec3::new(0.999, 2.99 + 5e-5, 0.2),
        ] {
            assert!(e.contains(from, p), "{p}");
        }
    }

    #[test]
    fn the_ceiling_beside_and_above_the_lamp_is_not() {
        let (e, from) = lamp();
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
            assert!(!e.contains(from, p), "{p}");
        }
    }

    #[test]
    fn no_surfaces_contain_nothing() {
        let e = ExactSurfaces::new(&[], Vec::new(), 1e-3, 1e-2);
        assert!(e.is_empty());
        assert!(!e.contains(Vec3::NEG_Y, Vec3::ZERO));
    }
}
