//! Back sides with texels of their own. A double-sided sheet open to the room (a lamp shade, a
//! chair's one-layer shell, a leaf) is lit differently on its two sides: under a pendant shade
//! the bulb, above it the ceiling. One set of texels for both would show the lit side's light
//! on the dark side. Such a sheet's back side is solved as a surface of its own: a *twin* of
//! each of its triangles, facing the other way, with its own chart in the atlas and its own
//! elements. Twins are not in the ray-casting BVH: a ray meeting a sheet's back face reads the
//! twin's texel ([`super::atlas::Atlas::side`]).
//!
//! Only sheets whose back sees the lit scene get twins: a closed double-sided mesh (a cup with
//! walls of some thickness, a table top) sees only its own inside from its back faces, and a
//! room's one-sided walls see nothing behind them; both keep one set of texels.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::atlas::weld;
use crate::geometry::{Bvh, Triangle};
use crate::sampling::{basis, r2, sample_cosine_hemisphere};
use crate::scene::Scene;

/// Rays cast from each triangle's back side to tell whether its sheet is open.
pub const BACK_RAYS: u32 = 8;

/// A sheet is open when at least this share of its back rays meet the front face of some
/// surface at least [`OPEN_GAP`] away (rays that leave the scene, or meet a back face, see
/// nothing lit).
pub const OPEN_SHARE: f32 = 0.25;

/// A back ray that meets a front face nearer than this fraction of its sheet's size (the
/// diagonal of its bounding box) sees into a gap no eye sees into: a painting's canvas in
/// front of its wall, a decal on a cup, a rubber foot capping a chair's leg.
pub const OPEN_GAP: f32 = 0.1;

/// A sheet smaller than this fraction of the scene's size (bounding-box diagonals) keeps one
/// set of texels: its two sides' difference is too small to see for the texels it would
/// cost (a chair leg's rubber cap, whose inside only shows edge-on).
pub const MIN_SHEET: f32 = 0.02;

/// The triangles whose back sides get texels of their own, ascending: every triangle of each
/// open sheet of double-sided, non-emitting, reflecting material. None when every triangle
/// has TEXCOORD_1: the glTF's own lightmap layout has one place for each triangle.
pub fn open_backs(scene: &Scene, bvh: &Bvh) -> Vec<u32> {
    let tris = &scene.triangles;
    if tris.iter().all(|t| t.uv1.is_some()) {
        return Vec::new();
    }
    let candidate = |t: &Triangle| {
        let m = &scene.materials[t.material as usize];
        m.double_sided
            && m.emission.max_element() <= 0.0
            && m.albedo.max_element() > 0.0
            && t.area() > 0.0
    };
    let is: Vec<bool> = tris.iter().map(candidate).collect();
    if !is.contains(&true) {
        return Vec::new();
    }
    let sheet = sheets(tris, &is);
    // Each sheet's size: the diagonal of its triangles' bounding box.
    let mut bounds = vec![(Vec3::INFINITY, Vec3::NEG_INFINITY); tris.len()];
    for (t, tri) in tris.iter().enumerate().filter(|(t, _)| is[*t]) {
        let b = &mut bounds[sheet[t] as usize];
        for p in tri.p {
            *b = (b.0.min(p), b.1.max(p));
        }
    }
    // Sheets too small to matter cast no rays.
    let size = |t: usize| {
        let (lo, hi) = bounds[sheet[t] as usize];
        (hi - lo).length()
    };
    let min_size = MIN_SHEET * scene.bounds.diagonal();
    let tested = |t: usize| is[t] && size(t) >= min_size;
    // Per tested triangle: how many of its back rays meet a front face across a gap.
    let seen: Vec<u32> = (0..tris.len() as u32)
        .into_par_iter()
        .map(|t| {
            if tested(t as usize) {
                front_faces_seen(tris, bvh, t, OPEN_GAP * size(t as usize))
            } else {
                0
            }
        })
        .collect();
    // Integer sums per sheet: the same whatever the thread count.
    let mut rays = vec![0u64; tris.len()];
    let mut hits = vec![0u64; tris.len()];
    for t in (0..tris.len()).filter(|&t| tested(t)) {
        rays[sheet[t] as usize] += BACK_RAYS as u64;
        hits[sheet[t] as usize] += seen[t] as u64;
    }
    (0..tris.len() as u32)
        .filter(|&t| {
            let s = sheet[t as usize] as usize;
            tested(t as usize) && hits[s] as f64 >= OPEN_SHARE as f64 * rays[s] as f64
        })
        .collect()
}

/// How many of [`BACK_RAYS`] cosine-distributed rays from the back of triangle `t`'s
/// centroid meet a front face at least `gap` away.
fn front_faces_seen(tris: &[Triangle], bvh: &Bvh, t: u32, gap: f32) -> u32 {
    let tri = &tris[t as usize];
    let n = -tri.face_normal();
    let (u, v) = basis(n);
    let origin = bvh.offset_origin(tri.point(Vec2::splat(1.0 / 3.0)), n);
    // A shift of the pattern per triangle, so that a sheet's triangles look different ways.
    let shift = r2(t.wrapping_mul(0x9e37_79b9), Vec2::ZERO);
    (0..BACK_RAYS)
        .filter(|&k| {
            let l = sample_cosine_hemisphere(r2(k, shift));
            let d = u * l.x + v * l.y + n * l.z;
            bvh.closest_hit(origin, d, f32::INFINITY)
                .is_some_and(|h| h.t >= gap && d.dot(tris[h.triangle as usize].face_normal()) < 0.0)
        })
        .count() as u32
}

/// Per triangle, its sheet: the smallest index of the candidate triangles joined to it
/// through shared edges (positions welded) of one material. Non-candidates are their own.
fn sheets(tris: &[Triangle], is: &[bool]) -> Vec<u32> {
    let vid = weld(tris);
    let mut sets = super::disjoint::Sets::new(tris.len());
    let mut first_on_edge: std::collections::HashMap<(u32, u32, u32), usize> =
        std::collections::HashMap::new();
    for (t, ids) in vid.iter().enumerate().filter(|(t, _)| is[*t]) {
        for e in 0..3 {
            let (a, b) = (ids[e], ids[(e + 1) % 3]);
            let key = (a.min(b), a.max(b), tris[t].material);
            let other = *first_on_edge.entry(key).or_insert(t);
            sets.join(t, other);
        }
    }
    (0..tris.len()).map(|t| sets.root(t) as u32).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::radiosity::sides::tests::tri;

    #[test]
    fn sheets_join_across_shared_edges_of_one_material_only() {
        let (a, b, c, d) = (Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE);
        let e = Vec3::new(5.0, 0.0, 0.0);
        let tris = [
            tri([a, b, c], 0),
            tri([b, d, c], 0),                        // shares b–c: same sheet
            tri([b, e, d], 1),                        // shares b–d, other material
            tri([e + a, e + b, e + c], 0),            // apart
            tri([c, d, Vec3::new(0.0, 2.0, 0.0)], 0), // shares c–d with 1
        ];
        let s = sheets(&tris, &[true; 5]);
        assert_eq!(s, vec![0, 0, 2, 3, 0]);
        // A non-candidate joins nothing.
        let s = sheets(&tris, &[true, false, true, true, true]);
        assert_eq!(s, vec![0, 1, 2, 3, 4]);
    }
}
