//! The interactive viewer: a winit 0.30 window drawing the scene with [`Renderer`].
//!
//! - Fly camera: W/S forward and back, A/D sideways, Q/E down and up (Shift: ×4); drag with
//!   the left mouse button to look; the mouse wheel scales the speed. The base speed is a fifth
//!   of the scene's bounding-box diagonal per second, so every scene crosses in a few seconds.
//! - Keys 1–9 play the scene's camera paths, Space pauses and resumes; moving takes over.
//! - R starts and stops recording a path: the pose every [`RECORD_INTERVAL`] seconds, saved as
//!   a `camera_paths` entry of scene.json (`recorded-N.json` in the output folder).
//! - P saves a screenshot (`screenshot-N.png`), rendered offscreen at the window's size.
//! - The title shows the frame time (mean over the last quarter second).
//!
//! The pure parts ([`FlyCamera`], [`PathRecorder`], [`Playback`]) are tested without a window.

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;
use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

use super::curved::gpu::CurvedReflections;
use super::curved::{CurvedMode, CurvedSettings};
use super::gpu::{Gpu, GpuError};
use super::headless::{Offscreen, rgba_to_rgb};
use super::impostors::{ImpostorKind, ImpostorReflections, ReflectorSet, impostor_pass};
use super::load::ViewData;
use super::radiance_maps::Selection;
use super::reflections::recursive::MAX_RECURSION_DEPTH;
use super::reflections::{
    GeometryReflections, RecursionSettings, RecursiveReflections, ReflectanceLayout,
    ReflectanceSettings, ReflectionMode, Source,
};
use super::renderer::{RenderError, Renderer, TargetFormats, depth_texture};
use crate::camera::{Camera, frame_count, pose_at};
use crate::image_io;
use crate::scene::{CameraPath, Keyframe};

/// Seconds between the keyframes of a recorded path.
pub const RECORD_INTERVAL: f32 = 0.25;

/// Frames per second written into recorded paths.
pub const RECORD_FPS: f32 = 30.0;

/// Radians of turn per pixel of mouse drag.
const LOOK_SENSITIVITY: f32 = 0.003;

/// Largest pitch, radians: keeps the view off the vertical so the world's up stays usable.
const MAX_PITCH: f32 = 89f32 * std::f32::consts::PI / 180.0;

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
    /// Multiplies D before display.
    pub exposure: f32,
    /// Folder for screenshots and recorded paths.
    pub out: PathBuf,
    /// Save a screenshot after this many frames and exit (automation).
    pub screenshot_after: Option<u64>,
    /// Glossy reflections at start (G switches).
    pub reflections: ReflectionMode,
    /// Reflections: R's map and channel at start (T switches sphere/1D map).
    pub reflectance: ReflectanceSettings,
    /// Reflections of impostors in planar reflectors at start (I switches).
    pub impostors: bool,
    /// Depth maps or billboards at start (K switches).
    pub impostor_kind: ImpostorKind,
    /// Curved reflectors at start (C switches).
    pub curved: CurvedMode,
    /// Curved reflectors' settings.
    pub curved_settings: CurvedSettings,
    /// Geometry reflections' recursion at start ([ and ] change the depth).
    pub recursion: RecursionSettings,
}

/// A free-flying camera: position, yaw about +Y (0 looks down −Z, positive turns right)
/// and pitch (positive looks up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlyCamera {
    /// Eye position.
    pub position: Vec3,
    /// Radians.
    pub yaw: f32,
    /// Radians, within ±89°.
    pub pitch: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
}

impl FlyCamera {
    /// The fly camera looking where `camera` looks.
    pub fn from_camera(camera: &Camera) -> FlyCamera {
        let f = camera.forward.normalize_or(-Vec3::Z);
        FlyCamera {
            position: camera.position,
            yaw: f.x.atan2(-f.z),
            pitch: f.y.clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH),
            fov_y: camera.fov_y,
        }
    }

    /// Unit view direction.
    pub fn forward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(cp * sy, sp, -cp * cy)
    }

    /// The camera (world +Y up).
    pub fn camera(&self) -> Camera {
        Camera::look_at(
            self.position,
            self.position + self.forward(),
            Vec3::Y,
            self.fov_y,
        )
    }

    /// Moves by `local` = (right, up, forward) metres: forward along the view, up along +Y.
    pub fn translate(&mut self, local: Vec3) {
        let forward = self.forward();
        let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
        self.position += right * local.x + Vec3::Y * local.y + forward * local.z;
    }

    /// Turns by a mouse drag of (`dx`, `dy`) pixels (right and down positive).
    pub fn look(&mut self, dx: f32, dy: f32) {
        self.yaw += dx * LOOK_SENSITIVITY;
        self.pitch = (self.pitch - dy * LOOK_SENSITIVITY).clamp(-MAX_PITCH, MAX_PITCH);
    }
}

/// Records the camera's pose at regular times into a camera path.
#[derive(Clone, Debug, Default)]
pub struct PathRecorder {
    keyframes: Vec<Keyframe>,
}

impl PathRecorder {
    /// An empty recording.
    pub fn new() -> PathRecorder {
        PathRecorder::default()
    }

    /// Offers the pose at recording time `t` (seconds); kept when it is the first or at least
    /// [`RECORD_INTERVAL`] after the last kept one. Returns whether it was kept.
    pub fn offer(&mut self, t: f32, camera: &Camera) -> bool {
        if let Some(last) = self.keyframes.last()
            && t < last.time + RECORD_INTERVAL
        {
            return false;
        }
        self.push(t, camera);
        true
    }

    fn push(&mut self, t: f32, camera: &Camera) {
        let target = camera.position + camera.forward;
        self.keyframes.push(Keyframe {
            time: t,
            position: camera.position.to_array(),
            target: target.to_array(),
            up: [0.0, 1.0, 0.0],
            fov_y_deg: camera.fov_y.to_degrees(),
        });
    }

    /// Number of keyframes so far.
    pub fn len(&self) -> usize {
        self.keyframes.len()
    }

    /// Whether nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.keyframes.is_empty()
    }

    /// The recording as a camera path named `name`, ending with the pose at time `t` (added
    /// when later than the last keyframe); `None` when nothing was recorded.
    pub fn finish(mut self, name: &str, t: f32, camera: &Camera) -> Option<CameraPath> {
        let last = self.keyframes.last()?.time;
        if t > last {
            self.push(t, camera);
        }
        Some(CameraPath {
            name: name.to_owned(),
            fps: RECORD_FPS,
            keyframes: self.keyframes,
        })
    }
}

/// Playing one of the scene's camera paths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Playback {
    /// Index into the scene's camera paths.
    pub path: usize,
    /// Seconds since the path's first keyframe.
    pub elapsed: f32,
    /// Whether time stands still.
    pub paused: bool,
}

impl Playback {
    /// Advances by `dt` seconds unless paused; returns the pose and whether the path has ended.
    pub fn advance(&mut self, path: &CameraPath, dt: f32) -> (Camera, bool) {
        if !self.paused {
            self.elapsed += dt;
        }
        let start = path.keyframes.first().map_or(0.0, |k| k.time);
        let end = path.keyframes.last().map_or(0.0, |k| k.time);
        let t = (start + self.elapsed).min(end);
        (
            pose_at(path, t),
            start + self.elapsed >= end && !self.paused,
        )
    }
}

/// The next `prefix-N.ext` in `dir` that does not exist yet (N from 1, four digits).
pub fn next_free_name(dir: &Path, prefix: &str, ext: &str) -> PathBuf {
    (1u32..)
        .map(|n| dir.join(format!("{prefix}-{n:04}.{ext}")))
        .find(|p| !p.exists())
        .expect("some index is free")
}

/// The reflection passes of `mode` for a `size` target (`None` when off).
fn reflection_passes(
    gpu: &Gpu,
    renderer: &Renderer,
    data: &ViewData,
    mode: ReflectionMode,
    reflectance: ReflectanceSettings,
    size: (u32, u32),
) -> Result<Option<GeometryReflections>, WindowError> {
    let source = match mode {
        ReflectionMode::Off => return Ok(None),
        ReflectionMode::Geometry => Source::Geometry,
        ReflectionMode::Image => Source::Image {
            selection: Selection::Angle,
            count: 2,
        },
    };
    Ok(Some(GeometryReflections::with_reflectance(
        gpu,
        renderer,
        data,
        size.0,
        size.1,
        source,
        reflectance,
    )?))
}

/// The curved-reflector passes of `mode` (`None` when off); building them renders the cube
/// maps.
fn curved_passes(
    gpu: &Gpu,
    renderer: &Renderer,
    data: &ViewData,
    mode: CurvedMode,
    settings: CurvedSettings,
) -> Result<Option<CurvedReflections>, WindowError> {
    Ok(match mode {
        CurvedMode::Off | CurvedMode::Impostor => None,
        CurvedMode::Cubemap => Some(CurvedReflections::new(gpu, renderer, data, settings)?),
    })
}

/// Recursive reflections for a `size` target when geometry reflections are on at a depth other
/// than 1 (issue 10; they replace the single mirror pass), else `None`.
fn recursive_passes(
    gpu: &Gpu,
    renderer: &Renderer,
    data: &ViewData,
    options: &WindowOptions,
    size: (u32, u32),
) -> Result<Option<RecursiveReflections>, WindowError> {
    if options.reflections != ReflectionMode::Geometry || options.recursion.depth == 1 {
        return Ok(None);
    }
    Ok(Some(RecursiveReflections::new(
        gpu,
        renderer,
        data,
        size.0,
        size.1,
        options.reflectance,
        options.recursion,
    )?))
}

/// The impostor passes: planar reflectors when `planar`, curved ones in
/// [`CurvedMode::Impostor`].
fn impostor_passes(
    gpu: &Gpu,
    renderer: &Renderer,
    data: &ViewData,
    planar: bool,
    curved: CurvedMode,
    kind: ImpostorKind,
) -> Result<(Option<ImpostorReflections>, Option<ImpostorReflections>), WindowError> {
    let a = if planar {
        Some(impostor_pass(
            gpu,
            renderer,
            data,
            kind,
            ReflectorSet::Planar,
        )?)
    } else {
        None
    };
    let b = if curved == CurvedMode::Impostor {
        Some(impostor_pass(
            gpu,
            renderer,
            data,
            kind,
            ReflectorSet::Curved,
        )?)
    } else {
        None
    };
    Ok((a, b))
}

/// A starting view: the first path's first pose, else the bounding box from its +Z side.
pub fn initial_camera(data: &ViewData) -> Camera {
    if let Some(path) = data.scene.desc.camera_paths.first() {
        return pose_at(path, path.keyframes.first().map_or(0.0, |k| k.time));
    }
    let b = data.scene.bounds;
    let centre = b.center();
    let eye = centre + Vec3::new(0.0, 0.0, (b.max.z - centre.z) + b.diagonal() * 0.6);
    Camera::look_at(eye, centre, Vec3::Y, 50f32.to_radians())
}

/// Opens the window and runs until it is closed (or the automated screenshot is taken).
pub fn run_window(data: ViewData, options: WindowOptions) -> Result<(), WindowError> {
    let playback = match &options.play {
        None => None,
        Some(name) => {
            let paths = &data.scene.desc.camera_paths;
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
    let fly = FlyCamera::from_camera(&initial_camera(&data));
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
C curved reflectors off/cubemap/impostor, [ ] recursion depth, H help, Esc quit";

/// The window's GPU side, created once the event loop runs.
struct Running {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    gpu: Gpu,
    renderer: Renderer,
    depth_view: wgpu::TextureView,
    reflections: Option<GeometryReflections>,
    impostors: Option<ImpostorReflections>,
    curved: Option<CurvedReflections>,
    recursive: Option<RecursiveReflections>,
    curved_impostors: Option<ImpostorReflections>,
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
    screenshot: Option<Offscreen>,
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
        let descriptor = wgpu::InstanceDescriptor::new_with_display_handle(Box::new(
            event_loop.owned_display_handle(),
        ))
        .with_env();
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
        .map_err(|e| WindowError::Surface(format!("no adapter can present to the window: {e}")))?;
        let gpu = Gpu::from_adapter(adapter, wgpu::Features::empty())?;
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
        config.present_mode = wgpu::PresentMode::AutoVsync;
        surface.configure(&gpu.device, &config);
        let mut renderer = Renderer::new(
            &gpu,
            &self.data.scene,
            &self.data.map,
            TargetFormats {
                color: config.format,
                hdr: false,
            },
        )?;
        renderer.exposure = self.options.exposure;
        let depth_view = depth_texture(&gpu, config.width, config.height)
            .create_view(&wgpu::TextureViewDescriptor::default());
        let reflections = reflection_passes(
            &gpu,
            &renderer,
            &self.data,
            self.options.reflections,
            self.options.reflectance,
            (config.width, config.height),
        )?;
        let (impostors, curved_impostors) = impostor_passes(
            &gpu,
            &renderer,
            &self.data,
            self.options.impostors,
            self.options.curved,
            self.options.impostor_kind,
        )?;
        let curved = curved_passes(
            &gpu,
            &renderer,
            &self.data,
            self.options.curved,
            self.options.curved_settings,
        )?;
        let recursive = recursive_passes(
            &gpu,
            &renderer,
            &self.data,
            &self.options,
            (config.width, config.height),
        )?;
        Ok(Running {
            window,
            surface,
            config,
            gpu,
            renderer,
            depth_view,
            reflections,
            impostors,
            curved,
            recursive,
            curved_impostors,
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
        match reflection_passes(
            &r.gpu,
            &r.renderer,
            &self.data,
            self.options.reflections,
            self.options.reflectance,
            (size.width, size.height),
        ) {
            Ok(passes) => r.reflections = passes,
            Err(e) => {
                log::error!("{e}; reflections off");
                r.reflections = None;
            }
        }
        r.recursive = recursive_passes(
            &r.gpu,
            &r.renderer,
            &self.data,
            &self.options,
            (size.width, size.height),
        )
        .unwrap_or_else(|e| {
            log::error!("{e}; recursive reflections off");
            None
        });
    }

    /// Changes the recursion depth of geometry reflections by `delta` (within 0–4).
    fn change_depth(&mut self, delta: i8) -> Result<(), WindowError> {
        let depth = &mut self.options.recursion.depth;
        *depth = depth.saturating_add_signed(delta).min(MAX_RECURSION_DEPTH);
        log::info!("recursion depth: {depth}");
        self.rebuild_reflections()
    }

    /// Rebuilds the planar reflection passes (single mirror and recursive) for the current
    /// options, after a switch changed them.
    fn rebuild_reflections(&mut self) -> Result<(), WindowError> {
        self.screenshot = None;
        let Some(r) = &mut self.running else {
            return Ok(());
        };
        r.reflections = reflection_passes(
            &r.gpu,
            &r.renderer,
            &self.data,
            self.options.reflections,
            self.options.reflectance,
            (r.config.width, r.config.height),
        )?;
        r.recursive = recursive_passes(
            &r.gpu,
            &r.renderer,
            &self.data,
            &self.options,
            (r.config.width, r.config.height),
        )?;
        Ok(())
    }

    /// Switches reflections of impostors on or off.
    fn toggle_impostors(&mut self) -> Result<(), WindowError> {
        self.options.impostors = !self.options.impostors;
        log::info!(
            "impostor reflections: {}",
            if self.options.impostors { "on" } else { "off" }
        );
        self.screenshot = None;
        let Some(r) = &mut self.running else {
            return Ok(());
        };
        (r.impostors, r.curved_impostors) = impostor_passes(
            &r.gpu,
            &r.renderer,
            &self.data,
            self.options.impostors,
            self.options.curved,
            self.options.impostor_kind,
        )?;
        Ok(())
    }

    /// Switches impostors between depth maps and billboards.
    fn toggle_impostor_kind(&mut self) -> Result<(), WindowError> {
        self.options.impostor_kind = match self.options.impostor_kind {
            ImpostorKind::Srdm => ImpostorKind::Billboard,
            ImpostorKind::Billboard => ImpostorKind::Srdm,
        };
        log::info!("impostors: {}", self.options.impostor_kind);
        self.screenshot = None;
        let Some(r) = &mut self.running else {
            return Ok(());
        };
        (r.impostors, r.curved_impostors) = impostor_passes(
            &r.gpu,
            &r.renderer,
            &self.data,
            self.options.impostors,
            self.options.curved,
            self.options.impostor_kind,
        )?;
        Ok(())
    }

    /// Cycles reflections off → geometry → image (two maps per element, by angle) → off.
    fn toggle_reflections(&mut self) -> Result<(), WindowError> {
        self.options.reflections = match self.options.reflections {
            ReflectionMode::Off => ReflectionMode::Geometry,
            ReflectionMode::Geometry => ReflectionMode::Image,
            ReflectionMode::Image => ReflectionMode::Off,
        };
        log::info!("reflections: {}", self.options.reflections);
        self.rebuild_reflections()
    }

    /// Switches R between the sphere map and the 1D map (rebuilds the reflection passes).
    fn toggle_reflectance(&mut self) -> Result<(), WindowError> {
        let layout = &mut self.options.reflectance.layout;
        *layout = match layout {
            ReflectanceLayout::OneD => ReflectanceLayout::Sphere,
            ReflectanceLayout::Sphere => ReflectanceLayout::OneD,
        };
        log::info!("reflectance map: {layout}");
        self.rebuild_reflections()
    }

    /// Switches curved reflectors off ↔ cubemap (the cube maps are rendered when switched on).
    fn toggle_curved(&mut self) -> Result<(), WindowError> {
        self.options.curved = self.options.curved.next();
        log::info!("curved reflectors: {}", self.options.curved);
        self.screenshot = None;
        let Some(r) = &mut self.running else {
            return Ok(());
        };
        r.curved = curved_passes(
            &r.gpu,
            &r.renderer,
            &self.data,
            self.options.curved,
            self.options.curved_settings,
        )?;
        r.curved_impostors = impostor_passes(
            &r.gpu,
            &r.renderer,
            &self.data,
            false,
            self.options.curved,
            self.options.impostor_kind,
        )?
        .1;
        Ok(())
    }

    /// The camera of this frame: the playing path's pose, else the fly camera moved by the
    /// held keys.
    fn update_camera(&mut self, dt: f32) -> Camera {
        let paths = &self.data.scene.desc.camera_paths;
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
        r.renderer
            .prepare(&r.gpu, &camera, r.config.width, r.config.height);
        let mut encoder = r
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("glint window frame"),
            });
        r.renderer
            .draw(&mut encoder, &view, None, &r.depth_view, None);
        if let Some(passes) = &r.recursive {
            passes.prepare(&r.gpu, &r.renderer, &camera, r.curved.as_ref());
            passes.draw_timed(
                &mut encoder,
                &r.renderer,
                &view,
                None,
                &r.depth_view,
                None,
                r.curved.as_ref(),
            );
        } else if let Some(passes) = &r.reflections {
            passes.prepare(&r.gpu, &r.renderer, &camera, r.curved.as_ref());
            passes.draw_timed(
                &mut encoder,
                &r.renderer,
                &camera,
                &view,
                None,
                &r.depth_view,
                None,
                r.curved.as_ref(),
            );
        }
        if let Some(pass) = &r.impostors {
            pass.prepare(&r.gpu, &camera);
            pass.draw(&mut encoder, &view, None, &r.depth_view);
        }
        if let Some(pass) = &r.curved_impostors {
            pass.prepare(&r.gpu, &camera);
            pass.draw(&mut encoder, &view, None, &r.depth_view);
        }
        if let Some(passes) = &r.curved {
            passes.prepare(&r.gpu, &camera);
            passes.draw(&mut encoder, &view, None, &r.depth_view);
        }
        r.gpu.queue.submit([encoder.finish()]);
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
        if self
            .options
            .screenshot_after
            .is_some_and(|n| self.frames >= n)
        {
            match self.save_screenshot(&camera) {
                Ok(path) => println!("{}", path.display()),
                Err(e) => return self.fail(event_loop, e),
            }
            event_loop.exit();
        }
    }

    fn title(&self) -> String {
        let paths = &self.data.scene.desc.camera_paths;
        let mut title = format!(
            "glint-view — {} — {:.1} ms ({:.0} fps) — reflections {}",
            self.data.scene.name,
            self.frame_ms,
            1e3 / self.frame_ms.max(1e-3),
            self.options.reflections
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

    /// Renders the current view offscreen at the window's size and writes it as PNG.
    fn save_screenshot(&mut self, camera: &Camera) -> Result<PathBuf, WindowError> {
        let Some(r) = &self.running else {
            return Err(WindowError::Surface("no window yet".into()));
        };
        let (w, h) = (r.config.width, r.config.height);
        let stale = self
            .screenshot
            .as_ref()
            .is_none_or(|s| (s.target.width, s.target.height) != (w, h));
        if stale {
            let mut off = Offscreen::new(&r.gpu, &self.data, w, h, false)?;
            off.renderer.exposure = self.options.exposure;
            off.reflectance = self.options.reflectance;
            if self.options.reflections == ReflectionMode::Geometry {
                off.recursion = self.options.recursion;
            }
            off.set_reflections(&r.gpu, &self.data, self.options.reflections)?;
            off.impostor_kind = self.options.impostor_kind;
            off.set_impostors(&r.gpu, &self.data, self.options.impostors)?;
            off.set_curved(
                &r.gpu,
                &self.data,
                self.options.curved,
                self.options.curved_settings,
            )?;
            self.screenshot = Some(off);
        }
        let off = self.screenshot.as_ref().expect("created above");
        off.render(&r.gpu, camera)?;
        let rgb = rgba_to_rgb(&off.read_rgba8(&r.gpu)?);
        let path = next_free_name(&self.options.out, "screenshot", "png");
        let write_err = |message: String| WindowError::Write {
            path: path.clone(),
            message,
        };
        let png = image_io::encode_png(w, h, &rgb, false).map_err(|e| write_err(e.to_string()))?;
        std::fs::create_dir_all(&self.options.out).map_err(|e| write_err(e.to_string()))?;
        std::fs::write(&path, png).map_err(|e| write_err(e.to_string()))?;
        log::info!("screenshot: {}", path.display());
        Ok(path)
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
                std::fs::create_dir_all(&self.options.out).map_err(|e| write_err(e.to_string()))?;
                std::fs::write(&path_file, json + "\n").map_err(|e| write_err(e.to_string()))?;
                log::info!(
                    "recorded path {:?} ({} keyframes) → {}: add it to scene.json's camera_paths",
                    path.name,
                    path.keyframes.len(),
                    path_file.display()
                );
                // Playable at once in this session.
                self.data.scene.desc.camera_paths.push(path);
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
        let paths = &self.data.scene.desc.camera_paths;
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
                let camera = self.fly.camera();
                self.save_screenshot(&camera).map(|_| ())
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

    #[test]
    fn fly_camera_round_trips_a_camera() {
        let cam = Camera::look_at(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(-1.0, 1.0, -2.0),
            Vec3::Y,
            0.7,
        );
        let fly = FlyCamera::from_camera(&cam);
        let back = fly.camera();
        assert!((back.forward - cam.forward).length() < 1e-5);
        assert!((back.position - cam.position).length() < 1e-6);
        assert_eq!(back.fov_y, 0.7);
        // Yaw 0 looks down −Z.
        let f = FlyCamera {
            position: Vec3::ZERO,
            yaw: 0.0,
            pitch: 0.0,
            fov_y: 1.0,
        };
        assert!((f.forward() - (-Vec3::Z)).length() < 1e-6);
    }

    #[test]
    fn fly_camera_moves_in_view_space_and_clamps_pitch() {
        let mut f = FlyCamera {
            position: Vec3::ZERO,
            yaw: 0.0,
            pitch: 0.0,
            fov_y: 1.0,
        };
        f.translate(Vec3::new(1.0, 2.0, 3.0));
        assert!((f.position - Vec3::new(1.0, 2.0, -3.0)).length() < 1e-6);
        f.look(0.0, -1e6);
        assert!((f.pitch - MAX_PITCH).abs() < 1e-6);
        assert!(f.camera().up.is_finite());
        f.look(100.0, 0.0);
        assert!((f.yaw - 0.3).abs() < 1e-6, "dragging right turns right");
    }

    #[test]
    fn recorder_keeps_poses_at_the_interval_and_makes_a_valid_path() {
        let cam = |x: f32| Camera::look_at(Vec3::new(x, 1.0, 4.0), Vec3::ZERO, Vec3::Y, 0.8);
        let mut rec = PathRecorder::new();
        assert!(rec.offer(0.0, &cam(0.0)));
        assert!(!rec.offer(0.1, &cam(0.1)));
        assert!(rec.offer(0.3, &cam(0.3)));
        let path = rec.finish("take", 0.4, &cam(0.4)).unwrap();
        assert_eq!(path.keyframes.len(), 3);
        assert!(path.keyframes.windows(2).all(|w| w[0].time < w[1].time));
        assert!((path.keyframes[2].position[0] - 0.4).abs() < 1e-6);
        // scene.json accepts it: it parses as a camera_paths entry.
        let json = serde_json::to_string(&path).unwrap();
        let again: CameraPath = serde_json::from_str(&json).unwrap();
        assert_eq!(again, path);
        assert!(PathRecorder::new().finish("x", 1.0, &cam(0.0)).is_none());
    }

    #[test]
    fn playback_pauses_and_ends() {
        let key = |time: f32, x: f32| Keyframe {
            time,
            position: [x, 1.0, 5.0],
            target: [x, 1.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 50.0,
        };
        let path = CameraPath {
            name: "p".into(),
            fps: 30.0,
            keyframes: vec![key(1.0, 0.0), key(2.0, 1.0)],
        };
        let mut p = Playback {
            path: 0,
            elapsed: 0.0,
            paused: false,
        };
        let (c, ended) = p.advance(&path, 0.5);
        assert!(!ended && (c.position.x - 0.5).abs() < 1e-5);
        p.paused = true;
        let (c, ended) = p.advance(&path, 5.0);
        assert!(!ended && (c.position.x - 0.5).abs() < 1e-5);
        p.paused = false;
        let (c, ended) = p.advance(&path, 0.6);
        assert!(ended && (c.position.x - 1.0).abs() < 1e-5);
    }

    #[test]
    fn free_names_count_up() {
        let dir = std::env::temp_dir().join(format!("glint-names-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let a = next_free_name(&dir, "screenshot", "png");
        assert!(a.ends_with("screenshot-0001.png"));
        std::fs::write(&a, b"x").unwrap();
        assert!(next_free_name(&dir, "screenshot", "png").ends_with("screenshot-0002.png"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
