//! `glint-view`'s command line: a window with a fly camera, or a headless replay of a camera
//! path. The binary parses [`Args`] and calls [`run`].

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Parser;

use super::headless::{ReplayOptions, ViewError, replay};
use super::load::load;
use super::options::ViewArgs;

use super::window::{WindowOptions, run_window};
use crate::progress::TerminalProgress;

#[derive(Parser)]
#[command(
    name = "glint-view",
    version,
    about = "View a bundle's scene lit by its radiosity textures: a window with a fly camera, or a headless replay of a camera path to frames and timings",
    after_help = "Window keys: WASD + Q/E move (Shift: faster, mouse wheel: speed), drag with the left mouse button to look, \
1-9 play camera path N, Space pause/resume, R start/stop recording a path, P screenshot, G reflections off/geometry/image, T reflectance sphere/1D map, I impostor reflections (planar), K impostors srdm/billboard, C curved reflectors off/cubemap/impostor, [ ] recursion depth (geometry reflections), - = exposure down/up half a stop, 0 auto exposure, M tone curve neutral/none, H help, Esc quit.\n\n\
Examples:\n  glint-view out/cornell-box.glint\n  glint-view out/cornell-box.glint --replay --headless --size 720x486 --out out/frames/cornell-box\n  glint-view out/breakfast-room.glint --replay walkthrough --headless --out out/frames/breakfast --every 10 --hdr"
)]
/// `glint-view`'s arguments.
pub struct Args {
    /// The bundle to view (a folder written by glint-bake), e.g. out/cornell-box.glint.
    #[arg(value_name = "BUNDLE.glint")]
    bundle: PathBuf,
    /// Replay a camera path: the named one, or the scene's first when no name is given.
    #[arg(long, value_name = "NAME", num_args = 0..=1, default_missing_value = "")]
    replay: Option<String>,
    /// Render offscreen without a window (needs --replay and --out); no display needed.
    #[arg(long, requires = "replay", requires = "out")]
    headless: bool,
    /// Frame (headless) or initial window size, WIDTHxHEIGHT.
    #[arg(long, value_parser = crate::cli::parse_size, default_value = "720x486")]
    size: (u32, u32),
    /// Output folder: frames and timings.json (headless), screenshots and recorded paths
    /// (window; default: the current folder).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Write every K-th frame (frame 0, K, 2K, …); every frame is still rendered and timed.
    /// 0 writes no frames, only timings.json.
    #[arg(long, value_name = "K", default_value_t = 1)]
    every: usize,
    /// Also write each written frame as a half-float EXR of linear radiance (never exposed:
    /// --exposure and --tonemap change only the PNG).
    #[arg(long)]
    hdr: bool,
    #[command(flatten)]
    view: ViewArgs,
    /// Window: save a screenshot after N frames and exit (for automation, e.g. under xvfb-run).
    #[arg(long, value_name = "N", conflicts_with = "headless")]
    screenshot_after: Option<u64>,
}

/// Replays headless (`--headless`) or opens the window; its exit code (errors go to
/// [`crate::cli::exit_code`]).
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let path = args.replay.clone().filter(|n| !n.is_empty());
    let view = args.view.options().map_err(anyhow::Error::msg)?;
    if args.headless {
        let out = args.out.clone().context("--headless needs --out DIR")?;
        let progress = TerminalProgress::new();
        let timings = replay(
            &args.bundle,
            &ReplayOptions {
                path,
                width: args.size.0,
                height: args.size.1,
                out: Some(out.clone()),
                every: args.every,
                hdr: args.hdr,
                view,
            },
            &progress,
        );
        progress.finish();
        let timings = match timings {
            Err(e @ ViewError::Interrupted { .. }) => {
                writeln!(std::io::stderr(), "error: {e}")?;
                // 128 + SIGINT: what a shell reports for a program stopped by Ctrl-C.
                return Ok(ExitCode::from(130));
            }
            t => t?,
        };
        let written = timings
            .frames
            .iter()
            .filter(|f| !f.files.is_empty())
            .count();
        let mut stdout = std::io::stdout().lock();
        write!(stdout, "{}", timings.summary_table())?;
        writeln!(
            stdout,
            "wrote {written} frame(s) and {}",
            out.join(super::headless::replay::TIMINGS_FILE).display()
        )?;
        return Ok(ExitCode::SUCCESS);
    }
    let data = load(&args.bundle)?;
    run_window(
        data,
        WindowOptions {
            size: args.size,
            play: args
                .replay
                .map(|n| if n.is_empty() { None } else { Some(n) }),
            out: args.out.unwrap_or_else(|| PathBuf::from(".")),
            screenshot_after: args.screenshot_after,
            view,
        },
    )?;
    Ok(ExitCode::SUCCESS)
}
