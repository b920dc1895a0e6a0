//! The viewer reads bundles through each stage's domain module (`materials`, `radiance`,
//! `srdm`, `radiosity`), never through the bakers: nothing under `src/view` may name
//! `crate::bake`.

use std::path::{Path, PathBuf};

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn the_viewer_imports_nothing_from_the_bakers() {
    let view = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/view");
    let mut files = Vec::new();
    rust_files(&view, &mut files);
    assert!(
        files.len() > 10,
        "found the viewer's sources under {}",
        view.display()
    );
    let mut offences = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        for (i, line) in text.lines().enumerate() {
            if line.contains("crate::bake") || line.contains("glint::bake") {
                offences.push(format!("{}:{}: {}", f.display(), i + 1, line.trim()));
            }
        }
    }
    assert!(
        offences.is_empty(),
        "src/view must not reach into the bakers:\n{}",
        offences.join("\n")
    );
}

/// Lines of the files under `src/{dir}` (or the file `src/{dir}.rs`) that name one of
/// `modules` as `crate::M`.
fn naming(dir: &str, modules: &[&str]) -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    if root.join(dir).is_dir() {
        rust_files(&root.join(dir), &mut files);
    } else {
        files.push(root.join(format!("{dir}.rs")));
    }
    let mut out = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        for (i, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            if modules.iter().any(|m| {
                code.contains(&format!("crate::{m}::")) || code.contains(&format!("crate::{m};"))
            }) {
                out.push(format!("{}:{}: {}", f.display(), i + 1, line.trim()));
            }
        }
    }
    out
}

/// The scene layer imports no stage (stages import it), the stages' settings import nothing
/// of glint, and the camera module nothing of the scene: no import loop through them.
#[test]
fn the_scene_layer_and_the_settings_import_no_stage() {
    let above_scene = [
        "bake",
        "radiosity",
        "materials",
        "radiance",
        "srdm",
        "eval",
        "view",
    ];
    let offences = naming("scene", &above_scene);
    assert!(
        offences.is_empty(),
        "src/scene imports a stage:\n{}",
        offences.join("\n")
    );
    let mut all = above_scene.to_vec();
    all.extend(["scene", "camera", "geometry", "brdf", "bundle", "cli"]);
    let offences = naming("settings", &all);
    assert!(
        offences.is_empty(),
        "src/settings imports glint modules:\n{}",
        offences.join("\n")
    );
    let offences = naming("camera", &all);
    assert!(
        offences.is_empty(),
        "src/camera.rs imports glint modules:\n{}",
        offences.join("\n")
    );
}
