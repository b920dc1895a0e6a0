//! The `materials` stage: how each glossy material reflects (Bastos et al. §8.2, Luksch et
//! al. §3–7), baked for every material that has a glossy lobe and covers some triangle.
//!
//! Per lobe of such a material (`materials/<material>/lobe<k>-…`):
//! - `kernel.exr` (kind `kernel`): K, D·G over the reflected image, sums to 1 ([`crate::materials::kernel`]);
//! - `reflectance.exr` (kind `reflectance-sphere`): R and the albedo A as a sphere map;
//! - `reflectance-1d.exr` (kind `reflectance-1d`, isotropic lobes): the same as a 1D map
//!   dense at grazing angles ([`crate::materials::reflectance`]);
//! - `pattern.bin` (kind `sample-pattern`): the regular pattern closest to the sample budget
//!   ([`crate::materials::pattern_format`] specifies the file).
//!
//! Per `curved` reflector with a glossy material (`materials/env/<reflector>/mip<ℓ>.exr`,
//! kind `env-mip`): the cube map seen from its centroid, shaded with D, rays going on through
//! near-mirror planar reflectors and other glossy surfaces adding what they reflect of D
//! ([`ENV_CAPTURE`]), and its MIP levels
//! ([`crate::materials::envmap`]). These need the bundle's `radiosity` stage; without it they are skipped with
//! the reason and the rest of the stage is baked.
//!
//! Per reflection probe the scene needs (`materials/probes/<probe>/mip<ℓ>.exr`, kind
//! `env-mip`; [`crate::materials::probes`]): the same capture from the probe's point, its MIP
//! levels, level 0 with the distance to what each texel sees. Skipped, as environment maps
//! are, without D.
//!
//! `materials/index.json` (kind `materials-index`, [`crate::materials::index`]) lists
//! everything with its parameters.
//! EXR channels are f32 for K and R (exact sums, large grazing values), half for env maps.
//! The bake is deterministic: every work item is a pure function of the scene and settings,
//! results are gathered in order, so the bytes do not depend on the thread count.
//!
//! The math lives in [`crate::materials`]; this module runs the steps in order: choose the
//! materials ([`lobes::chosen_materials`]), bake their lobes (`lobes::bake_lobes`), write
//! them (`lobes::write_materials`), the environment maps (`env_maps::write_env_maps`), the
//! index, then commit.

mod env_maps;
mod lobes;
mod probes;
mod report;

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use glam::Vec3;

pub use crate::materials::MaterialsSettings;
pub use report::{EnvReport, LobeReport, MaterialReport, Outcome, Report};

use crate::bundle::{BundleError, StageInfo, StageWriter};
use crate::geometry::Hit;
use crate::image_io::ImageError;
use crate::materials::index::{INDEX_FILE, INDEX_FORMAT, MaterialsIndex};
use crate::progress::{Cancelled, Progress};
use crate::radiosity::CurrentD;
use crate::radiosity::RadiosityMap;
use crate::radiosity::sides::Sides;
use crate::scene::Scene;

use super::part::{Item, Part};
use super::{Stage, plan};
pub use env_maps::curved_glossy_reflectors;
pub use lobes::chosen_materials;
pub use probes::probe_folders;

/// Why the materials stage failed.
#[derive(Debug, thiserror::Error)]
pub enum MaterialsError {
    /// A setting in scene.json is out of range.
    #[error("{}: field `{field}`: {message}", path.display())]
    Setting {
        /// scene.json.
        path: std::path::PathBuf,
        /// Dotted field path.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// Writing the bundle.
    #[error(transparent)]
    Bundle(#[from] BundleError),
    /// Encoding an image.
    #[error("{path}: {source}")]
    Image {
        /// Asset path.
        path: String,
        /// Cause.
        source: ImageError,
    },
    /// Stopped by the user.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

/// Shades an environment-map ray hit: the radiance leaving the hit point towards the capture
/// point (D, the diffuse radiosity, for glint's bakes). It reads the hit's point alone (its
/// triangle and barycentrics, not its distance): the stage evaluates its captures' records
/// with it ([`crate::materials::capture_reads`]).
pub type HitShader = Box<dyn Fn(&Hit) -> Vec3 + Send + Sync>;

/// A shader for environment maps with the identity of what it reads (recorded in the
/// stage's settings so a changed D makes the stage out of date).
pub struct EnvShading {
    /// The shader.
    pub shade: HitShader,
    /// The back sides its D has: a hit's triangle may be a twin ([`Sides::side`]).
    pub sides: Sides,
    /// Identity of its data (e.g. a hash of the radiosity stage's assets).
    pub source: String,
}

/// ════════════════════════════════════════════════════════════════════════════════════════
/// THE ONE PLACE WHERE THE MATERIALS STAGE READS D ([`crate::radiosity::current`] says
/// which D is current).
///
/// Environment maps are shaded with D, the radiosity baked into the bundle's `radiosity`
/// stage: [`crate::radiosity::RadiosityMap`] at the hit (exitant radiance, emission
/// included; quad area lights are not geometry, so no hit is on one: the capture adds those
/// a ray crosses, [`crate::materials::envmap::capture_cube`]). Returns the shader, or why environment maps cannot be baked: no radiosity stage,
/// one baked from another scene, or one that cannot be read. The stage then skips the
/// environment maps, says why, and bakes the rest. `source` (a hash of the radiosity
/// assets) goes into the stage's settings, so a re-baked D makes this stage out of date.
/// ════════════════════════════════════════════════════════════════════════════════════════
pub fn shade_with_d(bundle_dir: &Path, scene: &Scene) -> Result<EnvShading, String> {
    let missing = || {
        format!(
            "{}: no `radiosity` stage (D) in the bundle: environment maps need it; bake it first (glint-radiosity), then re-run glint-materials",
            bundle_dir.display()
        )
    };
    let current = crate::radiosity::current_d(bundle_dir, &scene.content_hash)
        .map_err(|e| format!("cannot read the bundle for D: {e}"))?;
    if let CurrentD::OtherScene = current {
        return Err(format!(
            "{}: the `radiosity` stage was baked from another scene; re-bake it (glint-radiosity --force)",
            bundle_dir.display()
        ));
    }
    let (map, source) = current
        .load()
        .map_err(|e| format!("cannot read D from the `radiosity` stage: {e}"))?
        .ok_or_else(missing)?;
    Ok(EnvShading::with(scene, map, source))
}

impl EnvShading {
    /// Shading with D of `map` (identity `source`): at a textured surface, D at full texture
    /// resolution (scene::texturing), the texture read on the scene's triangle where the hit
    /// is on a twin.
    fn with(scene: &Scene, map: RadiosityMap, source: String) -> EnvShading {
        let textured = scene.textured_surfaces();
        let sides = map.atlas.sides();
        let fronts = sides.clone();
        EnvShading {
            shade: Box::new(move |hit: &Hit| {
                let stored = map.radiance(hit.triangle, hit.bary);
                match &textured {
                    Some(t) => {
                        let (triangle, bary) = fronts.front_of(hit.triangle, hit.bary);
                        t.d_at(triangle, bary, stored)
                    }
                    None => stored,
                }
            }),
            sides,
            source,
        }
    }
}

/// The settings the stage records in the manifest: `settings` plus `d_source`, the identity
/// of the D its environment maps were shaded with (null: none). For an up-to-date check:
/// `recorded_settings(&settings, crate::radiosity::d_identity(dir, &scene.content_hash).as_deref())`.
pub fn recorded_settings(
    settings: &MaterialsSettings,
    d_source: Option<&str>,
) -> serde_json::Value {
    let mut v = serde_json::to_value(settings).expect("settings serialize");
    v["d_source"] = d_source.into();
    v["env_capture"] = ENV_CAPTURE.into();
    v
}

/// How environment maps are captured, recorded in the stage's settings so that bundles
/// captured otherwise re-bake: 4, rays collect the scene.json area lights they cross
/// ([`crate::scene::Scene::lights_along`]); 3, glossy surfaces add what their lobes reflect
/// of D ([`crate::materials::envmap::ENV_GLOSSY_SAMPLES`] samples a ray); 2, rays go on
/// through near-mirror planar reflectors ([`crate::materials::envmap::capture_cube`]); 1,
/// absent: they stopped there, black.
pub const ENV_CAPTURE: u32 = 4;

/// Bakes the materials stage of `scene` into the bundle at `bundle_dir`, shading environment
/// maps with D from the bundle ([`shade_with_d`]).
pub fn bake(
    scene: &Scene,
    bundle_dir: &Path,
    settings: &MaterialsSettings,
    force: bool,
    progress: &dyn Progress,
) -> Result<Outcome, MaterialsError> {
    bake_part(scene, bundle_dir, settings, force, Part::whole(), progress)
}

/// [`bake`] of `part`: everything, one material's lobes ([`Item::Material`]: no environment
/// map) or one environment map ([`Item::EnvMap`]: no material), shaded with D from the
/// bundle written or from `part.d_from`. `materials/index.json` lists what was baked.
pub fn bake_part(
    scene: &Scene,
    bundle_dir: &Path,
    settings: &MaterialsSettings,
    force: bool,
    part: Part<'_>,
    progress: &dyn Progress,
) -> Result<Outcome, MaterialsError> {
    let (shading, d_read) = match (part.d_from, part.item) {
        (Some(from), _) => {
            let shading = crate::bake::part::require_d(from)
                .map(|(map, source)| EnvShading::with(scene, map, source))
                .map_err(|e| format!("cannot read D from {}: {e}", from.display()));
            (shading, None)
        }
        (None, Item::Material(_)) => (
            Err("environment maps are baked by their own work units".to_string()),
            None,
        ),
        (None, _) => {
            let shading = shade_with_d(bundle_dir, scene);
            // The D read: the commit refuses if another baker replaced it meanwhile.
            let d_read = shading.as_ref().ok().map(|s| s.source.clone());
            (shading, d_read)
        }
    };
    bake_reading(
        scene, bundle_dir, settings, force, shading, d_read, part.item, part.reads, progress,
    )
}

/// [`bake`] with the environment-map shading given: `Ok` shades hits, `Err` is the reason
/// environment maps are skipped. Tests and tools use it with their own shaders.
pub fn bake_with(
    scene: &Scene,
    bundle_dir: &Path,
    settings: &MaterialsSettings,
    force: bool,
    shading: Result<EnvShading, String>,
    progress: &dyn Progress,
) -> Result<Outcome, MaterialsError> {
    bake_reading(
        scene,
        bundle_dir,
        settings,
        force,
        shading,
        None,
        Item::All,
        None,
        progress,
    )
}

/// [`bake_with`] of `item`, where `d_read` is the identity of the radiosity stage the
/// shading read (checked again at the commit), keeping the captures' records in `reads`
/// (a probe's or an environment map's unit folder, [`crate::bake::read_cache`]).
#[allow(clippy::too_many_arguments)]
fn bake_reading(
    scene: &Scene,
    bundle_dir: &Path,
    settings: &MaterialsSettings,
    force: bool,
    shading: Result<EnvShading, String>,
    d_read: Option<String>,
    item: Item,
    reads: Option<&Path>,
    progress: &dyn Progress,
) -> Result<Outcome, MaterialsError> {
    let start = Instant::now();
    let step = plan(scene)
        .into_iter()
        .find(|p| p.stage == Stage::Materials)
        .expect("the plan lists every stage");
    if !step.needed {
        return Ok(Outcome::Skipped(step.reason));
    }
    // Before the compute: a bundle that cannot be written fails now.
    let mut w = StageWriter::begin(bundle_dir, Stage::Materials.name())?;
    if let Some(d) = &d_read {
        w.read_from(Stage::Radiosity.name(), d);
    }
    let all = lobes::chosen_materials(scene);
    // Folder names are made over every chosen material, so one material's unit names its
    // folder as the whole stage does.
    let folders =
        crate::bundle::unique_folders(all.iter().map(|&i| scene.materials[i].name.as_str()));
    let (chosen, folders): (Vec<usize>, Vec<String>) = all
        .iter()
        .zip(folders)
        .enumerate()
        .filter(|(k, _)| item.takes(Item::Material(*k)))
        .map(|(_, (&m, f))| (m, f))
        .unzip();
    let baked = lobes::bake_lobes(scene, &chosen, settings, progress)?;

    let mut stats: BTreeMap<String, serde_json::Value> = BTreeMap::new();
    let materials = lobes::write_materials(&mut w, scene, &chosen, &folders, &baked, &mut stats)?;
    let d_source = shading.as_ref().ok().map(|s| s.source.clone());
    let take_probe = |k: usize| item.takes(Item::Probe(k));
    let probes = probes::write_probes(
        &mut w,
        scene,
        settings,
        &shading,
        &take_probe,
        reads,
        progress,
        &mut stats,
    )?;
    let take_env = |k: usize| item.takes(Item::EnvMap(k));
    let env = env_maps::write_env_maps(
        &mut w, scene, settings, shading, &take_env, reads, progress, &mut stats,
    )?;
    let index = MaterialsIndex {
        format: INDEX_FORMAT.into(),
        version: 1,
        settings: settings.clone(),
        materials: materials.index,
        env_maps: env.index,
        env_maps_skipped: env.skipped.clone(),
        probes: probes.index,
        probes_skipped: probes.skipped.clone(),
    };
    w.write(INDEX_FILE, "materials-index", &index.to_bytes())?;

    stats.insert("materials".into(), chosen.len().into());
    stats.insert("lobes".into(), materials.lobes.into());
    stats.insert("env_maps".into(), env.reports.len().into());
    if let Some(reason) = &env.skipped {
        stats.insert("env_maps_skipped".into(), reason.clone().into());
    }
    // Only scenes that need probes say so: the others' records stay as they were.
    if !probes.reports.is_empty() {
        stats.insert("probes".into(), probes.reports.len().into());
    }
    if let Some(reason) = &probes.skipped {
        stats.insert("probes_skipped".into(), reason.clone().into());
    }
    let record = w.commit(StageInfo {
        scene_name: scene.name.clone(),
        scene_hash: scene.content_hash.clone(),
        settings: recorded_settings(settings, d_source.as_deref()),
        stats,
        bake_seconds: start.elapsed().as_secs_f64(),
        force,
    })?;
    Ok(Outcome::Baked(Box::new(Report {
        record,
        reason: step.reason,
        materials: materials.reports,
        env_maps: env.reports,
        env_maps_skipped: env.skipped,
        probes: probes.reports,
        probes_skipped: probes.skipped,
    })))
}
