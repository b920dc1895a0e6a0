//! The `srdm` stage (Popescu §4): for every impostor object and view, a depth-map capture and
//! its simplified rotated depth maps, in the bundle's `srdm/` folder.
//!
//! Files, per impostor `NAME` (a file-safe form of the glTF name) and view `K`:
//! - `srdm/NAME/viewK.exr` (kind `impostor-exr`): the capture, `w × w`, channels R G B (half,
//!   linear colour: D when the bundle has the radiosity stage, else the diffuse albedo),
//!   A (half, 1 on the object, 0 on background) and Z (float, normalized 1/z as defined in
//!   [`crate::srdm`], 0 on background);
//! - `srdm/NAME/viewK.srdm` (kind `srdm`): the SRDM set and the camera ([`Srdm::from_bytes`]);
//! - `srdm/NAME/viewK.png` (kind `preview-png`): the colour, tone-mapped, with alpha;
//! - `srdm/index.json` (kind `srdm-index`): the list of views, their files and cameras
//!   ([`SrdmIndex`]).
//!
//! The capture and its file format are [`crate::srdm::capture`]; the index and the reader the
//! viewer uses are [`crate::srdm::index`].

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use serde::Serialize;

pub use crate::settings::srdm::SrdmSettings;
pub use crate::srdm::capture::{
    Capture, ColourSource, SrdmAssetError, capture, colour_source, colour_source_read,
    encode_capture, impostor_triangles, view_camera,
};

use crate::bundle::{BundleError, StageInfo, StageRecord, StageWriter};
use crate::image_io;
use crate::progress::{Cancelled, Progress};
use crate::scene::{Impostor, Scene};
use crate::srdm::index::{INDEX_FILE, IndexedView, SrdmIndex};
use crate::srdm::{ErrorStats, Srdm, SrdmError, SrdmParams, error_stats};

use super::Stage;
use super::part::{Item, Part};

/// Why the SRDM stage failed.
#[derive(Debug, thiserror::Error)]
pub enum SrdmStageError {
    /// A setting out of range; the message names the field or flag.
    #[error("{0}")]
    Setting(String),
    /// Capturing, building, encoding or reading a view.
    #[error(transparent)]
    Asset(#[from] SrdmAssetError),
    /// Reading or writing the bundle.
    #[error(transparent)]
    Bundle(#[from] BundleError),
    /// Ctrl-C.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

impl From<crate::settings::SettingError> for SrdmStageError {
    fn from(e: crate::settings::SettingError) -> Self {
        SrdmStageError::Setting(e.to_string())
    }
}

/// The settings as recorded in the manifest, with the colour source (`albedo` or
/// `radiosity`) and `d_source`, the identity of the D read (none for `albedo`): what an
/// up-to-date check compares, so a bundle that gains D, or a re-baked D, re-bakes.
pub fn settings_json(
    settings: &SrdmSettings,
    colour: &str,
    d_source: Option<&str>,
) -> serde_json::Value {
    let mut v = serde_json::to_value(settings).expect("settings serialize");
    v["colour"] = colour.into();
    v["d_source"] = d_source.into();
    v
}

/// What one view came to.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ViewReport {
    /// Impostor name.
    pub impostor: String,
    /// View number.
    pub view: u32,
    /// Fraction of texels on the object.
    pub coverage: f64,
    /// Seconds to capture.
    pub capture_seconds: f64,
    /// Seconds to build the SRDM set (§5.1's construction time).
    pub build_seconds: f64,
    /// Accuracy against the capture.
    pub errors: ErrorStats,
    /// Bytes of the `.srdm` file.
    pub srdm_bytes: u64,
    /// Bytes of the capture EXR.
    pub capture_bytes: u64,
}

/// What the stage did.
#[derive(Debug)]
pub enum SrdmOutcome {
    /// The scene declares no impostor.
    Skipped {
        /// One line saying why.
        reason: String,
    },
    /// Baked and committed.
    Baked {
        /// The manifest record (boxed: it dwarfs the skipped variant).
        record: Box<StageRecord>,
        /// Per view.
        views: Vec<ViewReport>,
        /// `albedo` or `radiosity`.
        colour: &'static str,
    },
}

/// A file-safe folder name for an impostor, unique among `taken`.
fn folder_name(name: &str, index: usize, taken: &[String]) -> String {
    let mut s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() {
        s = "impostor".into();
    }
    if taken.contains(&s) {
        s = format!("{s}-{index}");
    }
    s
}

/// Each impostor's folder in the stage, in scene order.
pub fn impostor_folders(scene: &Scene) -> Vec<String> {
    let mut folders: Vec<String> = Vec::new();
    for (i, imp) in scene.impostors.iter().enumerate() {
        let folder = folder_name(&imp.name, i, &folders);
        folders.push(folder);
    }
    folders
}

/// Bakes every view of every impostor of `scene` into the bundle at `bundle`; a scene with
/// no impostor is skipped (nothing is written).
pub fn bake(
    scene: &Scene,
    bundle: &Path,
    settings: &SrdmSettings,
    force: bool,
    progress: &dyn Progress,
) -> Result<SrdmOutcome, SrdmStageError> {
    bake_part(scene, bundle, settings, force, Part::whole(), progress)
}

/// [`bake`] of `part`: every impostor, or one ([`Item::Impostor`]; `srdm/index.json` then
/// lists its views only), coloured with D from the bundle written or from `part.d_from`.
pub fn bake_part(
    scene: &Scene,
    bundle: &Path,
    settings: &SrdmSettings,
    force: bool,
    part: Part<'_>,
    progress: &dyn Progress,
) -> Result<SrdmOutcome, SrdmStageError> {
    let start = Instant::now();
    if let Some(p) = super::plan(scene)
        .into_iter()
        .find(|p| p.stage == Stage::Srdm && !p.needed)
    {
        return Ok(SrdmOutcome::Skipped { reason: p.reason });
    }
    settings.check()?;
    crate::bundle::check_scene(bundle, &scene.name, &scene.content_hash, force)?;
    let (colour, d_read, check_d) = match part.d_from {
        Some(from) => {
            let (map, identity) = super::part::require_d(from).map_err(SrdmAssetError::from)?;
            (
                ColourSource::Radiosity(Box::new(map)),
                Some(identity),
                false,
            )
        }
        None if part.item != Item::All => (ColourSource::Albedo, None, false),
        None => {
            let (colour, d_read) = colour_source_read(bundle, scene)?;
            (colour, d_read, true)
        }
    };

    let mut w = StageWriter::begin(bundle, Stage::Srdm.name())?;
    if let Some(d) = d_read.as_ref().filter(|_| check_d) {
        // Checked again at the commit: captures coloured with this D are never labelled
        // with another.
        w.read_from(Stage::Radiosity.name(), d);
    }
    let folders = impostor_folders(scene);
    let mut views = Vec::new();
    let mut index = SrdmIndex {
        version: 1,
        colour: colour.name().into(),
        settings: *settings,
        views: Vec::new(),
    };
    for (ii, imp) in scene.impostors.iter().enumerate() {
        let folder = &folders[ii];
        if !part.item.takes(Item::Impostor(ii)) {
            continue;
        }
        for v in 0..imp.views {
            let view = ViewToBake {
                scene,
                impostor: imp,
                view: v,
                folder,
            };
            let (entry, report) = view.bake(&mut w, settings, &colour, progress)?;
            index.views.push(entry);
            views.push(report);
        }
    }
    let index_json = serde_json::to_string_pretty(&index).expect("index serializes");
    w.write(INDEX_FILE, "srdm-index", index_json.as_bytes())?;

    let record = w.commit(StageInfo {
        scene_name: scene.name.clone(),
        scene_hash: scene.content_hash.clone(),
        settings: settings_json(settings, colour.name(), d_read.as_deref()),
        stats: summary(scene, colour.name(), &views),
        bake_seconds: start.elapsed().as_secs_f64(),
        force,
    })?;
    Ok(SrdmOutcome::Baked {
        record: Box::new(record),
        views,
        colour: colour.name(),
    })
}

/// One view of one impostor, to capture, simplify and write.
struct ViewToBake<'a> {
    scene: &'a Scene,
    impostor: &'a Impostor,
    view: u32,
    folder: &'a str,
}

impl ViewToBake<'_> {
    /// Captures the view, builds its SRDM set, writes the capture EXR, the `.srdm` and the
    /// preview PNG, and returns its index entry and report.
    fn bake(
        &self,
        w: &mut StageWriter,
        settings: &SrdmSettings,
        colour: &ColourSource,
        progress: &dyn Progress,
    ) -> Result<(IndexedView, ViewReport), SrdmStageError> {
        let (scene, imp, v, folder) = (self.scene, self.impostor, self.view, self.folder);
        let params = SrdmParams {
            domains: settings.domains,
            points: settings.points,
        };
        let label = format!("impostor {:?} view {v}", imp.name);
        let camera = view_camera(scene, imp, v, settings.resolution);
        let t = Instant::now();
        let cap = capture(scene, imp, &camera, colour, progress)?;
        let capture_seconds = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let srdm = Srdm::build(&cap.depth, camera, params, progress).map_err(|e| match e {
            SrdmError::Cancelled(c) => SrdmStageError::Cancelled(c),
            source => SrdmAssetError::Srdm {
                path: label.clone(),
                source,
            }
            .into(),
        })?;
        let build_seconds = t.elapsed().as_secs_f64();
        let errors = error_stats(&cap.depth, &srdm);

        let image = |source| SrdmAssetError::Image {
            path: label.clone(),
            source,
        };
        let exr = encode_capture(&cap).map_err(image)?;
        let bytes = srdm.to_bytes();
        let rgba: Vec<u8> = image_io::tonemap_preview(&cap.colour)
            .chunks(3)
            .zip(cap.depth.texels())
            .flat_map(|(c, d)| [c[0], c[1], c[2], if *d >= 0.0 { 255 } else { 0 }])
            .collect();
        let png = image_io::encode_png(camera.resolution, camera.resolution, &rgba, true)
            .map_err(image)?;
        let (srdm_rel, exr_rel) = (
            format!("{folder}/view{v}.srdm"),
            format!("{folder}/view{v}.exr"),
        );
        w.write(&exr_rel, "impostor-exr", &exr)?;
        w.write(&srdm_rel, "srdm", &bytes)?;
        w.write(&format!("{folder}/view{v}.png"), "preview-png", &png)?;
        let entry = IndexedView {
            impostor: imp.name.clone(),
            view: v,
            srdm: srdm_rel,
            capture: exr_rel,
            position: camera.view.position.to_array(),
            forward: camera.view.forward.to_array(),
        };
        let report = ViewReport {
            impostor: imp.name.clone(),
            view: v,
            coverage: cap.depth.coverage(),
            capture_seconds,
            build_seconds,
            errors,
            srdm_bytes: bytes.len() as u64,
            capture_bytes: exr.len() as u64,
        };
        Ok((entry, report))
    }
}

/// The figures recorded in the manifest: counts, bytes, build time, accuracy, coverage.
fn summary(
    scene: &Scene,
    colour: &str,
    views: &[ViewReport],
) -> BTreeMap<String, serde_json::Value> {
    let n = views.len().max(1) as f64;
    let mean = |f: &dyn Fn(&ViewReport) -> f64| views.iter().map(f).sum::<f64>() / n;
    BTreeMap::from([
        ("impostors".to_string(), scene.impostors.len().into()),
        ("views".into(), views.len().into()),
        ("colour".into(), colour.into()),
        (
            "srdm_bytes".into(),
            views.iter().map(|v| v.srdm_bytes).sum::<u64>().into(),
        ),
        (
            "capture_bytes".into(),
            views.iter().map(|v| v.capture_bytes).sum::<u64>().into(),
        ),
        (
            "build_ms".into(),
            round(1e3 * views.iter().map(|v| v.build_seconds).sum::<f64>(), 1).into(),
        ),
        (
            "mean_relative_z_error".into(),
            round(mean(&|v| v.errors.mean_relative_z_error), 7).into(),
        ),
        (
            "max_row_error".into(),
            round(
                views
                    .iter()
                    .map(|v| v.errors.max_row_error as f64)
                    .fold(0.0, f64::max),
                7,
            )
            .into(),
        ),
        (
            "rows_dropping_spans".into(),
            views
                .iter()
                .map(|v| v.errors.rows_dropping_spans)
                .sum::<u64>()
                .into(),
        ),
        ("coverage".into(), round(mean(&|v| v.coverage), 4).into()),
    ])
}

fn round(v: f64, digits: i32) -> f64 {
    let k = 10f64.powi(digits);
    (v * k).round() / k
}
