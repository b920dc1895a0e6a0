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
use super::shard::{Checked, Marker, read_shard_checked};
use super::units::{GATHER, UnitPlan, kind};
use crate::bundle::{
    Bundle, FaultHook, Manifest, SceneCommit, StageInfo, StageRecord, StageWriter,
};
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

/// How [`merge`] treats the bundle it writes.
#[derive(Default)]
pub struct MergeOptions {
    /// Replace a bundle of another scene (by name) instead of refusing.
    pub force: bool,
    /// Called before each file-system step of the commit (fault-injection tests).
    pub fault_hook: Option<FaultHook>,
}

impl std::fmt::Debug for MergeOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MergeOptions")
            .field("force", &self.force)
            .finish_non_exhaustive()
    }
}

/// Checks `shards` and assembles them into the bundle at `out` (new, empty, or a bundle:
/// its stages are replaced). Every stage is committed at once (one manifest rename,
/// [`SceneCommit`]): a reader, a crash or a concurrent merge sees the old bundle or the new
/// one, never a mix. A bundle of the same scene (an earlier version of it, whatever its
/// hash) is replaced; one of another scene (by name) only with `options.force`.
pub fn merge(
    out: &Path,
    shards: &[PathBuf],
    options: MergeOptions,
) -> Result<MergeReport, MergeError> {
    merge_into(out, shards, options, false, &Checked::default())
}

/// [`merge`], leaving each stage the bundle holds already with the assets (intact) and
/// settings the merge would write: only its scene hash is updated, and its files are not
/// written again. At least one stage is written. Shards `checked` holds (this run baked or
/// checked them) are not hashed again.
pub fn merge_keeping(
    out: &Path,
    shards: &[PathBuf],
    options: MergeOptions,
    checked: &Checked,
) -> Result<MergeReport, MergeError> {
    merge_into(out, shards, options, true, checked)
}

fn merge_into(
    out: &Path,
    shards: &[PathBuf],
    options: MergeOptions,
    keep_unchanged: bool,
    checked: &Checked,
) -> Result<MergeReport, MergeError> {
    if shards.is_empty() {
        return Err(MergeError::one("no shards given"));
    }
    let mut problems = Vec::new();
    let mut read: Vec<(PathBuf, Marker, Bundle)> = Vec::new();
    for s in shards {
        match read_shard_checked(s, checked) {
            Ok((m, b)) => read.push((s.clone(), m, b)),
            Err(e) => problems.push(e.to_string()),
        }
    }
    let views: Vec<ShardView> = read
        .iter()
        .map(|(path, marker, b)| ShardView {
            path,
            marker,
            manifest: b.manifest(),
        })
        .collect();
    let assembly = check_shards(&views, problems)?;
    let plan = &assembly.plan;

    SceneCommit::check(out, &plan.scene_name, &plan.scene_hash, options.force)
        .map_err(|e| MergeError::one(e.to_string()))?;
    let mut commit = SceneCommit::new(out, options.force);
    if let Some(hook) = options.fault_hook {
        commit = commit.with_fault_hook(hook);
    }
    let mut report = MergeReport {
        bundle: out.to_owned(),
        scene: plan.scene_name.clone(),
        units: plan.units.len(),
        stages: Vec::new(),
        assets: 0,
    };
    // Ctrl-C stops the merge before its one commit: the bundle stays as it was.
    let stop = || {
        crate::progress::interrupted().then(|| {
            MergeError::one(format!(
                "interrupted: nothing was written; {} is as it was (a merge commits every stage at once)",
                out.display()
            ))
        })
    };
    let current = if keep_unchanged {
        Bundle::open(out).ok()
    } else {
        None
    };
    // Each stage's units with their shards, in assembly order.
    let units: Vec<Vec<(&str, &Bundle)>> = assembly
        .stages
        .iter()
        .map(|part| {
            part.units
                .iter()
                .map(|(id, i)| (id.as_str(), &read[*i].2))
                .collect()
        })
        .collect();
    let mut kept = Vec::new();
    for (part, units) in assembly.stages.iter().zip(&units) {
        let name = part.stage.name();
        let held = current
            .as_ref()
            .and_then(|b| Some((b, b.stage(name)?)))
            .filter(|(_, r)| r.settings == part.settings);
        if let Some((b, r)) = held
            && same_assets(part.stage, units, r)?
            && b.verify_stages(&[name]).is_empty()
        {
            kept.push((part.stage.name(), r.identity()));
        }
    }
    // A commit writes at least one stage: with none changed, all are written again.
    if kept.len() == assembly.stages.len() {
        kept.clear();
    }
    drop(current);
    for (stage, identity) in &kept {
        commit.keep(stage, identity);
        report.stages.push((*stage).into());
    }
    for (part, units) in assembly.stages.iter().zip(&units) {
        if let Some(e) = stop() {
            return Err(e);
        }
        if kept.iter().any(|(k, _)| *k == part.stage.name()) {
            continue;
        }
        let name = part.stage.name();
        let (w, info) = assemble(out, plan, part.stage, units)?;
        report.assets += w.assets().len();
        report.stages.push(name.into());
        commit.push(
            w,
            StageInfo {
                settings: part.settings.clone(),
                stats: part.stats.clone(),
                bake_seconds: part.bake_seconds,
                ..info
            },
        );
    }
    if let Some(e) = stop() {
        return Err(e);
    }
    commit
        .commit()
        .map_err(|e| MergeError::one(e.to_string()))?;
    Ok(report)
}

/// One shard as read: its path, marker and manifest.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ShardView<'a> {
    /// The shard.
    pub path: &'a Path,
    /// Its `unit.json`, checked against its manifest ([`super::shard::check_marker`]).
    pub marker: &'a Marker,
    /// Its manifest.
    pub manifest: &'a Manifest,
}

/// What a checked merge assembles: the plan, and per stage (in stage order) its units.
#[derive(Clone, Debug)]
pub(crate) struct Assembly {
    /// The plan every shard belongs to.
    pub plan: UnitPlan,
    /// The stages to write.
    pub stages: Vec<StagePart>,
}

/// One stage of an [`Assembly`].
#[derive(Clone, Debug)]
pub(crate) struct StagePart {
    /// The stage.
    pub stage: Stage,
    /// Its units in plan order: ID and index of its shard, which holds the stage.
    pub units: Vec<(String, usize)>,
    /// The settings the stage records (the plan's, with the D assembled).
    pub settings: serde_json::Value,
    /// The stage's figures, from its units' ([`merge_stats`]).
    pub stats: BTreeMap<String, serde_json::Value>,
    /// The units' bake times summed.
    pub bake_seconds: f64,
}

/// Checks that `shards` (read without the `problems` found so far) hold every unit of one
/// plan exactly once, each baked from the plan's inputs into the stage the plan gives it,
/// and that every unit that read D read the D assembled; returns what to assemble, or every
/// problem found. Pure: no file is read.
pub(crate) fn check_shards(
    shards: &[ShardView],
    mut problems: Vec<String>,
) -> Result<Assembly, MergeError> {
    let Some(first) = shards.first() else {
        return Err(MergeError { problems });
    };
    let plan: UnitPlan = first.marker.plan.clone();
    let mut by_unit: BTreeMap<&str, usize> = BTreeMap::new();
    for (i, v) in shards.iter().enumerate() {
        let (path, m) = (v.path, v.marker);
        if m.plan.plan_hash != plan.plan_hash {
            problems.push(format!(
                "{}: unit `{}` belongs to another plan ({:.12}…) than {} ({:.12}…): the scene or settings changed; rerun the unit",
                path.display(), m.unit, m.plan.plan_hash, first.path.display(), plan.plan_hash
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
            Some(u) if u.stage != m.stage => problems.push(format!(
                "{}: unit `{}` holds stage `{}`, but the plan gives it stage `{}`: rerun it",
                path.display(),
                m.unit,
                m.stage,
                u.stage
            )),
            Some(_) => {
                if let Some(j) = by_unit.insert(&m.unit, i) {
                    problems.push(format!(
                        "unit `{}` is in two shards: {} and {}",
                        m.unit,
                        shards[j].path.display(),
                        path.display()
                    ));
                }
            }
        }
    }
    for u in &plan.units {
        if u.stage != GATHER && !Stage::ALL.iter().any(|s| s.name() == u.stage) {
            problems.push(format!(
                "{}: the plan's unit `{}` is of unknown stage `{}`",
                first.path.display(),
                u.id,
                u.stage
            ));
        }
    }
    // Gathering shards are read by the `radiosity` unit alone, whose key covers theirs.
    let missing: Vec<&str> = plan
        .units
        .iter()
        .filter(|u| kind(&u.id) != GATHER)
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
        .and_then(|&i| shards[i].manifest.stages.get(Stage::Radiosity.name()))
        .map(|r| r.identity());
    for v in shards {
        if let Some(r) = &v.marker.read_d
            && d.as_deref() != Some(r.as_str())
        {
            problems.push(format!(
                "{}: unit `{}` read D {:.12}…, but the radiosity shard holds {}: rerun the unit",
                v.path.display(),
                v.marker.unit,
                r,
                d.as_deref().map_or("none".into(), |d| format!("{d:.12}…"))
            ));
        }
    }
    if !problems.is_empty() {
        return Err(MergeError { problems });
    }

    let mut stages = Vec::new();
    for stage in Stage::ALL {
        let name = stage.name();
        let units: Vec<(String, usize)> = plan
            .units
            .iter()
            .filter(|u| u.stage == name)
            .map(|u| (u.id.clone(), by_unit[u.id.as_str()]))
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
        let records: Vec<(&str, &StageRecord)> = units
            .iter()
            .map(|(id, i)| {
                let record = shards[*i].manifest.stages.get(name);
                (
                    id.as_str(),
                    record.expect("the unit's stage, checked above"),
                )
            })
            .collect();
        let stats: Vec<(&str, BTreeMap<String, serde_json::Value>)> = records
            .iter()
            .map(|(id, r)| (*id, r.stats.clone()))
            .collect();
        stages.push(StagePart {
            stage,
            settings,
            stats: merge_stats(stage, &stats),
            bake_seconds: records.iter().map(|(_, r)| r.bake_seconds).sum(),
            units,
        });
    }
    Ok(Assembly { plan, stages })
}

/// Whether the stage `record` holds exactly the assets (paths and hashes, in order) that
/// [`assemble`] would write from `units`.
fn same_assets(
    stage: Stage,
    units: &[(&str, &Bundle)],
    record: &StageRecord,
) -> Result<bool, MergeError> {
    let name = stage.name();
    let index_path = format!("{name}/index.json");
    let joins_index = matches!(stage, Stage::Materials | Stage::Srdm);
    let mut want: Vec<(String, String)> = Vec::new();
    let mut indexes = Vec::new();
    for (id, shard) in units {
        let r = shard.stage(name).expect("checked by check_shards");
        for a in &r.assets {
            if joins_index && a.path == index_path {
                let bytes = shard
                    .read_asset(a)
                    .map_err(|e| MergeError::one(format!("stage `{name}`: {e}")))?;
                indexes.push((*id, bytes));
            } else {
                want.push((a.path.clone(), a.blake3.clone()));
            }
        }
    }
    if joins_index {
        let bytes = match stage {
            Stage::Srdm => join_srdm(&indexes)?,
            _ => join_materials(&indexes)?,
        };
        want.push((index_path, blake3::hash(&bytes).to_hex().to_string()));
    }
    Ok(want.len() == record.assets.len()
        && want
            .iter()
            .zip(&record.assets)
            .all(|((p, h), a)| *p == a.path && *h == a.blake3))
}

/// Files an assembly holds in memory and writes at once.
const BATCH_FILES: usize = 64;

/// Writes stage `stage` of `out` from its units' shards into a [`StageWriter`]; returns it
/// with the stage's record (its figures left for the caller), for the merge's one commit.
fn assemble(
    out: &Path,
    plan: &UnitPlan,
    stage: Stage,
    units: &[(&str, &Bundle)],
) -> Result<(StageWriter, StageInfo), MergeError> {
    let name = stage.name();
    let err = |e: &dyn std::fmt::Display| MergeError::one(format!("stage `{name}`: {e}"));
    let index_path = format!("{name}/index.json");
    let joins_index = matches!(stage, Stage::Materials | Stage::Srdm);
    let mut w = StageWriter::begin(out, name).map_err(|e| err(&e))?;
    let mut indexes = Vec::new();
    // Files are written a batch at a time, flushed together ([`StageWriter::write_many`]).
    let mut batch: Vec<(String, String, Vec<u8>)> = Vec::new();
    let flush = |w: &mut StageWriter, batch: &mut Vec<(String, String, Vec<u8>)>| {
        let written = w.write_many(batch).map_err(|e| err(&e));
        batch.clear();
        written
    };
    for (id, shard) in units {
        let record = shard.stage(name).expect("checked by check_shards");
        for a in &record.assets {
            let bytes = shard.read_asset(a).map_err(|e| err(&e))?;
            if joins_index && a.path == index_path {
                indexes.push((*id, bytes));
                continue;
            }
            let rel = a.path.strip_prefix(&format!("{name}/")).unwrap_or(&a.path);
            batch.push((rel.to_owned(), a.kind.clone(), bytes));
            if batch.len() >= BATCH_FILES {
                flush(&mut w, &mut batch)?;
            }
        }
    }
    flush(&mut w, &mut batch)?;
    if joins_index {
        let bytes = match stage {
            Stage::Srdm => join_srdm(&indexes)?,
            _ => join_materials(&indexes)?,
        };
        w.write("index.json", kind_of_index(stage), &bytes)
            .map_err(|e| err(&e))?;
    }
    let info = StageInfo {
        scene_name: plan.scene_name.clone(),
        scene_hash: plan.scene_hash.clone(),
        settings: serde_json::Value::Null,
        stats: BTreeMap::new(),
        bake_seconds: 0.0,
        // The scene guard is the merge's whole commit's (SceneCommit), not this stage's.
        force: true,
    };
    Ok((w, info))
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
                j.probes.extend(index.probes);
                // Only probe units note why probes were skipped.
                j.probes_skipped = j.probes_skipped.take().or(index.probes_skipped);
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
        Stage::Materials => &["materials", "lobes", "env_maps", "probes"],
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
                // Counts past u64 (only forged figures reach that) are summed as floats.
                let exact = all
                    .iter()
                    .try_fold(0u64, |sum, v| sum.checked_add(v.as_u64()?));
                if let Some(sum) = exact {
                    sum.into()
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
