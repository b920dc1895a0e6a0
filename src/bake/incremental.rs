//! The plain `glint-bake SCENE --bundle B`, incremental by content: the scene's work units
//! ([`super::units`]) are kept as shards in a cache beside the bundle (`B.units/`, see
//! [`cache_dir`]); a unit is rebaked only when its key changed (its named inputs, or a unit it
//! reads), and the bundle is then assembled from the shards ([`super::merge`]), which gives
//! the same bytes as a bake from scratch. Nothing changed: nothing is written.
//!
//! The gathering units are not run: the `radiosity` unit gathers every element itself (the
//! same D), as a bake stage by stage does, without writing each ray's hit to disk.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::merge::{MergeOptions, merge_keeping};
use super::shard::shard_path;
use super::shard::{Checked, MARKER, Marker, bake_unit_gathering, parse_marker};
use super::units::{GATHER, Unit, UnitPlan, kind, plan_units};
use super::{BakeSettings, Stage, StageReport, StageStatus};
use crate::bundle::{Bundle, SceneCommit, StageWriter, write_atomic};
use crate::progress::Progress;
use crate::scene::Scene;

/// The file in the cache naming the plan and stages the bundle was last assembled from.
const ASSEMBLED: &str = "assembled.json";

/// The shard cache of the bundle at `bundle`: `NAME.units` beside it (`out/room.glint` →
/// `out/room.glint.units`).
pub fn cache_dir(bundle: &Path) -> PathBuf {
    let bundle = std::path::absolute(bundle).unwrap_or_else(|_| bundle.to_owned());
    let mut name = bundle
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_else(|| "bundle".into());
    name.push(".units");
    bundle.with_file_name(name)
}

/// What happened to one work unit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct UnitOutcome {
    /// The unit's ID.
    pub unit: String,
    /// Its stage (`gather` for gathering units).
    pub stage: String,
    /// Baked now, or kept (up to date).
    pub baked: bool,
    /// Why it was baked: which inputs changed, which units it reads were rebaked, or that
    /// the cache held no earlier bake of it. Empty when kept.
    #[serde(skip_serializing_if = "String::is_empty")]
    pub why: String,
    /// Wall-clock seconds (0 when kept).
    pub seconds: f64,
}

/// What [`bake_incremental`] did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Incremental {
    /// Per stage, as a whole bake reports it.
    pub stages: Vec<StageReport>,
    /// Per unit, in plan order, less the gathering units (the `radiosity` unit gathers).
    pub units: Vec<UnitOutcome>,
    /// Whether the bundle was (re)assembled; false when it already held this plan's bake.
    pub assembled: bool,
    /// Fields of scene.json that differ from the last bake's (`materials.Floor.albedo`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub scene_changes: Vec<String>,
}

impl Incremental {
    /// The units baked now.
    pub fn baked(&self) -> impl Iterator<Item = &UnitOutcome> {
        self.units.iter().filter(|u| u.baked)
    }
}

/// `assembled.json`: the plan the bundle was last assembled from, and its stages' identities.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Assembled {
    plan_hash: String,
    stages: BTreeMap<String, String>,
}

/// Bakes `scene` into the bundle at `bundle`, rebaking only the work units whose inputs
/// changed since the last bake into it (see the module doc). A bundle of another scene (by
/// name) is refused unless `force`; an earlier version of this scene is replaced.
pub fn bake_incremental(
    scene: &Scene,
    bundle: &Path,
    settings: &BakeSettings,
    force: bool,
    progress: &dyn Progress,
) -> anyhow::Result<Incremental> {
    SceneCommit::check(bundle, &scene.name, &scene.content_hash, force)?;
    // Fail before the compute when the bundle cannot be written (its lock, its folder).
    drop(StageWriter::begin(bundle, Stage::Scene.name())?);
    let units = plan_units(scene, settings).map_err(anyhow::Error::msg)?;
    let plan = &units;
    let cache = cache_dir(bundle);
    crate::out_dir::create_dir_all(&cache)
        .map_err(|e| anyhow::anyhow!("{}: {e}", cache.display()))?;

    let scene_changes = scene_changes(&cache, scene);
    if !scene_changes.is_empty() {
        log::info!(
            "{}: scene.json changed: {}",
            scene.name,
            scene_changes.join(", ")
        );
    }
    // The marker alone says whether to log a rebake; `bake_unit` checks the assets too.
    let fresh = |u: &Unit| {
        old_marker(&shard_path(&cache, &u.id)).is_some_and(|m| m.unit == u.id && m.key == u.key)
    };
    // Each shard's files are hashed once a run: by its unit, or as it is written.
    let checked = Checked::default();
    let mut outcomes: Vec<UnitOutcome> = Vec::new();
    let mut rebaked: BTreeSet<String> = BTreeSet::new();
    let last = plan.units.iter().map(|u| u.wave).max().unwrap_or(0);
    for wave in 0..=last {
        let todo: Vec<&Unit> = plan
            .units
            .iter()
            .filter(|u| u.wave == wave && kind(&u.id) != GATHER)
            .collect();
        // The units of a wave read only earlier waves' (their `why` reads `rebaked` of those).
        let whys: Vec<String> = todo
            .iter()
            .map(|u| {
                if fresh(u) {
                    String::new()
                } else {
                    why_rebake(&shard_path(&cache, &u.id), u, &rebaked, &scene_changes)
                }
            })
            .collect();
        let costs: Vec<f64> = todo.iter().map(|u| u.cost).collect();
        let ran = super::wave::run_wave(
            &costs,
            super::wave::units_at_once(),
            progress,
            |k, progress| {
                let (u, why) = (todo[k], &whys[k]);
                if !why.is_empty() {
                    log::info!("{}: rebaking unit {} ({why})", u.stage, u.id);
                }
                let shard = shard_path(&cache, &u.id);
                bake_unit_gathering(
                    scene, settings, plan, &u.id, &shard, None, true, &checked, progress,
                )
            },
        );
        for ((u, why), r) in todo.into_iter().zip(whys).zip(ran) {
            let r = r?;
            let seconds = match r.status {
                StageStatus::Baked { seconds } => seconds,
                _ => 0.0,
            };
            let baked = matches!(r.status, StageStatus::Baked { .. });
            if baked {
                rebaked.insert(u.id.clone());
            }
            outcomes.push(UnitOutcome {
                unit: u.id.clone(),
                stage: u.stage.clone(),
                baked,
                why: match (baked, why.is_empty()) {
                    (false, _) => String::new(),
                    (true, true) => "its shard is damaged".into(),
                    (true, false) => why,
                },
                seconds,
            });
        }
    }

    let assembled = if rebaked.is_empty() && assembled_matches(bundle, &cache, plan) {
        false
    } else {
        progress.phase("assembling the bundle", 1);
        let shards: Vec<PathBuf> = plan
            .units
            .iter()
            .filter(|u| kind(&u.id) != GATHER)
            .map(|u| shard_path(&cache, &u.id))
            .collect();
        merge_keeping(
            bundle,
            &shards,
            MergeOptions {
                force,
                ..Default::default()
            },
            &checked,
        )?;
        record_assembled(bundle, &cache, plan)?;
        progress.advance(1);
        true
    };

    let stages = super::plan(scene)
        .into_iter()
        .map(|p| {
            let status = if !p.needed {
                StageStatus::Skipped {
                    reason: p.reason.clone(),
                }
            } else {
                let of_stage: Vec<&UnitOutcome> = outcomes
                    .iter()
                    .filter(|o| o.stage == p.stage.name())
                    .collect();
                if of_stage.iter().any(|o| o.baked) {
                    StageStatus::Baked {
                        seconds: of_stage.iter().map(|o| o.seconds).sum(),
                    }
                } else {
                    StageStatus::UpToDate
                }
            };
            StageReport { plan: p, status }
        })
        .collect();
    Ok(Incremental {
        stages,
        units: outcomes,
        assembled,
        scene_changes,
    })
}

/// Why unit `u`, whose shard at `shard` does not hold its key, is baked: the inputs that
/// differ from the shard's last bake (each with the fields of `scene_changes` it reads), and
/// the units it reads that were rebaked.
fn why_rebake(
    shard: &Path,
    u: &Unit,
    rebaked: &BTreeSet<String>,
    scene_changes: &[String],
) -> String {
    let Some(old) = old_marker(shard).filter(|m| m.unit == u.id) else {
        return "no earlier bake in the cache".into();
    };
    let mut parts = Vec::new();
    if let Some(before) = old.plan.unit(&u.id) {
        let changed: Vec<&str> = u
            .inputs
            .iter()
            .filter(|(k, v)| before.inputs.get(*k) != Some(v))
            .map(|(k, _)| k.as_str())
            .chain(
                before
                    .inputs
                    .keys()
                    .filter(|k| !u.inputs.contains_key(*k))
                    .map(String::as_str),
            )
            .collect();
        for input in changed {
            let fields: Vec<&str> = scene_changes
                .iter()
                .filter(|c| touches(input, u, c))
                .map(String::as_str)
                .collect();
            parts.push(if fields.is_empty() {
                format!("{input} changed")
            } else {
                format!("{input} changed: {}", fields.join(", "))
            });
        }
    }
    let reads: Vec<&str> = u
        .depends_on
        .iter()
        .filter(|d| rebaked.contains(*d) && kind(d) != GATHER)
        .map(String::as_str)
        .collect();
    if !reads.is_empty() {
        parts.push(format!("reads {}, rebaked", reads.join(", ")));
    }
    if parts.is_empty() {
        // Same inputs, but the shard is damaged or incomplete.
        parts.push("its shard is incomplete or damaged".into());
    }
    parts.join("; ")
}

/// The marker of the shard at `shard`, unchecked against its assets.
fn old_marker(shard: &Path) -> Option<Marker> {
    let text = crate::bundle::read_top_file(shard, MARKER).ok().flatten()?;
    parse_marker(shard, text.as_bytes()).ok()
}

/// Whether the changed scene.json field `change` (`materials.Floor.albedo`) is part of unit
/// `u`'s `input`.
fn touches(input: &str, u: &Unit, change: &str) -> bool {
    let under = |prefix: &str| {
        change == prefix
            || change.starts_with(&format!("{prefix}."))
            || change.starts_with(&format!("{prefix}["))
            || change.starts_with(&format!("{prefix} "))
    };
    match input {
        "scene_files" => true,
        "materials" => under("materials"),
        "material" => u
            .item
            .as_ref()
            .is_some_and(|m| under(&format!("materials.{m}"))),
        "lights" => under("lights"),
        "reflectors" | "reflector" => under("reflectors"),
        "impostor" => under("impostors"),
        "probe" => under("probes") || under("materials"),
        "first_camera" => under("camera_paths"),
        "settings" => under("bake") || under("reflectors"),
        // A mirror's map resolution follows the camera paths' looks into it.
        "plan" => under("bake") || under("reflectors") || under("camera_paths"),
        _ => false,
    }
}

/// The identities of the bundle's stages, when it holds this scene's bake (`verify`: with
/// every asset intact).
fn bundle_stages(bundle: &Path, plan: &UnitPlan, verify: bool) -> Option<BTreeMap<String, String>> {
    let b = Bundle::open(bundle).ok()?;
    let m = b.manifest();
    let ours = m.scene_name == plan.scene_name
        && m.stages.values().all(|r| r.scene_hash == plan.scene_hash);
    (ours && (!verify || b.verify().is_empty())).then(|| {
        m.stages
            .iter()
            .map(|(name, r)| (name.clone(), r.identity()))
            .collect()
    })
}

/// Whether the bundle still holds what the last assembly of this plan wrote.
fn assembled_matches(bundle: &Path, cache: &Path, plan: &UnitPlan) -> bool {
    let Ok(text) = std::fs::read(cache.join(ASSEMBLED)) else {
        return false;
    };
    let Ok(a) = serde_json::from_slice::<Assembled>(&text) else {
        return false;
    };
    a.plan_hash == plan.plan_hash && bundle_stages(bundle, plan, true).as_ref() == Some(&a.stages)
}

fn record_assembled(bundle: &Path, cache: &Path, plan: &UnitPlan) -> anyhow::Result<()> {
    // Just written from verified shards: read back without hashing every asset again.
    let Some(stages) = bundle_stages(bundle, plan, false) else {
        anyhow::bail!(
            "{}: the assembled bundle holds another scene",
            bundle.display()
        );
    };
    let a = Assembled {
        plan_hash: plan.plan_hash.clone(),
        stages,
    };
    write_atomic(
        &cache.join(ASSEMBLED),
        serde_json::to_string_pretty(&a)?.as_bytes(),
    )?;
    Ok(())
}

/// The fields of scene.json that differ from the scene the cache's `scene` shard was baked
/// from; empty when there is none.
fn scene_changes(cache: &Path, scene: &Scene) -> Vec<String> {
    let old = Bundle::open(shard_path(cache, "scene"))
        .ok()
        .and_then(|b| b.read_stage_file(Stage::Scene.name(), "scene.json").ok())
        .and_then(|t| serde_json::from_slice::<serde_json::Value>(&t).ok());
    let desc = super::scene_stage::stored_desc(scene);
    // Through text, as stored: a value's own f32 digits, not its f64 widening.
    let new = serde_json::to_string(&desc)
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok());
    let (Some(old), Some(new)) = (old, new) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    json_diff("", &old, &new, &mut out);
    out
}

/// The paths (`a.b[2].c`) at which `old` and `new` differ: object keys, and the elements of
/// equal-length arrays of objects or arrays (a changed colour or position is named whole).
fn json_diff(at: &str, old: &serde_json::Value, new: &serde_json::Value, out: &mut Vec<String>) {
    use serde_json::Value;
    let join = |k: &str| {
        if at.is_empty() {
            k.to_string()
        } else {
            format!("{at}.{k}")
        }
    };
    match (old, new) {
        (Value::Object(a), Value::Object(b)) => {
            for k in a.keys().chain(b.keys().filter(|k| !a.contains_key(*k))) {
                match (a.get(k), b.get(k)) {
                    (Some(x), Some(y)) => json_diff(&join(k), x, y, out),
                    (Some(_), None) => out.push(format!("{} removed", join(k))),
                    (None, _) => out.push(format!("{} added", join(k))),
                }
            }
        }
        (Value::Array(a), Value::Array(b))
            if a.len() == b.len() && a.iter().any(|v| v.is_object() || v.is_array()) =>
        {
            for (i, (x, y)) in a.iter().zip(b).enumerate() {
                json_diff(&format!("{at}[{i}]"), x, y, out);
            }
        }
        (a, b) if a != b => out.push(if at.is_empty() {
            "(root)".into()
        } else {
            at.into()
        }),
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_diff_names_each_changed_field() {
        let old = serde_json::json!({"materials": {"Floor": {"albedo": [0.4, 0.4, 0.4]}},
            "camera_paths": [{"fps": 30}], "lights": [1]});
        let new = serde_json::json!({"materials": {"Floor": {"albedo": [0.5, 0.4, 0.4]}},
            "camera_paths": [{"fps": 24}], "lights": [1, 2], "impostors": []});
        let mut out = Vec::new();
        json_diff("", &old, &new, &mut out);
        assert_eq!(
            out,
            [
                "materials.Floor.albedo",
                "camera_paths[0].fps",
                "lights",
                "impostors added"
            ]
        );
    }

    #[test]
    fn a_changed_input_is_named_with_the_fields_it_reads() {
        let unit = |item: Option<&str>| Unit {
            id: "material.Floor".into(),
            stage: "materials".into(),
            item: item.map(String::from),
            inputs: BTreeMap::new(),
            depends_on: Vec::new(),
            key: String::new(),
            cost: 0.0,
            wave: 0,
        };
        let u = unit(Some("Floor"));
        assert!(touches("material", &u, "materials.Floor.albedo"));
        assert!(!touches("material", &u, "materials.FloorTile.albedo"));
        assert!(touches("materials", &u, "materials.FloorTile.albedo"));
        assert!(touches("lights", &u, "lights[0].radiance"));
        assert!(touches("reflectors", &u, "reflectors"));
        assert!(!touches("lights", &u, "camera_paths[0].fps"));
        assert!(touches("scene_files", &u, "camera_paths[0].fps"));
        assert!(touches("plan", &u, "camera_paths[0].keyframes"));
        assert!(!touches("settings", &u, "camera_paths[0].keyframes"));
    }

    #[test]
    fn the_cache_lies_beside_the_bundle() {
        let c = cache_dir(Path::new("/x/out/room.glint/"));
        assert_eq!(c, Path::new("/x/out/room.glint.units"));
    }
}
