//! `glint-srdm`: bake depth-map impostors and their simplified rotated depth maps (SRDM).

use std::process::ExitCode;

use clap::Parser;
use glint::bake::tool::{Tool, run};
use glint::cli::BakeArgs;
use glint::settings::srdm::SrdmOverride;

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
    #[command(flatten)]
    srdm: SrdmOverride,
}

fn main() -> ExitCode {
    glint::cli::init_logging();
    glint::cli::init_threads();
    // Ctrl-C from here on stops the bake between work items; it exits 130.
    glint::progress::install_interrupt_handler();
    let args = Args::parse();
    let tool = Tool::Srdm(args.srdm);
    glint::cli::exit_code(run(&args.bake, tool, &mut std::io::stdout().lock()))
}
