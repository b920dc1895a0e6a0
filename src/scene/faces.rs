//! Coplanar face sets of an object: when a planar reflector is one face of a solid (a slab
//! mirror's front, beside its back and bevelled edges), the triangles that make up that face.
//! Pure geometry.

use std::collections::HashMap;

use glam::{DVec3, Vec3};

use crate::geometry::Triangle;

/// Largest angle between a triangle's normal and its face set's seed normal (the normal of the
/// set's largest triangle), degrees.
pub const COPLANAR_ANGLE_DEG: f64 = 1.0;

/// Smallest share a face set must hold of the area of its object's faces that face its way
/// (normal · its normal > 0) to reflect as the object's plane: a slab mirror's front against
/// its bevels holds about 0.97, its back 1; half of a bent panel holds 0.5, a curved object's
/// largest flat patch far less.
pub const MIN_FACE_SHARE: f64 = 0.75;

/// The share of the area of the face sets facing `set`'s way (normal · its normal > 0, `set`
/// included) that `set` holds.
pub fn share_of_its_side(set: &FaceSet, sets: &[FaceSet]) -> f64 {
    let side: f64 = sets
        .iter()
        .filter(|s| s.normal.dot(set.normal) > 0.0)
        .map(|s| s.area)
        .sum();
    if side > 0.0 { set.area / side } else { 0.0 }
}

/// Triangles of an object that lie in one plane and face one way.
#[derive(Clone, Debug, PartialEq)]
pub struct FaceSet {
    /// Its triangles (indices into the scene's triangles), in ascending order.
    pub triangles: Vec<u32>,
    /// Area-weighted unit normal.
    pub normal: Vec3,
    /// Total area, m².
    pub area: f64,
}

/// Splits `selected` into coplanar face sets, largest area first (ties: the set whose largest
/// triangle comes first in `selected`'s area order). Greedy over triangles by decreasing area
/// (ties by index): a triangle joins the first set whose seed normal lies within
/// [`COPLANAR_ANGLE_DEG`] of its own and whose seed plane all three of its vertices lie within
/// `max_offset` metres of; otherwise it seeds a new set. Triangles of zero area belong to none.
/// Deterministic; about linear in the triangle count (seeds are looked up by quantised normal).
pub fn coplanar_sets(triangles: &[Triangle], selected: &[u32], max_offset: f64) -> Vec<FaceSet> {
    struct Building {
        seed_normal: DVec3,
        seed_offset: f64,
        triangles: Vec<u32>,
        normal_sum: DVec3,
        area: f64,
    }
    let cos_tol = COPLANAR_ANGLE_DEG.to_radians().cos();
    // A normal within the angle of a seed differs from it by less than `cell` per component,
    // so the seed lies in the same or an adjacent cell.
    let cell = 2.0 * (0.5 * COPLANAR_ANGLE_DEG.to_radians()).sin() * 1.001;
    let key = |n: DVec3| {
        let q = (n / cell).floor();
        (q.x as i64, q.y as i64, q.z as i64)
    };
    let mut order: Vec<(f64, u32)> = selected
        .iter()
        .map(|&t| (0.5 * triangles[t as usize].cross().as_dvec3().length(), t))
        .filter(|(a, _)| *a > 0.0 && a.is_finite())
        .collect();
    order.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut sets: Vec<Building> = Vec::new();
    let mut by_cell: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
    for (area, t) in order {
        let tri = &triangles[t as usize];
        let c = tri.cross().as_dvec3();
        let n = c / c.length();
        let (kx, ky, kz) = key(n);
        let mut found: Option<usize> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(ids) = by_cell.get(&(kx + dx, ky + dy, kz + dz)) else {
                        continue;
                    };
                    for &s in ids {
                        if found.is_some_and(|f| f <= s) {
                            continue;
                        }
                        let set = &sets[s];
                        let fits = set.seed_normal.dot(n) >= cos_tol
                            && tri.p.iter().all(|p| {
                                (set.seed_normal.dot(p.as_dvec3()) - set.seed_offset).abs()
                                    <= max_offset
                            });
                        if fits {
                            found = Some(s);
                        }
                    }
                }
            }
        }
        let s = found.unwrap_or_else(|| {
            let centroid = (tri.p[0] + tri.p[1] + tri.p[2]).as_dvec3() / 3.0;
            sets.push(Building {
                seed_normal: n,
                seed_offset: n.dot(centroid),
                triangles: Vec::new(),
                normal_sum: DVec3::ZERO,
                area: 0.0,
            });
            by_cell
                .entry((kx, ky, kz))
                .or_default()
                .push(sets.len() - 1);
            sets.len() - 1
        });
        let set = &mut sets[s];
        set.triangles.push(t);
        set.normal_sum += c;
        set.area += area;
    }
    let mut out: Vec<FaceSet> = sets
        .into_iter()
        .map(|mut s| {
            s.triangles.sort_unstable();
            FaceSet {
                triangles: s.triangles,
                normal: s.normal_sum.normalize().as_vec3(),
                area: s.area,
            }
        })
        .collect();
    // Stable: equal areas keep their seeds' order.
    out.sort_by(|a, b| b.area.total_cmp(&a.area));
    out
}

/// Rays [`free_distance`] casts.
pub const FREE_RAYS: u32 = 64;

/// How open the space in front of a face set is: the mean distance (capped at `cap`) that
/// [`FREE_RAYS`] cosine-distributed rays (a fixed 8 × 8 stratified pattern) travel from the
/// set's area-weighted centroid, lifted by `lift` along its normal, before they hit a triangle
/// of `bvh`. A mirror's back against a wall gets millimetres; its front, the room.
pub fn free_distance(
    set: &FaceSet,
    triangles: &[Triangle],
    bvh: &crate::geometry::Bvh,
    lift: f32,
    cap: f32,
) -> f32 {
    let (mut centroid, mut area) = (DVec3::ZERO, 0.0f64);
    for &t in &set.triangles {
        let t = &triangles[t as usize];
        let a = t.area() as f64;
        centroid += a * (t.p[0] + t.p[1] + t.p[2]).as_dvec3() / 3.0;
        area += a;
    }
    let n = set.normal;
    let origin = (centroid / area.max(1e-30)).as_vec3() + n * lift;
    let (t, b) = crate::sampling::basis(n);
    let side = (FREE_RAYS as f32).sqrt() as u32;
    let mut sum = 0.0f32;
    for i in 0..side {
        for j in 0..side {
            let u = glam::Vec2::new(
                (i as f32 + 0.5) / side as f32,
                (j as f32 + 0.5) / side as f32,
            );
            let d = crate::sampling::sample_cosine_hemisphere(u);
            let dir = (t * d.x + b * d.y + n * d.z).normalize();
            sum += bvh
                .closest_hit(origin, dir, cap)
                .map_or(cap, |h| h.t.min(cap));
        }
    }
    sum / (side * side) as f32
}

/// A short description of the largest face sets for messages: "0.700 m² facing (0.00, 0.00,
/// 1.00), 2 triangles; …".
pub fn describe(sets: &[FaceSet]) -> String {
    let mut s = sets
        .iter()
        .take(4)
        .map(|f| {
            format!(
                "{:.4} m² facing ({:.2}, {:.2}, {:.2}), {} triangle{}",
                f.area,
                f.normal.x,
                f.normal.y,
                f.normal.z,
                f.triangles.len(),
                if f.triangles.len() == 1 { "" } else { "s" }
            )
        })
        .collect::<Vec<_>>()
        .join("; ");
    if sets.len() > 4 {
        s += &format!("; and {} smaller", sets.len() - 4);
    }
    if s.is_empty() { "none".into() } else { s }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> Triangle {
        let p = [Vec3::from(a), Vec3::from(b), Vec3::from(c)];
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        Triangle {
            p,
            n: [n; 3],
            uv: [glam::Vec2::ZERO; 3],
            uv1: None,
            material: 0,
            object: 0,
        }
    }

    /// Two triangles of a w × h quad in the plane z = `z`, facing +z or −z.
    fn quad(w: f32, h: f32, z: f32, up: bool) -> [Triangle; 2] {
        let (a, b, c, d) = ([0.0, 0.0, z], [w, 0.0, z], [w, h, z], [0.0, h, z]);
        if up {
            [tri(a, b, c), tri(a, c, d)]
        } else {
            [tri(a, c, b), tri(a, d, c)]
        }
    }

    #[test]
    fn a_slab_splits_into_front_back_and_edges() {
        let mut t: Vec<Triangle> = Vec::new();
        t.extend(quad(1.0, 0.7, 0.01, true));
        t.extend(quad(1.0, 0.7, 0.0, false));
        // One edge strip (x = 1, facing +x).
        t.push(tri([1.0, 0.0, 0.0], [1.0, 0.7, 0.0], [1.0, 0.7, 0.01]));
        // A front triangle a little off the plane (within 1 mm) and tilted by 0.1°.
        t.push(tri(
            [0.2, 0.2, 0.0105],
            [0.4, 0.2, 0.0105],
            [0.3, 0.4, 0.0108],
        ));
        let all: Vec<u32> = (0..t.len() as u32).collect();
        let sets = coplanar_sets(&t, &all, 1e-3);
        assert_eq!(sets.len(), 3, "{}", describe(&sets));
        let front = sets.iter().find(|s| s.normal.z > 0.99).unwrap();
        assert_eq!(front.triangles, vec![0, 1, 5]);
        let back = sets.iter().find(|s| s.normal.z < -0.99).unwrap();
        assert_eq!(back.triangles, vec![2, 3]);
        assert!((back.area - 0.7).abs() < 1e-6);
        assert!(sets[0].area >= sets[1].area && sets[1].area >= sets[2].area);
        let edge = sets.iter().find(|s| s.normal.x > 0.99).unwrap();
        assert!((share_of_its_side(back, &sets) - 1.0).abs() < 1e-9);
        assert!(
            (share_of_its_side(edge, &sets) - 1.0).abs() < 1e-9,
            "alone on its side"
        );
        assert!(share_of_its_side(front, &sets) > MIN_FACE_SHARE);
        // The same triangle 2 mm off the plane is a set of its own.
        t[5] = tri([0.2, 0.2, 0.012], [0.4, 0.2, 0.012], [0.3, 0.4, 0.012]);
        assert_eq!(coplanar_sets(&t, &all, 1e-3).len(), 4);
    }

    #[test]
    fn a_bent_panel_has_no_dominant_face_set() {
        // Two halves of a 1 m square folded by 3° along y = 0.5.
        let rise = 0.5 * 3f32.to_radians().tan();
        let t = vec![
            tri([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.5, 0.0]),
            tri([0.0, 0.0, 0.0], [1.0, 0.5, 0.0], [0.0, 0.5, 0.0]),
            tri([0.0, 0.5, 0.0], [1.0, 0.5, 0.0], [1.0, 1.0, rise]),
            tri([0.0, 0.5, 0.0], [1.0, 1.0, rise], [0.0, 1.0, rise]),
        ];
        let sets = coplanar_sets(&t, &[0, 1, 2, 3], 1e-3);
        assert_eq!(sets.len(), 2, "{}", describe(&sets));
        assert_eq!(sets[0].triangles.len(), 2);
        assert!((share_of_its_side(&sets[0], &sets) - 0.5).abs() < 0.01);
    }

    #[test]
    fn a_sphere_has_no_large_face_set() {
        let mut t = Vec::new();
        let (rings, segs) = (12, 24);
        let p = |i: u32, j: u32| {
            let th = std::f32::consts::PI * i as f32 / rings as f32;
            let ph = std::f32::consts::TAU * j as f32 / segs as f32;
            [th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()]
        };
        for i in 0..rings {
            for j in 0..segs {
                t.push(tri(p(i, j), p(i + 1, j), p(i + 1, j + 1)));
                t.push(tri(p(i, j), p(i + 1, j + 1), p(i, j + 1)));
            }
        }
        let all: Vec<u32> = (0..t.len() as u32).collect();
        let sets = coplanar_sets(&t, &all, 1e-3 * 2.0);
        assert!(
            share_of_its_side(&sets[0], &sets) < 0.1 * MIN_FACE_SHARE,
            "{}",
            describe(&sets)
        );
    }
}
