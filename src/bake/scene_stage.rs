//! The `scene` stage: scene.json and its glTF files copied into the bundle, with a summary,
//! so the viewer and later tools read one self-contained bundle.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use crate::bundle::{BundleError, StageInfo, StageRecord, StageWriter};
use crate::scene::{Scene, SceneError};

use super::Stage;

/// Why the scene stage failed.
#[derive(Debug, thiserror::Error)]
pub enum SceneStageError {
    /// Reading the scene's files.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// Writing the bundle.
    #[error(transparent)]
    Bundle(#[from] BundleError),
}

/// Figures recorded for the scene stage.
pub fn summary(scene: &Scene) -> BTreeMap<String, serde_json::Value> {
    let glossy = scene.materials.iter().filter(|m| m.is_glossy()).count();
    BTreeMap::from([
        ("triangles".into(), scene.triangles.len().into()),
        ("dropped_triangles".into(), scene.dropped_triangles.into()),
        ("objects".into(), scene.objects.len().into()),
        ("materials".into(), scene.materials.len().into()),
        ("glossy_materials".into(), glossy.into()),
        ("area_lights".into(), scene.lights.len().into()),
        ("reflectors".into(), scene.reflectors.len().into()),
        ("impostors".into(), scene.impostors.len().into()),
        ("camera_paths".into(), scene.desc.camera_paths.len().into()),
    ])
}

/// Copies the scene into `bundle`'s `scene/` folder: `scene.json` (with `geometry` pointing
/// at the copy) and the glTF file with every external buffer it names.
pub fn bake(scene: &Scene, bundle: &Path, force: bool) -> Result<StageRecord, SceneStageError> {
    let start = Instant::now();
    let scene_dir = scene.path.parent().unwrap_or(Path::new("."));
    let gltf_path = scene_dir.join(&scene.desc.geometry);
    let read = |p: &Path| {
        std::fs::read(p).map_err(|source| SceneError::Io {
            path: p.to_owned(),
            source,
        })
    };
    let gltf_bytes = read(&gltf_path)?;
    let file_name = gltf_path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "geometry.glb".into());

    let mut w = StageWriter::begin(bundle, Stage::Scene.name())?;
    let mut desc = scene.desc.clone();
    desc.geometry = file_name.clone();
    desc.name = Some(scene.name.clone());
    let json = serde_json::to_string_pretty(&desc).expect("scene description serializes");
    w.write("scene.json", "scene-json", json.as_bytes())?;
    w.write(&file_name, "gltf", &gltf_bytes)?;
    // External buffers of a .gltf, at the same relative paths.
    if let Ok(doc) = gltf::Gltf::from_slice(&gltf_bytes) {
        for b in doc.document.buffers() {
            if let gltf::buffer::Source::Uri(uri) = b.source()
                && !uri.starts_with("data:")
            {
                let bytes = read(&gltf_path.parent().unwrap_or(Path::new(".")).join(uri))?;
                w.write(uri, "gltf-buffer", &bytes)?;
            }
        }
    }
    Ok(w.commit(StageInfo {
        scene_name: scene.name.clone(),
        scene_hash: scene.content_hash.clone(),
        settings: serde_json::json!({}),
        stats: summary(scene),
        bake_seconds: start.elapsed().as_secs_f64(),
        force,
    })?)
}
