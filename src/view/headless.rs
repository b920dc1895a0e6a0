//! Offscreen rendering and headless replay: every frame of a camera path rendered without a
//! window, frames written as PNG (and EXR), per-frame GPU and CPU times to `timings.json`.

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Instant;

use exr::prelude::f16;
use glam::Vec3;

use super::curved::gpu::CurvedReflections;
use super::curved::{CurvedMode, CurvedSettings};
use super::gpu::{Gpu, GpuError, read_texture, read_texture_rgba8};
use super::impostors::{ImpostorKind, ImpostorReflections, ReflectorSet, impostor_pass};
use super::load::{LoadError, ViewData, load};
use super::radiance_maps::Selection;
use super::reflections::{
    GeometryReflections, RecursionSettings, RecursiveReflections, ReflectanceSettings,
    ReflectionMode, Source,
};
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
    /// The bundle cannot be viewed.
    #[error(transparent)]
    Load(#[from] LoadError),
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
    /// Multiplies D before display.
    pub exposure: f32,
    /// Glossy planar reflections ([`ReflectionMode::Off`]: D only).
    pub reflections: ReflectionMode,
    /// Image-based mode: map selection.
    pub selection: Selection,
    /// Image-based mode: maps per reflector element.
    pub map_count: usize,
    /// Reflections: where R is read from (sphere or 1D map) and which channel.
    pub reflectance: ReflectanceSettings,
    /// Reflections of impostors in planar reflectors (Popescu §3–4; `--impostors`).
    pub impostors: bool,
    /// What stands for impostors: depth maps (SRDM) or billboards (`--impostor-kind`).
    pub impostor_kind: ImpostorKind,
    /// Curved reflectors ([`CurvedMode::Off`]: kd·D only).
    pub curved: CurvedMode,
    /// Curved reflectors: regular samples per pixel and lobe (0: one mirror lookup), cube-map
    /// size and generations.
    pub curved_settings: CurvedSettings,
    /// Geometry mode: recursion depth and specular-weight cutoff (issue 10; depth 1 is the
    /// single mirror pass of issue 9, other depths [`RecursiveReflections`]).
    pub recursion: RecursionSettings,
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
            exposure: 1.0,
            reflections: ReflectionMode::Off,
            selection: Selection::Angle,
            map_count: 2,
            reflectance: ReflectanceSettings::default(),
            impostors: false,
            impostor_kind: ImpostorKind::Srdm,
            curved: CurvedMode::Off,
            curved_settings: CurvedSettings::default(),
            recursion: RecursionSettings::default(),
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

    /// The first pass's writes: its beginning, and its end too when it is the only pass.
    fn writes(&self, only_pass: bool) -> wgpu::RenderPassTimestampWrites<'_> {
        wgpu::RenderPassTimestampWrites {
            query_set: &self.queries,
            beginning_of_pass_write_index: Some(0),
            end_of_pass_write_index: only_pass.then_some(1),
        }
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

/// A renderer with an offscreen target: renders frames, times them, reads them back.
pub struct Offscreen {
    /// The scene's renderer.
    pub renderer: Renderer,
    /// The target frames go to.
    pub target: OffscreenTarget,
    timer: Option<GpuTimer>,
    reflections: Option<GeometryReflections>,
    mode: ReflectionMode,
    /// Image-based mode: how radiance maps are selected (takes effect at the next
    /// [`Offscreen::set_reflections`]).
    pub selection: Selection,
    /// Image-based mode: maps selected per reflector element (likewise).
    pub map_count: usize,
    /// Reflections: R's layout and channel (likewise).
    pub reflectance: ReflectanceSettings,
    impostors: Option<ImpostorReflections>,
    curved: Option<CurvedReflections>,
    /// Geometry mode's recursion (likewise): depth 1 uses [`GeometryReflections`], any other
    /// depth [`RecursiveReflections`].
    pub recursion: RecursionSettings,
    recursive: Option<RecursiveReflections>,
    curved_impostors: Option<ImpostorReflections>,
    /// Depth maps or billboards (takes effect at the next [`Offscreen::set_impostors`] or
    /// [`Offscreen::set_curved`]).
    pub impostor_kind: ImpostorKind,
}

impl Offscreen {
    /// A `width` × `height` offscreen renderer of `data` (with an HDR target when `hdr`).
    pub fn new(
        gpu: &Gpu,
        data: &ViewData,
        width: u32,
        height: u32,
        hdr: bool,
    ) -> Result<Offscreen, RenderError> {
        let renderer = Renderer::new(
            gpu,
            &data.scene,
            &data.map,
            TargetFormats {
                color: COLOR_FORMAT,
                hdr,
            },
        )?;
        let target = OffscreenTarget::new(gpu, width, height, hdr)?;
        Ok(Offscreen {
            renderer,
            target,
            timer: GpuTimer::new(gpu),
            reflections: None,
            mode: ReflectionMode::Off,
            selection: Selection::Angle,
            map_count: 2,
            reflectance: ReflectanceSettings::default(),
            impostors: None,
            curved: None,
            recursion: RecursionSettings::default(),
            recursive: None,
            curved_impostors: None,
            impostor_kind: ImpostorKind::Srdm,
        })
    }

    /// Switches reflections of impostors in planar reflectors on or off (depth maps need the
    /// bundle's `srdm` stage when the scene has impostors).
    pub fn set_impostors(
        &mut self,
        gpu: &Gpu,
        data: &ViewData,
        on: bool,
    ) -> Result<(), RenderError> {
        self.impostors = if on {
            Some(impostor_pass(
                gpu,
                &self.renderer,
                data,
                self.impostor_kind,
                ReflectorSet::Planar,
            )?)
        } else {
            None
        };
        Ok(())
    }

    /// Uses `pass` for impostor reflections (benchmarks build it with other tables).
    pub fn set_impostor_pass(&mut self, pass: Option<ImpostorReflections>) {
        self.impostors = pass;
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
        self.curved = None;
        self.curved_impostors = None;
        match mode {
            CurvedMode::Off => {}
            CurvedMode::Cubemap => {
                self.curved = Some(CurvedReflections::new(gpu, &self.renderer, data, settings)?);
            }
            CurvedMode::Impostor => {
                self.curved_impostors = Some(impostor_pass(
                    gpu,
                    &self.renderer,
                    data,
                    self.impostor_kind,
                    ReflectorSet::Curved,
                )?);
            }
        }
        Ok(())
    }

    /// The impostor pass of curved reflectors (`--curved impostor`), if any.
    pub fn curved_impostors(&self) -> Option<&ImpostorReflections> {
        self.curved_impostors.as_ref()
    }

    /// The curved-reflector passes in use, if any.
    pub fn curved(&self) -> Option<&CurvedReflections> {
        self.curved.as_ref()
    }

    /// Switches glossy reflections to `mode` (built for this target's size). The image-based
    /// mode needs the bundle's `radiance` stage.
    pub fn set_reflections(
        &mut self,
        gpu: &Gpu,
        data: &ViewData,
        mode: ReflectionMode,
    ) -> Result<(), RenderError> {
        self.mode = mode;
        self.recursive = None;
        if mode != ReflectionMode::Geometry && self.recursion.depth != 1 {
            return Err(RenderError::Reflections(format!(
                "recursion depth {} needs geometry reflections (reflections are {mode})",
                self.recursion.depth
            )));
        }
        self.reflections = match mode {
            ReflectionMode::Off => None,
            ReflectionMode::Geometry if self.recursion.depth != 1 => {
                self.recursive = Some(RecursiveReflections::new(
                    gpu,
                    &self.renderer,
                    data,
                    self.target.width,
                    self.target.height,
                    self.reflectance,
                    self.recursion,
                )?);
                None
            }
            ReflectionMode::Geometry => Some(GeometryReflections::with_reflectance(
                gpu,
                &self.renderer,
                data,
                self.target.width,
                self.target.height,
                Source::Geometry,
                self.reflectance,
            )?),
            ReflectionMode::Image => Some(GeometryReflections::with_reflectance(
                gpu,
                &self.renderer,
                data,
                self.target.width,
                self.target.height,
                Source::Image {
                    selection: self.selection,
                    count: self.map_count,
                },
                self.reflectance,
            )?),
        };
        Ok(())
    }

    /// The reflection passes in use (`None` when off).
    pub fn reflections(&self) -> Option<&GeometryReflections> {
        self.reflections.as_ref()
    }

    /// The recursive reflection passes in use (geometry mode at a depth other than 1).
    pub fn recursive(&self) -> Option<&RecursiveReflections> {
        self.recursive.as_ref()
    }

    /// The reflection mode in use.
    pub fn reflection_mode(&self) -> ReflectionMode {
        self.mode
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
            self.renderer
                .prepare(gpu, camera, self.target.width, self.target.height);
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("glint frame encoder"),
                });
            if let Some(r) = &self.recursive {
                r.prepare(gpu, &self.renderer, camera, self.curved.as_ref());
            }
            let reflection_passes = self
                .reflections
                .as_ref()
                .map_or(0, |r| r.pass_count(camera))
                + self.recursive.as_ref().map_or(0, |r| r.pass_count());
            self.target.draw(
                &self.renderer,
                &mut encoder,
                self.timer
                    .as_ref()
                    .map(|t| t.writes(reflection_passes == 0)),
            );
            if let Some(r) = &self.reflections {
                r.prepare(gpu, &self.renderer, camera, self.curved.as_ref());
                let (color, hdr, depth) = self.target.views();
                // The last reflection pass ends the frame's timestamp span.
                r.draw_timed(
                    &mut encoder,
                    &self.renderer,
                    camera,
                    color,
                    hdr,
                    depth,
                    self.timer.as_ref().map(|t| (&t.queries, 1)),
                    self.curved.as_ref(),
                );
            }
            if let Some(r) = &self.impostors {
                r.prepare(gpu, camera);
                let (color, hdr, depth) = self.target.views();
                r.draw(&mut encoder, color, hdr, depth);
            }
            if let Some(r) = &self.curved_impostors {
                r.prepare(gpu, camera);
                let (color, hdr, depth) = self.target.views();
                r.draw(&mut encoder, color, hdr, depth);
            }
            if let Some(c) = &self.curved {
                c.prepare(gpu, camera);
                let (color, hdr, depth) = self.target.views();
                c.draw(&mut encoder, color, hdr, depth);
            }
            if let Some(r) = &self.recursive {
                let (color, hdr, depth) = self.target.views();
                r.draw_timed(
                    &mut encoder,
                    &self.renderer,
                    color,
                    hdr,
                    depth,
                    self.timer.as_ref().map(|t| (&t.queries, 1)),
                    self.curved.as_ref(),
                );
            }
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
    let mut offscreen = Offscreen::new(gpu, data, options.width, options.height, options.hdr)?;
    offscreen.renderer.exposure = options.exposure;
    offscreen.selection = options.selection;
    offscreen.map_count = options.map_count;
    offscreen.reflectance = options.reflectance;
    offscreen.recursion = options.recursion;
    offscreen.set_reflections(gpu, data, options.reflections)?;
    offscreen.impostor_kind = options.impostor_kind;
    offscreen.set_impostors(gpu, data, options.impostors)?;
    offscreen.set_curved(gpu, data, options.curved, options.curved_settings)?;
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
