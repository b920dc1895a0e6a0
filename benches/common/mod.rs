//! Helpers the viewer benchmarks share: the tests' scaffolding (`tests/common/scaffold.rs`:
//! paths, the adapter), draft bundles baked when missing or stale, medians and 8-bit image
//! differences.

#![allow(dead_code)]

#[path = "../../tests/common/scaffold.rs"]
mod scaffold;

pub use scaffold::{gpu, repo};

use std::path::{Path, PathBuf};
use std::time::Instant;

use glint::bake::{
    BakeSettings, Stage, StageStatus, bake_all, materials, radiosity_stage, scene_stage, up_to_date,
};
use glint::progress::Silent;
use glint::scene::desc::RadiositySettings;
use glint::scene::{Quality, Scene};

/// The median of `v` (sorted in place; the upper one of an even count).
pub fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// An RGBA8 frame of `width` pixels per row box-filtered 2×2 (the path tracer's noise).
pub fn half_size(rgba: &[u8], width: u32, height: u32) -> Vec<u8> {
    let (w, hw, hh) = (width as usize, width as usize / 2, height as usize / 2);
    let mut out = Vec::with_capacity(hw * hh * 4);
    for y in 0..hh {
        for x in 0..hw {
            for k in 0..4 {
                let at =
                    |dx: usize, dy: usize| u32::from(rgba[((2 * y + dy) * w + 2 * x + dx) * 4 + k]);
                out.push(((at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1) + 2) / 4) as u8);
            }
        }
    }
    out
}

/// Mean absolute difference over RGB of two RGBA8 images, 8-bit units.
pub fn mean_diff(a: &[u8], b: &[u8]) -> f64 {
    let (mut sum, mut n) = (0u64, 0u64);
    for (pa, pb) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
        for k in 0..3 {
            sum += u64::from(pa[k].abs_diff(pb[k]));
            n += 1;
        }
    }
    sum as f64 / n.max(1) as f64
}

/// The scene's bundle in `work` with the scene and draft radiosity stages (and the draft
/// materials stage when `with_materials`), each baked unless up to date.
pub fn bake_if_needed(scene_json: &Path, work: &Path, name: &str, with_materials: bool) -> PathBuf {
    bake_at(scene_json, work, name, with_materials, Quality::Draft)
}

/// The bundle of `name` at `quality` under `work`: `NAME.glint` at draft, `NAME-QUALITY.glint`
/// otherwise.
fn bundle_path(work: &Path, name: &str, quality: Quality) -> PathBuf {
    match quality {
        Quality::Draft => work.join(format!("{name}.glint")),
        q => work.join(format!("{name}-{}.glint", q.name())),
    }
}

/// As [`bake_if_needed`] at the preset `quality`: the bundle is `NAME.glint` at draft and
/// `NAME-QUALITY.glint` otherwise.
pub fn bake_at(
    scene_json: &Path,
    work: &Path,
    name: &str,
    with_materials: bool,
    quality: Quality,
) -> PathBuf {
    let bundle = bundle_path(work, name, quality);
    let scene = Scene::load(scene_json).unwrap_or_else(|e| panic!("{e}"));
    let settings =
        RadiositySettings::resolve(quality, &[&scene.desc.bake.radiosity], None).unwrap();
    let settings_json = radiosity_stage::settings_json(&settings);
    if !up_to_date(&bundle, &scene, Stage::Scene, None) {
        scene_stage::bake(&scene, &bundle, true).unwrap_or_else(|e| panic!("{e}"));
    }
    if !up_to_date(&bundle, &scene, Stage::Radiosity, Some(&settings_json)) {
        let start = Instant::now();
        radiosity_stage::bake(&scene, &bundle, &settings, true, &Silent)
            .unwrap_or_else(|e| panic!("{e}"));
        eprintln!(
            "baked {name} ({}) in {:.1} s",
            quality.name(),
            start.elapsed().as_secs_f64()
        );
    }
    let settings = materials::MaterialsSettings::preset(quality);
    // The settings the stage records (D's identity and how env maps are captured included),
    // so a re-baked D or a new capture re-bakes it.
    let recorded = materials::recorded_settings(
        &settings,
        glint::radiosity::d_identity(&bundle, &scene.content_hash).as_deref(),
    );
    if with_materials && !up_to_date(&bundle, &scene, Stage::Materials, Some(&recorded)) {
        materials::bake(&scene, &bundle, &settings, true, &Silent)
            .unwrap_or_else(|e| panic!("{e}"));
    }
    bundle
}

/// Every stage `scene_json` requires, baked at `quality` into [`bake_at`]'s bundle by
/// [`bake_all`], as `glint-bake` does: the scene's overrides apply, and a stage is re-baked
/// when its recorded settings (plans and D's identity included) differ from what it would
/// record now, so a bench never measures maps planned by an older build.
pub fn bake_all_at(scene_json: &Path, work: &Path, name: &str, quality: Quality) -> PathBuf {
    let bundle = bundle_path(work, name, quality);
    let scene = Scene::load(scene_json).unwrap_or_else(|e| panic!("{e}"));
    let settings = BakeSettings::resolve(&scene, quality).unwrap_or_else(|e| panic!("{e}"));
    let start = Instant::now();
    let report =
        bake_all(&scene, &bundle, &settings, true, &Silent).unwrap_or_else(|e| panic!("{e}"));
    let baked: Vec<&str> = report
        .iter()
        .filter(|r| matches!(r.status, StageStatus::Baked { .. }))
        .map(|r| r.plan.stage.name())
        .collect();
    if !baked.is_empty() {
        eprintln!(
            "baked {name} ({}: {}) in {:.1} s",
            quality.name(),
            baked.join(", "),
            start.elapsed().as_secs_f64()
        );
    }
    bundle
}
