//! The eight-wide slab test in one AVX register per row (x86-64 with AVX, detected at run
//! time). The operations and their order are those of [`Node::enter`]'s two halves, so both
//! give the same bits.

use std::arch::x86_64::*;

use super::WideRay;
use super::node::{Node, ROBUST_FAR, WIDTH};

/// A ray's origin and inverse direction broadcast to eight lanes.
#[derive(Clone, Copy)]
pub(super) struct Ray8 {
    o: [__m256; 3],
    inv: [__m256; 3],
}

impl Ray8 {
    #[target_feature(enable = "avx")]
    pub fn new(r: &WideRay) -> Ray8 {
        let splat = |v: glam::Vec4| _mm256_set1_ps(v.x);
        Ray8 {
            o: r.o4.map(splat),
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
