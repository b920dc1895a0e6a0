//! A curved reflector's own triangles, for self-reflection: a two-wide BVH (obvhs' BVH2)
//! flattened into the records `shaders/curved.wgsl` traverses (`own_closest`), and
//! [`OwnMesh::closest_hit`], the same traversal on the CPU that the shader is tested against.
//!
//! A reflector's cube map is taken without it, so a ray a concave reflector sends back into
//! itself (a teapot's body towards its spout, handle, lid or knob) would show the room. Each
//! reflected ray is therefore cast against the reflector's own triangles first; where it meets
//! one, the pixel shows that point's kd·D and mirror term instead (`own_radiance`). A
//! departure from Nielsen & Christensen 2002, whose reflectors are convex. The records carry
//! what D needs at the hit (lightmap coordinates and page, UVs, material) and the vertex
//! normals, so the hit is shaded as the scene pass would draw it.

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};
use obvhs::{
    BvhBuildParams, bvh2::builder::build_bvh2_from_tris, triangle::Triangle as BvhTriangle,
};

use crate::radiosity::atlas::Atlas;
use crate::scene::Scene;

/// Entries of the shader's traversal stack (`OWN_STACK` in `shaders/curved.wgsl`): a mesh
/// whose tree is deeper is not tested ([`OwnMesh::build`] says so). Each level pushes at most
/// one node, so the depth bounds the stack.
pub const OWN_STACK: usize = 48;

/// Triangles per leaf at most.
const LEAF_SIZE: u32 = 4;

/// A BVH node as the shader reads it (32 bytes, `OwnNode` in `shaders/curved.wgsl`): an inner
/// node (`count` 0) has its children at `first` and `first + 1`; a leaf holds triangles
/// `first .. first + count`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct OwnNode {
    pub min: [f32; 3],
    pub count: u32,
    pub max: [f32; 3],
    pub first: u32,
}

/// A triangle as the shader reads it (208 bytes, `OwnTri`): first vertex and edges for the
/// intersection (Möller & Trumbore 1997), vertex normals, and per vertex what D needs.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct OwnTri {
    /// p0 (w unused).
    pub v0: [f32; 4],
    /// p1 − p0.
    pub e1: [f32; 4],
    /// p2 − p0.
    pub e2: [f32; 4],
    /// Unit vertex normals (w unused).
    pub n: [[f32; 4]; 3],
    /// Atlas page, material, its scene triangle, unused.
    pub ids: [u32; 4],
    /// Lightmap coordinates (texels of the page) per vertex, then one unused.
    pub lightmap: [[f32; 2]; 4],
    /// UV set 0 per vertex, then one unused.
    pub uv0: [[f32; 2]; 4],
    /// UV set 1 per vertex (zero without one), then one unused.
    pub uv1: [[f32; 2]; 4],
}

/// Where a ray meets the mesh: distance, the hit record's index in [`OwnMesh::tris`] and
/// barycentrics (u, v): p = (1 − u − v)·p0 + u·p1 + v·p2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OwnHit {
    pub t: f32,
    pub tri: u32,
    pub bary: Vec2,
}

/// A reflector's own triangles with their BVH, ready to upload.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OwnMesh {
    /// Node 0 is the root.
    pub nodes: Vec<OwnNode>,
    /// In leaf order.
    pub tris: Vec<OwnTri>,
    /// Levels below the root of the deepest leaf.
    pub depth: usize,
}

impl OwnMesh {
    /// The mesh of `triangles` (scene triangle numbers) with `atlas`'s lightmap coordinates.
    /// Deterministic: obvhs' build does not depend on the thread count.
    pub fn build(scene: &Scene, atlas: &Atlas, triangles: &[u32]) -> OwnMesh {
        let records: Vec<OwnTri> = triangles
            .iter()
            .map(|&t| {
                let tri = &scene.triangles[t as usize];
                let coords = atlas.tri_coords[t as usize];
                let uv1 = tri.uv1.unwrap_or([Vec2::ZERO; 3]);
                let pad2 = |a: [Vec2; 3]| [a[0].into(), a[1].into(), a[2].into(), [0.0; 2]];
                OwnTri {
                    v0: tri.p[0].extend(0.0).into(),
                    e1: (tri.p[1] - tri.p[0]).extend(0.0).into(),
                    e2: (tri.p[2] - tri.p[0]).extend(0.0).into(),
                    n: tri.n.map(|n| n.extend(0.0).into()),
                    ids: [atlas.tri_page[t as usize], tri.material, t, 0],
                    lightmap: pad2(coords),
                    uv0: pad2(tri.uv),
                    uv1: pad2(uv1),
                }
            })
            .collect();
        Self::from_records(records)
    }

    /// The BVH over `records` (reordered into leaf order).
    pub fn from_records(records: Vec<OwnTri>) -> OwnMesh {
        if records.is_empty() {
            return OwnMesh::default();
        }
        let tris: Vec<BvhTriangle> = records
            .iter()
            .map(|r| {
                let (v0, e1, e2) = (v3(r.v0), v3(r.e1), v3(r.e2));
                BvhTriangle {
                    v0: v0.into(),
                    v1: (v0 + e1).into(),
                    v2: (v0 + e2).into(),
                }
            })
            .collect();
        let params = BvhBuildParams {
            max_prims_per_leaf: LEAF_SIZE,
            ..BvhBuildParams::slow_build()
        };
        let bvh = build_bvh2_from_tris(&tris, params, &mut std::time::Duration::default());
        let nodes: Vec<OwnNode> = bvh
            .nodes
            .iter()
            .map(|n| OwnNode {
                min: n.aabb.min.to_array(),
                count: n.prim_count,
                max: n.aabb.max.to_array(),
                first: n.first_index,
            })
            .collect();
        let tris = bvh
            .primitive_indices
            .iter()
            .map(|&i| records[i as usize])
            .collect();
        let depth = depth_of(&nodes, 0);
        OwnMesh { nodes, tris, depth }
    }

    /// Whether the shader can traverse it: not empty, and no deeper than its stack.
    pub fn traversable(&self) -> bool {
        !self.nodes.is_empty() && self.depth < OWN_STACK
    }

    /// The nearest hit along unit `dir` from `origin` with t in (`t_min`, ∞), either face:
    /// `own_closest` in `shaders/curved.wgsl` is the GPU form (the same traversal: nearer
    /// child first, the other pushed).
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, t_min: f32) -> Option<OwnHit> {
        if !self.traversable() {
            return None;
        }
        let inv = safe_inverse(dir);
        let mut best: Option<OwnHit> = None;
        let mut t_max = f32::INFINITY;
        let mut stack = [0u32; OWN_STACK];
        let mut sp = 0;
        let root = &self.nodes[0];
        let mut node = if box_entry(root, origin, inv, t_min, t_max).is_some() {
            Some(0u32)
        } else {
            None
        };
        while let Some(i) = node.take() {
            let n = &self.nodes[i as usize];
            if n.count > 0 {
                for k in n.first..n.first + n.count {
                    if let Some((t, bary)) =
                        intersect(&self.tris[k as usize], origin, dir, t_min, t_max)
                    {
                        t_max = t;
                        best = Some(OwnHit { t, tri: k, bary });
                    }
                }
            } else {
                let (a, b) = (n.first, n.first + 1);
                let ta = box_entry(&self.nodes[a as usize], origin, inv, t_min, t_max);
                let tb = box_entry(&self.nodes[b as usize], origin, inv, t_min, t_max);
                match (ta, tb) {
                    (Some(x), Some(y)) => {
                        let (near, far) = if x <= y { (a, b) } else { (b, a) };
                        stack[sp] = far;
                        sp += 1;
                        node = Some(near);
                    }
                    (Some(_), None) => node = Some(a),
                    (None, Some(_)) => node = Some(b),
                    (None, None) => {}
                }
            }
            // Pop until a node still in reach (a hit may have shortened the ray).
            while node.is_none() && sp > 0 {
                sp -= 1;
                let c = stack[sp];
                if box_entry(&self.nodes[c as usize], origin, inv, t_min, t_max).is_some() {
                    node = Some(c);
                }
            }
        }
        best
    }
}

fn v3(a: [f32; 4]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

/// Levels below `i` of its deepest leaf.
fn depth_of(nodes: &[OwnNode], i: u32) -> usize {
    // Iterative: a degenerate tree may be as deep as it has nodes.
    let mut deepest = 0;
    let mut todo = vec![(i, 0usize)];
    while let Some((i, d)) = todo.pop() {
        let n = &nodes[i as usize];
        if n.count > 0 {
            deepest = deepest.max(d);
        } else {
            todo.push((n.first, d + 1));
            todo.push((n.first + 1, d + 1));
        }
    }
    deepest
}

/// 1/d per axis, with ±1e30 for a zero component (so 0 · ∞ never makes a NaN).
fn safe_inverse(d: Vec3) -> Vec3 {
    let f = |x: f32| {
        if x.abs() < 1e-30 {
            if x.is_sign_negative() { -1e30 } else { 1e30 }
        } else {
            1.0 / x
        }
    };
    Vec3::new(f(d.x), f(d.y), f(d.z))
}

/// Where the ray enters the node's box within (t_min, t_max), or `None` (slab test).
fn box_entry(n: &OwnNode, origin: Vec3, inv: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
    let a = (Vec3::from(n.min) - origin) * inv;
    let b = (Vec3::from(n.max) - origin) * inv;
    let near = a.min(b).max_element().max(t_min);
    // Widened a little, so a box grazed in rounding is still entered.
    let far = a.max(b).min_element().min(t_max) * (1.0 + 4.0 * f32::EPSILON);
    (near <= far).then_some(near)
}

/// Möller–Trumbore (1997), either face: t in (t_min, t_max) and the barycentrics.
fn intersect(r: &OwnTri, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Option<(f32, Vec2)> {
    let (e1, e2) = (v3(r.e1), v3(r.e2));
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-20 {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - v3(r.v0);
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > t_min && t < t_max).then_some((t, Vec2::new(u, v)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Bvh, Triangle};

    /// A torus about +Y (radii 1 and 0.35), `n` × `n` quads: a concave surface whose
    /// reflected rays often meet it again.
    fn torus(n: usize) -> Vec<[Vec3; 3]> {
        let at = |i: usize, j: usize| {
            let a = std::f32::consts::TAU * (i % n) as f32 / n as f32;
            let b = std::f32::consts::TAU * (j % n) as f32 / n as f32;
            let r = 1.0 + 0.35 * b.cos();
            Vec3::new(r * a.cos(), 0.35 * b.sin(), r * a.sin())
        };
        let mut tris = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let (p00, p10, p01, p11) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
                tris.push([p00, p10, p11]);
                tris.push([p00, p11, p01]);
            }
        }
        tris
    }

    fn mesh_of(tris: &[[Vec3; 3]]) -> OwnMesh {
        OwnMesh::from_records(
            tris.iter()
                .enumerate()
                .map(|(k, p)| OwnTri {
                    v0: p[0].extend(0.0).into(),
                    e1: (p[1] - p[0]).extend(0.0).into(),
                    e2: (p[2] - p[0]).extend(0.0).into(),
                    ids: [0, 0, k as u32, 0],
                    ..Default::default()
                })
                .collect(),
        )
    }

    /// Deterministic points and directions (a Weyl sequence).
    fn rays(count: usize) -> Vec<(Vec3, Vec3)> {
        let g = [
            0.754_877_7f32,
            0.569_840_3,
            0.438_108_2,
            0.347_296_4,
            0.2871,
            0.6180,
        ];
        (0..count)
            .map(|i| {
                let x = |k: usize| (0.5 + g[k] * i as f32).fract();
                let o = Vec3::new(x(0) * 3.0 - 1.5, x(1) * 0.9 - 0.45, x(2) * 3.0 - 1.5);
                let z = 2.0 * x(3) - 1.0;
                let phi = std::f32::consts::TAU * x(4);
                let s = (1.0 - z * z).sqrt();
                (o, Vec3::new(s * phi.cos(), z, s * phi.sin()))
            })
            .collect()
    }

    #[test]
    fn closest_hit_agrees_with_the_scene_bvh() {
        let tris = torus(24);
        let mesh = mesh_of(&tris);
        assert_eq!(mesh.tris.len(), tris.len());
        assert!(mesh.traversable(), "depth {}", mesh.depth);
        let scene_tris: Vec<Triangle> = tris
            .iter()
            .map(|p| Triangle {
                p: *p,
                n: [Vec3::Y; 3],
                uv: [Vec2::ZERO; 3],
                uv1: None,
                material: 0,
                object: 0,
            })
            .collect();
        let truth = Bvh::build(&scene_tris);
        let (mut hits, mut misses) = (0, 0);
        for (o, d) in rays(4000) {
            let want = truth.closest_hit(o, d, f32::INFINITY);
            let got = mesh.closest_hit(o, d, 0.0);
            match (want, got) {
                (Some(w), Some(g)) => {
                    hits += 1;
                    assert!(
                        (w.t - g.t).abs() <= 1e-4 * w.t.max(1.0),
                        "{o} {d}: {} vs {}",
                        w.t,
                        g.t
                    );
                    let p = o + d * g.t;
                    let k = mesh.tris[g.tri as usize].ids[2] as usize;
                    let on = scene_tris[k].point(g.bary);
                    assert!(p.distance(on) < 1e-4, "{p} vs {on}");
                }
                (None, None) => misses += 1,
                (w, g) => {
                    // Only a ray grazing an edge may be found by one and not the other.
                    let t = w.map(|h| h.t).or(g.map(|h| h.t)).unwrap();
                    let near_edge = tris.iter().any(|p| {
                        let q = o + d * t;
                        (0..3).any(|e| segment_distance(q, p[e], p[(e + 1) % 3]) < 1e-4)
                    });
                    assert!(near_edge, "{o} {d}: {w:?} vs {g:?}");
                }
            }
        }
        assert!(hits > 1000 && misses > 500, "{hits} hits, {misses} misses");
    }

    fn segment_distance(q: Vec3, a: Vec3, b: Vec3) -> f32 {
        let ab = b - a;
        let s = ((q - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
        q.distance(a + ab * s)
    }

    #[test]
    fn hits_nearer_than_t_min_are_skipped() {
        let mesh = mesh_of(&[[Vec3::ZERO, Vec3::X, Vec3::Y]]);
        let o = Vec3::new(0.25, 0.25, -1.0);
        let hit = mesh.closest_hit(o, Vec3::Z, 0.0).expect("straight through");
        assert!((hit.t - 1.0).abs() < 1e-6);
        assert!((hit.bary - Vec2::splat(0.25)).length() < 1e-6);
        assert_eq!(mesh.closest_hit(o, Vec3::Z, 1.0), None);
        assert_eq!(mesh.closest_hit(o, -Vec3::Z, 0.0), None);
        // From the surface itself (a reflected ray's origin): nothing at t ≈ 0.
        assert_eq!(
            mesh.closest_hit(Vec3::new(0.25, 0.25, 0.0), Vec3::Z, 1e-5),
            None
        );
        // Empty: nothing, and not traversable.
        assert!(!OwnMesh::default().traversable());
        assert_eq!(OwnMesh::default().closest_hit(o, Vec3::Z, 0.0), None);
    }

    #[test]
    fn the_build_is_deterministic_and_shallow() {
        let tris = torus(48);
        let a = mesh_of(&tris);
        let b = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| mesh_of(&tris));
        assert_eq!(a, b);
        assert!(a.depth < OWN_STACK, "depth {}", a.depth);
        // Every triangle lies in exactly one leaf.
        let leaf_sum: u32 = a.nodes.iter().map(|n| n.count).sum();
        assert_eq!(leaf_sum as usize, tris.len());
    }

    #[test]
    fn the_shader_declares_the_same_stack() {
        let want = format!("const OWN_STACK: u32 = {OWN_STACK}u;");
        assert!(super::super::shader_source().contains(&want), "{want}");
    }

    #[test]
    fn records_match_the_wgsl_structs() {
        let src = super::super::shader_source();
        crate::assert_wgsl_layout!(
            src,
            "OwnNode",
            OwnNode {
                min,
                count,
                max,
                first
            }
        );
        crate::assert_wgsl_layout!(
            src,
            "OwnTri",
            OwnTri {
                v0,
                e1,
                e2,
                n,
                ids,
                lightmap,
                uv0,
                uv1
            }
        );
    }
}
