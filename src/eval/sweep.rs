//! Speed-for-accuracy sweeps: for each value of each knob (`radiosity.rays=64,256,1024`,
//! `view.maps=1,2,4`, …), bake what the scene needs, record bake time and bundle bytes,
//! render the same view, time it, and compare it with a path-traced reference; then write
//! `sweep.csv` and `sweep.svg` (error against bake time and against frame time, one curve per
//! knob).
//!
//! The view is the headless viewer's HDR frame when the viewer is built (the `view` feature)
//! and a GPU adapter opens: D, plus glossy reflections when `view.reflections` is not `off`,
//! with the median time of a few frames. Without the viewer it is D at the first hit on the
//! CPU ([`super::reference::render_radiosity`]), no frame time, and no `view.*` knobs.
//!
//! Each knob is varied alone; everything else stays at the preset (with the scene's
//! overrides) and the base view. Every setting's bundle starts as a copy of the base bundle,
//! so only the stages its knob changes (and the stages downstream of them) are baked again.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;
use serde::Serialize;

use super::Image;
use super::compare::{self, Metrics};
use super::reference::render_radiosity;
use crate::bake::{BakeError, BakeSettings, Stage, StageReport, StageStatus, bake_all};
use crate::bundle::{Bundle, BundleError};
use crate::camera::Camera;
use crate::progress::Progress;
use crate::radiosity::RadiosityMap;
use crate::scene::Scene;
use crate::scene::desc::Quality;

/// Whether this build has the headless viewer (frame times, `view.*` knobs).
pub const VIEWER_BUILT: bool = cfg!(feature = "view");

/// Knobs that are not fields of a stage's settings struct: `radiance.resolution_scale`
/// (scene.json's `bake.radiance`) and the viewer's settings.
const OTHER_KNOBS: [&str; 8] = [
    "radiance.resolution_scale",
    "view.reflections",
    "view.maps",
    "view.selection",
    "view.recursion_depth",
    "view.curved",
    "view.glossy_samples",
    "view.impostors",
];

/// Every knob name a sweep accepts, `STAGE.FIELD`, in stage order.
pub fn valid_knobs() -> Vec<String> {
    let base = BakeSettings {
        quality: Quality::Draft,
        radiosity: crate::scene::desc::RadiositySettings::preset(Quality::Draft),
        materials: crate::bake::materials::MaterialsSettings::preset(Quality::Draft),
        srdm: crate::bake::srdm_stage::SrdmSettings::preset(Quality::Draft),
    };
    let fields = |stage: &str, v: serde_json::Value| -> Vec<String> {
        v.as_object()
            .expect("settings are objects")
            .keys()
            .map(|k| format!("{stage}.{k}"))
            .collect()
    };
    let mut all = fields("radiosity", json(&base.radiosity));
    all.extend(fields("materials", json(&base.materials)));
    all.push(OTHER_KNOBS[0].into());
    all.extend(fields("srdm", json(&base.srdm)));
    all.extend(OTHER_KNOBS[1..].iter().map(|s| s.to_string()));
    all
}

fn json<T: Serialize>(v: &T) -> serde_json::Value {
    serde_json::to_value(v).expect("settings serialize")
}

/// Glossy reflections in the sweep's view (the viewer's `--reflections`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Reflections {
    /// D only.
    #[default]
    Off,
    /// The mirrored scene re-rendered per reflector.
    Geometry,
    /// From the baked radiance maps.
    Image,
}

/// How the image mode picks radiance maps (the viewer's `--selection`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum MapSelection {
    /// Smallest angle to the mirrored eye.
    #[default]
    Angle,
    /// Smallest distance to the mirrored eye.
    Distance,
}

/// The viewer settings a frame is rendered with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct ViewSettings {
    /// Glossy reflections.
    pub reflections: Reflections,
    /// Image mode: maps per reflector element (1 ..= 16).
    pub maps: usize,
    /// Image mode: map selection.
    pub selection: MapSelection,
    /// Geometry mode: recursion depth (0 ..= 4; 1 is the single mirror pass).
    pub recursion_depth: u8,
    /// Curved reflectors by cube maps (the viewer's `--curved cubemap`).
    pub curved: bool,
    /// Curved reflectors: regular samples per pixel (0: one mirror lookup).
    pub glossy_samples: u32,
    /// Reflections of depth-map impostors (the viewer's `--impostors on`).
    pub impostors: bool,
}

impl ViewSettings {
    /// Checks every value: maps in 1 ..= 16, recursion depth in 0 ..= 4, glossy samples in
    /// 0 ..= 256.
    pub fn check(&self) -> Result<(), crate::scene::desc::SettingError> {
        use crate::scene::desc::SettingError;
        if !(1..=16).contains(&self.maps) {
            return Err(SettingError::new(
                "maps",
                format!("{} is not in 1 ..= 16", self.maps),
            ));
        }
        if self.recursion_depth > 4 {
            return Err(SettingError::new(
                "recursion_depth",
                format!("{} is not in 0 ..= 4", self.recursion_depth),
            ));
        }
        if self.glossy_samples > 256 {
            return Err(SettingError::new(
                "glossy_samples",
                format!("{} is not in 0 ..= 256", self.glossy_samples),
            ));
        }
        Ok(())
    }
}

impl Default for ViewSettings {
    fn default() -> Self {
        ViewSettings {
            reflections: Reflections::Off,
            maps: 2,
            selection: MapSelection::Angle,
            recursion_depth: 1,
            curved: false,
            glossy_samples: 0,
            impostors: false,
        }
    }
}

/// One knob and the values it takes: `STAGE.FIELD=V1,V2,...`.
#[derive(Clone, Debug, PartialEq)]
pub struct Knob {
    /// Stage name (`radiosity`, `materials`, `radiance`, `srdm`) or `view`.
    pub stage: String,
    /// Settings field.
    pub field: String,
    /// Values, in the order given.
    pub values: Vec<serde_json::Value>,
}

impl Knob {
    /// `STAGE.FIELD`.
    pub fn name(&self) -> String {
        format!("{}.{}", self.stage, self.field)
    }

    /// The bake stage it changes (`None` for viewer knobs).
    pub fn bake_stage(&self) -> Option<Stage> {
        Some(match self.stage.as_str() {
            "radiosity" => Stage::Radiosity,
            "materials" => Stage::Materials,
            "radiance" => Stage::Radiance,
            "srdm" => Stage::Srdm,
            _ => return None,
        })
    }
}

/// Why a sweep failed.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// A `--set` value that does not parse or names no setting.
    #[error("--set {0}: {1}")]
    Knob(String, String),
    /// A bake failed.
    #[error("bake with {0}: {1}")]
    Bake(String, #[source] BakeError),
    /// Reading a baked bundle.
    #[error(transparent)]
    Bundle(#[from] BundleError),
    /// Reading the bake's radiosity, or loading it into the viewer.
    #[error("{0}: {1}")]
    Map(PathBuf, String),
    /// Rendering a frame in the headless viewer.
    #[error("viewer, {0}: {1}")]
    View(String, String),
    /// Drawing the plot.
    #[error("plot: {0}")]
    Plot(String),
    /// Writing the outputs.
    #[error("{0}: {1}")]
    Io(PathBuf, #[source] std::io::Error),
    /// Images that cannot be compared.
    #[error(transparent)]
    Compare(#[from] compare::CompareError),
}

/// Parses `STAGE.FIELD=V1,V2,...`: each value becomes a JSON number (or string) and is
/// checked now against the setting, so a typo fails before hours of baking. An unknown name
/// is an error listing every valid knob.
pub fn parse_knob(text: &str) -> Result<Knob, SweepError> {
    let err = |m: String| SweepError::Knob(text.to_string(), m);
    let (key, values) = text
        .split_once('=')
        .ok_or_else(|| err("expected STAGE.FIELD=V1,V2,...".into()))?;
    let valid = valid_knobs();
    let key = key.trim();
    if !valid.iter().any(|k| k == key) {
        return Err(err(format!(
            "unknown knob `{key}`; valid knobs: {}",
            valid.join(", ")
        )));
    }
    let (stage, field) = key.split_once('.').expect("valid knobs are STAGE.FIELD");
    let values = values
        .split(',')
        .map(|v| {
            let v = v.trim();
            serde_json::from_str::<serde_json::Value>(v)
                .unwrap_or_else(|_| serde_json::Value::String(v.to_string()))
        })
        .collect::<Vec<_>>();
    if values.iter().any(|v| v.as_str() == Some("")) {
        return Err(err("empty value".into()));
    }
    let knob = Knob {
        stage: stage.into(),
        field: field.into(),
        values,
    };
    let base = Point {
        bake: BakeSettings {
            quality: Quality::Draft,
            radiosity: crate::scene::desc::RadiositySettings::preset(Quality::Draft),
            materials: crate::bake::materials::MaterialsSettings::preset(Quality::Draft),
            srdm: crate::bake::srdm_stage::SrdmSettings::preset(Quality::Draft),
        },
        radiance_scale: None,
        view: ViewSettings::default(),
    };
    for v in &knob.values {
        base.with(&knob, v, None)?;
    }
    Ok(knob)
}

/// Whether the sweep's view shows glossy reflections somewhere (then the reference must be
/// the full glossy scene, not the diffuse one a radiosity bake represents).
pub fn shows_reflections(base: &ViewSettings, knobs: &[Knob]) -> bool {
    base.reflections != Reflections::Off
        || base.curved
        || base.impostors
        || knobs.iter().any(|k| {
            ["view.reflections", "view.curved", "view.impostors"].contains(&k.name().as_str())
        })
}

/// One point of a sweep: every stage's settings and the view.
#[derive(Clone, Debug, PartialEq)]
struct Point {
    bake: BakeSettings,
    /// `bake.radiance.resolution_scale` (`None`: the scene's).
    radiance_scale: Option<f32>,
    view: ViewSettings,
}

impl Point {
    /// This point with `knob` set to `value`, checked by the settings' own `check` (with the
    /// scene's size, when known, for the radiosity density).
    fn with(
        &self,
        knob: &Knob,
        value: &serde_json::Value,
        scene_size: Option<f32>,
    ) -> Result<Point, SweepError> {
        let err = |m: String| SweepError::Knob(format!("{}={value}", knob.name()), m);
        let mut p = self.clone();
        let number = || {
            value
                .as_f64()
                .filter(|v| v.is_finite())
                .ok_or_else(|| err("expected a number".into()))
        };
        // A whole number ≥ 0; anything else becomes u32::MAX, which the setting's own check
        // refuses (its message then quotes the value as given).
        let integer = |v: f64| -> u32 {
            if v.fract() == 0.0 && (0.0..=u32::MAX as f64).contains(&v) {
                v as u32
            } else {
                u32::MAX
            }
        };
        let word = |choices: &[&str]| -> Result<String, SweepError> {
            match value.as_str() {
                Some(s) if choices.contains(&s) => Ok(s.to_string()),
                _ => Err(err(format!("expected one of {}", choices.join(", ")))),
            }
        };
        match knob.stage.as_str() {
            "radiosity" => {
                p.bake.radiosity = set_field(&p.bake.radiosity, &knob.field, value).map_err(err)?;
                p.bake
                    .radiosity
                    .check(scene_size)
                    .map_err(|e| err(e.message))?;
            }
            "materials" => {
                p.bake.materials = set_field(&p.bake.materials, &knob.field, value).map_err(err)?;
                p.bake.materials.check().map_err(|e| err(e.message))?;
            }
            "srdm" => {
                p.bake.srdm = set_field(&p.bake.srdm, &knob.field, value).map_err(err)?;
                p.bake.srdm.check().map_err(|e| err(e.message))?;
            }
            "radiance" => {
                let v = number()? as f32;
                let over = crate::scene::desc::RadianceStageOverride {
                    resolution_scale: Some(v),
                };
                over.check().map_err(|e| err(e.message))?;
                p.radiance_scale = Some(v);
            }
            "view" => {
                if !VIEWER_BUILT {
                    return Err(err(
                        "view knobs need the headless viewer: this glint-eval was built \
                         without the `view` feature"
                            .into(),
                    ));
                }
                match knob.field.as_str() {
                    "reflections" => {
                        p.view.reflections = match word(&["off", "geometry", "image"])?.as_str() {
                            "off" => Reflections::Off,
                            "geometry" => Reflections::Geometry,
                            _ => Reflections::Image,
                        }
                    }
                    "selection" => {
                        p.view.selection = match word(&["angle", "distance"])?.as_str() {
                            "angle" => MapSelection::Angle,
                            _ => MapSelection::Distance,
                        }
                    }
                    "recursion_depth" => {
                        p.view.recursion_depth = u8::try_from(integer(number()?)).unwrap_or(u8::MAX)
                    }
                    "curved" => p.view.curved = word(&["off", "cubemap"])? == "cubemap",
                    "impostors" => p.view.impostors = word(&["off", "on"])? == "on",
                    "glossy_samples" => p.view.glossy_samples = integer(number()?),
                    _ => p.view.maps = integer(number()?) as usize,
                }
                p.view
                    .check()
                    .map_err(|e| match e.message.split_once(' ') {
                        Some((_, rest)) => err(format!("{value} {rest}")),
                        None => err(e.message),
                    })?;
            }
            other => unreachable!("parse_knob admits no stage `{other}`"),
        }
        Ok(p)
    }
}

/// `base` with `field` set to `value`, through its JSON form (so names and types are the
/// struct's own).
fn set_field<T: Serialize + serde::de::DeserializeOwned>(
    base: &T,
    field: &str,
    value: &serde_json::Value,
) -> Result<T, String> {
    let mut v = json(base);
    v.as_object_mut()
        .expect("settings are objects")
        .insert(field.to_string(), value.clone());
    serde_json::from_value(v).map_err(|e| e.to_string())
}

/// One setting of a sweep.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// `STAGE.FIELD`.
    pub knob: String,
    /// The value it had.
    pub value: String,
    /// Bake time of every stage of the bundle (seconds, wall clock; stages this setting did
    /// not change count with their time in the base bake).
    pub bake_seconds: f64,
    /// Bake time of the knob's own stage (`None` for view knobs).
    pub stage_seconds: Option<f64>,
    /// Bytes of every asset in the bundle.
    pub bundle_bytes: u64,
    /// Median time of a frame in the headless viewer, start to GPU finished (ms); `None`
    /// without the viewer.
    pub frame_ms: Option<f64>,
    /// Median GPU time of a frame as the viewer reports it (ms).
    pub gpu_ms: Option<f64>,
    /// Error of the view against the reference.
    pub metrics: Metrics,
}

/// What to sweep and how to look at it.
pub struct SweepConfig<'a> {
    /// Preset the knobs start from (scene overrides applied).
    pub quality: Quality,
    /// The knobs; each is varied alone, the others stay at the preset.
    pub knobs: &'a [Knob],
    /// The view.
    pub camera: &'a Camera,
    /// Viewer settings of every setting but a `view.*` knob's own.
    pub view: ViewSettings,
    /// Render with the headless viewer when it is built (else D on the CPU).
    pub use_viewer: bool,
    /// Timed frames per setting in the viewer (after one untimed warm-up frame).
    pub frames: usize,
    /// Samples per pixel of the view, for antialiasing: stratified rays of the CPU view of D;
    /// in the viewer, the compared frame is rendered at ⌊√spp⌋× the size and box-filtered.
    pub view_spp: u32,
    /// Output folder: `bundles/`, `views/`, `sweep.csv`, `sweep.svg`.
    pub out: &'a Path,
}

/// Runs the sweep against `reference` (whose size sets the view's size).
pub fn sweep(
    scene: &Scene,
    reference: &Image,
    cfg: &SweepConfig,
    progress: &dyn Progress,
) -> Result<Vec<Row>, SweepError> {
    let io = |p: &Path| {
        let p = p.to_path_buf();
        move |e| SweepError::Io(p, e)
    };
    let views = cfg.out.join("views");
    std::fs::create_dir_all(&views).map_err(io(&views))?;
    let bundles = cfg.out.join("bundles");
    let (w, h) = (reference.width as u32, reference.height as u32);
    let mut viewer = if cfg.use_viewer {
        Viewer::open(w, h, cfg.frames, cfg.view_spp)
    } else {
        None
    };
    if viewer.is_none() && shows_reflections(&cfg.view, cfg.knobs) {
        return Err(SweepError::View(
            "reflections".into(),
            "glossy reflections need the headless viewer (the `view` feature and a GPU \
             adapter)"
                .into(),
        ));
    }
    let settings = BakeSettings::resolve(scene, cfg.quality)
        .map_err(|e| SweepError::Bake("the scene's settings".into(), e))?;
    let base = Point {
        bake: settings,
        radiance_scale: None,
        view: cfg.view,
    };
    // The base bundle: every other bundle starts as a copy of it.
    let base_dir = bundles.join("base.glint");
    let base_report = bake_all(scene, &base_dir, &base.bake, true, progress)
        .map_err(|e| SweepError::Bake("the base settings".into(), e))?;
    let mut rows = Vec::new();
    let mut cpu_bvh = None;
    for knob in cfg.knobs {
        for value in &knob.values {
            let point = base.with(knob, value, Some(scene.bounds.diagonal()))?;
            let label = format!("{}={}", knob.name(), plain(value));
            // View knobs change no bake: they look at the base bundle.
            let (dir, report) = if knob.bake_stage().is_none() {
                (base_dir.clone(), base_report.clone())
            } else {
                let dir = bundles.join(format!("{}.glint", file_safe(&label)));
                if dir.exists() {
                    crate::bundle::check_folder(&dir)?;
                    std::fs::remove_dir_all(&dir).map_err(io(&dir))?;
                }
                copy_dir(&base_dir, &dir)?;
                let variant;
                let scene = match point.radiance_scale {
                    Some(s) => {
                        variant = scene_with_radiance_scale(scene, s)?;
                        &variant
                    }
                    None => scene,
                };
                let report = bake_all(scene, &dir, &point.bake, true, progress)
                    .map_err(|e| SweepError::Bake(label.clone(), e))?;
                (dir, report)
            };
            let seconds = |stage: Stage| stage_seconds(&report, &base_report, stage);
            let bake_seconds = Stage::ALL.iter().map(|&s| seconds(s).unwrap_or(0.0)).sum();
            let stage_seconds = knob.bake_stage().and_then(seconds);
            let bundle = Bundle::open(&dir)?;
            let bundle_bytes = bundle
                .manifest()
                .stages
                .values()
                .flat_map(|s| &s.assets)
                .map(|a| a.bytes)
                .sum();
            let (view, frame_ms, gpu_ms) = match viewer.as_mut() {
                Some(v) => v.render(&dir, &point.view, cfg.camera, &label)?,
                None => {
                    let map = RadiosityMap::load(&bundle)
                        .map_err(|e| SweepError::Map(dir.clone(), e.to_string()))?
                        .ok_or_else(|| SweepError::Map(dir.clone(), "no radiosity stage".into()))?;
                    let bvh = cpu_bvh.get_or_insert_with(|| scene.build_bvh());
                    let img = render_radiosity(scene, bvh, &map, cfg.camera, w, h, cfg.view_spp);
                    (img, None, None)
                }
            };
            let metrics = compare::compare(&view, reference, None)?;
            let exr = views.join(format!("{}.exr", file_safe(&label)));
            let bytes = view
                .to_exr()
                .map_err(|e| SweepError::Io(exr.clone(), std::io::Error::other(e)))?;
            std::fs::write(&exr, bytes).map_err(io(&exr))?;
            log::info!(
                "{label}: bake {bake_seconds:.2} s, {bundle_bytes} B, frame {}, rel. RMSE {:.4}",
                frame_ms.map_or("-".into(), |f| format!("{f:.2} ms")),
                metrics.rel_rmse
            );
            rows.push(Row {
                knob: knob.name(),
                value: plain(value),
                bake_seconds,
                stage_seconds,
                bundle_bytes,
                frame_ms,
                gpu_ms,
                metrics,
            });
        }
    }
    let csv = cfg.out.join("sweep.csv");
    std::fs::write(&csv, to_csv(&rows)).map_err(io(&csv))?;
    let svg = cfg.out.join("sweep.svg");
    std::fs::write(&svg, plot_svg(&scene.name, &rows)?).map_err(io(&svg))?;
    Ok(rows)
}

/// A stage's bake time in this setting's bundle: its own if it was baked now, else the base
/// bake's (the copy kept it).
fn stage_seconds(report: &[StageReport], base: &[StageReport], stage: Stage) -> Option<f64> {
    let baked = |r: &[StageReport]| {
        r.iter()
            .find(|s| s.plan.stage == stage)
            .and_then(|s| match s.status {
                StageStatus::Baked { seconds } => Some(seconds),
                _ => None,
            })
    };
    baked(report).or_else(|| baked(base))
}

/// The scene loaded again with `bake.radiance.resolution_scale` set (the radiance stage
/// reads it from the scene).
fn scene_with_radiance_scale(scene: &Scene, scale: f32) -> Result<Scene, SweepError> {
    let mut s =
        Scene::load(&scene.path).map_err(|e| SweepError::Map(scene.path.clone(), e.to_string()))?;
    s.desc.bake.radiance.resolution_scale = Some(scale);
    Ok(s)
}

/// A value as written on the command line (strings without quotes).
fn plain(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::String(s) => s.clone(),
        v => v.to_string(),
    }
}

fn file_safe(label: &str) -> String {
    label
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "._=-".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Copies the folder `from` to `to` (files and sub-folders).
fn copy_dir(from: &Path, to: &Path) -> Result<(), SweepError> {
    let io = |p: &Path| {
        let p = p.to_path_buf();
        move |e| SweepError::Io(p, e)
    };
    std::fs::create_dir_all(to).map_err(io(to))?;
    for entry in std::fs::read_dir(from).map_err(io(from))? {
        let entry = entry.map_err(io(from))?;
        let (src, dst) = (entry.path(), to.join(entry.file_name()));
        if entry.file_type().map_err(io(&src))?.is_dir() {
            copy_dir(&src, &dst)?;
        } else {
            std::fs::copy(&src, &dst).map_err(io(&src))?;
        }
    }
    Ok(())
}

/// The headless viewer, when built and a GPU adapter opens.
#[cfg(feature = "view")]
struct Viewer {
    gpu: crate::view::gpu::Gpu,
    width: u32,
    height: u32,
    frames: usize,
    /// The compared frame is rendered at `supersample`× the size and box-filtered down, as
    /// the reference's pixels are (timed frames are rendered at the real size).
    supersample: u32,
}

#[cfg(feature = "view")]
impl Viewer {
    fn open(width: u32, height: u32, frames: usize, spp: u32) -> Option<Viewer> {
        match crate::view::gpu::Gpu::headless_with_features(wgpu::Features::TIMESTAMP_QUERY) {
            Ok(gpu) => Some(Viewer {
                gpu,
                width,
                height,
                frames: frames.max(1),
                supersample: (spp.max(1) as f64).sqrt().floor() as u32,
            }),
            Err(e) => {
                log::warn!("no GPU for the headless viewer ({e}): views are D on the CPU, untimed");
                None
            }
        }
    }

    /// The HDR frame of the bundle at `dir` from `camera`, and the median frame and GPU
    /// times of `frames` frames after a warm-up one.
    fn render(
        &mut self,
        dir: &Path,
        view: &ViewSettings,
        camera: &Camera,
        label: &str,
    ) -> Result<(Image, Option<f64>, Option<f64>), SweepError> {
        use crate::view::headless::Offscreen;
        use crate::view::radiance_maps::Selection;
        use crate::view::reflections::ReflectionMode;
        let fail = |e: &dyn std::fmt::Display| SweepError::View(label.to_string(), e.to_string());
        let data = crate::view::load::load(dir).map_err(|e| fail(&e))?;
        let gpu = &self.gpu;
        let offscreen = |w: u32, h: u32| -> Result<Offscreen, SweepError> {
            let mut off = Offscreen::new(gpu, &data, w, h, true).map_err(|e| fail(&e))?;
            off.selection = match view.selection {
                MapSelection::Angle => Selection::Angle,
                MapSelection::Distance => Selection::Distance,
            };
            off.map_count = view.maps;
            let mode = match view.reflections {
                Reflections::Off => ReflectionMode::Off,
                Reflections::Geometry => ReflectionMode::Geometry,
                Reflections::Image => ReflectionMode::Image,
            };
            if mode == ReflectionMode::Geometry {
                off.recursion.depth = view.recursion_depth;
            }
            off.set_reflections(gpu, &data, mode)
                .map_err(|e| fail(&e))?;
            off.set_impostors(gpu, &data, view.impostors)
                .map_err(|e| fail(&e))?;
            let curved = if view.curved {
                crate::view::curved::CurvedMode::Cubemap
            } else {
                crate::view::curved::CurvedMode::Off
            };
            let settings = crate::view::curved::CurvedSettings {
                glossy_samples: view.glossy_samples,
                ..Default::default()
            };
            off.set_curved(gpu, &data, curved, settings)
                .map_err(|e| fail(&e))?;
            Ok(off)
        };
        let timed = offscreen(self.width, self.height)?;
        timed.render(gpu, camera).map_err(|e| fail(&e))?;
        let mut frame = Vec::with_capacity(self.frames);
        let mut gpu_ms = Vec::with_capacity(self.frames);
        for _ in 0..self.frames {
            let t = timed.render(gpu, camera).map_err(|e| fail(&e))?;
            frame.push(t.frame_ms);
            gpu_ms.push(t.gpu_ms);
        }
        let k = self.supersample;
        let big;
        let shown = if k > 1 {
            big = offscreen(self.width * k, self.height * k)?;
            big.render(gpu, camera).map_err(|e| fail(&e))?;
            &big
        } else {
            &timed
        };
        let rgb = shown
            .read_hdr(gpu)
            .map_err(|e| fail(&e))?
            .expect("the target was made with HDR");
        let img = box_down(
            &Image {
                width: (self.width * k) as usize,
                height: (self.height * k) as usize,
                rgb,
            },
            k as usize,
        );
        Ok((img, Some(median(&mut frame)), Some(median(&mut gpu_ms))))
    }
}

/// The mean of every `k` × `k` block.
#[cfg(feature = "view")]
fn box_down(img: &Image, k: usize) -> Image {
    if k == 1 {
        return img.clone();
    }
    let (w, h) = (img.width / k, img.height / k);
    let mut rgb = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let mut sum = glam::DVec3::ZERO;
            for j in 0..k {
                for i in 0..k {
                    sum += img.rgb[(y * k + j) * img.width + x * k + i].as_dvec3();
                }
            }
            rgb.push((sum / (k * k) as f64).as_vec3());
        }
    }
    Image {
        width: w,
        height: h,
        rgb,
    }
}

#[cfg(feature = "view")]
fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Without the viewer there is none to open.
#[cfg(not(feature = "view"))]
struct Viewer;

#[cfg(not(feature = "view"))]
impl Viewer {
    fn open(_: u32, _: u32, _: usize, _: u32) -> Option<Viewer> {
        None
    }

    fn render(
        &mut self,
        _: &Path,
        _: &ViewSettings,
        _: &Camera,
        _: &str,
    ) -> Result<(Image, Option<f64>, Option<f64>), SweepError> {
        unreachable!("never opened")
    }
}

/// The rows as CSV with a header line; empty fields where a figure was not measured.
pub fn to_csv(rows: &[Row]) -> String {
    let mut s = String::from(
        "knob,value,bake_seconds,stage_seconds,bundle_bytes,frame_ms,gpu_ms,rmse,rel_rmse,psnr_db,max_error\n",
    );
    let opt = |v: Option<f64>, digits: usize| v.map_or(String::new(), |v| format!("{v:.digits$}"));
    for r in rows {
        let m = &r.metrics;
        s += &format!(
            "{},{},{:.4},{},{},{},{},{:.6},{:.6},{:.3},{:.6}\n",
            r.knob,
            r.value,
            r.bake_seconds,
            opt(r.stage_seconds, 4),
            r.bundle_bytes,
            opt(r.frame_ms, 3),
            opt(r.gpu_ms, 3),
            m.rmse,
            m.rel_rmse,
            m.psnr_db,
            m.max_error
        );
    }
    s
}

/// The plot as SVG (plotters): relative RMSE against bake time and, when view knobs were
/// timed, against frame time; log axes, one curve per knob, each point labelled with its
/// value.
pub fn plot_svg(title: &str, rows: &[Row]) -> Result<String, SweepError> {
    // Frame time is the cost of a view knob; stage knobs barely change it (it is in the CSV).
    let timed = rows
        .iter()
        .any(|r| r.frame_ms.is_some() && r.knob.starts_with("view."));
    let mut svg = String::new();
    {
        let size = if timed { (1200, 480) } else { (640, 480) };
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let root = root
            .titled(
                &format!("{title}: error vs time, one curve per knob"),
                ("sans-serif", 18),
            )
            .map_err(plot_err)?;
        let mut knobs: Vec<&str> = Vec::new();
        for r in rows {
            if !knobs.contains(&r.knob.as_str()) {
                knobs.push(&r.knob);
            }
        }
        if timed {
            let panels = root.split_evenly((1, 2));
            // View knobs change no bake: they are plotted against frame time only.
            panel(&panels[0], rows, &knobs, "bake time (s, log)", |r| {
                r.stage_seconds.map(|_| r.bake_seconds)
            })?;
            panel(&panels[1], rows, &knobs, "frame time (ms, log)", |r| {
                r.frame_ms
            })?;
        } else {
            panel(&root, rows, &knobs, "bake time (s, log)", |r| {
                Some(r.bake_seconds)
            })?;
        }
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}

fn plot_err(e: impl std::fmt::Display) -> SweepError {
    SweepError::Plot(e.to_string())
}

/// Colours of the curves (Tableau 10).
const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    rows: &[Row],
    knobs: &[&str],
    x_desc: &str,
    x: impl Fn(&Row) -> Option<f64>,
) -> Result<(), SweepError> {
    // Log axes need positive values: a 0 s bake (a view knob's) sits at 0.1 ms.
    let pts: Vec<(&Row, f64, f64)> = rows
        .iter()
        .filter_map(|r| Some((r, x(r)?.max(1e-4), r.metrics.rel_rmse.max(1e-6))))
        .collect();
    let xr = log_range(pts.iter().map(|p| p.1));
    let yr = log_range(pts.iter().map(|p| p.2));
    // Head room for the legend, one line per knob.
    let yr = yr.start..yr.end * 1.25f64.powi(knobs.len() as i32);
    let mut chart = ChartBuilder::on(area)
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(
            xr.clone().log_scale().with_key_points(ticks(xr)),
            yr.clone().log_scale().with_key_points(ticks(yr)),
        )
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc("relative RMSE vs reference (log)")
        .x_label_formatter(&|v| short(*v))
        .y_label_formatter(&|v| short(*v))
        .draw()
        .map_err(plot_err)?;
    for (k, name) in knobs.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        let mine: Vec<(f64, f64, &str)> = pts
            .iter()
            .filter(|p| p.0.knob == *name)
            .map(|p| (p.1, p.2, p.0.value.as_str()))
            .collect();
        if mine.is_empty() {
            continue;
        }
        chart
            .draw_series(LineSeries::new(
                mine.iter().map(|p| (p.0, p.1)),
                colour.stroke_width(2),
            ))
            .map_err(plot_err)?
            .label(*name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        chart
            .draw_series(mine.iter().map(|&(x, y, v)| {
                EmptyElement::at((x, y))
                    + Circle::new((0, 0), 4, colour.filled())
                    + Text::new(
                        v.to_string(),
                        (6, -16),
                        ("sans-serif", 12).into_font().color(&colour),
                    )
            }))
            .map_err(plot_err)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(plot_err)?;
    Ok(())
}

/// A log axis range around the values: 30% beyond them, at least a factor 4 wide.
fn log_range(v: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = v.fold((f64::INFINITY, 0.0f64), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    });
    if !lo.is_finite() {
        return 0.1..1.0;
    }
    let widen = (4.0 / (hi / lo)).sqrt().max(1.3);
    lo / widen..hi * widen
}

/// 1-2-5 ticks per decade inside `r`; 1 … 9 when that gives fewer than three.
fn ticks(r: std::ops::Range<f64>) -> Vec<f64> {
    let within = |mantissas: &[f64]| {
        let mut v = Vec::new();
        for d in (r.start.log10().floor() as i32)..=(r.end.log10().ceil() as i32) {
            for &m in mantissas {
                let t = m * 10f64.powi(d);
                if r.contains(&t) {
                    v.push(t);
                }
            }
        }
        v
    };
    let v = within(&[1.0, 2.0, 5.0]);
    if v.len() >= 3 {
        return v;
    }
    within(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
}

/// A tick label: a few significant digits, no trailing zeros.
fn short(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    if (1e-3..1e5).contains(&v.abs()) {
        let digits = (3 - v.abs().log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{v:.1e}")
    }
}
