//! The environment-map step of the materials stage (Luksch et al. §3): per glossy `curved`
//! reflector, the cube map seen from its centroid shaded with D, and its MIP levels
//! (`materials/env/<reflector>/mip<ℓ>.exr`, kind `env-mip`).

use std::collections::BTreeMap;

use super::report::EnvReport;
use super::{EnvShading, MaterialsError};
use crate::bundle::StageWriter;
use crate::image_io::{ChannelData, ExrCompression, Precision, encode_rgb_exr_with};
use crate::materials::MaterialsSettings;
use crate::materials::envmap::{
    CaptureSettings, ENV_GLOSSY_SAMPLES, MAX_MIRROR_BOUNCES, MipPyramid, capture_centre,
    capture_cube,
};
use crate::materials::index::{ENV_LAYOUT, IndexedEnvMap};
use crate::progress::Progress;
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
/// reason they are skipped), adding an `env NAME` entry to `stats` for each.
pub fn write_env_maps(
    w: &mut StageWriter,
    scene: &Scene,
    settings: &MaterialsSettings,
    shading: Result<EnvShading, String>,
    take: &dyn Fn(usize) -> bool,
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
        let cube = capture_cube(
            scene,
            &bvh,
            centre,
            &capture,
            &refl.triangles,
            &*shading.shade,
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
