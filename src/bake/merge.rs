//! `glint-bundle merge OUT SHARD…`: assembles the shards of a plan's work units
//! ([`super::units`], [`super::shard`]) into one bundle, after checking that every unit of
//! the plan is there exactly once, complete and intact, baked for this plan, and that every
//! unit that read D read the D assembled. The result holds the same assets, byte for byte,
//! as a whole bake (`glint-bake`) of the same scene and settings.
//!
//! Each stage is assembled from its units' shards in plan order (the order a whole bake
//! writes its items), with the index files that list a stage's items (`materials/index.json`,
//! `srdm/index.json`) joined from the units' own and written last, as a whole bake does;
//! settings come from the plan with `d_source` set to the D assembled.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::Stage;
use super::shard::{Marker, ShardError, read_shard};
use super::units::{UnitPlan, kind};
use crate::bundle::{Bundle, StageInfo, StageWriter};
use crate::materials::index::MaterialsIndex;
use crate::srdm::index::SrdmIndex;

/// Why shards cannot be merged: every problem found, each naming its shard or unit.
#[derive(Debug, thiserror::Error)]
#[error("cannot merge: {}", problems.join("; "))]
pub struct MergeError {
    /// One line per problem.
    pub problems: Vec<String>,
}

impl MergeError {
    fn one(problem: impl Into<String>) -> MergeError {
        MergeError {
            problems: vec![problem.into()],
        }
    }
}

/// What a merge assembled.
#[derive(Clone, Debug, Serialize)]
pub struct MergeReport {
    /// The bundle written.
    #[serde(serialize_with = "crate::lossy_path::serialize")]
    pub bundle: PathBuf,
    /// The scene.
    pub scene: String,
    /// Units assembled.
    pub units: usize,
    /// Stages written, in order.
    pub stages: Vec<String>,
    /// Assets written.
    pub assets: usize,
}

/// Checks `shards` and assembles them into the bundle at `out` (new, empty, or a bundle:
/// its stages are replaced).
pub fn merge(out: &Path, shards: &[PathBuf]) -> Result<MergeReport, MergeError> {
    if shards.is_empty() {
        return Err(MergeError::one("no shards given"));
    }
    let mut problems = Vec::new();
    let mut read: Vec<(PathBuf, Marker, Bundle)> = Vec::new();
    for s in shards {
        match read_shard(s) {
            Ok((m, b)) => read.push((s.clone(), m, b)),
            Err(e @ (ShardError::Incomplete { .. } | ShardError::Invalid { .. })) => {
                problems.push(e.to_string())
            }
        }
    }
    let Some((first_path, first, _)) = read.first() else {
        return Err(MergeError { problems });
    };
    let plan: UnitPlan = first.plan.clone();
    let mut by_unit: BTreeMap<&str, usize> = BTreeMap::new();
    for (i, (path, m, _)) in read.iter().enumerate() {
        if m.plan.plan_hash != plan.plan_hash {
            problems.push(format!(
                "{}: unit `{}` belongs to another plan ({:.12}…) than {} ({:.12}…): the scene or settings changed; rerun the unit",
                path.display(), m.unit, m.plan.plan_hash, first_path.display(), plan.plan_hash
            ));
            continue;
        }
        match plan.unit(&m.unit) {
            None => problems.push(format!(
                "{}: unit `{}` is not in the plan",
                path.display(),
                m.unit
            )),
            Some(u) if u.key != m.key => problems.push(format!(
                "{}: unit `{}` was baked from other inputs (key {:.12}…, the plan's {:.12}…): rerun it",
                path.display(), m.unit, m.key, u.key
            )),
            Some(_) => {
                if let Some(j) = by_unit.insert(&m.unit, i) {
                    problems.push(format!(
                        "unit `{}` is in two shards: {} and {}",
                        m.unit,
                        read[j].0.display(),
                        path.display()
                    ));
                }
            }
        }
    }
    let missing: Vec<&str> = plan
        .units
        .iter()
        .map(|u| u.id.as_str())
        .filter(|id| !by_unit.contains_key(id))
        .collect();
    if !missing.is_empty() {
        problems.push(format!(
            "{} unit(s) of the plan have no complete shard: {}",
            missing.len(),
            missing.join(", ")
        ));
    }
    // D as assembled: what every unit that read D must have read.
    let d = by_unit
        .get("radiosity")
        .and_then(|&i| read[i].2.stage(Stage::Radiosity.name()))
        .map(|r| r.identity());
    for (path, m, _) in &read {
        if let Some(r) = &m.read_d
            && d.as_deref() != Some(r.as_str())
        {
            problems.push(format!(
                "{}: unit `{}` read D {:.12}…, but the radiosity shard holds {}: rerun the unit",
                path.display(),
                m.unit,
                r,
                d.as_deref().map_or("none".into(), |d| format!("{d:.12}…"))
            ));
        }
    }
    if !problems.is_empty() {
        return Err(MergeError { problems });
    }

    let fail = |e: &dyn std::fmt::Display| MergeError::one(format!("{}: {e}", out.display()));
    crate::bundle::check_folder(out).map_err(|e| fail(&e))?;
    let mut report = MergeReport {
        bundle: out.to_owned(),
        scene: plan.scene_name.clone(),
        units: plan.units.len(),
        stages: Vec::new(),
        assets: 0,
    };
    for stage in Stage::ALL {
        let name = stage.name();
        let units: Vec<(&str, &Bundle)> = plan
            .units
            .iter()
            .filter(|u| u.stage == name)
            .map(|u| (u.id.as_str(), &read[by_unit[u.id.as_str()]].2))
            .collect();
        if units.is_empty() {
            continue;
        }
        let mut settings = plan.stages.get(name).cloned().unwrap_or_default();
        if let (Some(d), Some(obj)) = (&d, settings.as_object_mut())
            && obj.contains_key("d_source")
        {
            obj.insert("d_source".into(), d.clone().into());
        }
        report.assets += assemble(out, &plan, stage, &units, settings)?;
        report.stages.push(name.into());
    }
    Ok(report)
}

/// Writes stage `stage` of `out` from its units' shards; returns the assets written.
fn assemble(
    out: &Path,
    plan: &UnitPlan,
    stage: Stage,
    units: &[(&str, &Bundle)],
    settings: serde_json::Value,
) -> Result<usize, MergeError> {
    let name = stage.name();
    let err = |e: &dyn std::fmt::Display| MergeError::one(format!("stage `{name}`: {e}"));
    let index_path = format!("{name}/index.json");
    let joins_index = matches!(stage, Stage::Materials | Stage::Srdm);
    let mut w = StageWriter::begin(out, name).map_err(|e| err(&e))?;
    let mut indexes = Vec::new();
    let mut stats = Vec::new();
    let mut seconds = 0.0;
    for (id, shard) in units {
        let record = shard.stage(name).expect("checked by read_shard");
        for a in &record.assets {
            let bytes = shard.read_asset(a).map_err(|e| err(&e))?;
            if joins_index && a.path == index_path {
                indexes.push((*id, bytes));
                continue;
            }
            let rel = a.path.strip_prefix(&format!("{name}/")).unwrap_or(&a.path);
            w.write(rel, &a.kind, &bytes).map_err(|e| err(&e))?;
        }
        stats.push((*id, record.stats.clone()));
        seconds += record.bake_seconds;
    }
    if joins_index {
        let bytes = match stage {
            Stage::Srdm => join_srdm(&indexes)?,
            _ => join_materials(&indexes)?,
        };
        w.write("index.json", kind_of_index(stage), &bytes)
            .map_err(|e| err(&e))?;
    }
    let n = w.assets().len();
    w.commit(StageInfo {
        scene_name: plan.scene_name.clone(),
        scene_hash: plan.scene_hash.clone(),
        settings,
        stats: merge_stats(stage, &stats),
        bake_seconds: seconds,
        force: true,
    })
    .map_err(|e| err(&e))?;
    Ok(n)
}

fn kind_of_index(stage: Stage) -> &'static str {
    match stage {
        Stage::Srdm => "srdm-index",
        _ => "materials-index",
    }
}

/// `srdm/index.json` of every impostor: the units' views, in order.
fn join_srdm(parts: &[(&str, Vec<u8>)]) -> Result<Vec<u8>, MergeError> {
    let mut joined: Option<SrdmIndex> = None;
    for (id, bytes) in parts {
        let index: SrdmIndex = serde_json::from_slice(bytes)
            .map_err(|e| MergeError::one(format!("unit `{id}`: srdm/index.json: {e}")))?;
        match &mut joined {
            None => joined = Some(index),
            Some(j) => j.views.extend(index.views),
        }
    }
    let index = joined.ok_or_else(|| MergeError::one("no srdm/index.json in the srdm units"))?;
    Ok(serde_json::to_string_pretty(&index)
        .expect("index serializes")
        .into_bytes())
}

/// `materials/index.json` of every material and environment map. Without environment-map
/// units, the reason the material units give for their absence is kept.
fn join_materials(parts: &[(&str, Vec<u8>)]) -> Result<Vec<u8>, MergeError> {
    let mut joined: Option<MaterialsIndex> = None;
    let mut env_units = false;
    for (id, bytes) in parts {
        let index = MaterialsIndex::parse(bytes)
            .map_err(|e| MergeError::one(format!("unit `{id}`: {e}")))?;
        env_units |= kind(id) == "envmap";
        match &mut joined {
            None => joined = Some(index),
            Some(j) => {
                j.materials.extend(index.materials);
                j.env_maps.extend(index.env_maps);
            }
        }
    }
    let mut index =
        joined.ok_or_else(|| MergeError::one("no materials/index.json in the materials units"))?;
    if env_units {
        index.env_maps_skipped = None;
    }
    Ok(index.to_bytes())
}

/// The stage's figures from its units': counts and bytes summed, per-item lists joined,
/// maxima kept, means weighted by the units' view counts (SRDM); anything else as the
/// first unit has it. Timings are the units' own.
fn merge_stats(
    stage: Stage,
    units: &[(&str, BTreeMap<String, serde_json::Value>)],
) -> BTreeMap<String, serde_json::Value> {
    if units.len() == 1 {
        return units[0].1.clone();
    }
    let sum_keys: &[&str] = match stage {
        Stage::Radiance => &["maps", "rays_cast"],
        Stage::Materials => &["materials", "lobes", "env_maps"],
        Stage::Srdm => &[
            "views",
            "srdm_bytes",
            "capture_bytes",
            "rows_dropping_spans",
            "build_ms",
        ],
        _ => &[],
    };
    let mut out: BTreeMap<String, serde_json::Value> = BTreeMap::new();
    let views: Vec<f64> = units
        .iter()
        .map(|(_, s)| s.get("views").and_then(|v| v.as_f64()).unwrap_or(1.0))
        .collect();
    let total_views: f64 = views.iter().sum::<f64>().max(1.0);
    for (_, s) in units {
        for (k, v) in s {
            if out.contains_key(k) {
                continue;
            }
            let all: Vec<&serde_json::Value> = units.iter().filter_map(|(_, s)| s.get(k)).collect();
            let merged = if sum_keys.contains(&k.as_str()) {
                if all.iter().all(|v| v.is_u64()) {
                    all.iter().filter_map(|v| v.as_u64()).sum::<u64>().into()
                } else {
                    all.iter().filter_map(|v| v.as_f64()).sum::<f64>().into()
                }
            } else if k == "max_row_error" {
                all.iter()
                    .filter_map(|v| v.as_f64())
                    .fold(0.0, f64::max)
                    .into()
            } else if stage == Stage::Srdm && (k == "coverage" || k == "mean_relative_z_error") {
                let weighted: f64 = units
                    .iter()
                    .zip(&views)
                    .filter_map(|((_, s), w)| Some(s.get(k)?.as_f64()? * w))
                    .sum();
                (weighted / total_views).into()
            } else if all.iter().all(|v| v.is_array()) {
                serde_json::Value::Array(
                    all.iter()
                        .flat_map(|v| v.as_array().cloned().unwrap_or_default())
                        .collect(),
                )
            } else {
                v.clone()
            };
            out.insert(k.clone(), merged);
        }
    }
    // The material units' note that environment maps are baked elsewhere is moot when some
    // environment-map unit baked them.
    if stage == Stage::Materials && units.iter().any(|(id, _)| kind(id) == "envmap") {
        out.remove("env_maps_skipped");
    }
    out
}
