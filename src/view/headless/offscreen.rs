//! Offscreen frames: a frame's passes ([`FramePasses`]) drawn into an offscreen target,
//! timed (timestamp queries where the device has them) and read back.

use std::time::Instant;

use glam::Vec3;

use super::replay::GpuTimeSource;
use crate::camera::Camera;
use crate::view::curved::gpu::CurvedReflections;
use crate::view::frame::{FramePasses, Rebuild};
use crate::view::gpu::RenderError;
use crate::view::gpu::build::buffer;
use crate::view::gpu::readback::{map_read, read_texture_rgba8, read_texture_rgba16f};
use crate::view::gpu::target::{COLOR_FORMAT, OffscreenTarget};
use crate::view::gpu::{Gpu, GpuError, error_scoped};
use crate::view::impostors::ImpostorReflections;
use crate::view::load::ViewData;
use crate::view::options::{
    CurvedMode, CurvedSettings, Exposure, ReflectionMode, Tonemap, ViewOptions,
};
use crate::view::passes::renderer::Renderer;
use crate::view::reflections::{GeometryReflections, RecursiveReflections};

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
        let buffer = |usage, label| buffer(&gpu.device, label, 16, usage);
        Some(GpuTimer {
            queries,
            resolve: buffer(
                wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                "glint timestamp resolve",
            ),
            readback: buffer(wgpu::BufferUsages::MAP_READ, "glint timestamp readback"),
            period_ns: f64::from(gpu.queue.get_timestamp_period()),
        })
    }

    fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.queries, 0..2, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, 16);
    }

    /// Milliseconds between the two timestamps (the submission must be complete).
    fn read_ms(&self, gpu: &Gpu) -> Result<f64, GpuError> {
        let bytes = map_read(gpu, &self.readback, None)?;
        let ticks: [u64; 2] = bytemuck::pod_read_unaligned(&bytes[..16]);
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
    /// A `width` × `height` offscreen renderer of `data`, drawing D only until a `set_*` call
    /// turns passes on, its 8-bit frames shown by [`ViewOptions::linear_display`] (0 EV, no
    /// tone curve: radiance clamped and sRGB-encoded, as the CPU references are) until
    /// [`Offscreen::set_display`] says otherwise, one sample a pixel (the CPU references cast
    /// one ray through each pixel's centre) until [`Offscreen::set_options`] says otherwise.
    pub fn new(
        gpu: &Gpu,
        data: &ViewData,
        width: u32,
        height: u32,
    ) -> Result<Offscreen, RenderError> {
        let target = OffscreenTarget::new(gpu, width, height)?;
        let mut frame = FramePasses::scene_only(gpu, data, COLOR_FORMAT, (width, height), 1)?;
        let options = ViewOptions {
            samples: 1,
            ..ViewOptions::default().linear_display()
        };
        frame.set_display(options.exposure, options.tonemap);
        Ok(Offscreen {
            target,
            timer: GpuTimer::new(gpu),
            frame,
            options,
        })
    }

    /// A `width` × `height` offscreen renderer of `data` with every pass `options` asks for.
    pub fn with_options(
        gpu: &Gpu,
        data: &ViewData,
        width: u32,
        height: u32,
        options: &ViewOptions,
    ) -> Result<Offscreen, RenderError> {
        let target = OffscreenTarget::new(gpu, width, height)?;
        let frame = FramePasses::new(gpu, data, COLOR_FORMAT, (width, height), options)?;
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

    /// Switches the 8-bit frames' exposure and tone curve (nothing is rebuilt; the radiance
    /// target, the HDR output, does not change).
    pub fn set_display(&mut self, exposure: Exposure, tonemap: Tonemap) {
        self.options.exposure = exposure;
        self.options.tonemap = tonemap;
        self.frame.set_display(exposure, tonemap);
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
        let submission = error_scoped(&gpu.device, "rendering a frame", || {
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("glint frame encoder"),
                });
            self.frame.prepare(gpu, camera);
            self.frame.record(
                &gpu.device,
                &mut encoder,
                camera,
                self.target.views(),
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

    /// The last frame as 8-bit sRGB RGBA (exposed and tone-mapped), top row first.
    pub fn read_rgba8(&self, gpu: &Gpu) -> Result<Vec<u8>, GpuError> {
        read_texture_rgba8(gpu, &self.target.color)
    }

    /// The last frame's linear radiance (never exposed), top row first.
    pub fn read_hdr(&self, gpu: &Gpu) -> Result<Vec<Vec3>, GpuError> {
        Ok(read_texture_rgba16f(gpu, &self.target.radiance)?
            .into_iter()
            .map(|t| t.truncate())
            .collect())
    }
}
