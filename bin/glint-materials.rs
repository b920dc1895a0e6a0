//! `glint-materials`: bake how each glossy material reflects: kernel and reflectance textures,
//! regular sample patterns, and prefiltered environment maps of glossy curved objects.

use std::process::ExitCode;

use clap::Parser;
use glint::bake::tool::{Tool, run};
use glint::cli::BakeArgs;

#[derive(Parser)]
#[command(
    name = "glint-materials",
    version,
    about = "Bake the materials stage: per glossy material the kernel texture K (D·G), the reflectance maps R (sphere map and grazing-dense 1D map), the regular sample pattern closest to the sample budget, and MIP-filtered environment maps of glossy curved reflectors (these need the bundle's radiosity stage). A scene without glossy materials is skipped with the reason.",
    after_help = "Example:\n  glint-materials scenes/glossy-room/scene.json --bundle out/glossy-room.glint --quality draft\n  glint-bundle stats out/glossy-room.glint"
)]
struct Args {
    #[command(flatten)]
    bake: BakeArgs,
}

fn main() -> ExitCode {
    glint::cli::init_logging();
    glint::cli::init_threads();
    // Ctrl-C from here on stops the bake between work items; it exits 130.
    glint::progress::install_interrupt_handler();
    let args = Args::parse();
    let tool = Tool::Materials;
    glint::cli::exit_code(run(&args.bake, tool, &mut std::io::stdout().lock()))
}
