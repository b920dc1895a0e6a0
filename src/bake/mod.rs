//! Bake stages: what a scene requires, and the stages that write into a bundle.

pub mod plan;
pub mod scene_stage;

pub use plan::{Stage, StagePlan, plan};
