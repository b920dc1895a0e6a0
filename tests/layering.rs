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
