//! `glint-bake`: bake every stage a scene requires into one bundle, skipping the rest.

use std::process::ExitCode;

use clap::Parser;
use glint::bake::tool::{Tool, run};
use glint::cli::BakeArgs;

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
    let args = Args::parse();
    let tool = Tool::All;
    glint::cli::exit_code(run(&args.bake, tool, &mut std::io::stdout().lock()))
}
