//! Texel density that follows contacts and near occluders.
//!
//! Where other geometry comes within a texel or two of a surface (a model resting on a
//! floor, a panel standing just in front of a wall), D changes within millimetres: it falls
//! to ~0 at a contact, and a penumbra's width scales with the occluder's distance d from the
//! receiver (width ≈ light size × d / light distance, similar triangles). Texels spaced h
//! apart cannot follow a change over d < h, and bilinear lookups spread it over 2h.
//!
//! So, after a first atlas at the rule's density, each texel sample casts [`DIRECTIONS`]
//! short proximity rays (a fixed cosine-weighted pattern about the face normal, the same for
//! every texel: no random numbers, nothing that depends on threads) up to [`REACH`] × h, and
//! takes the nearest hit d on geometry that does not meet the texel's chart (a chart's own
//! neighbours across its sides are resolved by the texels that lie on its sides). The texel
//! asks for spacing d / [`REACH`], i.e. a density boost of REACH·h/d, capped by the setting.
//! Charts' boosts then grow in steps of √2, the step that meets most of what the asking texels
//! lack per added texel first, until the atlas has [`TEXEL_BUDGET`] × the texels of the first one;
//! the atlas is rebuilt with these per-chart boosts.

use std::collections::HashSet;

use glam::Vec3;
use rayon::prelude::*;

use super::atlas::{self, Atlas, DensityRule, TexelSample};
use crate::geometry::Bvh;
use crate::scene::Scene;

/// Proximity rays per texel sample.
pub const DIRECTIONS: u32 = 16;

/// How far the rays reach, in the texel's spacing; a texel asks for spacing d / REACH, so
/// geometry at d ≥ REACH × h asks for nothing.
pub const REACH: f32 = 2.0;

/// Largest total texels of the boosted atlas, as a multiple of the first atlas's.
pub const TEXEL_BUDGET: f64 = 2.0;

/// A texel asks for a boost where the nearest distance changes by more than this fraction
/// to a neighbouring texel (`requests`).
pub const VARY: f32 = 0.25;

/// A boost below this is not worth a chart's rebuild.
const MIN_BOOST: f32 = 1.25;

/// Direction `k` of the fixed pattern, in the frame whose z is the normal: a Fibonacci
/// spiral over the unit disc lifted to the hemisphere (Malley's method: cosine-weighted).
fn direction(k: u32) -> Vec3 {
    let u = (k as f32 + 0.5) / DIRECTIONS as f32;
    // The golden angle: successive points never line up.
    let phi = k as f32 * std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let r = u.sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u).max(0.0).sqrt())
}

/// What the proximity pass found and granted.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Boosts {
    /// Per chart (atlas chart ids): its density multiplier (1: unchanged).
    pub per_chart: Vec<f32>,
    /// Texel samples that asked for a boost.
    pub asking: usize,
    /// Charts granted a boost.
    pub charts: usize,
    /// Texels of the first atlas and (estimated from the boosts) of the rebuilt one.
    pub texels: (usize, usize),
}

/// Per texel sample: the density boost it asks for (1: none), capped at `max_boost`.
///
/// A texel asks only where the nearest distance changes from it to a neighbouring texel of
/// its chart by more than [`VARY`] × the nearer of the two: under the middle of a lamp 2 cm below a
/// ceiling, or of a panel in front of a wall, the distance is the same from texel to texel
/// and so is D; at the panel's rim, or where a curved surface nears a floor, both change.
fn requests(
    scene: &Scene,
    bvh: &Bvh,
    atlas: &Atlas,
    samples: &[TexelSample],
    max_boost: f32,
) -> Vec<f32> {
    let near = nearest(scene, bvh, atlas, samples);
    let offsets = atlas.page_offsets();
    let at = |texel: u32| samples.binary_search_by_key(&texel, |s| s.texel).ok();
    (0..samples.len())
        .map(|i| {
            let (h, d) = near[i];
            if h <= 0.0 {
                return 1.0;
            }
            let texel = samples[i].texel;
            let chart = atlas.texel_chart[texel as usize];
            let page = offsets.partition_point(|&o| o <= texel) - 1;
            let size = atlas.pages[page];
            let local = texel - offsets[page];
            let (x, y) = (local % size.width, local / size.width);
            let mut closest = d;
            let mut varies = false;
            for (dx, dy) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                if nx < 0 || ny < 0 || nx >= size.width as i64 || ny >= size.height as i64 {
                    continue;
                }
                let t = offsets[page] + ny as u32 * size.width + nx as u32;
                if atlas.texel_chart[t as usize] != chart {
                    continue;
                }
                if let Some(j) = at(t) {
                    let dn = near[j].1;
                    if (dn - d).abs() > VARY * dn.min(d) {
                        varies = true;
                        closest = closest.min(dn);
                    }
                }
            }
            if !varies {
                return 1.0;
            }
            (REACH * h / closest.max(1e-9)).clamp(1.0, max_boost)
        })
        .collect()
}

/// Per texel sample: its spacing h in metres (0: none to resolve) and the nearest hit of its
/// proximity rays (at most [`REACH`] × h).
fn nearest(scene: &Scene, bvh: &Bvh, atlas: &Atlas, samples: &[TexelSample]) -> Vec<(f32, f32)> {
    let (charts, vid) = atlas::charts(&scene.triangles);
    // Per chart, its welded vertices: a hit on a triangle touching one meets the chart.
    let chart_vertices: Vec<HashSet<u32>> = charts
        .iter()
        .map(|c| c.iter().flat_map(|&t| vid[t as usize]).collect())
        .collect();
    samples
        .par_iter()
        .map(|s| {
            let chart = atlas.texel_chart[s.texel as usize];
            let tri = &scene.triangles[s.triangle as usize];
            // Charts without diffuse reflection hold D = 0: no need to resolve them.
            let m = scene.material_of(s.triangle);
            if chart == u32::MAX || (m.albedo.max_element() <= 0.0 && m.base_texture.is_none()) {
                return (0.0, 0.0);
            }
            let h = atlas.texel_spacing(s.triangle, tri);
            if !(h.is_finite() && h > 0.0) {
                return (0.0, 0.0);
            }
            let ng = tri.face_normal();
            let origin = bvh.offset_origin(tri.point(s.bary), ng);
            let (t, b) = crate::sampling::basis(ng);
            let mut nearest = REACH * h;
            for k in 0..DIRECTIONS {
                let l = direction(k);
                let d = (t * l.x + b * l.y + ng * l.z).normalize();
                if let Some(hit) = bvh.closest_hit(origin, d, nearest)
                    && !vid[hit.triangle as usize]
                        .iter()
                        .any(|v| chart_vertices[chart as usize].contains(v))
                {
                    nearest = nearest.min(hit.t);
                }
            }
            (h, nearest)
        })
        .collect()
}

/// The per-chart boosts for `atlas` (built at `rule`), each at most `max_boost` (≤ 1: none).
pub fn boosts(
    scene: &Scene,
    bvh: &Bvh,
    atlas: &Atlas,
    samples: &[TexelSample],
    max_boost: f32,
) -> Boosts {
    let n = atlas.charts as usize;
    let base = atlas.texel_count();
    let mut out = Boosts {
        per_chart: vec![1.0; n],
        texels: (base, base),
        ..Default::default()
    };
    if max_boost <= 1.0 || atlas.from_uv1 || n == 0 {
        return out;
    }
    let wanted = requests(scene, bvh, atlas, samples, max_boost);
    // Per chart: its texels' requests, largest first, and its rectangle's texels.
    let mut asks: Vec<Vec<f32>> = vec![Vec::new(); n];
    for (s, &w) in samples.iter().zip(&wanted) {
        if w > 1.0 {
            asks[atlas.texel_chart[s.texel as usize] as usize].push(w);
        }
    }
    for a in &mut asks {
        a.sort_by(|x, y| y.total_cmp(x));
    }
    out.asking = asks.iter().map(Vec::len).sum();
    let mut rect = vec![0usize; n];
    for &c in &atlas.texel_chart {
        if c != u32::MAX {
            rect[c as usize] += 1;
        }
    }
    // Greedy by marginal worth: boosts grow in steps of √2 (texels ×2), each step of chart c
    // worth the texels its texels still lack (Σ (w/b)² − 1 over requests w above its boost b)
    // per texel it adds; the best step
    // first (ties by chart id), until the budget is spent. A small chart at a contact is raised
    // far before a whole wall with a strip of shadow is raised a little.
    let step = |c: usize, b: f32| {
        let next = (b * std::f32::consts::SQRT_2).min(asks[c].first().copied().unwrap_or(1.0));
        // Each texel still asking for w > b lacks (w/b)² − 1 texels per texel it has.
        let lack: f64 = asks[c]
            .iter()
            .take_while(|&&w| w > b)
            .map(|&w| (w as f64 / b as f64).powi(2) - 1.0)
            .sum();
        let cost = rect[c] as f64 * ((next as f64).powi(2) - (b as f64).powi(2));
        (next, lack / cost.max(1.0))
    };
    let mut heap = std::collections::BinaryHeap::new();
    for (c, a) in asks.iter().enumerate() {
        if a.first().is_some_and(|&w| w >= MIN_BOOST) {
            // Positive f64s order as their bits do.
            heap.push((step(c, 1.0).1.to_bits(), std::cmp::Reverse(c)));
        }
    }
    let mut left = base as f64 * (TEXEL_BUDGET - 1.0);
    let granted = &mut out.per_chart;
    while let Some((_, std::cmp::Reverse(c))) = heap.pop() {
        let b = granted[c];
        let (mut next, _) = step(c, b);
        let mut cost = rect[c] as f64 * ((next as f64).powi(2) - (b as f64).powi(2));
        let partial = cost > left;
        if partial {
            // What is left of the budget, and no further step.
            next = ((b as f64).powi(2) + left / rect[c] as f64).sqrt() as f32;
            cost = left;
        }
        if next <= b * 1.05 || (b == 1.0 && next < MIN_BOOST) {
            continue;
        }
        left -= cost;
        granted[c] = next;
        if !partial && asks[c][0] > next {
            heap.push((step(c, next).1.to_bits(), std::cmp::Reverse(c)));
        }
    }
    out.charts = granted.iter().filter(|&&b| b > 1.0).count();
    for (c, &b) in granted.iter().enumerate().filter(|(_, b)| **b > 1.0) {
        log::debug!(
            "contacts: chart {c}: {} texels, {} asking (up to {:.1}×), raised {b:.2}×",
            rect[c],
            asks[c].len(),
            asks[c][0]
        );
    }
    out.texels.1 = (base as f64 * TEXEL_BUDGET - left).round() as usize;
    out
}

/// The atlas for `scene` under `rule`, with contact boosts up to `max_boost` (≤ 1: the
/// rule's atlas).
pub fn build(
    scene: &Scene,
    bvh: &Bvh,
    rule: DensityRule,
    max_boost: f32,
) -> Result<(Atlas, Vec<TexelSample>, Boosts), atlas::AtlasError> {
    let (first, samples) = atlas::build_with(&scene.triangles, rule)?;
    let b = boosts(scene, bvh, &first, &samples, max_boost);
    if b.charts == 0 {
        return Ok((first, samples, b));
    }
    let (atlas, samples) = atlas::build_boosted(&scene.triangles, rule, &b.per_chart)?;
    Ok((atlas, samples, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pattern_is_cosine_weighted_and_unit() {
        let mut mean_cos = 0.0;
        for k in 0..DIRECTIONS {
            let d = direction(k);
            assert!((d.length() - 1.0).abs() < 1e-5 && d.z > 0.0, "{d}");
            mean_cos += d.z / DIRECTIONS as f32;
        }
        // E[cos θ] under a cosine density is 2/3.
        assert!((mean_cos - 2.0 / 3.0).abs() < 0.02, "{mean_cos}");
    }
}
