//! The `scene` stage: scene.json and its glTF files copied into the bundle, with a summary,
//! so the viewer and later tools read one self-contained bundle.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use crate::bundle::{BundleError, StageInfo, StageRecord, StageWriter};
use crate::scene::desc::SceneDesc;
use crate::scene::{Scene, SceneError, uri_path};

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
/// at the copy) and the glTF file with every external buffer (`gltf-buffer`) and image
/// (`gltf-image`: the textures the viewer and the stages sample) it names.
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

    // External buffers and images of a .gltf, at the same relative paths; one whose URI is
    // not a plain relative path inside the glTF's folder (`../x.bin`, percent-escapes) is
    // stored as `buffers/{index}.bin` or `images/{index}` and the copy's URI rewritten to it.
    let gltf_dir = gltf_path.parent().unwrap_or(Path::new("."));
    let mut buffers = Vec::new();
    let mut images = Vec::new();
    let mut renamed = Vec::new();
    if let Ok(doc) = gltf::Gltf::from_slice(&gltf_bytes) {
        for b in doc.document.buffers() {
            if let gltf::buffer::Source::Uri(uri) = b.source()
                && !uri.starts_with("data:")
            {
                let bytes = read(&gltf_dir.join(uri_path(uri)))?;
                let name = if is_plain_relative(uri) {
                    uri.to_string()
                } else {
                    let name = format!("buffers/{}.bin", b.index());
                    renamed.push(("buffers", b.index(), name.clone()));
                    name
                };
                buffers.push((name, bytes));
            }
        }
        for image in doc.document.images() {
            if let gltf::image::Source::Uri { uri, .. } = image.source()
                && !uri.starts_with("data:")
            {
                let bytes = read(&gltf_dir.join(uri_path(uri)))?;
                let name = if is_plain_relative(uri) {
                    uri.to_string()
                } else {
                    let name = format!("images/{}", image.index());
                    renamed.push(("images", image.index(), name.clone()));
                    name
                };
                images.push((name, bytes));
            }
        }
    }
    let gltf_bytes = if renamed.is_empty() {
        gltf_bytes
    } else {
        rewrite_buffer_uris(&gltf_bytes, &renamed).map_err(|message| SceneError::Gltf {
            path: gltf_path.clone(),
            message,
        })?
    };

    let mut w = StageWriter::begin(bundle, Stage::Scene.name())?;
    let desc = stored_desc(scene);
    let json = serde_json::to_string_pretty(&desc).expect("scene description serializes");
    w.write("scene.json", "scene-json", json.as_bytes())?;
    w.write(&desc.geometry, "gltf", &gltf_bytes)?;
    for (name, bytes) in &buffers {
        w.write(name, "gltf-buffer", bytes)?;
    }
    for (name, bytes) in &images {
        w.write(name, "gltf-image", bytes)?;
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

/// `scene`'s description as the stage stores it: named, its geometry the file beside it.
pub fn stored_desc(scene: &Scene) -> SceneDesc {
    let mut desc = scene.desc.clone();
    desc.name = Some(scene.name.clone());
    desc.geometry = Path::new(&desc.geometry)
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "geometry.glb".into());
    desc
}

/// Whether a buffer URI is a path the bundle can store as it is: relative, `/`-separated,
/// without `.`/`..` components or percent-escapes.
fn is_plain_relative(uri: &str) -> bool {
    !uri.is_empty()
        && !uri.starts_with('/')
        && !uri.contains(['\\', ':', '%', '?', '#'])
        && uri
            .split('/')
            .all(|c| !c.is_empty() && c != "." && c != "..")
}

/// The glTF JSON (`.gltf`) with `buffers[i].uri` or `images[i].uri` set to each new name
/// (`renamed`: array, index, name). A `.glb` with such a file is refused: its JSON chunk is
/// not rewritten.
fn rewrite_buffer_uris(gltf: &[u8], renamed: &[(&str, usize, String)]) -> Result<Vec<u8>, String> {
    if gltf.starts_with(b"glTF") {
        let (array, i, _) = &renamed[0];
        let what = array.trim_end_matches('s');
        return Err(format!(
            "a .glb whose external {what} URI leaves its folder or is percent-escaped cannot be copied into a bundle ({what} {i}); put the file beside the .glb"
        ));
    }
    let mut doc: serde_json::Value =
        serde_json::from_slice(gltf).map_err(|e| format!("not JSON: {e}"))?;
    for (array, i, name) in renamed {
        doc[*array][*i]["uri"] = name.clone().into();
    }
    Ok(serde_json::to_vec_pretty(&doc).expect("glTF JSON serializes"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_relative_uris() {
        for ok in ["x.bin", "sub/x.bin", "a-b_c.bin"] {
            assert!(is_plain_relative(ok), "{ok}");
        }
        for bad in [
            "../x.bin",
            "./x.bin",
            "/abs/x.bin",
            "a%20b.bin",
            "sub//x.bin",
            "c:x.bin",
        ] {
            assert!(!is_plain_relative(bad), "{bad}");
        }
    }
}
