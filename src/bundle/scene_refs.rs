//! The files the scene stage's own files name: scene.json's `geometry` and the glTF's buffer
//! and image `uri`s. Inside a bundle each must be a relative reference to an asset of the
//! scene stage of the right kind, so that it lies inside the stage's folder, is listed in the
//! manifest and is hash-checked; `data:` URIs name no file and are left to the glTF reader.
//! `verify` and the viewer run this one check before any scene file is read.

use std::path::PathBuf;

use super::{AssetRecord, Bundle, BundleError, StageRecord};

/// The stage whose files name other files.
const STAGE: &str = "scene";

impl Bundle {
    /// Checks every file reference of the scene stage (module `bundle::scene_refs`); an empty
    /// list when they are all confined (or the bundle has no scene stage).
    pub fn check_scene_references(&self) -> Vec<BundleError> {
        let Some(stage) = self.stage(STAGE) else {
            return Vec::new();
        };
        let mut problems = Vec::new();
        if let Err(e) = self.check_scene_stage(stage, &mut problems) {
            problems.push(e);
        }
        problems
    }

    /// [`Bundle::check_scene_references`] of `stage`: reference errors go to `problems`, an
    /// unreadable file ends the check.
    fn check_scene_stage(
        &self,
        stage: &StageRecord,
        problems: &mut Vec<BundleError>,
    ) -> Result<(), BundleError> {
        let scene_json = stage
            .assets
            .iter()
            .find(|a| a.kind == "scene-json")
            .ok_or_else(|| BundleError::Asset {
                path: self.dir.join(stage.folder(STAGE)),
                problem: "stage `scene` has no scene-json asset".into(),
            })?;
        let scene_path = self.asset_path(scene_json);
        let text = self.read_asset(scene_json)?;
        let value: serde_json::Value =
            serde_json::from_slice(&text).map_err(|e| BundleError::Asset {
                path: scene_path.clone(),
                problem: format!("not JSON: {e}"),
            })?;
        let Some(geometry) = value.get("geometry").and_then(|g| g.as_str()) else {
            return Err(BundleError::Asset {
                path: scene_path,
                problem: "field `geometry` is missing or not a string".into(),
            });
        };
        let gltf = match self.scene_asset(geometry, "gltf") {
            Ok(a) => a,
            Err(why) => {
                problems.push(bad_reference(scene_path, "geometry", geometry, why));
                return Ok(());
            }
        };
        let gltf_path = self.asset_path(gltf);
        let bytes = self.read_asset(gltf)?;
        let json = gltf_json(&bytes).map_err(|problem| BundleError::Asset {
            path: gltf_path.clone(),
            problem,
        })?;
        for (array, kind) in [("buffers", "gltf-buffer"), ("images", "gltf-image")] {
            let items = json.get(array).and_then(|a| a.as_array());
            for (i, item) in items.into_iter().flatten().enumerate() {
                let Some(uri) = item.get("uri") else { continue };
                let field = format!("{array}[{i}].uri");
                let Some(uri) = uri.as_str() else {
                    problems.push(bad_reference(
                        gltf_path.clone(),
                        &field,
                        &uri.to_string(),
                        "not a string".into(),
                    ));
                    continue;
                };
                if uri.starts_with("data:") {
                    continue;
                }
                let rel = crate::scene::uri_path(uri);
                let rel = rel.to_string_lossy();
                if let Err(why) = self.scene_asset(&rel, kind) {
                    problems.push(bad_reference(gltf_path.clone(), &field, uri, why));
                }
            }
        }
        Ok(())
    }

    /// The scene stage's asset of kind `kind` at `rel` (a path inside the stage's folder), or
    /// why `rel` names none.
    fn scene_asset(&self, rel: &str, kind: &str) -> Result<&AssetRecord, String> {
        if rel.starts_with('/') || rel.contains(['\\', ':']) {
            return Err(
                "not a relative path (a bundle's files name only files of their own stage)".into(),
            );
        }
        if rel
            .split('/')
            .any(|c| c.is_empty() || c == "." || c == "..")
        {
            return Err(
                "has an empty, `.` or `..` component (a bundle's files name only files of their own stage)".into(),
            );
        }
        let logical = format!("{STAGE}/{rel}");
        match self
            .stage(STAGE)
            .and_then(|s| s.assets.iter().find(|a| a.path == logical))
        {
            Some(a) if a.kind == kind => Ok(a),
            Some(a) => Err(format!("names a `{}` asset, expected `{kind}`", a.kind)),
            None if kind == "gltf-image"
                && !self
                    .stage(STAGE)
                    .is_some_and(|s| s.assets.iter().any(|a| a.kind == kind)) =>
            {
                Err("names no asset of the scene stage, which holds no texture images (it was baked before bundle format 2.1 carried them): re-bake it with `glint-bake --force`".into())
            }
            None => Err(format!(
                "names no asset of the scene stage (it must be a `{kind}` file listed in the manifest)"
            )),
        }
    }
}

/// The error for a reference `field` = `reference` of bundle file `file`.
fn bad_reference(file: PathBuf, field: &str, reference: &str, why: String) -> BundleError {
    BundleError::BadReference {
        file: file.into_boxed_path(),
        field: field.into(),
        reference: reference.into(),
        why,
    }
}

/// The JSON of a `.gltf`, or of a `.glb`'s JSON chunk.
fn gltf_json(bytes: &[u8]) -> Result<serde_json::Value, String> {
    let json = if bytes.starts_with(b"glTF") {
        let len = bytes
            .get(12..16)
            .map(|l| u32::from_le_bytes(l.try_into().expect("4 bytes")) as usize)
            .ok_or("GLB header is cut short")?;
        bytes
            .get(20..20usize.saturating_add(len))
            .ok_or("GLB JSON chunk is cut short")?
    } else {
        bytes
    };
    serde_json::from_slice(json).map_err(|e| format!("glTF JSON: {e}"))
}
