//! `glint-srdm`: bake depth-map impostors and their simplified rotated depth maps (SRDM).

use std::io::Write;
use std::process::ExitCode;

use anyhow::Context;
use clap::Parser;
use glint::bake::srdm_stage::{self, SrdmOutcome, SrdmSettings};
use glint::bake::{Stage, scene_stage, up_to_date};
use glint::bundle::stats::{format_table, human_bytes};
use glint::cli::BakeArgs;
use glint::progress::TerminalProgress;
use glint::scene::Scene;
use glint::srdm::{MAX_DOMAINS, MAX_POINTS, MAX_RESOLUTION};

#[derive(Parser)]
#[command(
    name = "glint-srdm",
    version,
    about = "Bake depth-map impostors and simplified rotated depth maps (Popescu et al. 2006 §4) for every impostor object of a scene",
    after_help = "Example:\n  glint-srdm scenes/bunny-mirror/scene.json --bundle out/bunny-mirror.glint -n 60 -m 16\n  glint-bundle stats out/bunny-mirror.glint\n\nSettings come from the preset, then the scene's `bake.srdm`, then these flags. Views per object are `impostors[].views` in scene.json. Colour is D when the bundle holds the radiosity stage, else the albedo (recorded as `colour`)."
)]
struct Args {
    #[command(flatten)]
    bake: BakeArgs,
    /// Rotated domains n (angular step 180°/n).
    #[arg(short = 'n', long = "domains", value_name = "DOMAINS",
          value_parser = clap::value_parser!(u32).range(1..=MAX_DOMAINS as i64))]
    domains: Option<u32>,
    /// Points per simplified row m.
    #[arg(short = 'm', long = "points", value_name = "POINTS",
          value_parser = clap::value_parser!(u32).range(2..=MAX_POINTS as i64))]
    points: Option<u32>,
    /// Depth-map resolution W (W × W texels).
    #[arg(long, value_name = "W",
          value_parser = clap::value_parser!(u32).range(2..=MAX_RESOLUTION as i64))]
    resolution: Option<u32>,
}

fn main() -> ExitCode {
    glint::cli::init_logging();
    glint::cli::exit_code(run(Args::parse()))
}

fn run(args: Args) -> anyhow::Result<ExitCode> {
    let b = &args.bake;
    let scene = Scene::load(&b.scene)?;
    let quality = b.quality.unwrap_or(scene.desc.bake.quality);
    let mut settings = SrdmSettings::resolve(&scene.path, quality, &scene.desc.bake.srdm)?;
    if let Some(v) = args.domains {
        settings.domains = v;
    }
    if let Some(v) = args.points {
        settings.points = v;
    }
    if let Some(v) = args.resolution {
        settings.resolution = v;
    }
    let mut out = std::io::stdout().lock();
    if scene.impostors.is_empty() {
        let reason = "no impostor objects declared (scene.json `impostors`)";
        if b.json {
            let v = serde_json::json!({ "stage": "srdm", "status": "skipped", "reason": reason });
            writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
        } else {
            writeln!(out, "{}: srdm skipped: {reason}", scene.name)?;
        }
        return Ok(ExitCode::SUCCESS);
    }
    glint::bundle::check_scene(&b.bundle, &scene.content_hash, b.force)?;
    if !up_to_date(&b.bundle, &scene, Stage::Scene, None) {
        scene_stage::bake(&scene, &b.bundle, b.force).context("stage scene")?;
    }
    let progress = TerminalProgress::new();
    let outcome = srdm_stage::bake(&scene, &b.bundle, &settings, b.force, &progress);
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
    if b.json {
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
        settings.domains,
        settings.points,
        settings.resolution,
        b.bundle.display()
    )?;
    let mut rows = vec![[
        "impostor".to_string(),
        "view".into(),
        "coverage".into(),
        "capture ms".into(),
        "build ms".into(),
        "rel. z error".into(),
        "max row error".into(),
        "rows dropping spans".into(),
        "srdm".into(),
        "capture".into(),
    ]];
    for v in &views {
        rows.push([
            v.impostor.clone(),
            v.view.to_string(),
            format!("{:.1} %", 100.0 * v.coverage),
            format!("{:.1}", 1e3 * v.capture_seconds),
            format!("{:.1}", 1e3 * v.build_seconds),
            format!("{:.3} %", 100.0 * v.errors.mean_relative_z_error),
            format!("{:.2e}", v.errors.max_row_error),
            v.errors.rows_dropping_spans.to_string(),
            human_bytes(v.srdm_bytes),
            human_bytes(v.capture_bytes),
        ]);
    }
    write!(
        out,
        "{}",
        format_table(
            &rows,
            &[false, true, true, true, true, true, true, true, true, true]
        )
    )?;
    Ok(ExitCode::SUCCESS)
}
