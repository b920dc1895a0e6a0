//! The interactive viewer: a winit 0.30 window drawing a frame's passes into its surface.
//!
//! - Fly camera: W/S forward and back, A/D sideways, Q/E down and up (Shift: ×4); drag with
//!   the left mouse button to look; the mouse wheel scales the speed. The base speed is a fifth
//!   of the scene's bounding-box diagonal per second, so every scene crosses in a few seconds.
//! - Keys 1–9 play the scene's camera paths, Space pauses and resumes; moving takes over.
//! - R starts and stops recording a path: the pose every [`RECORD_INTERVAL`] seconds, saved as
//!   a `camera_paths` entry of scene.json (`recorded-N.json` in the output folder).
//! - The `-` and `=` keys lower and raise the exposure by half a stop, `0` returns to auto, M
//!   switches the tone curve ([`exposure_key`], [`super::exposure::Exposure::step`]).
//! - G, T, I, K, C, \[ and \] change the [`ViewOptions`]; [`FramePasses`] rebuilds what they
//!   feed, so the window draws exactly what headless replay draws with the same options.
//! - P saves a screenshot (`screenshot-N.png`): the window's own next frame, read back from
//!   the surface (or, where the surface cannot be copied, the same passes rendered offscreen).
//! - The title shows the frame time (mean over the last quarter second).
//!
//! The camera tools ([`FlyCamera`], [`PathRecorder`], [`Playback`]) live in `camera.rs`.

mod camera;
mod screenshot;

use screenshot::save_screenshot;

pub use camera::{
    FlyCamera, PathRecorder, Playback, RECORD_FPS, RECORD_INTERVAL, initial_camera, next_free_name,
};

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;
use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

use super::frame::FramePasses;
use super::gpu::target::FrameViews;
use super::gpu::{Gpu, GpuError, SUPPORTED_BACKENDS, VULKAN_INSTALL_HINT};
use super::load::ViewData;
use super::options::{ExposureKey, MAX_RECURSION_DEPTH, ViewOptions};
use crate::camera::{Camera, frame_count};
use crate::view::gpu::RenderError;
use crate::view::gpu::target::texture_2d;
use crate::view::gpu::target::{MULTISAMPLE_FEATURES, depth_texture};
use crate::view::passes::display::RADIANCE_FORMAT;

/// Why the window viewer stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum WindowError {
    /// No window system (no display), or the event loop failed.
    #[error("cannot open a window: {0} (no display? use --headless for offscreen replay)")]
    EventLoop(String),
    /// The surface or device could not be set up.
    #[error("cannot draw into the window: {0}")]
    Surface(String),
    /// Rendering failed.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// A path to play does not exist.
    #[error("bundle {}: {message}", bundle.display())]
    NoPath {
        /// The bundle.
        bundle: PathBuf,
        /// Which paths exist.
        message: String,
    },
    /// Writing a screenshot or a recorded path.
    #[error("{}: {message}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
}

impl From<GpuError> for WindowError {
    fn from(e: GpuError) -> Self {
        WindowError::Render(RenderError::Gpu(e))
    }
}

/// What the window starts with.
#[derive(Clone, Debug)]
pub struct WindowOptions {
    /// Initial inner size in pixels.
    pub size: (u32, u32),
    /// Play a path at start: `Some(None)` the first, `Some(Some(name))` a named one.
    pub play: Option<Option<String>>,
    /// Folder for screenshots and recorded paths.
    pub out: PathBuf,
    /// Save a screenshot after this many frames and exit (automation).
    pub screenshot_after: Option<u64>,
    /// The starting camera (`None`: the first path's first pose, or a view of the whole scene).
    pub camera: Option<Camera>,
    /// What the frame shows at start (G, T, I, K, C, \[ and \] change it).
    pub view: ViewOptions,
}

/// Opens the window and runs until it is closed (or the automated screenshot is taken).
pub fn run_window(data: ViewData, options: WindowOptions) -> Result<(), WindowError> {
    let playback = match &options.play {
        None => None,
        Some(name) => {
            let paths = &data.scene.camera_paths;
            let index = match name {
                None => (!paths.is_empty()).then_some(0),
                Some(n) => paths.iter().position(|p| &p.name == n),
            };
            let Some(path) = index else {
                let names: Vec<&str> = paths.iter().map(|p| p.name.as_str()).collect();
                return Err(WindowError::NoPath {
                    bundle: data.bundle.dir().to_owned(),
                    message: if names.is_empty() {
                        "its scene has no camera paths".into()
                    } else {
                        format!(
                            "its scene has no camera path {:?}; it has {}",
                            name.as_deref().unwrap_or_default(),
                            names.join(", ")
                        )
                    },
                });
            };
            Some(Playback {
                path,
                elapsed: 0.0,
                paused: false,
            })
        }
    };
    let event_loop = EventLoop::new().map_err(|e| WindowError::EventLoop(e.to_string()))?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let fly = FlyCamera::from_camera(&options.camera.unwrap_or_else(|| initial_camera(&data)));
    let mut app = App {
        speed: (data.scene.bounds.diagonal() * 0.2).max(1e-3),
        data,
        options,
        running: None,
        error: None,
        fly,
        playback,
        recording: None,
        keys: HashSet::new(),
        dragging: false,
        cursor: None,
        speed_scale: 1.0,
        frames: 0,
        last_frame: Instant::now(),
        title_window: (Instant::now(), 0.0, 0),
        frame_ms: 0.0,
        screenshot: None,
    };
    log::info!("{}", HELP);
    event_loop
        .run_app(&mut app)
        .map_err(|e| WindowError::EventLoop(e.to_string()))?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

const HELP: &str = "keys: WASD + Q/E move (Shift faster, wheel: speed), left-drag look, \
1-9 play path, Space pause/resume, R record path, P screenshot, G reflections off/geometry/image, \
T reflectance sphere/1D map, I impostor reflections (planar), K impostors srdm/billboard, \
C curved reflectors off/cubemap/impostor, [ ] recursion depth, - = exposure (0: auto), \
M tone curve neutral/none, H help, Esc quit";

/// The window's GPU side, created once the event loop runs.
struct Running {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    gpu: Gpu,
    frame: FramePasses,
    /// The radiance and depth targets the passes draw into (the surface's size).
    radiance_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
}

/// A radiance target (the passes draw into it; the display pass reads it) of `width` ×
/// `height`.
fn radiance_view(gpu: &Gpu, width: u32, height: u32) -> wgpu::TextureView {
    texture_2d(
        &gpu.device,
        "glint window radiance",
        width,
        height,
        RADIANCE_FORMAT,
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
    )
    .create_view(&wgpu::TextureViewDescriptor::default())
}

/// A screenshot asked for: saved from the next frame drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Screenshot {
    /// P: save it and go on.
    Key,
    /// `--screenshot-after`: save it, print its path and exit.
    Exit,
}

struct App {
    data: ViewData,
    options: WindowOptions,
    running: Option<Running>,
    error: Option<WindowError>,
    fly: FlyCamera,
    playback: Option<Playback>,
    recording: Option<(PathRecorder, Instant)>,
    keys: HashSet<KeyCode>,
    dragging: bool,
    cursor: Option<PhysicalPosition<f64>>,
    speed: f32,
    speed_scale: f32,
    frames: u64,
    last_frame: Instant,
    /// Start, summed milliseconds and count of the frames since the title was last set.
    title_window: (Instant, f64, u32),
    frame_ms: f64,
    /// A screenshot to save from the next frame.
    screenshot: Option<Screenshot>,
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: WindowError) {
        log::error!("{e}");
        self.error = Some(e);
        event_loop.exit();
    }

    fn start(&mut self, event_loop: &ActiveEventLoop) -> Result<Running, WindowError> {
        let (w, h) = self.options.size;
        let attributes = Window::default_attributes()
            .with_title(format!("glint-view — {}", self.data.scene.name))
            .with_inner_size(PhysicalSize::new(w, h));
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .map_err(|e| WindowError::EventLoop(e.to_string()))?,
        );
        let mut descriptor = wgpu::InstanceDescriptor::new_with_display_handle(Box::new(
            event_loop.owned_display_handle(),
        ))
        .with_env();
        descriptor.backends &= SUPPORTED_BACKENDS;
        let instance = wgpu::Instance::new(descriptor);
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| WindowError::Surface(e.to_string()))?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: Some(&surface),
            apply_limit_buckets: false,
        }))
        .map_err(|e| {
            WindowError::Surface(format!(
                "no Vulkan, Metal or DX12 adapter can present to the window ({e}): {VULKAN_INSTALL_HINT}"
            ))
        })?;
        let gpu = Gpu::from_adapter(adapter, MULTISAMPLE_FEATURES)?;
        log::info!("GPU: {}", gpu.adapter_summary());
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&gpu.adapter, size.width.max(1), size.height.max(1))
            .ok_or_else(|| {
                WindowError::Surface("the surface is not supported by the adapter".into())
            })?;
        let caps = surface.get_capabilities(&gpu.adapter);
        if let Some(srgb) = caps.formats.iter().copied().find(|f| f.is_srgb()) {
            config.format = srgb;
        }
        // Screenshots read the frame back from the surface where it can be copied.
        if caps.usages.contains(wgpu::TextureUsages::COPY_SRC) {
            config.usage |= wgpu::TextureUsages::COPY_SRC;
        }
        config.present_mode = wgpu::PresentMode::AutoVsync;
        surface.configure(&gpu.device, &config);
        let frame = FramePasses::new(
            &gpu,
            &self.data,
            config.format,
            (config.width, config.height),
            &self.options.view,
        )?;
        log::info!(
            "exposure {} (auto: {:+.2} EV), tone curve {}; - and = change the exposure, 0 returns to auto, M switches the curve",
            self.options.view.exposure,
            frame.auto_ev(),
            self.options.view.tonemap
        );
        let depth_view = depth_texture(&gpu, config.width, config.height)
            .create_view(&wgpu::TextureViewDescriptor::default());
        let radiance_view = radiance_view(&gpu, config.width, config.height);
        Ok(Running {
            window,
            surface,
            config,
            gpu,
            frame,
            radiance_view,
            depth_view,
        })
    }

    fn resize(&mut self, size: PhysicalSize<u32>) {
        let Some(r) = &mut self.running else { return };
        if size.width == 0 || size.height == 0 {
            return;
        }
        r.config.width = size.width;
        r.config.height = size.height;
        r.surface.configure(&r.gpu.device, &r.config);
        r.depth_view = depth_texture(&r.gpu, size.width, size.height)
            .create_view(&wgpu::TextureViewDescriptor::default());
        r.radiance_view = radiance_view(&r.gpu, size.width, size.height);
        if let Err(e) = r
            .frame
            .resize(&r.gpu, &self.data, (size.width, size.height))
        {
            log::error!("{e}; planar reflections off");
        }
    }

    /// Applies `change` to the options and rebuilds the passes it touches.
    fn change(&mut self, change: impl FnOnce(&mut ViewOptions)) -> Result<(), WindowError> {
        change(&mut self.options.view);
        let Some(r) = &mut self.running else {
            return Ok(());
        };
        r.frame
            .set_options(&r.gpu, &self.data, &self.options.view)?;
        Ok(())
    }

    /// Changes the exposure by `key` (a step from the EV in effect, or back to auto).
    fn change_exposure(&mut self, key: ExposureKey) {
        let Some(r) = &mut self.running else { return };
        let o = &mut self.options.view;
        o.exposure = o.exposure.step(key, r.frame.auto_ev());
        r.frame.set_display(o.exposure, o.tonemap);
        log::info!(
            "exposure {} ({:+.2} EV)",
            o.exposure,
            o.exposure.ev(r.frame.auto_ev())
        );
    }

    /// Switches the tone curve (PBR Neutral / none).
    fn toggle_tonemap(&mut self) {
        let Some(r) = &mut self.running else { return };
        let o = &mut self.options.view;
        o.tonemap = o.tonemap.other();
        r.frame.set_display(o.exposure, o.tonemap);
        log::info!("tone curve: {}", o.tonemap);
    }

    /// Changes the recursion depth of geometry reflections by `delta` (within 0–4).
    fn change_depth(&mut self, delta: i8) -> Result<(), WindowError> {
        self.change(|o| {
            let depth = &mut o.recursion.depth;
            *depth = depth.saturating_add_signed(delta).min(MAX_RECURSION_DEPTH);
            log::info!("recursion depth: {depth}");
        })
    }

    /// Switches reflections of impostors in planar reflectors on or off.
    fn toggle_impostors(&mut self) -> Result<(), WindowError> {
        self.change(|o| {
            o.impostors = !o.impostors;
            let on = if o.impostors { "on" } else { "off" };
            log::info!("impostor reflections: {on}");
        })
    }

    /// Switches impostors between depth maps and billboards.
    fn toggle_impostor_kind(&mut self) -> Result<(), WindowError> {
        self.change(|o| {
            o.impostor_kind = o.impostor_kind.other();
            log::info!("impostors: {}", o.impostor_kind);
        })
    }

    /// Cycles reflections off → geometry → image → off.
    fn toggle_reflections(&mut self) -> Result<(), WindowError> {
        self.change(|o| {
            o.reflections = o.reflections.next();
            log::info!("reflections: {}", o.reflections);
        })
    }

    /// Switches R between the sphere map and the 1D map.
    fn toggle_reflectance(&mut self) -> Result<(), WindowError> {
        self.change(|o| {
            o.reflectance.layout = o.reflectance.layout.other();
            log::info!("reflectance map: {}", o.reflectance.layout);
        })
    }

    /// Cycles curved reflectors off → cubemap → impostor → off (the cube maps are rendered
    /// when switched on).
    fn toggle_curved(&mut self) -> Result<(), WindowError> {
        self.change(|o| {
            o.curved = o.curved.next();
            log::info!("curved reflectors: {}", o.curved);
        })
    }

    /// The camera of this frame: the playing path's pose, else the fly camera moved by the
    /// held keys.
    fn update_camera(&mut self, dt: f32) -> Camera {
        let paths = &self.data.scene.camera_paths;
        let k = |c| self.keys.contains(&c);
        let axis = |pos, neg| (k(pos) as i32 - k(neg) as i32) as f32;
        let dir = Vec3::new(
            axis(KeyCode::KeyD, KeyCode::KeyA),
            axis(KeyCode::KeyE, KeyCode::KeyQ),
            axis(KeyCode::KeyW, KeyCode::KeyS),
        );
        if dir != Vec3::ZERO && self.playback.is_some() {
            // Moving takes over from the path at its current pose.
            self.playback = None;
        }
        if let Some(mut play) = self.playback
            && let Some(path) = paths.get(play.path)
        {
            let (camera, ended) = play.advance(path, dt);
            self.playback = (!ended).then_some(play);
            if ended {
                log::info!("path {:?} ended", path.name);
            }
            self.fly = FlyCamera::from_camera(&camera);
            return camera;
        }
        let boost = if k(KeyCode::ShiftLeft) || k(KeyCode::ShiftRight) {
            4.0
        } else {
            1.0
        };
        self.fly
            .translate(dir * self.speed * self.speed_scale * boost * dt);
        self.fly.camera()
    }

    fn redraw(&mut self, event_loop: &ActiveEventLoop) {
        let now = Instant::now();
        let dt = (now - self.last_frame).as_secs_f32().min(0.25);
        self.last_frame = now;
        let camera = self.update_camera(dt);
        if let Some((rec, start)) = &mut self.recording {
            rec.offer(start.elapsed().as_secs_f32(), &camera);
        }
        let Some(r) = &mut self.running else { return };
        let frame = match r.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => return,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                r.surface.configure(&r.gpu.device, &r.config);
                return;
            }
            other => {
                let e = WindowError::Surface(format!("acquiring the next frame: {other:?}"));
                self.fail(event_loop, e);
                return;
            }
        };
        let view = frame
            .texture
            .create_view(&wgpu::TextureViewDescriptor::default());
        let mut encoder = r
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("glint window frame"),
            });
        r.frame.prepare(&r.gpu, &camera);
        r.frame.record(
            &r.gpu.device,
            &mut encoder,
            &camera,
            FrameViews {
                radiance: &r.radiance_view,
                display: &view,
                depth: &r.depth_view,
            },
            None,
        );
        r.gpu.queue.submit([encoder.finish()]);
        if self
            .options
            .screenshot_after
            .is_some_and(|n| self.frames + 1 >= n)
        {
            self.screenshot = Some(Screenshot::Exit);
        }
        let shot = self.screenshot.take().map(|kind| {
            let saved = save_screenshot(r, &self.data, &frame.texture, &camera, &self.options.out);
            (kind, saved)
        });
        r.window.pre_present_notify();
        r.gpu.queue.present(frame);
        self.frames += 1;

        // Title: mean frame time over about a quarter second.
        let (since, sum, n) = &mut self.title_window;
        *sum += f64::from(dt) * 1e3;
        *n += 1;
        if since.elapsed().as_secs_f32() >= 0.25 {
            self.frame_ms = *sum / f64::from(*n);
            *since = Instant::now();
            *sum = 0.0;
            *n = 0;
            let title = self.title();
            if let Some(r) = &self.running {
                r.window.set_title(&title);
            }
        }
        match shot {
            Some((Screenshot::Exit, Ok(path))) => {
                println!("{}", path.display());
                event_loop.exit();
            }
            Some((Screenshot::Exit, Err(e))) => self.fail(event_loop, e),
            // A failed screenshot from the key is reported, not fatal.
            Some((Screenshot::Key, Err(e))) => log::error!("{e}"),
            Some((Screenshot::Key, Ok(_))) | None => {}
        }
    }

    fn title(&self) -> String {
        let paths = &self.data.scene.camera_paths;
        let mut title = format!(
            "glint-view — {} — {:.1} ms ({:.0} fps) — reflections {}",
            self.data.scene.name,
            self.frame_ms,
            1e3 / self.frame_ms.max(1e-3),
            self.options.view.reflections
        );
        if let Some(p) = &self.playback
            && let Some(path) = paths.get(p.path)
        {
            let end = path.keyframes.last().map_or(0.0, |k| k.time);
            title += &format!(
                " — {} {} {:.1}/{:.1} s ({} frames)",
                if p.paused { "paused" } else { "playing" },
                path.name,
                p.elapsed,
                end,
                frame_count(path)
            );
        }
        if let Some((rec, start)) = &self.recording {
            title += &format!(
                " — recording {:.1} s, {} keyframes",
                start.elapsed().as_secs_f32(),
                rec.len()
            );
        }
        title
    }

    fn toggle_recording(&mut self) -> Result<(), WindowError> {
        let camera = self.fly.camera();
        match self.recording.take() {
            None => {
                let mut rec = PathRecorder::new();
                rec.offer(0.0, &camera);
                self.recording = Some((rec, Instant::now()));
                log::info!("recording a camera path (R stops)");
            }
            Some((rec, start)) => {
                let path_file = next_free_name(&self.options.out, "recorded", "json");
                let name = path_file
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_else(|| "recorded".into());
                let Some(path) = rec.finish(&name, start.elapsed().as_secs_f32(), &camera) else {
                    return Ok(());
                };
                let write_err = |message: String| WindowError::Write {
                    path: path_file.clone(),
                    message,
                };
                let json =
                    serde_json::to_string_pretty(&path).map_err(|e| write_err(e.to_string()))?;
                crate::out_dir::create_dir_all(&self.options.out)
                    .map_err(|e| write_err(e.to_string()))?;
                std::fs::write(&path_file, json + "\n").map_err(|e| write_err(e.to_string()))?;
                log::info!(
                    "recorded path {:?} ({} keyframes) → {}: add it to scene.json's camera_paths",
                    path.name,
                    path.keyframes.len(),
                    path_file.display()
                );
                // Playable at once in this session.
                self.data.scene.camera_paths.push(path);
            }
        }
        Ok(())
    }

    fn key(&mut self, event_loop: &ActiveEventLoop, code: KeyCode, pressed: bool, repeat: bool) {
        if pressed {
            self.keys.insert(code);
        } else {
            self.keys.remove(&code);
        }
        if !pressed || repeat {
            return;
        }
        let digit = match code {
            KeyCode::Digit1 => Some(0),
            KeyCode::Digit2 => Some(1),
            KeyCode::Digit3 => Some(2),
            KeyCode::Digit4 => Some(3),
            KeyCode::Digit5 => Some(4),
            KeyCode::Digit6 => Some(5),
            KeyCode::Digit7 => Some(6),
            KeyCode::Digit8 => Some(7),
            KeyCode::Digit9 => Some(8),
            _ => None,
        };
        if let Some(key) = exposure_key(code) {
            self.change_exposure(key);
            return;
        }
        let paths = &self.data.scene.camera_paths;
        if let Some(i) = digit {
            match paths.get(i) {
                Some(p) => {
                    log::info!("playing path {} {:?}", i + 1, p.name);
                    self.playback = Some(Playback {
                        path: i,
                        elapsed: 0.0,
                        paused: false,
                    });
                }
                None => log::warn!("the scene has {} camera path(s)", paths.len()),
            }
            return;
        }
        let result = match code {
            KeyCode::Escape => {
                event_loop.exit();
                Ok(())
            }
            KeyCode::Space => {
                if let Some(p) = &mut self.playback {
                    p.paused = !p.paused;
                }
                Ok(())
            }
            KeyCode::KeyR => self.toggle_recording(),
            KeyCode::KeyG => self.toggle_reflections(),
            KeyCode::KeyT => self.toggle_reflectance(),
            KeyCode::KeyI => self.toggle_impostors(),
            KeyCode::KeyK => self.toggle_impostor_kind(),
            KeyCode::KeyC => self.toggle_curved(),
            KeyCode::BracketLeft => self.change_depth(-1),
            KeyCode::BracketRight => self.change_depth(1),
            KeyCode::KeyP | KeyCode::F12 => {
                self.screenshot = Some(Screenshot::Key);
                Ok(())
            }
            KeyCode::KeyM => {
                self.toggle_tonemap();
                Ok(())
            }
            KeyCode::KeyH => {
                log::info!("{HELP}");
                Ok(())
            }
            _ => Ok(()),
        };
        if let Err(e) = result {
            // A failed screenshot or recording is reported, not fatal.
            log::error!("{e}");
        }
    }
}

/// The exposure change of a key: - darker, = (the + key) brighter, 0 back to auto (the
/// number row and the keypad).
pub fn exposure_key(code: KeyCode) -> Option<ExposureKey> {
    match code {
        KeyCode::Minus | KeyCode::NumpadSubtract => Some(ExposureKey::Lower),
        KeyCode::Equal | KeyCode::NumpadAdd => Some(ExposureKey::Raise),
        KeyCode::Digit0 | KeyCode::Numpad0 => Some(ExposureKey::Auto),
        _ => None,
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        match self.start(event_loop) {
            Ok(r) => {
                r.window.request_redraw();
                self.running = Some(r);
                self.last_frame = Instant::now();
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => self.resize(size),
            WindowEvent::RedrawRequested => self.redraw(event_loop),
            WindowEvent::KeyboardInput { event, .. } => {
                if let PhysicalKey::Code(code) = event.physical_key {
                    self.key(
                        event_loop,
                        code,
                        event.state == ElementState::Pressed,
                        event.repeat,
                    );
                }
            }
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Left,
                ..
            } => {
                self.dragging = state == ElementState::Pressed;
            }
            WindowEvent::CursorMoved { position, .. } => {
                if let Some(last) = self.cursor
                    && self.dragging
                {
                    self.playback = None;
                    self.fly
                        .look((position.x - last.x) as f32, (position.y - last.y) as f32);
                }
                self.cursor = Some(position);
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => (p.y / 40.0) as f32,
                };
                self.speed_scale = (self.speed_scale * 1.25f32.powf(steps)).clamp(1e-3, 1e3);
            }
            WindowEvent::Focused(false) => self.keys.clear(),
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _event_loop: &ActiveEventLoop) {
        if let Some(r) = &self.running {
            r.window.request_redraw();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view::exposure::{Exposure, KEY_STEP_EV};

    #[test]
    fn exposure_keys_step_half_a_stop_and_zero_returns_to_auto() {
        let auto = -2.0;
        let mut e = Exposure::Auto;
        for code in [KeyCode::Equal, KeyCode::Equal, KeyCode::Minus] {
            e = e.step(exposure_key(code).unwrap(), auto);
        }
        assert_eq!(e, Exposure::Ev(auto + KEY_STEP_EV));
        e = e.step(exposure_key(KeyCode::NumpadSubtract).unwrap(), auto);
        assert_eq!(e, Exposure::Ev(auto));
        e = e.step(exposure_key(KeyCode::Digit0).unwrap(), auto);
        assert_eq!(e, Exposure::Auto);
        assert_eq!(exposure_key(KeyCode::Digit1), None, "1-9 play paths");
    }
}
