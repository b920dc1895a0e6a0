//! The bake stages' settings, each defined once: per stage an override struct (serde for
//! scene.json's `bake.STAGE`, `clap::Args` for the tool's flags, schemars for the schema; every
//! field an `Option` with one doc comment) and the resolved settings the stage runs with and
//! records in the manifest, made by that stage's one `resolve(quality, overrides)`, which
//! checks every value in one place.
//!
//! Layering of the top-level modules, lowest first; each imports only modules listed before
//! it (`.ci/import-loops.py` checks that no two import each other, directly or round a loop):
//! 1. `settings`, `camera`, `colour`, `sampling`, `geometry`, `progress`, `bundle`, then `brdf`,
//!    `image_io` and `cli`: no scene and no stage;
//! 2. `scene`: scene.json and glTF; it holds the stages' overrides but imports no stage;
//! 3. the stages `radiosity`, `radiance`, then `materials` and `srdm` (which read D);
//! 4. `bake`: runs the stages, and the tools' command lines;
//! 5. `eval`, `view` and `fuzz`; the binaries in `bin/` over everything.
//!
//! The settings live here, not in their stages' modules, because scene.json holds the
//! overrides and the scene layer imports no stage; each stage re-exports its own.

pub mod materials;
pub mod radiance;
pub mod radiosity;
pub mod srdm;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Quality preset: the speed-for-accuracy point of every stage.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Quality {
    /// Fast previews.
    Draft,
    /// Everyday bakes.
    #[default]
    Default,
    /// Final bakes.
    High,
}

impl Quality {
    /// All presets, fastest first.
    pub const ALL: [Quality; 3] = [Quality::Draft, Quality::Default, Quality::High];

    /// The preset's name as written in scene.json and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Quality::Draft => "draft",
            Quality::Default => "default",
            Quality::High => "high",
        }
    }
}

/// A setting outside its range: the field, as named in the stage's settings (`texel_density`),
/// and what was expected. Callers say where the value came from: scene.json's
/// `bake.radiosity.texel_density`, a flag `--texel-density`, or a sweep's knob.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("`{field}`: {message}")]
pub struct SettingError {
    /// The field.
    pub field: &'static str,
    /// The value and what was expected.
    pub message: String,
}

impl SettingError {
    /// An error for `field`.
    pub fn new(field: &'static str, message: impl Into<String>) -> SettingError {
        SettingError {
            field,
            message: message.into(),
        }
    }

    /// The field as a command-line flag: `--texel-density`.
    pub fn flag(&self) -> String {
        format!("--{}", self.field.replace('_', "-"))
    }
}

/// Whether `over` (an override struct, whose unset fields serialize to nothing) sets `field`:
/// tells a flag's bad value from the scene's.
pub fn sets<T: Serialize>(over: &T, field: &str) -> bool {
    serde_json::to_value(over)
        .ok()
        .is_some_and(|v| v.get(field).is_some())
}

/// The field names of a settings struct as scene.json, the manifest and sweeps write them, in
/// declaration order: read from its schema, so that a list of knobs is never written by hand.
pub fn field_names<T: JsonSchema>() -> Vec<String> {
    let schema = schemars::schema_for!(T);
    schema
        .get("properties")
        .and_then(|p| p.as_object())
        .map(|p| p.keys().cloned().collect())
        .unwrap_or_default()
}

/// Checks that a count is in `lo ..= hi`; the error says why the bound is where it is.
pub(crate) fn check_count(
    field: &'static str,
    v: u64,
    lo: u64,
    hi: u64,
    why: &str,
) -> Result<(), SettingError> {
    if v < lo {
        return Err(SettingError::new(field, format!("{v} is not ≥ {lo}")));
    }
    if v > hi {
        return Err(SettingError::new(
            field,
            format!("{v} is more than {hi} ({why})"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_name_the_bound_and_its_reason() {
        assert!(check_count("rays", 5, 1, 10, "why").is_ok());
        let e = check_count("rays", 0, 1, 10, "why").unwrap_err();
        assert_eq!((e.field, e.message.as_str()), ("rays", "0 is not ≥ 1"));
        let e = check_count("rays", 11, 1, 10, "too slow").unwrap_err();
        assert_eq!(e.message, "11 is more than 10 (too slow)");
    }
}
