//! `schemas/*.schema.json` are generated from the Rust types; this test keeps them current.
//! After changing the types, regenerate deliberately with
//! `GLINT_UPDATE_GOLDENS=1 cargo test --test schemas` (the one golden-update switch,
//! [`common::UPDATE_GOLDENS`]).

mod common;

use common::{repo, update_goldens};

use glint::bundle::Manifest;
use glint::scene::SceneDesc;

fn check(file: &str, schema: schemars::Schema) {
    let path = repo("schemas").join(file);
    let text = serde_json::to_string_pretty(&schema).unwrap() + "\n";
    if update_goldens() {
        std::fs::write(&path, &text).unwrap();
        return;
    }
    let current = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        current == text,
        "{} is out of date with the Rust types; run GLINT_UPDATE_GOLDENS=1 cargo test --test schemas",
        path.display()
    );
}

#[test]
fn scene_schema_is_current() {
    check("scene.schema.json", schemars::schema_for!(SceneDesc));
}

#[test]
fn manifest_schema_is_current() {
    check("manifest.schema.json", schemars::schema_for!(Manifest));
}

#[test]
fn scene_schema_requires_version_and_forbids_unknown_fields() {
    let v = serde_json::to_value(schemars::schema_for!(SceneDesc)).unwrap();
    let required: Vec<&str> = v["required"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r.as_str().unwrap())
        .collect();
    assert!(
        required.contains(&"version") && required.contains(&"geometry"),
        "{required:?}"
    );
    assert_eq!(v["additionalProperties"], false);
}
