//! The radiosity solver: B = E + ρ·F·B on lightmap texels, by gathering with the BVH.
//!
//! Everything is expressed as radiance. For a texel with albedo ρ, the reflected radiance is
//! L_r = ρ/π · E_irr, where the irradiance E_irr comes from
//! - emitters, sampled explicitly: area lights (quads, not geometry) by evenly spread points,
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
//!
//! Kept in one file: gathering, the link cache and the Jacobi iteration share the links' layout
//! and the per-round random streams that keep a bake deterministic.

use std::collections::VecDeque;
use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::Vec3;
use rayon::prelude::*;

use super::atlas::{Atlas, TexelSample};
pub use super::batch::GatherBatch;
use super::batch::samples_hash;
use super::emitters::{Emitters, luminance};
use super::gather::{Context, GatherOut, Gathered, Prior, RaySequence, gather};
use super::many_lights::{LIGHTS_SAMPLED_EACH, ManyLights};
use super::mirror_lights::{MirrorLights, is_mirror};
pub use super::ray_cache::RAY_CACHE_BUDGET;
use super::ray_cache::{self, KeptBatch, RayCache};
use super::terms::PackedTerms;
use super::transmission::Glass;
use super::transport::{Glossy, Term, is_glossy};
use super::varint;
use crate::geometry::Bvh;
use crate::progress::{Cancelled, Progress};
use crate::sampling::Rng;
use crate::scene::Scene;
use crate::scene::texturing::{TexelSurface, stored_radiance};
use crate::settings::radiosity::RadiositySettings;

pub use super::gather::{BACKFACE_LIMIT, OPEN_LIMIT};

/// Most refinement rounds of [`SolveSettings::target_error`].
pub const MAX_ROUNDS: u32 = 4;

/// Most samples an element may get under [`SolveSettings::target_error`], as a multiple of
/// its first batch (`rays`, `light_samples`). The elements that ask for more are those whose
/// error is mostly the part that falls as 1/samples (glossy paths drawn at random, emitter
/// samples): on glossy-room they took most of the refinement's rays, and the path tracer's
/// probes read the same D without them (docs/tuning.md#refinement-limits).
pub const MAX_SAMPLE_FACTOR: u32 = 8;

/// Gathering rays [`MAX_SAMPLE_FACTOR`] allows an element at least (its emitter samples in
/// proportion): a coarse first batch, whose elements cost little, may still be refined to
/// the target.
pub const MIN_SAMPLE_CAP: u64 = 2048;

/// Emitter samples an element may be refined to, as a multiple of the share of them that
/// [`MAX_SAMPLE_FACTOR`]'s rays would bring in the first batch's ratio. More buys down the
/// elements whose error is their emitter samples' (a building's rooms beside their windows),
/// at a cost in time (docs/tuning.md#refinement-limits).
pub const LIGHT_CAP_FACTOR: u64 = 1;

/// Most gathering rays all refinement rounds together may add, as a multiple of the first
/// batch's (elements × `rays`): the refinement's time. Its memory is bounded by
/// [`SolveSettings::cache_budget`] (see `bake::radiosity_stage::memory_estimate`).
pub const REFINE_BUDGET: u64 = 8;

pub use crate::settings::radiosity::CACHE_BUDGET;

/// Samples per work item, each item a task of its own (`with_max_len(1)`), also the progress
/// and cancellation granularity. Neighbouring elements cost alike and elements far apart do
/// not (those that see a mirror follow glossy paths): in runs of 256 left to rayon's own
/// splitting, one thread gathered glossy-room's last 0.7 s alone.
const CHUNK: usize = 16;

/// Elements a refinement round gathers before packing their rays into the links.
const REFINE_SLICE: usize = 16384;

/// The most bytes one ray's hit can add to an element's packed links (a LEB128 gap of a
/// `u32`: inserting a hit splits one gap into two, neither longer than before).
const MAX_HIT_BYTES: u64 = 5;

/// The most bytes one glossy term can add ([`PackedTerms`]: a varint head of at most five
/// bytes and three floats).
const MAX_TERM_BYTES: u64 = 17;

/// What the solver reads of [`RadiositySettings`] (the atlas's settings are used before it),
/// with the seed and the cache budget in bytes; each field means what the setting of its name
/// does there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveSettings {
    /// [`RadiositySettings::rays`].
    pub rays: u32,
    /// [`RadiositySettings::light_samples`]; with more than `LIGHTS_SAMPLED_EACH` emitters,
    /// drawn from all of them (`radiosity::many_lights`).
    pub light_samples: u32,
    /// [`RadiositySettings::bounces`].
    pub bounces: u32,
    /// [`RadiositySettings::glossy_depth`] (`radiosity::transport`).
    pub glossy_depth: u32,
    /// [`RadiositySettings::tolerance`].
    pub tolerance: f32,
    /// [`RadiositySettings::target_error`]: refinement runs up to [`MAX_ROUNDS`] rounds and
    /// up to [`MAX_SAMPLE_FACTOR`] × an element's first batch (at least [`MIN_SAMPLE_CAP`]
    /// rays).
    pub target_error: Option<f32>,
    /// Random seed (every texel draws from its own stream of it).
    pub seed: u64,
    /// [`RadiositySettings::cache_budget`], bytes. An element refined beyond it has its new
    /// rays read once, against the reflected radiance of that moment, and kept as sums
    /// (`Links::freeze`); under the budget every cached ray follows every bounce
    /// (docs/tuning.md#cache-budget).
    pub cache_budget: u64,
}

impl SolveSettings {
    /// The solver's part of `s`, with `seed`.
    pub fn new(s: &RadiositySettings, seed: u64) -> SolveSettings {
        SolveSettings {
            rays: s.rays,
            light_samples: s.light_samples,
            bounces: s.bounces,
            glossy_depth: s.glossy_depth,
            tolerance: s.tolerance,
            target_error: s.target_error,
            seed,
            cache_budget: s.cache_budget(),
        }
    }
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
    /// Refinement rounds run for the target error.
    pub rounds: u32,
    /// Elements given more samples (each counted once).
    pub refined: u64,
    /// Estimated relative standard error of the elements' D: median, 95th percentile, max.
    pub error_median: f64,
    pub error_p95: f64,
    pub error_max: f64,
    /// Bytes of the gathered rays the bounces read (their hits and glossy terms): what grows
    /// with rays × elements.
    pub cache_bytes: u64,
    /// The glossy terms' share of `cache_bytes`.
    pub cache_terms_bytes: u64,
    /// Refinement gathering rays read once rather than cached: the cache reached
    /// [`SolveSettings::cache_budget`].
    pub frozen_rays: u64,
}

/// A converged solution.
pub struct Solution {
    /// Exitant radiance (emission + reflected) per global atlas texel, padding filled.
    pub radiance: Vec<Vec3>,
    /// Figures.
    pub stats: SolveStats,
}

/// The random stream of element `index`'s emitter samples in refinement round `round` (0: the
/// first batch); its gathering rays draw from their own ([`super::gather::ray_rng`]).
fn stream(round: u32, index: usize) -> u64 {
    ((round as u64) << 40) | index as u64
}

/// The stream of the shift of each element's ray sequence (no refinement round gets there).
const SHIFT_STREAM_ROUND: u32 = 0xff_ffff;

/// A solve's ray cache ([`super::ray_cache`]): the earlier bake's with the materials
/// whose lobes changed since, and the batches this solve keeps, per element.
struct CacheRun {
    prior: Option<(RayCache, u64)>,
    kept: Vec<Vec<KeptBatch>>,
    /// Bytes of the batches packed so far; past `budget` the solve keeps none.
    bytes: AtomicU64,
    budget: u64,
    /// Rays kept from the prior bake, and rays gathered in all.
    reused: u64,
    gathered: u64,
}

impl CacheRun {
    fn over_budget(&self) -> bool {
        self.bytes.load(Ordering::Relaxed) > self.budget
    }
}

/// Gathers the elements `which` (indices into `samples`), in parallel, with per-element
/// sample counts, continuing the ray sequences of what they `have`, keeping the batches in
/// `cache` (and reusing its prior bake's rays) when given; `None` when cancelled.
#[allow(clippy::too_many_arguments)]
fn gather_all(
    cx: &Context,
    samples: &[TexelSample],
    which: &[(u32, u32, u32)],
    have: Option<&[Gathered]>,
    seed: u64,
    round: u32,
    mut cache: Option<&mut CacheRun>,
    progress: &dyn Progress,
) -> Option<Vec<Gathered>> {
    let run = cache.as_deref();
    let prior = run.and_then(|c| c.prior.as_ref());
    let chunks: Vec<Option<Vec<GatherOut>>> = which
        .par_chunks(CHUNK)
        .with_max_len(1)
        .map(|chunk| {
            if progress.cancelled() {
                return None;
            }
            let out = chunk
                .iter()
                .map(|&(i, rays, light)| {
                    let mut rng = Rng::new(seed, stream(round, i as usize));
                    let seq = RaySequence {
                        first: have.map_or(0, |g| g[i as usize].gathering_rays),
                        shift: Rng::new(seed, stream(SHIFT_STREAM_ROUND, i as usize)).uniform2(),
                    };
                    let prior = prior.map(|(c, changed)| Prior {
                        batches: &c.elements[i as usize],
                        changed: *changed,
                    });
                    // Past the budget nothing more is packed: the whole cache is dropped.
                    let keep = run.is_some_and(|r| !r.over_budget());
                    let out = gather(
                        cx,
                        &samples[i as usize],
                        i,
                        seed,
                        round,
                        &mut rng,
                        seq,
                        rays,
                        light,
                        prior,
                        keep,
                    );
                    if let (Some(r), Some(k)) = (run, &out.kept) {
                        r.bytes.fetch_add(k.bytes(), Ordering::Relaxed);
                    }
                    out
                })
                .collect();
            progress.advance(chunk.len() as u64);
            Some(out)
        })
        .collect();
    let over = cache.as_ref().is_some_and(|c| c.over_budget());
    let mut out = Vec::with_capacity(which.len());
    for (c, chunk) in chunks.into_iter().zip(which.chunks(CHUNK)) {
        for (g, &(i, _, _)) in c?.into_iter().zip(chunk) {
            if let Some(cache) = cache.as_deref_mut() {
                cache.reused += u64::from(g.reused);
                cache.gathered += u64::from(g.gathered.gathering_rays);
                if let Some(k) = g.kept.filter(|_| !over) {
                    cache.kept[i as usize].push(k);
                }
            }
            out.push(g.gathered);
        }
    }
    if let Some(cache) = cache.filter(|_| over) {
        cache.kept = Vec::new();
    }
    Some(out)
}

/// The emitters gathering samples, owned for a solve's or a batch's [`Context`].
struct Lights {
    emitters: Emitters,
    /// Every triangle's face normal ([`Context::normals`]).
    normals: Vec<Vec3>,
    mirrors: Option<MirrorLights>,
    many: Option<ManyLights>,
}

impl Lights {
    fn new(scene: &Scene, set: &SolveSettings) -> Lights {
        let many = ManyLights::new(scene, LIGHTS_SAMPLED_EACH);
        Lights {
            emitters: Emitters::new(scene),
            normals: scene.triangles.iter().map(|t| t.face_normal()).collect(),
            // Mirror images of emitters are part of glossy transport.
            mirrors: if set.glossy_depth > 0 {
                MirrorLights::new(scene, many.as_ref())
            } else {
                None
            },
            many,
        }
    }

    fn context<'a>(
        &'a self,
        scene: &'a Scene,
        bvh: &'a Bvh,
        atlas: &'a Atlas,
        offsets: &'a [u32],
        set: &SolveSettings,
    ) -> Context<'a> {
        Context {
            scene,
            bvh,
            atlas,
            offsets,
            normals: &self.normals,
            emitters: &self.emitters,
            glossy: Glossy::new(
                scene,
                bvh,
                atlas,
                offsets,
                &self.emitters,
                set.glossy_depth,
                self.mirrors.as_ref(),
                self.many.as_ref(),
            ),
            mirrors: self.mirrors.as_ref(),
            many: self.many.as_ref(),
            glass: Glass::of(scene, bvh),
        }
    }
}

/// The first gathering batch of the elements `range` (indices into `samples`): what a
/// radiosity work unit computes. Every element draws from its own random streams, so the
/// batches of any split, solved together by [`solve_batches`], give the bytes of [`solve`].
pub fn gather_batch(
    scene: &Scene,
    bvh: &Bvh,
    atlas: &Atlas,
    samples: &[TexelSample],
    set: &SolveSettings,
    range: Range<u32>,
    progress: &dyn Progress,
) -> Result<GatherBatch, Cancelled> {
    let offsets = atlas.page_offsets();
    let lights = Lights::new(scene, set);
    let cx = lights.context(scene, bvh, atlas, &offsets, set);
    gather_first(&cx, samples, set, range, None, progress)
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
    solve_keeping(scene, bvh, atlas, samples, set, None, progress)
}

/// [`solve`], keeping its gathering in `cache` when given.
fn solve_keeping(
    scene: &Scene,
    bvh: &Bvh,
    atlas: &Atlas,
    samples: &[TexelSample],
    set: &SolveSettings,
    mut cache: Option<&mut CacheRun>,
    progress: &dyn Progress,
) -> Result<Solution, Cancelled> {
    let offsets = atlas.page_offsets();
    let lights = Lights::new(scene, set);
    let cx = lights.context(scene, bvh, atlas, &offsets, set);
    let range = 0..samples.len() as u32;
    let all = gather_first(&cx, samples, set, range, cache.as_deref_mut(), progress)?;
    solve_gathered(&cx, samples, set, vec![all], cache, progress)
}

/// The key of a ray cache for a solve of `scene` on the atlas of `samples` with `set`:
/// everything a gathering ray's result depends on besides the materials' lobes (module
/// comment), and per material the BLAKE3 of its lobes.
pub(super) fn cache_key(
    scene: &Scene,
    samples: &[TexelSample],
    set: &SolveSettings,
) -> ([u8; 32], Vec<[u8; 32]>) {
    let mut h = blake3::Hasher::new();
    h.update(ray_cache::MAGIC);
    h.update(&ray_cache::VERSION.to_le_bytes());
    h.update(&GATHER_REVISION.to_le_bytes());
    h.update(crate::bundle::manifest::generator().as_bytes());
    h.update(scene.geometry_hash.as_bytes());
    h.update(&samples_hash(samples));
    // Debug prints every float so that it reads back exactly.
    h.update(format!("{set:?}").as_bytes());
    h.update(format!("{:?}", scene.lights).as_bytes());
    h.update(format!("{:?}", scene.reflectors).as_bytes());
    let mut lobes = Vec::with_capacity(scene.materials.len());
    for m in &scene.materials {
        let mut rest = m.clone();
        rest.lobes.clear();
        h.update(format!("{rest:?}").as_bytes());
        let own = *blake3::hash(format!("{:?}", m.lobes).as_bytes()).as_bytes();
        // Every ray reads which materials reflect glossily, and mirror lights read the
        // mirrors' lobes.
        let mirror = is_mirror(m);
        h.update(&[u8::from(is_glossy(m)), u8::from(mirror)]);
        if mirror {
            h.update(&own);
        }
        lobes.push(own);
    }
    (*h.finalize().as_bytes(), lobes)
}

/// Raised whenever what a gathering ray or an element's emitter samples return changes for
/// the same scene and settings, so that a ray cache written before is not read as this one's.
const GATHER_REVISION: u32 = 3;

/// How much of a prior ray cache a solve used.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CacheUse {
    /// Gathering rays kept from the prior bake.
    pub kept: u64,
    /// Gathering rays in all.
    pub gathered: u64,
}

/// [`solve`], keeping every gathering ray in a ray cache ([`super::ray_cache`]) that it
/// returns (`None` when it would be larger than `budget` bytes, e.g. [`RAY_CACHE_BUDGET`]),
/// and reusing the rays of `prior` (an earlier bake's) that the scene's changes since do not
/// touch; the same bytes as [`solve`].
#[allow(clippy::too_many_arguments)]
pub fn solve_cached(
    scene: &Scene,
    bvh: &Bvh,
    atlas: &Atlas,
    samples: &[TexelSample],
    set: &SolveSettings,
    prior: Option<RayCache>,
    budget: u64,
    progress: &dyn Progress,
) -> Result<(Solution, Option<RayCache>, CacheUse), Cancelled> {
    let (key, lobes) = cache_key(scene, samples, set);
    let prior = prior.and_then(|c| {
        let changed = c.changed(&key, &lobes, samples.len());
        if changed.is_none() {
            log::info!("ray cache: made for another scene, atlas or settings; not used");
        }
        changed.map(|m| (c, m))
    });
    let mut run = CacheRun {
        prior,
        kept: vec![Vec::new(); samples.len()],
        bytes: AtomicU64::new(0),
        budget,
        reused: 0,
        gathered: 0,
    };
    let solution = solve_keeping(scene, bvh, atlas, samples, set, Some(&mut run), progress)?;
    if run.prior.is_some() {
        log::info!(
            "ray cache: {} of {} gathering rays kept, the rest followed again",
            run.reused,
            run.gathered
        );
    }
    let used = CacheUse {
        kept: run.reused,
        gathered: run.gathered,
    };
    let cache = if run.over_budget() {
        log::info!(
            "ray cache: over its budget of {} MiB; not kept, so the next edit follows every ray",
            budget >> 20
        );
        None
    } else {
        Some(RayCache {
            key,
            lobes,
            elements: run.kept,
        })
    };
    Ok((solution, cache, used))
}

/// Solves from first gathering batches that cover every element once, in order (refinement
/// rounds, when [`SolveSettings::target_error`] asks for them, gather here).
pub fn solve_batches(
    scene: &Scene,
    bvh: &Bvh,
    atlas: &Atlas,
    samples: &[TexelSample],
    set: &SolveSettings,
    batches: Vec<GatherBatch>,
    progress: &dyn Progress,
) -> Result<Solution, Cancelled> {
    let offsets = atlas.page_offsets();
    let lights = Lights::new(scene, set);
    let cx = lights.context(scene, bvh, atlas, &offsets, set);
    solve_gathered(&cx, samples, set, batches, None, progress)
}

/// [`gather_batch`] in a context.
fn gather_first(
    cx: &Context,
    samples: &[TexelSample],
    set: &SolveSettings,
    range: Range<u32>,
    cache: Option<&mut CacheRun>,
    progress: &dyn Progress,
) -> Result<GatherBatch, Cancelled> {
    assert!(
        range.end as usize <= samples.len(),
        "batch beyond the elements"
    );
    let (rays, light) = (set.rays.max(1), set.light_samples.max(1));
    progress.phase("gathering", range.len() as u64);
    let which: Vec<(u32, u32, u32)> = range.clone().map(|i| (i, rays, light)).collect();
    let elements =
        gather_all(cx, samples, &which, None, set.seed, 0, cache, progress).ok_or(Cancelled)?;
    Ok(GatherBatch { range, elements })
}

/// [`solve_batches`] in a context.
fn solve_gathered(
    cx: &Context,
    samples: &[TexelSample],
    set: &SolveSettings,
    batches: Vec<GatherBatch>,
    mut cache: Option<&mut CacheRun>,
    progress: &dyn Progress,
) -> Result<Solution, Cancelled> {
    let mut next = 0u32;
    for b in &batches {
        assert_eq!(
            b.range.start, next,
            "gathering batches must tile the elements in order"
        );
        next = b.range.end;
    }
    assert_eq!(
        next as usize,
        samples.len(),
        "gathering batches must cover every element"
    );
    let (scene, atlas) = (cx.scene, cx.atlas);
    let (rays, light) = (set.rays.max(1), set.light_samples.max(1));
    let mut gathered: Vec<Gathered> = Vec::with_capacity(samples.len());
    for b in batches {
        gathered.extend(b.elements);
    }

    let mut stats = SolveStats {
        elements: samples.len() as u64,
        excluded: gathered.iter().filter(|g| g.inside).count() as u64,
        ..Default::default()
    };

    // Each texel resolves to the nearest valid element of its chart.
    let (resolve, filled) = resolve_texels(atlas, samples, &gathered);
    stats.filled = filled;
    // The rays' hits move into the links: each ray's hit is held once.
    let mut links: Vec<Links> = gathered
        .par_iter_mut()
        .map(|g| Links::take(g, &resolve))
        .collect();
    // Albedo and emission over each element's texel (textures averaged over its footprint).
    let surfaces: Vec<TexelSurface> = samples
        .par_iter()
        .map(|s| scene.texel_surface(s.triangle, &atlas.tri_coords[s.triangle as usize], s.bary))
        .collect();
    let albedo: Vec<Vec3> = surfaces.iter().map(|s| s.albedo).collect();
    let emission: Vec<Vec3> = surfaces.iter().map(|s| s.emission).collect();

    // Jacobi iteration on reflected radiance.
    let mut lr: Vec<Vec3> = gathered
        .iter()
        .zip(&albedo)
        .map(|(g, a)| *a * g.direct())
        .collect();
    iterate(
        &mut lr, &links, &gathered, &albedo, None, set, &mut stats, progress,
    )?;

    // Refinement: more samples where the estimated error is above the target.
    let mut refined = vec![false; samples.len()];
    let (mut error, mut sums) = relative_errors(&lr, &links, &gathered, &albedo, &emission);
    if let Some(target) = set.target_error {
        // Each element's share of the surface: the probes and the eye sample D by area.
        let area: Vec<f64> = samples
            .par_iter()
            .map(|s| {
                let spacing =
                    atlas.texel_spacing(s.triangle, &scene.triangles[s.triangle as usize]);
                if spacing.is_finite() {
                    (spacing as f64).powi(2)
                } else {
                    0.0
                }
            })
            .collect();
        let mut budget = REFINE_BUDGET * rays as u64 * samples.len() as u64;
        // Bytes the links hold, kept up to date as refinement adds to them.
        let mut held: u64 = links.iter().map(Links::held).sum();
        for round in 1..=MAX_ROUNDS {
            let mut which = more_samples(&error, &gathered, target, rays, light);
            let totals: Vec<f64> = error.iter().map(|p| p.error()).collect();
            share_budget(&mut which, &totals, &gathered, &area, &mut budget);
            if which.is_empty() {
                break;
            }
            progress.phase("refining", which.len() as u64);
            // Elements whose links this round leaves alone keep the sums the estimate read.
            let mut kept = vec![true; samples.len()];
            for &(i, _, _) in &which {
                kept[i as usize] = false;
            }
            // A slice at a time: a round's raw rays (4 bytes each, and their glossy terms)
            // are packed into the links before the next slice is gathered.
            for slice in which.chunks(REFINE_SLICE) {
                let more = gather_all(
                    cx,
                    samples,
                    slice,
                    Some(&gathered),
                    set.seed,
                    round,
                    cache.as_deref_mut(),
                    progress,
                )
                .ok_or(Cancelled)?;
                // Where even the most the slice's rays could pack into fits the budget,
                // every element below is extended: pack them in parallel (each element's
                // links alone), then account in order as below.
                let most: u64 = more
                    .iter()
                    .map(|g| {
                        MAX_HIT_BYTES * g.hits.len() as u64 + MAX_TERM_BYTES * g.terms.len() as u64
                    })
                    .sum();
                if held + most <= set.cache_budget {
                    let packed: Vec<(Links, Gathered)> = slice
                        .par_iter()
                        .zip(more)
                        .map(|(&(i, _, _), mut g)| {
                            (links[i as usize].extended(&mut g, &resolve), g)
                        })
                        .collect();
                    for (&(i, _, _), (l, g)) in slice.iter().zip(packed) {
                        let i = i as usize;
                        held = held + l.held() - links[i].held();
                        links[i] = l;
                        gathered[i].merge(&g);
                        refined[i] = true;
                    }
                    continue;
                }
                for (&(i, _, _), mut g) in slice.iter().zip(more) {
                    let i = i as usize;
                    // A ray's hit packs into ~2 bytes and a glossy term into ~8.
                    let adds = 2 * g.hits.len() as u64 + 8 * g.terms.len() as u64;
                    if held + adds <= set.cache_budget {
                        let before = links[i].held();
                        links[i].extend(&mut g, &resolve);
                        held = held + links[i].held() - before;
                    } else {
                        links[i].freeze(&mut g, &resolve, &lr);
                        stats.frozen_rays += g.gathering_rays as u64;
                    }
                    gathered[i].merge(&g);
                    refined[i] = true;
                }
            }
            stats.rounds = round;
            let read = Read {
                sums: &sums,
                kept: &kept,
            };
            iterate(
                &mut lr,
                &links,
                &gathered,
                &albedo,
                Some(read),
                set,
                &mut stats,
                progress,
            )?;
            (error, sums) = relative_errors(&lr, &links, &gathered, &albedo, &emission);
        }
    }
    stats.refined = refined.iter().filter(|&&r| r).count() as u64;
    stats.rays_cast = gathered.iter().map(|g| g.rays).sum();
    stats.cache_bytes = links.iter().map(Links::bytes).sum();
    stats.cache_terms_bytes = links.iter().map(|l| l.terms.bytes()).sum();
    let mut valid: Vec<f64> = error
        .iter()
        .zip(&gathered)
        .filter(|(_, g)| !g.inside)
        .map(|(e, _)| e.error())
        .collect();
    valid.sort_by(f64::total_cmp);
    if !valid.is_empty() {
        let pick = |q: f64| valid[((valid.len() - 1) as f64 * q).round() as usize];
        stats.error_median = pick(0.5);
        stats.error_p95 = pick(0.95);
        stats.error_max = valid[valid.len() - 1];
    }

    // Exitant radiance per texel: the resolved element's emission + reflection (for a
    // textured material, reflection over its texture's texel mean: scene::texturing).
    let exitant: Vec<Vec3> = surfaces
        .iter()
        .zip(&lr)
        .map(|(s, l)| stored_radiance(s, *l))
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

/// An element's gathering rays resolved to the elements they read.
struct Links {
    /// The elements the rays read, in increasing order, as LEB128 gaps (the first from 0):
    /// about 2 bytes a ray instead of 4. Rays that read nothing (a miss, a back face, a chart
    /// with no valid element) are only counted in `rays`.
    hits: Vec<u8>,
    /// Gathering rays, those that read nothing included (the mean's denominator).
    rays: u32,
    /// Elements reached through glossy reflection, with weights (packed, exact).
    terms: PackedTerms,
    /// Refinement rays read once instead of cached (over the cache budget).
    frozen: Frozen,
}

/// Sums of rays read once against the reflected radiance of their gathering's time
/// ([`SolveSettings::cache_budget`]).
#[derive(Clone, Copy, Debug, Default)]
struct Frozen {
    /// Gathering rays (those that read nothing included).
    rays: u32,
    /// Σ over the rays' reads (hits and glossy terms) of the radiance read.
    sum: [f64; 3],
    /// Σ and Σ² of the reads' luminance (for the error estimate, read by read as the links').
    u: f64,
    u2: f64,
}

impl Links {
    /// Heap bytes held.
    fn bytes(&self) -> u64 {
        self.hits.capacity() as u64 + self.terms.bytes()
    }

    /// Bytes the links hold, by length (what the budget counts: independent of the
    /// allocator).
    fn held(&self) -> u64 {
        self.hits.len() as u64 + self.terms.len_bytes()
    }

    /// Reads `g`'s rays once against `lr` and adds them to the frozen sums, leaving `g`'s
    /// hits and terms empty.
    fn freeze(&mut self, g: &mut Gathered, resolve: &[u32], lr: &[Vec3]) {
        let f = &mut self.frozen;
        let raw = std::mem::take(&mut g.hits);
        f.rays += raw.len() as u32;
        let mut read = |l: Vec3| {
            f.sum[0] += l.x as f64;
            f.sum[1] += l.y as f64;
            f.sum[2] += l.z as f64;
            let v = luminance(l) as f64;
            f.u += v;
            f.u2 += v * v;
        };
        for h in raw.into_iter().filter(|&h| h != u32::MAX) {
            let e = resolve[h as usize];
            if e != u32::MAX {
                read(lr[e as usize]);
            }
        }
        for t in std::mem::take(&mut g.terms) {
            let e = resolve[t.texel as usize];
            if e != u32::MAX {
                read(t.weight * lr[e as usize]);
            }
        }
    }

    /// The links of `g`'s rays, moved out of it.
    fn take(g: &mut Gathered, resolve: &[u32]) -> Links {
        let mut l = Links {
            hits: Vec::new(),
            rays: 0,
            terms: PackedTerms::default(),
            frozen: Frozen::default(),
        };
        l.extend(g, resolve);
        l
    }

    /// The elements the rays read, in increasing order (one per ray that reads one).
    fn hits(&self) -> impl Iterator<Item = u32> + '_ {
        let (mut at, mut last) = (0usize, 0u32);
        std::iter::from_fn(move || {
            last += varint::read(&self.hits, &mut at)? as u32;
            Some(last)
        })
    }

    /// Calls `f` with each element the rays read, in [`Self::hits`]' order: the loop every
    /// bounce runs over every link. Gaps of one and two bytes (nearly all) are read without a
    /// branch on their length, which mispredicts about every other gap.
    #[inline]
    fn for_each_hit(&self, mut f: impl FnMut(u32)) {
        let bytes = self.hits.as_slice();
        let (mut at, mut last) = (0usize, 0u32);
        while at < bytes.len() {
            let b0 = u32::from(bytes[at]);
            let b1 = u32::from(bytes.get(at + 1).copied().unwrap_or(0));
            let more = b0 >> 7;
            if more & (b1 >> 7) == 0 {
                last += (b0 & 0x7f) | (((b1 & 0x7f) << 7) * more);
                at += 1 + more as usize;
            } else {
                last += varint::read(bytes, &mut at).expect("links end on a whole varint") as u32;
            }
            f(last);
        }
    }

    /// Adds the links of `g`'s rays, moved out of it (exact capacity: the solve's memory is
    /// mostly these lists).
    fn extend(&mut self, g: &mut Gathered, resolve: &[u32]) {
        *self = self.extended(g, resolve);
    }

    /// These links with `g`'s rays added, moved out of `g`.
    fn extended(&self, g: &mut Gathered, resolve: &[u32]) -> Links {
        let resolved = |h: u32| {
            if h == u32::MAX {
                u32::MAX
            } else {
                resolve[h as usize]
            }
        };
        let raw = std::mem::take(&mut g.hits);
        let rays = self.rays + raw.len() as u32;
        let mut hits: Vec<u32> = self.hits().collect();
        hits.extend(raw.iter().map(|&h| resolved(h)).filter(|&e| e != u32::MAX));
        drop(raw);
        hits.sort_unstable();
        let mut packed = Vec::with_capacity(hits.len() * 3);
        let mut last = 0u32;
        for h in hits {
            varint::push(&mut packed, u64::from(h - last));
            last = h;
        }
        packed.shrink_to_fit();
        let mut terms = self.terms.clone();
        terms.extend(std::mem::take(&mut g.terms).into_iter().filter_map(|t| {
            let texel = resolved(t.texel);
            (texel != u32::MAX).then_some(Term { texel, ..t })
        }));
        Links {
            hits: packed,
            rays,
            terms,
            frozen: self.frozen,
        }
    }
}

/// Σ over an element's cached links of the radiance they read from `lr`: its hits in order,
/// then its glossy terms (frozen rays apart). The one order the bounces and the estimate both
/// sum in, so that a sum the estimate read is the bounce's to the bit.
fn links_sum(links: &Links, lr: &[Vec3]) -> [f64; 3] {
    let mut sum = [0.0f64; 3];
    links.for_each_hit(|h| {
        let l = lr[h as usize];
        sum[0] += l.x as f64;
        sum[1] += l.y as f64;
        sum[2] += l.z as f64;
    });
    links.terms.for_each(|texel, weight| {
        let l = weight * lr[texel as usize];
        sum[0] += l.x as f64;
        sum[1] += l.y as f64;
        sum[2] += l.z as f64;
    });
    sum
}

/// What the last error estimate read ([`relative_errors`]): each element's [`links_sum`] of
/// the `lr` a refinement round's bounces start from, and whether the round left the
/// element's links as they were (then its first bounce reads the sum instead of its links).
#[derive(Clone, Copy)]
struct Read<'a> {
    sums: &'a [[f64; 3]],
    kept: &'a [bool],
}

/// Jacobi iteration of L_r = ρ·(direct + mean incoming L_r) from `lr`, until a bounce changes
/// the total by less than the tolerance or the bounces run out. With `read`, the first bounce
/// takes the sums of the elements it keeps from it (same `lr`, same links: same bits).
#[allow(clippy::too_many_arguments)]
fn iterate(
    lr: &mut Vec<Vec3>,
    links: &[Links],
    gathered: &[Gathered],
    albedo: &[Vec3],
    mut read: Option<Read>,
    set: &SolveSettings,
    stats: &mut SolveStats,
    progress: &dyn Progress,
) -> Result<(), Cancelled> {
    progress.phase("bouncing", set.bounces as u64);
    for _ in 0..set.bounces {
        if progress.cancelled() {
            return Err(Cancelled);
        }
        let first = read.take();
        let next: Vec<Vec3> = (0..links.len())
            .into_par_iter()
            .map(|i| {
                // What `links_sum` adds, in its order.
                let mut sum = match first {
                    Some(r) if r.kept[i] => r.sums[i],
                    _ => {
                        let mut sum = [0.0f64; 3];
                        // Read as f32 and widened per read (exact): half the bytes of a
                        // widened copy, which the random reads keep in cache better.
                        links[i].for_each_hit(|h| {
                            let l = lr[h as usize];
                            sum[0] += l.x as f64;
                            sum[1] += l.y as f64;
                            sum[2] += l.z as f64;
                        });
                        links[i].terms.for_each(|texel, weight| {
                            let l = weight * lr[texel as usize];
                            sum[0] += l.x as f64;
                            sum[1] += l.y as f64;
                            sum[2] += l.z as f64;
                        });
                        sum
                    }
                };
                let frozen = &links[i].frozen;
                if frozen.rays > 0 {
                    for (s, f) in sum.iter_mut().zip(frozen.sum) {
                        *s += f;
                    }
                }
                let n = (links[i].rays + frozen.rays).max(1) as f64;
                let incoming = Vec3::new(
                    (sum[0] / n) as f32,
                    (sum[1] / n) as f32,
                    (sum[2] / n) as f32,
                );
                albedo[i] * (gathered[i].direct() + incoming)
            })
            .collect();
        let (mut change, mut total) = (0.0f64, 0.0f64);
        for (a, b) in lr.iter().zip(&next) {
            change += luminance((*b - *a).abs()) as f64;
            total += luminance(*b) as f64;
        }
        *lr = next;
        stats.bounces += 1;
        stats.last_change = if total > 0.0 { change / total } else { 0.0 };
        progress.advance(1);
        if stats.last_change < set.tolerance as f64 {
            break;
        }
    }
    Ok(())
}

/// An element's estimated relative variance of D (luminance), in the three parts that fall at
/// different rates as rays and emitter samples are added.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct ErrorParts {
    /// From the texel values its gathering rays read: the rays are a prefix of one
    /// low-discrepancy sequence, so this part falls as rays^-3/2.
    sequence: f64,
    /// From what its rays bring back besides texel values (emission hit, glossy paths, which
    /// draw at random): falls as 1/rays.
    random: f64,
    /// From its emitter samples (and the emitters' images in mirrors): falls as 1/samples.
    light: f64,
}

impl ErrorParts {
    /// The relative standard error.
    fn error(self) -> f64 {
        (self.sequence + self.random + self.light).sqrt()
    }

    /// The rays' parts with the rays multiplied by `x`.
    fn rays_at(self, x: f64) -> f64 {
        self.sequence * x.powf(-1.5) + self.random / x
    }

    /// The factor x ≥ 1 on the rays at which their parts fall to `v` (the root of
    /// sequence·x^-3/2 + random·x^-1 = v).
    fn rays_to(self, v: f64) -> f64 {
        if self.rays_at(1.0) <= v {
            return 1.0;
        }
        // Each part alone would need at most its own root; together, at most twice that.
        let (mut lo, mut hi) = (
            1.0f64,
            2.0 * ((self.sequence / v).powf(2.0 / 3.0) + self.random / v),
        );
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if self.rays_at(mid) > v {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        hi
    }

    /// The factors (x on the rays, y on the emitter samples, each ≥ 1) that bring the error to
    /// `target` at the least cost, a factor x costing `ray_cost`·x and y `light_cost`·y: the
    /// emitter samples' part is bought with emitter samples and the rays' with rays, in the
    /// mix that costs least (the cost is convex in x along the target's curve).
    fn factors_to(self, target: f64, ray_cost: f64, light_cost: f64) -> (f64, f64) {
        let t2 = target * target;
        if self.error() <= target {
            return (1.0, 1.0);
        }
        if self.light <= 0.0 {
            return (self.rays_to(t2), 1.0);
        }
        if self.rays_at(1.0) <= 0.0 {
            return (1.0, self.light / t2);
        }
        let y_at = |x: f64| (self.light / (t2 - self.rays_at(x))).max(1.0);
        let cost = |x: f64| ray_cost * x + light_cost * y_at(x);
        // From just past where the rays alone reach the target to where the samples need
        // no more (or, when they always do, where the rays' parts are a thousandth of it).
        let lo = self.rays_to(t2) * (1.0 + 1e-9);
        let hi = if self.light < t2 {
            self.rays_to(t2 - self.light)
        } else {
            self.rays_to(1e-3 * t2)
        }
        .max(lo);
        // Golden-section search for the least cost.
        let g = 0.5 * (5f64.sqrt() - 1.0);
        let (mut a, mut b) = (lo, hi);
        for _ in 0..80 {
            let (c, d) = (b - g * (b - a), a + g * (b - a));
            if cost(c) <= cost(d) {
                b = d;
            } else {
                a = c;
            }
        }
        let x = 0.5 * (a + b);
        (x, y_at(x))
    }
}

/// Each element's estimated relative variance of D (luminance), in [`ErrorParts`]: the
/// variance over its rays of the texel values they read directly (from `lr`) over rays^3/2 (a
/// low-discrepancy sequence's rate where the integrand has edges, as the texels seen do); what
/// the rest of their return adds to the per-ray variance (glossy terms, the rays' own emission
/// and glossy light), over rays; its emitter samples' variance; all scaled by the albedo, over
/// D². Elements inside geometry get 0. With each element's [`links_sum`] of `lr`, read in the
/// same pass ([`Read`]).
fn relative_errors(
    lr: &[Vec3],
    links: &[Links],
    gathered: &[Gathered],
    albedo: &[Vec3],
    emission: &[Vec3],
) -> (Vec<ErrorParts>, Vec<[f64; 3]>) {
    // Each element's luminance once rather than once per ray that reads it.
    let lum: Vec<f64> = lr.par_iter().map(|l| luminance(*l) as f64).collect();
    (0..links.len())
        .into_par_iter()
        .map(|i| {
            let g = &gathered[i];
            let mut sum = [0.0f64; 3];
            if g.inside {
                return (ErrorParts::default(), links_sum(&links[i], lr));
            }
            let frozen = &links[i].frozen;
            let n = (links[i].rays + frozen.rays).max(1) as f64;
            let per_ray = |s: f64, s2: f64| {
                if n > 1.0 {
                    (s2 / n - (s / n).powi(2)).max(0.0) * n / (n - 1.0)
                } else {
                    0.0
                }
            };
            let (mut u, mut u2) = (0.0f64, 0.0f64);
            // `sum` adds what `links_sum` adds, in its order.
            links[i].for_each_hit(|h| {
                let l = lr[h as usize];
                sum[0] += l.x as f64;
                sum[1] += l.y as f64;
                sum[2] += l.z as f64;
                let v = lum[h as usize];
                u += v;
                u2 += v * v;
            });
            // The texel values the rays read directly: a function of each ray's direction.
            let reads = per_ray(u, u2);
            links[i].terms.for_each(|texel, weight| {
                let l = weight * lr[texel as usize];
                sum[0] += l.x as f64;
                sum[1] += l.y as f64;
                sum[2] += l.z as f64;
                let v = luminance(l) as f64;
                u += v;
                u2 += v * v;
            });
            if frozen.rays > 0 {
                u += frozen.u;
                u2 += frozen.u2;
            }
            // Everything the rays bring back, glossy paths (drawn at random) included.
            let (c, c2) = (g.moments.ray_const, g.moments.ray_const2);
            let all = per_ray(u + c, u2 + c2 + 2.0 * (u / n) * c);
            let rho = luminance(albedo[i]) as f64;
            let sequence = rho * rho * reads / n.powf(1.5);
            let random = rho * rho * (all - reads).max(0.0) / n;
            let light = rho * rho * g.moments.light_var;
            let d = luminance(emission[i] + lr[i]) as f64;
            let parts = if sequence + random + light == 0.0 {
                ErrorParts::default()
            } else if d > 0.0 {
                ErrorParts {
                    sequence: sequence / (d * d),
                    random: random / (d * d),
                    light: light / (d * d),
                }
            } else {
                ErrorParts {
                    sequence: f64::INFINITY,
                    random: f64::INFINITY,
                    light: f64::INFINITY,
                }
            };
            (parts, sum)
        })
        .unzip()
}

/// Fits the added samples `which` (each element's want, from [`more_samples`]) into `budget`
/// (what is left of [`REFINE_BUDGET`]) and takes them from it. When they do not fit, each
/// element is brought to c·√(area × per-ray variance) rays for the one c that spends the
/// budget, within what it wants: the split that minimises the area-weighted squared error
/// (Σ aᵢVᵢ/nᵢ for Σ nᵢ fixed), so small texels (contact boosts) and nearly converged ones
/// no longer take rays in proportion to their want. Deterministic: the sums are integers.
fn share_budget(
    which: &mut Vec<(u32, u32, u32)>,
    error: &[f64],
    gathered: &[Gathered],
    area: &[f64],
    budget: &mut u64,
) {
    let total: u64 = which.iter().map(|w| w.1 as u64).sum();
    if total > *budget {
        // (have, weight) per wanting element: nᵢ·eᵢ² is its per-ray relative variance.
        let weights: Vec<(f64, f64)> = which
            .iter()
            .map(|&(i, _, _)| {
                let have = gathered[i as usize].gathering_rays as f64;
                let w = (area[i as usize] * have).sqrt() * error[i as usize];
                (have, if w.is_finite() { w } else { f64::MAX })
            })
            .collect();
        let adds = |c: f64| -> Vec<u32> {
            which
                .iter()
                .zip(&weights)
                .map(|(w, &(have, weight))| {
                    ((c * weight).min(1e18) - have).clamp(0.0, w.1 as f64) as u32
                })
                .collect()
        };
        let spent = |a: &[u32]| a.iter().map(|&x| x as u64).sum::<u64>();
        // Bisection on c: the largest whose adds fit.
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        while spent(&adds(hi)) <= *budget && hi < 1e30 {
            hi *= 2.0;
        }
        for _ in 0..64 {
            let mid = 0.5 * (lo + hi);
            if spent(&adds(mid)) <= *budget {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let fitted = adds(lo);
        for (w, rays) in which.iter_mut().zip(fitted) {
            // Emitter samples asked with rays are cut with them; asked alone, they stay.
            if w.1 > 0 {
                w.2 = ((w.2 as u64 * rays as u64).div_ceil(w.1 as u64)) as u32;
            }
            w.1 = rays;
        }
        which.retain(|w| w.1 > 0 || w.2 > 0);
    }
    let used: u64 = which.iter().map(|w| w.1 as u64).sum();
    *budget -= used.min(*budget);
}

/// The elements whose error is above `target`, with the rays and emitter samples of their next
/// batch: each part of the error bought with its own samples at the least cost
/// ([`ErrorParts::factors_to`], times 1.1; a gathering ray costs the rays its path casts plus
/// one for its link, an emitter sample its shadow rays, as the element's batches so far
/// counted them), at least a quarter of what they have of whichever is added; rays within
/// [`MAX_SAMPLE_FACTOR`] × the first batch (at least [`MIN_SAMPLE_CAP`]), emitter samples
/// within [`LIGHT_CAP_FACTOR`] times that multiple of the first batch's.
fn more_samples(
    error: &[ErrorParts],
    gathered: &[Gathered],
    target: f32,
    rays: u32,
    light: u32,
) -> Vec<(u32, u32, u32)> {
    let target = target as f64;
    let max_rays = (rays as u64 * MAX_SAMPLE_FACTOR as u64).max(MIN_SAMPLE_CAP);
    let max_light = (max_rays * light as u64).div_ceil(rays as u64) * LIGHT_CAP_FACTOR;
    // What a factor f on `have` adds: at least a quarter of it, within `room`.
    let adding = |have: u64, f: f64, room: u64| -> u64 {
        if f <= 1.0 || room == 0 {
            return 0;
        }
        let add = (have as f64 * (f * 1.1 - 1.0)).ceil().min(room as f64) as u64;
        add.max(have / 4).min(room).max(1)
    };
    error
        .iter()
        .zip(gathered)
        .enumerate()
        .filter_map(|(i, (&p, g))| {
            let have = g.gathering_rays as u64;
            let have_light = g.light_samples as u64;
            let e = p.error();
            if g.inside || e.is_nan() || e <= target {
                return None;
            }
            let room = max_rays.saturating_sub(have);
            let light_room = max_light.saturating_sub(have_light);
            let (add, add_light) = if !e.is_finite() {
                (
                    room,
                    (room * light as u64).div_ceil(rays as u64).min(light_room),
                )
            } else {
                let ray_cost = have as f64
                    * (1.0 + g.rays.saturating_sub(g.light_rays) as f64 / have.max(1) as f64);
                let light_cost = g.light_rays.max(1) as f64;
                let (x, y) = p.factors_to(target, ray_cost, light_cost);
                // Where one kind is at its cap, the other buys what it can of the rest.
                let t2 = target * target;
                let (x_cap, y_cap) = (
                    max_rays as f64 / have.max(1) as f64,
                    max_light as f64 / have_light.max(1) as f64,
                );
                // (A kind whose part is 0 cannot help.)
                let (x, y) = if y > y_cap && p.rays_at(1.0) > 0.0 {
                    let rest = t2 - p.light / y_cap;
                    (if rest > 0.0 { p.rays_to(rest) } else { x_cap }, y_cap)
                } else if x > x_cap && p.light > 0.0 {
                    let rest = t2 - p.rays_at(x_cap);
                    (x_cap, if rest > 0.0 { p.light / rest } else { y_cap })
                } else {
                    (x, y)
                };
                (adding(have, x, room), adding(have_light, y, light_room))
            };
            if add == 0 && add_light == 0 {
                return None;
            }
            Some((
                i as u32,
                add.min(u32::MAX as u64) as u32,
                add_light.min(u32::MAX as u64) as u32,
            ))
        })
        .collect()
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

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::{
        ErrorParts, Gathered, Links, MAX_SAMPLE_FACTOR, MIN_SAMPLE_CAP, more_samples, share_budget,
    };
    use crate::radiosity::gather::Moments;

    fn gathered(hits: Vec<u32>) -> Gathered {
        Gathered {
            emitted: Vec3::ZERO,
            glossy: Vec3::ZERO,
            gathering_rays: hits.len() as u32,
            hits,
            terms: Vec::new(),
            inside: false,
            rays: 0,
            light_rays: 0,
            light_samples: 1,
            moments: Moments::default(),
        }
    }

    #[test]
    fn links_keep_every_read_hit_once_sorted_and_count_every_ray() {
        // Texel → element: texel 3 lies in a chart with no valid element.
        let big = u32::MAX - 1;
        let resolve = |t: u32| match t {
            3 => u32::MAX,
            9 => big,
            t => t * 1000,
        };
        let texels = 10u32;
        let map: Vec<u32> = (0..texels).map(resolve).collect();
        let mut g = gathered(vec![5, u32::MAX, 0, 3, 9, 5, 1, 2]);
        let mut l = Links::take(&mut g, &map);
        assert!(g.hits.is_empty(), "the gathered hits move into the links");
        assert_eq!(l.rays, 8);
        assert_eq!(
            l.hits().collect::<Vec<_>>(),
            [0, 1000, 2000, 5000, 5000, big]
        );
        // A refinement batch merges in order; gaps of every LEB128 length read back.
        let mut more = gathered(vec![7, 8, 0, u32::MAX]);
        l.extend(&mut more, &map);
        assert_eq!(l.rays, 12);
        assert_eq!(
            l.hits().collect::<Vec<_>>(),
            [0, 0, 1000, 2000, 5000, 5000, 7000, 8000, big]
        );
        let mut each = Vec::new();
        l.for_each_hit(|h| each.push(h));
        assert_eq!(each, [0, 0, 1000, 2000, 5000, 5000, 7000, 8000, big]);
        assert!(l.hits.len() < 9 * 4, "packed: {} bytes", l.hits.len());
        // No ray reads anything: nothing stored, every ray still counted.
        let l = Links::take(&mut gathered(vec![u32::MAX; 5]), &map);
        assert_eq!((l.rays, l.hits().count(), l.hits.len()), (5, 0, 0));
    }

    #[test]
    fn each_part_of_the_error_falls_at_its_own_rate() {
        let t = 0.02f64;
        let parts = |sequence: f64, random: f64, light: f64| ErrorParts {
            sequence,
            random,
            light,
        };
        // The sequence's part alone: (e/t)^(4/3) more rays (error ∝ rays^-3/4), not (e/t)².
        let seq = parts(0.08f64.powi(2), 0.0, 0.0);
        let (x, y) = seq.factors_to(t, 1.0, 1.0);
        assert!(
            (x - 4f64.powf(4.0 / 3.0)).abs() < 1e-6 && y == 1.0,
            "{x} {y}"
        );
        // The rays' random part alone: (e/t)² more rays, no more emitter samples.
        let random = parts(0.0, 0.08f64.powi(2), 0.0);
        assert_eq!(random.factors_to(t, 1.0, 1.0).1, 1.0);
        assert!((random.factors_to(t, 1.0, 1.0).0 - 16.0).abs() < 1e-6);
        // The emitter samples' part alone: (e/t)² more samples and no more rays.
        let light = parts(0.0, 0.0, 0.08f64.powi(2));
        assert_eq!(light.factors_to(t, 1.0, 1.0), (1.0, 16.0));
        // Both rays' parts: the factor brings their sum to the target.
        let both = parts(0.06f64.powi(2), 0.04f64.powi(2), 0.0);
        let x = both.rays_to(t * t);
        let at = both.rays_at(x);
        assert!((at - t * t).abs() < 1e-9 * t * t, "{x}: {at}");
        assert!((both.error() - 0.0052f64.sqrt()).abs() < 1e-12);
        // Already at the target: nothing more.
        assert_eq!(parts(1e-4, 1e-4, 1e-4).factors_to(t, 1.0, 1.0), (1.0, 1.0));
        // All three: the pair reaches the target, and costs least along it (moving the rays'
        // factor either way, with the samples that then reach the target, costs more).
        let all = parts(0.03f64.powi(2), 0.03f64.powi(2), 0.04f64.powi(2));
        for (ray_cost, light_cost) in [(1.0, 1.0), (1.0, 10.0), (10.0, 1.0)] {
            let (x, y) = all.factors_to(t, ray_cost, light_cost);
            let reached = all.rays_at(x) + all.light / y;
            assert!((reached - t * t).abs() < 1e-6 * t * t, "{x} {y}: {reached}");
            let cost = |x: f64| ray_cost * x + light_cost * all.light / (t * t - all.rays_at(x));
            for dx in [0.98, 1.02] {
                assert!(cost(x * dx) > cost(x), "{ray_cost}/{light_cost}: x {x}");
            }
        }
        // Dearer samples buy more rays.
        let (cheap, _) = all.factors_to(t, 1.0, 1.0);
        let (dear, _) = all.factors_to(t, 1.0, 10.0);
        assert!(dear > cheap, "{cheap} {dear}");
    }

    #[test]
    fn an_element_far_above_the_target_asks_for_at_most_eight_times_its_first_batch() {
        // The default preset's first batch: 256 rays, 128 emitter samples. Element 0's error
        // is its rays' random part at ten times the target (a hundredfold batch would reach
        // it); element 1's its emitter samples' at ten times; element 2's its rays' a little
        // above the target; element 3 is below it.
        let first = |n: usize| {
            let mut g = gathered(vec![0; n]);
            g.light_samples = n as u32 / 2;
            (g.rays, g.light_rays) = (2 * n as u64, n as u64);
            g
        };
        let have = [first(256), first(256), first(256), first(256)];
        let t = 0.015f64;
        let random = |e: f64| ErrorParts {
            random: e * e,
            ..Default::default()
        };
        let light = |e: f64| ErrorParts {
            light: e * e,
            ..Default::default()
        };
        let error = [
            random(10.0 * t),
            light(10.0 * t),
            random(1.2 * t),
            random(0.9 * t),
        ];
        let which = more_samples(&error, &have, t as f32, 256, 128);
        assert_eq!(MAX_SAMPLE_FACTOR, 8);
        // Capped: the first batch and the added rays together are 8 × 256; no samples.
        assert_eq!(which[0], (0, 7 * 256, 0), "{which:?}");
        // Emitter samples alone, capped at 8 × 128.
        assert_eq!(which[1], (1, 0, 7 * 128), "{which:?}");
        // Under the cap the ask brings the error to the target, times 1.1: 1.44 × 1.1.
        assert_eq!(which[2], (2, 150, 0), "{which:?}");
        assert_eq!(which.len(), 3, "{which:?}");
        // At the cap, nothing more, however far above the target.
        let capped = || {
            let mut g = first(8 * 256);
            g.light_samples = 8 * 128;
            g
        };
        let at_cap = [capped(), capped()];
        assert!(more_samples(&error[..2], &at_cap, t as f32, 256, 128).is_empty());
        // A coarse first batch (32 rays, 4 emitter samples) may go on to the floor's 2048.
        assert_eq!(MIN_SAMPLE_CAP, 2048);
        let coarse = more_samples(&error[..1], &[first(32)], t as f32, 32, 4);
        assert_eq!(coarse, [(0, 2048 - 32, 0)]);
    }

    #[test]
    fn refinement_spends_its_budget_by_area_times_variance_within_each_want() {
        let have = |n: usize| gathered(vec![0; n]);
        let gathered = [have(100), have(100), have(100), have(100)];
        // Element 1 is a quarter-area texel (a contact boost), element 2 has half the error;
        // element 3 wants little.
        let error = [0.1, 0.1, 0.05, 0.1];
        let area = [1.0, 0.25, 1.0, 1.0];
        let wants = vec![(0, 1000, 100), (1, 1000, 100), (2, 1000, 100), (3, 20, 2)];
        // √(a·n)·e: 1, 0.5, 0.5, 1; each brought to c·weight rays, capped at its want: with
        // element 3 at its 20, 2c − 300 = 580, c = 440.
        let mut which = wants.clone();
        let mut budget = 600;
        share_budget(&mut which, &error, &gathered, &area, &mut budget);
        let rays: Vec<u32> = which.iter().map(|w| w.1).collect();
        assert!(rays[0].abs_diff(340) <= 1, "{rays:?}");
        assert!(rays[1].abs_diff(120) <= 1 && rays[1] == rays[2], "{rays:?}");
        assert_eq!(rays[3], 20);
        assert!(budget <= 3, "left {budget}");
        // Light samples scale with the rays.
        assert_eq!(which[0].2, (100 * rays[0]).div_ceil(1000));
        // Nothing left, nothing added.
        let mut none = wants.clone();
        share_budget(&mut none, &error, &gathered, &area, &mut 0);
        assert!(none.is_empty());
        // Within the budget every want is met.
        let mut fits = wants.clone();
        let mut big = 5000;
        share_budget(&mut fits, &error, &gathered, &area, &mut big);
        assert_eq!((fits, big), (wants, 5000 - 3020));
    }
}
