//! `glint-bundle`: inspect and check a baked bundle from the terminal.

use std::process::ExitCode;

use clap::Parser;
use glint::bake::bundle_tool::{Args, run};

fn main() -> ExitCode {
    glint::cli::init_logging();
    glint::cli::exit_code(run(Args::parse()))
}
