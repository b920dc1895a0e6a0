//! An eight-wide node with plain float child boxes (Embree's BVH8 layout: Wald et al. 2014,
//! "Embree: A Kernel Framework for Efficient CPU Ray Tracing", §4): its eight boxes are tested
//! in one 8-lane slab test with AVX ([`super::avx`]) or, portably, as two 4-lane halves with
//! glam's `Vec4`. Both give the same bits: the same operations in the same order, lane by
//! lane.
//!
//! Against four-wide nodes, eight cut the tree's depth by about a third, and with it the
//! dependent node loads a ray waits for on its way to a leaf.

use glam::Vec4;

use super::WideRay;

/// Children per node.
pub(super) const WIDTH: usize = 8;

/// A lane with no child.
const EMPTY: u32 = u32::MAX;

/// 1 + 2γ(3) with γ(n) = nε / (1 − nε), ε = 2⁻²⁴ (Ize 2013, "Robust BVH Ray Traversal", §3).
pub(super) const ROBUST_FAR: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub(super) struct Node {
    /// Child boxes by lane: lo x, hi x, lo y, hi y, lo z, hi z. An empty lane holds the
    /// inverted box (lo +∞, hi −∞), which no ray enters.
    pub bounds: [[f32; WIDTH]; 6],
    /// Per lane: an inner child's node index, or a leaf's first pack, or `EMPTY`.
    pub child: [u32; WIDTH],
    /// Per lane: a leaf's pack count; 0 for inner children and empty lanes.
    pub count: [u32; WIDTH],
}

impl Node {
    /// A node with every lane empty.
    pub fn empty() -> Node {
        let (lo, hi) = ([f32::INFINITY; WIDTH], [f32::NEG_INFINITY; WIDTH]);
        Node {
            bounds: [lo, hi, lo, hi, lo, hi],
            child: [EMPTY; WIDTH],
            count: [0; WIDTH],
        }
    }

    /// Sets `lane` to a child with box (min, max).
    pub fn set(&mut self, lane: usize, min: [f32; 3], max: [f32; 3], child: u32, count: u32) {
        for axis in 0..3 {
            self.bounds[2 * axis][lane] = min[axis];
            self.bounds[2 * axis + 1][lane] = max[axis];
        }
        self.child[lane] = child;
        self.count[lane] = count;
    }

    /// Which children the node's boxes let the ray into before `t_max` (bit per lane), and
    /// their entry distances; two 4-lane halves.
    #[inline(always)]
    pub fn enter(&self, r: &WideRay, t_max: f32) -> (u32, [f32; WIDTH]) {
        let half = |h: usize| {
            let row = |i: usize| Vec4::from_slice(&self.bounds[i][4 * h..4 * h + 4]);
            let tx0 = (row(r.near[0]) - r.o4[0]) * r.inv4[0];
            let ty0 = (row(r.near[1]) - r.o4[1]) * r.inv4[1];
            let tz0 = (row(r.near[2]) - r.o4[2]) * r.inv4[2];
            let tx1 = (row(r.far[0]) - r.o4[0]) * r.inv4[0];
            let ty1 = (row(r.far[1]) - r.o4[1]) * r.inv4[1];
            let tz1 = (row(r.far[2]) - r.o4[2]) * r.inv4[2];
            let t_in = tx0.max(ty0).max(tz0).max(Vec4::ZERO);
            let t_out = (tx1.min(ty1).min(tz1) * ROBUST_FAR).min(Vec4::splat(t_max));
            (t_in.cmple(t_out).bitmask(), t_in)
        };
        let (m0, t0) = half(0);
        let (m1, t1) = half(1);
        let mut t = [0.0; WIDTH];
        t0.write_to_slice(&mut t[..4]);
        t1.write_to_slice(&mut t[4..]);
        (m0 | m1 << 4, t)
    }
}
