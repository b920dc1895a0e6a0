//! `glint-radiance`: bake radiance maps with depth and their quadtrees for glossy planar reflectors.

use std::io::Write;
use std::process::ExitCode;

use anyhow::Context;
use clap::Parser;
use glint::bake::{Stage, plan, radiance_stage};
use glint::cli::BakeArgs;
use glint::progress::TerminalProgress;
use glint::scene::Scene;

#[derive(Parser)]
#[command(
    name = "glint-radiance",
    version,
    about = "Bake radiance maps with depth (and their quadtrees) on hemispheres behind every glossy planar reflector; needs the radiosity stage in the bundle",
    after_help = "Example:\n  glint-radiosity scenes/glossy-room/scene.json --bundle out/glossy-room.glint\n  glint-radiance scenes/glossy-room/scene.json --bundle out/glossy-room.glint\n  glint-bundle stats out/glossy-room.glint\n\nMap resolution, reflector elements and cameras per hemisphere follow each reflector's glossiness\n(mirror: 128², 4 elements along the long side, 9 cameras; glossy m ≤ 0.1: 64², 3, 7; rougher: 32², 2, 5),\nscaled by the preset (draft ×½, high ×2) and overridable per reflector in scene.json (`radiance`)."
)]
struct Args {
    #[command(flatten)]
    bake: BakeArgs,
}

fn main() -> ExitCode {
    glint::cli::init_logging();
    glint::cli::exit_code(run(Args::parse().bake))
}

fn run(b: BakeArgs) -> anyhow::Result<ExitCode> {
    let scene = Scene::load(&b.scene)?;
    let mut out = std::io::stdout().lock();
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
    let quality = b.quality.unwrap_or(scene.desc.bake.quality);
    let progress = TerminalProgress::new();
    let record = radiance_stage::bake(&scene, &b.bundle, quality, b.force, &progress);
    progress.finish();
    let record = record.context("stage radiance")?;
    if b.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&record)?)?;
    } else {
        writeln!(
            out,
            "{}: {} radiance maps baked in {:.2} s ({} quality) → {}",
            scene.name,
            record.stats["maps"],
            record.bake_seconds,
            quality.name(),
            b.bundle.display()
        )?;
    }
    Ok(ExitCode::SUCCESS)
}
