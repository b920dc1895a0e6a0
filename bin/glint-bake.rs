//! `glint-bake`: bake every stage a scene requires into one bundle, skipping the rest.

use std::io::Write;
use std::process::ExitCode;

use clap::Parser;
use glint::bake::{BakeSettings, StagePlan, StageStatus, bake_all};
use glint::bundle::stats::format_table;
use glint::cli::BakeArgs;
use glint::progress::TerminalProgress;
use glint::scene::Scene;

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
    let settings = BakeSettings::resolve(&scene, quality)?;
    // One reporter for the whole run: it owns the process's only Ctrl-C handler.
    let progress = TerminalProgress::new();
    let report = bake_all(&scene, &args.bundle, &settings, args.force, &progress);
    progress.finish();
    let report: Vec<(StagePlan, String)> = report?
        .into_iter()
        .map(|r| {
            let status = match &r.status {
                // A stage that found nothing to bake says why; a stage not needed says it
                // in the reason column.
                StageStatus::Skipped { reason } if *reason != r.plan.reason => {
                    format!("skipped: {reason}")
                }
                s => s.to_string(),
            };
            (r.plan, status)
        })
        .collect();
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
