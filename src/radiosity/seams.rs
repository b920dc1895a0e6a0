//! Chart seams: where a smooth surface continues from one chart of the atlas into another
//! (or into another place of a TEXCOORD_1 layout), D is looked up on two sets of texels that
//! the solver estimated independently, and any difference between them shows as a hard edge.
//!
//! - [`find`] lists the seam edges: mesh edges shared by two triangles of one material whose
//!   shading normals agree at both ends (the surface is smooth there, so D is continuous)
//!   and turn by less than [`MAX_TURN_PER_TEXEL`] about the edge (the texel grid can follow
//!   the surface), but whose ends lie in different places of the atlas.
//! - [`seam_points`] places paired samples along them: the same world point as barycentrics
//!   of either triangle; [`measure`] compares D looked up on both sides, with the bilinear
//!   filter of [`super::RadiosityMap::radiance`] or the viewer's cubic B-spline;
//!   [`texel_noise`] gives the scale to compare against (neighbouring texels of one chart).
//! - [`stitch`] changes the texels near seams so that both sides' lookups agree: a linear
//!   least-squares problem, seam constraints plus a weak pull of every texel towards its
//!   solved value (Castaño, "Lightmap parameterization", The Witness blog 2010; Liu,
//!   Ferguson, Jacobson and Gingold 2017, "Seamless: seam erasure and seam-aware decoupling
//!   of shading from geometry", §4), solved per independent part by a sparse Cholesky
//!   factor in nested-dissection order (conjugate gradients for a part too large for one).
//!
//! Seams are visited in a fixed order and every sum is taken in a fixed order, so the result
//! does not depend on the thread count.
//!
//! Finding, measuring and stitching share one file because they all work on the same paired
//! seam points; the stitch's linear solve is in `seam_solve`.

use std::collections::BTreeMap;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::atlas::{Atlas, CHART_MAX_ANGLE_DEG, TexelSample, weld};
use super::map::{bilinear, bspline_weights};
use super::seam_solve::{Problem, Weights, dot, row_products};
use crate::geometry::Triangle;

/// A seam point or texel darker than this fraction of the median seam point counts as this
/// bright in [`stitch`]'s relative weights: a black seam has no jump to close.
const RELATIVE_FLOOR: f64 = 0.02;

/// Passes of [`stitch`] in [`stitch_seams`], each weighing the seam points by what the one
/// before left.
const STITCH_PASSES: usize = 2;

/// Radians per texel (of the coarser side): a seam edge across one of whose triangles the
/// shading normals turn faster than this is a rounded edge narrower than a texel (a picture's front turning into
/// its side, a chair shell's rim). The texels on its two sides hold faces whose D differs as
/// across a crease, and making them agree would spread one face's D over a texel of the
/// other. A curved mesh's charts get texels per radian of its turn, far under this.
pub const MAX_TURN_PER_TEXEL: f32 = std::f32::consts::FRAC_PI_2;

/// Two ends closer than this in the atlas (texels) are the same place: no seam.
const SAME_PLACE: f32 = 1e-3;

/// Paired samples per texel of seam length (on the side where the edge is longer): the
/// bilinear lookup along a line is quadratic within each texel it crosses, so three points
/// per texel pin it down.
pub const POINTS_PER_TEXEL: f32 = 3.0;

/// A mesh edge whose two triangles lie in different places of the atlas.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeamEdge {
    /// The two triangles.
    pub triangles: [u32; 2],
    /// Per triangle, the barycentrics of the edge's two ends (the same two world points, in
    /// the same order on both sides).
    pub ends: [[Vec2; 2]; 2],
}

/// One world point on a seam, as barycentrics of each of its two triangles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeamPoint {
    /// The two triangles.
    pub triangles: [u32; 2],
    /// The point on each.
    pub bary: [Vec2; 2],
}

/// A reconstruction filter of the radiosity textures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    /// Bilinear, as [`super::RadiosityMap::radiance`] (every bake stage's lookups).
    Bilinear,
    /// The uniform cubic B-spline of the viewer (`view::bicubic::bspline`).
    BSpline,
}

/// Barycentrics of a triangle's corner `k`.
fn corner(k: usize) -> Vec2 {
    [Vec2::ZERO, Vec2::X, Vec2::Y][k]
}

/// The seam edges of `triangles` in `atlas`, in a fixed order (by welded vertex ids).
pub fn find(triangles: &[Triangle], atlas: &Atlas) -> Vec<SeamEdge> {
    let vid = weld(triangles);
    let mut edges: BTreeMap<(u32, u32), Vec<u32>> = BTreeMap::new();
    for (t, v) in vid.iter().enumerate() {
        if !triangles[t].is_valid() {
            continue;
        }
        for k in 0..3 {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            if a != b {
                edges
                    .entry((a.min(b), a.max(b)))
                    .or_default()
                    .push(t as u32);
            }
        }
    }
    let cos_max = CHART_MAX_ANGLE_DEG.to_radians().cos();
    let local = |t: u32, v: u32| vid[t as usize].iter().position(|&x| x == v).unwrap();
    let mut seams = Vec::new();
    for (&(a, b), tris) in &edges {
        for (i, &ta) in tris.iter().enumerate() {
            for &tb in &tris[i + 1..] {
                let (ra, rb) = (&triangles[ta as usize], &triangles[tb as usize]);
                if ra.material != rb.material {
                    continue;
                }
                let ia = [local(ta, a), local(ta, b)];
                let ib = [local(tb, a), local(tb, b)];
                let (ca, cb) = (atlas.tri_coords[ta as usize], atlas.tri_coords[tb as usize]);
                // A crease (normals split), a fold, or a crease on the texel grid: D may
                // jump there, it is not a seam.
                if (0..2).any(|e| ra.n[ia[e]].dot(rb.n[ib[e]]) < cos_max)
                    || ra.face_normal().dot(rb.face_normal()) <= 0.0
                    || turn_per_metre([ra, rb], [ia, ib])
                        * texel_span(ra, ca).max(texel_span(rb, cb))
                        > MAX_TURN_PER_TEXEL
                {
                    continue;
                }
                if atlas.tri_page[ta as usize] == atlas.tri_page[tb as usize]
                    && (0..2).all(|e| ca[ia[e]].distance(cb[ib[e]]) <= SAME_PLACE)
                {
                    continue;
                }
                seams.push(SeamEdge {
                    triangles: [ta, tb],
                    ends: [ia.map(corner), ib.map(corner)],
                });
            }
        }
    }
    seams
}

/// How far the shading normals turn per metre about the edge that triangles `t[k]` share
/// (between their corners `edge[k]`): across either triangle (the largest angle between its
/// vertex normals over its height from the edge), and from one to the other at the edge's
/// ends (flat-shaded facets) over the narrower one's height.
fn turn_per_metre(t: [&Triangle; 2], edge: [[usize; 2]; 2]) -> f32 {
    let height = |k: usize| {
        let [a, b] = edge[k].map(|i| t[k].p[i]);
        2.0 * t[k].area() / a.distance(b)
    };
    let within = |k: usize| {
        let n = t[k].n;
        let turn = [(0, 1), (1, 2), (2, 0)]
            .map(|(i, j)| n[i].angle_between(n[j]))
            .into_iter()
            .fold(0.0f32, f32::max);
        if turn == 0.0 { 0.0 } else { turn / height(k) }
    };
    let across = (0..2)
        .map(|e| t[0].n[edge[0][e]].angle_between(t[1].n[edge[1][e]]))
        .fold(0.0f32, f32::max);
    let across = if across == 0.0 {
        0.0
    } else {
        across / height(0).min(height(1))
    };
    within(0).max(within(1)).max(across)
}

/// The longest a texel of `tri`'s chart spans on it, in metres: over its three edges, the
/// edge's length over its length in the atlas (`coords`, texels).
fn texel_span(tri: &Triangle, coords: [Vec2; 3]) -> f32 {
    (0..3)
        .map(|k| {
            let j = (k + 1) % 3;
            tri.p[j].distance(tri.p[k]) / coords[j].distance(coords[k]).max(1e-6)
        })
        .fold(0.0f32, f32::max)
}

/// Position of barycentrics `bary` of `triangle` on its page, in texels.
fn atlas_point(atlas: &Atlas, triangle: u32, bary: Vec2) -> Vec2 {
    let c = &atlas.tri_coords[triangle as usize];
    c[0] * (1.0 - bary.x - bary.y) + c[1] * bary.x + c[2] * bary.y
}

/// Paired samples along every seam, [`POINTS_PER_TEXEL`] per texel of length, at the
/// centres of equal steps (never at the ends, which other seams share).
pub fn seam_points(atlas: &Atlas, seams: &[SeamEdge]) -> Vec<SeamPoint> {
    let mut points = Vec::new();
    for s in seams {
        let len = (0..2)
            .map(|k| {
                let [e0, e1] = s.ends[k];
                atlas_point(atlas, s.triangles[k], e0).distance(atlas_point(
                    atlas,
                    s.triangles[k],
                    e1,
                ))
            })
            .fold(0.0f32, f32::max);
        let n = ((len * POINTS_PER_TEXEL).ceil() as usize).max(1);
        for i in 0..n {
            let t = (i as f32 + 0.5) / n as f32;
            points.push(SeamPoint {
                triangles: s.triangles,
                bary: [0, 1].map(|k| s.ends[k][0].lerp(s.ends[k][1], t)),
            });
        }
    }
    points
}

/// Texels (global indices) and weights that `filter` reads for barycentrics `bary` of
/// `triangle`, clamped at the page's edges as the samplers are; appended to `out`.
fn footprint(
    filter: Filter,
    atlas: &Atlas,
    offsets: &[u32],
    triangle: u32,
    bary: Vec2,
    sign: f32,
    out: &mut Vec<(u32, f32)>,
) {
    let page = atlas.tri_page[triangle as usize] as usize;
    let size = atlas.pages[page];
    let q = atlas_point(atlas, triangle, bary) - Vec2::splat(0.5);
    let i = q.floor();
    let f = q - i;
    let axis = |i: f32, f: f32, n: u32| {
        let i = i as i64;
        let (idx, w, taps) = match filter {
            Filter::Bilinear => ([i, i + 1, 0, 0], [1.0 - f, f, 0.0, 0.0], 2),
            Filter::BSpline => ([i - 1, i, i + 1, i + 2], bspline_weights(f), 4),
        };
        (idx.map(|j| j.clamp(0, n as i64 - 1)), w, taps)
    };
    let (xs, wx, nx) = axis(i.x, f.x, size.width);
    let (ys, wy, ny) = axis(i.y, f.y, size.height);
    for (y, wy) in ys.iter().zip(&wy).take(ny) {
        for (x, wx) in xs.iter().zip(&wx).take(nx) {
            let texel = offsets[page] + *y as u32 * size.width + *x as u32;
            out.push((texel, sign * wx * wy));
        }
    }
}

/// D at barycentrics `bary` of `triangle` through `filter`, from `texels` (per global atlas
/// texel). [`Filter::Bilinear`] is exactly [`super::RadiosityMap::radiance`].
pub fn lookup(
    filter: Filter,
    atlas: &Atlas,
    offsets: &[u32],
    texels: &[Vec3],
    triangle: u32,
    bary: Vec2,
) -> Vec3 {
    match filter {
        Filter::Bilinear => {
            let page = atlas.tri_page[triangle as usize] as usize;
            let size = atlas.pages[page];
            let start = offsets[page] as usize;
            let n = (size.width * size.height) as usize;
            bilinear(
                &texels[start..start + n],
                size.width,
                size.height,
                atlas_point(atlas, triangle, bary),
            )
        }
        Filter::BSpline => {
            let mut fp = Vec::with_capacity(16);
            footprint(filter, atlas, offsets, triangle, bary, 1.0, &mut fp);
            fp.iter().map(|&(t, w)| w * texels[t as usize]).sum()
        }
    }
}

/// Rec. 709 luminance, in f64 for the ratios below.
fn luminance(c: Vec3) -> f64 {
    crate::colour::luminance(c) as f64
}

/// |a − b| relative to their mean, in luminance; `None` where both are black.
fn relative(a: Vec3, b: Vec3) -> Option<f64> {
    let mean = luminance((a + b) * 0.5);
    (mean > 0.0).then(|| luminance((a - b).abs()) / mean)
}

/// Distribution of relative differences.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Spread {
    /// Pairs compared (black pairs left out).
    pub pairs: usize,
    /// Median.
    pub median: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Largest.
    pub max: f64,
}

impl Spread {
    /// Median, p95 (nearest rank) and max of `values`; zeros when empty.
    pub fn of(mut values: Vec<f64>) -> Spread {
        if values.is_empty() {
            return Spread::default();
        }
        values.sort_by(f64::total_cmp);
        let rank =
            |p: f64| values[((p * values.len() as f64).ceil() as usize).clamp(1, values.len()) - 1];
        Spread {
            pairs: values.len(),
            median: rank(0.5),
            p95: rank(0.95),
            max: values[values.len() - 1],
        }
    }
}

/// Per seam point, |ΔD| / D between the lookups on its two sides (luminance; points black
/// on both sides are left out).
pub fn jumps(atlas: &Atlas, texels: &[Vec3], points: &[SeamPoint], filter: Filter) -> Vec<f64> {
    let offsets = atlas.page_offsets();
    points
        .iter()
        .filter_map(|p| {
            let [a, b] =
                [0, 1].map(|k| lookup(filter, atlas, &offsets, texels, p.triangles[k], p.bary[k]));
            relative(a, b)
        })
        .collect()
}

/// The jump in D across seams: [`jumps`] summarised.
pub fn measure(atlas: &Atlas, texels: &[Vec3], points: &[SeamPoint], filter: Filter) -> Spread {
    Spread::of(jumps(atlas, texels, points, filter))
}

/// The texel-to-texel variation inside charts, the scale a seam's jump must stay below:
/// |ΔD| / D between horizontally and vertically adjacent texels that both hold an element of
/// the same chart. With `charts`, only texels of those charts count (the charts that touch
/// a seam, say: a flat floor's smooth texels would hide a curved mesh's noise).
pub fn texel_noise(
    atlas: &Atlas,
    samples: &[TexelSample],
    texels: &[Vec3],
    charts: Option<&[u32]>,
) -> Spread {
    let mut element = vec![false; atlas.texel_count()];
    for s in samples {
        element[s.texel as usize] = true;
    }
    let counts = |c: u32| charts.is_none_or(|cs| cs.binary_search(&c).is_ok());
    let offsets = atlas.page_offsets();
    let mut values = Vec::new();
    for (page, size) in atlas.pages.iter().enumerate() {
        let at = |x: u32, y: u32| (offsets[page] + y * size.width + x) as usize;
        for y in 0..size.height {
            for x in 0..size.width {
                let t = at(x, y);
                let chart = atlas.texel_chart[t];
                if !element[t] || chart == u32::MAX || !counts(chart) {
                    continue;
                }
                for (nx, ny) in [(x + 1, y), (x, y + 1)] {
                    if nx < size.width && ny < size.height {
                        let n = at(nx, ny);
                        if element[n]
                            && atlas.texel_chart[n] == chart
                            && let Some(r) = relative(texels[t], texels[n])
                        {
                            values.push(r);
                        }
                    }
                }
            }
        }
    }
    Spread::of(values)
}

/// The charts (sorted) that seam points lie in, for [`texel_noise`].
pub fn seam_charts(atlas: &Atlas, points: &[SeamPoint]) -> Vec<u32> {
    let offsets = atlas.page_offsets();
    let mut charts: Vec<u32> = points
        .iter()
        .flat_map(|p| [0, 1].map(|k| atlas.texel_at(&offsets, p.triangles[k], p.bary[k])))
        .map(|t| atlas.texel_chart[t as usize])
        .filter(|&c| c != u32::MAX)
        .collect();
    charts.sort_unstable();
    charts.dedup();
    charts
}

/// Weights of the stitching problem.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StitchSettings {
    /// Pull λ of every texel towards its solved value, against a weight of 1 per seam
    /// constraint (one per seam point and filter).
    pub closeness: f64,
    /// Pull μ between the changes of 4-adjacent texels of one chart (a texel next to one the
    /// seams do not read counts that one's change as 0): the change spreads smoothly over
    /// the chart instead of oscillating from texel to texel.
    pub smoothness: f64,
    /// Conjugate-gradient iterations at most.
    pub max_iterations: u32,
    /// Stop when the residual is below this fraction of the right-hand side.
    pub tolerance: f64,
}

impl Default for StitchSettings {
    fn default() -> Self {
        StitchSettings {
            closeness: 1e-3,
            smoothness: 3e-3,
            max_iterations: 4000,
            tolerance: 1e-6,
        }
    }
}

/// What [`stitch`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct StitchStats {
    /// Texels the problem could change.
    pub unknowns: usize,
    /// Seam constraints (seam points × filters).
    pub constraints: usize,
    /// Conjugate-gradient iterations run by the slowest independent part (until its last
    /// channel converged; 0 where every part was solved by its factor; summed over the
    /// passes of [`stitch_seams`]).
    pub iterations: u32,
}

/// Makes D agree on both sides of every seam point through each of `filters`, changing
/// only the texels those lookups read: minimises, over the relative change y of those
/// texels (texel i changes by δ_i = s_i·y_i, s_i its luminance),
///
/// Σ_points,filters |(lookup_a − lookup_b) / D_p|² + λ²·Σ_texels |y|² + μ²·Σ_adjacent |y_i − y_j|²
///
/// (D_p the seam point's level, the mean of its two sides; s and D floored at
/// `RELATIVE_FLOOR` × the median seam level; λ = `closeness`, μ = `smoothness`; adjacent:
/// 4-neighbours in one chart, a texel that does not change counting as y = 0). Relative
/// terms make a dark seam (under a model, at a contact) close as well as a bright one: in
/// absolute terms its jump is small beside the pulls of brighter texels nearby. The
/// smoothness term makes the change a smooth field over each chart, which a chart one or
/// two texels wide takes as a shift of its level, instead of texel-to-texel oscillations
/// fitted to nearby constraints. The normal equations (AᵀA + λ²·I + μ²·L)·y = −AᵀA·x₀ (A in
/// these units, x₀ the texels over s) are solved for the three channels, each independent
/// part (unknowns no constraint or pull links) on its own: by its Cholesky factor
/// (`seam_solve`), or by conjugate gradients with a Jacobi preconditioner where the factor
/// would be too large. Texels stay ≥ 0. Every sum runs in a fixed order
/// (parallel over rows and texels, reductions over fixed chunks): the same texels whatever
/// the thread count.
pub fn stitch(
    atlas: &Atlas,
    texels: &mut [Vec3],
    points: &[SeamPoint],
    filters: &[Filter],
    settings: &StitchSettings,
) -> StitchStats {
    let offsets = atlas.page_offsets();
    // Constraint rows, by global texel.
    let mut row_start = vec![0usize];
    let mut entries: Vec<(u32, f32)> = Vec::new();
    let mut row = Vec::with_capacity(32);
    // Each seam point's constraints weigh as 1 / D there (the mean of its two sides'
    // bilinear lookups): the jump that matters is relative to D, and a dark seam under a
    // model would otherwise give way to the pull of its brighter surroundings.
    let level: Vec<f64> = points
        .iter()
        .map(|p| {
            let [a, b] = [0, 1].map(|k| {
                lookup(
                    Filter::Bilinear,
                    atlas,
                    &offsets,
                    texels,
                    p.triangles[k],
                    p.bary[k],
                )
            });
            luminance((a + b) * 0.5)
        })
        .collect();
    let floor = RELATIVE_FLOOR * median(&level);
    if floor <= 0.0 {
        return StitchStats::default();
    }
    for (p, &l) in points.iter().zip(&level) {
        let weight = (1.0 / l.max(floor)) as f32;
        for &f in filters {
            row.clear();
            footprint(
                f,
                atlas,
                &offsets,
                p.triangles[0],
                p.bary[0],
                weight,
                &mut row,
            );
            footprint(
                f,
                atlas,
                &offsets,
                p.triangles[1],
                p.bary[1],
                -weight,
                &mut row,
            );
            row.sort_by_key(|e| e.0);
            let start = entries.len();
            for &(t, w) in &row {
                match entries[start..].last_mut() {
                    Some(last) if last.0 == t => last.1 += w,
                    _ => entries.push((t, w)),
                }
            }
            row_start.push(entries.len());
        }
    }
    let mut unknowns: Vec<u32> = entries.iter().map(|e| e.0).collect();
    unknowns.sort_unstable();
    unknowns.dedup();
    let mut stats = StitchStats {
        unknowns: unknowns.len(),
        constraints: row_start.len() - 1,
        iterations: 0,
    };
    if unknowns.is_empty() {
        return stats;
    }
    let index = |t: u32| unknowns.binary_search(&t).unwrap();
    // The unknowns are relative changes: texel i changes by scale_i·y_i, scale_i its own
    // luminance (floored as the seam points are), so the pulls below are relative too and
    // the rows' weights stay near those of the filters.
    let scale: Vec<f64> = unknowns
        .iter()
        .map(|&t| luminance(texels[t as usize]).max(floor))
        .collect();
    let cols: Vec<(usize, f64)> = entries
        .iter()
        .map(|&(t, w)| {
            let i = index(t);
            (i, w as f64 * scale[i])
        })
        .collect();
    let n = unknowns.len();
    let rows: Vec<&[(usize, f64)]> = row_start.windows(2).map(|w| &cols[w[0]..w[1]]).collect();
    // Per unknown: its 4-neighbours in the same chart that also change, and how many stay.
    let mu2 = settings.smoothness * settings.smoothness;
    let mut neighbours: Vec<(Vec<usize>, f64)> = vec![(Vec::new(), 0.0); n];
    if mu2 > 0.0 {
        for (page, size) in atlas.pages.iter().enumerate() {
            let (start, end) = (offsets[page], offsets[page] + size.width * size.height);
            let lo = unknowns.partition_point(|&t| t < start);
            let hi = unknowns.partition_point(|&t| t < end);
            for (i, &t) in unknowns.iter().enumerate().take(hi).skip(lo) {
                let chart = atlas
                    .texel_chart
                    .get(t as usize)
                    .copied()
                    .unwrap_or(u32::MAX);
                if chart == u32::MAX {
                    continue;
                }
                let (x, y) = ((t - start) % size.width, (t - start) / size.width);
                let around = [
                    (x > 0).then(|| t - 1),
                    (x + 1 < size.width).then(|| t + 1),
                    (y > 0).then(|| t - size.width),
                    (y + 1 < size.height).then(|| t + size.width),
                ];
                for nb in around.into_iter().flatten() {
                    if atlas.texel_chart[nb as usize] == chart {
                        match unknowns.binary_search(&nb) {
                            Ok(j) => neighbours[i].0.push(j),
                            Err(_) => neighbours[i].1 += 1.0,
                        }
                    }
                }
            }
        }
    }
    let x0: Vec<[f64; 3]> = unknowns
        .iter()
        .zip(&scale)
        .map(|(&t, &s)| texels[t as usize].to_array().map(|c| f64::from(c) / s))
        .collect();
    // Unknowns linked by no constraint and no smoothness pull are independent problems:
    // each is solved on its own, stopping when it is as converged as its share of the whole
    // asks, so a small seam does not pay for the iterations of the hardest one.
    let parts = components(n, &rows, &neighbours);
    let stop = stop_threshold(&rows, &x0, settings.tolerance);
    let solved: Vec<(Vec<[f64; 3]>, u32)> = parts
        .members
        .par_iter()
        .zip(&parts.rows)
        .map(|(members, part_rows)| {
            let problem = Problem::part(members, part_rows, &rows, &neighbours, &parts.local);
            let x0: Vec<[f64; 3]> = members.iter().map(|&i| x0[i]).collect();
            let share = (members.len() as f64 / n as f64).sqrt();
            let weights = Weights {
                closeness: settings.closeness,
                smoothness: settings.smoothness,
                max_iterations: settings.max_iterations,
            };
            problem.solve(&x0, weights, stop.map(|s| s * share))
        })
        .collect();
    for (members, (delta, iterations)) in parts.members.iter().zip(solved) {
        stats.iterations = stats.iterations.max(iterations);
        for (&i, d) in members.iter().zip(&delta) {
            let (x, s) = (x0[i], scale[i]);
            texels[unknowns[i] as usize] =
                Vec3::from_array([0, 1, 2].map(|c| (s * (x[c] + d[c])).max(0.0) as f32));
        }
    }
    stats
}

/// The unknowns split into independent problems: those one constraint row reads, and
/// 4-neighbours pulled together by the smoothness term, belong together.
struct Components {
    /// Per component, its unknowns in increasing order; components ordered by their first.
    members: Vec<Vec<usize>>,
    /// Per component, its constraint rows in order.
    rows: Vec<Vec<usize>>,
    /// Per unknown, its index among its component's members.
    local: Vec<usize>,
}

fn components(n: usize, rows: &[&[(usize, f64)]], neighbours: &[(Vec<usize>, f64)]) -> Components {
    // The smaller index is the root: components are found in a fixed order.
    let mut sets = super::disjoint::Sets::new(n);
    for row in rows {
        for w in row.windows(2) {
            sets.join(w[0].0, w[1].0);
        }
    }
    for (i, (nbrs, _)) in neighbours.iter().enumerate() {
        for &j in nbrs {
            sets.join(i, j);
        }
    }
    let mut id = vec![usize::MAX; n];
    let mut members: Vec<Vec<usize>> = Vec::new();
    let mut local = vec![0; n];
    for (i, slot) in local.iter_mut().enumerate() {
        let r = sets.root(i);
        if id[r] == usize::MAX {
            id[r] = members.len();
            members.push(Vec::new());
        }
        *slot = members[id[r]].len();
        members[id[r]].push(i);
    }
    let mut part_rows = vec![Vec::new(); members.len()];
    for (r, row) in rows.iter().enumerate() {
        if let Some(&(i, _)) = row.first() {
            part_rows[id[sets.root(i)]].push(r);
        }
    }
    Components {
        members,
        rows: part_rows,
        local,
    }
}

/// Per channel, the residual at which the whole problem counts as solved: `tolerance` ×
/// |b| (b = −AᵀA·x₀ over every unknown).
fn stop_threshold(rows: &[&[(usize, f64)]], x0: &[[f64; 3]], tolerance: f64) -> [f64; 3] {
    let n = x0.len();
    let ax0 = row_products(rows, x0);
    let mut b = vec![[0.0; 3]; n];
    for (row, a) in rows.iter().zip(&ax0) {
        for &(i, w) in row.iter() {
            for c in 0..3 {
                b[i][c] -= w * a[c];
            }
        }
    }
    dot(&b, &b).map(|s| s.sqrt() * tolerance)
}

/// The seams of a solved atlas measured, stitched and measured again ([`stitch_seams`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct SeamReport {
    /// Seam edges.
    pub edges: usize,
    /// Jump across seams through the bilinear filter, before stitching.
    pub before: Spread,
    /// The same after.
    pub after: Spread,
    /// Jump through the viewer's B-spline, before.
    pub before_bspline: Spread,
    /// The same after.
    pub after_bspline: Spread,
    /// Texel-to-texel variation inside the charts that touch a seam ([`texel_noise`]),
    /// before stitching.
    pub noise: Spread,
    /// The least-squares problem.
    pub stitch: StitchStats,
}

/// Finds the seams of `atlas`, stitches `texels` (per global atlas texel, as the solver
/// returns them) for both filters with the default weights, and reports the jumps before
/// and after.
pub fn stitch_seams(
    triangles: &[Triangle],
    atlas: &Atlas,
    samples: &[TexelSample],
    texels: &mut [Vec3],
) -> SeamReport {
    let start = std::time::Instant::now();
    let seams = find(triangles, atlas);
    let points = seam_points(atlas, &seams);
    let charts = seam_charts(atlas, &points);
    let mut report = SeamReport {
        edges: seams.len(),
        before: measure(atlas, texels, &points, Filter::Bilinear),
        before_bspline: measure(atlas, texels, &points, Filter::BSpline),
        noise: texel_noise(atlas, samples, texels, Some(&charts)),
        ..Default::default()
    };
    // Twice: the second pass weighs each seam point by the level the first one left there
    // (the first weighs it by the mean of two sides that may differ by tens of percent).
    // The second's right-hand side is what the first left, far smaller: its tolerance,
    // relative to it, is looser.
    for k in 0..STITCH_PASSES {
        let defaults = StitchSettings::default();
        let settings = StitchSettings {
            tolerance: defaults.tolerance * if k == 0 { 1.0 } else { 100.0 },
            ..defaults
        };
        let pass = stitch(
            atlas,
            texels,
            &points,
            &[Filter::Bilinear, Filter::BSpline],
            &settings,
        );
        report.stitch = StitchStats {
            iterations: report.stitch.iterations + pass.iterations,
            ..pass
        };
    }
    report.after = measure(atlas, texels, &points, Filter::Bilinear);
    report.after_bspline = measure(atlas, texels, &points, Filter::BSpline);
    log::info!(
        "seams: {} edges, jump in D p95 {:.2}% → {:.3}% (bilinear), {:.2}% → {:.3}% (B-spline); {} texels stitched in {} iterations, {:.2} s",
        report.edges,
        report.before.p95 * 100.0,
        report.after.p95 * 100.0,
        report.before_bspline.p95 * 100.0,
        report.after_bspline.p95 * 100.0,
        report.stitch.unknowns,
        report.stitch.iterations,
        start.elapsed().as_secs_f64()
    );
    report
}

/// The median of the positive values (0 when there are none).
fn median(values: &[f64]) -> f64 {
    let mut sorted: Vec<f64> = values.iter().copied().filter(|&l| l > 0.0).collect();
    sorted.sort_by(f64::total_cmp);
    sorted.get(sorted.len() / 2).copied().unwrap_or(0.0)
}
