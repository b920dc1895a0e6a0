//! `glint-eval`: a CPU reference path tracer, probes of a bake, image metrics and
//! speed-vs-accuracy sweeps.

use std::process::ExitCode;

use clap::Parser;
use glint::eval::cli::{Args, run};

fn main() -> ExitCode {
    glint::cli::quiet_gpu_probe();
    glint::cli::init_logging();
    glint::cli::exit_code(run(Args::parse()))
}
