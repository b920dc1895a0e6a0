//! `glint-radiosity`: bake the radiosity textures (the diffuse light D) of a scene.

use std::process::ExitCode;

use clap::Parser;
use glint::bake::tool::{Tool, run};
use glint::cli::BakeArgs;
use glint::settings::radiosity::RadiosityOverride;

#[derive(Parser)]
#[command(
    name = "glint-radiosity",
    version,
    about = "Bake radiosity textures (the view-independent diffuse light D) into a bundle",
    after_help = "Example:\n  glint-radiosity scenes/cornell-box/scene.json --bundle out/cornell-box.glint --quality draft --light-samples 64\n  glint-bundle stats out/cornell-box.glint\n\nSettings come from the preset, then the scene's `bake.radiosity`, then these flags."
)]
struct Args {
    #[command(flatten)]
    bake: BakeArgs,
    #[command(flatten)]
    radiosity: RadiosityOverride,
}

fn main() -> ExitCode {
    glint::cli::init_logging();
    glint::cli::init_threads();
    // Ctrl-C from here on stops the bake between work items; it exits 130.
    glint::progress::install_interrupt_handler();
    let args = Args::parse();
    let tool = Tool::Radiosity(args.radiosity);
    glint::cli::exit_code(run(&args.bake, tool, &mut std::io::stdout().lock()))
}
