//! An eight-wide BVH with plain float child boxes ([`node`]) and triangles stored as
//! (v0, e1, e2) in packs of four, traversed one ray at a time: a node's eight child boxes are
//! tested together in one SIMD slab test (AVX where the CPU has it, else two 4-lane halves
//! with glam's `Vec4`: SSE2 on x86-64, NEON on aarch64). Closest-hit queries visit the nearest
//! hit child first; occlusion queries take them in lane order, unsorted (any hit will do, as
//! in Embree's any-hit traversal; docs/tuning.md#occlusion-order). A leaf's triangles are
//! tested together ([`pack`]): four with `Vec4`, five to eight in one AVX test. Coherent rays
//! can also be traced eight at a time ([`packet`]), with the same hits.
//!
//! Built by collapsing obvhs' BVH2 (PLOC build with reinsertion, leaves collapsed by SAH):
//! each node takes up to eight descendants, opening the inner child of largest surface area
//! first (Wald, Benthin, Boulos 2008, "Getting Rid of Packets", §3.1; Dammertz et al. 2008,
//! "Shallow Bounding Volume Hierarchies", §2).
//!
//! Box tests are conservative in floating point: each far distance is widened by 2γ(3)
//! (Ize 2013, "Robust BVH Ray Traversal", §3), so a triangle is never skipped because its
//! box was grazed.
//!
//! Kept in one file: the build and the single-ray traversals share the node layout and the
//! traversal stack; the SIMD parts are apart already (`avx`, `node`, `pack`, `packet`).

#[cfg(target_arch = "x86_64")]
mod avx;
mod node;
mod pack;
mod packet;

use glam::{Vec3A, Vec4};
use node::{Node, WIDTH};
use obvhs::{
    BvhBuildParams, bvh2::Bvh2, bvh2::builder::build_bvh2_from_tris,
    triangle::Triangle as BvhTriangle,
};
use pack::{DEGENERATE, Hits, Pack};
pub(super) use packet::PACKET;
use packet::{Frustum, Rays};
use smallvec::SmallVec;
use std::time::Duration;

/// Cache lines prefetched per child: a node's four (256 bytes), a leaf's first 256 bytes (a
/// pack is 144, a pair 288); docs/tuning.md#prefetch-lines.
const PREFETCH_LINES: usize = 4;

/// Directions below this magnitude per axis count as this (keeps 1/d finite: no NaN from
/// 0 · ∞ when an axis-parallel ray starts on a box plane).
const MIN_DIR: f32 = 1e-30;

/// Relative distance within which two triangles' hits count as a near tie in packet traversal
/// (their order decides which one a ray keeps, see [`WideBvh::traverse_packet`]): far wider
/// than the rounding of a box's entry distance or of a hit's.
const NEAR_TIE: f32 = 1.0 / 4096.0;
const NEAR_TIE_UP: f32 = 1.0 + NEAR_TIE;
const NEAR_TIE_DOWN: f32 = 1.0 - NEAR_TIE;

/// A triangle as its first vertex and two edges (the part of Möller–Trumbore 1997 that
/// does not depend on the ray).
#[derive(Clone, Copy, Debug)]
pub(super) struct Tri {
    pub v0: Vec3A,
    pub e1: Vec3A,
    pub e2: Vec3A,
}

impl Tri {
    fn new(t: &BvhTriangle) -> Tri {
        Tri {
            v0: t.v0,
            e1: t.v1 - t.v0,
            e2: t.v2 - t.v0,
        }
    }
}

/// A ray prepared for the slab tests.
pub(super) struct WideRay {
    o4: [Vec4; 3],
    d4: [Vec4; 3],
    inv4: [Vec4; 3],
    /// Per axis, the node box row entered first (lo for d ≥ 0) and left last.
    near: [usize; 3],
    far: [usize; 3],
    /// Origin and direction are finite. A NaN or infinite component would turn the slab
    /// tests' distances into NaN, which lets the ray into empty lanes: such a ray hits nothing.
    finite: bool,
}

impl WideRay {
    pub fn new(o: Vec3A, d: Vec3A) -> WideRay {
        let inv = |c: f32| {
            if c.abs() < MIN_DIR {
                1.0 / MIN_DIR
            } else {
                1.0 / c
            }
        };
        let inv = [inv(d.x), inv(d.y), inv(d.z)];
        // Axis a's rows are lo 2a and hi 2a + 1; a ray going −a enters through hi.
        let neg = inv.map(|i| (i < 0.0) as usize);
        WideRay {
            o4: [Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z)],
            d4: [Vec4::splat(d.x), Vec4::splat(d.y), Vec4::splat(d.z)],
            inv4: inv.map(Vec4::splat),
            near: [neg[0], 2 + neg[1], 4 + neg[2]],
            far: [1 - neg[0], 3 - neg[1], 5 - neg[2]],
            finite: o.is_finite() && d.is_finite(),
        }
    }
}

/// A hit found in a leaf.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct LeafHit {
    /// The leaf slot (pack · 4 + lane), and the triangle's index in the caller's list.
    pub slot: usize,
    pub original: u32,
    /// Distance and barycentrics (u, v), as Möller–Trumbore computes them (unclamped).
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

/// Whether this CPU has AVX.
pub(super) fn avx_detected() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx");
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// The wide BVH; triangles in leaf order, four slots per leaf pack.
pub(super) struct WideBvh {
    nodes: Vec<Node>,
    packs: Vec<Pack>,
    /// The root: node 0 (count 0), or a single leaf (first pack, pack count).
    root: (u32, u32),
    /// Per slot (pack · 4 + lane), the index of the triangle in the caller's list (`u32::MAX` in padding).
    pub original: Vec<u32>,
    /// Whether node boxes are tested with AVX (detected at build).
    avx: bool,
}

/// The BVH2 build: obvhs' slow build (PLOC with a wide search, reinsertion, large triangles
/// pre-split into several boxes; leaves collapsed by SAH with at most eight triangles each: two
/// packs): faster rays for a longer build, docs/tuning.md#bvh-build.
pub(super) const BUILD: BvhBuildParams = BvhBuildParams {
    max_prims_per_leaf: 8,
    ..BvhBuildParams::slow_build()
};

impl WideBvh {
    /// Builds over `tris` (in parallel with rayon; the result does not depend on the thread
    /// count). `tris` must not be empty.
    pub fn build(tris: &[BvhTriangle], params: BvhBuildParams) -> WideBvh {
        let bvh2 = build_bvh2_from_tris(tris, params, &mut Duration::default());
        let mut out = WideBvh {
            nodes: Vec::new(),
            packs: Vec::new(),
            root: (0, 0),
            original: Vec::with_capacity(tris.len()),
            avx: avx_detected(),
        };
        out.root = out.emit(&bvh2, tris, 0);
        out
    }

    /// Switches the AVX tests off (or on, where the CPU has AVX), to test both.
    #[cfg(test)]
    pub fn set_avx(&mut self, on: bool) {
        self.avx = on && avx_detected();
    }

    /// Appends BVH2 node `index` (a leaf's packs, or a wide node and its subtree) and returns
    /// its (child, count) entry.
    fn emit(&mut self, bvh2: &Bvh2, tris: &[BvhTriangle], index: usize) -> (u32, u32) {
        let n = &bvh2.nodes[index];
        if n.is_leaf() {
            let first = self.packs.len() as u32;
            let slots = &bvh2.primitive_indices
                [n.first_index as usize..(n.first_index + n.prim_count) as usize];
            // Eight triangles to a pair of packs; a remainder of four or fewer to one pack.
            for chunk in slots.chunks(8) {
                let lanes = if chunk.len() > 4 { 8 } else { 4 };
                let mut packs = [Pack::empty(); 2];
                for lane in 0..lanes {
                    let (tri, original) = match chunk.get(lane) {
                        Some(&i) => (Tri::new(&tris[i as usize]), i),
                        None => (DEGENERATE, u32::MAX),
                    };
                    if lanes == 8 {
                        pack::set_pair(&mut packs, lane, &tri);
                    } else {
                        pack::set(&mut packs[0], lane, &tri);
                    }
                    self.original.push(original);
                }
                self.packs.extend_from_slice(&packs[..lanes / 4]);
            }
            return (first, self.packs.len() as u32 - first);
        }
        // Open the largest inner child until there are eight.
        let mut kids: SmallVec<[usize; WIDTH]> =
            SmallVec::from_slice(&[n.first_index as usize, n.first_index as usize + 1]);
        while kids.len() < WIDTH {
            let open = kids
                .iter()
                .enumerate()
                .filter(|&(_, &k)| !bvh2.nodes[k].is_leaf())
                .max_by(|a, b| {
                    let area = |k: usize| bvh2.nodes[k].aabb().half_area();
                    area(*a.1).total_cmp(&area(*b.1))
                })
                .map(|(i, _)| i);
            let Some(i) = open else { break };
            let k = kids[i];
            let left = bvh2.nodes[k].first_index as usize;
            kids[i] = left;
            kids.insert(i + 1, left + 1);
        }
        let at = self.nodes.len();
        self.nodes.push(Node::empty());
        for (lane, &k) in kids.iter().enumerate() {
            let (child, count) = self.emit(bvh2, tris, k);
            let bb = bvh2.nodes[k].aabb();
            self.nodes[at].set(lane, bb.min.to_array(), bb.max.to_array(), child, count);
        }
        (at as u32, 0)
    }

    /// The nearest slot the ray hits in (0, t_max) that `keep(slot, u, v)` accepts (u, v: the
    /// leaf test's barycentrics, unclamped), and its distance.
    #[inline(always)]
    pub fn closest(
        &self,
        r: &WideRay,
        t_max: f32,
        keep: impl Fn(usize, f32, f32) -> bool,
    ) -> Option<LeafHit> {
        if !r.finite {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        if self.avx {
            // SAFETY: `avx` is set only where the CPU has AVX.
            return unsafe { self.traverse_avx::<false>(r, t_max, keep) };
        }
        self.traverse::<false>(
            r,
            t_max,
            keep,
            |n, t| n.enter(r, t),
            |p, t| pack::intersect_pair(p, r, t),
        )
    }

    /// Whether the ray hits a slot in (0, t_max) that `keep(slot, u, v)` accepts.
    #[inline(always)]
    pub fn any(&self, r: &WideRay, t_max: f32, keep: impl Fn(usize, f32, f32) -> bool) -> bool {
        if !r.finite {
            return false;
        }
        #[cfg(target_arch = "x86_64")]
        if self.avx {
            // SAFETY: as in `closest`.
            return unsafe { self.traverse_avx::<true>(r, t_max, keep) }.is_some();
        }
        self.traverse::<true>(
            r,
            t_max,
            keep,
            |n, t| n.enter(r, t),
            |p, t| pack::intersect_pair(p, r, t),
        )
        .is_some()
    }

    /// [`WideBvh::traverse`] compiled for AVX, with AVX node tests.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn traverse_avx<const ANY: bool>(
        &self,
        r: &WideRay,
        t_max: f32,
        keep: impl Fn(usize, f32, f32) -> bool,
    ) -> Option<LeafHit> {
        let r8 = avx::Ray8::new(r);
        // SAFETY (both): this function runs only on CPUs with AVX.
        self.traverse::<ANY>(
            r,
            t_max,
            keep,
            |n, t| unsafe { avx::enter(n, r, &r8, t) },
            |p, t| unsafe { avx::intersect_pair(p, &r8, t) },
        )
    }

    /// Nearest-child-first traversal; with `ANY`, stops at the first accepted hit.
    #[inline(always)]
    fn traverse<const ANY: bool>(
        &self,
        r: &WideRay,
        mut t_max: f32,
        keep: impl Fn(usize, f32, f32) -> bool,
        enter: impl Fn(&Node, f32) -> (u32, [f32; WIDTH]),
        pair: impl Fn(&[Pack; 2], f32) -> Hits,
    ) -> Option<LeafHit> {
        let mut best = None;
        let mut stack: SmallVec<[(u32, u32, f32); 64]> = SmallVec::new();
        let (mut child, mut count) = self.root;
        loop {
            if count > 0 {
                if let Some(hit) = self.leaf_hit::<ANY>(child, count, r, &mut t_max, &keep, &pair) {
                    best = Some(hit);
                    if ANY {
                        return best;
                    }
                }
            } else {
                let node = &self.nodes[child as usize];
                let (mut mask, t_in) = enter(node, t_max);
                if !ANY {
                    // An occlusion query often stops early; prefetching for it measured slower.
                    self.prefetch(node, mask);
                }
                if ANY {
                    // Any hit will do: test the leaves here first, before descending (large
                    // triangles such as walls sit in leaves near the root).
                    let mut leaves = mask;
                    while leaves != 0 {
                        let lane = leaves.trailing_zeros() as usize;
                        leaves &= leaves - 1;
                        if node.count[lane] > 0 {
                            mask &= !(1 << lane);
                            let (first, count) = (node.child[lane], node.count[lane]);
                            let hit =
                                self.leaf_hit::<ANY>(first, count, r, &mut t_max, &keep, &pair);
                            if hit.is_some() {
                                return hit;
                            }
                        }
                    }
                }
                if mask != 0 {
                    if mask & (mask - 1) == 0 {
                        let lane = mask.trailing_zeros() as usize;
                        (child, count) = (node.child[lane], node.count[lane]);
                        continue;
                    }
                    let first = mask.trailing_zeros() as usize;
                    if ANY {
                        // Any hit will do: in lane order, unsorted.
                        let mut m = mask & (mask - 1);
                        while m != 0 {
                            let lane = 31 - m.leading_zeros() as usize;
                            m &= !(1 << lane);
                            stack.push((node.child[lane], node.count[lane], t_in[lane]));
                        }
                        (child, count) = (node.child[first], node.count[first]);
                        continue;
                    }
                    let rest = mask & (mask - 1);
                    if rest & (rest - 1) == 0 {
                        // Two: the nearer (the first lane on a tie), the other pushed.
                        let second = rest.trailing_zeros() as usize;
                        let (near, far) = if t_in[second] < t_in[first] {
                            (second, first)
                        } else {
                            (first, second)
                        };
                        stack.push((node.child[far], node.count[far], t_in[far]));
                        (child, count) = (node.child[near], node.count[near]);
                        continue;
                    }
                    // Nearest first: push the others far to near.
                    let mut lanes = [(0.0f32, 0usize); WIDTH];
                    let mut n = 0;
                    let mut m = mask;
                    while m != 0 {
                        let lane = m.trailing_zeros() as usize;
                        m &= m - 1;
                        let t = t_in[lane];
                        let mut i = n;
                        while i > 0 && lanes[i - 1].0 > t {
                            lanes[i] = lanes[i - 1];
                            i -= 1;
                        }
                        lanes[i] = (t, lane);
                        n += 1;
                    }
                    for &(t, lane) in lanes[1..n].iter().rev() {
                        stack.push((node.child[lane], node.count[lane], t));
                    }
                    let lane = lanes[0].1;
                    (child, count) = (node.child[lane], node.count[lane]);
                    continue;
                }
            }
            loop {
                let Some((c, k, t)) = stack.pop() else {
                    return best;
                };
                if t <= t_max {
                    (child, count) = (c, k);
                    break;
                }
            }
        }
    }

    /// Each ray's nearest hit in (0, t_max), as [`WideBvh::closest`] with every hit kept
    /// finds it alone (the same triangle, distance and barycentrics to the bit), the rays
    /// traversing the tree together ([`packet`]). For coherent rays: a packet whose rays go
    /// different ways along an axis is traced one ray at a time.
    pub fn closest_packet(
        &self,
        rays: &[WideRay; PACKET],
        t_max: f32,
    ) -> [Option<LeafHit>; PACKET] {
        let all = |_: usize, _: f32, _: f32| true;
        let Some(f) = Frustum::new(rays) else {
            return rays.each_ref().map(|r| self.closest(r, t_max, all));
        };
        let soa = Rays::new(rays);
        let portable = || {
            self.traverse_packet(
                rays,
                t_max,
                |n, t| f.enter(n, t),
                |n, lane, t| soa.enter(&f, n, lane, t),
                |p, i, t| pack::intersect_pair(p, &rays[i], t),
            )
        };
        #[cfg(target_arch = "x86_64")]
        let (mut hits, redo) = if self.avx {
            // SAFETY: `avx` is set only where the CPU has AVX.
            unsafe { self.packet_avx(rays, &f, &soa, t_max) }
        } else {
            portable()
        };
        #[cfg(not(target_arch = "x86_64"))]
        let (mut hits, redo) = portable();
        let mut m = redo;
        while m != 0 {
            let i = m.trailing_zeros() as usize;
            m &= m - 1;
            hits[i] = self.closest(&rays[i], t_max, all);
        }
        hits
    }

    /// [`WideBvh::traverse_packet`] compiled for AVX, with AVX node and leaf tests.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn packet_avx(
        &self,
        rays: &[WideRay; PACKET],
        f: &Frustum,
        soa: &Rays,
        t_max: f32,
    ) -> ([Option<LeafHit>; PACKET], u32) {
        let f8 = avx::Frustum8::new(f);
        let r8 = rays.each_ref().map(|r| avx::Ray8::new(r));
        let soa8 = avx::Rays8::new(soa);
        // SAFETY (all): this function runs only on CPUs with AVX.
        self.traverse_packet(
            rays,
            t_max,
            |n, t| unsafe { avx::enter_frustum(n, f, &f8, t) },
            |n, lane, t| unsafe { avx::enter_rays(n, lane, f, &soa8, t) },
            |p, i, t| unsafe { avx::intersect_pair(p, &r8[i], t) },
        )
    }

    /// Packet traversal, nearest child first by the packet's entry bound: `frustum` tests a
    /// node's children for the packet, `enter_rays` which rays enter the child box in a lane
    /// (done for the leaf children the packet enters: each ray tests only the leaves whose box
    /// it enters alone, with the single-ray test's bits), `pair` a pair of packs for ray i. Returns the hits and, as a bit per ray, the rays whose nearest hit may
    /// depend on the order leaves were visited in: another triangle hit within [`NEAR_TIE`]
    /// (relative) of the nearest. Boxes are entered up to that much beyond a ray's nearest hit,
    /// so a triangle that a box's rounding puts slightly before the box is still seen.
    #[inline(always)]
    fn traverse_packet(
        &self,
        rays: &[WideRay; PACKET],
        t_max0: f32,
        frustum: impl Fn(&Node, f32) -> (u32, [f32; WIDTH]),
        enter_rays: impl Fn(&Node, usize, &[f32; PACKET]) -> u32,
        pair: impl Fn(&[Pack; 2], usize, f32) -> Hits,
    ) -> ([Option<LeafHit>; PACKET], u32) {
        const ALL: u32 = (1 << PACKET) - 1;
        let mut t_max = [t_max0; PACKET];
        // The limit boxes are entered within: t_max widened by NEAR_TIE.
        let mut t_lim = [t_max0; PACKET];
        let mut best: [Option<LeafHit>; PACKET] = [None; PACKET];
        let mut ties = 0u32;
        let mut stack: SmallVec<[(u32, u32, f32, u32); 64]> = SmallVec::new();
        let (mut child, mut count) = self.root;
        let mut active = ALL;
        loop {
            if count > 0 {
                let mut m = active;
                while m != 0 {
                    let i = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let near_tie = self.leaf_hit_tied(
                        child,
                        count,
                        &rays[i],
                        &mut t_max[i],
                        &mut best[i],
                        &|p, t| pair(p, i, t),
                    );
                    ties |= (near_tie as u32) << i;
                    t_lim[i] = t_max[i] * NEAR_TIE_UP;
                }
            } else {
                let node = &self.nodes[child as usize];
                let packet_lim = t_lim.iter().fold(0.0f32, |a, &b| a.max(b));
                let (mut mask, t_in) = frustum(node, packet_lim);
                self.prefetch(node, mask);
                let mut rays_of = [ALL; WIDTH];
                let mut leaves = 0u32;
                let mut m = mask;
                while m != 0 {
                    let lane = m.trailing_zeros() as usize;
                    m &= m - 1;
                    leaves |= ((node.count[lane] > 0) as u32) << lane;
                }
                // Each leaf only for the rays that enter its box.
                let mut m = leaves;
                while m != 0 {
                    let lane = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let r = enter_rays(node, lane, &t_lim);
                    rays_of[lane] = r;
                    if r == 0 {
                        mask &= !(1 << lane);
                    }
                }
                if mask != 0 {
                    // Nearest first: push the others far to near.
                    let mut lanes = [(0.0f32, 0usize); WIDTH];
                    let mut n = 0;
                    let mut m = mask;
                    while m != 0 {
                        let lane = m.trailing_zeros() as usize;
                        m &= m - 1;
                        let t = t_in[lane];
                        let mut i = n;
                        while i > 0 && lanes[i - 1].0 > t {
                            lanes[i] = lanes[i - 1];
                            i -= 1;
                        }
                        lanes[i] = (t, lane);
                        n += 1;
                    }
                    for &(t, lane) in lanes[1..n].iter().rev() {
                        stack.push((node.child[lane], node.count[lane], t, rays_of[lane]));
                    }
                    let lane = lanes[0].1;
                    (child, count, active) = (node.child[lane], node.count[lane], rays_of[lane]);
                    continue;
                }
            }
            loop {
                let Some((c, k, t, rays_in)) = stack.pop() else {
                    return (best, ties);
                };
                let mut live = 0;
                let mut m = rays_in;
                while m != 0 {
                    let i = m.trailing_zeros() as usize;
                    m &= m - 1;
                    live |= ((t <= t_lim[i]) as u32) << i;
                }
                if live != 0 {
                    (child, count, active) = (c, k, live);
                    break;
                }
            }
        }
    }

    /// [`WideBvh::leaf_hit`] for one ray of a packet (every hit kept), updating its nearest hit
    /// `best` and `t_max`; whether another triangle's hit lay within [`NEAR_TIE`] of the
    /// nearest hit so far (before or after this leaf lowered it).
    #[inline(always)]
    fn leaf_hit_tied(
        &self,
        first: u32,
        count: u32,
        r: &WideRay,
        t_max: &mut f32,
        best: &mut Option<LeafHit>,
        pair: &impl Fn(&[Pack; 2], f32) -> Hits,
    ) -> bool {
        let (mut p, end) = (first as usize, (first + count) as usize);
        let mut tied = false;
        while p < end {
            let is_pair = end - p >= 2;
            let lim = *t_max * NEAR_TIE_UP;
            let hits = if is_pair {
                pair(self.packs[p..p + 2].try_into().unwrap(), lim)
            } else {
                self.packs[p].intersect(r, lim)
            };
            let mut mask = hits.mask;
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let slot = p * 4 + lane;
                let t = hits.t[lane];
                // Within NEAR_TIE of the nearest so far, on another triangle (the same triangle
                // in another leaf, pre-split, gives the same bits).
                if let Some(b) = best
                    && t >= b.t * NEAR_TIE_DOWN
                    && t <= b.t * NEAR_TIE_UP
                    && self.original[slot] != b.original
                {
                    tied = true;
                }
                if t < *t_max {
                    *t_max = t;
                    *best = Some(LeafHit {
                        slot,
                        original: self.original[slot],
                        t,
                        u: hits.u[lane],
                        v: hits.v[lane],
                    });
                }
            }
            p += 1 + is_pair as usize;
        }
        tied
    }

    /// Starts loading the children in `mask` (software prefetch), so that the cache misses of
    /// those the ray visits later overlap with the work on the nearest instead of following it
    /// (as Embree's traversal prefetches child nodes); it pays on diffuse rays, whose nodes and
    /// leaves are rarely in cache (docs/tuning.md#prefetch).
    ///
    /// The same [`PREFETCH_LINES`] lines for a leaf as for a node, the address picked without
    /// a branch, which is faster than a branch and a loop on the size.
    #[inline(always)]
    fn prefetch(&self, node: &Node, mask: u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            let (packs, nodes) = (self.packs.as_ptr() as usize, self.nodes.as_ptr() as usize);
            let mut m = mask;
            while m != 0 {
                let lane = m.trailing_zeros() as usize;
                m &= m - 1;
                let leaf = node.count[lane] > 0;
                let (base, size) = if leaf {
                    (packs, std::mem::size_of::<Pack>())
                } else {
                    (nodes, std::mem::size_of::<Node>())
                };
                let at = base.wrapping_add(node.child[lane] as usize * size) as *const i8;
                for line in 0..PREFETCH_LINES {
                    // SAFETY: a prefetch never faults, whatever the address.
                    unsafe { _mm_prefetch::<_MM_HINT_T0>(at.wrapping_add(64 * line)) };
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = (node, mask);
    }

    /// The nearest hit in the leaf of `count` packs from `first` below `t_max` that `keep`
    /// accepts (lowering `t_max` to it), the first such slot among equally near ones; with
    /// `ANY`, the first accepted hit. Pairs of packs are tested with `pair`.
    #[inline(always)]
    fn leaf_hit<const ANY: bool>(
        &self,
        first: u32,
        count: u32,
        r: &WideRay,
        t_max: &mut f32,
        keep: &impl Fn(usize, f32, f32) -> bool,
        pair: &impl Fn(&[Pack; 2], f32) -> Hits,
    ) -> Option<LeafHit> {
        let (mut p, end) = (first as usize, (first + count) as usize);
        let mut best = None;
        while p < end {
            let is_pair = end - p >= 2;
            let hits = if is_pair {
                pair(self.packs[p..p + 2].try_into().unwrap(), *t_max)
            } else {
                self.packs[p].intersect(r, *t_max)
            };
            let mut mask = hits.mask;
            let mut found = None;
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let slot = p * 4 + lane;
                if hits.t[lane] < *t_max && keep(slot, hits.u[lane], hits.v[lane]) {
                    *t_max = hits.t[lane];
                    found = Some(lane);
                    if ANY {
                        break;
                    }
                }
            }
            if let Some(lane) = found {
                best = Some(LeafHit {
                    slot: p * 4 + lane,
                    original: self.original[p * 4 + lane],
                    t: hits.t[lane],
                    u: hits.u[lane],
                    v: hits.v[lane],
                });
                if ANY {
                    return best;
                }
            }
            p += 1 + is_pair as usize;
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic soup of `n` small triangles in the unit cube, and some large ones
    /// crossing it (walls, which pre-splitting cuts up).
    fn soup(n: usize) -> Vec<BvhTriangle> {
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut v = |s: f32| {
            let c = Vec3A::new(next(), next(), next());
            c + (Vec3A::new(next(), next(), next()) - 0.5) * s
        };
        let mut tris: Vec<BvhTriangle> = (0..n)
            .map(|_| BvhTriangle {
                v0: v(0.0),
                v1: v(0.1),
                v2: v(0.1),
            })
            .collect();
        for k in 0..4 {
            let z = 0.2 * k as f32 + 0.1;
            tris.push(BvhTriangle {
                v0: Vec3A::new(-0.5, -0.5, z),
                v1: Vec3A::new(1.5, -0.5, z),
                v2: Vec3A::new(-0.5, 1.5, z + 0.3),
            });
        }
        tris
    }

    /// The nearest hit by testing every triangle.
    fn brute(tris: &[BvhTriangle], r: &WideRay) -> Option<(u32, f32)> {
        let mut best: Option<(u32, f32)> = None;
        for (i, t) in tris.iter().enumerate() {
            let tri = Tri::new(t);
            let mut pack = Pack::empty();
            for lane in 0..4 {
                pack::set(&mut pack, lane, &tri);
            }
            let hits = pack.intersect(r, f32::INFINITY);
            if hits.mask & 1 != 0 && best.is_none_or(|(_, b)| hits.t[0] < b) {
                best = Some((i as u32, hits.t[0]));
            }
        }
        best
    }

    #[test]
    fn traversal_finds_the_same_hits_as_testing_every_triangle() {
        let tris = soup(1500);
        // Both node tests: portable, and AVX where this CPU has it.
        let simd = [false, avx_detected()];
        for (params, avx) in [BUILD, BvhBuildParams::medium_build()]
            .into_iter()
            .flat_map(|p| simd.map(|avx| (p, avx)))
        {
            let mut bvh = WideBvh::build(&tris, params);
            bvh.avx = avx;
            let mut hits = 0;
            for k in 0..500 {
                let a = k as f32 * 0.618_034;
                let o = Vec3A::new(
                    0.5 + 0.9 * a.cos(),
                    0.5 + 0.9 * a.sin(),
                    (k % 7) as f32 / 6.0,
                );
                let target = Vec3A::new((a * 3.1).fract(), (a * 1.7).fract(), (a * 2.3).fract());
                let d = (target - o).normalize();
                let r = WideRay::new(o, d);
                let want = brute(&tris, &r);
                let got = bvh.closest(&r, f32::INFINITY, |_, _, _| true).map(|h| {
                    assert_eq!(h.original, bvh.original[h.slot]);
                    // The leaf test's barycentrics are those computed afresh.
                    let tri = Tri::new(&tris[h.original as usize]);
                    let bary = super::super::barycentrics(&tri, o, d);
                    assert_eq!(super::super::clamp_bary(h.u, h.v), bary, "ray {k}");
                    (h.original, h.t)
                });
                assert_eq!(got, want, "ray {k}: {o} → {d}");
                assert_eq!(bvh.any(&r, f32::INFINITY, |_, _, _| true), want.is_some());
                if let Some((_, t)) = want {
                    hits += 1;
                    // Up to the hit, nothing; just beyond it, occluded.
                    assert!(!bvh.any(&r, t, |_, _, _| true), "ray {k}");
                    assert!(bvh.any(&r, t * 1.0001, |_, _, _| true), "ray {k}");
                }
            }
            assert!(
                hits > 100,
                "only {hits} of 500 rays hit: the test scene is too sparse"
            );
        }
    }

    /// A ray with a NaN or infinite origin or direction (a camera looking from its target)
    /// hits nothing, alone or in a packet, and indexes no empty lane.
    #[test]
    fn a_ray_that_is_not_finite_hits_nothing() {
        let tris = soup(1500);
        let (nan, inf) = (f32::NAN, f32::INFINITY);
        let good = (Vec3A::new(0.5, 0.5, -1.0), Vec3A::Z);
        let bad = [
            (Vec3A::new(0.5, 0.5, -1.0), Vec3A::splat(nan)),
            (Vec3A::new(0.5, 0.5, -1.0), Vec3A::new(0.0, nan, 1.0)),
            (Vec3A::splat(nan), Vec3A::Z),
            (Vec3A::new(0.5, inf, -1.0), Vec3A::Z),
            (Vec3A::new(0.5, 0.5, -1.0), Vec3A::new(0.0, 0.0, inf)),
            (Vec3A::new(0.5, 0.5, -1.0), Vec3A::new(-inf, 0.0, 1.0)),
        ];
        for avx in [false, avx_detected()] {
            let mut bvh = WideBvh::build(&tris, BUILD);
            bvh.avx = avx;
            let all = |_: usize, _: f32, _: f32| true;
            let g = WideRay::new(good.0, good.1);
            assert!(bvh.closest(&g, f32::INFINITY, all).is_some());
            for (k, &(o, d)) in bad.iter().enumerate() {
                let r = WideRay::new(o, d);
                assert_eq!(
                    bvh.closest(&r, f32::INFINITY, all),
                    None,
                    "ray {k}: {o} → {d}"
                );
                assert!(!bvh.any(&r, f32::INFINITY, all), "ray {k}: {o} → {d}");
                // In a packet of otherwise good rays going the same way.
                let rays: [WideRay; PACKET] = std::array::from_fn(|i| {
                    let (o, d) = if i == 3 { (o, d) } else { good };
                    WideRay::new(o, d)
                });
                let hits = bvh.closest_packet(&rays, f32::INFINITY);
                assert_eq!(hits[3], None, "ray {k} in a packet");
                assert!(hits[0].is_some(), "ray {k}: the good rays still hit");
            }
        }
    }

    /// A triangle with a NaN or infinite vertex (a NaN box) is never hit, and rays that
    /// reach it still find the other triangles.
    #[test]
    fn a_triangle_that_is_not_finite_is_never_hit() {
        let mut tris = soup(200);
        let n = tris.len() as u32;
        for v in [f32::NAN, f32::INFINITY] {
            tris.push(BvhTriangle {
                v0: Vec3A::new(0.0, 0.0, 0.5),
                v1: Vec3A::new(1.0, v, 0.5),
                v2: Vec3A::new(0.0, 1.0, 0.5),
            });
        }
        for avx in [false, avx_detected()] {
            let mut bvh = WideBvh::build(&tris, BUILD);
            bvh.avx = avx;
            for k in 0..100 {
                let o = Vec3A::new(0.01 * k as f32, 0.3, -1.0);
                let r = WideRay::new(o, Vec3A::Z);
                let got = bvh.closest(&r, f32::INFINITY, |_, _, _| true);
                assert!(got.is_none_or(|h| h.original < n), "ray {k}: {got:?}");
                assert_eq!(
                    got.map(|h| h.original),
                    brute(&tris[..n as usize], &r).map(|b| b.0)
                );
            }
        }
    }

    #[test]
    fn the_build_does_not_depend_on_the_thread_count() {
        let tris = soup(20_000);
        let build = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| WideBvh::build(&tris, BUILD))
        };
        let (a, b) = (build(1), build(3));
        assert_eq!(a.original, b.original);
        assert_eq!(a.root, b.root);
        assert_eq!(a.nodes.len(), b.nodes.len());
        assert_eq!(a.nodes, b.nodes);
    }
}
