//! The stage tools' one entry point. `glint-bake` and each single-stage tool
//! (`glint-radiosity`, `glint-materials`, `glint-radiance`, `glint-srdm`) turn their
//! arguments into a [`Tool`] and call [`run`]: it loads the scene, resolves the settings
//! (preset, then scene.json, then the flags, each checked by its settings type's `check`),
//! bakes the scene stage first where a single-stage tool needs it, bakes, and prints the
//! stage's report (its own table, or JSON).

use std::io::Write;
use std::process::ExitCode;

use anyhow::Context;

use super::materials::{self, MaterialsError, MaterialsSettings, Outcome};
use super::report::{BakeReport, SrdmViews};
use super::srdm_stage::{self, SrdmOutcome, SrdmSettings};
use super::written::Written;
use super::{BakeSettings, Stage, plan, radiance_stage, radiosity_stage};
use super::{scene_stage, up_to_date};
use crate::cli::BakeArgs;
use crate::progress::TerminalProgress;
use crate::scene::Scene;
use crate::settings::radiosity::{RadiosityOverride, RadiositySettings};
use crate::settings::srdm::SrdmOverride;
use crate::settings::{SettingError, sets};

/// Which tool runs, with its own flags (each overrides the preset and scene.json).
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Tool {
    /// Every stage the scene requires (`glint-bake`).
    #[default]
    All,
    /// The radiosity stage (`glint-radiosity`), with its flags (one per radiosity setting).
    Radiosity(RadiosityOverride),
    /// The materials stage (`glint-materials`).
    Materials,
    /// The radiance stage (`glint-radiance`).
    Radiance,
    /// The SRDM stage (`glint-srdm`), with its flags.
    Srdm(SrdmOverride),
}

/// A value refused by its settings type's check, named as given: a flag (`--texel-density:
/// 1e-30 …`) when `flags` set it, else scene.json's field (the scene loader checked those
/// already, under the scene's own preset).
fn setting_error<T: serde::Serialize>(
    scene: &Scene,
    stage: &str,
    flags: &T,
    e: SettingError,
) -> anyhow::Error {
    if sets(flags, e.field) {
        anyhow::anyhow!("{}: {}", e.flag(), e.message)
    } else {
        anyhow::anyhow!(
            "{}: field `bake.{stage}.{}`: {}",
            scene.path.display(),
            e.field,
            e.message
        )
    }
}

/// Runs `tool` with `args`, writing its report to `out`. Stopped by Ctrl-C, its error says
/// which stages it wrote ([`Written`]).
pub fn run(args: &BakeArgs, tool: Tool, out: &mut dyn Write) -> anyhow::Result<ExitCode> {
    let mut written = Written::snapshot(&[&args.bundle]);
    if matches!(tool, Tool::All) {
        written = written.with_unit_cache(super::incremental::cache_dir(&args.bundle));
    }
    run_tool(args, tool, out).map_err(|e| written.explain(e))
}

fn run_tool(args: &BakeArgs, tool: Tool, out: &mut dyn Write) -> anyhow::Result<ExitCode> {
    let scene = Scene::load(&args.options.scene)?;
    let quality = args.options.quality.unwrap_or(scene.desc.bake.quality);
    match tool {
        Tool::All => bake_every_stage(args, &scene, quality, out),
        Tool::Radiosity(flags) => {
            let over = [&scene.desc.bake.radiosity, &flags];
            let s = RadiositySettings::resolve(quality, &over, Some(scene.bounds.diagonal()))
                .map_err(|e| setting_error(&scene, "radiosity", &flags, e))?;
            radiosity_stage::check(&scene, &s)?;
            scene_stage_first(args, &scene)?;
            let progress = TerminalProgress::new();
            let record =
                radiosity_stage::bake(&scene, &args.bundle, &s, args.options.force, &progress);
            progress.finish();
            let record = record.context("stage radiosity")?;
            if args.options.json {
                writeln!(out, "{}", serde_json::to_string_pretty(&record)?)?;
            } else {
                writeln!(
                    out,
                    "{}: radiosity baked in {:.2} s ({} quality): {} elements, {} rays, {} bounces → {}",
                    scene.name,
                    record.bake_seconds,
                    quality.name(),
                    record.stats["elements"],
                    record.stats["rays_cast"],
                    record.stats["bounces"],
                    args.bundle.display()
                )?;
            }
            Ok(ExitCode::SUCCESS)
        }
        Tool::Materials => {
            let settings = MaterialsSettings::resolve(quality, &[&scene.desc.bake.materials])
                .map_err(|e| MaterialsError::Setting {
                    path: scene.path.clone(),
                    field: format!("bake.materials.{}", e.field),
                    message: e.message,
                })?;
            let progress = TerminalProgress::new();
            let outcome = materials::bake(
                &scene,
                &args.bundle,
                &settings,
                args.options.force,
                &progress,
            );
            progress.finish();
            match outcome.context("stage materials")? {
                Outcome::Skipped(reason) => skipped(args, &scene, Stage::Materials, &reason, out),
                Outcome::Baked(report) if args.options.json => {
                    let v = serde_json::json!({
                        "bundle": crate::lossy_path::json(&args.bundle), "stage": "materials", "status": "baked",
                        "quality": quality.name(), "bake_seconds": report.record.bake_seconds,
                        "report": &*report,
                    });
                    writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
                    Ok(ExitCode::SUCCESS)
                }
                Outcome::Baked(report) => {
                    writeln!(
                        out,
                        "{}: materials baked into {} in {:.2} s ({} quality; {})",
                        scene.name,
                        args.bundle.display(),
                        report.record.bake_seconds,
                        quality.name(),
                        report.reason
                    )?;
                    write!(out, "{report}")?;
                    Ok(ExitCode::SUCCESS)
                }
            }
        }
        Tool::Radiance => {
            let step = plan(&scene)
                .into_iter()
                .find(|p| p.stage == Stage::Radiance)
                .expect("radiance is planned");
            if !step.needed {
                writeln!(
                    out,
                    "{}: radiance stage skipped: {}",
                    scene.name, step.reason
                )?;
                return Ok(ExitCode::SUCCESS);
            }
            let progress = TerminalProgress::new();
            let record =
                radiance_stage::bake(&scene, &args.bundle, quality, args.options.force, &progress);
            progress.finish();
            let record = record.context("stage radiance")?;
            if args.options.json {
                writeln!(out, "{}", serde_json::to_string_pretty(&record)?)?;
            } else {
                writeln!(
                    out,
                    "{}: {} radiance maps baked in {:.2} s ({} quality) → {}",
                    scene.name,
                    record.stats["maps"],
                    record.bake_seconds,
                    quality.name(),
                    args.bundle.display()
                )?;
            }
            Ok(ExitCode::SUCCESS)
        }
        Tool::Srdm(flags) => {
            let s = SrdmSettings::resolve(quality, &[&scene.desc.bake.srdm, &flags])
                .map_err(|e| setting_error(&scene, "srdm", &flags, e))?;
            if scene.impostors.is_empty() {
                let reason = "no impostor objects declared (scene.json `impostors`)";
                return skipped(args, &scene, Stage::Srdm, reason, out);
            }
            scene_stage_first(args, &scene)?;
            let progress = TerminalProgress::new();
            let outcome = srdm_stage::bake(&scene, &args.bundle, &s, args.options.force, &progress);
            progress.finish();
            let (record, views, colour) = match outcome.context("stage srdm")? {
                SrdmOutcome::Skipped { reason } => {
                    writeln!(out, "{}: srdm skipped: {reason}", scene.name)?;
                    return Ok(ExitCode::SUCCESS);
                }
                SrdmOutcome::Baked {
                    record,
                    views,
                    colour,
                } => (record, views, colour),
            };
            if args.options.json {
                let v = serde_json::json!({ "stage": "srdm", "status": "baked", "record": record, "views": views });
                writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
                return Ok(ExitCode::SUCCESS);
            }
            writeln!(
                out,
                "{}: srdm baked in {:.2} s ({} quality: n = {}, m = {}, {}² texels; colour: {colour}) → {}",
                scene.name,
                record.bake_seconds,
                quality.name(),
                s.domains,
                s.points,
                s.resolution,
                args.bundle.display()
            )?;
            write!(out, "{}", SrdmViews(&views))?;
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// `glint-bake`: every stage the scene requires, then the stage table.
fn bake_every_stage(
    args: &BakeArgs,
    scene: &Scene,
    quality: crate::scene::Quality,
    out: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    log::info!(
        "{}: {} triangles, {} materials, {} reflectors, {} impostors",
        scene.name,
        scene.triangles.len(),
        scene.materials.len(),
        scene.reflectors.len(),
        scene.impostors.len()
    );
    let unused = super::plan::unused_declarations(scene);
    for u in &unused {
        log::warn!("{}: {u}", scene.path.display());
    }
    let settings = BakeSettings::resolve(scene, quality)?;
    // One reporter for the whole run: it owns the process's only Ctrl-C handler.
    let progress = TerminalProgress::new();
    let done = super::incremental::bake_incremental(
        scene,
        &args.bundle,
        &settings,
        args.options.force,
        &progress,
    );
    progress.finish();
    let done = done?;
    let report = BakeReport {
        scene: scene.name.clone(),
        bundle: args.bundle.clone(),
        stages: done.stages.clone(),
    };
    if args.options.json {
        let mut v = report.to_json();
        v["warnings"] = serde_json::to_value(&unused)?;
        v["units"] = serde_json::to_value(&done.units)?;
        v["assembled"] = done.assembled.into();
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
    } else {
        write!(out, "{report}")?;
    }
    Ok(ExitCode::SUCCESS)
}

/// A single-stage tool writes the scene stage first when the bundle lacks it (or holds
/// another scene's, with `--force`).
fn scene_stage_first(args: &BakeArgs, scene: &Scene) -> anyhow::Result<()> {
    crate::bundle::check_scene(
        &args.bundle,
        &scene.name,
        &scene.content_hash,
        args.options.force,
    )?;
    if !up_to_date(&args.bundle, scene, Stage::Scene, None) {
        scene_stage::bake(scene, &args.bundle, args.options.force).context("stage scene")?;
    }
    Ok(())
}

/// A stage with nothing to bake: one line, or JSON.
fn skipped(
    args: &BakeArgs,
    scene: &Scene,
    stage: Stage,
    reason: &str,
    out: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    if args.options.json {
        let v = serde_json::json!({
            "bundle": crate::lossy_path::json(&args.bundle), "stage": stage.name(), "status": "skipped", "reason": reason,
        });
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
    } else {
        writeln!(out, "{}: {} skipped: {reason}", scene.name, stage.name())?;
    }
    Ok(ExitCode::SUCCESS)
}
