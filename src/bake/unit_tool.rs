//! `glint-bake`'s work-unit modes: `--plan` prints the units, `--unit ID` bakes one into its
//! shard, `--units DIR` bakes every unit (skipping those up to date) and merges them.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use super::BakeSettings;
use super::shard::{UnitReport, bake_unit, shard_path};
use super::units::{Unit, UnitPlan, plan_units};
use super::written::Written;
use crate::bundle::stats::format_table;
use crate::cli::{BakeArgs, GlintBakeArgs};
use crate::progress::TerminalProgress;
use crate::scene::Scene;

/// Runs `glint-bake` with `args`: a work-unit mode, or the whole bake ([`super::tool::run`]).
pub fn run(args: &GlintBakeArgs, out: &mut dyn Write) -> anyhow::Result<ExitCode> {
    if !args.plan && args.unit.is_none() && args.units.is_none() {
        let bake = BakeArgs {
            bundle: args.bundle.clone().expect("clap requires --bundle"),
            options: args.options.clone(),
        };
        return super::tool::run(&bake, super::tool::Tool::All, out);
    }
    let scene = Scene::load(&args.options.scene)?;
    let quality = args.options.quality.unwrap_or(scene.desc.bake.quality);
    let settings = BakeSettings::resolve(&scene, quality)?;
    let plan = plan_units(&scene, &settings).map_err(anyhow::Error::msg)?;
    if args.plan {
        print_plan(&plan, args.wave, args.options.json, out)?;
        return Ok(ExitCode::SUCCESS);
    }
    let mut targets: Vec<PathBuf> = args.bundle.iter().cloned().collect();
    if let Some(dir) = &args.units {
        targets.extend(plan.units.iter().map(|u| shard_path(dir, &u.id)));
    }
    let written = Written::snapshot(&targets.iter().map(PathBuf::as_path).collect::<Vec<_>>());
    run_units(args, &scene, &settings, &plan, out).map_err(|e| written.explain(e))
}

/// `--unit` or `--units`: bakes, merges, reports.
fn run_units(
    args: &GlintBakeArgs,
    scene: &Scene,
    settings: &BakeSettings,
    plan: &UnitPlan,
    out: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    let progress = TerminalProgress::new();
    let result = if let Some(id) = &args.unit {
        let shard = args.bundle.as_deref().expect("clap requires --bundle");
        bake_unit(
            scene,
            settings,
            plan,
            id,
            shard,
            args.d_shard.as_deref(),
            &progress,
        )
        .map(|r| vec![r])
    } else {
        let dir = args.units.as_deref().expect("one mode is chosen");
        bake_every_unit(scene, settings, plan, dir, &progress)
    };
    progress.finish();
    let reports = result?;
    let merged = match (&args.units, &args.bundle) {
        (Some(dir), Some(bundle)) => {
            let shards: Vec<PathBuf> = plan.units.iter().map(|u| shard_path(dir, &u.id)).collect();
            let options = super::merge::MergeOptions {
                force: args.options.force,
                ..Default::default()
            };
            Some(super::merge::merge(bundle, &shards, options)?)
        }
        _ => None,
    };
    if args.options.json {
        let v = serde_json::json!({ "scene": scene.name, "units": reports, "merged": merged });
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
    } else {
        for r in &reports {
            writeln!(
                out,
                "{}: unit {} {} → {}",
                scene.name,
                r.unit,
                r.status,
                r.shard.display()
            )?;
        }
        if let Some(m) = merged {
            writeln!(
                out,
                "{}: {} units merged into {} ({} stages, {} assets)",
                m.scene,
                m.units,
                m.bundle.display(),
                m.stages.len(),
                m.assets
            )?;
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Bakes every unit of `plan` into `dir`, wave by wave, the units of a wave side by side,
/// the costliest first (`bake::wave`).
pub fn bake_every_unit(
    scene: &Scene,
    settings: &BakeSettings,
    plan: &UnitPlan,
    dir: &Path,
    progress: &TerminalProgress,
) -> anyhow::Result<Vec<UnitReport>> {
    crate::out_dir::create_dir_all(dir).map_err(|e| anyhow::anyhow!("{}: {e}", dir.display()))?;
    let mut reports = Vec::new();
    let last = plan.units.iter().map(|u| u.wave).max().unwrap_or(0);
    for wave in 0..=last {
        let units: Vec<&Unit> = plan.wave(wave).collect();
        let costs: Vec<f64> = units.iter().map(|u| u.cost).collect();
        let baked = super::wave::run_wave(
            &costs,
            super::wave::units_at_once(),
            progress,
            |i, progress| {
                let shard = shard_path(dir, &units[i].id);
                bake_unit(scene, settings, plan, &units[i].id, &shard, None, progress)
            },
        );
        for r in baked {
            reports.push(r?);
        }
    }
    Ok(reports)
}

/// `--plan`: a table, the JSON plan, or the IDs of one wave.
fn print_plan(
    plan: &UnitPlan,
    wave: Option<u32>,
    json: bool,
    out: &mut dyn Write,
) -> anyhow::Result<()> {
    if let Some(w) = wave {
        let waves = plan.units.iter().map(|u| u.wave + 1).max().unwrap_or(0);
        if w >= waves {
            anyhow::bail!(
                "--wave {w}: the plan has {waves} waves, numbered 0 to {}",
                waves.saturating_sub(1)
            );
        }
        for u in plan.wave(w) {
            writeln!(out, "{}", u.id)?;
        }
        return Ok(());
    }
    if json {
        writeln!(out, "{}", serde_json::to_string_pretty(plan)?)?;
        return Ok(());
    }
    let mut rows = vec![[
        "unit".to_string(),
        "wave".into(),
        "cost (rays)".into(),
        "reads".into(),
        "key".into(),
    ]];
    for u in &plan.units {
        rows.push([
            u.id.clone(),
            u.wave.to_string(),
            format!("{:.3e}", u.cost),
            u.depends_on.join(", "),
            format!("{:.12}", u.key),
        ]);
    }
    write!(
        out,
        "{}",
        format_table(&rows, &[false, true, true, false, false])
    )?;
    Ok(())
}
