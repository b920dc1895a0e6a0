//! Offscreen rendering and headless replay: every frame of a camera path rendered without a
//! window, frames written as PNG (and EXR), per-frame GPU and CPU times to `timings.json`.

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Instant;

use exr::prelude::f16;
use glam::Vec3;

use super::curved::gpu::CurvedReflections;
use super::frame::{FramePasses, FrameViews, Rebuild};
use super::gpu::{Gpu, GpuError, read_texture, read_texture_rgba8};
use super::impostors::ImpostorReflections;
use super::load::{LoadError, ViewData, load};
use super::options::{CurvedMode, CurvedSettings, ReflectionMode, ViewOptions};
use super::reflections::{GeometryReflections, RecursiveReflections};
use super::renderer::{COLOR_FORMAT, OffscreenTarget, RenderError, Renderer, TargetFormats};
use super::replay::{
    FrameTiming, GpuTimeSource, Summary, TIMINGS_FORMAT, TIMINGS_VERSION, Timings, frame_file_name,
    is_written, schedule,
};
use crate::camera::Camera;
use crate::image_io::{self, ImageError};
use crate::progress::{Cancelled, Progress};

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
    /// Ctrl-C.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
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
    /// Write every `every`-th frame (0: none; timings.json is still written).
    pub every: usize,
    /// Also write each written frame as a half-float linear EXR.
    pub hdr: bool,
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
            hdr: false,
            view: ViewOptions::default(),
        }
    }
}

/// Timestamp queries spanning a frame's render passes, when the device has them: the first
/// pass's beginning (index 0) to the last pass's end (index 1).
struct GpuTimer {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    /// Nanoseconds per timestamp tick.
    period_ns: f64,
}

impl GpuTimer {
    fn new(gpu: &Gpu) -> Option<GpuTimer> {
        if !gpu
            .device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
        {
            return None;
        }
        let queries = gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("glint frame timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: 2,
        });
        let buffer = |usage, label| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 16,
                usage,
                mapped_at_creation: false,
            })
        };
        Some(GpuTimer {
            queries,
            resolve: buffer(
                wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                "glint timestamp resolve",
            ),
            readback: buffer(
                wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                "glint timestamp readback",
            ),
            period_ns: f64::from(gpu.queue.get_timestamp_period()),
        })
    }

    fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.queries, 0..2, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, 16);
    }

    /// Milliseconds between the two timestamps (the submission must be complete).
    fn read_ms(&self, gpu: &Gpu) -> Result<f64, GpuError> {
        let slice = self.readback.slice(..);
        let (sender, receiver) = mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = sender.send(r);
        });
        gpu.device.poll(wgpu::PollType::wait_indefinitely())?;
        receiver
            .recv()
            .map_err(|_| GpuError::MapCallbackDropped)??;
        let ticks: [u64; 2] = {
            let mapped = slice.get_mapped_range()?;
            let v: &[u64] = bytemuck::cast_slice(&mapped);
            [v[0], v[1]]
        };
        self.readback.unmap();
        Ok(ticks[1].saturating_sub(ticks[0]) as f64 * self.period_ns * 1e-6)
    }
}

/// Times of one rendered frame, milliseconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameTimes {
    /// GPU time from the first pass's beginning to the last pass's end, reflection passes
    /// included (or submit-to-complete without timestamp queries).
    pub gpu_ms: f64,
    /// Uniform update, command recording and submission.
    pub cpu_ms: f64,
    /// Start of the frame until the GPU finished it.
    pub frame_ms: f64,
}

/// A frame's passes with an offscreen target: renders frames, times them, reads them back.
pub struct Offscreen {
    /// The target frames go to.
    pub target: OffscreenTarget,
    timer: Option<GpuTimer>,
    frame: FramePasses,
    /// The options the next `set_*` call builds with (the reflection mode, impostors and
    /// curved mode are set by those calls; the rest is read from here).
    pub options: ViewOptions,
}

impl Offscreen {
    /// A `width` × `height` offscreen renderer of `data` (with an HDR target when `hdr`),
    /// drawing D only until a `set_*` call turns passes on.
    pub fn new(
        gpu: &Gpu,
        data: &ViewData,
        width: u32,
        height: u32,
        hdr: bool,
    ) -> Result<Offscreen, RenderError> {
        let target = OffscreenTarget::new(gpu, width, height, hdr)?;
        let frame = FramePasses::scene_only(gpu, data, formats(hdr), (width, height))?;
        Ok(Offscreen {
            target,
            timer: GpuTimer::new(gpu),
            frame,
            options: ViewOptions::default(),
        })
    }

    /// A `width` × `height` offscreen renderer of `data` with every pass `options` asks for.
    pub fn with_options(
        gpu: &Gpu,
        data: &ViewData,
        width: u32,
        height: u32,
        hdr: bool,
        options: &ViewOptions,
    ) -> Result<Offscreen, RenderError> {
        let target = OffscreenTarget::new(gpu, width, height, hdr)?;
        let frame = FramePasses::new(gpu, data, formats(hdr), (width, height), options)?;
        Ok(Offscreen {
            target,
            timer: GpuTimer::new(gpu),
            frame,
            options: *options,
        })
    }

    /// The scene pass.
    pub fn renderer(&self) -> &Renderer {
        self.frame.renderer()
    }

    /// The frame's passes.
    pub fn frame(&self) -> &FramePasses {
        &self.frame
    }

    /// Switches to `options`, rebuilding the passes whose inputs changed.
    pub fn set_options(
        &mut self,
        gpu: &Gpu,
        data: &ViewData,
        options: &ViewOptions,
    ) -> Result<(), RenderError> {
        self.options = *options;
        self.frame.set_options(gpu, data, options)
    }

    /// [`Offscreen::options`] with `change` applied, the passes of `groups` rebuilt.
    fn apply(
        &mut self,
        gpu: &Gpu,
        data: &ViewData,
        change: impl FnOnce(&mut ViewOptions),
        groups: Rebuild,
    ) -> Result<(), RenderError> {
        change(&mut self.options);
        self.frame
            .set_options_rebuilding(gpu, data, &self.options, groups)
    }

    /// Switches reflections of impostors in planar reflectors on or off (depth maps need the
    /// bundle's `srdm` stage when the scene has impostors).
    pub fn set_impostors(
        &mut self,
        gpu: &Gpu,
        data: &ViewData,
        on: bool,
    ) -> Result<(), RenderError> {
        let groups = Rebuild {
            impostors: true,
            ..Rebuild::default()
        };
        self.apply(gpu, data, |o| o.impostors = on, groups)
    }

    /// Uses `pass` for impostor reflections (benchmarks build it with other tables).
    pub fn set_impostor_pass(&mut self, pass: Option<ImpostorReflections>) {
        self.frame.set_impostor_pass(pass);
    }

    /// Switches curved reflectors to `mode` with `settings`; building them renders their
    /// cube maps (every generation) before returning.
    pub fn set_curved(
        &mut self,
        gpu: &Gpu,
        data: &ViewData,
        mode: CurvedMode,
        settings: CurvedSettings,
    ) -> Result<(), RenderError> {
        let groups = Rebuild {
            curved: true,
            ..Rebuild::default()
        };
        let change = |o: &mut ViewOptions| {
            o.curved = mode;
            o.curved_settings = settings;
        };
        self.apply(gpu, data, change, groups)
    }

    /// The impostor pass of curved reflectors (`--curved impostor`), if any.
    pub fn curved_impostors(&self) -> Option<&ImpostorReflections> {
        self.frame.curved_impostors()
    }

    /// The curved-reflector passes in use, if any.
    pub fn curved(&self) -> Option<&CurvedReflections> {
        self.frame.curved()
    }

    /// Switches glossy reflections to `mode` (built for this target's size). The image-based
    /// mode needs the bundle's `radiance` stage; a recursion depth other than 1 needs
    /// geometry reflections.
    pub fn set_reflections(
        &mut self,
        gpu: &Gpu,
        data: &ViewData,
        mode: ReflectionMode,
    ) -> Result<(), RenderError> {
        if mode != ReflectionMode::Geometry && self.options.recursion.depth != 1 {
            return Err(RenderError::Reflections(format!(
                "recursion depth {} needs geometry reflections (reflections are {mode})",
                self.options.recursion.depth
            )));
        }
        let groups = Rebuild {
            planar: true,
            ..Rebuild::default()
        };
        self.apply(gpu, data, |o| o.reflections = mode, groups)
    }

    /// The single planar reflection pass in use (`None` when off or recursive).
    pub fn reflections(&self) -> Option<&GeometryReflections> {
        self.frame.planar()
    }

    /// The recursive reflection passes in use (geometry mode at a depth other than 1).
    pub fn recursive(&self) -> Option<&RecursiveReflections> {
        self.frame.recursive()
    }

    /// The reflection mode in use.
    pub fn reflection_mode(&self) -> ReflectionMode {
        self.frame.options().reflections
    }

    /// How [`FrameTimes::gpu_ms`] is measured on this device.
    pub fn gpu_time_source(&self) -> GpuTimeSource {
        if self.timer.is_some() {
            GpuTimeSource::TimestampQuery
        } else {
            GpuTimeSource::SubmitToComplete
        }
    }

    /// Renders one frame from `camera` and waits for it to finish.
    pub fn render(&self, gpu: &Gpu, camera: &Camera) -> Result<FrameTimes, GpuError> {
        let start = Instant::now();
        let submission = super::gpu::error_scoped(&gpu.device, "rendering a frame", || {
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("glint frame encoder"),
                });
            self.frame.prepare(gpu, camera);
            let (color, hdr, depth) = self.target.views();
            self.frame.record(
                &mut encoder,
                camera,
                FrameViews { color, hdr, depth },
                self.timer.as_ref().map(|t| &t.queries),
            );
            if let Some(t) = &self.timer {
                t.resolve(&mut encoder);
            }
            gpu.queue.submit([encoder.finish()])
        })?;
        let submitted = Instant::now();
        gpu.device.poll(wgpu::PollType::Wait {
            submission_index: Some(submission),
            timeout: None,
        })?;
        let done = Instant::now();
        let ms = |a: Instant, b: Instant| (b - a).as_secs_f64() * 1e3;
        let gpu_ms = match &self.timer {
            Some(t) => t.read_ms(gpu)?,
            None => ms(submitted, done),
        };
        Ok(FrameTimes {
            gpu_ms,
            cpu_ms: ms(start, submitted),
            frame_ms: ms(start, done),
        })
    }

    /// The last frame as 8-bit sRGB RGBA, top row first.
    pub fn read_rgba8(&self, gpu: &Gpu) -> Result<Vec<u8>, GpuError> {
        read_texture_rgba8(gpu, &self.target.color)
    }

    /// The last frame's linear radiance (× exposure), top row first; `None` without an HDR
    /// target.
    pub fn read_hdr(&self, gpu: &Gpu) -> Result<Option<Vec<Vec3>>, GpuError> {
        let Some(hdr) = &self.target.hdr else {
            return Ok(None);
        };
        let bytes = read_texture(gpu, hdr)?;
        let halves: Vec<u16> = bytes
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
            .collect();
        Ok(Some(
            halves
                .chunks_exact(4)
                .map(|t| Vec3::new(h(t[0]), h(t[1]), h(t[2])))
                .collect(),
        ))
    }
}

/// The offscreen target's formats: [`COLOR_FORMAT`], and HDR when asked for.
fn formats(hdr: bool) -> TargetFormats {
    TargetFormats {
        color: COLOR_FORMAT,
        hdr,
    }
}

fn h(bits: u16) -> f32 {
    f16::from_bits(bits).to_f32()
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

/// Renders every frame of the camera path offscreen, writes the chosen frames and
/// `timings.json` into `options.out` (created if missing), and returns the timings.
/// One untimed warm-up frame is rendered first (shader compilation, first uploads).
pub fn replay_with(
    gpu: &Gpu,
    data: &ViewData,
    options: &ReplayOptions,
    progress: &dyn Progress,
) -> Result<Timings, ViewError> {
    let bundle = data.bundle.dir().to_owned();
    let path = data
        .scene
        .camera_path(options.path.as_deref())
        .ok_or_else(|| {
            let names: Vec<&str> = data
                .scene
                .desc
                .camera_paths
                .iter()
                .map(|p| p.name.as_str())
                .collect();
            let message = if names.is_empty() {
                "its scene has no camera paths to replay; add `camera_paths` to scene.json \
                 (or record one in the window with R)"
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
    if let Some(out) = &options.out {
        std::fs::create_dir_all(out).map_err(|source| ViewError::Io {
            path: out.clone(),
            source,
        })?;
    }
    let offscreen = Offscreen::with_options(
        gpu,
        data,
        options.width,
        options.height,
        options.hdr,
        &options.view,
    )?;
    let frames = schedule(path).map_err(|message| ViewError::PathTooLong {
        bundle: bundle.clone(),
        message,
    })?;

    let warmup = offscreen.render(gpu, &frames[0].camera)?;
    progress.phase("rendering frames", frames.len() as u64);
    let mut timings = Vec::with_capacity(frames.len());
    for f in &frames {
        if progress.cancelled() {
            return Err(Cancelled.into());
        }
        let t = offscreen.render(gpu, &f.camera)?;
        let mut files = Vec::new();
        if let Some(out) = &options.out
            && is_written(f.index, options.every)
        {
            files = write_frame(gpu, &offscreen, out, f.index)?;
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
        path: path.name.clone(),
        size: [options.width, options.height],
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

/// Writes the target's current frame as PNG (and EXR when it has an HDR target).
fn write_frame(
    gpu: &Gpu,
    offscreen: &Offscreen,
    out: &Path,
    index: usize,
) -> Result<Vec<String>, ViewError> {
    let (w, h) = (offscreen.target.width, offscreen.target.height);
    let mut files = Vec::new();
    let name = frame_file_name(index, "png");
    let path = out.join(&name);
    let rgb = rgba_to_rgb(&offscreen.read_rgba8(gpu)?);
    let png = image_io::encode_png(w, h, &rgb, false).map_err(|source| ViewError::Image {
        path: path.clone(),
        source,
    })?;
    std::fs::write(&path, png).map_err(|source| ViewError::Io { path, source })?;
    files.push(name);
    if let Some(hdr) = offscreen.read_hdr(gpu)? {
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
