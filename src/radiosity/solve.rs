//! The radiosity solver: B = E + ρ·F·B on lightmap texels, by gathering with the BVH.
//!
//! Everything is expressed as radiance. For a texel with albedo ρ, the reflected radiance is
//! L_r = ρ/π · E_irr, where the irradiance E_irr comes from
//! - emitters, sampled explicitly: area lights (quads, not geometry) by stratified points,
//!   emissive triangles by points chosen in proportion to area × luminance, combined by
//!   multiple importance sampling (power heuristic) with the gathering rays that hit them;
//! - other surfaces, by cosine-distributed gathering rays whose hits read the previous
//!   iteration's L_r of the texel they land on (the texel's own emission is direct light).
//!
//! The rays are cast once: each texel keeps the texels its rays hit, so every bounce after
//! the first is a sparse product over those lists (a Monte Carlo estimate of the form
//! factors, solved by Jacobi iteration). Texels whose sample point lies inside or behind
//! geometry (many rays hit back faces) are excluded and their texels filled from valid
//! neighbours of the same chart, so they neither leak light nor darkness.

use std::collections::VecDeque;
use std::f32::consts::PI;

use glam::Vec3;
use rayon::prelude::*;

use super::atlas::{Atlas, TexelSample};
use super::emitters::{Emitters, luminance, power};
use super::transport::{Glossy, Term};
use crate::geometry::Bvh;
use crate::progress::{Cancelled, Progress};
use crate::sampling::{Rng, basis, sample_cosine_hemisphere, sample_triangle};
use crate::scene::Scene;

/// A sample is inside geometry when more than this fraction of its gathering rays hit back
/// faces (a floor texel under a wall sees the wall's inner faces).
pub const BACKFACE_LIMIT: f32 = 0.25;

/// Samples per work item (progress and cancellation granularity).
const CHUNK: usize = 256;

/// Solver settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveSettings {
    /// Gathering rays per texel.
    pub rays: u32,
    /// Emitter samples per texel and per area light (and for all emissive triangles).
    pub light_samples: u32,
    /// Largest number of indirect bounces.
    pub bounces: u32,
    /// Largest number of glossy reflections a gathering ray follows ([`super::transport`]);
    /// 0 gathers diffuse interreflection only.
    pub glossy_depth: u32,
    /// Stop when a bounce changes the total reflected radiance by less than this fraction.
    pub tolerance: f32,
    /// Random seed (every texel draws from its own stream of it).
    pub seed: u64,
}

/// Figures of a solve.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct SolveStats {
    /// Texels with a sample (finite elements).
    pub elements: u64,
    /// Elements excluded as inside geometry.
    pub excluded: u64,
    /// Texels (in charts) whose value was filled from a neighbour.
    pub filled: u64,
    /// Rays cast (gathering and shadow).
    pub rays_cast: u64,
    /// Bounces run.
    pub bounces: u32,
    /// Relative change of the last bounce.
    pub last_change: f64,
}

/// A converged solution.
pub struct Solution {
    /// Exitant radiance (emission + reflected) per global atlas texel, padding filled.
    pub radiance: Vec<Vec3>,
    /// Figures.
    pub stats: SolveStats,
}

/// What one element's gathering pass found.
struct Gathered {
    /// Direct irradiance / π (so that L_r = ρ · (direct + mean incoming L_r)).
    direct: Vec3,
    /// Per ray, the atlas texel hit on a front face (u32::MAX: miss or back face).
    hits: Vec<u32>,
    /// Texels reached through glossy reflection, with their weights (summed over the rays
    /// like `hits`).
    terms: Vec<Term>,
    inside: bool,
    rays: u64,
}

fn gather(
    scene: &Scene,
    bvh: &Bvh,
    atlas: &Atlas,
    offsets: &[u32],
    emitters: &Emitters,
    glossy: Option<&Glossy>,
    s: &TexelSample,
    index: usize,
    set: &SolveSettings,
) -> Gathered {
    let mut rng = Rng::new(set.seed, index as u64);
    let tri = &scene.triangles[s.triangle as usize];
    let ng = tri.face_normal();
    let mut ns = tri.normal(s.bary);
    if ns.dot(ng) <= 0.0 {
        ns = ng;
    }
    let p = tri.point(s.bary);
    let origin = bvh.offset_origin(p, ng);
    let (t, b) = basis(ns);
    let n_rays = set.rays.max(1);
    let n_light = set.light_samples.max(1);
    let mut direct = Vec3::ZERO;
    let mut hits = Vec::with_capacity(n_rays as usize);
    let mut terms = Vec::new();
    // Radiance the rays bring back through glossy reflection (besides `terms`).
    let mut via_glossy = Vec3::ZERO;
    let mut backfaces = 0u32;
    let mut rays = 0u64;

    // Gathering rays (cosine-distributed about the shading normal).
    for _ in 0..n_rays {
        let l = sample_cosine_hemisphere(rng.uniform2());
        let d = t * l.x + b * l.y + ns * l.z;
        rays += 1;
        if d.dot(ng) <= 0.0 {
            hits.push(u32::MAX);
            continue;
        }
        match bvh.closest_hit(origin, d, f32::INFINITY) {
            Some(h) => {
                let ht = &scene.triangles[h.triangle as usize];
                let hn = ht.face_normal();
                let cos_l = -d.dot(hn);
                if cos_l <= 0.0 {
                    backfaces += 1;
                    hits.push(u32::MAX);
                    continue;
                }
                let e = scene.materials[ht.material as usize].emission;
                if e.max_element() > 0.0 {
                    // MIS against explicit emitter sampling (solid-angle densities).
                    let p_light = emitters.area_pdf(e) * h.t * h.t / cos_l;
                    let p_bsdf = l.z / PI;
                    let w = power(n_rays as f32, p_bsdf, n_light as f32, p_light);
                    // Irradiance/π from this ray: L · (cos/p_bsdf)/π/N = L/N.
                    direct += e * w / n_rays as f32;
                }
                hits.push(atlas.texel_at(offsets, h.triangle, h.bary));
                if let Some(g) = glossy
                    && g.reflects(h.triangle)
                {
                    via_glossy += g.follow(h, d, &mut rng, &mut terms, &mut rays);
                }
            }
            None => hits.push(u32::MAX),
        }
    }
    if via_glossy != Vec3::ZERO {
        // Mean incoming radiance over the cosine-distributed rays is irradiance/π.
        direct += via_glossy / n_rays as f32;
    }

    // Area lights: stratified points on each quad.
    let grid = (n_light as f32).sqrt().ceil() as u32;
    for light in &scene.lights {
        let mut sum = Vec3::ZERO;
        for k in 0..n_light {
            let (i, j) = (k % grid, (k / grid) % grid);
            let u = rng.uniform2();
            let q = light.corner
                + light.edge_u * ((i as f32 + u.x) / grid as f32)
                + light.edge_v * ((j as f32 + u.y) / grid as f32);
            let w = q - origin;
            let dist2 = w.length_squared();
            let dist = dist2.sqrt();
            let d = w / dist;
            let cos_s = d.dot(ns);
            let mut cos_l = -d.dot(light.normal);
            if light.two_sided {
                cos_l = cos_l.abs();
            }
            if cos_s <= 0.0 || cos_l <= 0.0 || d.dot(ng) <= 0.0 {
                continue;
            }
            rays += 1;
            if bvh.occluded(origin, d, dist * (1.0 - 1e-5)) {
                continue;
            }
            sum += light.radiance * (cos_s * cos_l / dist2);
        }
        direct += sum * (light.area / n_light as f32) / PI;
    }

    // Emissive triangles: points in proportion to area × luminance.
    if !emitters.tris.is_empty() {
        let mut sum = Vec3::ZERO;
        for _ in 0..n_light {
            let et = &scene.triangles[emitters.pick(rng.uniform()) as usize];
            let e = scene.materials[et.material as usize].emission;
            let q = et.point(sample_triangle(rng.uniform2()));
            let w = q - origin;
            let dist2 = w.length_squared();
            let dist = dist2.sqrt();
            if dist <= 0.0 {
                continue;
            }
            let d = w / dist;
            let cos_s = d.dot(ns);
            let cos_l = -d.dot(et.face_normal());
            if cos_s <= 0.0 || cos_l <= 0.0 || d.dot(ng) <= 0.0 {
                continue;
            }
            rays += 1;
            // Stop short of the emitter: it must not occlude itself.
            if bvh.occluded(origin, d, dist - 2.0 * bvh.epsilon().max(dist * 1e-5)) {
                continue;
            }
            let p_light = emitters.area_pdf(e) * dist2 / cos_l;
            let p_bsdf = cos_s / PI;
            let wgt = power(n_light as f32, p_light, n_rays as f32, p_bsdf);
            sum += e * (wgt * cos_s / p_light);
        }
        direct += sum / (n_light as f32 * PI);
    }

    Gathered {
        direct,
        hits,
        terms,
        inside: backfaces as f32 > BACKFACE_LIMIT * n_rays as f32,
        rays,
    }
}

/// Solves the scene's radiosity on the atlas. `samples` come from [`super::atlas::build`].
pub fn solve(
    scene: &Scene,
    bvh: &Bvh,
    atlas: &Atlas,
    samples: &[TexelSample],
    set: &SolveSettings,
    progress: &dyn Progress,
) -> Result<Solution, Cancelled> {
    let offsets = atlas.page_offsets();
    let emitters = Emitters::new(scene);
    let glossy = Glossy::new(scene, bvh, atlas, &offsets, &emitters, set.glossy_depth);
    progress.phase("gathering", samples.len() as u64);
    let chunks: Vec<Option<Vec<Gathered>>> = samples
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            if progress.cancelled() {
                return None;
            }
            let out = chunk
                .iter()
                .enumerate()
                .map(|(k, s)| {
                    gather(
                        scene,
                        bvh,
                        atlas,
                        &offsets,
                        &emitters,
                        glossy.as_ref(),
                        s,
                        c * CHUNK + k,
                        set,
                    )
                })
                .collect();
            progress.advance(chunk.len() as u64);
            Some(out)
        })
        .collect();
    let mut gathered = Vec::with_capacity(samples.len());
    for c in chunks {
        gathered.extend(c.ok_or(Cancelled)?);
    }

    let mut stats = SolveStats {
        elements: samples.len() as u64,
        excluded: gathered.iter().filter(|g| g.inside).count() as u64,
        rays_cast: gathered.iter().map(|g| g.rays).sum(),
        ..Default::default()
    };

    // Each texel resolves to the nearest valid element of its chart.
    let (resolve, filled) = resolve_texels(atlas, samples, &gathered);
    stats.filled = filled;
    let resolved = |h: u32| {
        if h == u32::MAX {
            u32::MAX
        } else {
            resolve[h as usize]
        }
    };
    let hits: Vec<Vec<u32>> = gathered
        .par_iter()
        .map(|g| g.hits.iter().map(|&h| resolved(h)).collect())
        .collect();
    let terms: Vec<Vec<Term>> = gathered
        .par_iter()
        .map(|g| {
            g.terms
                .iter()
                .map(|t| Term {
                    texel: resolved(t.texel),
                    weight: t.weight,
                })
                .filter(|t| t.texel != u32::MAX)
                .collect()
        })
        .collect();
    let albedo: Vec<Vec3> = samples
        .iter()
        .map(|s| scene.materials[scene.triangles[s.triangle as usize].material as usize].albedo)
        .collect();

    // Jacobi iteration on reflected radiance.
    let mut lr: Vec<Vec3> = gathered
        .iter()
        .zip(&albedo)
        .map(|(g, a)| *a * g.direct)
        .collect();
    progress.phase("bouncing", set.bounces as u64);
    for bounce in 0..set.bounces {
        if progress.cancelled() {
            return Err(Cancelled);
        }
        let next: Vec<Vec3> = (0..samples.len())
            .into_par_iter()
            .map(|i| {
                let mut sum = [0.0f64; 3];
                for &h in &hits[i] {
                    if h != u32::MAX {
                        let l = lr[h as usize];
                        sum[0] += l.x as f64;
                        sum[1] += l.y as f64;
                        sum[2] += l.z as f64;
                    }
                }
                for t in &terms[i] {
                    let l = t.weight * lr[t.texel as usize];
                    sum[0] += l.x as f64;
                    sum[1] += l.y as f64;
                    sum[2] += l.z as f64;
                }
                let n = hits[i].len().max(1) as f64;
                let incoming = Vec3::new(
                    (sum[0] / n) as f32,
                    (sum[1] / n) as f32,
                    (sum[2] / n) as f32,
                );
                albedo[i] * (gathered[i].direct + incoming)
            })
            .collect();
        let (mut change, mut total) = (0.0f64, 0.0f64);
        for (a, b) in lr.iter().zip(&next) {
            change += luminance((*b - *a).abs()) as f64;
            total += luminance(*b) as f64;
        }
        lr = next;
        stats.bounces = bounce + 1;
        stats.last_change = if total > 0.0 { change / total } else { 0.0 };
        progress.advance(1);
        if stats.last_change < set.tolerance as f64 {
            break;
        }
    }

    // Exitant radiance per texel: the resolved element's emission + reflection.
    let exitant: Vec<Vec3> = samples
        .iter()
        .zip(&lr)
        .map(|(s, l)| {
            scene.materials[scene.triangles[s.triangle as usize].material as usize].emission + *l
        })
        .collect();
    let radiance = resolve
        .iter()
        .map(|&r| {
            if r == u32::MAX {
                Vec3::ZERO
            } else {
                exitant[r as usize]
            }
        })
        .collect();
    Ok(Solution { radiance, stats })
}

/// For every atlas texel, the index of the element whose value it shows: its own when valid,
/// else the nearest valid element of the same chart (breadth-first over 4-neighbours, ties
/// to the lower element index); `u32::MAX` outside charts or in charts with no valid element.
/// Returns the map and the number of chart texels filled from a neighbour.
fn resolve_texels(
    atlas: &Atlas,
    samples: &[TexelSample],
    gathered: &[Gathered],
) -> (Vec<u32>, u64) {
    let mut resolve = vec![u32::MAX; atlas.texel_count()];
    let mut queue = VecDeque::new();
    for (i, (s, g)) in samples.iter().zip(gathered).enumerate() {
        if !g.inside {
            resolve[s.texel as usize] = i as u32;
            queue.push_back(s.texel);
        }
    }
    let offsets = atlas.page_offsets();
    let mut filled = 0u64;
    while let Some(t) = queue.pop_front() {
        let page = offsets.partition_point(|&o| o <= t) - 1;
        let size = atlas.pages[page];
        let local = t - offsets[page];
        let (x, y) = (local % size.width, local / size.width);
        let chart = atlas.texel_chart[t as usize];
        let mut visit = |nx: u32, ny: u32| {
            let n = offsets[page] + ny * size.width + nx;
            if resolve[n as usize] == u32::MAX && atlas.texel_chart[n as usize] == chart {
                resolve[n as usize] = resolve[t as usize];
                filled += 1;
                queue.push_back(n);
            }
        };
        if x > 0 {
            visit(x - 1, y);
        }
        if x + 1 < size.width {
            visit(x + 1, y);
        }
        if y > 0 {
            visit(x, y - 1);
        }
        if y + 1 < size.height {
            visit(x, y + 1);
        }
    }
    (resolve, filled)
}
