//! Speed-for-accuracy sweeps: for each value of each knob (`radiosity.rays=64,256,1024`),
//! bake, record bake time and bundle bytes, render the view the viewer shows (D at the first
//! hit, [`super::reference::render_radiosity`]) and compare it with a path-traced reference of
//! the diffuse scene; then write `sweep.csv` and an SVG plot of error against bake time, one
//! curve per knob.
//!
//! Only radiosity knobs exist so far: the other stages (materials, radiance, SRDM) change
//! glossy reflections, which the CPU view of D does not show.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use super::Image;
use super::compare::{self, Metrics};
use super::reference::render_radiosity;
use crate::bake::radiosity_stage::{self, RadiosityError};
use crate::bundle::{Bundle, BundleError};
use crate::camera::Camera;
use crate::progress::Progress;
use crate::radiosity::RadiosityMap;
use crate::scene::Scene;
use crate::scene::desc::{Quality, RadiositySettings};

/// One knob and the values it takes: `STAGE.FIELD=V1,V2,...`.
#[derive(Clone, Debug, PartialEq)]
pub struct Knob {
    /// Stage name (only `radiosity` so far).
    pub stage: String,
    /// Settings field, as in scene.json's `bake.STAGE` object.
    pub field: String,
    /// Values, in the order given.
    pub values: Vec<serde_json::Value>,
}

impl Knob {
    /// `STAGE.FIELD`.
    pub fn name(&self) -> String {
        format!("{}.{}", self.stage, self.field)
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
    Bake(String, #[source] RadiosityError),
    /// Reading a baked bundle.
    #[error(transparent)]
    Bundle(#[from] BundleError),
    /// Reading the bake's radiosity.
    #[error("{0}: {1}")]
    Map(PathBuf, String),
    /// Writing the outputs.
    #[error("{0}: {1}")]
    Io(PathBuf, #[source] std::io::Error),
    /// Images that cannot be compared.
    #[error(transparent)]
    Compare(#[from] compare::CompareError),
}

/// Parses `STAGE.FIELD=V1,V2,...`: each value becomes a JSON number (or string), and is
/// checked later against the stage's settings.
pub fn parse_knob(text: &str) -> Result<Knob, SweepError> {
    let err = |m: &str| SweepError::Knob(text.to_string(), m.to_string());
    let (key, values) = text
        .split_once('=')
        .ok_or_else(|| err("expected STAGE.FIELD=V1,V2,..."))?;
    let (stage, field) = key
        .split_once('.')
        .ok_or_else(|| err("expected STAGE.FIELD before '='"))?;
    if stage != "radiosity" {
        return Err(err(&format!(
            "unknown stage `{stage}`: only `radiosity` settings can be swept (its view is what the reference is compared with)"
        )));
    }
    let values = values
        .split(',')
        .map(|v| {
            let v = v.trim();
            serde_json::from_str::<serde_json::Value>(v)
                .unwrap_or_else(|_| serde_json::Value::String(v.to_string()))
        })
        .collect::<Vec<_>>();
    if values.is_empty() || values.iter().any(|v| v.as_str() == Some("")) {
        return Err(err("empty value"));
    }
    let knob = Knob {
        stage: stage.into(),
        field: field.into(),
        values,
    };
    // Check every value now, so a typo fails before hours of baking.
    for v in &knob.values {
        apply(&RadiositySettings::preset(Quality::Draft), &knob, v)?;
    }
    Ok(knob)
}

/// `base` with the knob's field set to `value`.
fn apply(
    base: &RadiositySettings,
    knob: &Knob,
    value: &serde_json::Value,
) -> Result<RadiositySettings, SweepError> {
    let err = |m: String| SweepError::Knob(format!("{}={value}", knob.name()), m);
    let mut json = serde_json::to_value(base).expect("settings serialize");
    let obj = json.as_object_mut().expect("settings are an object");
    if !obj.contains_key(&knob.field) {
        let known: Vec<&str> = obj.keys().map(|k| k.as_str()).collect();
        return Err(err(format!(
            "`{}` is not a radiosity setting (known: {})",
            knob.field,
            known.join(", ")
        )));
    }
    obj.insert(knob.field.clone(), value.clone());
    serde_json::from_value(json).map_err(|e| err(e.to_string()))
}

/// One bake of a sweep.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// `STAGE.FIELD`.
    pub knob: String,
    /// The value it had.
    pub value: String,
    /// Bake time of the stage (seconds, wall clock).
    pub bake_seconds: f64,
    /// Bytes of the stage's assets in the bundle.
    pub bundle_bytes: u64,
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
    /// Rays per pixel of the view of D (stratified; antialiasing only).
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
    let bvh = scene.build_bvh();
    let base = RadiositySettings::resolve(cfg.quality, &scene.desc.bake.radiosity);
    let mut rows = Vec::new();
    for knob in cfg.knobs {
        for value in &knob.values {
            let settings = apply(&base, knob, value)?;
            let label = format!("{}={}", knob.name(), value);
            let bundle_dir = cfg.out.join("bundles").join(format!("{label}.glint"));
            let start = Instant::now();
            radiosity_stage::bake(scene, &bundle_dir, &settings, true, progress)
                .map_err(|e| SweepError::Bake(label.clone(), e))?;
            let bake_seconds = start.elapsed().as_secs_f64();
            let bundle = Bundle::open(&bundle_dir)?;
            let bundle_bytes = bundle
                .stage("radiosity")
                .map(|s| s.assets.iter().map(|a| a.bytes).sum())
                .unwrap_or(0);
            let map = RadiosityMap::load(&bundle)
                .map_err(|e| SweepError::Map(bundle_dir.clone(), e.to_string()))?
                .ok_or_else(|| SweepError::Map(bundle_dir.clone(), "no radiosity stage".into()))?;
            let view = render_radiosity(
                scene,
                &bvh,
                &map,
                cfg.camera,
                reference.width as u32,
                reference.height as u32,
                cfg.view_spp,
            );
            let metrics = compare::compare(&view, reference, None)?;
            let exr = views.join(format!("{label}.exr"));
            let bytes = view
                .to_exr()
                .map_err(|e| SweepError::Io(exr.clone(), std::io::Error::other(e)))?;
            std::fs::write(&exr, bytes).map_err(io(&exr))?;
            log::info!(
                "{label}: {bake_seconds:.2} s, {bundle_bytes} B, rel. RMSE {:.4}",
                metrics.rel_rmse
            );
            rows.push(Row {
                knob: knob.name(),
                value: value.to_string(),
                bake_seconds,
                bundle_bytes,
                metrics,
            });
        }
    }
    let csv = cfg.out.join("sweep.csv");
    std::fs::write(&csv, to_csv(&rows)).map_err(io(&csv))?;
    let svg = cfg.out.join("sweep.svg");
    std::fs::write(&svg, plot_svg(&scene.name, &rows)).map_err(io(&svg))?;
    Ok(rows)
}

/// The rows as CSV with a header line.
pub fn to_csv(rows: &[Row]) -> String {
    let mut s = String::from(
        "knob,value,bake_seconds,bundle_bytes,rmse,rel_rmse,psnr_db,max_error,frame_ms\n",
    );
    for r in rows {
        let m = &r.metrics;
        // frame_ms: headless viewer frame time, not measured by this build (empty).
        let _ = writeln!(
            s,
            "{},{},{:.4},{},{:.6},{:.6},{:.3},{:.6},",
            r.knob,
            r.value,
            r.bake_seconds,
            r.bundle_bytes,
            m.rmse,
            m.rel_rmse,
            m.psnr_db,
            m.max_error
        );
    }
    s
}

/// Error (relative RMSE, log scale) against bake time (seconds, log scale), one polyline per
/// knob with its points labelled by value, as a self-contained SVG.
pub fn plot_svg(title: &str, rows: &[Row]) -> String {
    const W: f64 = 640.0;
    const H: f64 = 420.0;
    const L: f64 = 70.0;
    const R: f64 = 20.0;
    const T: f64 = 40.0;
    const B: f64 = 50.0;
    const COLOURS: [&str; 6] = [
        "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b",
    ];
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| (r.bake_seconds.max(1e-6), r.metrics.rel_rmse.max(1e-9)))
        .collect();
    // Log ranges around the data with a 10% margin (of a decade at least a factor 2 wide).
    let range = |f: fn(&(f64, f64)) -> f64| {
        let lo = pts.iter().map(f).fold(f64::INFINITY, f64::min);
        let hi = pts.iter().map(f).fold(f64::NEG_INFINITY, f64::max);
        if !lo.is_finite() {
            return (0.0, 1.0);
        }
        let (a, b) = (lo.log10(), hi.log10());
        let pad = ((b - a) * 0.1).max(0.5 * (2f64.log10() - (b - a)).max(0.0) + 0.02);
        (a - pad, b + pad)
    };
    let (x0, x1) = range(|p| p.0);
    let (y0, y1) = range(|p| p.1);
    let sx = |x: f64| L + (x.log10() - x0) / (x1 - x0) * (W - L - R);
    let sy = |y: f64| H - B - (y.log10() - y0) / (y1 - y0) * (H - T - B);
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="{W}" height="{H}" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="22" text-anchor="middle" font-size="15">{}: error vs bake time</text>"#,
        W / 2.0,
        xml(title)
    );
    // Axes, decade grid and labels.
    for v in ticks(x0, x1) {
        let x = sx(v);
        let _ = writeln!(
            s,
            r##"<line x1="{x:.1}" y1="{T}" x2="{x:.1}" y2="{}" stroke="#ddd"/><text x="{x:.1}" y="{}" text-anchor="middle">{}</text>"##,
            H - B,
            H - B + 16.0,
            tick_label(v)
        );
    }
    for v in ticks(y0, y1) {
        let y = sy(v);
        let _ = writeln!(
            s,
            r##"<line x1="{L}" y1="{y:.1}" x2="{}" y2="{y:.1}" stroke="#ddd"/><text x="{}" y="{:.1}" text-anchor="end">{}</text>"##,
            W - R,
            L - 6.0,
            y + 4.0,
            tick_label(v)
        );
    }
    let _ = writeln!(
        s,
        r#"<rect x="{L}" y="{T}" width="{}" height="{}" fill="none" stroke="black"/>"#,
        W - L - R,
        H - T - B
    );
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">bake time (s, log)</text>"#,
        (L + W - R) / 2.0,
        H - 12.0
    );
    let _ = writeln!(
        s,
        r#"<text transform="translate(18 {}) rotate(-90)" text-anchor="middle">relative RMSE vs reference (log)</text>"#,
        (T + H - B) / 2.0
    );
    // One curve per knob, in the order the knobs came.
    let mut knobs: Vec<&str> = Vec::new();
    for r in rows {
        if !knobs.contains(&r.knob.as_str()) {
            knobs.push(&r.knob);
        }
    }
    for (k, name) in knobs.iter().enumerate() {
        let c = COLOURS[k % COLOURS.len()];
        let mine: Vec<(usize, &Row)> = rows
            .iter()
            .enumerate()
            .filter(|(_, r)| r.knob == *name)
            .collect();
        let line: Vec<String> = mine
            .iter()
            .map(|(i, _)| format!("{:.1},{:.1}", sx(pts[*i].0), sy(pts[*i].1)))
            .collect();
        let _ = writeln!(
            s,
            r#"<polyline points="{}" fill="none" stroke="{c}" stroke-width="2"/>"#,
            line.join(" ")
        );
        for (i, r) in &mine {
            let (x, y) = (sx(pts[*i].0), sy(pts[*i].1));
            let _ = writeln!(
                s,
                r#"<circle cx="{x:.1}" cy="{y:.1}" r="3.5" fill="{c}"/><text x="{:.1}" y="{:.1}" fill="{c}">{}</text>"#,
                x + 6.0,
                y - 6.0,
                xml(&r.value)
            );
        }
        let ly = T + 16.0 + 16.0 * k as f64;
        let _ = writeln!(
            s,
            r#"<line x1="{}" y1="{ly:.1}" x2="{}" y2="{ly:.1}" stroke="{c}" stroke-width="2"/><text x="{}" y="{:.1}">{}</text>"#,
            W - R - 190.0,
            W - R - 170.0,
            W - R - 164.0,
            ly + 4.0,
            xml(name)
        );
    }
    s.push_str("</svg>\n");
    s
}

/// 1-2-5 ticks per decade inside [10^lo, 10^hi] (log10 bounds); 1…9 when that gives fewer
/// than three.
fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let v = ticks_with(lo, hi, &[1.0, 2.0, 5.0]);
    if v.len() >= 3 {
        return v;
    }
    ticks_with(lo, hi, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
}

fn ticks_with(lo: f64, hi: f64, mantissas: &[f64]) -> Vec<f64> {
    let mut v = Vec::new();
    for d in (lo.floor() as i32)..=(hi.ceil() as i32) {
        for &m in mantissas {
            let t = m * 10f64.powi(d);
            if t.log10() >= lo && t.log10() <= hi {
                v.push(t);
            }
        }
    }
    v
}

fn tick_label(v: f64) -> String {
    if (1e-3..1e4).contains(&v) {
        format!("{}", (v * 1e6).round() / 1e6)
    } else {
        format!("{v:e}")
    }
}

fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
