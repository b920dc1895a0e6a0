//! The `radiosity` stage: atlas, solve, and the bundle's `radiosity/` folder.
//!
//! Writes `radiosity/page{N}.exr` (RGB half, linear exitant radiance D), a tone-mapped
//! `radiosity/page{N}.png` preview per page, and `radiosity/atlas.bin`
//! ([`crate::radiosity::format`]).

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use crate::bundle::{BundleError, StageInfo, StageRecord, StageWriter};
use crate::image_io::{self, ImageError};
use crate::progress::{Cancelled, Progress};
use crate::radiosity::atlas::{self, AtlasError};
use crate::radiosity::back_sides;
use crate::radiosity::format;
use crate::radiosity::seams;
use crate::radiosity::sides;
use crate::radiosity::solve::{
    GatherBatch, RAY_CACHE_BUDGET, REFINE_BUDGET, Solution, SolveSettings, gather_batch, solve,
    solve_batches, solve_cached,
};
use crate::scene::Scene;
use crate::settings::radiosity::RadiositySettings;

use super::Stage;

/// Seed of every radiosity bake (recorded in the manifest).
pub const SEED: u64 = 0x6c69_6e74;

/// Why the radiosity stage failed.
#[derive(Debug, thiserror::Error)]
pub enum RadiosityError {
    /// Nothing emits light.
    #[error(
        "{}: the scene has no emitters (no `lights` in scene.json and no emissive glTF material): its radiosity would be black; add an area light",
        path.display()
    )]
    NoEmitters {
        /// scene.json.
        path: std::path::PathBuf,
    },
    /// The bake would not fit in memory.
    #[error(
        "texel density {density} texels/m with {rays} rays needs about {need_gib:.1} GiB ({texels:.0} texels), but {avail_gib:.1} GiB are available; lower --texel-density or --rays, or refine less (--target-error 0 turns refinement off)"
    )]
    TooBig {
        /// Requested density.
        density: f32,
        /// Rays per texel.
        rays: u32,
        /// Estimated texels.
        texels: f64,
        /// Estimated memory.
        need_gib: f64,
        /// Memory available.
        avail_gib: f64,
    },
    /// A setting out of range.
    #[error("{0}")]
    Setting(String),
    /// The atlas cannot be made.
    #[error(transparent)]
    Atlas(#[from] AtlasError),
    /// Encoding a page.
    #[error(transparent)]
    Image(#[from] ImageError),
    /// Writing the bundle.
    #[error(transparent)]
    Bundle(#[from] BundleError),
    /// Ctrl-C.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

/// Memory a bake needs at most, in bytes, for `texels` elements with `rays` cached hits each,
/// and, when refining towards a target error, up to [`REFINE_BUDGET`] times as many more,
/// their cache bounded by `cache_budget` bytes (rays beyond it are read once, not held).
pub fn memory_estimate(texels: f64, rays: u32, refine: bool, cache_budget: u64) -> f64 {
    // Cached hit ids (4 B per ray as gathered), per-element data, per-atlas-texel maps and
    // the solution.
    let first = texels * rays as f64 * 4.0;
    let more = if refine {
        (first * REFINE_BUDGET as f64).min(cache_budget as f64)
    } else {
        0.0
    };
    first + more + texels * 96.0 + texels * 2.0 * 40.0
}

/// The densities a radiosity bake of a scene uses, with what its estimates read.
#[derive(Debug)]
pub struct Density {
    /// The rule `settings` give the scene ([`base_rule`]), every
    /// density scaled down by [`Self::scale`].
    pub rule: atlas::DensityRule,
    /// The one factor on every density asked (1: as asked; less where the scene would have
    /// more than [`RadiositySettings::max_elements`]).
    pub scale: f32,
    /// The scene's charts as the estimates read them (made once per bake).
    shapes: atlas::ChartShapes,
}

impl Density {
    /// Estimated atlas texels under [`Self::rule`], before contact boosts
    /// ([`atlas::estimate_texels`]).
    pub fn texels(&self) -> f64 {
        self.shapes.texels(self.rule)
    }
}

/// How the atlas sizes the charts of a scene whose longest side is `scene_side` metres under
/// `s`, before any scaling down to [`RadiositySettings::max_elements`].
pub fn base_rule(s: &RadiositySettings, scene_side: f32) -> atlas::DensityRule {
    atlas::DensityRule {
        per_metre: s.scene_density(scene_side),
        min_across: s.min_chart_texels as f32,
        per_radian: s.texels_per_radian,
    }
}

/// The most by which contact boosts may multiply the atlas's texels under `s`.
pub fn contact_texel_factor(s: &RadiositySettings) -> f64 {
    if s.contact_boost > 1.0 {
        crate::radiosity::contacts::TEXEL_BUDGET
    } else {
        1.0
    }
}

/// The [`Density`] `settings` give `scene`.
pub fn density_rule(
    scene: &Scene,
    settings: &RadiositySettings,
) -> Result<Density, RadiosityError> {
    let rule = base_rule(settings, scene.bounds.longest_side());
    if settings.max_elements == 0 {
        return Ok(Density {
            rule,
            scale: 1.0,
            shapes: atlas::ChartShapes::new(&scene.triangles, rule),
        });
    }
    let shapes = atlas::ChartShapes::with_charts(&scene.triangles);
    let factor = contact_texel_factor(settings);
    let (rule, scale) = match atlas::fit_elements(
        &shapes,
        rule,
        factor,
        settings.max_elements as f64,
    ) {
        Some(s) if s >= 1.0 => (rule, 1.0),
        Some(s) => (rule.scaled(s), s),
        None => {
            return Err(RadiosityError::Setting(format!(
                "`max_elements` {}: the scene's charts need about {:.0} elements even a texel or two across each; raise `max_elements` (0: no limit)",
                settings.max_elements,
                shapes.elements(rule.scaled(atlas::MIN_FIT_SCALE)) * factor,
            )));
        }
    };
    Ok(Density {
        rule,
        scale,
        shapes,
    })
}

/// Memory the ray cache adds to a bake through it ([`Gathering::Cached`]), in bytes: the prior
/// bake's cache, read, beside this bake's, built (its file is streamed from it), each bounded by
/// [`RAY_CACHE_BUDGET`], at about 10 bytes a gathering ray as packed
/// ([`crate::radiosity::ray_cache`]).
pub fn ray_cache_memory(texels: f64, rays: u32, refine: bool) -> f64 {
    let rounds = if refine {
        1.0 + REFINE_BUDGET as f64
    } else {
        1.0
    };
    2.0 * (texels * rays as f64 * rounds * 10.0).min(RAY_CACHE_BUDGET as f64)
}

/// Bytes of memory available to this process (Linux `MemAvailable`), if known.
pub fn available_memory() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024.0)
}

/// Checks settings and memory before anything is allocated; the densities the bake uses.
pub fn check(scene: &Scene, s: &RadiositySettings) -> Result<Density, RadiosityError> {
    check_share(scene, s, 1.0, false)
}

/// [`check`] for a bake that holds `share` of the elements' gathered rays (a gathering unit),
/// and with `cached` a ray cache ([`ray_cache_memory`]).
fn check_share(
    scene: &Scene,
    s: &RadiositySettings,
    share: f64,
    cached: bool,
) -> Result<Density, RadiosityError> {
    if !scene.has_emitters() {
        return Err(RadiosityError::NoEmitters {
            path: scene.path.clone(),
        });
    }
    s.check(Some(scene.bounds.diagonal()))
        .map_err(|e| RadiosityError::Setting(e.to_string()))?;
    let density = density_rule(scene, s)?;
    let texels = density.texels() * contact_texel_factor(s);
    let refine = s.target_error.is_some();
    let mut need = memory_estimate(texels, s.rays, refine, s.cache_budget()) * share;
    if cached {
        need += ray_cache_memory(texels, s.rays, refine);
    }
    if let Some(avail) = available_memory()
        && need > avail
    {
        let gib = (1u64 << 30) as f64;
        return Err(RadiosityError::TooBig {
            density: density.rule.per_metre,
            rays: s.rays,
            texels,
            need_gib: need / gib,
            avail_gib: avail / gib,
        });
    }
    Ok(density)
}

/// The settings as recorded in the manifest (with the seed), for up-to-date checks.
pub fn settings_json(settings: &RadiositySettings) -> serde_json::Value {
    let mut v = serde_json::to_value(settings).expect("settings serialize");
    v["seed"] = SEED.into();
    // The rule that decides which texels lie inside geometry: a D baked before texels that see
    // the room through a gap kept their own light reads as stale.
    v["inside_open_limit"] = crate::radiosity::solve::OPEN_LIMIT.into();
    v
}

/// What a radiosity or gathering stage records.
fn stage_info(
    scene: &Scene,
    settings: &RadiositySettings,
    stats: BTreeMap<String, serde_json::Value>,
    start: Instant,
    force: bool,
) -> StageInfo {
    StageInfo {
        scene_name: scene.name.clone(),
        scene_hash: scene.content_hash.clone(),
        settings: settings_json(settings),
        stats,
        bake_seconds: start.elapsed().as_secs_f64(),
        force,
    }
}

/// Where a radiosity bake's first gathering batch comes from.
#[derive(Clone, Copy, Debug, Default)]
pub enum Gathering<'a> {
    /// Gathered here, every element.
    #[default]
    Here,
    /// Read from the `gather` stages of these bundles (the gathering units' shards, in
    /// order), whose batches tile the elements.
    From(&'a [std::path::PathBuf]),
    /// Gathered here through the ray cache in this file (`crate::radiosity::ray_cache`):
    /// the rays an earlier bake kept there that the scene's changes do not touch are reused,
    /// and the file is replaced by this bake's.
    Cached(&'a Path),
}

/// Stage name of a gathering unit's shard (not a stage of a whole bundle).
pub const GATHER_STAGE: &str = "gather";
/// Its one asset, in its stage folder.
pub const GATHER_ASSET: &str = "elements.bin";

/// Bakes the radiosity of `scene` into the bundle at `bundle`.
pub fn bake(
    scene: &Scene,
    bundle: &Path,
    settings: &RadiositySettings,
    force: bool,
    progress: &dyn Progress,
) -> Result<StageRecord, RadiosityError> {
    bake_from(scene, bundle, settings, force, Gathering::Here, progress)
}

/// The scene the solve works on: `scene` itself, or a copy with the twins of the back sides
/// that get texels of their own ([`back_sides`]) after its triangles; and the ray-casting BVH
/// of `scene`'s own triangles (twins are reached through the atlas, never hit).
struct Sided {
    bvh: crate::geometry::Bvh,
    backs: Vec<u32>,
    twinned: Option<Scene>,
}

impl Sided {
    fn of(scene: &Scene) -> Sided {
        let bvh = scene.build_bvh();
        let backs = back_sides::open_backs(scene, &bvh);
        let twinned = (!backs.is_empty()).then(|| {
            log::info!(
                "back sides: {} triangles of open double-sided sheets get texels of their own",
                backs.len()
            );
            Scene {
                triangles: sides::with_twins(&scene.triangles, &backs),
                ..scene.clone()
            }
        });
        Sided {
            bvh,
            backs,
            twinned,
        }
    }

    /// [`Sided::of`], with `density` ([`check_share`] of `scene` at `(share, cached)`)
    /// checked again when back sides add texels: they count towards the density's and the
    /// memory's limits.
    fn checked(
        scene: &Scene,
        settings: &RadiositySettings,
        (share, cached): (f64, bool),
        density: Density,
    ) -> Result<(Sided, Density), RadiosityError> {
        let sided = Sided::of(scene);
        let density = match &sided.twinned {
            Some(t) => check_share(t, settings, share, cached)?,
            None => density,
        };
        Ok((sided, density))
    }
}

/// What every radiosity bake and gathering unit computes before gathering.
struct Prepared {
    bvh: crate::geometry::Bvh,
    atlas: atlas::Atlas,
    samples: Vec<atlas::TexelSample>,
    solve: SolveSettings,
}

/// The atlas (with `backs`, whose twins end `scene`'s triangles) and the solve's settings.
fn prepare(
    scene: &Scene,
    bvh: crate::geometry::Bvh,
    backs: Vec<u32>,
    settings: &RadiositySettings,
    density: Density,
) -> Result<Prepared, RadiosityError> {
    let Density { rule, scale, .. } = density;
    if scale < 1.0 {
        log::info!(
            "texel density {:.2} per metre ({:.3} × every density asked): the scene would have more than `max_elements` = {} elements",
            rule.per_metre,
            scale,
            settings.max_elements
        );
    } else if rule.per_metre != settings.texel_density {
        log::info!(
            "texel density {:.1} per metre: the scene's longest side, {:.2} m, gets `min_scene_texels` = {} texels",
            rule.per_metre,
            scene.bounds.longest_side(),
            settings.min_scene_texels
        );
    }
    let (mut atlas, samples, boosts) =
        crate::radiosity::contacts::build(scene, &bvh, rule, settings.contact_boost)?;
    atlas.backs = backs;
    if boosts.charts > 0 {
        log::info!(
            "contacts: {} texels ask for up to {}× the density; {} charts raised, {} → {} texels",
            boosts.asking,
            settings.contact_boost,
            boosts.charts,
            boosts.texels.0,
            atlas.texel_count()
        );
    }
    if samples.is_empty() {
        return Err(RadiosityError::Setting(format!(
            "`texel_density`: {} texels per metre gives no element",
            settings.texel_density
        )));
    }
    log::info!(
        "atlas: {} charts on {} page(s), {} elements",
        atlas.charts,
        atlas.pages.len(),
        samples.len()
    );
    let solve = SolveSettings::new(settings, SEED);
    Ok(Prepared {
        bvh,
        atlas,
        samples,
        solve,
    })
}

/// The elements gathering unit `k` of `n` gathers: the `k`-th of `n` near-equal runs of the
/// atlas's elements (chart order, so a run is a range of charts and pages).
pub fn gather_range(elements: usize, k: usize, n: usize) -> std::ops::Range<u32> {
    let at = |i: usize| (elements as u64 * i as u64 / n.max(1) as u64) as u32;
    at(k)..at(k + 1)
}

/// Gathers the first batch of unit `k` of `n` ([`gather_range`]) into the `gather` stage of
/// the shard at `shard`.
pub fn bake_gather(
    scene: &Scene,
    shard: &Path,
    settings: &RadiositySettings,
    (k, n): (usize, usize),
    progress: &dyn Progress,
) -> Result<StageRecord, RadiosityError> {
    let start = Instant::now();
    // A first batch only: no refinement rays.
    let first = RadiositySettings {
        target_error: None,
        ..settings.clone()
    };
    let share = 1.0 / n.max(1) as f64;
    let density = check_share(scene, &first, share, false)?;
    let mut w = StageWriter::begin(shard, GATHER_STAGE)?;
    let (sided, density) = Sided::checked(scene, &first, (share, false), density)?;
    let scene = sided.twinned.as_ref().unwrap_or(scene);
    let p = prepare(scene, sided.bvh, sided.backs, settings, density)?;
    let range = gather_range(p.samples.len(), k, n);
    let batch = gather_batch(
        scene,
        &p.bvh,
        &p.atlas,
        &p.samples,
        &p.solve,
        range.clone(),
        progress,
    )?;
    w.write(GATHER_ASSET, "radiosity-gather", &batch.encode(&p.samples))?;
    let stats = BTreeMap::from([
        ("elements".to_string(), p.samples.len().into()),
        ("first".into(), range.start.into()),
        ("end".into(), range.end.into()),
    ]);
    Ok(w.commit(stage_info(scene, settings, stats, start, true))?)
}

/// Reads the gathering batches of `shards` (one at a time: the file and the batch are not
/// held together longer than one shard).
fn read_batches(
    shards: &[std::path::PathBuf],
    p: &Prepared,
) -> Result<Vec<GatherBatch>, RadiosityError> {
    let mut out = Vec::with_capacity(shards.len());
    for shard in shards {
        let bad = |why: String| {
            RadiosityError::Setting(format!("{}: gathering shard: {why}", shard.display()))
        };
        let bytes = crate::bundle::Bundle::open(shard)
            .and_then(|b| b.read_stage_file(GATHER_STAGE, GATHER_ASSET))
            .map_err(|e| bad(e.to_string()))?;
        out.push(
            GatherBatch::decode(&bytes, &p.atlas, &p.samples).map_err(|e| bad(e.to_string()))?,
        );
    }
    let mut next = 0u32;
    for (b, shard) in out.iter().zip(shards) {
        if b.range.start != next {
            return Err(RadiosityError::Setting(format!(
                "{}: gathers elements {}..{}, but the next batch must start at element {next}",
                shard.display(),
                b.range.start,
                b.range.end
            )));
        }
        next = b.range.end;
    }
    if next as usize != p.samples.len() {
        return Err(RadiosityError::Setting(format!(
            "the gathering shards cover elements 0..{next} of {}",
            p.samples.len()
        )));
    }
    Ok(out)
}

/// The ray cache in `file`; `None` (and a warning when it is damaged) when there is none.
fn read_ray_cache(file: &Path) -> Option<crate::radiosity::ray_cache::RayCache> {
    let bytes = match std::fs::read(file) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return None,
        Err(e) => {
            log::warn!("{}: cannot read the ray cache: {e}", file.display());
            return None;
        }
    };
    crate::radiosity::ray_cache::RayCache::decode(&bytes)
        .inspect_err(|e| log::warn!("{}: {e}; gathering every ray", file.display()))
        .ok()
}

/// [`bake`], with the first gathering batch from `gathering`.
pub fn bake_from(
    scene: &Scene,
    bundle: &Path,
    settings: &RadiositySettings,
    force: bool,
    gathering: Gathering<'_>,
    progress: &dyn Progress,
) -> Result<StageRecord, RadiosityError> {
    let start = Instant::now();
    let cached = matches!(gathering, Gathering::Cached(_));
    let density = check_share(scene, settings, 1.0, cached)?;
    crate::bundle::check_scene(bundle, &scene.name, &scene.content_hash, force)?;
    // Before the compute: a bundle that cannot be written fails now.
    let w = StageWriter::begin(bundle, Stage::Radiosity.name())?;
    progress.phase("building the atlas", 1);
    let (sided, density) = Sided::checked(scene, settings, (1.0, cached), density)?;
    let scene = sided.twinned.as_ref().unwrap_or(scene);
    let p = prepare(scene, sided.bvh, sided.backs, settings, density)?;
    progress.advance(1);
    // The ray cache to write, while the rest of the stage runs: (file, cache).
    let mut keep_rays = None;
    let mut solution = match gathering {
        Gathering::Here => solve(scene, &p.bvh, &p.atlas, &p.samples, &p.solve, progress)?,
        Gathering::Cached(file) => {
            let prior = read_ray_cache(file);
            let (solution, cache, _) = solve_cached(
                scene,
                &p.bvh,
                &p.atlas,
                &p.samples,
                &p.solve,
                prior,
                RAY_CACHE_BUDGET,
                progress,
            )?;
            match cache {
                Some(cache) => keep_rays = Some((file, cache)),
                // An earlier bake's cache would only be read and found stale: free its disk.
                None => match std::fs::remove_file(file) {
                    Ok(()) => {}
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                    Err(e) => log::warn!("{}: cannot remove: {e}", file.display()),
                },
            }
            solution
        }
        Gathering::From(shards) => {
            let batches = read_batches(shards, &p)?;
            solve_batches(
                scene, &p.bvh, &p.atlas, &p.samples, &p.solve, batches, progress,
            )?
        }
    };
    // The cache is encoded and written (and synced) on a thread of its own, beside the seams
    // and the pages: its write is serial and mostly waits on the disk.
    std::thread::scope(|s| {
        let writer = keep_rays.map(|(file, cache)| {
            s.spawn(move || {
                let mut bytes = 0;
                crate::bundle::writer::write_atomic_with(file, |f| {
                    bytes = cache.write_to(f)?;
                    Ok(())
                })?;
                drop(cache);
                log::info!(
                    "ray cache: {} ({:.1} MB)",
                    file.display(),
                    bytes as f64 / 1e6
                );
                Ok::<(), RadiosityError>(())
            })
        });
        let record = finish(
            scene,
            settings,
            &p,
            &mut solution,
            w,
            start,
            force,
            progress,
        );
        if let Some(writer) = writer {
            writer
                .join()
                .expect("the ray cache's writer does not panic")?;
        }
        record
    })
}

/// The rest of [`bake_from`] once D is solved: seams, pages, atlas and the stage's record.
#[allow(clippy::too_many_arguments)]
fn finish(
    scene: &Scene,
    settings: &RadiositySettings,
    p: &Prepared,
    solution: &mut Solution,
    mut w: StageWriter,
    start: Instant,
    force: bool,
    progress: &dyn Progress,
) -> Result<StageRecord, RadiosityError> {
    let (atlas, samples) = (&p.atlas, &p.samples);
    if settings.stitch_seams {
        progress.phase("stitching seams", 1);
    }
    let seam = settings
        .stitch_seams
        .then(|| seams::stitch_seams(&scene.triangles, atlas, samples, &mut solution.radiance));
    if settings.stitch_seams {
        progress.advance(1);
    }
    if progress.cancelled() {
        return Err(Cancelled.into());
    }

    progress.phase("writing radiosity", atlas.pages.len() as u64);
    let mut offset = 0usize;
    for (i, page) in atlas.pages.iter().enumerate() {
        let n = (page.width * page.height) as usize;
        let texels = &solution.radiance[offset..offset + n];
        offset += n;
        let exr = image_io::encode_rgb_exr(page.width as usize, page.height as usize, texels)?;
        w.write(&format!("page{i}.exr"), "radiosity-exr", &exr)?;
        let png = image_io::encode_png(
            page.width,
            page.height,
            &image_io::tonemap_preview(texels),
            false,
        )?;
        w.write(&format!("page{i}.png"), "preview-png", &png)?;
        progress.advance(1);
    }
    w.write("atlas.bin", "atlas", &format::encode(atlas))?;

    let st = &solution.stats;
    let mut stats = BTreeMap::from([
        ("pages".to_string(), atlas.pages.len().into()),
        ("charts".into(), atlas.charts.into()),
        ("atlas_texels".into(), atlas.texel_count().into()),
        ("back_sides".into(), atlas.backs.len().into()),
        ("elements".into(), st.elements.into()),
        ("elements_inside_geometry".into(), st.excluded.into()),
        ("texels_filled".into(), st.filled.into()),
        ("rays_cast".into(), st.rays_cast.into()),
        ("gather_cache_bytes".into(), st.cache_bytes.into()),
        (
            "gather_cache_terms_bytes".into(),
            st.cache_terms_bytes.into(),
        ),
        ("gather_frozen_rays".into(), st.frozen_rays.into()),
        ("bounces".into(), st.bounces.into()),
        ("last_change".into(), st.last_change.into()),
        ("refine_rounds".into(), st.rounds.into()),
        ("texels_refined".into(), st.refined.into()),
        ("error_median".into(), st.error_median.into()),
        ("error_p95".into(), st.error_p95.into()),
        ("error_max".into(), st.error_max.into()),
        (
            "uv_source".into(),
            if atlas.from_uv1 {
                "TEXCOORD_1"
            } else {
                "generated"
            }
            .into(),
        ),
    ]);
    if let Some(seam) = seam {
        for (key, v) in [
            ("seam_jump_p95_before", seam.before.p95),
            ("seam_jump_p95_after", seam.after.p95),
            ("seam_jump_max_after", seam.after.max),
            ("seam_jump_bspline_p95_after", seam.after_bspline.p95),
            ("seam_texel_noise_median", seam.noise.median),
        ] {
            stats.insert(key.into(), v.into());
        }
        stats.insert("seam_edges".into(), seam.edges.into());
        stats.insert(
            "seam_stitch_iterations".into(),
            seam.stitch.iterations.into(),
        );
    }
    Ok(w.commit(stage_info(scene, settings, stats, start, force))?)
}

#[cfg(test)]
mod tests {
    use super::{gather_range, ray_cache_memory, settings_json};
    use crate::radiosity::solve::RAY_CACHE_BUDGET;

    /// A bake through the ray cache holds two caches, each within its budget.
    #[test]
    fn the_ray_cache_adds_two_caches_to_a_bake_within_its_budget() {
        let small = ray_cache_memory(10_000.0, 64, false);
        assert!(small > 2.0 * 10_000.0 * 64.0 * 4.0, "{small}");
        assert!(ray_cache_memory(10_000.0, 64, true) > small);
        let huge = ray_cache_memory(1e9, 256, true);
        assert_eq!(huge, 2.0 * RAY_CACHE_BUDGET as f64);
    }
    use crate::settings::Quality;
    use crate::settings::radiosity::RadiositySettings;

    /// A stage is up to date only when its recorded settings, read back from the manifest,
    /// equal what it would record now: every preset's numbers must survive the round trip
    /// (0.015 as f64 did not, without serde_json's correctly rounded parsing).
    #[test]
    fn recorded_settings_read_back_equal_at_every_preset() {
        for q in [Quality::Draft, Quality::Default, Quality::High] {
            let recorded = settings_json(&RadiositySettings::preset(q));
            let text = serde_json::to_string(&recorded).unwrap();
            let back: serde_json::Value = serde_json::from_str(&text).unwrap();
            assert_eq!(back, recorded, "{} preset: {text}", q.name());
        }
    }

    #[test]
    fn gathering_runs_tile_the_elements_in_order() {
        for (elements, n) in [(0, 2), (1, 2), (7, 3), (10_000, 7), (5, 5), (3, 8)] {
            let mut next = 0;
            for k in 0..n {
                let r = gather_range(elements, k, n);
                assert_eq!(r.start, next, "{elements} in {n}");
                // Near-equal: no run differs from another by more than one element.
                assert!(r.len() <= elements.div_ceil(n) && r.len() >= elements / n);
                next = r.end;
            }
            assert_eq!(next as usize, elements);
        }
    }
}
