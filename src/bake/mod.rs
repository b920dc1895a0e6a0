//! Bake stages: what a scene requires, the stages that write into a bundle, and the tools' command
//! lines over them (`tool`, `unit_tool`, and `bundle_tool` for `glint-bundle`).

pub mod build_script;
pub mod bundle_tool;
pub mod incremental;
pub mod materials;
pub mod merge;
pub mod part;
pub mod plan;
pub mod radiance_stage;
pub mod radiosity_stage;
pub mod read_cache;
pub mod report;
pub mod run;
pub mod scene_stage;
pub mod shard;
pub mod srdm_stage;
pub mod tool;
pub mod unit_tool;
pub mod units;
mod wave;
pub mod written;

use std::path::Path;

pub use plan::{Stage, StagePlan, plan};
pub use run::{BakeError, BakeSettings, StageReport, StageStatus, bake_all};

use crate::bundle::Bundle;
use crate::scene::Scene;

/// Whether the bundle at `dir` already holds `stage` baked from this scene by this glint,
/// with `settings` (when given), every asset intact.
pub fn up_to_date(
    dir: &Path,
    scene: &Scene,
    stage: Stage,
    settings: Option<&serde_json::Value>,
) -> bool {
    let Ok(bundle) = Bundle::open(dir) else {
        return false;
    };
    let Some(rec) = bundle.stage(stage.name()) else {
        return false;
    };
    rec.scene_hash == scene.content_hash
        && rec.generator == crate::bundle::manifest::generator()
        && settings.is_none_or(|s| *s == rec.settings)
        && rec.assets.iter().all(|a| bundle.verify_asset(a).is_ok())
}
