//! Packets of eight rays traversing the tree together, for coherent rays (camera rays of
//! neighbouring pixels): a node's eight child boxes are tested once for the whole packet by
//! interval arithmetic on the rays' origins and inverse directions (Boulos, Wald et al. 2006,
//! "Geometric and Arithmetic Culling Methods for Entire Ray Packets"), and each ray is tested
//! exactly, as alone, only where a leaf's box and triangles are tested.
//!
//! The interval test is conservative for the rays' own computed slab distances, not only for
//! the real ones: each ray's distance is fl(fl(b − o)·(1/d)), and rounding to nearest is
//! monotonic, so the same operations on the interval's ends bound it. A ray therefore reaches
//! every leaf box it would reach alone (up to the order, which only its current nearest hit
//! prunes), and its leaf tests are the single-ray tests: same bits.
//!
//! The order does matter where a ray hits two triangles at the same distance: alone it keeps
//! the first it visits. A ray that meets another triangle within a small relative distance of
//! its nearest hit (boxes are entered that far beyond it, so rounding that puts a triangle's
//! hit just before its box's entry is covered) is traced again alone, so the hits are those of
//! single-ray traversal (how often: docs/tuning.md#packet-retrace).

use glam::Vec4;

use super::WideRay;
use super::node::{Node, ROBUST_FAR, WIDTH};

/// Rays per packet.
pub(crate) const PACKET: usize = 8;

/// A packet's rays as intervals, per axis.
pub(super) struct Frustum {
    /// The origin bound the near slab plane is measured from: the largest origin where the
    /// rays go +axis (near plane lo: lo − o is smallest), else the smallest.
    pub near_o: [f32; 3],
    /// And the far plane's: the smallest where the rays go +axis, else the largest.
    pub far_o: [f32; 3],
    /// The smallest and largest inverse direction.
    pub inv_lo: [f32; 3],
    pub inv_hi: [f32; 3],
    /// The node box rows entered first and left last (as [`WideRay`]'s, the same for every
    /// ray of the packet).
    pub near: [usize; 3],
    pub far: [usize; 3],
}

impl Frustum {
    /// The packet's intervals, or `None` where its rays do not all go the same way along
    /// every axis (or one is not finite): those are traced one at a time.
    pub fn new(rays: &[WideRay; PACKET]) -> Option<Frustum> {
        let first = &rays[0];
        let mut f = Frustum {
            near_o: [0.0; 3],
            far_o: [0.0; 3],
            inv_lo: [f32::INFINITY; 3],
            inv_hi: [f32::NEG_INFINITY; 3],
            near: first.near,
            far: first.far,
        };
        let mut o_lo = [f32::INFINITY; 3];
        let mut o_hi = [f32::NEG_INFINITY; 3];
        for r in rays {
            if r.near != first.near || !r.finite {
                return None;
            }
            for a in 0..3 {
                let (o, inv) = (r.o4[a].x, r.inv4[a].x);
                o_lo[a] = o_lo[a].min(o);
                o_hi[a] = o_hi[a].max(o);
                f.inv_lo[a] = f.inv_lo[a].min(inv);
                f.inv_hi[a] = f.inv_hi[a].max(inv);
            }
        }
        for a in 0..3 {
            // Rows 2a (lo) and 2a + 1 (hi); near is lo for rays going +a.
            let positive = f.near[a] == 2 * a;
            (f.near_o[a], f.far_o[a]) = if positive {
                (o_hi[a], o_lo[a])
            } else {
                (o_lo[a], o_hi[a])
            };
        }
        Some(f)
    }

    /// Which children some ray of the packet may enter before `t_max` (the packet's largest),
    /// and a lower bound of their entry distances; two 4-lane halves.
    #[inline(always)]
    pub fn enter(&self, node: &Node, t_max: f32) -> (u32, [f32; WIDTH]) {
        let half = |h: usize| {
            let row = |i: usize| Vec4::from_slice(&node.bounds[i][4 * h..4 * h + 4]);
            let near = |a: usize| {
                let x = row(self.near[a]) - Vec4::splat(self.near_o[a]);
                (x * Vec4::splat(self.inv_lo[a])).min(x * Vec4::splat(self.inv_hi[a]))
            };
            let far = |a: usize| {
                let x = row(self.far[a]) - Vec4::splat(self.far_o[a]);
                (x * Vec4::splat(self.inv_lo[a])).max(x * Vec4::splat(self.inv_hi[a]))
            };
            let t_in = near(0).max(near(1)).max(near(2)).max(Vec4::ZERO);
            let t_out = (far(0).min(far(1)).min(far(2)) * ROBUST_FAR).min(Vec4::splat(t_max));
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

/// A packet's origins and inverse directions by axis, a lane per ray.
pub(super) struct Rays {
    pub o: [[f32; PACKET]; 3],
    pub inv: [[f32; PACKET]; 3],
}

impl Rays {
    pub fn new(rays: &[WideRay; PACKET]) -> Rays {
        Rays {
            o: std::array::from_fn(|a| rays.each_ref().map(|r| r.o4[a].x)),
            inv: std::array::from_fn(|a| rays.each_ref().map(|r| r.inv4[a].x)),
        }
    }

    /// Which of the rays enter the child box in `lane` before their `t_max`: [`Node::enter`]
    /// for each ray (the same operations, so the same bits), the rays in lanes; two 4-lane
    /// halves.
    #[inline(always)]
    pub fn enter(&self, f: &Frustum, node: &Node, lane: usize, t_max: &[f32; PACKET]) -> u32 {
        let half = |h: usize| {
            let o = |a: usize| Vec4::from_slice(&self.o[a][4 * h..4 * h + 4]);
            let inv = |a: usize| Vec4::from_slice(&self.inv[a][4 * h..4 * h + 4]);
            let t = |row: usize, a: usize| (Vec4::splat(node.bounds[row][lane]) - o(a)) * inv(a);
            let tx0 = t(f.near[0], 0);
            let ty0 = t(f.near[1], 1);
            let tz0 = t(f.near[2], 2);
            let tx1 = t(f.far[0], 0);
            let ty1 = t(f.far[1], 1);
            let tz1 = t(f.far[2], 2);
            let t_in = tx0.max(ty0).max(tz0).max(Vec4::ZERO);
            let t_lim = Vec4::from_slice(&t_max[4 * h..4 * h + 4]);
            let t_out = (tx1.min(ty1).min(tz1) * ROBUST_FAR).min(t_lim);
            t_in.cmple(t_out).bitmask()
        };
        half(0) | half(1) << 4
    }
}
