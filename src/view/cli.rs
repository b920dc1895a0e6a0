//! `glint-view`'s command line: a window with a fly camera, or a headless replay of a camera
//! path. The binary parses [`Args`] and calls [`run`].

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Parser;

use super::defaults::baked;
use super::gpu::Gpu;
use super::headless::{ReplayOptions, ViewError, replay_with};
use super::load::load;
use super::options::ViewArgs;
use crate::camera::{Camera, Keyframe};

use super::window::{WindowOptions, run_window};
use crate::progress::TerminalProgress;

#[derive(Parser)]
#[command(
    name = "glint-view",
    version,
    about = "View a bundle's scene lit by its radiosity textures: a window with a fly camera, or a headless replay of a camera path to frames and timings",
    after_help = "Window keys: WASD + Q/E move (Shift: faster, mouse wheel: speed), drag with the left mouse button to look, \
1-9 play camera path N, Space pause/resume, R start/stop recording a path, P screenshot, G reflections off/geometry/image, T reflectance sphere/1D map, I impostor reflections (planar), K impostors srdm/billboard, C curved reflectors off/cubemap/impostor, [ ] recursion depth (geometry reflections), - = exposure down/up half a stop, 0 auto exposure, M tone curve neutral/none, H help, Esc quit.\n\n\
Reflections default to what the bundle was baked for (image-based planar reflections where it has radiance maps, cube maps for curved reflectors, impostors where it has depth maps but no radiance maps); a line at start names the modes chosen, and --reflections, --curved and --impostors override them.\n\n\
Examples:\n  glint-view out/glossy-room.glint\n  glint-view out/glossy-room.glint --replay --headless --size 720x486 --every 10 --out out/frames/glossy-room\n  glint-view out/glossy-room.glint --replay walkthrough --frame 120 --headless --hdr --supersample 3 --out out/frames/one\n  glint-view out/glossy-room.glint --headless --eye 1.2,1.45,1.5 --target -0.15,0.95,-1 --fov 55 --out out/frames/view\n  glint-view out/glossy-room.glint --replay --headless --reflections off --curved off --out out/frames/diffuse"
)]
#[command(group(clap::ArgGroup::new("shot").args(["replay", "eye"])))]
/// `glint-view`'s arguments.
pub struct Args {
    /// The bundle to view (a folder written by glint-bake), e.g. out/cornell-box.glint.
    #[arg(value_name = "BUNDLE.glint")]
    bundle: PathBuf,
    /// Replay a camera path: the named one, or the scene's first when no name is given.
    #[arg(long, value_name = "NAME", num_args = 0..=1, default_missing_value = "")]
    replay: Option<String>,
    /// Render offscreen without a window (needs --out, and --replay or --eye); no display
    /// needed.
    #[arg(long, requires = "shot", requires = "out")]
    headless: bool,
    /// Headless: render and write frame K of the replayed path alone (from 0).
    #[arg(
        long,
        value_name = "K",
        requires = "replay",
        requires = "headless",
        conflicts_with = "every"
    )]
    frame: Option<usize>,
    /// A camera for a one-off view without a path: its eye position, world metres (with
    /// --target; headless: one frame, frame_00000.png; window: the starting view).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, requires = "target",
          allow_hyphen_values = true)]
    eye: Option<[f32; 3]>,
    /// The point the --eye camera looks at (up is +Y).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, requires = "eye",
          allow_hyphen_values = true)]
    target: Option<[f32; 3]>,
    /// Vertical field of view of the --eye camera, degrees (0.1 to 179).
    #[arg(long, value_name = "DEG", value_parser = parse_fov, requires = "eye", default_value = "60")]
    fov: f32,
    /// Frame (headless) or initial window size, WIDTHxHEIGHT.
    #[arg(long, value_parser = crate::cli::parse_size, default_value = "720x486")]
    size: (u32, u32),
    /// Output folder: frames and timings.json (headless), screenshots and recorded paths
    /// (window; default: the current folder).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Render and write every K-th frame of the path (frame 0, K, 2K, …); the others are not
    /// rendered. 0 renders and times every frame and writes none, only timings.json.
    #[arg(long, value_name = "K", default_value_t = 1)]
    every: usize,
    /// Also write each written frame as a half-float EXR of linear radiance (never exposed:
    /// --exposure and --tonemap change only the PNG).
    #[arg(long)]
    hdr: bool,
    /// Headless: render each frame at N × N samples a pixel and box-filter it down in linear
    /// radiance, on top of --samples' multisampling (N² the GPU's work a frame). Sharp
    /// highlights smaller than a pixel then average as a path tracer's pixels do.
    #[arg(long, value_name = "N", value_parser = super::headless::supersample::parse_supersample,
          default_value_t = 1, requires = "headless")]
    supersample: u32,
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
    let camera = args.camera()?;
    let data = load(&args.bundle)?;
    let baked = baked(&data);
    let modes = args.view.defaults(&baked);
    let view = args.view.options_for(&baked).map_err(anyhow::Error::msg)?;
    log::info!("view: {}", modes.describe());
    if args.headless {
        let out = args.out.clone().context("--headless needs --out DIR")?;
        let gpu = Gpu::headless_with_features(
            wgpu::Features::TIMESTAMP_QUERY | super::gpu::target::MULTISAMPLE_FEATURES,
        )?;
        let progress = TerminalProgress::new();
        let timings = replay_with(
            &gpu,
            &data,
            &ReplayOptions {
                path,
                width: args.size.0,
                height: args.size.1,
                out: Some(out.clone()),
                every: args.every,
                frame: args.frame,
                camera,
                hdr: args.hdr,
                supersample: args.supersample,
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
    run_window(
        data,
        WindowOptions {
            size: args.size,
            play: args
                .replay
                .map(|n| if n.is_empty() { None } else { Some(n) }),
            out: args.out.unwrap_or_else(|| PathBuf::from(".")),
            screenshot_after: args.screenshot_after,
            camera: camera.as_ref().map(Camera::from_keyframe),
            view,
        },
    )?;
    Ok(ExitCode::SUCCESS)
}

impl Args {
    /// The camera `--eye`, `--target` and `--fov` give, or why it has no view direction.
    fn camera(&self) -> anyhow::Result<Option<Keyframe>> {
        let (Some(eye), Some(target)) = (self.eye, self.target) else {
            return Ok(None);
        };
        let dir = glam::Vec3::from(target) - glam::Vec3::from(eye);
        let [ex, ey, ez] = eye;
        let [tx, ty, tz] = target;
        if dir.length() <= 1e-6 * (1.0 + glam::Vec3::from(eye).abs().max_element()) {
            anyhow::bail!(
                "--eye {ex},{ey},{ez} and --target {tx},{ty},{tz}: the camera is at its target; give a --target apart from --eye"
            );
        }
        if dir.normalize().cross(glam::Vec3::Y).length() < 1e-4 {
            anyhow::bail!(
                "--eye {ex},{ey},{ez} and --target {tx},{ty},{tz}: the camera looks straight up or down, along its up vector +Y; move --target sideways"
            );
        }
        Ok(Some(Keyframe {
            time: 0.0,
            position: eye,
            target,
            up: [0.0, 1.0, 0.0],
            fov_y_deg: self.fov,
        }))
    }
}

/// Largest coordinate of `--eye` and `--target`, metres (as scene.json's keyframes).
const MAX_COORDINATE: f32 = 1e6;

/// `X,Y,Z`: three finite numbers within ±[`MAX_COORDINATE`].
fn parse_point(s: &str) -> Result<[f32; 3], String> {
    let expected = || {
        format!("expected three numbers X,Y,Z within ±{MAX_COORDINATE} metres, e.g. 1.2,1.45,1.5")
    };
    let v: Vec<f32> = s
        .split(',')
        .map(|c| c.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| expected())?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite() && c.abs() <= MAX_COORDINATE) => {
            Ok([*x, *y, *z])
        }
        _ => Err(expected()),
    }
}

/// A vertical field of view in degrees, 0.1 to 179 (as scene.json's keyframes).
fn parse_fov(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(v) if (0.1..=179.0).contains(&v) => Ok(v),
        _ => Err("expected a vertical field of view in degrees, from 0.1 to 179".into()),
    }
}
