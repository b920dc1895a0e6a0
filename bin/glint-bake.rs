//! `glint-bake`: bake every stage a scene requires into one bundle, skipping the rest.

use std::io::Write;
use std::process::ExitCode;

use anyhow::Context;
use clap::Parser;
use glint::bake::materials::{self, MaterialsSettings};
use glint::bake::srdm_stage::{self, SrdmSettings};
use glint::bake::{Stage, plan, radiance_stage, radiosity_stage, scene_stage, up_to_date};
use glint::bundle::stats::format_table;
use glint::cli::BakeArgs;
use glint::progress::TerminalProgress;
use glint::scene::Scene;
use glint::scene::desc::RadiositySettings;

#[derive(Parser)]
#[command(
    name = "glint-bake",
    version,
    about = "Bake every stage a scene requires into a bundle, in dependency order; stages a scene does not need are skipped with the reason, stages already up to date are left alone",
    after_help = "Example:\n  glint-bake scenes/cornell-box/scene.json --bundle out/cornell-box.glint\n  glint-bundle stats out/cornell-box.glint"
)]
struct Args {
    #[command(flatten)]
    bake: BakeArgs,
}

fn main() -> ExitCode {
    glint::cli::init_logging();
    glint::cli::exit_code(run(Args::parse().bake))
}

fn run(args: BakeArgs) -> anyhow::Result<ExitCode> {
    let scene = Scene::load(&args.scene)?;
    log::info!(
        "{}: {} triangles, {} materials, {} reflectors, {} impostors",
        scene.name,
        scene.triangles.len(),
        scene.materials.len(),
        scene.reflectors.len(),
        scene.impostors.len()
    );
    let quality = args.quality.unwrap_or(scene.desc.bake.quality);
    glint::bundle::check_scene(&args.bundle, &scene.content_hash, args.force)?;
    // One reporter for the whole run: it owns the process's only Ctrl-C handler.
    let progress = TerminalProgress::new();
    let mut report = Vec::new();
    for p in plan(&scene) {
        let status = if !p.needed {
            "skipped".to_string()
        } else {
            match p.stage {
                Stage::Scene => {
                    if up_to_date(&args.bundle, &scene, p.stage, None) {
                        "up to date".into()
                    } else {
                        let rec = scene_stage::bake(&scene, &args.bundle, args.force)
                            .with_context(|| format!("stage {}", p.stage.name()))?;
                        format!("baked in {:.2} s", rec.bake_seconds)
                    }
                }
                Stage::Radiosity => {
                    let settings = RadiositySettings::resolve(quality, &scene.desc.bake.radiosity);
                    if up_to_date(
                        &args.bundle,
                        &scene,
                        p.stage,
                        Some(&radiosity_stage::settings_json(&settings)),
                    ) {
                        "up to date".into()
                    } else {
                        let rec = radiosity_stage::bake(
                            &scene,
                            &args.bundle,
                            &settings,
                            args.force,
                            &progress,
                        );
                        let rec = rec.with_context(|| format!("stage {}", p.stage.name()))?;
                        format!("baked in {:.2} s", rec.bake_seconds)
                    }
                }
                Stage::Radiance => {
                    let d_source = materials::d_identity(&args.bundle, &scene);
                    let settings =
                        radiance_stage::settings_json(&scene, quality, d_source.as_deref());
                    if up_to_date(&args.bundle, &scene, p.stage, Some(&settings)) {
                        "up to date".into()
                    } else {
                        let rec = radiance_stage::bake(
                            &scene,
                            &args.bundle,
                            quality,
                            args.force,
                            &progress,
                        );
                        let rec = rec.with_context(|| format!("stage {}", p.stage.name()))?;
                        format!("baked in {:.2} s", rec.bake_seconds)
                    }
                }
                Stage::Materials => {
                    let settings = MaterialsSettings::resolve(quality, &scene.desc.bake.materials)
                        .map_err(|(field, why)| {
                            anyhow::anyhow!("{}: field `{field}`: {why}", scene.path.display())
                        })?;
                    let recorded = materials::recorded_settings(
                        &settings,
                        materials::d_identity(&args.bundle, &scene).as_deref(),
                    );
                    if up_to_date(&args.bundle, &scene, p.stage, Some(&recorded)) {
                        "up to date".into()
                    } else {
                        let start = std::time::Instant::now();
                        let outcome =
                            materials::bake(&scene, &args.bundle, &settings, args.force, &progress);
                        match outcome.with_context(|| format!("stage {}", p.stage.name()))? {
                            materials::Outcome::Skipped(why) => format!("skipped: {why}"),
                            materials::Outcome::Baked(_) => {
                                format!("baked in {:.2} s", start.elapsed().as_secs_f64())
                            }
                        }
                    }
                }
                Stage::Srdm => {
                    let settings =
                        SrdmSettings::resolve(&scene.path, quality, &scene.desc.bake.srdm)?;
                    let colour = srdm_stage::colour_source(&args.bundle, &scene)?;
                    let recorded = srdm_stage::settings_json(&settings, colour.name());
                    if up_to_date(&args.bundle, &scene, p.stage, Some(&recorded)) {
                        "up to date".into()
                    } else {
                        let start = std::time::Instant::now();
                        let outcome = srdm_stage::bake(
                            &scene,
                            &args.bundle,
                            &settings,
                            args.force,
                            &progress,
                        );
                        match outcome.with_context(|| format!("stage {}", p.stage.name()))? {
                            srdm_stage::SrdmOutcome::Skipped { reason } => {
                                format!("skipped: {reason}")
                            }
                            srdm_stage::SrdmOutcome::Baked { .. } => {
                                format!("baked in {:.2} s", start.elapsed().as_secs_f64())
                            }
                        }
                    }
                }
            }
        };
        report.push((p, status));
    }
    progress.finish();
    let mut out = std::io::stdout().lock();
    if args.json {
        let v: Vec<_> = report
            .iter()
            .map(|(p, s)| serde_json::json!({ "stage": p.stage, "needed": p.needed, "status": s, "reason": p.reason }))
            .collect();
        writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(
                &serde_json::json!({ "bundle": args.bundle, "stages": v })
            )?
        )?;
    } else {
        let mut rows = vec![[
            "stage".to_string(),
            "needed".into(),
            "status".into(),
            "reason".into(),
        ]];
        rows.extend(report.iter().map(|(p, s)| {
            [
                p.stage.name().to_string(),
                if p.needed { "yes" } else { "no" }.into(),
                s.clone(),
                p.reason.clone(),
            ]
        }));
        writeln!(out, "{}: {}", scene.name, args.bundle.display())?;
        write!(
            out,
            "{}",
            format_table(&rows, &[false, false, false, false])
        )?;
    }
    Ok(ExitCode::SUCCESS)
}
