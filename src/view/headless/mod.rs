//! Headless replay: every frame of a camera path rendered without a window
//! ([`Offscreen`], re-exported from [`offscreen`]), frames written as PNG (and EXR),
//! per-frame GPU and CPU times to `timings.json`; frames may be supersampled
//! ([`supersample`]).

pub mod offscreen;
pub mod replay;
pub mod supersample;

use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::camera::{Camera, Keyframe};
use crate::image_io::{self, ImageError};
use crate::progress::Progress;
use crate::view::gpu::RenderError;
use crate::view::gpu::{Gpu, GpuError};
use crate::view::load::{LoadError, ViewData, load};
use crate::view::options::ViewOptions;
pub use offscreen::{FrameTimes, Offscreen};
use replay::{
    FrameTiming, Rendered, ScheduledFrame, Summary, TIMINGS_FILE, TIMINGS_FORMAT, TIMINGS_VERSION,
    Timings, frame_file_name, schedule,
};

/// Why a headless replay failed.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    /// The bundle cannot be viewed (boxed: a load error is large, and every result of a
    /// replay carries this type).
    #[error(transparent)]
    Load(Box<LoadError>),
    /// GPU set-up or rendering failed.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// The scene has no such camera path (or none at all).
    #[error("bundle {}: {message}", bundle.display())]
    NoPath {
        /// The bundle.
        bundle: PathBuf,
        /// Which path was asked for and which exist.
        message: String,
    },
    /// The frame asked for is past the camera path's end.
    #[error("bundle {}: {message}", bundle.display())]
    NoFrame {
        /// The bundle.
        bundle: PathBuf,
        /// The frame asked for and the path's frames.
        message: String,
    },
    /// The camera path has more frames than a replay renders.
    #[error("bundle {}: {message}", bundle.display())]
    PathTooLong {
        /// The bundle.
        bundle: PathBuf,
        /// The path, its frame count and the limit.
        message: String,
    },
    /// Writing an output file.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// Encoding a frame.
    #[error("{}: {source}", path.display())]
    Image {
        /// The file being written.
        path: PathBuf,
        /// The cause.
        source: ImageError,
    },
    /// Writing timings.json.
    #[error(transparent)]
    Timings(#[from] crate::bundle::BundleError),
    /// Ctrl-C during a replay: the frames written so far stay, timings.json is not written.
    #[error(
        "interrupted after {rendered} of {frames} frames: {written} frame(s) were written{}, no {TIMINGS_FILE}",
        out.as_ref().map_or(String::new(), |o| format!(" to {}", o.display()))
    )]
    Interrupted {
        /// Frames rendered and timed, and in the path.
        rendered: usize,
        frames: usize,
        /// Frames written, and where.
        written: usize,
        out: Option<PathBuf>,
    },
}

impl From<LoadError> for ViewError {
    fn from(e: LoadError) -> Self {
        ViewError::Load(Box::new(e))
    }
}

impl From<GpuError> for ViewError {
    fn from(e: GpuError) -> Self {
        ViewError::Render(RenderError::Gpu(e))
    }
}

/// What a headless replay renders and writes.
#[derive(Clone, Debug)]
pub struct ReplayOptions {
    /// Camera path name; `None`: the scene's first path.
    pub path: Option<String>,
    /// Frame width in pixels.
    pub width: u32,
    /// Frame height in pixels.
    pub height: u32,
    /// Output folder for frames and timings.json; `None` writes nothing (benchmarks).
    pub out: Option<PathBuf>,
    /// Render and write every `every`-th frame of the path (0: render and time every frame,
    /// write none; timings.json is still written).
    pub every: usize,
    /// Render frame K of the path alone (`every` is then ignored).
    pub frame: Option<usize>,
    /// Render one frame from this camera instead of a path (`path`, `frame` and `every` are
    /// then ignored).
    pub camera: Option<Keyframe>,
    /// Also write each written frame as a half-float EXR of linear radiance (never exposed).
    pub hdr: bool,
    /// Samples a pixel along each axis: each frame is rendered at this many times its width
    /// and height and box-filtered down in linear radiance ([`supersample`]); 1: off.
    pub supersample: u32,
    /// What the frames show.
    pub view: ViewOptions,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        ReplayOptions {
            path: None,
            width: 720,
            height: 486,
            out: None,
            every: 1,
            frame: None,
            camera: None,
            hdr: false,
            supersample: 1,
            view: ViewOptions::default(),
        }
    }
}

/// RGBA8 to RGB8 (frames are opaque).
pub fn rgba_to_rgb(rgba: &[u8]) -> Vec<u8> {
    rgba.chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect()
}

/// Opens the bundle at `bundle` and the GPU, then [`replay_with`].
pub fn replay(
    bundle: &Path,
    options: &ReplayOptions,
    progress: &dyn Progress,
) -> Result<Timings, ViewError> {
    let data = load(bundle)?;
    let gpu = Gpu::headless_with_features(wgpu::Features::TIMESTAMP_QUERY)?;
    replay_with(&gpu, &data, options, progress)
}

/// Renders the chosen frames of the camera path (or the one camera) offscreen, writes them
/// and `timings.json` into `options.out` (created if missing), and returns the timings.
/// One untimed warm-up frame is rendered first (shader compilation, first uploads).
pub fn replay_with(
    gpu: &Gpu,
    data: &ViewData,
    options: &ReplayOptions,
    progress: &dyn Progress,
) -> Result<Timings, ViewError> {
    let bundle = data.bundle.dir().to_owned();
    let (path_name, path_frames, frames, rendered) = match options.camera {
        Some(key) => {
            let frame = ScheduledFrame {
                index: 0,
                time: 0.0,
                camera: Camera::from_keyframe(&key),
            };
            (String::new(), 1, vec![frame], Rendered::Camera(key))
        }
        None => path_frames(data, options)?,
    };
    if let Some(out) = &options.out {
        crate::out_dir::create_dir_all(out).map_err(|source| ViewError::Io {
            path: out.clone(),
            source,
        })?;
    }
    let k = options.supersample.max(1);
    let offscreen = Offscreen::with_options(
        gpu,
        data,
        options.width * k,
        options.height * k,
        &options.view,
    )?;
    log::info!(
        "8-bit frames: exposure {} ({:+.2} EV; auto would be {:+.2} EV), tone curve {}",
        options.view.exposure,
        options.view.exposure.ev(offscreen.frame().auto_ev()),
        offscreen.frame().auto_ev(),
        options.view.tonemap
    );
    // `--every 0` times every frame and writes none.
    let write = rendered != Rendered::All || options.every != 0;

    let warmup = offscreen.render(gpu, &frames[0].camera)?;
    progress.phase("rendering frames", frames.len() as u64);
    let mut timings: Vec<FrameTiming> = Vec::with_capacity(frames.len());
    for f in &frames {
        if progress.cancelled() {
            return Err(ViewError::Interrupted {
                rendered: timings.len(),
                frames: frames.len(),
                written: timings.iter().filter(|t| !t.files.is_empty()).count(),
                out: options.out.clone(),
            });
        }
        let t = offscreen.render(gpu, &f.camera)?;
        let mut files = Vec::new();
        if let Some(out) = &options.out
            && write
        {
            files = write_frame(gpu, &offscreen, out, f.index, options)?;
        }
        timings.push(FrameTiming {
            frame: f.index,
            time: f.time,
            gpu_ms: t.gpu_ms,
            cpu_ms: t.cpu_ms,
            frame_ms: t.frame_ms,
            files,
        });
        progress.advance(1);
    }
    let result = Timings {
        format: TIMINGS_FORMAT.into(),
        version: TIMINGS_VERSION,
        bundle,
        scene: data.scene.name.clone(),
        path: path_name,
        path_frames,
        rendered,
        size: [options.width, options.height],
        supersample: k,
        adapter: gpu.adapter_summary(),
        gpu_time_source: offscreen.gpu_time_source(),
        warmup_ms: warmup.frame_ms,
        summary: Summary::of(&timings),
        frames: timings,
    };
    if let Some(out) = &options.out {
        result.write(out)?;
    }
    Ok(result)
}

/// The camera path `options` names: its name, its frame count, the frames to render and
/// which they are.
fn path_frames(
    data: &ViewData,
    options: &ReplayOptions,
) -> Result<(String, usize, Vec<ScheduledFrame>, Rendered), ViewError> {
    let bundle = data.bundle.dir().to_owned();
    let path = data
        .scene
        .camera_path(options.path.as_deref())
        .ok_or_else(|| {
            let names: Vec<&str> = data
                .scene
                .camera_paths
                .iter()
                .map(|p| p.name.as_str())
                .collect();
            let message = if names.is_empty() {
                "its scene has no camera paths to replay; add `camera_paths` to scene.json \
                 or a camera node to its glTF (or record a path in the window with R)"
                    .to_string()
            } else {
                format!(
                    "its scene has no camera path {:?}; it has {}",
                    options.path.as_deref().unwrap_or_default(),
                    names.join(", ")
                )
            };
            ViewError::NoPath {
                bundle: bundle.clone(),
                message,
            }
        })?;
    let all = schedule(path).map_err(|message| ViewError::PathTooLong {
        bundle: bundle.clone(),
        message,
    })?;
    let count = all.len();
    let rendered = match options.frame {
        Some(k) => Rendered::Frame(k),
        None => Rendered::every(options.every),
    };
    let frames = rendered
        .pick(&path.name, all)
        .map_err(|message| ViewError::NoFrame { bundle, message })?;
    Ok((path.name.clone(), count, frames, rendered))
}

/// Writes the target's current frame as PNG (exposed, tone-mapped) and, when `options.hdr`,
/// as EXR (linear radiance); a supersampled frame is box-filtered down first, in radiance.
fn write_frame(
    gpu: &Gpu,
    offscreen: &Offscreen,
    out: &Path,
    index: usize,
    options: &ReplayOptions,
) -> Result<Vec<String>, ViewError> {
    let (w, h) = (options.width, options.height);
    let k = options.supersample.max(1);
    // One sample a pixel: the display pass's own 8-bit frame. Supersampled: the radiance
    // filtered down, then the same mapping on the CPU (`DisplayMapping::apply`, held to the
    // shader by a test), since filtering after the tone curve would darken highlights.
    let radiance = (k > 1 || options.hdr)
        .then(|| offscreen.read_hdr(gpu))
        .transpose()?
        .map(|fine| match k {
            1 => fine,
            _ => image_io::downsample(
                &fine,
                (w * k) as usize,
                (h * k) as usize,
                w as usize,
                h as usize,
            ),
        });
    let rgba = match &radiance {
        Some(radiance) if k > 1 => {
            let mapping = offscreen.frame().display_mapping();
            let shown: Vec<Vec3> = radiance.iter().map(|&c| mapping.apply(c)).collect();
            crate::view::cpu::to_srgb8(&shown)
        }
        _ => offscreen.read_rgba8(gpu)?,
    };
    let rgb = rgba_to_rgb(&rgba);
    let mut files = Vec::new();
    let name = frame_file_name(index, "png");
    let path = out.join(&name);
    let png = image_io::encode_png(w, h, &rgb, false).map_err(|source| ViewError::Image {
        path: path.clone(),
        source,
    })?;
    std::fs::write(&path, png).map_err(|source| ViewError::Io { path, source })?;
    files.push(name);
    if let (true, Some(hdr)) = (options.hdr, radiance) {
        let name = frame_file_name(index, "exr");
        let path = out.join(&name);
        let exr = image_io::encode_rgb_exr(w as usize, h as usize, &hdr).map_err(|source| {
            ViewError::Image {
                path: path.clone(),
                source,
            }
        })?;
        std::fs::write(&path, exr).map_err(|source| ViewError::Io { path, source })?;
        files.push(name);
    }
    Ok(files)
}
