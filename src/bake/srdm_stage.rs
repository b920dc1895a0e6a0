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

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::bundle::{Bundle, BundleError, StageInfo, StageRecord, StageWriter};
use crate::camera::Camera;
use crate::geometry::{Bvh, Triangle};
use crate::image_io::{self, ChannelData, ExrCompression, ImageError, Precision};
use crate::progress::{Cancelled, Progress};
use crate::radiosity::RadiosityMap;
use crate::radiosity::map::MapError;
use crate::scene::desc::{SettingError, SrdmOverride};
use crate::scene::{Impostor, Quality, Scene};
use crate::srdm::{
    BACKGROUND, DepthMap, ErrorStats, ImpostorCamera, MAX_DOMAINS, MAX_POINTS, MAX_RESOLUTION,
    MIN_DEPTH, Srdm, SrdmError, SrdmParams, error_stats,
};

use super::Stage;

/// Why the SRDM stage failed.
#[derive(Debug, thiserror::Error)]
pub enum SrdmStageError {
    /// A setting out of range; the message names the field or flag.
    #[error("{0}")]
    Setting(String),
    /// Building or reading an SRDM.
    #[error("{path}: {source}")]
    Srdm {
        /// The view (or asset path) concerned.
        path: String,
        /// Cause.
        source: SrdmError,
    },
    /// Encoding or decoding a capture.
    #[error("{path}: {source}")]
    Image {
        /// The view (or asset path) concerned.
        path: String,
        /// Cause.
        source: ImageError,
    },
    /// The bundle's index or assets disagree.
    #[error("{0}")]
    Inconsistent(String),
    /// Reading the radiosity stage for colour.
    #[error(transparent)]
    Radiosity(#[from] MapError),
    /// Reading or writing the bundle.
    #[error(transparent)]
    Bundle(#[from] BundleError),
    /// Ctrl-C.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

/// Resolved SRDM settings: preset, then scene.json's `bake.srdm`, then the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SrdmSettings {
    /// Rotated domains n.
    pub domains: u32,
    /// Points per row m.
    pub points: u32,
    /// Depth-map resolution w (square).
    pub resolution: u32,
}

impl SrdmSettings {
    /// The preset's values. `default` is the paper's set-up (256², n = 60, m within its 8–16).
    pub fn preset(quality: Quality) -> SrdmSettings {
        let (domains, points, resolution) = match quality {
            Quality::Draft => (30, 8, 128),
            Quality::Default => (60, 16, 256),
            Quality::High => (120, 32, 512),
        };
        SrdmSettings {
            domains,
            points,
            resolution,
        }
    }

    /// The preset with the scene's overrides, each checked ([`SrdmSettings::check`]); errors
    /// name scene.json and the field.
    pub fn resolve(
        scene_path: &Path,
        quality: Quality,
        over: &SrdmOverride,
    ) -> Result<SrdmSettings, SrdmStageError> {
        let mut s = SrdmSettings::preset(quality);
        if let Some(v) = over.domains {
            s.domains = v;
        }
        if let Some(v) = over.points {
            s.points = v;
        }
        if let Some(v) = over.resolution {
            s.resolution = v;
        }
        s.check().map_err(|e| {
            SrdmStageError::Setting(format!(
                "{}: field `bake.srdm.{}`: {}",
                scene_path.display(),
                e.field,
                e.message
            ))
        })?;
        Ok(s)
    }

    /// Checks every value: domains in 1 ..= [`MAX_DOMAINS`], points in 2 ..= [`MAX_POINTS`],
    /// resolution in 2 ..= [`MAX_RESOLUTION`].
    pub fn check(&self) -> Result<(), SettingError> {
        let ranges = [
            ("domains", self.domains, 1, MAX_DOMAINS),
            ("points", self.points, 2, MAX_POINTS),
            ("resolution", self.resolution, 2, MAX_RESOLUTION),
        ];
        for (name, v, lo, hi) in ranges {
            if !(lo..=hi).contains(&v) {
                return Err(SettingError::new(
                    name,
                    format!("{v} is outside {lo} ..= {hi}"),
                ));
            }
        }
        Ok(())
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

/// Where the impostors' colour comes from.
pub enum ColourSource {
    /// The diffuse albedo of the hit material: unlit, used when the bundle has no D.
    Albedo,
    /// D, the baked radiosity (exitant diffuse radiance) at the hit.
    Radiosity(Box<RadiosityMap>),
}

impl ColourSource {
    /// The name recorded in the manifest (`colour`).
    pub fn name(&self) -> &'static str {
        match self {
            ColourSource::Albedo => "albedo",
            ColourSource::Radiosity(_) => "radiosity",
        }
    }

    /// The colour at barycentrics `bary` of scene triangle `triangle`.
    pub fn colour(&self, scene: &Scene, triangle: u32, bary: Vec2) -> Vec3 {
        match self {
            ColourSource::Albedo => {
                scene.materials[scene.triangles[triangle as usize].material as usize].albedo
            }
            ColourSource::Radiosity(d) => d.radiance(triangle, bary),
        }
    }
}

/// THE place the impostor colour is chosen: D from the bundle's `radiosity` stage when it was
/// baked from this scene (issue 8: "colour comes from D when the radiosity stage is in the
/// bundle"), else the albedo. The choice is recorded as `colour` in the stage's settings.
pub fn colour_source(bundle: &Path, scene: &Scene) -> Result<ColourSource, SrdmStageError> {
    Ok(colour_source_read(bundle, scene)?.0)
}

/// [`colour_source`] with the identity of the radiosity stage it read (none for the albedo),
/// from the one manifest the map was loaded through.
pub fn colour_source_read(
    bundle: &Path,
    scene: &Scene,
) -> Result<(ColourSource, Option<String>), SrdmStageError> {
    let opened = match Bundle::open(bundle) {
        Ok(b) => b,
        Err(BundleError::MissingManifest { .. }) => return Ok((ColourSource::Albedo, None)),
        Err(e) => return Err(e.into()),
    };
    let Some(d) = opened
        .stage(Stage::Radiosity.name())
        .filter(|r| r.scene_hash == scene.content_hash)
    else {
        return Ok((ColourSource::Albedo, None));
    };
    Ok(match RadiosityMap::load(&opened)? {
        Some(map) => (ColourSource::Radiosity(Box::new(map)), Some(d.identity())),
        None => (ColourSource::Albedo, None),
    })
}

/// The scene triangles of an impostor, in object order.
pub fn impostor_triangles(scene: &Scene, impostor: &Impostor) -> Vec<u32> {
    impostor
        .objects
        .iter()
        .flat_map(|&o| scene.objects[o as usize].triangles.clone())
        .collect()
}

/// The capture camera of view `view` of an impostor.
///
/// Views are spread evenly around the world's up axis, starting from the direction of the
/// scene's first camera keyframe as seen from the object (else +Z, glTF's front), with that
/// direction's elevation clamped to ±60°. The eye is 3 half-diagonals of the object's bounding
/// box from its centre; the field of view is the smallest that holds every vertex's projection
/// in the image's inscribed circle (so every rotated domain covers the object) plus a texel;
/// hither and yon enclose the bounding box with 1% of its depth range to spare, so every
/// foreground depth is ≥ ~0.01 (§4.1: "hither and yon planes that encompass the bounding box").
pub fn view_camera(
    scene: &Scene,
    impostor: &Impostor,
    view: u32,
    resolution: u32,
) -> ImpostorCamera {
    let b = impostor.bounds;
    let centre = b.center();
    let radius = (0.5 * b.diagonal()).max(1e-6);
    let reference = scene
        .desc
        .camera_paths
        .first()
        .and_then(|p| p.keyframes.first())
        .map(|k| Vec3::from(k.position) - centre)
        .and_then(|d| d.try_normalize())
        .unwrap_or(Vec3::Z);
    let max_el = 60f32.to_radians();
    let elevation = reference.y.clamp(-1.0, 1.0).asin().clamp(-max_el, max_el);
    let azimuth = if reference.x.abs() + reference.z.abs() > 1e-6 {
        reference.x.atan2(reference.z)
    } else {
        0.0
    };
    let az = azimuth + std::f32::consts::TAU * view as f32 / impostor.views.max(1) as f32;
    let dir = Vec3::new(
        elevation.cos() * az.sin(),
        elevation.sin(),
        elevation.cos() * az.cos(),
    );
    let eye = centre + dir * (3.0 * radius);
    let mut view_cam = Camera::look_at(eye, centre, Vec3::Y, 1.0);
    let mut tan = 0.0f32;
    for &t in &impostor_triangles(scene, impostor) {
        for p in scene.triangles[t as usize].p {
            let q = p - eye;
            let z = q.dot(view_cam.forward);
            let r = Vec2::new(q.dot(view_cam.right), q.dot(view_cam.up)).length();
            tan = tan.max(r / z);
        }
    }
    let tan = tan.max(1e-6) * (1.0 + 2.0 / resolution as f32);
    view_cam.fov_y = 2.0 * tan.atan();
    let (mut z0, mut z1) = (f32::INFINITY, f32::NEG_INFINITY);
    for k in 0..8 {
        let corner = Vec3::new(
            if k & 1 == 0 { b.min.x } else { b.max.x },
            if k & 2 == 0 { b.min.y } else { b.max.y },
            if k & 4 == 0 { b.min.z } else { b.max.z },
        );
        let z = (corner - eye).dot(view_cam.forward);
        z0 = z0.min(z);
        z1 = z1.max(z);
    }
    let margin = 0.01 * (z1 - z0).max(1e-3 * radius);
    ImpostorCamera {
        view: view_cam,
        hither: z0 - margin,
        yon: z1 + margin,
        resolution,
    }
}

/// A captured view: the depth map and the colour per texel (black on background).
#[derive(Clone, Debug, PartialEq)]
pub struct Capture {
    /// The camera.
    pub camera: ImpostorCamera,
    /// Normalized 1/z per texel.
    pub depth: DepthMap,
    /// Linear colour per texel, row-major.
    pub colour: Vec<Vec3>,
}

/// Captures an impostor (§4: "depth map impostors are constructed the same way … as
/// billboards … the texture is extended with a z channel") by casting one ray through each
/// texel centre against the impostor's own triangles. Rows in parallel; deterministic.
pub fn capture(
    scene: &Scene,
    impostor: &Impostor,
    camera: &ImpostorCamera,
    colour: &ColourSource,
    progress: &dyn Progress,
) -> Result<Capture, SrdmStageError> {
    let ids = impostor_triangles(scene, impostor);
    let tris: Vec<Triangle> = ids.iter().map(|&t| scene.triangles[t as usize]).collect();
    let bvh = Bvh::build(&tris);
    let w = camera.resolution as usize;
    let mut depth = vec![BACKGROUND; w * w];
    let mut rgb = vec![Vec3::ZERO; w * w];
    progress.phase(&format!("capture {}", impostor.name), w as u64);
    depth
        .par_chunks_mut(w)
        .zip(rgb.par_chunks_mut(w))
        .enumerate()
        .try_for_each(|(y, (drow, crow))| {
            if progress.cancelled() {
                return Err(Cancelled);
            }
            for x in 0..w {
                let dir = camera.texel_ray(x as u32, y as u32);
                if let Some(hit) = bvh.closest_hit(camera.view.position, dir, f32::INFINITY) {
                    let z = hit.t * dir.dot(camera.view.forward);
                    drow[x] = camera.depth_of_z(z).clamp(MIN_DEPTH, 1.0);
                    crow[x] = colour.colour(scene, ids[hit.triangle as usize], hit.bary);
                }
            }
            progress.advance(1);
            Ok(())
        })?;
    let depth = DepthMap::new(camera.resolution, depth).map_err(|source| SrdmStageError::Srdm {
        path: impostor.name.clone(),
        source,
    })?;
    Ok(Capture {
        camera: *camera,
        depth,
        colour: rgb,
    })
}

/// The capture as an EXR: R G B A half, Z float (see the module docs).
pub fn encode_capture(c: &Capture) -> Result<Vec<u8>, ImageError> {
    let w = c.camera.resolution as usize;
    let split = |k: usize| c.colour.iter().map(|v| v[k]).collect::<Vec<f32>>();
    let (r, g, b) = (split(0), split(1), split(2));
    let texels = c.depth.texels();
    let a: Vec<f32> = texels.iter().map(|d| f32::from(*d >= 0.0)).collect();
    let z: Vec<f32> = texels.iter().map(|d| d.max(0.0)).collect();
    let ch = |name, precision, samples| ChannelData {
        name,
        precision,
        samples,
    };
    image_io::encode_exr(
        w,
        w,
        &[
            ch("R", Precision::Half, &r),
            ch("G", Precision::Half, &g),
            ch("B", Precision::Half, &b),
            ch("A", Precision::Half, &a),
            ch("Z", Precision::Float, &z),
        ],
        ExrCompression::Zip16,
    )
}

/// Reads a capture written by [`encode_capture`]; `camera` comes from the view's `.srdm`.
pub fn decode_capture(bytes: &[u8], camera: ImpostorCamera) -> Result<Capture, SrdmStageError> {
    let img = image_io::decode_exr(bytes).map_err(|source| SrdmStageError::Image {
        path: "capture".into(),
        source,
    })?;
    let w = camera.resolution as usize;
    if (img.width, img.height) != (w, w) {
        return Err(SrdmStageError::Inconsistent(format!(
            "the capture is {}×{} texels, its SRDM {w}×{w}",
            img.width, img.height
        )));
    }
    let shape = |source| SrdmStageError::Image {
        path: "capture".into(),
        source,
    };
    let colour = img.rgb().map_err(shape)?;
    let (a, z) = (
        img.channel("A").map_err(shape)?,
        img.channel("Z").map_err(shape)?,
    );
    let depth = a
        .iter()
        .zip(z)
        .map(|(a, z)| if *a > 0.5 { *z } else { BACKGROUND })
        .collect();
    let depth = DepthMap::new(camera.resolution, depth).map_err(|source| SrdmStageError::Srdm {
        path: "capture".into(),
        source,
    })?;
    Ok(Capture {
        camera,
        depth,
        colour,
    })
}

/// `srdm/index.json`: what the stage holds, for the viewer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SrdmIndex {
    /// Index version, 1.
    pub version: u32,
    /// `albedo` or `radiosity`: what the captures' colour is.
    pub colour: String,
    /// Settings used.
    pub settings: SrdmSettings,
    /// Every view of every impostor, in scene.json order.
    pub views: Vec<IndexedView>,
}

/// One view in [`SrdmIndex`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IndexedView {
    /// Impostor name (the glTF mesh or node name from scene.json).
    pub impostor: String,
    /// View number, 0-based.
    pub view: u32,
    /// The `.srdm` file, relative to the stage folder.
    pub srdm: String,
    /// The capture EXR, relative to the stage folder.
    pub capture: String,
    /// Camera eye position.
    pub position: [f32; 3],
    /// Camera view direction.
    pub forward: [f32; 3],
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
        /// The manifest record.
        record: StageRecord,
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

/// Bakes every view of every impostor of `scene` into the bundle at `bundle`; a scene with
/// no impostor is skipped (nothing is written).
pub fn bake(
    scene: &Scene,
    bundle: &Path,
    settings: &SrdmSettings,
    force: bool,
    progress: &dyn Progress,
) -> Result<SrdmOutcome, SrdmStageError> {
    let start = Instant::now();
    if let Some(p) = super::plan(scene)
        .into_iter()
        .find(|p| p.stage == Stage::Srdm && !p.needed)
    {
        return Ok(SrdmOutcome::Skipped { reason: p.reason });
    }
    settings
        .check()
        .map_err(|e| SrdmStageError::Setting(e.to_string()))?;
    crate::bundle::check_scene(bundle, &scene.content_hash, force)?;
    let (colour, d_read) = colour_source_read(bundle, scene)?;
    let params = SrdmParams {
        domains: settings.domains,
        points: settings.points,
    };

    let mut w = StageWriter::begin(bundle, Stage::Srdm.name())?;
    if let Some(d) = &d_read {
        // Checked again at the commit: captures coloured with this D are never labelled
        // with another.
        w.read_from(Stage::Radiosity.name(), d);
    }
    let mut folders: Vec<String> = Vec::new();
    let mut views = Vec::new();
    let mut index = SrdmIndex {
        version: 1,
        colour: colour.name().into(),
        settings: *settings,
        views: Vec::new(),
    };
    for (ii, imp) in scene.impostors.iter().enumerate() {
        let folder = folder_name(&imp.name, ii, &folders);
        folders.push(folder.clone());
        for v in 0..imp.views {
            let label = format!("impostor {:?} view {v}", imp.name);
            let camera = view_camera(scene, imp, v, settings.resolution);
            let t = Instant::now();
            let cap = capture(scene, imp, &camera, &colour, progress)?;
            let capture_seconds = t.elapsed().as_secs_f64();
            let t = Instant::now();
            let srdm = Srdm::build(&cap.depth, camera, params, progress).map_err(|e| match e {
                SrdmError::Cancelled(c) => SrdmStageError::Cancelled(c),
                source => SrdmStageError::Srdm {
                    path: label.clone(),
                    source,
                },
            })?;
            let build_seconds = t.elapsed().as_secs_f64();
            let errors = error_stats(&cap.depth, &srdm);

            let image = |source| SrdmStageError::Image {
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
            index.views.push(IndexedView {
                impostor: imp.name.clone(),
                view: v,
                srdm: srdm_rel,
                capture: exr_rel,
                position: camera.view.position.to_array(),
                forward: camera.view.forward.to_array(),
            });
            views.push(ViewReport {
                impostor: imp.name.clone(),
                view: v,
                coverage: cap.depth.coverage(),
                capture_seconds,
                build_seconds,
                errors,
                srdm_bytes: bytes.len() as u64,
                capture_bytes: exr.len() as u64,
            });
        }
    }
    let index_json = serde_json::to_string_pretty(&index).expect("index serializes");
    w.write("index.json", "srdm-index", index_json.as_bytes())?;

    let n = views.len().max(1) as f64;
    let mean = |f: &dyn Fn(&ViewReport) -> f64| views.iter().map(f).sum::<f64>() / n;
    let stats = BTreeMap::from([
        ("impostors".to_string(), scene.impostors.len().into()),
        ("views".into(), views.len().into()),
        ("colour".into(), colour.name().into()),
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
    ]);
    let record = w.commit(StageInfo {
        scene_name: scene.name.clone(),
        scene_hash: scene.content_hash.clone(),
        settings: settings_json(settings, colour.name(), d_read.as_deref()),
        stats,
        bake_seconds: start.elapsed().as_secs_f64(),
        force,
    })?;
    Ok(SrdmOutcome::Baked {
        record,
        views,
        colour: colour.name(),
    })
}

fn round(v: f64, digits: i32) -> f64 {
    let k = 10f64.powi(digits);
    (v * k).round() / k
}

/// One view read back from a bundle.
pub struct LoadedView {
    /// Its index entry.
    pub entry: IndexedView,
    /// The SRDM set (with the camera).
    pub srdm: Srdm,
    /// The capture.
    pub capture: Capture,
}

/// Reads every view of the bundle's `srdm` stage (what the viewer needs); `Ok(None)` when the
/// bundle has no such stage. Asset hashes are checked; errors name the asset.
pub fn load(bundle: &Bundle) -> Result<Option<(SrdmIndex, Vec<LoadedView>)>, SrdmStageError> {
    let Some(stage) = bundle.stage(Stage::Srdm.name()) else {
        return Ok(None);
    };
    let asset = |rel: &str| {
        let path = format!("{}/{rel}", Stage::Srdm.name());
        stage.assets.iter().find(|a| a.path == path).ok_or_else(|| {
            SrdmStageError::Inconsistent(format!(
                "{}: the srdm stage lists no asset {path}",
                bundle.dir().display()
            ))
        })
    };
    let index_rec = asset("index.json")?;
    let index: SrdmIndex = serde_json::from_slice(&bundle.read_asset(index_rec)?).map_err(|e| {
        SrdmStageError::Inconsistent(format!("{}: {e}", bundle.asset_path(index_rec).display()))
    })?;
    let mut views = Vec::new();
    for entry in &index.views {
        let rec = asset(&entry.srdm)?;
        let at = |p: PathBuf| p.display().to_string();
        let srdm =
            Srdm::from_bytes(&bundle.read_asset(rec)?).map_err(|source| SrdmStageError::Srdm {
                path: at(bundle.asset_path(rec)),
                source,
            })?;
        let crec = asset(&entry.capture)?;
        let capture = decode_capture(&bundle.read_asset(crec)?, *srdm.camera()).map_err(|e| {
            SrdmStageError::Inconsistent(format!("{}: {e}", at(bundle.asset_path(crec))))
        })?;
        views.push(LoadedView {
            entry: entry.clone(),
            srdm,
            capture,
        });
    }
    Ok(Some((index, views)))
}
