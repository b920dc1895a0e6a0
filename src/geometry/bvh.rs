//! Ray casting over the scene's triangles with an eight-wide BVH (`wide`) built from obvhs'
//! BVH2.

mod wide;

use std::sync::Arc;

use glam::{Vec2, Vec3};
use obvhs::triangle::Triangle as BvhTriangle;

use super::{Aabb, Triangle};
use wide::{LeafHit, PACKET, WideBvh, WideRay};

/// The nearest intersection along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) ray direction.
    pub t: f32,
    /// Index of the hit triangle in the scene's triangle list.
    pub triangle: u32,
    /// Barycentrics (u, v) of the hit: p = (1 − u − v)·p0 + u·p1 + v·p2.
    pub bary: Vec2,
}

/// A BVH over a triangle list, answering closest-hit and occlusion queries.
///
/// Triangles are stored in the BVH's leaf order as (v0, e1, e2), which saves an indirection
/// and two subtractions per intersection test.
pub struct Bvh {
    /// `None` for an empty triangle list.
    wide: Option<WideBvh>,
    bounds: Aabb,
    epsilon: f32,
    /// Hits this rejects are passed through (alpha cut-outs); `None`: every hit counts.
    filter: Option<HitFilter>,
}

/// Whether a hit on triangle (caller's index) at barycentrics counts; `false` lets the ray
/// pass (see [`Bvh::with_filter`]).
pub type HitFilter = Arc<dyn Fn(u32, Vec2) -> bool + Send + Sync>;

impl Bvh {
    /// Builds the BVH (in parallel with rayon). The result does not depend on the thread count.
    pub fn build(triangles: &[Triangle]) -> Bvh {
        let tris: Vec<BvhTriangle> = triangles
            .iter()
            .map(|t| BvhTriangle {
                v0: t.p[0].into(),
                v1: t.p[1].into(),
                v2: t.p[2].into(),
            })
            .collect();
        let bounds = Aabb::from_points(triangles.iter().flat_map(|t| t.p.iter()));
        if tris.is_empty() {
            return Bvh {
                wide: None,
                bounds,
                epsilon: 0.0,
                filter: None,
            };
        }
        Bvh {
            wide: Some(WideBvh::build(&tris, wide::BUILD)),
            bounds,
            epsilon: scene_epsilon(&bounds),
            filter: None,
        }
    }

    /// Bounds of all triangles.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Self-intersection offset for this scene: relative to its size, so a 1 mm scene and a
    /// 1 km scene behave the same up to scale.
    pub fn epsilon(&self) -> f32 {
        self.epsilon
    }

    /// Moves a surface point off its surface along `normal` (towards the side the ray leaves
    /// from), far enough that a ray from it does not hit the surface it starts on.
    pub fn offset_origin(&self, p: Vec3, normal: Vec3) -> Vec3 {
        // f32 spacing grows with |p|: keep the offset above a few ulps of the coordinates.
        let eps = self
            .epsilon
            .max(p.abs().max_element() * 64.0 * f32::EPSILON);
        p + normal * eps
    }

    /// The nearest hit along `dir` (unit length) from `origin` in (0, t_max).
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
        match &self.filter {
            Some(f) => self.closest_hit_where(origin, dir, t_max, &**f),
            None => {
                let w = self.wide.as_ref()?;
                let r = WideRay::new(origin.into(), dir.into());
                self.hit(w.closest(&r, t_max, |_, _, _| true))
            }
        }
    }

    /// [`Bvh::closest_hit`] for many rays (`origins[i]`, `dirs[i]`), each the same hit to the
    /// bit, found by tracing packets of eight consecutive rays together: faster for coherent
    /// rays, such as a camera's in pixel order (benches/bvh.rs). Calls `each(i, hit)` for every
    /// ray, in order.
    pub fn closest_hits(
        &self,
        origins: &[Vec3],
        dirs: &[Vec3],
        t_max: f32,
        mut each: impl FnMut(usize, Option<Hit>),
    ) {
        assert_eq!(origins.len(), dirs.len());
        let Some(w) = self.wide.as_ref().filter(|_| self.filter.is_none()) else {
            for (i, (&o, &d)) in origins.iter().zip(dirs).enumerate() {
                each(i, self.closest_hit(o, d, t_max));
            }
            return;
        };
        let (o8, o_rest) = origins.as_chunks::<PACKET>();
        let (d8, d_rest) = dirs.as_chunks::<PACKET>();
        for (k, (o, d)) in o8.iter().zip(d8).enumerate() {
            let rays: [WideRay; PACKET] =
                std::array::from_fn(|i| WideRay::new(o[i].into(), d[i].into()));
            for (i, h) in w.closest_packet(&rays, t_max).into_iter().enumerate() {
                each(k * PACKET + i, self.hit(h));
            }
        }
        let done = o8.len() * PACKET;
        for (i, (&o, &d)) in o_rest.iter().zip(d_rest).enumerate() {
            each(done + i, self.closest_hit(o, d, t_max));
        }
    }

    /// The [`Hit`] for a leaf's hit: its barycentrics clamped into the triangle so attribute
    /// lookups at edges stay inside it.
    fn hit(&self, found: Option<LeafHit>) -> Option<Hit> {
        let h = found?;
        Some(Hit {
            t: h.t,
            triangle: h.original,
            bary: clamp_bary(h.u, h.v),
        })
    }

    /// Whether anything blocks the segment from `origin` along `dir` (unit) up to `t_max`.
    pub fn occluded(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        if let Some(f) = &self.filter {
            return self.occluded_where(origin, dir, t_max, &**f);
        }
        let Some(w) = &self.wide else {
            return false;
        };
        let r = WideRay::new(origin.into(), dir.into());
        w.any(&r, t_max, |_, _, _| true)
    }

    /// Number of triangles in the BVH.
    pub fn len(&self) -> usize {
        self.wide
            .as_ref()
            .map_or(0, |w| w.original.iter().filter(|&&i| i != u32::MAX).count())
    }

    /// Whether the BVH holds no triangle.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl Bvh {
    /// This BVH with `filter` applied to every query: a hit it rejects does not stop the ray
    /// (an alpha-masked cut-out), the ray goes on to the next.
    pub fn with_filter(mut self, filter: HitFilter) -> Bvh {
        self.filter = Some(filter);
        self
    }

    /// [`Bvh::closest_hit`] counting only hits `keep(triangle, bary)` accepts.
    pub fn closest_hit_where(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
        keep: &(dyn Fn(u32, Vec2) -> bool + Send + Sync),
    ) -> Option<Hit> {
        let w = self.wide.as_ref()?;
        let r = WideRay::new(origin.into(), dir.into());
        self.hit(w.closest(&r, t_max, |slot, u, v| kept(w, slot, u, v, keep)))
    }

    /// [`Bvh::occluded`] counting only hits `keep(triangle, bary)` accepts.
    pub fn occluded_where(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
        keep: &(dyn Fn(u32, Vec2) -> bool + Send + Sync),
    ) -> bool {
        let Some(w) = &self.wide else {
            return false;
        };
        let r = WideRay::new(origin.into(), dir.into());
        w.any(&r, t_max, |slot, u, v| kept(w, slot, u, v, keep))
    }
}

/// Whether `keep` accepts the ray's hit on leaf slot `slot` at the leaf test's (u, v).
fn kept(
    w: &WideBvh,
    slot: usize,
    u: f32,
    v: f32,
    keep: &(dyn Fn(u32, Vec2) -> bool + Send + Sync),
) -> bool {
    keep(w.original[slot], clamp_bary(u, v))
}

/// The default self-intersection offset for a scene of these bounds.
pub fn scene_epsilon(bounds: &Aabb) -> f32 {
    1e-5 * bounds.diagonal()
}

/// Barycentrics of the ray's crossing of the triangle's plane (Möller–Trumbore), clamped
/// into the triangle: what the leaf tests give, computed afresh (the tests compare them).
#[cfg(test)]
fn barycentrics(t: &wide::Tri, o: glam::Vec3A, d: glam::Vec3A) -> Vec2 {
    let pvec = d.cross(t.e2);
    let inv_det = 1.0 / t.e1.dot(pvec);
    let tvec = o - t.v0;
    let u = tvec.dot(pvec) * inv_det;
    let qvec = tvec.cross(t.e1);
    let v = d.dot(qvec) * inv_det;
    clamp_bary(u, v)
}

/// Barycentrics clamped into the triangle.
fn clamp_bary(u: f32, v: f32) -> Vec2 {
    let u = u.clamp(0.0, 1.0);
    Vec2::new(u, v.clamp(0.0, 1.0 - u))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(z: f32, size: f32, material: u32) -> [Triangle; 2] {
        let p = [
            Vec3::new(-size, -size, z),
            Vec3::new(size, -size, z),
            Vec3::new(size, size, z),
            Vec3::new(-size, size, z),
        ];
        let mk = |a: usize, b: usize, c: usize| Triangle {
            p: [p[a], p[b], p[c]],
            n: [Vec3::Z; 3],
            uv: [Vec2::ZERO; 3],
            uv1: None,
            material,
            object: 0,
        };
        [mk(0, 1, 2), mk(0, 2, 3)]
    }

    #[test]
    fn closest_hit_finds_the_nearer_of_two_planes() {
        for scale in [1e-3_f32, 1.0, 1e3] {
            let mut tris = quad(-2.0 * scale, scale, 0).to_vec();
            tris.extend(quad(-5.0 * scale, scale, 1));
            let bvh = Bvh::build(&tris);
            let o = Vec3::new(0.25, 0.5, 0.0) * scale;
            // −Z is (−0, −0, −1): the negative zeros must not make the ray miss.
            let hit = bvh
                .closest_hit(o, -Vec3::Z, f32::INFINITY)
                .unwrap_or_else(|| panic!("miss at scale {scale}"));
            assert!(
                (hit.t - 2.0 * scale).abs() <= 1e-5 * scale,
                "{scale}: {hit:?}"
            );
            let t = &tris[hit.triangle as usize];
            assert_eq!(t.material, 0);
            let p = t.point(hit.bary);
            assert!((p - (o - Vec3::Z * hit.t)).length() < 1e-5 * scale);
            // t_max before the first plane: no hit, and not occluded.
            assert!(bvh.closest_hit(o, -Vec3::Z, 1.5 * scale).is_none());
            assert!(!bvh.occluded(o, -Vec3::Z, 1.5 * scale));
            assert!(bvh.occluded(o, -Vec3::Z, 2.5 * scale));
            // Pointing away: nothing.
            assert!(bvh.closest_hit(o, Vec3::Z, f32::INFINITY).is_none());
        }
    }

    #[test]
    fn a_filter_lets_rejected_hits_through() {
        let mut tris = quad(-2.0, 1.0, 0).to_vec();
        tris.extend(quad(-5.0, 1.0, 1));
        // Triangle 0 (the near quad's lower-right half, u > v side) is cut where bary.x > 0.5.
        let bvh = Bvh::build(&tris).with_filter(Arc::new(|tri, b| !(tri == 0 && b.x > 0.5)));
        let down = -Vec3::Z;
        // Over triangle 0 near vertex 1 (x = 1, y = −1): cut, the far plane is hit.
        let o = Vec3::new(0.8, -0.8, 0.0);
        let h = bvh.closest_hit(o, down, f32::INFINITY).unwrap();
        assert!((h.t - 5.0).abs() < 1e-5, "{h:?}");
        assert!(!bvh.occluded(o, down, 4.0));
        assert!(bvh.occluded(o, down, 6.0));
        // Over triangle 0 near vertex 0: kept.
        let o = Vec3::new(-0.5, -0.9, 0.0);
        let h = bvh.closest_hit(o, down, f32::INFINITY).unwrap();
        assert!((h.t - 2.0).abs() < 1e-5 && h.triangle == 0, "{h:?}");
        assert!(bvh.occluded(o, down, 4.0));
    }

    #[test]
    fn rays_through_a_shared_edge_hit() {
        // The quad's diagonal runs from (−1, −1) to (1, 1): rays straight down onto it.
        let tris = quad(0.0, 1.0, 0).to_vec();
        let bvh = Bvh::build(&tris);
        for k in -9..=9 {
            let x = k as f32 / 10.0;
            let o = Vec3::new(x, x, 1.0);
            assert!(
                bvh.closest_hit(o, -Vec3::Z, f32::INFINITY).is_some(),
                "miss at ({x}, {x})"
            );
            assert!(bvh.occluded(o, -Vec3::Z, 2.0), "not occluded at ({x}, {x})");
        }
    }

    /// Two walls meeting at a right angle along the y axis (floor z = 0, wall x = 0), `size`
    /// across.
    fn corner(size: f32) -> Vec<Triangle> {
        let mut tris = quad(0.0, size, 0).to_vec();
        // The wall x = 0: the floor quad turned about the y axis.
        for t in quad(0.0, size, 1) {
            let turn = |p: Vec3| Vec3::new(0.0, p.y, p.x + size);
            tris.push(Triangle {
                p: t.p.map(turn),
                n: [Vec3::X; 3],
                ..t
            });
        }
        tris
    }

    #[test]
    fn a_wall_right_beside_the_origin_is_hit_at_every_scale() {
        // obvhs culls nodes nearer than 1e-4 along the ray; the wall is far nearer here. The
        // smallest gap is the scene's own self-intersection offset (1e-5 of its diagonal).
        for scale in [1e-5_f32, 1e-3, 1.0, 1e3] {
            let bvh = Bvh::build(&corner(scale));
            for gap in [1e-5_f32, 1e-4, 1e-2, 0.5] {
                let d = gap * scale;
                let o = Vec3::new(d, 0.3 * scale, 0.25 * scale);
                let hit = bvh
                    .closest_hit(o, -Vec3::X, f32::INFINITY)
                    .unwrap_or_else(|| panic!("scale {scale}, gap {gap}: the wall was missed"));
                assert_eq!(hit.triangle / 2, 1, "scale {scale}, gap {gap}: {hit:?}");
                assert!(
                    (hit.t - d).abs() <= 1e-3 * d + 1e3 * f32::EPSILON * scale,
                    "scale {scale}, gap {gap}: t {} for a wall {d} away",
                    hit.t
                );
                assert!(
                    bvh.occluded(o, -Vec3::X, 2.0 * d),
                    "scale {scale}, gap {gap}"
                );
                // Short of the wall: nothing, and nothing behind the origin either.
                assert!(bvh.closest_hit(o, -Vec3::X, 0.5 * d).is_none());
                assert!(!bvh.occluded(o, -Vec3::X, 0.5 * d));
                assert!(bvh.closest_hit(o, Vec3::X, f32::INFINITY).is_none());
            }
        }
    }

    #[test]
    fn offset_origin_avoids_self_intersection() {
        let tris = quad(0.0, 1.0, 0).to_vec();
        let bvh = Bvh::build(&tris);
        let p = Vec3::new(0.3, 0.2, 0.0);
        let o = bvh.offset_origin(p, Vec3::Z);
        assert!(o.z > 0.0);
        assert!(!bvh.occluded(o, Vec3::new(0.0, 0.6, 0.8), f32::INFINITY));
    }

    #[test]
    fn empty_bvh_answers_misses() {
        let bvh = Bvh::build(&[]);
        assert!(bvh.is_empty());
        assert!(bvh.closest_hit(Vec3::ZERO, Vec3::X, 1.0).is_none());
        assert!(!bvh.occluded(Vec3::ZERO, Vec3::X, 1.0));
    }

    /// Packets give each ray the hit it gets alone, to the bit, with both node and leaf tests
    /// (portable, and AVX where the CPU has it), on a real mesh: coherent camera packets
    /// (some rays leaving the room), packets of rays spread over an octant from spread
    /// origins, axis-parallel and zero directions, and a finite t_max.
    #[test]
    fn packets_find_the_hits_of_single_rays() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/scenes/bunny-mirror/scene.json"
        );
        let scene = crate::scene::Scene::load(path).unwrap();
        let mut bvh = Bvh::build(&scene.triangles);
        let (c, size) = (scene.bounds.center(), scene.bounds.diagonal());
        let mut state = 0x853c_49e6_748f_ea9b_u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut origins = Vec::new();
        let mut dirs = Vec::new();
        // Camera packets: rows of eight pixels, from inside and from outside the room.
        for k in 0..24 {
            let eye = if k % 3 == 0 {
                c + Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * size * 1.5
            } else {
                c + Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * size * 0.3
            };
            let fwd = (Vec3::new(next(), next(), next()) - 0.5).normalize();
            let (right, up) = fwd.any_orthonormal_pair();
            for y in 0..16 {
                for x in 0..64 {
                    let (sx, sy) = (x as f32 / 64.0 - 0.5, y as f32 / 16.0 - 0.5);
                    origins.push(eye);
                    dirs.push((fwd + right * sx * 1.2 + up * sy * 0.4).normalize());
                }
            }
        }
        // Incoherent packets: random origins in the scene, directions within one octant (so
        // the packet is traced together over very wide intervals), or anywhere (one by one).
        for k in 0..4000 {
            origins.push(c + Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * size * 0.6);
            let d = Vec3::new(next(), next(), next()) + 0.01;
            let signs = Vec3::new(
                if (k / 8) & 1 == 0 { 1.0 } else { -1.0 },
                if (k / 16) & 1 == 0 { 1.0 } else { -1.0 },
                if k % 40 < 8 { next() - 0.5 } else { 1.0 },
            );
            dirs.push((d * signs).normalize());
        }
        // Degenerate directions: axis-parallel (zeros of either sign), tiny, zero.
        for k in 0..800 {
            origins.push(c + Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * size * 0.4);
            let axis = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X][(k / 8) % 4];
            dirs.push(match k % 8 {
                0 => Vec3::new(-0.0, 0.0, -0.0) + axis,
                1 => axis + Vec3::splat(1e-35),
                2 if k % 40 == 2 => Vec3::ZERO,
                _ => axis,
            });
        }
        // And with every fifth triangle doubled: coincident copies, hit at the same distance,
        // of which a ray keeps the first it meets (traced again alone in a packet).
        let mut doubled = scene.triangles.clone();
        doubled.extend(scene.triangles.iter().step_by(5).cloned());
        let mut hits = 0;
        for (avx, tris) in [(false, 0), (true, 0), (false, 1), (true, 1)] {
            if avx && !wide::avx_detected() {
                continue;
            }
            if tris == 1 {
                bvh = Bvh::build(&doubled);
            }
            bvh.wide.as_mut().unwrap().set_avx(avx);
            for t_max in [f32::INFINITY, 0.3 * size] {
                let mut got = vec![None; origins.len()];
                bvh.closest_hits(&origins, &dirs, t_max, |i, h| got[i] = h);
                for (i, g) in got.iter().enumerate() {
                    let want = bvh.closest_hit(origins[i], dirs[i], t_max);
                    let bits = |h: &Option<Hit>| {
                        h.map(|h| {
                            (
                                h.triangle,
                                h.t.to_bits(),
                                h.bary.to_array().map(f32::to_bits),
                            )
                        })
                    };
                    assert_eq!(
                        bits(g),
                        bits(&want),
                        "ray {i}, avx {avx}, doubled {tris}, t_max {t_max}"
                    );
                    hits += want.is_some() as usize;
                }
            }
        }
        let n = origins.len();
        assert!(
            hits > 4 * n / 2 && hits < 8 * n * 9 / 10,
            "{hits} hits of {n} rays, eight passes"
        );
    }
}
