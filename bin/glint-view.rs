//! `glint-view`: a bundle's scene lit by its radiosity, in a window or replayed headless.

use std::process::ExitCode;

use clap::Parser;
use glint::view::cli::{Args, run};

fn main() -> ExitCode {
    glint::cli::quiet_gpu_probe();
    glint::cli::init_logging();
    glint::cli::exit_code(run(Args::parse()))
}
