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
//!
//! - `knobs`: the knob grammar and the point each value gives;
//! - `viewer`: the headless viewer's frame for a point;
//! - `report`: CSV and SVG.

mod knobs;
mod report;
mod viewer;

use std::path::{Path, PathBuf};

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
pub use crate::view::options::ViewOptions;

use knobs::Point;
pub use knobs::{Knob, VIEWER_BUILT, knobs_help, parse_knob, shows_reflections, valid_knobs};
pub use report::{plot_svg, to_csv};
use viewer::Viewer;

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
    pub view: ViewOptions,
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
    crate::out_dir::create_dir_all(&views).map_err(io(&views))?;
    let bundles = cfg.out.join("bundles");
    let (w, h) = (reference.width as u32, reference.height as u32);
    let (mut viewer, no_viewer) = if cfg.use_viewer {
        match Viewer::open(w, h, cfg.frames, cfg.view_spp) {
            Ok(v) => (Some(v), String::new()),
            Err(why) => (None, why),
        }
    } else {
        (None, "the sweep was asked not to use it".to_string())
    };
    if viewer.is_none() && shows_reflections(&cfg.view, cfg.knobs) {
        return Err(SweepError::View(
            "reflections".into(),
            format!("glossy reflections need the headless viewer, and none opened: {no_viewer}"),
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
    crate::out_dir::create_dir_all(to).map_err(io(to))?;
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
