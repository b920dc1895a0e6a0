//! `glint-radiosity`: bake the radiosity textures (the diffuse light D) of a scene.

use std::io::Write;
use std::process::ExitCode;

use anyhow::Context;
use clap::Parser;
use glint::bake::{Stage, radiosity_stage, scene_stage, up_to_date};
use glint::cli::BakeArgs;
use glint::progress::TerminalProgress;
use glint::scene::Scene;
use glint::scene::desc::RadiositySettings;

#[derive(Parser)]
#[command(
    name = "glint-radiosity",
    version,
    about = "Bake radiosity textures (the view-independent diffuse light D) into a bundle",
    after_help = "Example:\n  glint-radiosity scenes/cornell-box/scene.json --bundle out/cornell-box.glint --quality draft\n  glint-bundle stats out/cornell-box.glint\n\nSettings come from the preset, then the scene's `bake.radiosity`, then these flags."
)]
struct Args {
    #[command(flatten)]
    bake: BakeArgs,
    /// Lightmap texels per metre.
    #[arg(long, value_name = "T")]
    texel_density: Option<f32>,
    /// Gathering rays per texel.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    rays: Option<u32>,
    /// Largest number of indirect bounces.
    #[arg(long, value_name = "B")]
    bounces: Option<u32>,
}

fn main() -> ExitCode {
    glint::cli::init_logging();
    glint::cli::exit_code(run(Args::parse()))
}

fn run(args: Args) -> anyhow::Result<ExitCode> {
    let b = &args.bake;
    let scene = Scene::load(&b.scene)?;
    let quality = b.quality.unwrap_or(scene.desc.bake.quality);
    let mut settings = RadiositySettings::resolve(quality, &scene.desc.bake.radiosity);
    if let Some(v) = args.texel_density {
        settings.texel_density = v;
    }
    if let Some(v) = args.rays {
        settings.rays = v;
    }
    if let Some(v) = args.bounces {
        settings.bounces = v;
    }
    radiosity_stage::check(&scene, &settings)?;
    glint::bundle::check_scene(&b.bundle, &scene.content_hash, b.force)?;
    if !up_to_date(&b.bundle, &scene, Stage::Scene, None) {
        scene_stage::bake(&scene, &b.bundle, b.force).context("stage scene")?;
    }
    let progress = TerminalProgress::new();
    let record = radiosity_stage::bake(&scene, &b.bundle, &settings, b.force, &progress);
    progress.finish();
    let record = record.context("stage radiosity")?;
    let mut out = std::io::stdout().lock();
    if b.json {
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
            b.bundle.display()
        )?;
    }
    Ok(ExitCode::SUCCESS)
}
