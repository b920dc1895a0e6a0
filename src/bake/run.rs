//! Every stage a scene requires, baked in dependency order into one bundle: what
//! `glint-bake` runs, and what sweeps run once per setting.
//!
//! A stage the scene does not need is skipped with the reason; a stage already up to date
//! (same scene hash, settings, generator and, downstream of D, the same D) is left alone, so
//! a build script can call this on every build.

use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use super::materials::{self, MaterialsSettings};
use super::srdm_stage::{self, SrdmSettings};
use super::{Stage, StagePlan, plan, radiance_stage, radiosity_stage, scene_stage, up_to_date};
use crate::progress::Progress;
use crate::scene::Scene;
use crate::settings::radiosity::RadiositySettings;
use crate::settings::{Quality, SettingError};

/// The resolved settings of every stage: a preset, the scene's overrides, then (for sweeps)
/// single fields changed by hand. The radiance stage reads its settings from the preset and
/// the scene (`bake.radiance`, per-reflector `radiance`).
#[derive(Clone, Debug, PartialEq)]
pub struct BakeSettings {
    /// The preset (also the radiance stage's resolution and camera scale).
    pub quality: Quality,
    /// Radiosity.
    pub radiosity: RadiositySettings,
    /// Materials.
    pub materials: MaterialsSettings,
    /// SRDM.
    pub srdm: SrdmSettings,
}

impl BakeSettings {
    /// The preset `quality` with `scene`'s overrides, each stage's through its own `resolve`;
    /// an invalid override names scene.json and the field.
    pub fn resolve(scene: &Scene, quality: Quality) -> Result<BakeSettings, BakeError> {
        let over = &scene.desc.bake;
        let at = |stage: Stage| {
            move |e: SettingError| BakeError {
                stage,
                source: format!(
                    "{}: field `bake.{}.{}`: {}",
                    scene.path.display(),
                    stage.name(),
                    e.field,
                    e.message
                )
                .into(),
            }
        };
        let materials = MaterialsSettings::resolve(quality, &[&over.materials])
            .map_err(at(Stage::Materials))?;
        let srdm = SrdmSettings::resolve(quality, &[&over.srdm]).map_err(at(Stage::Srdm))?;
        let radiosity =
            RadiositySettings::resolve(quality, &[&over.radiosity], Some(scene.bounds.diagonal()))
                .map_err(at(Stage::Radiosity))?;
        Ok(BakeSettings {
            quality,
            radiosity,
            materials,
            srdm,
        })
    }
}

/// A stage that failed, and why.
#[derive(Debug, thiserror::Error)]
#[error("stage {}: {source}", stage.name())]
pub struct BakeError {
    /// The stage.
    pub stage: Stage,
    /// The stage's own error.
    #[source]
    pub source: Box<dyn std::error::Error + Send + Sync>,
}

/// What happened to one stage.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "status")]
pub enum StageStatus {
    /// The scene does not need it ([`StagePlan::reason`]), or the stage found nothing to
    /// bake (the reason).
    Skipped {
        /// One line.
        reason: String,
    },
    /// Already baked from this scene with these settings.
    UpToDate,
    /// Baked now.
    Baked {
        /// Wall-clock seconds.
        seconds: f64,
    },
}

impl std::fmt::Display for StageStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StageStatus::Skipped { .. } => f.write_str("skipped"),
            StageStatus::UpToDate => f.write_str("up to date"),
            StageStatus::Baked { seconds } => write!(f, "baked in {seconds:.2} s"),
        }
    }
}

/// One line of a bake's report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StageReport {
    /// Whether the scene needs the stage, and why.
    pub plan: StagePlan,
    /// What was done.
    pub status: StageStatus,
}

/// Bakes every stage `scene` requires into the bundle at `bundle`, in dependency order,
/// leaving stages that are up to date alone. `force` replaces stages baked from another
/// scene.
pub fn bake_all(
    scene: &Scene,
    bundle: &Path,
    settings: &BakeSettings,
    force: bool,
    progress: &dyn Progress,
) -> Result<Vec<StageReport>, BakeError> {
    crate::bundle::check_scene(bundle, &scene.name, &scene.content_hash, force).map_err(|e| {
        BakeError {
            stage: Stage::Scene,
            source: e.into(),
        }
    })?;
    let mut report = Vec::new();
    for p in plan(scene) {
        let status = if p.needed {
            bake_stage(scene, bundle, p.stage, settings, force, progress).map_err(|source| {
                BakeError {
                    stage: p.stage,
                    source,
                }
            })?
        } else {
            StageStatus::Skipped {
                reason: p.reason.clone(),
            }
        };
        report.push(StageReport { plan: p, status });
    }
    Ok(report)
}

type StageResult = Result<StageStatus, Box<dyn std::error::Error + Send + Sync>>;

fn bake_stage(
    scene: &Scene,
    bundle: &Path,
    stage: Stage,
    s: &BakeSettings,
    force: bool,
    progress: &dyn Progress,
) -> StageResult {
    let start = Instant::now();
    let baked = || StageStatus::Baked {
        seconds: start.elapsed().as_secs_f64(),
    };
    let fresh = |recorded: Option<&serde_json::Value>| up_to_date(bundle, scene, stage, recorded);
    Ok(match stage {
        Stage::Scene if fresh(None) => StageStatus::UpToDate,
        Stage::Scene => {
            scene_stage::bake(scene, bundle, force)?;
            baked()
        }
        Stage::Radiosity => {
            if fresh(Some(&radiosity_stage::settings_json(&s.radiosity))) {
                StageStatus::UpToDate
            } else {
                radiosity_stage::bake(scene, bundle, &s.radiosity, force, progress)?;
                baked()
            }
        }
        Stage::Materials => {
            let d = crate::radiosity::d_identity(bundle, &scene.content_hash);
            if fresh(Some(&materials::recorded_settings(
                &s.materials,
                d.as_deref(),
            ))) {
                StageStatus::UpToDate
            } else {
                match materials::bake(scene, bundle, &s.materials, force, progress)? {
                    materials::Outcome::Skipped(reason) => StageStatus::Skipped { reason },
                    materials::Outcome::Baked(_) => baked(),
                }
            }
        }
        Stage::Radiance => {
            let d = crate::radiosity::d_identity(bundle, &scene.content_hash);
            if fresh(Some(&radiance_stage::settings_json(
                scene,
                s.quality,
                d.as_deref(),
            ))) {
                StageStatus::UpToDate
            } else {
                radiance_stage::bake(scene, bundle, s.quality, force, progress)?;
                baked()
            }
        }
        Stage::Srdm => {
            // The colour the stage would read: D when the bundle has it from this scene.
            let d = crate::radiosity::d_identity(bundle, &scene.content_hash);
            let colour = if d.is_some() { "radiosity" } else { "albedo" };
            if fresh(Some(&srdm_stage::settings_json(
                &s.srdm,
                colour,
                d.as_deref(),
            ))) {
                StageStatus::UpToDate
            } else {
                match srdm_stage::bake(scene, bundle, &s.srdm, force, progress)? {
                    srdm_stage::SrdmOutcome::Skipped { reason } => StageStatus::Skipped { reason },
                    srdm_stage::SrdmOutcome::Baked { .. } => baked(),
                }
            }
        }
    })
}
