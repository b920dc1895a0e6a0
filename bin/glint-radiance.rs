//! `glint-radiance`: bake radiance maps with depth and their quadtrees for glossy planar reflectors.

use std::process::ExitCode;

use clap::Parser;
use glint::bake::tool::{Tool, run};
use glint::cli::BakeArgs;

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
    glint::cli::init_threads();
    // Ctrl-C from here on stops the bake between work items; it exits 130.
    glint::progress::install_interrupt_handler();
    let args = Args::parse();
    let tool = Tool::Radiance;
    glint::cli::exit_code(run(&args.bake, tool, &mut std::io::stdout().lock()))
}
