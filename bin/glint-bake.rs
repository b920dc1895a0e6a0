//! `glint-bake`: bake every stage a scene requires into one bundle, skipping the rest; or
//! list, bake and merge the work units the bake splits into.

use std::process::ExitCode;

use clap::Parser;
use glint::bake::unit_tool::run;
use glint::cli::GlintBakeArgs;

#[derive(Parser)]
#[command(
    name = "glint-bake",
    version,
    about = "Bake every stage a scene requires into a bundle, in dependency order; stages a scene does not need are skipped with the reason, stages already up to date are left alone. Or split the bake into work units for a job engine: --plan lists them, --unit bakes one into a shard, `glint-bundle merge` assembles the shards",
    after_help = "Examples:\n  glint-bake scenes/cornell-box/scene.json --bundle out/cornell-box.glint\n  glint-bundle stats out/cornell-box.glint\n  glint-bake scenes/glossy-room/scene.json --plan\n  glint-bake scenes/glossy-room/scene.json --plan --wave 0 | xargs -P 2 -I{} glint-bake scenes/glossy-room/scene.json --unit {} --bundle shards/{}.glint\n  glint-bake scenes/glossy-room/scene.json --plan --wave 1 | xargs -P 2 -I{} glint-bake scenes/glossy-room/scene.json --unit {} --bundle shards/{}.glint\n  glint-bundle merge out/glossy-room.glint shards/*.glint\n  glint-bake scenes/glossy-room/scene.json --units shards --bundle out/glossy-room.glint"
)]
struct Args {
    #[command(flatten)]
    bake: GlintBakeArgs,
}

fn main() -> ExitCode {
    glint::cli::init_logging();
    glint::cli::init_threads();
    // Ctrl-C from here on stops the bake between work items; it exits 130.
    glint::progress::install_interrupt_handler();
    let args = Args::parse();
    glint::cli::exit_code(run(&args.bake, &mut std::io::stdout().lock()))
}
