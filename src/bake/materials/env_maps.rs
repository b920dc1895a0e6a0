//! The environment-map step of the materials stage (Luksch et al. §3): per glossy `curved`
//! reflector, the cube map seen from its centroid shaded with D, and its MIP levels
//! (`materials/env/<reflector>/mip<ℓ>.exr`, kind `env-mip`).

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::Path;

use super::report::EnvReport;
use super::{EnvShading, MaterialsError};
use crate::bake::read_cache::{self, MaterialPrints};
use crate::bundle::StageWriter;
use crate::geometry::{Bvh, Hit};
use crate::image_io::{ChannelData, ExrCompression, Precision, encode_rgb_exr_with};
use crate::materials::MaterialsSettings;
use crate::materials::envmap::{
    CaptureSettings, CubeMap, ENV_GLOSSY_SAMPLES, MAX_MIRROR_BOUNCES, MipPyramid, capture_centre,
    capture_recorded,
};
use crate::materials::index::{ENV_LAYOUT, IndexedEnvMap};
use crate::progress::Progress;
use crate::radiance::reads::{MapReads, Replay};
use crate::scene::{ReflectorKind, Scene};

/// What [`write_env_maps`] did.
pub struct WrittenEnvMaps {
    /// Index entries, in reflector order.
    pub index: Vec<IndexedEnvMap>,
    /// Reports, in reflector order.
    pub reports: Vec<EnvReport>,
    /// Why none were baked, if none were.
    pub skipped: Option<String>,
}

/// The reflectors that get environment maps: `curved` ones with a glossy material.
pub fn curved_glossy_reflectors(scene: &Scene) -> Vec<usize> {
    (0..scene.reflectors.len())
        .filter(|&r| {
            let refl = &scene.reflectors[r];
            refl.kind == ReflectorKind::Curved
                && scene.materials[refl.material as usize].is_glossy()
        })
        .collect()
}

/// Captures, filters and writes the environment map of every glossy curved reflector `k`
/// (in [`curved_glossy_reflectors`] order) that `take(k)` selects, with `shading` (`Err`: the
/// reason they are skipped), keeping their captures' records in `reads` ([`capture_kept`]),
/// adding an `env NAME` entry to `stats` for each.
#[allow(clippy::too_many_arguments)]
pub fn write_env_maps(
    w: &mut StageWriter,
    scene: &Scene,
    settings: &MaterialsSettings,
    shading: Result<EnvShading, String>,
    take: &dyn Fn(usize) -> bool,
    reads: Option<&Path>,
    progress: &dyn Progress,
    stats: &mut BTreeMap<String, serde_json::Value>,
) -> Result<WrittenEnvMaps, MaterialsError> {
    let curved = curved_glossy_reflectors(scene);
    let mut out = WrittenEnvMaps {
        index: Vec::new(),
        reports: Vec::new(),
        skipped: None,
    };
    if curved.is_empty() {
        out.skipped = Some("no `curved` reflector has a glossy material".to_string());
        return Ok(out);
    }
    let shading = match shading {
        Err(reason) => {
            out.skipped = Some(reason);
            return Ok(out);
        }
        Ok(s) => s,
    };
    let bvh = scene.build_bvh();
    let capture = capture_settings(settings);
    let env_folders =
        crate::bundle::unique_folders(curved.iter().map(|&r| scene.reflectors[r].name.as_str()));
    progress.phase(
        "environment maps",
        (curved.len() * 6 * capture.face_size) as u64,
    );
    for (k, &r) in curved.iter().enumerate() {
        if !take(k) {
            continue;
        }
        let refl = &scene.reflectors[r];
        let centre = capture_centre(scene, &refl.triangles);
        let record = format!("envmap.{}.reads", env_folders[k]);
        let cube = capture_kept(
            scene,
            &bvh,
            (centre, &refl.triangles),
            &shading,
            (reads, &record),
            &capture,
            progress,
        )?;
        let pyramid = MipPyramid::build(cube, settings.env_filter);
        let (paths, bytes) = write_levels(w, &format!("env/{}", env_folders[k]), &pyramid, None)?;
        let material = scene.materials[refl.material as usize].name.clone();
        stats.insert(
            format!("env {}", refl.name),
            serde_json::json!({
                "material": material, "face_size": capture.face_size,
                "levels": pyramid.levels.len(), "filter": settings.env_filter.name(),
                "files": paths.len(), "bytes": bytes,
            }),
        );
        out.index.push(IndexedEnvMap {
            reflector: refl.name.clone(),
            material: material.clone(),
            centre: centre.to_array(),
            face_size: capture.face_size,
            filter: settings.env_filter,
            levels: paths,
            layout: ENV_LAYOUT.into(),
        });
        out.reports.push(EnvReport {
            reflector: refl.name.clone(),
            material,
            centre: centre.to_array(),
            face_size: capture.face_size,
            levels: pyramid.levels.len(),
            filter: settings.env_filter.name(),
            bytes,
        });
    }
    Ok(out)
}

/// The cube seen from `at` (its point and the triangles it sees through) shaded with
/// `shading`, each texel given by its record ([`capture_recorded`]). With `kept` (a unit's
/// folder of records, [`read_cache`], and the name of this capture's, whose face `f` is the
/// file `NAME.face{f}`), the records kept there under this capture's key are evaluated with
/// this bake's D where the materials their rays met are unchanged, and the records are kept
/// for the next bake: a face's file rewritten when a texel of it was traced, all removed past
/// [`read_cache::READS_BUDGET`]. The shading reads D at the hit's point
/// alone (its triangle and barycentrics), as [`super::shade_with_d`]'s does.
pub fn capture_kept(
    scene: &Scene,
    bvh: &Bvh,
    at: (glam::Vec3, &[u32]),
    shading: &EnvShading,
    kept: (Option<&Path>, &str),
    capture: &CaptureSettings,
    progress: &dyn Progress,
) -> Result<CubeMap, MaterialsError> {
    let (centre, see_through) = at;
    let (dir, name) = kept;
    let d = |triangle: u32, bary: glam::Vec2| {
        (shading.shade)(&Hit {
            t: 0.0,
            triangle,
            bary,
        })
    };
    let key = read_cache::capture_key(scene, capture, centre, see_through);
    let prints = MaterialPrints::of(&scene.materials);
    // One file per cube face: an edit rewrites (and hashes) only the faces it traced texels
    // of again. A texel is stale where a material its rays met changed since its face's file
    // was written (a face kept as it is keeps the prints it was made with).
    let size = capture.face_size.max(1);
    let faces: Vec<(Option<read_cache::RecordFile>, Vec<bool>)> = (0..6)
        .map(|f| read_cache::kept(dir, &face_file(name, f), &key, &prints))
        .collect();
    let mut rows = Vec::with_capacity(6 * size);
    let mut read = [false; 6];
    for (f, (file, _)) in faces.iter().enumerate() {
        match file.as_ref().map(|file| file.reads()) {
            Some(reads) if reads.rows.len() == size => {
                read[f] = true;
                rows.extend(reads.rows.into_iter().map(Some));
            }
            _ => rows.extend((0..size).map(|_| None)),
        }
    }
    let replay = read.iter().any(|&r| r).then(|| Replay {
        rows,
        changed: faces.iter().map(|(_, c)| &c[..]).collect(),
    });
    let captured = capture_recorded(
        scene,
        bvh,
        centre,
        capture,
        see_through,
        (&shading.sides, &d),
        replay,
        progress,
    )?;
    let texels = 6 * captured.cube.size * captured.cube.size;
    let mut written = 0;
    if let Some(dir) = dir {
        // The records of an earlier layout, one file for the cube.
        read_cache::remove_file(dir, name)?;
        // A face's rows are borrowed from its file where none of its texels was traced
        // again: that file is still right, kept as it is.
        let mut rows = captured.reads.rows.into_iter();
        let mut spent = 0;
        for (f, was_read) in read.into_iter().enumerate() {
            let face: Vec<_> = rows.by_ref().take(size).collect();
            let file = face_file(name, f);
            if was_read && face.iter().all(|r| matches!(r, Cow::Borrowed(_))) {
                if !read_cache::count_kept(dir, &file, &mut spent)? {
                    break;
                }
                continue;
            }
            let reads = MapReads { rows: face };
            if read_cache::keep(dir, &file, &key, &prints, &reads, &mut spent)?.is_none() {
                break;
            }
            written += 1;
        }
        log::info!(
            "{name}: {} of {texels} texels traced, the rest evaluated from their records; {written} of 6 faces' records written",
            captured.traced
        );
    }
    Ok(captured.cube)
}

/// The file of face `f`'s records of the capture whose records are `name`.
fn face_file(name: &str, f: usize) -> String {
    format!("{name}.face{f}")
}

/// The capture of an environment map or a reflection probe: both show the room as the curved
/// reflectors see it.
pub fn capture_settings(settings: &MaterialsSettings) -> CaptureSettings {
    CaptureSettings {
        face_size: settings.env_map_size as usize,
        supersample: settings.env_supersample,
        mirror_bounces: MAX_MIRROR_BOUNCES,
        glossy_samples: ENV_GLOSSY_SAMPLES,
    }
}

/// Writes `pyramid`'s levels as `FOLDER/mip<ℓ>.exr` (kind `env-mip`), level 0 with the
/// distances `z` in channel `Z` when given; their paths and bytes.
pub fn write_levels(
    w: &mut StageWriter,
    folder: &str,
    pyramid: &MipPyramid,
    z: Option<&[f32]>,
) -> Result<(Vec<String>, u64), MaterialsError> {
    let mut bytes = 0u64;
    let mut paths = Vec::new();
    for (l, level) in pyramid.levels.iter().enumerate() {
        let rel = format!("{folder}/mip{l:02}.exr");
        let extra: Vec<ChannelData> = match z {
            Some(samples) if l == 0 => vec![ChannelData {
                name: "Z",
                precision: Precision::Float,
                samples,
            }],
            _ => Vec::new(),
        };
        let data = encode_rgb_exr_with(
            6 * level.size,
            level.size,
            &level.strip(),
            &extra,
            ExrCompression::Zip16,
        )
        .map_err(|source| MaterialsError::Image {
            path: rel.clone(),
            source,
        })?;
        bytes += data.len() as u64;
        w.write(&rel, "env-mip", &data)?;
        paths.push(rel);
    }
    Ok((paths, bytes))
}
