//! A work unit's shard: a bundle holding the part of one stage that the unit baked, and
//! `unit.json`, its completion marker, written last (temp + rename). A shard without the
//! marker is incomplete: the unit failed or was killed, and the merge refuses it by name.
//!
//! A unit first removes the shard's marker, then commits its stage part (the bundle's atomic
//! stage commit), then writes the marker: killed at any point, it leaves no marker. A unit
//! whose shard already holds a marker with the unit's key, and whose assets are intact, is
//! up to date: only the marker is rewritten, naming the current plan.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::materials::{self, Outcome};
use super::part::{Item, Part};
use super::radiosity_stage::Gathering;
use super::srdm_stage::{self, SrdmOutcome};
use super::units::{GATHER, Unit, UnitPlan, kind};
use super::{BakeSettings, Stage, StageStatus, radiance_stage, radiosity_stage, scene_stage};
use crate::bundle::{Bundle, Manifest, write_atomic};
use crate::progress::Progress;
use crate::scene::Scene;

/// The marker's file name inside a shard.
pub const MARKER: &str = "unit.json";
/// `format` of a marker.
pub const MARKER_FORMAT: &str = "glint-unit";

/// `unit.json`: which unit a complete shard holds, from which plan.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Marker {
    /// Always `glint-unit`.
    pub format: String,
    /// Marker version, 1.
    pub version: u32,
    /// The unit's ID.
    pub unit: String,
    /// The unit's key when it was baked.
    pub key: String,
    /// The stage the shard holds.
    pub stage: String,
    /// [`crate::bundle::StageRecord::identity`] of that stage as committed.
    pub stage_identity: String,
    /// The identity of the D the unit read (units that read D).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub read_d: Option<String>,
    /// The plan the shard belongs to (rewritten when a later plan finds it up to date).
    pub plan: UnitPlan,
}

/// Why a shard cannot be read or a unit cannot be baked. Messages name the shard.
#[derive(Debug, thiserror::Error)]
pub enum ShardError {
    /// No marker: the unit never finished.
    #[error(
        "{}: incomplete shard: no {MARKER} (its unit failed or was killed before it finished); rerun its unit{}",
        shard.display(), hint.as_deref().map(|u| format!(" (`glint-bake SCENE --unit {u} --bundle {}`)", shard.display())).unwrap_or_default()
    )]
    Incomplete {
        /// The shard.
        shard: PathBuf,
        /// The unit, guessed from the shard's file name.
        hint: Option<String>,
    },
    /// Nothing at the shard's path.
    #[error("{}: no shard there: the path does not exist", shard.display())]
    Missing {
        /// The path given.
        shard: PathBuf,
    },
    /// A bundle of several stages without a marker: a whole bake (or a merge), not a shard.
    #[error(
        "{}: a whole bundle (stages {}), not a unit shard (it has no {MARKER}): merge takes the shards `glint-bake SCENE --unit ID --bundle SHARD.glint` writes",
        shard.display(), stages.join(", ")
    )]
    WholeBake {
        /// The bundle.
        shard: PathBuf,
        /// Its stages.
        stages: Vec<String>,
    },
    /// Anything else wrong with a shard.
    #[error("{}: {why}", shard.display())]
    Invalid {
        /// The shard.
        shard: PathBuf,
        /// What is wrong.
        why: String,
    },
}

fn invalid(shard: &Path, why: impl Into<String>) -> ShardError {
    ShardError::Invalid {
        shard: shard.to_owned(),
        why: why.into(),
    }
}

/// The unit ID a shard's file name suggests (`radiance.Floor.glint` → `radiance.Floor`).
fn unit_of_name(shard: &Path) -> Option<String> {
    let name = shard.file_name()?.to_string_lossy().into_owned();
    Some(name.strip_suffix(".glint").unwrap_or(&name).to_string())
}

/// Why the folder at `shard` has no marker: nothing there, a file, a whole bundle (several
/// stages), or a shard whose unit never finished (a unit commits one stage).
fn no_marker(shard: &Path) -> ShardError {
    match std::fs::metadata(shard) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return ShardError::Missing {
                shard: shard.to_owned(),
            };
        }
        Err(e) => return invalid(shard, e.to_string()),
        Ok(m) if !m.is_dir() => return invalid(shard, "a file, not a shard folder"),
        Ok(_) => {}
    }
    if let Ok(b) = Bundle::open(shard)
        && b.manifest().stages.len() > 1
    {
        return ShardError::WholeBake {
            shard: shard.to_owned(),
            stages: b.manifest().stages.keys().cloned().collect(),
        };
    }
    ShardError::Incomplete {
        shard: shard.to_owned(),
        hint: unit_of_name(shard),
    }
}

/// The shards one run has hashed every asset of, or written, each with the identity of the
/// stage it held then: read again in the same run (by a unit that reads D, by the assembly),
/// such a shard's marker and manifest are checked but its files are not hashed again.
#[derive(Debug, Default)]
pub struct Checked(Mutex<BTreeMap<PathBuf, String>>);

impl Checked {
    /// Whether the shard at `shard` was checked or written holding the stage `identity`.
    fn holds(&self, shard: &Path, identity: &str) -> bool {
        let held = self.0.lock().unwrap_or_else(|e| e.into_inner());
        held.get(shard).is_some_and(|i| i == identity)
    }

    /// Records that the shard at `shard` holds the stage `identity`, every asset intact.
    fn insert(&self, shard: &Path, identity: String) {
        let mut held = self.0.lock().unwrap_or_else(|e| e.into_inner());
        held.insert(shard.to_owned(), identity);
    }
}

/// Reads a shard's marker and checks the shard against it: the stage it names exists with
/// the recorded identity and every asset matches its hash. Returns the marker and the opened
/// shard.
pub fn read_shard(shard: &Path) -> Result<(Marker, Bundle), ShardError> {
    read_shard_checked(shard, &Checked::default())
}

/// [`read_shard`], hashing the assets only of a shard `checked` does not hold as it is now.
pub fn read_shard_checked(shard: &Path, checked: &Checked) -> Result<(Marker, Bundle), ShardError> {
    let text = match crate::bundle::read_top_file(shard, MARKER) {
        Ok(Some(t)) => t,
        Ok(None) => return Err(no_marker(shard)),
        Err(e) => return Err(invalid(shard, e.to_string())),
    };
    let marker = parse_marker(shard, text.as_bytes())?;
    let bundle = Bundle::open(shard).map_err(|e| invalid(shard, e.to_string()))?;
    check_marker(shard, &marker, bundle.manifest())?;
    if checked.holds(shard, &marker.stage_identity) {
        return Ok((marker, bundle));
    }
    let problems = bundle.verify();
    if let Some(p) = problems.first() {
        return Err(invalid(
            shard,
            format!(
                "{} damaged asset(s), e.g. {p}: rerun unit `{}`",
                problems.len(),
                marker.unit
            ),
        ));
    }
    checked.insert(shard, marker.stage_identity.clone());
    Ok((marker, bundle))
}

/// Parses the marker `text` of the shard at `shard` and checks its format and version.
pub(crate) fn parse_marker(shard: &Path, text: &[u8]) -> Result<Marker, ShardError> {
    let marker: Marker = serde_json::from_slice(text)
        .map_err(|e| invalid(shard, format!("{MARKER}: not a unit marker: {e}")))?;
    if marker.format != MARKER_FORMAT || marker.version != 1 {
        return Err(invalid(
            shard,
            format!(
                "{MARKER}: format {:?} version {}, expected {MARKER_FORMAT:?} version 1",
                marker.format, marker.version
            ),
        ));
    }
    Ok(marker)
}

/// Checks that the shard's `manifest` holds the stage `marker` names, as the unit committed
/// it (the same identity).
pub(crate) fn check_marker(
    shard: &Path,
    marker: &Marker,
    manifest: &Manifest,
) -> Result<(), ShardError> {
    let record = manifest.stages.get(&marker.stage).ok_or_else(|| {
        invalid(
            shard,
            format!(
                "{MARKER} names stage `{}`, which the shard lacks",
                marker.stage
            ),
        )
    })?;
    if record.identity() != marker.stage_identity {
        return Err(invalid(
            shard,
            format!(
                "stage `{}` differs from what unit `{}` committed (identity {:.12}…, the marker records {:.12}…): rerun the unit",
                marker.stage,
                marker.unit,
                record.identity(),
                marker.stage_identity
            ),
        ));
    }
    Ok(())
}

/// What [`bake_unit`] did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct UnitReport {
    /// The unit.
    pub unit: String,
    /// The shard.
    #[serde(serialize_with = "crate::lossy_path::serialize")]
    pub shard: PathBuf,
    /// Baked, or up to date.
    #[serde(flatten)]
    pub status: StageStatus,
}

/// Bakes unit `id` of `plan` into the shard at `shard`, reading D (when the unit reads it)
/// from `d_shard` (default: `radiosity.glint` beside the shard). Up to date when the shard
/// holds this unit's key intact: then only the marker is rewritten with `plan`.
pub fn bake_unit(
    scene: &Scene,
    settings: &BakeSettings,
    plan: &UnitPlan,
    id: &str,
    shard: &Path,
    d_shard: Option<&Path>,
    progress: &dyn Progress,
) -> anyhow::Result<UnitReport> {
    let checked = Checked::default();
    bake_unit_gathering(
        scene, settings, plan, id, shard, d_shard, false, &checked, progress,
    )
}

/// [`bake_unit`], where the `radiosity` unit gathers every element itself when `gather_here`
/// (the same D: each element draws from its own random streams) instead of reading the
/// gathering units' shards, and a `radiance` unit keeps its maps' records beside its shard
/// ([`super::read_cache`]).
/// Shards `checked` holds are not hashed again (the unit's own, the D it reads); the unit's
/// shard is added to it, checked or written.
#[allow(clippy::too_many_arguments)]
pub fn bake_unit_gathering(
    scene: &Scene,
    settings: &BakeSettings,
    plan: &UnitPlan,
    id: &str,
    shard: &Path,
    d_shard: Option<&Path>,
    gather_here: bool,
    checked: &Checked,
    progress: &dyn Progress,
) -> anyhow::Result<UnitReport> {
    let unit = plan.unit(id).ok_or_else(|| {
        let ids: Vec<&str> = plan.units.iter().map(|u| u.id.as_str()).collect();
        anyhow::anyhow!(
            "{}: no work unit `{id}`; the scene's units are: {}",
            scene.path.display(),
            ids.join(", ")
        )
    })?;
    crate::bundle::check_folder(shard)?;
    let report = |status| UnitReport {
        unit: id.into(),
        shard: shard.to_owned(),
        status,
    };
    // The marker first: a shard of another key is rebaked without hashing its files.
    let same_key = crate::bundle::read_top_file(shard, MARKER)
        .ok()
        .flatten()
        .and_then(|t| parse_marker(shard, t.as_bytes()).ok())
        .is_some_and(|m| m.unit == unit.id && m.key == unit.key);
    if same_key && let Ok((old, _)) = read_shard_checked(shard, checked) {
        if old.plan != *plan {
            write_marker(
                shard,
                &Marker {
                    plan: plan.clone(),
                    ..old
                },
            )?;
        }
        return Ok(report(StageStatus::UpToDate));
    }
    let start = Instant::now();
    match std::fs::remove_file(shard.join(MARKER)) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => anyhow::bail!("{}: cannot remove: {e}", shard.join(MARKER).display()),
    }
    let d_path = d_source(unit, shard, d_shard, plan, checked)?;
    // The plain `glint-bake`'s unit cache keeps the records of radiance maps and cube-map
    // captures; a job engine's shards do not.
    let item = plan.item(unit);
    let records =
        unit.stage == Stage::Radiance.name() || matches!(item, Item::Probe(_) | Item::EnvMap(_));
    let reads = (gather_here && records).then(|| super::read_cache::reads_dir(shard));
    let part = Part {
        item,
        d_from: d_path.as_deref(),
        reads: reads.as_deref(),
    };
    let stage = bake_stage_part(
        scene,
        settings,
        plan,
        unit,
        shard,
        part,
        gather_here,
        progress,
    )?;
    let read_d = match &d_path {
        Some(p) => Some(d_identity(p)?),
        None => None,
    };
    let identity = Bundle::open(shard)?
        .stage(stage)
        .map(|r| r.identity())
        .ok_or_else(|| {
            anyhow::anyhow!(
                "{}: unit `{id}` committed no `{stage}` stage",
                shard.display(),
            )
        })?;
    write_marker(
        shard,
        &Marker {
            format: MARKER_FORMAT.into(),
            version: 1,
            unit: unit.id.clone(),
            key: unit.key.clone(),
            stage: stage.into(),
            stage_identity: identity.clone(),
            read_d,
            plan: plan.clone(),
        },
    )?;
    // Just written: the assets are the bytes the unit hashed as it wrote them.
    checked.insert(shard, identity);
    Ok(report(StageStatus::Baked {
        seconds: start.elapsed().as_secs_f64(),
    }))
}

/// The identity of the radiosity stage of the shard at `d_shard` (which the unit just read).
fn d_identity(d_shard: &Path) -> anyhow::Result<String> {
    Bundle::open(d_shard)?
        .stage(crate::radiosity::current::STAGE)
        .map(|r| r.identity())
        .ok_or_else(|| {
            anyhow::anyhow!(
                "{}: has no `radiosity` stage: bake the `radiosity` unit into it first",
                d_shard.display()
            )
        })
}

fn write_marker(shard: &Path, marker: &Marker) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(marker)?;
    write_atomic(&shard.join(MARKER), text.as_bytes())?;
    Ok(())
}

/// The shard of unit `dep` that `unit` reads: `given`, else `DEP.glint` beside `shard`; it
/// must hold `dep` of this plan, complete.
fn dep_shard(
    unit: &Unit,
    dep: &str,
    shard: &Path,
    given: Option<&Path>,
    plan: &UnitPlan,
    checked: &Checked,
) -> anyhow::Result<PathBuf> {
    let path = match given {
        Some(p) => p.to_owned(),
        None => shard
            .parent()
            .unwrap_or(Path::new("."))
            .join(format!("{dep}.glint")),
    };
    let (marker, _) = read_shard_checked(&path, checked).map_err(|e| match e {
        ShardError::Missing { .. } => anyhow::anyhow!(
            "unit `{}` reads unit `{dep}`'s shard, which is missing at {}: bake `{dep}` first (`glint-bake SCENE --unit {dep} --bundle {}`)",
            unit.id,
            path.display(),
            path.display()
        ),
        e => anyhow::anyhow!("unit `{}` reads unit `{dep}`'s shard: {e}", unit.id),
    })?;
    let want = plan.unit(dep).map(|u| u.key.as_str());
    if marker.unit != *dep || Some(marker.key.as_str()) != want {
        anyhow::bail!(
            "{}: holds unit `{}` with key {:.12}…, but unit `{}` needs unit `{dep}` of this plan (key {:.12}…): bake `{dep}` first",
            path.display(),
            marker.unit,
            marker.key,
            unit.id,
            want.unwrap_or("none")
        );
    }
    Ok(path)
}

/// The shard a unit reads D from: `d_shard`, else `radiosity.glint` beside `shard`; it must
/// hold the plan's `radiosity` unit, complete.
fn d_source(
    unit: &Unit,
    shard: &Path,
    d_shard: Option<&Path>,
    plan: &UnitPlan,
    checked: &Checked,
) -> anyhow::Result<Option<PathBuf>> {
    if !unit.depends_on.iter().any(|d| d == "radiosity") {
        return Ok(None);
    }
    dep_shard(unit, "radiosity", shard, d_shard, plan, checked).map(Some)
}

/// The gathering shards the `radiosity` unit reads, beside `shard`, in plan order.
fn gather_sources(unit: &Unit, shard: &Path, plan: &UnitPlan) -> anyhow::Result<Vec<PathBuf>> {
    unit.depends_on
        .iter()
        .filter(|d| kind(d) == GATHER)
        .map(|d| dep_shard(unit, d, shard, None, plan, &Checked::default()))
        .collect()
}

/// Bakes the stage part of `unit` into `shard` (replacing what it held); returns the name of
/// the stage it committed there.
#[allow(clippy::too_many_arguments)]
fn bake_stage_part(
    scene: &Scene,
    s: &BakeSettings,
    plan: &UnitPlan,
    unit: &Unit,
    shard: &Path,
    part: Part<'_>,
    gather_here: bool,
    progress: &dyn Progress,
) -> anyhow::Result<&'static str> {
    let force = true;
    let stage = match unit.stage.as_str() {
        "scene" => {
            scene_stage::bake(scene, shard, force)?;
            Stage::Scene.name()
        }
        GATHER => {
            let part = plan
                .gather_part(unit)
                .ok_or_else(|| anyhow::anyhow!("unit `{}` is no gathering unit", unit.id))?;
            radiosity_stage::bake_gather(scene, shard, &s.radiosity, part, progress)?;
            radiosity_stage::GATHER_STAGE
        }
        "radiosity" => {
            let gathers = if gather_here {
                Vec::new()
            } else {
                gather_sources(unit, shard, plan)?
            };
            // The incremental bake keeps every gathering ray beside the shard.
            let rays = shard.with_extension("rays");
            let from = if gather_here {
                Gathering::Cached(&rays)
            } else if gathers.is_empty() {
                Gathering::Here
            } else {
                Gathering::From(&gathers)
            };
            radiosity_stage::bake_from(scene, shard, &s.radiosity, force, from, progress)?;
            Stage::Radiosity.name()
        }
        "materials" => {
            if let Outcome::Skipped(why) =
                materials::bake_part(scene, shard, &s.materials, force, part, progress)?
            {
                anyhow::bail!("unit `{}`: the materials stage is skipped: {why}", unit.id);
            }
            Stage::Materials.name()
        }
        "radiance" => {
            radiance_stage::bake_part(scene, shard, s.quality, force, part, progress)?;
            Stage::Radiance.name()
        }
        "srdm" => {
            if let SrdmOutcome::Skipped { reason } =
                srdm_stage::bake_part(scene, shard, &s.srdm, force, part, progress)?
            {
                anyhow::bail!("unit `{}`: the srdm stage is skipped: {reason}", unit.id);
            }
            Stage::Srdm.name()
        }
        other => anyhow::bail!("unit `{}`: unknown stage `{other}`", unit.id),
    };
    Ok(stage)
}

/// The shard of unit `id` in `dir`.
pub fn shard_path(dir: &Path, id: &str) -> PathBuf {
    dir.join(format!("{id}.glint"))
}
