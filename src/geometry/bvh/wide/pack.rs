//! Leaf triangles stored by lane (SoA), tested several at once with Möller–Trumbore (1997):
//! a pack holds four triangles' (v0, e1, e2) as nine rows of four. A leaf of five to eight
//! triangles takes two consecutive packs laid out as nine rows of eight (row i's lanes 0–3,
//! then 4–7), tested in one 8-lane AVX test ([`super::avx::intersect_pair`]) or portably as
//! two 4-lane halves ([`intersect_pair`]): the same operations in the same order, lane by lane,
//! so both give the same bits.

use glam::{Vec3A, Vec4};

use super::{Tri, WideRay};

/// Four triangles' rows (v0 x, y, z; e1 x, y, z; e2 x, y, z), or half of a pair's.
#[derive(Clone, Copy)]
#[repr(C, align(16))]
pub(super) struct Pack {
    pub rows: [Vec4; ROWS],
}

/// Rows per pack.
const ROWS: usize = 9;

/// Per lane of a leaf test: which lanes the ray hits (bit per lane), and each lane's distance
/// and barycentrics (u, v).
pub(super) struct Hits {
    pub mask: u32,
    pub t: [f32; 8],
    pub u: [f32; 8],
    pub v: [f32; 8],
}

/// A triangle no ray hits (det 0): fills the lanes a leaf does not use.
pub(super) const DEGENERATE: Tri = Tri {
    v0: Vec3A::ZERO,
    e1: Vec3A::ZERO,
    e2: Vec3A::ZERO,
};

impl Pack {
    /// A pack of degenerate triangles.
    pub fn empty() -> Pack {
        Pack {
            rows: [Vec4::ZERO; ROWS],
        }
    }

    /// Per lane (0–3): whether the ray hits the triangle in (0, t_max), and where.
    #[inline(always)]
    pub fn intersect(&self, r: &WideRay, t_max: f32) -> Hits {
        let (mask, [t, u, v]) = intersect4(self.rows, r, t_max);
        let mut hits = Hits {
            mask,
            t: [0.0; 8],
            u: [0.0; 8],
            v: [0.0; 8],
        };
        t.write_to_slice(&mut hits.t[..4]);
        u.write_to_slice(&mut hits.u[..4]);
        v.write_to_slice(&mut hits.v[..4]);
        hits
    }
}

/// The nine values of a triangle, in row order.
fn values(tri: &Tri) -> impl Iterator<Item = f32> {
    [tri.v0, tri.e1, tri.e2]
        .into_iter()
        .flat_map(|v| v.to_array())
}

/// Stores `tri` in `lane` (0–3) of a single pack.
pub(super) fn set(pack: &mut Pack, lane: usize, tri: &Tri) {
    for (row, x) in values(tri).enumerate() {
        pack.rows[row][lane] = x;
    }
}

/// Stores `tri` in `lane` (0–7) of a pair of packs laid out as rows of eight.
pub(super) fn set_pair(pair: &mut [Pack; 2], lane: usize, tri: &Tri) {
    for (row, x) in values(tri).enumerate() {
        let k = 2 * row + lane / 4;
        pair[k / ROWS].rows[k % ROWS][lane % 4] = x;
    }
}

/// Half `h` (lanes 4h to 4h + 3) of a pair's rows.
#[inline(always)]
fn half(pair: &[Pack; 2], h: usize) -> [Vec4; 9] {
    std::array::from_fn(|row| {
        let k = 2 * row + h;
        pair[k / ROWS].rows[k % ROWS]
    })
}

/// Per lane of a pair (0–7): whether the ray hits the triangle in (0, t_max), and where; two
/// 4-lane halves.
#[inline(always)]
pub(super) fn intersect_pair(pair: &[Pack; 2], r: &WideRay, t_max: f32) -> Hits {
    let (m0, h0) = intersect4(half(pair, 0), r, t_max);
    let (m1, h1) = intersect4(half(pair, 1), r, t_max);
    let mut hits = Hits {
        mask: m0 | m1 << 4,
        t: [0.0; 8],
        u: [0.0; 8],
        v: [0.0; 8],
    };
    for (out, (lo, hi)) in [&mut hits.t, &mut hits.u, &mut hits.v]
        .into_iter()
        .zip(h0.into_iter().zip(h1))
    {
        lo.write_to_slice(&mut out[..4]);
        hi.write_to_slice(&mut out[4..]);
    }
    hits
}

/// Möller–Trumbore on four lanes: the hit mask, and (t, u, v) per lane. Edges are inclusive with ordinary comparisons: a ray through
/// the shared edge of two triangles (a quad's diagonal) hits one of them whatever the sign of
/// a zero.
#[inline(always)]
fn intersect4(rows: [Vec4; 9], r: &WideRay, t_max: f32) -> (u32, [Vec4; 3]) {
    let [v0x, v0y, v0z, e1x, e1y, e1z, e2x, e2y, e2z] = rows;
    let [dx, dy, dz] = r.d4;
    let px = dy * e2z - dz * e2y;
    let py = dz * e2x - dx * e2z;
    let pz = dx * e2y - dy * e2x;
    let det = e1x * px + e1y * py + e1z * pz;
    let inv = Vec4::ONE / det;
    let tx = r.o4[0] - v0x;
    let ty = r.o4[1] - v0y;
    let tz = r.o4[2] - v0z;
    let u = (tx * px + ty * py + tz * pz) * inv;
    let qx = ty * e1z - tz * e1y;
    let qy = tz * e1x - tx * e1z;
    let qz = tx * e1y - ty * e1x;
    let v = (dx * qx + dy * qy + dz * qz) * inv;
    let t = (e2x * qx + e2y * qy + e2z * qz) * inv;
    // NaN (a degenerate triangle: det 0) fails every comparison.
    let ok = u.cmpge(Vec4::ZERO)
        & u.cmple(Vec4::ONE)
        & v.cmpge(Vec4::ZERO)
        & (u + v).cmple(Vec4::ONE)
        & t.cmpgt(Vec4::ZERO)
        & t.cmplt(Vec4::splat(t_max))
        & det.cmpne(Vec4::ZERO);
    (ok.bitmask(), [t, u, v])
}
