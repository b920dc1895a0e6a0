//! The eight-wide slab test and the eight-triangle leaf test in one AVX register per row
//! (x86-64 with AVX, detected at run time). The operations and their order are those of
//! [`Node::enter`]'s and [`super::pack::intersect_pair`]'s two halves, so both give the same bits.

use std::arch::x86_64::*;

use super::WideRay;
use super::node::{Node, ROBUST_FAR, WIDTH};
use super::pack::{Hits, Pack};
use super::packet::{Frustum, Rays};

/// A ray's origin, direction and inverse direction broadcast to eight lanes.
#[derive(Clone, Copy)]
pub(super) struct Ray8 {
    o: [__m256; 3],
    d: [__m256; 3],
    inv: [__m256; 3],
}

impl Ray8 {
    #[target_feature(enable = "avx")]
    pub fn new(r: &WideRay) -> Ray8 {
        let splat = |v: glam::Vec4| _mm256_set1_ps(v.x);
        Ray8 {
            o: r.o4.map(splat),
            d: r.d4.map(splat),
            inv: r.inv4.map(splat),
        }
    }
}

/// [`Node::enter`] with AVX.
///
/// # Safety
///
/// The CPU must have AVX. Always inlined: called from a function compiled for AVX, its
/// intrinsics are inlined there too.
#[inline(always)]
pub(super) unsafe fn enter(node: &Node, r: &WideRay, r8: &Ray8, t_max: f32) -> (u32, [f32; WIDTH]) {
    // SAFETY: the caller's CPU has AVX; each row is eight f32 in bounds, `out` holds eight,
    // and loadu/storeu have no alignment requirement.
    unsafe {
        let t = |i: usize, a: usize| {
            let row = _mm256_loadu_ps(node.bounds[i].as_ptr());
            _mm256_mul_ps(_mm256_sub_ps(row, r8.o[a]), r8.inv[a])
        };
        let tx0 = t(r.near[0], 0);
        let ty0 = t(r.near[1], 1);
        let tz0 = t(r.near[2], 2);
        let tx1 = t(r.far[0], 0);
        let ty1 = t(r.far[1], 1);
        let tz1 = t(r.far[2], 2);
        let t_in = _mm256_max_ps(
            _mm256_max_ps(_mm256_max_ps(tx0, ty0), tz0),
            _mm256_setzero_ps(),
        );
        let t_out = _mm256_min_ps(
            _mm256_mul_ps(
                _mm256_min_ps(_mm256_min_ps(tx1, ty1), tz1),
                _mm256_set1_ps(ROBUST_FAR),
            ),
            _mm256_set1_ps(t_max),
        );
        let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t_in, t_out)) as u32;
        let mut out = [0.0; WIDTH];
        _mm256_storeu_ps(out.as_mut_ptr(), t_in);
        (mask, out)
    }
}

/// A packet's [`Frustum`] broadcast to eight lanes.
#[derive(Clone, Copy)]
pub(super) struct Frustum8 {
    near_o: [__m256; 3],
    far_o: [__m256; 3],
    inv_lo: [__m256; 3],
    inv_hi: [__m256; 3],
}

impl Frustum8 {
    #[target_feature(enable = "avx")]
    pub fn new(f: &Frustum) -> Frustum8 {
        let splat = |v: [f32; 3]| v.map(|x| _mm256_set1_ps(x));
        Frustum8 {
            near_o: splat(f.near_o),
            far_o: splat(f.far_o),
            inv_lo: splat(f.inv_lo),
            inv_hi: splat(f.inv_hi),
        }
    }
}

/// A slab plane's distance bound for the packet: the lower (or, with `UPPER`, the upper) of
/// (row − o)·inv_lo and (row − o)·inv_hi.
///
/// # Safety
///
/// As for [`enter`]; `row` points to eight f32.
#[inline(always)]
unsafe fn slab_bound<const UPPER: bool>(
    row: *const f32,
    o: __m256,
    inv_lo: __m256,
    inv_hi: __m256,
) -> __m256 {
    // SAFETY: as documented.
    unsafe {
        let x = _mm256_sub_ps(_mm256_loadu_ps(row), o);
        let (a, b) = (_mm256_mul_ps(x, inv_lo), _mm256_mul_ps(x, inv_hi));
        if UPPER {
            _mm256_max_ps(a, b)
        } else {
            _mm256_min_ps(a, b)
        }
    }
}

/// [`Frustum::enter`] with AVX.
///
/// # Safety
///
/// As for [`enter`].
#[inline(always)]
pub(super) unsafe fn enter_frustum(
    node: &Node,
    f: &Frustum,
    f8: &Frustum8,
    t_max: f32,
) -> (u32, [f32; WIDTH]) {
    // SAFETY: as in `enter`. (No closures: one not inlined is compiled without AVX, and its
    // intrinsics become calls.)
    unsafe {
        let b = &node.bounds;
        let (o, lo, hi) = (f8.near_o, f8.inv_lo, f8.inv_hi);
        let nx = slab_bound::<false>(b[f.near[0]].as_ptr(), o[0], lo[0], hi[0]);
        let ny = slab_bound::<false>(b[f.near[1]].as_ptr(), o[1], lo[1], hi[1]);
        let nz = slab_bound::<false>(b[f.near[2]].as_ptr(), o[2], lo[2], hi[2]);
        let o = f8.far_o;
        let fx = slab_bound::<true>(b[f.far[0]].as_ptr(), o[0], lo[0], hi[0]);
        let fy = slab_bound::<true>(b[f.far[1]].as_ptr(), o[1], lo[1], hi[1]);
        let fz = slab_bound::<true>(b[f.far[2]].as_ptr(), o[2], lo[2], hi[2]);
        let t_in = _mm256_max_ps(
            _mm256_max_ps(_mm256_max_ps(nx, ny), nz),
            _mm256_setzero_ps(),
        );
        let t_out = _mm256_min_ps(
            _mm256_mul_ps(
                _mm256_min_ps(_mm256_min_ps(fx, fy), fz),
                _mm256_set1_ps(ROBUST_FAR),
            ),
            _mm256_set1_ps(t_max),
        );
        let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t_in, t_out)) as u32;
        let mut out = [0.0; WIDTH];
        _mm256_storeu_ps(out.as_mut_ptr(), t_in);
        (mask, out)
    }
}

/// A packet's [`Rays`] in AVX registers.
#[derive(Clone, Copy)]
pub(super) struct Rays8 {
    o: [__m256; 3],
    inv: [__m256; 3],
}

impl Rays8 {
    #[target_feature(enable = "avx")]
    pub fn new(r: &Rays) -> Rays8 {
        // SAFETY: each row is eight f32; loadu has no alignment requirement.
        unsafe {
            Rays8 {
                o: [
                    _mm256_loadu_ps(r.o[0].as_ptr()),
                    _mm256_loadu_ps(r.o[1].as_ptr()),
                    _mm256_loadu_ps(r.o[2].as_ptr()),
                ],
                inv: [
                    _mm256_loadu_ps(r.inv[0].as_ptr()),
                    _mm256_loadu_ps(r.inv[1].as_ptr()),
                    _mm256_loadu_ps(r.inv[2].as_ptr()),
                ],
            }
        }
    }
}

/// [`Rays::enter`] with AVX.
///
/// # Safety
///
/// As for [`enter`].
#[inline(always)]
pub(super) unsafe fn enter_rays(
    node: &Node,
    lane: usize,
    f: &Frustum,
    r8: &Rays8,
    t_max: &[f32; 8],
) -> u32 {
    // SAFETY: as in `enter`; `t_max` is eight f32. No closures (see `enter_frustum`).
    unsafe {
        let b = &node.bounds;
        let tx0 = slab(b[f.near[0]][lane], r8.o[0], r8.inv[0]);
        let ty0 = slab(b[f.near[1]][lane], r8.o[1], r8.inv[1]);
        let tz0 = slab(b[f.near[2]][lane], r8.o[2], r8.inv[2]);
        let tx1 = slab(b[f.far[0]][lane], r8.o[0], r8.inv[0]);
        let ty1 = slab(b[f.far[1]][lane], r8.o[1], r8.inv[1]);
        let tz1 = slab(b[f.far[2]][lane], r8.o[2], r8.inv[2]);
        let t_in = _mm256_max_ps(
            _mm256_max_ps(_mm256_max_ps(tx0, ty0), tz0),
            _mm256_setzero_ps(),
        );
        let t_out = _mm256_min_ps(
            _mm256_mul_ps(
                _mm256_min_ps(_mm256_min_ps(tx1, ty1), tz1),
                _mm256_set1_ps(ROBUST_FAR),
            ),
            _mm256_loadu_ps(t_max.as_ptr()),
        );
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t_in, t_out)) as u32
    }
}

/// (b − o)·inv, b broadcast.
///
/// # Safety
///
/// As for [`enter`].
#[inline(always)]
unsafe fn slab(b: f32, o: __m256, inv: __m256) -> __m256 {
    // SAFETY: as documented.
    unsafe { _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(b), o), inv) }
}

/// [`super::pack::intersect_pair`] with AVX: Möller–Trumbore on a pair's eight lanes at once.
///
/// # Safety
///
/// As for [`enter`].
#[inline(always)]
pub(super) unsafe fn intersect_pair(pair: &[Pack; 2], r8: &Ray8, t_max: f32) -> Hits {
    // SAFETY: the caller's CPU has AVX; a pair is 72 contiguous f32 (nine rows of eight), and
    // loadu/storeu have no alignment requirement.
    unsafe {
        let at = pair.as_ptr() as *const f32;
        let row = |i: usize| _mm256_loadu_ps(at.add(8 * i));
        let (add, sub, mul) = (_mm256_add_ps, _mm256_sub_ps, _mm256_mul_ps);
        let (v0x, v0y, v0z) = (row(0), row(1), row(2));
        let (e1x, e1y, e1z) = (row(3), row(4), row(5));
        let (e2x, e2y, e2z) = (row(6), row(7), row(8));
        let [dx, dy, dz] = r8.d;
        let px = sub(mul(dy, e2z), mul(dz, e2y));
        let py = sub(mul(dz, e2x), mul(dx, e2z));
        let pz = sub(mul(dx, e2y), mul(dy, e2x));
        let det = add(add(mul(e1x, px), mul(e1y, py)), mul(e1z, pz));
        let one = _mm256_set1_ps(1.0);
        let zero = _mm256_setzero_ps();
        let inv = _mm256_div_ps(one, det);
        let tx = sub(r8.o[0], v0x);
        let ty = sub(r8.o[1], v0y);
        let tz = sub(r8.o[2], v0z);
        let u = mul(add(add(mul(tx, px), mul(ty, py)), mul(tz, pz)), inv);
        let qx = sub(mul(ty, e1z), mul(tz, e1y));
        let qy = sub(mul(tz, e1x), mul(tx, e1z));
        let qz = sub(mul(tx, e1y), mul(ty, e1x));
        let v = mul(add(add(mul(dx, qx), mul(dy, qy)), mul(dz, qz)), inv);
        let t = mul(add(add(mul(e2x, qx), mul(e2y, qy)), mul(e2z, qz)), inv);
        // The comparisons of `Vec4`'s cmpge, cmple, cmpgt, cmplt (ordered) and cmpne
        // (unordered: true for NaN).
        let and = _mm256_and_ps;
        let ok = and(
            and(
                and(
                    _mm256_cmp_ps::<_CMP_GE_OQ>(u, zero),
                    _mm256_cmp_ps::<_CMP_LE_OQ>(u, one),
                ),
                and(
                    _mm256_cmp_ps::<_CMP_GE_OQ>(v, zero),
                    _mm256_cmp_ps::<_CMP_LE_OQ>(add(u, v), one),
                ),
            ),
            and(
                and(
                    _mm256_cmp_ps::<_CMP_GT_OQ>(t, zero),
                    _mm256_cmp_ps::<_CMP_LT_OQ>(t, _mm256_set1_ps(t_max)),
                ),
                _mm256_cmp_ps::<_CMP_NEQ_UQ>(det, zero),
            ),
        );
        let mut hits = Hits {
            mask: _mm256_movemask_ps(ok) as u32,
            t: [0.0; 8],
            u: [0.0; 8],
            v: [0.0; 8],
        };
        _mm256_storeu_ps(hits.t.as_mut_ptr(), t);
        _mm256_storeu_ps(hits.u.as_mut_ptr(), u);
        _mm256_storeu_ps(hits.v.as_mut_ptr(), v);
        hits
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3A;

    use super::super::pack::{self, DEGENERATE};
    use super::super::{Tri, WideRay};
    use super::*;

    #[target_feature(enable = "avx")]
    fn avx_pair(pair: &[Pack; 2], r: &WideRay, t_max: f32) -> Hits {
        // SAFETY: this function runs only on CPUs with AVX.
        unsafe { intersect_pair(pair, &Ray8::new(r), t_max) }
    }

    #[test]
    fn the_pair_test_gives_the_portable_bits() {
        if !std::arch::is_x86_feature_detected!("avx") {
            return;
        }
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut hits = 0;
        for k in 0..4000 {
            let mut v = || Vec3A::new(next(), next(), next());
            let mut pair = [Pack::empty(); 2];
            for lane in 0..8 {
                let tri = match (k + lane) % 9 {
                    0 => DEGENERATE,
                    // Two triangles sharing an edge: a quad's diagonal.
                    1 => Tri {
                        v0: Vec3A::ZERO,
                        e1: Vec3A::X,
                        e2: Vec3A::Y,
                    },
                    2 => Tri {
                        v0: Vec3A::new(1.0, 1.0, 0.0),
                        e1: -Vec3A::X,
                        e2: -Vec3A::Y,
                    },
                    _ => Tri {
                        v0: v(),
                        e1: v() - 0.5,
                        e2: v() - 0.5,
                    },
                };
                pack::set_pair(&mut pair, lane, &tri);
            }
            let o = Vec3A::new(next(), next(), next() - 1.0);
            let d = if k % 5 == 0 {
                Vec3A::Z
            } else {
                (Vec3A::new(next(), next(), next()) - o).normalize()
            };
            let r = WideRay::new(o, d);
            let t_max = if k % 3 == 0 { next() } else { f32::INFINITY };
            let want = pack::intersect_pair(&pair, &r, t_max);
            // SAFETY: AVX detected above.
            let got = unsafe { avx_pair(&pair, &r, t_max) };
            assert_eq!(want.mask, got.mask, "ray {k}");
            for (a, b) in [(want.t, got.t), (want.u, got.u), (want.v, got.v)] {
                assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "ray {k}");
            }
            hits += want.mask.count_ones();
        }
        assert!(hits > 2000, "only {hits} hits");
    }
}
