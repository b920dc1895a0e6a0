//! The lightmap atlas: every triangle gets lightmap coordinates in one of a few pages of
//! texels, each texel a finite element of the radiosity solution.
//!
//! Charts are groups of edge-adjacent triangles of one object whose normals lie within
//! [`CHART_MAX_ANGLE_DEG`] of the chart's first triangle; each chart is projected to that
//! triangle's plane at its texel density ([`DensityRule`]: texels per metre, raised on small
//! charts so that each gets a minimum number of texels across), framed by [`BORDER`] texels
//! of padding, and packed into pages by a deterministic shelf packer. A glTF `TEXCOORD_1` set is used
//! instead when it is valid (inside [0, 1], no two triangles on one texel).
//!
//! Kept in one file: charting, projection, packing and texel cover share the chart types and
//! one build order; about 400 of its lines are tests.

use std::collections::HashMap;

use glam::{Vec2, Vec3};

use crate::geometry::Triangle;
use crate::sampling::basis;

/// Largest angle between a triangle's normal and its chart's projection normal. Projection
/// shrinks lengths by at most cos 35° = 0.82: every chart's texel density lies within
/// [0.82, 1] × the request along its most foreshortened direction.
pub const CHART_MAX_ANGLE_DEG: f32 = 35.0;

/// Padding around each chart, in texels: bicubic lookups read two texels beyond the last
/// covered one, and the padding is dilated from the chart itself, never from a neighbour.
pub const BORDER: u32 = 2;

/// A texel is covered by a triangle when the triangle's point closest to the texel centre
/// lies inside the texel (L∞ distance below half a texel, less a hair so that an edge lying
/// on a texel boundary does not cover the texel beyond it).
const COVER_HALF_WIDTH: f32 = 0.5 - 1e-4;

/// How far each sample is moved towards its triangle's centroid, in texels: a sample on a
/// chart's side would otherwise sit on the edge it may share with a wall meeting the chart
/// there, and its rays would start on that wall.
const EDGE_INSET: f32 = 0.01;

/// Largest page side.
pub const MAX_PAGE: u32 = 8192;

/// Largest factor by which [`DensityRule::min_across`] may raise a chart's density: a chart
/// smaller than 1/`MAX_CHART_BOOST` of what the minimum asks for stays coarser (thin trims
/// and tiny parts would otherwise cost more texels than the walls around them).
pub const MAX_CHART_BOOST: f32 = 16.0;

/// How many texels each chart gets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DensityRule {
    /// Texels per metre: every chart gets at least this density.
    pub per_metre: f32,
    /// Texels across each chart's longer side, at least (0: per metre only). A small chart's
    /// density is raised to meet it, by at most [`MAX_CHART_BOOST`]×: the density follows the
    /// surfaces' sizes, so a 0.5 m box gets as many texels across a wall as a 5 m room.
    pub min_across: f32,
    /// Texels across a chart per radian its surface turns (0: off): a curved chart whose
    /// normals spread by θ ([`chart_turn`]) gets at least θ × this many texels across, by at
    /// most [`MAX_CHART_BOOST`]× its per-metre density, so that D follows the shading of a
    /// curved mesh (a flat chart gets nothing from it).
    pub per_radian: f32,
}

impl DensityRule {
    /// `per_metre` texels per metre on every chart.
    pub fn uniform(per_metre: f32) -> Self {
        DensityRule {
            per_metre,
            min_across: 0.0,
            per_radian: 0.0,
        }
    }

    /// This rule with every density `s` × as high: the same proportions between charts, a
    /// coarser (s < 1) atlas ([`fit_elements`]).
    pub fn scaled(self, s: f32) -> DensityRule {
        DensityRule {
            per_metre: self.per_metre * s,
            min_across: self.min_across * s,
            per_radian: self.per_radian * s,
        }
    }

    /// The density of a chart whose longer side is `side` metres and whose normals spread
    /// by `turn` radians.
    pub fn chart_density(&self, side: f32, turn: f32) -> f32 {
        let d = self.per_metre;
        // A NaN or non-positive side (a degenerate chart) keeps the per-metre density.
        if side.is_nan() || side <= 0.0 {
            return d;
        }
        let curved = if turn.is_finite() && self.per_radian > 0.0 {
            turn * self.per_radian
        } else {
            0.0
        };
        let across = self.min_across.max(curved);
        if across <= 0.0 {
            return d;
        }
        let boost = (across / (side * d)).clamp(1.0, MAX_CHART_BOOST);
        d * boost
    }
}

/// Size of one atlas page in texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PageSize {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
}

/// A texel's finite-element sample: where on which triangle it lies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexelSample {
    /// Global texel index (pages one after the other, row-major).
    pub texel: u32,
    /// The triangle the sample lies on.
    pub triangle: u32,
    /// Barycentrics of the sample on it.
    pub bary: Vec2,
}

/// The lightmap atlas of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Atlas {
    /// Texels per metre requested.
    pub texel_density: f32,
    /// Pages, in order.
    pub pages: Vec<PageSize>,
    /// Per triangle: its page.
    pub tri_page: Vec<u32>,
    /// Per triangle: its vertices' positions in page texel units (texel (i, j) spans
    /// [i, i+1) × [j, j+1); divide by the page size for [0, 1] texture coordinates).
    pub tri_coords: Vec<[Vec2; 3]>,
    /// Per global texel: its chart (`u32::MAX` outside every chart).
    pub texel_chart: Vec<u32>,
    /// Number of charts (0 when the atlas comes from TEXCOORD_1: one chart per page).
    pub charts: u32,
    /// Whether the glTF's TEXCOORD_1 was used.
    pub from_uv1: bool,
    /// The scene triangles whose back sides have texels of their own ([`super::back_sides`]),
    /// ascending. The back of `backs[k]` is atlas triangle `S + k`, `S` the scene's
    /// triangle count: `tri_page` and `tri_coords` hold the scene's triangles, then these.
    pub backs: Vec<u32>,
}

impl Atlas {
    /// First global texel index of each page.
    pub fn page_offsets(&self) -> Vec<u32> {
        let mut off = 0;
        self.pages
            .iter()
            .map(|p| {
                let o = off;
                off += p.width * p.height;
                o
            })
            .collect()
    }

    /// Total texels over all pages.
    pub fn texel_count(&self) -> usize {
        self.pages
            .iter()
            .map(|p| (p.width * p.height) as usize)
            .sum()
    }

    /// The world distance between texel centres on `triangle` (`tri`, its geometry): the
    /// square root of its area in metres² per texel²; infinite where it covers no texels.
    pub fn texel_spacing(&self, triangle: u32, tri: &Triangle) -> f32 {
        let c = self.tri_coords[triangle as usize];
        let texels = 0.5 * (c[1] - c[0]).perp_dot(c[2] - c[0]).abs();
        if texels > 0.0 {
            (tri.area() / texels).sqrt()
        } else {
            f32::INFINITY
        }
    }

    /// The scene's triangle count: the atlas's triangles without the back sides.
    pub fn scene_triangles(&self) -> usize {
        self.tri_page.len().saturating_sub(self.backs.len())
    }

    /// The atlas triangle holding the back side of scene triangle `triangle`, if it has one.
    pub fn back_of(&self, triangle: u32) -> Option<u32> {
        super::sides::back_in(&self.backs, self.scene_triangles(), triangle)
    }

    /// Where to read D for point `bary` of scene triangle `triangle`, seen from its front or
    /// (`back`) from behind: the triangle itself, or its back side's twin (whose
    /// barycentrics are swapped, [`super::sides::twin`]).
    pub fn side(&self, triangle: u32, bary: Vec2, back: bool) -> (u32, Vec2) {
        let scene = self.scene_triangles();
        super::sides::side_in(&self.backs, scene, (triangle, bary), back)
    }

    /// What a stage reading D after the solve needs to know of the back sides.
    pub fn sides(&self) -> super::sides::Sides {
        super::sides::Sides {
            scene_triangles: self.scene_triangles(),
            backs: self.backs.clone(),
        }
    }

    /// Global index of the texel holding barycentric point `bary` of `triangle`.
    pub fn texel_at(&self, offsets: &[u32], triangle: u32, bary: Vec2) -> u32 {
        let page = self.tri_page[triangle as usize] as usize;
        let c = &self.tri_coords[triangle as usize];
        let p = c[0] * (1.0 - bary.x - bary.y) + c[1] * bary.x + c[2] * bary.y;
        let size = self.pages[page];
        let x = (floor(p.x) as i64).clamp(0, size.width as i64 - 1) as u32;
        let y = (floor(p.y) as i64).clamp(0, size.height as i64 - 1) as u32;
        offsets[page] + y * size.width + x
    }
}

/// `x.floor()`, bit for bit (−0 included; a NaN stays a NaN), without the library call that `floor`
/// is on x86-64 without SSE4.1: every read of D (gathering rays' texels, the bilinear reads of
/// records) takes two.
#[inline]
pub fn floor(x: f32) -> f32 {
    // From 2²³ on every f32 is a whole number (the infinities too).
    if x.is_nan() || x.abs() >= 8_388_608.0 {
        return x;
    }
    let t = x as i32 as f32;
    if t > x { t - 1.0 } else { t.copysign(x) }
}

/// Why an atlas cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AtlasError {
    /// A chart is wider than the largest page.
    #[error(
        "a chart of {w}×{h} texels does not fit in a {MAX_PAGE}² page at {density} texels/m; lower the texel density"
    )]
    ChartTooLarge {
        /// Chart width.
        w: u32,
        /// Chart height.
        h: u32,
        /// Requested density.
        density: f32,
    },
    /// The density is not a positive finite number.
    #[error("texel density {0} is not a finite number > 0")]
    BadDensity(f32),
}

/// Estimated texels of the atlas for `triangles` under `rule`, before building it: charted
/// area plus the padding of one chart per triangle group (an upper bound for memory checks);
/// with a minimum per chart, each chart's own rectangle at its raised density.
pub fn estimate_texels(triangles: &[Triangle], rule: DensityRule) -> f64 {
    ChartShapes::new(triangles, rule).texels(rule)
}

/// What the estimates read of a scene's charts: their area and count, and, where a rule
/// raises densities per chart, each chart's extent and turn (made once, read at any rule).
#[derive(Debug)]
pub struct ChartShapes {
    area: f64,
    triangles: usize,
    /// (extent in metres, turn in radians) per chart; `None` when only the area is needed.
    charts: Option<Vec<(Vec2, f32)>>,
}

impl ChartShapes {
    /// The shapes `rule`'s estimates need: the charts only when it raises densities per chart
    /// (they cost a chart-making pass, cheap beside the solve).
    pub fn new(triangles: &[Triangle], rule: DensityRule) -> Self {
        Self::make(triangles, rule.min_across > 0.0 || rule.per_radian > 0.0)
    }

    /// The shapes with every chart's extent and turn, whatever the rule.
    pub fn with_charts(triangles: &[Triangle]) -> Self {
        Self::make(triangles, true)
    }

    fn make(triangles: &[Triangle], charts: bool) -> Self {
        let charts = charts.then(|| {
            let vid = weld(triangles);
            make_charts(triangles, &vid)
                .iter()
                .map(|c| {
                    let extent = chart_extent(&chart_plane_coords(triangles, &vid, c));
                    (extent, chart_turn(triangles, c))
                })
                .collect()
        });
        ChartShapes {
            area: triangles.iter().map(|t| t.area() as f64).sum(),
            triangles: triangles.len(),
            charts,
        }
    }

    /// Estimated atlas texels under `rule` ([`estimate_texels`]).
    pub fn texels(&self, rule: DensityRule) -> f64 {
        let raised = rule.min_across > 0.0 || rule.per_radian > 0.0;
        match &self.charts {
            Some(charts) if raised => charts
                .iter()
                .map(|&(extent, turn)| {
                    let dc = rule.chart_density(extent.max_element(), turn) as f64;
                    let side = |e: f32| (e as f64 * dc).ceil().max(1.0) + (1 + 2 * BORDER) as f64;
                    side(extent.x) * side(extent.y)
                })
                .sum(),
            _ => {
                let d = rule.per_metre as f64;
                // Every chart adds its border; assume one chart per 64 triangles (curved meshes).
                let charts = (self.triangles as f64 / 64.0).max(1.0);
                self.area * d * d * 1.25 + charts * ((2 * BORDER + 3) as f64).powi(2)
            }
        }
    }

    /// Estimated elements (texels with a sample) under `rule`: each chart's grid of texel
    /// centres, its padding left out (an upper bound: a chart's rectangle is never less than
    /// what its triangles cover). Needs the charts ([`Self::with_charts`]).
    pub fn elements(&self, rule: DensityRule) -> f64 {
        let charts = self
            .charts
            .as_ref()
            .expect("ChartShapes::elements needs the charts (ChartShapes::with_charts)");
        charts
            .iter()
            .map(|&(extent, turn)| {
                let dc = rule.chart_density(extent.max_element(), turn) as f64;
                let side = |e: f32| (e as f64 * dc).ceil().max(1.0) + 1.0;
                side(extent.x) * side(extent.y)
            })
            .sum()
    }
}

/// Smallest scale [`fit_elements`] goes down to: there every chart is a texel or two across,
/// whatever density was asked (2⁻³⁰).
pub const MIN_FIT_SCALE: f32 = 1.0 / (1u32 << 30) as f32;

/// The largest scale s ≤ 1 at which `rule.scaled(s)` gives at most `max` elements, `factor` ×
/// [`ChartShapes::elements`] (the contact boosts' most), or `None` when not even
/// [`MIN_FIT_SCALE`] does (the charts alone need more). Deterministic: a fixed bisection of
/// log₂ s.
pub fn fit_elements(shapes: &ChartShapes, rule: DensityRule, factor: f64, max: f64) -> Option<f32> {
    let fits = |s: f32| shapes.elements(rule.scaled(s)) * factor <= max;
    if fits(1.0) {
        return Some(1.0);
    }
    if !fits(MIN_FIT_SCALE) {
        return None;
    }
    let (mut lo, mut hi) = (MIN_FIT_SCALE.log2(), 0.0f32);
    for _ in 0..32 {
        let mid = 0.5 * (lo + hi);
        if fits(mid.exp2()) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(lo.exp2())
}

/// Builds the atlas and the texel samples for `triangles` at `density` texels per metre.
pub fn build(
    triangles: &[Triangle],
    density: f32,
) -> Result<(Atlas, Vec<TexelSample>), AtlasError> {
    build_with(triangles, DensityRule::uniform(density))
}

/// Builds the atlas and the texel samples for `triangles`, each chart at the density `rule`
/// gives it (a TEXCOORD_1 atlas is used at the rule's per-metre density).
pub fn build_with(
    triangles: &[Triangle],
    rule: DensityRule,
) -> Result<(Atlas, Vec<TexelSample>), AtlasError> {
    build_boosted(triangles, rule, &[])
}

/// [`build_with`], chart `c` (in [`charts`] order) at `boost[c]` × the density the rule gives
/// it (1 for charts past the end of `boost`): an empty `boost` builds what [`build_with`] builds.
pub fn build_boosted(
    triangles: &[Triangle],
    rule: DensityRule,
    boost: &[f32],
) -> Result<(Atlas, Vec<TexelSample>), AtlasError> {
    let density = rule.per_metre;
    if !(density.is_finite() && density > 0.0) {
        return Err(AtlasError::BadDensity(density));
    }
    if let Some(result) = from_uv1(triangles, density) {
        return Ok(result);
    }
    let vid = weld(triangles);
    let charts = make_charts(triangles, &vid);
    // Project each chart to its plane, in texels.
    let mut projected: Vec<ProjectedChart> = charts
        .iter()
        .enumerate()
        .map(|(i, c)| project(triangles, &vid, c, rule, boost.get(i).copied()))
        .collect();
    for p in &projected {
        if p.w > MAX_PAGE || p.h > MAX_PAGE {
            return Err(AtlasError::ChartTooLarge {
                w: p.w,
                h: p.h,
                density,
            });
        }
    }
    let pages = pack(&mut projected);

    let mut atlas = Atlas {
        texel_density: density,
        pages,
        tri_page: vec![0; triangles.len()],
        tri_coords: vec![[Vec2::ZERO; 3]; triangles.len()],
        texel_chart: Vec::new(),
        charts: charts.len() as u32,
        from_uv1: false,
        backs: Vec::new(),
    };
    atlas.texel_chart = vec![u32::MAX; atlas.texel_count()];
    let offsets = atlas.page_offsets();
    let mut samples = Vec::new();
    for (ci, (chart, p)) in charts.iter().zip(&projected).enumerate() {
        let size = atlas.pages[p.page as usize];
        let origin = Vec2::new(p.x as f32, p.y as f32);
        for (k, &t) in chart.iter().enumerate() {
            atlas.tri_page[t as usize] = p.page;
            atlas.tri_coords[t as usize] = p.coords[k].map(|c| c + origin);
        }
        for y in 0..p.h {
            for x in 0..p.w {
                atlas.texel_chart
                    [(offsets[p.page as usize] + (p.y + y) * size.width + p.x + x) as usize] =
                    ci as u32;
            }
        }
        cover(&atlas, &offsets, chart, &mut samples);
    }
    samples.sort_by_key(|s| s.texel);
    Ok((atlas, samples))
}

/// Per triangle, an id for each vertex, equal for vertices at exactly the same position
/// (glTF splits vertices at UV and normal seams; their positions stay equal). Ids are
/// numbered in order of first appearance, so they do not depend on hashing.
pub fn weld(triangles: &[Triangle]) -> Vec<[u32; 3]> {
    let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
    triangles
        .iter()
        .map(|t| {
            t.p.map(|p| {
                let key = p.to_array().map(f32::to_bits);
                let n = ids.len() as u32;
                *ids.entry(key).or_insert(n)
            })
        })
        .collect()
}

/// The charts [`build_with`] makes of `triangles` (each a list of triangle indices), in the
/// order of the atlas's chart ids, with the welded vertex ids of [`weld`].
pub fn charts(triangles: &[Triangle]) -> (Vec<Vec<u32>>, Vec<[u32; 3]>) {
    let vid = weld(triangles);
    (make_charts(triangles, &vid), vid)
}

/// Groups triangles into charts (lists of triangle indices, in index order of their seeds).
fn make_charts(triangles: &[Triangle], vid: &[[u32; 3]]) -> Vec<Vec<u32>> {
    let mut edges: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (t, v) in vid.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            edges
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push(t as u32);
        }
    }
    let cos_max = CHART_MAX_ANGLE_DEG.to_radians().cos();
    let normals: Vec<Vec3> = triangles.iter().map(|t| t.face_normal()).collect();
    let mut chart_of = vec![u32::MAX; triangles.len()];
    let mut charts = Vec::new();
    for seed in 0..triangles.len() {
        if chart_of[seed] != u32::MAX {
            continue;
        }
        let id = charts.len() as u32;
        let n = normals[seed];
        let mut members = vec![seed as u32];
        chart_of[seed] = id;
        let mut head = 0;
        while head < members.len() {
            let t = members[head] as usize;
            head += 1;
            for k in 0..3 {
                let (a, b) = (vid[t][k], vid[t][(k + 1) % 3]);
                for &u in &edges[&(a.min(b), a.max(b))] {
                    let u = u as usize;
                    if chart_of[u] == u32::MAX
                        && triangles[u].object == triangles[seed].object
                        && normals[u].dot(n) >= cos_max
                    {
                        chart_of[u] = id;
                        members.push(u as u32);
                    }
                }
            }
        }
        members.sort_unstable();
        charts.push(members);
    }
    charts
}

struct ProjectedChart {
    /// Per member triangle, vertex coordinates in chart-local texels (border included).
    coords: Vec<[Vec2; 3]>,
    w: u32,
    h: u32,
    page: u32,
    x: u32,
    y: u32,
}

/// How far a chart's surface turns, in radians: the angular diameter of its face normals,
/// estimated in two sweeps (the normal farthest from the first triangle's, then the largest
/// angle from that one; exact for normals along one arc, within 2× otherwise). 0 for a flat
/// chart.
pub fn chart_turn(triangles: &[Triangle], chart: &[u32]) -> f32 {
    let normal = |t: &u32| triangles[*t as usize].face_normal();
    let Some(first) = chart.first().map(normal) else {
        return 0.0;
    };
    let farthest = |from: Vec3| {
        chart
            .iter()
            .map(normal)
            .filter(|n| n.is_finite())
            .min_by(|a, b| a.dot(from).total_cmp(&b.dot(from)))
            .unwrap_or(from)
    };
    let a = farthest(first);
    let b = farthest(a);
    a.dot(b).clamp(-1.0, 1.0).acos()
}

/// The axes of a chart's projection plane (the first triangle's): along the chart's longest
/// boundary edge (one no other triangle of the chart shares), so that a rectangle's sides lie
/// along the texel grid, whatever its orientation in the scene.
fn chart_axes(triangles: &[Triangle], vid: &[[u32; 3]], chart: &[u32]) -> (Vec3, Vec3) {
    let n = triangles[chart[0] as usize].face_normal();
    let edge = |t: usize, k: usize| {
        let (a, b) = (vid[t][k], vid[t][(k + 1) % 3]);
        (a.min(b), a.max(b))
    };
    let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
    for &i in chart {
        for k in 0..3 {
            *uses.entry(edge(i as usize, k)).or_default() += 1;
        }
    }
    // In chart order, the first of the longest: deterministic.
    let mut longest = (0.0f32, Vec3::ZERO);
    for &i in chart {
        let t = &triangles[i as usize];
        for k in 0..3 {
            if uses[&edge(i as usize, k)] == 1 {
                let d = t.p[(k + 1) % 3] - t.p[k];
                let d = d - n * n.dot(d);
                if d.length() > longest.0 {
                    longest = (d.length(), d / d.length());
                }
            }
        }
    }
    if longest.0 > 0.0 && longest.1.is_finite() && n.is_finite() {
        (longest.1, n.cross(longest.1))
    } else {
        basis(n)
    }
}

/// A chart's vertices in metres on its projection plane (see [`chart_axes`]).
fn chart_plane_coords(triangles: &[Triangle], vid: &[[u32; 3]], chart: &[u32]) -> Vec<[Vec2; 3]> {
    let (t, b) = chart_axes(triangles, vid, chart);
    chart
        .iter()
        .map(|&i| {
            triangles[i as usize]
                .p
                .map(|p| Vec2::new(p.dot(t), p.dot(b)))
        })
        .collect()
}

/// The bounding rectangle (min, max) of chart coordinates.
fn bounds(coords: &[[Vec2; 3]]) -> (Vec2, Vec2) {
    let min = coords
        .iter()
        .flatten()
        .fold(Vec2::INFINITY, |m, p| m.min(*p));
    let max = coords
        .iter()
        .flatten()
        .fold(Vec2::NEG_INFINITY, |m, p| m.max(*p));
    (min, max)
}

/// Width and height in metres of a chart's bounding rectangle on its projection plane.
fn chart_extent(coords: &[[Vec2; 3]]) -> Vec2 {
    let (min, max) = bounds(coords);
    (max - min).max(Vec2::ZERO)
}

/// Projects a chart at the density `rule` gives it (from its size on its plane), times
/// `boost` when given.
///
/// The chart's bounding rectangle runs from the centre of its first texel to the centre of its
/// last, in both directions (each direction's density raised a little, to a whole number of
/// texel intervals across): texels on the chart's sides sample the sides themselves. D then
/// interpolates between the edge and the texel inside it, where otherwise it would hold the
/// value half a texel in out to the edge, and D changes fastest at concave edges.
fn project(
    triangles: &[Triangle],
    vid: &[[u32; 3]],
    chart: &[u32],
    rule: DensityRule,
    boost: Option<f32>,
) -> ProjectedChart {
    let metres = chart_plane_coords(triangles, vid, chart);
    let (min, max) = bounds(&metres);
    let ext = (max - min).max(Vec2::ZERO);
    let mut density = rule.chart_density(ext.max_element(), chart_turn(triangles, chart));
    if let Some(b) = boost {
        density *= b;
    }
    let intervals = (ext * density).ceil().max(Vec2::ONE);
    let scale = Vec2::select(ext.cmpgt(Vec2::ZERO), intervals / ext, Vec2::splat(density));
    let shift = Vec2::splat(BORDER as f32 + 0.5);
    ProjectedChart {
        coords: metres
            .iter()
            .map(|c| c.map(|p| (p - min) * scale + shift))
            .collect(),
        w: intervals.x as u32 + 1 + 2 * BORDER,
        h: intervals.y as u32 + 1 + 2 * BORDER,
        page: 0,
        x: 0,
        y: 0,
    }
}

/// Shelf packing, tallest charts first; deterministic (ties broken by chart index).
fn pack(charts: &mut [ProjectedChart]) -> Vec<PageSize> {
    let total: f64 = charts.iter().map(|c| (c.w * c.h) as f64).sum();
    let widest = charts.iter().map(|c| c.w).max().unwrap_or(1);
    let width = ((total * 1.15).sqrt().ceil() as u32)
        .next_power_of_two()
        .clamp(64, 4096)
        .max(widest);
    let mut order: Vec<usize> = (0..charts.len()).collect();
    order.sort_by(|&a, &b| {
        charts[b]
            .h
            .cmp(&charts[a].h)
            .then(charts[b].w.cmp(&charts[a].w))
            .then(a.cmp(&b))
    });
    let mut pages = Vec::new();
    let (mut page, mut x, mut y, mut shelf) = (0u32, 0u32, 0u32, 0u32);
    for i in order {
        let c = &mut charts[i];
        if x + c.w > width {
            x = 0;
            y += shelf;
            shelf = 0;
        }
        if y + c.h > MAX_PAGE.min(width.max(4096)) {
            pages.push(PageSize { width, height: y });
            page += 1;
            x = 0;
            y = 0;
            shelf = 0;
        }
        c.page = page;
        c.x = x;
        c.y = y;
        x += c.w;
        shelf = shelf.max(c.h);
    }
    pages.push(PageSize {
        width,
        height: (y + shelf).max(1),
    });
    pages
}

/// Adds a sample for every texel of the chart that one of its triangles covers: the point
/// of the nearest triangle closest to the texel centre (the centre itself when inside).
fn cover(atlas: &Atlas, offsets: &[u32], chart: &[u32], out: &mut Vec<TexelSample>) {
    let page = atlas.tri_page[chart[0] as usize] as usize;
    let size = atlas.pages[page];
    let mut best: HashMap<u32, (f32, u32, Vec2)> = HashMap::new();
    for &t in chart {
        let c = atlas.tri_coords[t as usize];
        let lo = c.iter().fold(Vec2::INFINITY, |m, p| m.min(*p)) - Vec2::ONE;
        let hi = c.iter().fold(Vec2::NEG_INFINITY, |m, p| m.max(*p)) + Vec2::ONE;
        let (x0, y0) = (lo.x.floor().max(0.0) as u32, lo.y.floor().max(0.0) as u32);
        let (x1, y1) = (
            (hi.x.ceil() as u32).min(size.width),
            (hi.y.ceil() as u32).min(size.height),
        );
        for y in y0..y1 {
            for x in x0..x1 {
                let centre = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                let (d, bary) = closest_point(c, centre);
                let q = c[0] * (1.0 - bary.x - bary.y) + c[1] * bary.x + c[2] * bary.y;
                if (q - centre).abs().max_element() >= COVER_HALF_WIDTH {
                    continue;
                }
                let centroid = (c[0] + c[1] + c[2]) / 3.0;
                let inset = (EDGE_INSET / q.distance(centroid)).min(1.0);
                let bary = bary * (1.0 - inset) + Vec2::splat(inset / 3.0);
                let texel = offsets[page] + y * size.width + x;
                let e = best
                    .entry(texel)
                    .or_insert((f32::INFINITY, u32::MAX, Vec2::ZERO));
                if d < e.0 {
                    *e = (d, t, bary);
                }
            }
        }
    }
    out.extend(
        best.into_iter()
            .map(|(texel, (_, triangle, bary))| TexelSample {
                texel,
                triangle,
                bary,
            }),
    );
}

/// Distance from `p` to the 2D triangle `c` (0 inside) and the barycentrics (u, v) of the
/// closest point, with p = (1 − u − v)·c0 + u·c1 + v·c2.
pub fn closest_point(c: [Vec2; 3], p: Vec2) -> (f32, Vec2) {
    let (a, b, cc) = (c[0], c[1], c[2]);
    let (e1, e2) = (b - a, cc - a);
    let det = e1.perp_dot(e2);
    if det.abs() > 1e-12 {
        let d = p - a;
        let u = d.perp_dot(e2) / det;
        let v = e1.perp_dot(d) / det;
        if u >= 0.0 && v >= 0.0 && u + v <= 1.0 {
            return (0.0, Vec2::new(u, v));
        }
    }
    // Outside (or degenerate in 2D): nearest point on the three edges.
    let seg = |s: Vec2, e: Vec2| {
        let d = e - s;
        let t = if d.length_squared() > 0.0 {
            ((p - s).dot(d) / d.length_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (p.distance(s + d * t), t)
    };
    let (d0, t0) = seg(a, b);
    let (d1, t1) = seg(b, cc);
    let (d2, t2) = seg(cc, a);
    if d0 <= d1 && d0 <= d2 {
        (d0, Vec2::new(t0, 0.0))
    } else if d1 <= d2 {
        (d1, Vec2::new(1.0 - t1, t1))
    } else {
        (d2, Vec2::new(0.0, 1.0 - t2))
    }
}

/// Uses TEXCOORD_1 when every triangle has it inside [0, 1] and no texel centre of a
/// square page sized for `density` is covered by two triangles; `None` otherwise (logged).
fn from_uv1(triangles: &[Triangle], density: f32) -> Option<(Atlas, Vec<TexelSample>)> {
    let uv1: Vec<[Vec2; 3]> = triangles.iter().map(|t| t.uv1).collect::<Option<_>>()?;
    if uv1
        .iter()
        .flatten()
        .any(|p| !(p.is_finite() && p.cmpge(Vec2::ZERO).all() && p.cmple(Vec2::ONE).all()))
    {
        log::warn!("TEXCOORD_1 leaves [0, 1]: generating a lightmap atlas instead");
        return None;
    }
    let area: f64 = triangles.iter().map(|t| t.area() as f64).sum();
    let side = ((area.sqrt() * density as f64).ceil() as u32)
        .next_power_of_two()
        .clamp(16, MAX_PAGE);
    let atlas = Atlas {
        texel_density: density,
        pages: vec![PageSize {
            width: side,
            height: side,
        }],
        tri_page: vec![0; triangles.len()],
        tri_coords: uv1.iter().map(|c| c.map(|p| p * side as f32)).collect(),
        texel_chart: vec![0; (side * side) as usize],
        charts: 0,
        from_uv1: true,
        backs: Vec::new(),
    };
    let offsets = [0];
    // Texels whose centre lies inside a triangle: two different triangles on one is overlap.
    let mut owner: HashMap<u32, u32> = HashMap::new();
    for t in 0..triangles.len() as u32 {
        let c = atlas.tri_coords[t as usize];
        let lo = c.iter().fold(Vec2::INFINITY, |m, p| m.min(*p));
        let hi = c.iter().fold(Vec2::NEG_INFINITY, |m, p| m.max(*p));
        for y in lo.y.floor().max(0.0) as u32..(hi.y.ceil() as u32).min(side) {
            for x in lo.x.floor().max(0.0) as u32..(hi.x.ceil() as u32).min(side) {
                // Strictly inside: triangles sharing an edge through a texel centre don't overlap.
                let (d, b) = closest_point(c, Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                if d == 0.0
                    && b.min_element().min(1.0 - b.x - b.y) > 1e-4
                    && let Some(prev) = owner.insert(y * side + x, t)
                    && prev != t
                {
                    log::warn!(
                        "TEXCOORD_1 overlaps (triangles {prev} and {t} share a texel): generating a lightmap atlas instead"
                    );
                    return None;
                }
            }
        }
    }
    let mut samples = Vec::new();
    let all: Vec<u32> = (0..triangles.len() as u32).collect();
    cover(&atlas, &offsets, &all, &mut samples);
    samples.sort_by_key(|s| s.texel);
    Some((atlas, samples))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_is_the_library_floor_bit_for_bit() {
        let mut xs = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            -1.0,
            1.0,
            -1.5,
            2.999_999_8,
            -2.999_999_8,
            8_388_607.5,
            -8_388_607.5,
            8_388_608.0,
            -8_388_609.0,
            1e30,
            -1e30,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::from_bits(1),
            -f32::from_bits(1),
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        // Every 65,537th bit pattern: all signs, exponents and most fractions.
        xs.extend((0..=u32::MAX).step_by(65_537).map(f32::from_bits));
        for x in xs {
            if x.is_nan() {
                assert!(floor(x).is_nan());
            } else {
                assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "floor({x:e})");
            }
        }
    }

    fn tri(p: [Vec3; 3], object: u32) -> Triangle {
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        Triangle {
            p,
            n: [n; 3],
            uv: [Vec2::ZERO; 3],
            uv1: None,
            material: 0,
            object,
        }
    }

    /// A unit cube's 12 outward triangles, as object `object`, at `offset`.
    fn cube(offset: Vec3, size: f32, object: u32) -> Vec<Triangle> {
        let c = |x: f32, y: f32, z: f32| offset + Vec3::new(x, y, z) * size;
        let faces = [
            [c(0., 0., 0.), c(0., 1., 0.), c(1., 1., 0.), c(1., 0., 0.)],
            [c(0., 0., 1.), c(1., 0., 1.), c(1., 1., 1.), c(0., 1., 1.)],
            [c(0., 0., 0.), c(1., 0., 0.), c(1., 0., 1.), c(0., 0., 1.)],
            [c(0., 1., 0.), c(0., 1., 1.), c(1., 1., 1.), c(1., 1., 0.)],
            [c(0., 0., 0.), c(0., 0., 1.), c(0., 1., 1.), c(0., 1., 0.)],
            [c(1., 0., 0.), c(1., 1., 0.), c(1., 1., 1.), c(1., 0., 1.)],
        ];
        faces
            .iter()
            .flat_map(|q| {
                [
                    tri([q[0], q[1], q[2]], object),
                    tri([q[0], q[2], q[3]], object),
                ]
            })
            .collect()
    }

    #[test]
    fn cube_faces_become_six_charts_and_no_texel_is_shared() {
        let mut tris = cube(Vec3::ZERO, 1.0, 0);
        tris.extend(cube(Vec3::new(3.0, 0.0, 0.0), 0.5, 1));
        let (atlas, samples) = build(&tris, 16.0).unwrap();
        assert_eq!(atlas.charts, 12);
        // Distinct texels: every sample owns its texel, and each texel lies in its triangle's chart.
        let mut seen = std::collections::HashSet::new();
        let offsets = atlas.page_offsets();
        for s in &samples {
            assert!(seen.insert(s.texel), "texel {} sampled twice", s.texel);
            let chart = atlas.texel_chart[s.texel as usize];
            let centre_texel = atlas.texel_at(&offsets, s.triangle, s.bary);
            assert_eq!(atlas.texel_chart[centre_texel as usize], chart);
        }
        // No two charts' rectangles share a texel: count texels per chart.
        let mut per_chart = vec![0usize; atlas.charts as usize];
        for &c in &atlas.texel_chart {
            if c != u32::MAX {
                per_chart[c as usize] += 1;
            }
        }
        // A 1 m face at 16 texels/m: 16 texel intervals from side to side, so 17 texels and a
        // 2-texel border on each side: 21²; a 0.5 m face: (9 + 4)².
        assert_eq!(
            per_chart.iter().filter(|&&n| n == 441).count(),
            6,
            "{per_chart:?}"
        );
        assert_eq!(
            per_chart.iter().filter(|&&n| n == 169).count(),
            6,
            "{per_chart:?}"
        );
        // Covered texels of a 1 m face: its 17×17 texels, whose centres run from side to side.
        assert_eq!(samples.iter().filter(|s| s.triangle < 12).count(), 6 * 289);
        // The outermost texels sample the face's sides themselves (moved in by a hair).
        for s in samples.iter().filter(|s| s.triangle < 12) {
            let p = tris[s.triangle as usize].point(s.bary);
            let q = (p - Vec3::splat(0.5)).abs();
            assert!(q.max_element() <= 0.5 + 1e-6, "{p}");
        }
        let on_a_side = |a: f32| (a.abs() - 0.5).abs() < 0.01 / 16.0 * 2.0;
        let sides = samples
            .iter()
            .filter(|s| s.triangle < 12)
            .filter(|s| {
                let p = tris[s.triangle as usize].point(s.bary) - Vec3::splat(0.5);
                // Off the face's own plane, on one of the other two axes' sides.
                p.to_array().iter().filter(|&&a| on_a_side(a)).count() >= 2
            })
            .count();
        // 4 sides of 17 texels per face, corners shared: 64 per face.
        assert_eq!(sides, 6 * 64);
    }

    #[test]
    fn chart_density_is_within_tolerance_of_the_request() {
        // A faceted cylinder: neighbouring facets 15° apart, so charts span several facets.
        let mut tris = Vec::new();
        let n = 24;
        for i in 0..n {
            let a0 = i as f32 / n as f32 * std::f32::consts::TAU;
            let a1 = (i + 1) as f32 / n as f32 * std::f32::consts::TAU;
            let p = |a: f32, y: f32| Vec3::new(a.cos(), y, -a.sin());
            tris.push(tri([p(a0, 0.0), p(a1, 0.0), p(a1, 2.0)], 0));
            tris.push(tri([p(a0, 0.0), p(a1, 2.0), p(a0, 2.0)], 0));
        }
        for density in [4.0, 32.0] {
            let (atlas, _) = build(&tris, density).unwrap();
            assert!(atlas.charts > 1 && atlas.charts < 24, "{}", atlas.charts);
            // Each direction's density is raised to a whole number of texel intervals across
            // the chart: by at most 1 + 1/(side × density), the narrowest chart being one
            // facet (2 sin 7.5° m) wide and every chart 2 m tall.
            let facet = 2.0 * 7.5f32.to_radians().sin();
            let max = (1.0 + 1.0 / (facet * density)) * (1.0 + 1.0 / (2.0 * density));
            // Per triangle: projected area (texels²) against true area × density².
            for (t, c) in tris.iter().zip(&atlas.tri_coords) {
                let projected = 0.5 * (c[1] - c[0]).perp_dot(c[2] - c[0]).abs();
                let ratio = projected / (t.area() * density * density);
                let min = CHART_MAX_ANGLE_DEG.to_radians().cos();
                assert!(
                    ratio >= min - 1e-3 && ratio <= max + 1e-3,
                    "density ratio {ratio}, at most {max}"
                );
            }
        }
    }

    #[test]
    fn tiny_triangle_still_gets_a_texel() {
        let tris = vec![tri(
            [
                Vec3::ZERO,
                Vec3::new(1e-4, 0.0, 0.0),
                Vec3::new(0.0, 1e-4, 0.0),
            ],
            0,
        )];
        let (atlas, samples) = build(&tris, 16.0).unwrap();
        // One texel interval each way: the texels at its three corners cover it (and the
        // fourth, half a texel from its long side, when rounding puts it within reach).
        assert!((3..=4).contains(&samples.len()), "{}", samples.len());
        assert_eq!(
            atlas.texel_chart.iter().filter(|&&c| c == 0).count(),
            36,
            "2 texels + a 2-texel border"
        );
    }

    #[test]
    fn valid_uv1_is_used_and_overlapping_uv1_is_not() {
        let mut tris = vec![
            tri([Vec3::ZERO, Vec3::X, Vec3::Y], 0),
            tri([Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y], 0),
        ];
        tris[0].uv1 = Some([
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(0.0, 1.0),
        ]);
        tris[1].uv1 = Some([
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ]);
        let (atlas, _) = build(&tris, 16.0).unwrap();
        assert!(atlas.from_uv1);
        tris[1].uv1 = Some([
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(0.0, 1.0),
        ]);
        let (atlas, _) = build(&tris, 16.0).unwrap();
        assert!(!atlas.from_uv1, "overlapping UV1 must be replaced");
        tris[1].uv1 = Some([
            Vec2::new(1.0, 0.0),
            Vec2::new(1.5, 1.0),
            Vec2::new(0.0, 1.0),
        ]);
        let (atlas, _) = build(&tris, 16.0).unwrap();
        assert!(!atlas.from_uv1, "UV1 outside [0, 1] must be replaced");
    }

    #[test]
    fn closest_point_inside_on_edge_and_corner() {
        let c = [Vec2::ZERO, Vec2::new(2.0, 0.0), Vec2::new(0.0, 2.0)];
        assert_eq!(
            closest_point(c, Vec2::new(0.5, 0.5)),
            (0.0, Vec2::new(0.25, 0.25))
        );
        let (d, b) = closest_point(c, Vec2::new(1.0, -1.0));
        assert!((d - 1.0).abs() < 1e-6 && (b - Vec2::new(0.5, 0.0)).length() < 1e-6);
        let (d, b) = closest_point(c, Vec2::new(-1.0, -1.0));
        assert!((d - 2f32.sqrt()).abs() < 1e-6 && b == Vec2::ZERO);
    }

    #[test]
    fn small_charts_get_the_minimum_texels_across_and_large_ones_keep_their_density() {
        // A 0.5 m cube beside a 5 m one, at 4 texels per metre: the small cube's faces would
        // be 2 texels across, the large one's 20.
        let mut tris = cube(Vec3::ZERO, 0.5, 0);
        tris.extend(cube(Vec3::splat(10.0), 5.0, 1));
        let rule = DensityRule {
            per_metre: 4.0,
            min_across: 12.0,
            per_radian: 0.0,
        };
        let (atlas, samples) = build_with(&tris, rule).unwrap();
        // Texels covered per face (2 triangles each).
        let across = |face: usize| {
            let mut texels: Vec<u32> = samples
                .iter()
                .filter(|s| s.triangle as usize / 2 == face)
                .map(|s| s.texel)
                .collect();
            texels.sort_unstable();
            texels.dedup();
            (texels.len() as f32).sqrt()
        };
        for face in 0..6 {
            let small = across(face);
            assert!((12.0..=14.0).contains(&small), "small face {face}: {small}");
            let large = across(face + 6);
            assert!((20.0..=22.0).contains(&large), "large face {face}: {large}");
        }
        // The boost is bounded: a 1 mm chart gets 16× the density, not 12 texels.
        assert_eq!(rule.chart_density(0.001, 0.0), 64.0);
        assert_eq!(rule.chart_density(0.5, 0.0), 24.0);
        assert_eq!(rule.chart_density(5.0, 0.0), 4.0);
        assert_eq!(DensityRule::uniform(4.0).chart_density(0.5, 0.0), 4.0);
        // The estimate counts the raised density: within 2× of the atlas.
        let est = estimate_texels(&tris, rule);
        let built = atlas.texel_count() as f64;
        assert!(est > 0.5 * built && est < 2.0 * built, "{est} vs {built}");
        // A uniform rule builds what `build` builds.
        assert_eq!(
            build_with(&tris, DensityRule::uniform(4.0)).unwrap(),
            build(&tris, 4.0).unwrap()
        );
    }

    #[test]
    fn a_scene_over_its_element_budget_gets_one_lower_density_for_every_chart() {
        // Forty 0.5 m cubes and a 5 m one, at 4 per metre with 12 texels across each chart.
        let mut tris: Vec<Triangle> = (0..40)
            .flat_map(|k| cube(Vec3::new(2.0 * k as f32, 0.0, 0.0), 0.5, 0))
            .collect();
        tris.extend(cube(Vec3::splat(-10.0), 5.0, 1));
        let rule = DensityRule {
            per_metre: 4.0,
            min_across: 12.0,
            per_radian: 0.5,
        };
        let shapes = ChartShapes::with_charts(&tris);
        let full = shapes.elements(rule);
        // The estimate bounds what the atlas covers, and not loosely (these charts are squares).
        let (_, samples) = build_with(&tris, rule).unwrap();
        let covered = samples
            .iter()
            .map(|s| s.texel)
            .collect::<std::collections::HashSet<_>>();
        let covered = covered.len() as f64;
        assert!(
            covered <= full && full < 1.5 * covered,
            "{covered} covered, {full} estimated"
        );
        // Within the budget nothing changes.
        assert_eq!(fit_elements(&shapes, rule, 2.0, 2.0 * full), Some(1.0));
        // A quarter of it: one scale for every density, the largest that fits.
        for factor in [1.0, 2.0] {
            let max = factor * full / 4.0;
            let s = fit_elements(&shapes, rule, factor, max).unwrap();
            assert!(s > 0.3 && s < 0.6, "scale {s}");
            let fitted = rule.scaled(s);
            assert_eq!(
                (fitted.per_metre, fitted.min_across, fitted.per_radian),
                (4.0 * s, 12.0 * s, 0.5 * s)
            );
            assert!(shapes.elements(fitted) * factor <= max);
            assert!(
                shapes.elements(rule.scaled(s * 1.01)) * factor > max,
                "not the largest"
            );
            // The atlas built at the fitted rule keeps within the budget.
            let (_, samples) = build_with(&tris, fitted).unwrap();
            assert!(
                samples.len() as f64 * factor <= max,
                "{} samples",
                samples.len()
            );
            // Every chart keeps its proportion: the small cubes' faces are still as many
            // texels across as the large cube's (min_across scaled like the density).
            let ratio = |r: DensityRule| r.chart_density(0.5, 0.0) / r.chart_density(5.0, 0.0);
            assert!((ratio(fitted) / ratio(rule) - 1.0).abs() < 1e-5);
        }
        // Fewer elements than the charts need even as a texel or two each: refused.
        assert_eq!(fit_elements(&shapes, rule, 1.0, 100.0), None);
        // The texel estimate reads the same shapes at any rule.
        assert_eq!(shapes.texels(rule), estimate_texels(&tris, rule));
        let uniform = DensityRule::uniform(4.0);
        assert_eq!(
            ChartShapes::new(&tris, uniform).texels(uniform),
            shapes.texels(uniform)
        );
    }

    /// A strip of `n` quads around the y axis, radius `r`, height `h`, from angle 0 to
    /// `arc` radians: one chart while `arc` stays under the chart angle, turning by `arc`
    /// minus one quad's step (face normals sit at the quads' middles).
    fn cylinder_strip(r: f32, h: f32, arc: f32, n: usize) -> Vec<Triangle> {
        let at = |k: usize, y: f32| {
            let a = arc * k as f32 / n as f32;
            Vec3::new(r * a.cos(), y, r * a.sin())
        };
        (0..n)
            .flat_map(|k| {
                let (a, b, c, d) = (at(k, 0.0), at(k + 1, 0.0), at(k + 1, h), at(k, h));
                [tri([a, c, b], 0), tri([a, d, c], 0)]
            })
            .collect()
    }

    #[test]
    fn chart_turn_measures_how_far_a_curved_chart_turns_and_is_zero_when_flat() {
        let cube = cube(Vec3::ZERO, 1.0, 0);
        for c in &charts(&cube).0 {
            assert_eq!(chart_turn(&cube, c), 0.0, "a cube face is flat");
        }
        // A 36° arc in 12 quads: face normals from 1.5° to 34.5°, all within the chart
        // angle of the first.
        let strip = cylinder_strip(0.1, 0.05, 36f32.to_radians(), 12);
        let (strip_charts, _) = charts(&strip);
        assert_eq!(strip_charts.len(), 1, "one chart under the chart angle");
        let turn = chart_turn(&strip, &strip_charts[0]).to_degrees();
        assert!((turn - 33.0).abs() < 0.01, "{turn}°");
        assert_eq!(chart_turn(&strip, &[]), 0.0);
    }

    #[test]
    fn curved_charts_get_texels_per_radian_and_flat_ones_keep_their_density() {
        // A 36° strip of a 10 cm cylinder, 10 cm tall, beside a flat 10 cm cube, at 20
        // texels per metre: 2 texels across each without the rule.
        let mut tris = cylinder_strip(0.1, 0.1, 36f32.to_radians(), 12);
        let square = cube(Vec3::splat(5.0), 0.1, 1);
        tris.extend(square);
        let rule = DensityRule {
            per_metre: 20.0,
            min_across: 0.0,
            per_radian: 24.0,
        };
        let turn = 33f32.to_radians();
        // The strip's chart is 0.1 m across its longer side (its height; the chord is 6 cm).
        let d = rule.chart_density(0.1, turn);
        assert!(
            (d * 0.1 - turn * 24.0).abs() < 1e-3,
            "{d}: {} texels across",
            d * 0.1
        );
        assert_eq!(
            rule.chart_density(0.1, 0.0),
            20.0,
            "flat: the per-metre density"
        );
        assert_eq!(rule.chart_density(0.001, turn), 320.0, "at most 16×");
        assert_eq!(DensityRule::uniform(20.0).chart_density(0.1, turn), 20.0);
        assert_eq!(rule.chart_density(0.1, f32::NAN), 20.0);
        // In the atlas: 13.8 texels along the strip's height instead of 2, the cube's faces
        // unchanged.
        let count = |rule: DensityRule, object: u32| {
            let (_, samples) = build_with(&tris, rule).unwrap();
            let mut texels: Vec<u32> = samples
                .iter()
                .filter(|s| tris[s.triangle as usize].object == object)
                .map(|s| s.texel)
                .collect();
            texels.sort_unstable();
            texels.dedup();
            texels.len()
        };
        let off = DensityRule::uniform(20.0);
        assert_eq!(
            count(rule, 1),
            count(off, 1),
            "flat faces keep their texels"
        );
        let (curved, plain) = (count(rule, 0), count(off, 0));
        // 9 texels (3 × 3 sample points) without the rule; at least 13.8 × 8.5 with it.
        assert!(
            plain <= 12 && curved >= 117,
            "strip: {plain} → {curved} texels"
        );
        let est = estimate_texels(&tris, rule);
        let built = build_with(&tris, rule).unwrap().0.texel_count() as f64;
        assert!(est > 0.5 * built && est < 2.0 * built, "{est} vs {built}");
    }

    #[test]
    fn bad_density_is_refused() {
        let tris = cube(Vec3::ZERO, 1.0, 0);
        assert!(build(&tris, 0.0).is_err());
        assert!(build(&tris, f32::NAN).is_err());
        assert!(matches!(
            build(&tris, 1e5),
            Err(AtlasError::ChartTooLarge { .. })
        ));
    }
}
