//! The reflection-probe step of the materials stage: per probe the scene needs
//! ([`crate::materials::probes::scene_probes`]), the cube map seen from it shaded with D,
//! captured as the curved reflectors' environment maps are ([`capture_kept`]), its MIP levels
//! (`materials/probes/<probe>/mip<ℓ>.exr`, kind `env-mip`), level 0 with the distance to
//! what each texel sees in channel `Z`.

use std::collections::BTreeMap;
use std::path::Path;

use super::env_maps::{capture_kept, capture_settings, write_levels};
use super::report::EnvReport;
use super::{EnvShading, MaterialsError};
use crate::bundle::StageWriter;
use crate::materials::MaterialsSettings;
use crate::materials::envmap::MipPyramid;
use crate::materials::index::{ENV_LAYOUT, IndexedProbe};
use crate::materials::probes::{capture_distances, scene_probes};
use crate::progress::Progress;
use crate::scene::Scene;

/// What [`write_probes`] did.
pub struct WrittenProbes {
    /// Index entries, in probe order.
    pub index: Vec<IndexedProbe>,
    /// Reports, in probe order.
    pub reports: Vec<EnvReport>,
    /// Why the probes the scene needs were not baked, if they were not.
    pub skipped: Option<String>,
}

/// The probes' folders in the stage, in probe order.
pub fn probe_folders(scene: &Scene) -> Vec<String> {
    crate::bundle::unique_folders(scene_probes(scene).iter().map(|p| p.name.as_str()))
}

/// Captures, filters and writes every probe `k` that `take(k)` selects, with `shading`
/// (`Err`: the reason they are skipped), keeping their captures' records in `reads`
/// ([`capture_kept`]), adding a `probe NAME` entry to `stats` for each.
#[allow(clippy::too_many_arguments)]
pub fn write_probes(
    w: &mut StageWriter,
    scene: &Scene,
    settings: &MaterialsSettings,
    shading: &Result<EnvShading, String>,
    take: &dyn Fn(usize) -> bool,
    reads: Option<&Path>,
    progress: &dyn Progress,
    stats: &mut BTreeMap<String, serde_json::Value>,
) -> Result<WrittenProbes, MaterialsError> {
    let probes = scene_probes(scene);
    let mut out = WrittenProbes {
        index: Vec::new(),
        reports: Vec::new(),
        skipped: None,
    };
    // A unit that bakes no probe says nothing about them: its shard is kept across edits that
    // add or remove probes, so a note there could outlive the probes it spoke of.
    if !(0..probes.len()).any(take) {
        return Ok(out);
    }
    let shading = match shading {
        Err(reason) => {
            out.skipped = Some(reason.clone());
            return Ok(out);
        }
        Ok(s) => s,
    };
    let bvh = scene.build_bvh();
    let capture = capture_settings(settings);
    let folders = probe_folders(scene);
    progress.phase(
        "reflection probes",
        (probes.len() * 6 * capture.face_size) as u64,
    );
    for (k, probe) in probes.iter().enumerate() {
        if !take(k) {
            continue;
        }
        let record = format!("probe.{}.reads", folders[k]);
        let cube = capture_kept(
            scene,
            &bvh,
            (probe.position, &[]),
            shading,
            (reads, &record),
            &capture,
            progress,
        )?;
        let distances = capture_distances(&bvh, probe.position, capture.face_size);
        let z: Vec<f32> = distances.strip().iter().map(|v| v.x).collect();
        let pyramid = MipPyramid::build(cube, settings.env_filter);
        let (paths, bytes) =
            write_levels(w, &format!("probes/{}", folders[k]), &pyramid, Some(&z))?;
        stats.insert(
            format!("probe {}", probe.name),
            serde_json::json!({
                "centre": probe.position.to_array(), "radius": probe.radius,
                "face_size": capture.face_size, "levels": pyramid.levels.len(),
                "filter": settings.env_filter.name(), "files": paths.len(), "bytes": bytes,
            }),
        );
        out.index.push(IndexedProbe {
            name: probe.name.clone(),
            centre: probe.position.to_array(),
            radius: probe.radius,
            face_size: capture.face_size,
            filter: settings.env_filter,
            levels: paths,
            layout: ENV_LAYOUT.into(),
        });
        out.reports.push(EnvReport {
            reflector: format!("probe {}", probe.name),
            material: String::new(),
            centre: probe.position.to_array(),
            face_size: capture.face_size,
            levels: pyramid.levels.len(),
            filter: settings.env_filter.name(),
            bytes,
        });
    }
    Ok(out)
}
