//! `glint-view`: a bundle's scene lit by its radiosity, in a window or replayed headless.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Parser;
use glint::progress::TerminalProgress;
use glint::view::headless::{ReplayOptions, replay};
use glint::view::load::load;
use glint::view::replay::parse_size;
use glint::view::window::{WindowOptions, run_window};

#[derive(Parser)]
#[command(
    name = "glint-view",
    version,
    about = "View a bundle's scene lit by its radiosity textures: a window with a fly camera, or a headless replay of a camera path to frames and timings",
    after_help = "Window keys: WASD + Q/E move (Shift: faster, mouse wheel: speed), drag with the left mouse button to look, \
1-9 play camera path N, Space pause/resume, R start/stop recording a path, P screenshot, G reflections off/geometry/image, T reflectance sphere/1D map, I impostor reflections (planar), K impostors srdm/billboard, C curved reflectors off/cubemap/impostor, [ ] recursion depth (geometry reflections), H help, Esc quit.\n\n\
Examples:\n  glint-view out/cornell-box.glint\n  glint-view out/cornell-box.glint --replay --headless --size 720x486 --out out/frames/cornell-box\n  glint-view out/breakfast-room.glint --replay walkthrough --headless --out out/frames/breakfast --every 10 --hdr"
)]
struct Args {
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
    #[arg(long, value_parser = parse_size, default_value = "720x486")]
    size: (u32, u32),
    /// Output folder: frames and timings.json (headless), screenshots and recorded paths
    /// (window; default: the current folder).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Write every K-th frame (frame 0, K, 2K, …); every frame is still rendered and timed.
    /// 0 writes no frames, only timings.json.
    #[arg(long, value_name = "K", default_value_t = 1)]
    every: usize,
    /// Also write each written frame as a linear half-float EXR.
    #[arg(long)]
    hdr: bool,
    /// Multiplies the radiance before display.
    #[arg(long, default_value_t = 1.0, value_parser = parse_exposure)]
    exposure: f32,
    /// Glossy planar reflections: `geometry` (the mirrored scene re-rendered per reflector,
    /// ks·R·M added to D), `image` (the baked radiance maps splatted; needs the radiance
    /// stage) or `off`.
    #[arg(long, value_name = "MODE", default_value = "off")]
    reflections: glint::view::reflections::ReflectionMode,
    /// Image-based reflections: radiance maps selected per reflector element.
    #[arg(long, value_name = "N", default_value_t = 2)]
    maps: usize,
    /// Image-based reflections: select maps by `angle` (Bastos's default) or `distance`.
    #[arg(long, value_name = "HOW", default_value = "angle")]
    selection: glint::view::radiance_maps::Selection,
    /// Reflections: read R from the `sphere` map (by reflected direction) or the `1d`
    /// grazing-dense map (by view angle).
    #[arg(long, value_name = "MAP", default_value = "1d")]
    reflectance: glint::view::reflections::ReflectanceLayout,
    /// Reflections: R's channel, `albedo` (directional albedo, matches the path tracer) or
    /// `bastos` (F/(π cos²θ) as printed).
    #[arg(long, value_name = "CHANNEL", default_value = "albedo")]
    reflectance_channel: glint::view::reflections::ReflectanceChannel,
    /// Reflections of impostors in planar reflectors (Popescu §3–4): `on` or `off`. Curved
    /// reflectors reflect impostors with `--curved impostor` instead.
    #[arg(long, value_name = "on|off", default_value = "off", value_parser = parse_on_off, action = clap::ArgAction::Set)]
    impostors: bool,
    /// What stands for impostor objects in reflections (`--impostors on`, `--curved
    /// impostor`): `srdm` (depth maps through their SRDM rows, §4.3; needs the srdm stage) or
    /// `billboard` (one billboard per object and reflector, §3, made at load time; misses
    /// read the reflector's baked environment map when the materials stage has one).
    #[arg(long, value_name = "KIND", default_value = "srdm")]
    impostor_kind: glint::view::impostors::ImpostorKind,
    /// Curved reflectors: `cubemap` (a view-independent cube map per reflector, Nielsen §3.2),
    /// `impostor` (reflected rays against the impostors only, Popescu §3–4) or `off`.
    #[arg(long, value_name = "MODE", default_value = "off")]
    curved: glint::view::curved::CurvedMode,
    /// Curved reflectors: regular samples per pixel and lobe (Luksch §6–7; the pattern
    /// closest to N); 0: one mirror lookup. The glossy term reads the baked MIP environment
    /// map when the bundle's materials stage has one, else the live cube map.
    #[arg(long, value_name = "N", default_value_t = 0)]
    glossy_samples: u32,
    /// Curved reflectors: face size of the live cube maps, texels.
    #[arg(long, value_name = "N", default_value_t = glint::view::curved::DEFAULT_FACE_SIZE,
          value_parser = clap::value_parser!(u32).range(1..=8192))]
    cube_size: u32,
    /// Curved reflectors: generations of cube maps (1: no interreflection between them).
    #[arg(long, value_name = "N", default_value_t = glint::view::curved::DEFAULT_GENERATIONS,
          value_parser = clap::value_parser!(u32).range(1..=8))]
    cube_generations: u32,
    /// Geometry reflections: recursion depth 0–4 (Nielsen & Christensen 2002 §3.1): 0 draws
    /// no reflections (as `--reflections off`), 1 mirrors the scene once per reflector (the
    /// default), 2–4 also draw the reflectors seen in each reflection, one reflection map per
    /// level. Needs `--reflections geometry`. In the window, [ and ] change it.
    #[arg(long, value_name = "N", value_parser = glint::view::reflections::recursive::parse_depth)]
    recursion_depth: Option<u8>,
    /// Recursive reflections: a branch stops when its accumulated specular weight (the product
    /// of max ks·R along the path) falls below this.
    #[arg(long, value_name = "W", default_value_t = glint::view::reflections::recursive::DEFAULT_WEIGHT_CUTOFF, value_parser = parse_cutoff)]
    reflection_cutoff: f32,
    /// Window: save a screenshot after N frames and exit (for automation, e.g. under xvfb-run).
    #[arg(long, value_name = "N", conflicts_with = "headless")]
    screenshot_after: Option<u64>,
}

fn parse_on_off(s: &str) -> Result<bool, String> {
    match s {
        "on" => Ok(true),
        "off" => Ok(false),
        _ => Err(format!("{s:?} is not one of on, off")),
    }
}

fn curved_settings(args: &Args) -> glint::view::curved::CurvedSettings {
    glint::view::curved::CurvedSettings {
        glossy_samples: args.glossy_samples,
        face_size: args.cube_size,
        generations: args.cube_generations,
    }
}

fn parse_exposure(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("{s:?} is not a finite number > 0")),
    }
}

fn parse_cutoff(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(format!("{s:?} is not a weight from 0 to 1")),
    }
}

fn main() -> ExitCode {
    glint::cli::quiet_gpu_probe();
    glint::cli::init_logging();
    glint::cli::exit_code(run(Args::parse()))
}

fn run(args: Args) -> anyhow::Result<ExitCode> {
    let path = args.replay.clone().filter(|n| !n.is_empty());
    let curved = curved_settings(&args);
    if let Some(d) = args.recursion_depth {
        if args.reflections != glint::view::reflections::ReflectionMode::Geometry {
            anyhow::bail!(
                "--recursion-depth {d} needs --reflections geometry (reflections are {})",
                args.reflections
            );
        }
    }
    let recursion = glint::view::reflections::RecursionSettings {
        depth: args.recursion_depth.unwrap_or(1),
        cutoff: args.reflection_cutoff,
    };
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
                exposure: args.exposure,
                reflections: args.reflections,
                selection: args.selection,
                map_count: args.maps,
                reflectance: glint::view::reflections::ReflectanceSettings {
                    layout: args.reflectance,
                    channel: args.reflectance_channel,
                },
                impostors: args.impostors,
                impostor_kind: args.impostor_kind,
                curved: args.curved,
                curved_settings: curved,
                recursion,
            },
            &progress,
        );
        progress.finish();
        let timings = timings?;
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
            out.join(glint::view::replay::TIMINGS_FILE).display()
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
            exposure: args.exposure,
            out: args.out.unwrap_or_else(|| PathBuf::from(".")),
            screenshot_after: args.screenshot_after,
            reflections: args.reflections,
            reflectance: glint::view::reflections::ReflectanceSettings {
                layout: args.reflectance,
                channel: args.reflectance_channel,
            },
            impostors: args.impostors,
            impostor_kind: args.impostor_kind,
            curved: args.curved,
            curved_settings: curved,
            recursion,
        },
    )?;
    Ok(ExitCode::SUCCESS)
}
