//! `glint-eval`'s command line: its arguments (clap) and one function per subcommand. The
//! binary parses [`Args`] and calls [`run`].

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::{Args as ClapArgs, Parser, Subcommand};
use glam::Vec3;

use super::reference::{self, RenderOptions};
use super::{Image, compare, probe, sweep};
use crate::bundle::Bundle;
use crate::camera::{Camera, frame_camera};
use crate::progress::TerminalProgress;
use crate::radiosity::RadiosityMap;
use crate::scene::{Quality, Scene};
use crate::view::options::{CurvedMode, ReflectionMode, Selection, ViewOptions};

#[derive(Parser)]
#[command(
    name = "glint-eval",
    version,
    about = "Reference renders, probes, image metrics and speed-vs-accuracy sweeps",
    after_help = "Examples:\n  glint-eval reference scenes/cornell-box/scene.json --camera front --spp 256 --out out/ref.exr\n  glint-eval probe out/cornell-box.glint --points points.json --out values.json\n  glint-eval probe-reference scenes/cornell-box/scene.json --points points.json --out truth.json\n  glint-eval compare out/view.exr out/ref.exr --diff out/diff.png --json\n  glint-eval sweep scenes/cornell-box/scene.json --set radiosity.rays=64,256,1024 --camera front --out out/sweep"
)]
/// `glint-eval`'s arguments: one subcommand.
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Path-trace a view of a scene to a linear RGB EXR (deterministic for a seed).
    #[command(
        after_help = "Example:\n  glint-eval reference scenes/cornell-box/scene.json --camera front --size 256x256 --spp 256 --out out/ref.exr"
    )]
    Reference(ReferenceArgs),
    /// Look D up at world points: a JSON array of {"name"?, "position": [x,y,z], "normal": [x,y,z]}.
    #[command(
        after_help = "Example:\n  glint-eval probe out/cornell-box.glint --points points.json --out values.json"
    )]
    Probe(ProbeArgs),
    /// Probe points on a scene's diffuse faces (area-weighted, away from contact with other
    /// geometry), as the JSON `probe` and `probe-reference` read.
    #[command(
        after_help = "Example:\n  glint-eval probe-points scenes/glossy-room/scene.json --count 400 --out points.json"
    )]
    ProbePoints(ProbePointsArgs),
    /// Path-trace D at probe points: the diffuse exitant radiance with light from every path
    /// (glossy and mirror reflections included), with each value's standard error.
    #[command(
        after_help = "Example:\n  glint-eval probe-reference scenes/glossy-room/scene.json --points points.json --paths 16384 --out truth.json\n  glint-eval probe out/glossy-room.glint --points points.json --out d.json\n  glint-eval probe-compare d.json truth.json"
    )]
    ProbeReference(ProbeReferenceArgs),
    /// Relative error of probe values A against reference values B (same probes).
    #[command(after_help = "Example:\n  glint-eval probe-compare d.json truth.json --json")]
    ProbeCompare(ProbeCompareArgs),
    /// RMSE, relative RMSE, PSNR and max error of A against the reference B.
    #[command(
        after_help = "Example:\n  glint-eval compare view.exr ref.exr --mask walls.png --diff diff.png --json"
    )]
    Compare(CompareArgs),
    /// Bake with each setting, render the same view (timed in the headless viewer when it is
    /// built) and compare with a reference; writes DIR/sweep.csv and DIR/sweep.svg.
    #[command(
        after_help = sweep::knobs_help() + "\nExamples:\n  glint-eval sweep scenes/cornell-box/scene.json --set radiosity.rays=64,256,1024 --set radiosity.texel_density=8,16,32 --camera front --out out/sweep\n  glint-eval sweep scenes/glossy-room/scene.json --reflections image --set radiance.resolution_scale=0.5,1,2 --set view.maps=1,2,4 --out out/sweep-glossy"
    )]
    Sweep(SweepArgs),
}

// `glint-eval reference` (its help is the variant's doc comment).
#[derive(ClapArgs)]
struct ReferenceArgs {
    /// The scene description.
    scene: PathBuf,
    #[command(flatten)]
    view: ViewArgs,
    #[command(flatten)]
    render: RenderArgs,
    /// Output EXR.
    #[arg(long)]
    out: PathBuf,
}

// `glint-eval probe`.
#[derive(ClapArgs)]
struct ProbeArgs {
    /// A bundle with scene and radiosity stages.
    bundle: PathBuf,
    /// Probe points (JSON).
    #[arg(long)]
    points: PathBuf,
    /// Output JSON (stdout when omitted).
    #[arg(long)]
    out: Option<PathBuf>,
    /// How far from each point the surface is looked for along its normal (metres;
    /// default 1% of the scene's diagonal).
    #[arg(long, value_parser = positive_f32)]
    reach: Option<f32>,
}

// `glint-eval probe-points`.
#[derive(ClapArgs)]
struct ProbePointsArgs {
    /// The scene description.
    scene: PathBuf,
    /// Number of probes.
    #[arg(long, default_value_t = 400, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    count: u32,
    /// Seed of the placement.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Keep probes at least this far (metres) from any other surface, e.g. half a texel
    /// (0.03 at 16 texels/m): nearer a concave edge D changes faster than texels resolve.
    /// Always at least 10⁻⁴ of the scene's diagonal.
    #[arg(long, value_name = "M", default_value_t = 0.0, value_parser = non_negative_f32)]
    clearance: f32,
    /// Output JSON (stdout when omitted).
    #[arg(long)]
    out: Option<PathBuf>,
}

// `glint-eval probe-reference`.
#[derive(ClapArgs)]
struct ProbeReferenceArgs {
    /// The scene description.
    scene: PathBuf,
    /// Probe points (JSON).
    #[arg(long)]
    points: PathBuf,
    /// Paths per probe.
    #[arg(long, default_value_t = 4096, value_parser = clap::value_parser!(u32).range(1..))]
    paths: u32,
    /// Seed of the random streams.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Drop glossy lobes (diffuse transport only: what a bake without glossy transport holds).
    #[arg(long)]
    diffuse_only: bool,
    /// How far from each point the surface is looked for along its normal (metres;
    /// default 1% of the scene's diagonal).
    #[arg(long, value_parser = positive_f32)]
    reach: Option<f32>,
    /// Output JSON (stdout when omitted).
    #[arg(long)]
    out: Option<PathBuf>,
}

// `glint-eval probe-compare`.
#[derive(ClapArgs)]
struct ProbeCompareArgs {
    /// Probe values tested (JSON from `probe`).
    a: PathBuf,
    /// Reference values at the same probes (JSON from `probe-reference`).
    b: PathBuf,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

// `glint-eval compare`.
#[derive(ClapArgs)]
struct CompareArgs {
    /// The image tested (EXR).
    a: PathBuf,
    /// The reference (EXR).
    b: PathBuf,
    /// PNG of the same size: pixels whose first channel is ≥ 128 are compared.
    #[arg(long)]
    mask: Option<PathBuf>,
    /// Write a false-colour PNG of |lum(A) − lum(B)| (red = the largest difference).
    #[arg(long)]
    diff: Option<PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

// `glint-eval sweep`.
#[derive(ClapArgs)]
struct SweepArgs {
    /// The scene description.
    scene: PathBuf,
    /// STAGE.FIELD=V1,V2,... (repeatable): a field of scene.json's `bake.STAGE`
    /// settings, or a viewer setting `view.*`.
    #[arg(long = "set", required = true)]
    set: Vec<String>,
    #[command(flatten)]
    view: ViewArgs,
    #[command(flatten)]
    render: RenderArgs,
    /// Preset the knobs start from (default: the scene's).
    #[arg(long, value_enum)]
    quality: Option<QualityArg>,
    /// Glossy reflections in the view (`off`, `geometry` or `image`), for every setting but
    /// a view.reflections knob's.
    #[arg(long, default_value = "off")]
    reflections: ReflectionMode,
    /// Image-based reflections: maps per reflector element (1..=16).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u8).range(1..=16))]
    maps: u8,
    /// Image-based reflections: map selection (`angle` or `distance`).
    #[arg(long, default_value = "angle")]
    selection: Selection,
    /// Curved reflectors by cube maps in the view (`off` or `cubemap`), for every setting
    /// but a view.curved knob's; view.glossy_samples needs `cubemap`.
    #[arg(long, default_value = "off", value_parser = parse_curved)]
    curved: CurvedMode,
    /// Timed frames per setting in the headless viewer (the median is reported).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=1000))]
    frames: u32,
    /// Render D on the CPU even when the viewer is built (no frame times).
    #[arg(long)]
    cpu_view: bool,
    /// Samples per pixel of the compared view (antialiasing): rays of the CPU view of D; in
    /// the viewer, the frame is rendered at ⌊√N⌋× the size and box-filtered (timed frames
    /// stay at --size).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=1024))]
    view_spp: u32,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
}

/// `off` or `cubemap`: the sweep's view has no impostor mode of curved reflectors.
fn parse_curved(s: &str) -> Result<CurvedMode, String> {
    match s.parse()? {
        CurvedMode::Impostor => Err(format!("{s:?} is not one of off, cubemap")),
        mode => Ok(mode),
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum QualityArg {
    Draft,
    Default,
    High,
}

/// Which view: a camera path's first keyframe, or frame K of a path.
#[derive(ClapArgs)]
struct ViewArgs {
    /// Camera path NAME (its first keyframe).
    #[arg(long, conflicts_with = "path")]
    camera: Option<String>,
    /// Camera path P, with --frame.
    #[arg(long)]
    path: Option<String>,
    /// Frame K of --path (at the path's fps).
    #[arg(long, requires = "path", default_value_t = 0)]
    frame: usize,
}

#[derive(ClapArgs)]
struct RenderArgs {
    /// Image size WxH.
    #[arg(long, default_value = "256x256", value_parser = crate::cli::parse_size)]
    size: (u32, u32),
    /// Paths per pixel.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    spp: u32,
    /// Seed of the random streams.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Longest path, in bounces.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    max_depth: u32,
    /// Uniform sky radiance R,G,B for rays that leave the scene (default black).
    #[arg(long, value_parser = parse_rgb)]
    sky: Option<Vec3>,
    /// Drop glossy lobes (the scene a radiosity bake represents).
    #[arg(long)]
    diffuse_only: bool,
}

impl RenderArgs {
    fn options(&self) -> RenderOptions {
        RenderOptions {
            width: self.size.0,
            height: self.size.1,
            spp: self.spp,
            seed: self.seed,
            max_depth: self.max_depth,
            background: self.sky.unwrap_or(Vec3::ZERO),
            diffuse_only: self.diffuse_only,
            ..RenderOptions::default()
        }
    }
}

fn parse_rgb(s: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|c| c.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("`{s}`: {e}"))?;
    match v.as_slice() {
        [r, g, b] if v.iter().all(|c| c.is_finite() && *c >= 0.0) => Ok(Vec3::new(*r, *g, *b)),
        _ => Err(format!("`{s}`: expected three non-negative numbers R,G,B")),
    }
}

fn positive_f32(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("`{s}`: expected a positive number")),
    }
}

fn non_negative_f32(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("`{s}`: expected a number ≥ 0")),
    }
}

fn camera(scene: &Scene, v: &ViewArgs) -> anyhow::Result<Camera> {
    let path = scene.find_camera_path(v.path.as_deref().or(v.camera.as_deref()))?;
    frame_camera(path, v.frame).map_err(|e| anyhow::anyhow!("--frame {}: {e}", v.frame))
}

fn write(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        crate::out_dir::create_dir_all(dir)
            .with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(path, bytes).with_context(|| format!("writing {}", path.display()))
}

fn read_exr(path: &Path) -> anyhow::Result<Image> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    Image::from_exr(&bytes).with_context(|| format!("{}", path.display()))
}

fn render_reference(scene: &Scene, cam: &Camera, opts: &RenderOptions) -> anyhow::Result<Image> {
    let bvh = scene.build_bvh();
    let progress = TerminalProgress::new();
    let start = std::time::Instant::now();
    let r = reference::render(scene, &bvh, cam, opts, &progress);
    progress.finish();
    let r = r?;
    log::info!(
        "reference {}x{} at {} spp in {:.2} s",
        opts.width,
        opts.height,
        opts.spp,
        start.elapsed().as_secs_f64()
    );
    Ok(r.image)
}

/// Runs the subcommand `args` names; its exit code (errors go to [`crate::cli::exit_code`]).
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    match args.command {
        Command::Reference(a) => a.run(),
        Command::Probe(a) => a.run(),
        Command::ProbePoints(a) => a.run(),
        Command::ProbeReference(a) => a.run(),
        Command::ProbeCompare(a) => a.run(),
        Command::Compare(a) => a.run(),
        Command::Sweep(a) => a.run(),
    }
}

impl ReferenceArgs {
    /// Path-traces the view to the EXR `--out`.
    fn run(self) -> anyhow::Result<ExitCode> {
        let scene = Scene::load(&self.scene)?;
        let cam = camera(&scene, &self.view)?;
        let img = render_reference(&scene, &cam, &self.render.options())?;
        write(&self.out, &img.to_exr()?)?;
        Ok(ExitCode::SUCCESS)
    }
}

/// Reads a JSON file of `T`, saying which file and what was expected when it is not one.
fn read_json<T: serde::de::DeserializeOwned>(path: &Path, expected: &str) -> anyhow::Result<T> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: expected {expected}", path.display()))
}

/// Writes pretty JSON to `out`, or stdout when `None`.
fn write_json(out: Option<&Path>, value: &impl serde::Serialize) -> anyhow::Result<()> {
    let json = serde_json::to_string_pretty(value)? + "\n";
    match out {
        Some(p) => write(p, json.as_bytes()),
        // A closed stdout (`| head -1`) is an io::Error, not a panic: see cli::exit_code.
        None => Ok(std::io::stdout().lock().write_all(json.as_bytes())?),
    }
}

const POINTS_JSON: &str = "a JSON array of {\"position\", \"normal\"}";

impl ProbePointsArgs {
    fn run(self) -> anyhow::Result<ExitCode> {
        let scene = Scene::load(&self.scene)?;
        let bvh = scene.build_bvh();
        let points = probe::diffuse_points_clear_of(
            &scene,
            &bvh,
            self.count as usize,
            self.seed,
            self.clearance,
        );
        if points.len() < self.count as usize {
            log::warn!(
                "{}: only {} of {} probes: open diffuse faces are rare",
                self.scene.display(),
                points.len(),
                self.count
            );
        }
        if points.is_empty() {
            bail!(
                "{}: no diffuse face to put a probe on",
                self.scene.display()
            );
        }
        write_json(self.out.as_deref(), &points)?;
        Ok(ExitCode::SUCCESS)
    }
}

impl ProbeReferenceArgs {
    fn run(self) -> anyhow::Result<ExitCode> {
        let scene = Scene::load(&self.scene)?;
        let pts: Vec<probe::ProbePoint> = read_json(&self.points, POINTS_JSON)?;
        let bvh = scene.build_bvh();
        let reach = self.reach.unwrap_or_else(|| probe::default_reach(&scene));
        let opts = reference::ProbeTraceOptions {
            paths: self.paths,
            seed: self.seed,
            diffuse_only: self.diffuse_only,
            ..Default::default()
        };
        let progress = TerminalProgress::new();
        let values = reference::trace_probes(&scene, &bvh, &pts, reach, &opts, &progress);
        progress.finish();
        let values = values.with_context(|| self.points.display().to_string())?;
        warn_missing(&values, reach);
        write_json(self.out.as_deref(), &values)?;
        Ok(ExitCode::SUCCESS)
    }
}

impl ProbeCompareArgs {
    fn run(self) -> anyhow::Result<ExitCode> {
        let expected = "a JSON array of probe values (from glint-eval probe or probe-reference)";
        let a: Vec<probe::ProbeValue> = read_json(&self.a, expected)?;
        let b: Vec<probe::ProbeValue> = read_json(&self.b, expected)?;
        let m = probe::compare_probes(&a, &b).map_err(|e| {
            anyhow::anyhow!("{} against {}: {e}", self.a.display(), self.b.display())
        })?;
        if self.json {
            write_json(None, &m)?;
        } else {
            let pct = |x: f64| format!("{:.2}%", 100.0 * x);
            let mut out = std::io::stdout().lock();
            writeln!(out, "probes          {}", m.probes)?;
            writeln!(out, "rel. RMSE       {}", pct(m.rel_rmse))?;
            writeln!(out, "mean ratio      {:.4}", m.mean_ratio)?;
            writeln!(out, "median |error|  {}", pct(m.median))?;
            writeln!(out, "p95 |error|     {}", pct(m.p95))?;
            writeln!(out, "max |error|     {} (probe {})", pct(m.max), m.worst)?;
            if let Some(n) = m.reference_noise {
                writeln!(
                    out,
                    "reference noise {} (median relative standard error)",
                    pct(n)
                )?;
            }
            if let (Some(r), Some(d)) = (m.reference_noise_rms, m.rel_rmse_denoised) {
                writeln!(
                    out,
                    "noise-free RMSE {} (the reference's RMS noise, {}, taken out in quadrature)",
                    pct(d),
                    pct(r)
                )?;
            }
        }
        Ok(ExitCode::SUCCESS)
    }
}

/// Warns about probes that found no surface.
fn warn_missing(values: &[probe::ProbeValue], reach: f32) {
    let missing = values.iter().filter(|v| !v.found).count();
    if missing > 0 {
        log::warn!("{missing} probe(s) found no surface within {reach} m");
    }
}

impl ProbeArgs {
    /// Looks D up at the points, writing JSON to `--out` or stdout.
    fn run(self) -> anyhow::Result<ExitCode> {
        let Self {
            bundle,
            points,
            out,
            reach,
        } = self;
        let pts: Vec<probe::ProbePoint> = read_json(&points, POINTS_JSON)?;
        let b = Bundle::open(&bundle)?;
        let scene = b.load_scene()?;
        let map = RadiosityMap::load(&b)?.with_context(|| {
            format!(
                "{}: no radiosity stage (bake it with glint-bake)",
                bundle.display()
            )
        })?;
        let bvh = scene.build_bvh();
        let reach = reach.unwrap_or_else(|| probe::default_reach(&scene));
        let values = probe::probe(&scene, &bvh, &map, &pts, reach)
            .with_context(|| points.display().to_string())?;
        warn_missing(&values, reach);
        write_json(out.as_deref(), &values)?;
        Ok(ExitCode::SUCCESS)
    }
}

impl CompareArgs {
    /// Prints the metrics of A against B (table or JSON), writing the diff image if asked.
    fn run(self) -> anyhow::Result<ExitCode> {
        let Self {
            a,
            b,
            mask,
            diff,
            json,
        } = self;
        let (ia, ib) = (read_exr(&a)?, read_exr(&b)?);
        let mask = match mask {
            Some(m) => {
                let img = image::open(&m)
                    .with_context(|| format!("reading mask {}", m.display()))?
                    .to_luma8();
                if (img.width() as usize, img.height() as usize) != (ia.width, ia.height) {
                    bail!(
                        "{}: mask is {}x{}, images are {}x{}",
                        m.display(),
                        img.width(),
                        img.height(),
                        ia.width,
                        ia.height
                    );
                }
                Some(compare::mask_from_pixels(img.as_raw(), 1))
            }
            None => None,
        };
        let m = compare::compare(&ia, &ib, mask.as_deref())
            .with_context(|| format!("{} vs {}", a.display(), b.display()))?;
        if let Some(d) = diff {
            let px = compare::diff_image(&ia, &ib, mask.as_deref(), None);
            let png = crate::image_io::encode_png(ia.width as u32, ia.height as u32, &px, false)?;
            write(&d, &png)?;
        }
        let mut stdout = std::io::stdout().lock();
        if json {
            writeln!(stdout, "{}", serde_json::to_string_pretty(&m)?)?;
        } else {
            writeln!(stdout, "pixels     {}", m.pixels)?;
            writeln!(stdout, "RMSE       {:.6}", m.rmse)?;
            writeln!(stdout, "rel. RMSE  {:.6}", m.rel_rmse)?;
            writeln!(stdout, "PSNR       {:.2} dB", m.psnr_db)?;
            writeln!(stdout, "max error  {:.6}", m.max_error)?;
        }
        Ok(ExitCode::SUCCESS)
    }
}

impl SweepArgs {
    /// Renders the reference, sweeps the knobs and prints the CSV; DIR/sweep.csv and
    /// DIR/sweep.svg are written by [`sweep::sweep`].
    fn run(self) -> anyhow::Result<ExitCode> {
        let Self {
            scene,
            set,
            view,
            render,
            quality,
            reflections,
            maps,
            selection,
            curved,
            frames,
            cpu_view,
            view_spp,
            out,
        } = self;
        let knobs = set
            .iter()
            .map(|s| sweep::parse_knob(s))
            .collect::<Result<Vec<_>, _>>()?;
        let base_view = ViewOptions {
            reflections,
            maps: maps as usize,
            selection,
            curved,
            ..Default::default()
        };
        base_view.check().map_err(anyhow::Error::msg)?;
        let scene = Scene::load(&scene)?;
        let cam = camera(&scene, &view)?;
        let mut opts = render.options();
        // Without reflections the view is diffuse: compare with the diffuse scene.
        opts.diffuse_only |= !sweep::shows_reflections(&base_view, &knobs);
        crate::out_dir::create_dir_all(&out)
            .with_context(|| format!("creating {}", out.display()))?;
        let reference = render_reference(&scene, &cam, &opts)?;
        write(&out.join("reference.exr"), &reference.to_exr()?)?;
        let quality = match quality {
            Some(QualityArg::Draft) => Quality::Draft,
            Some(QualityArg::Default) => Quality::Default,
            Some(QualityArg::High) => Quality::High,
            None => scene.desc.bake.quality,
        };
        let progress = TerminalProgress::new();
        let rows = sweep::sweep(
            &scene,
            &reference,
            &sweep::SweepConfig {
                quality,
                knobs: &knobs,
                camera: &cam,
                view: base_view,
                use_viewer: !cpu_view,
                frames: frames as usize,
                view_spp,
                out: &out,
            },
            &progress,
        );
        progress.finish();
        let rows = rows.map_err(|e| {
            let e = anyhow::Error::from(e);
            if !crate::progress::is_interruption(&e) {
                return e;
            }
            // The rows done so far left their files; the table and plot come at the end.
            crate::progress::Interrupted {
                written: format!(
                    "wrote {} and, for the settings swept so far, their bundles under {} and views under {}; no sweep.csv, sweep.svg or table",
                    out.join("reference.exr").display(),
                    out.join("bundles").display(),
                    out.join("views").display()
                ),
            }
            .into()
        })?;
        std::io::stdout()
            .lock()
            .write_all(sweep::to_csv(&rows).as_bytes())?;
        if rows.iter().all(|r| r.frame_ms.is_none()) {
            eprintln!(
                "frame_ms is empty: {}",
                if !sweep::VIEWER_BUILT {
                    "this glint-eval was built without the viewer (`view` feature)"
                } else if cpu_view {
                    "--cpu-view renders D on the CPU"
                } else {
                    "no GPU adapter for the headless viewer"
                }
            );
        }
        eprintln!(
            "wrote {} and {}",
            out.join("sweep.csv").display(),
            out.join("sweep.svg").display()
        );
        Ok(ExitCode::SUCCESS)
    }
}
