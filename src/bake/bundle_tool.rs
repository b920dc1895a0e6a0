//! `glint-bundle`'s command line: `stats`, `verify`, `merge` and `ls` of a bundle. The binary parses
//! [`Args`] and calls [`run`].

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand};

use crate::bundle::Bundle;
use crate::bundle::stats::{BundleStats, format_table, human_bytes};

#[derive(Parser)]
#[command(
    name = "glint-bundle",
    version,
    about = "Inspect and verify a glint asset bundle (NAME.glint/)",
    after_help = "Examples:\n  glint-bundle stats out/cornell-box.glint\n  glint-bundle merge out/glossy-room.glint shards/*.glint\n  glint-bundle stats out/cornell-box.glint --json | jq .total\n  glint-bundle verify out/cornell-box.glint && echo intact\n  glint-bundle ls out/cornell-box.glint"
)]
/// `glint-bundle`'s arguments: one subcommand.
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Bytes and file counts per stage and per asset kind, and each stage's figures; checks
    /// that every asset exists with its recorded size and exits 1 with a warning per asset
    /// if not (hashes are checked by `verify`).
    Stats {
        /// The bundle folder.
        bundle: PathBuf,
        /// Print JSON for scripts instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Check the manifest and every asset's size and BLAKE3 hash; exit 0 only if all match.
    Verify {
        /// The bundle folder.
        bundle: PathBuf,
        /// Print a JSON report.
        #[arg(long)]
        json: bool,
    },
    /// Assemble the shards of a bake's work units (`glint-bake SCENE --unit ID --bundle
    /// SHARD.glint`) into one bundle, after checking that every unit of the plan is there
    /// once, complete (its `unit.json` written), intact and baked for the same plan, and that
    /// every unit that read D read the D assembled. Refuses, naming each bad shard, otherwise.
    Merge {
        /// The bundle to write (new, empty, or a bundle whose stages are replaced).
        out: PathBuf,
        /// Every unit's shard.
        #[arg(required = true)]
        shards: Vec<PathBuf>,
        /// Print a JSON report.
        #[arg(long)]
        json: bool,
    },
    /// List every asset: stage, kind, size, path.
    Ls {
        /// The bundle folder.
        bundle: PathBuf,
        /// Print JSON for scripts.
        #[arg(long)]
        json: bool,
    },
}

fn open(path: &Path) -> anyhow::Result<Bundle> {
    Bundle::open(path).with_context(|| format!("cannot open bundle {}", path.display()))
}

/// Runs the subcommand `args` names: exit code 1 when the bundle is damaged or fails
/// verification (errors go to [`crate::cli::exit_code`]).
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let mut out = std::io::stdout().lock();
    match args.command {
        Command::Stats { bundle, json } => {
            let stats = BundleStats::of(&open(&bundle)?);
            if json {
                writeln!(out, "{}", serde_json::to_string_pretty(&stats)?)?;
            } else {
                write!(out, "{}", stats.to_table())?;
            }
            if !stats.damaged.is_empty() {
                out.flush()?;
                let mut err = std::io::stderr().lock();
                for d in &stats.damaged {
                    writeln!(err, "warning: {}: {}", d.file, d.problem)?;
                }
                writeln!(
                    err,
                    "warning: {} of {} assets are missing or have the wrong size; the figures above are the manifest's (run `glint-bundle verify`, then re-bake)",
                    stats.damaged.len(),
                    stats.total.files
                )?;
                return Ok(ExitCode::FAILURE);
            }
        }
        Command::Verify { bundle, json } => {
            let b = open(&bundle)?;
            let problems = b.verify();
            let assets = b.manifest().assets().count();
            if json {
                let report = serde_json::json!({
                    "bundle": bundle.display().to_string(),
                    "assets": assets,
                    "ok": problems.is_empty(),
                    "problems": problems.iter().map(|p| p.to_string()).collect::<Vec<_>>(),
                });
                writeln!(out, "{}", serde_json::to_string_pretty(&report)?)?;
            } else if problems.is_empty() {
                let bytes: u64 = b.manifest().assets().map(|(_, a)| a.bytes).sum();
                writeln!(
                    out,
                    "ok: {} — manifest valid, {assets} assets ({}) match their hashes",
                    bundle.display(),
                    human_bytes(bytes)
                )?;
            } else {
                for p in &problems {
                    writeln!(out, "FAILED: {p}")?;
                }
                writeln!(
                    out,
                    "{} of {assets} assets failed verification",
                    problems.len()
                )?;
            }
            if !problems.is_empty() {
                return Ok(ExitCode::FAILURE);
            }
        }
        Command::Merge {
            out: bundle,
            shards,
            json,
        } => {
            let report = crate::bake::merge::merge(&bundle, &shards)?;
            if json {
                writeln!(out, "{}", serde_json::to_string_pretty(&report)?)?;
            } else {
                writeln!(
                    out,
                    "ok: {} — {} units of {} merged: {} stages ({}), {} assets",
                    bundle.display(),
                    report.units,
                    report.scene,
                    report.stages.len(),
                    report.stages.join(", "),
                    report.assets
                )?;
            }
        }
        Command::Ls { bundle, json } => {
            let b = open(&bundle)?;
            if json {
                let list: Vec<_> = b.manifest().assets().map(|(_, a)| a).collect();
                writeln!(out, "{}", serde_json::to_string_pretty(&list)?)?;
            } else {
                let mut rows = vec![[
                    "stage".to_string(),
                    "kind".to_string(),
                    "bytes".to_string(),
                    "path".to_string(),
                ]];
                rows.extend(b.manifest().assets().map(|(stage, a)| {
                    [
                        stage.to_string(),
                        a.kind.clone(),
                        a.bytes.to_string(),
                        a.path.clone(),
                    ]
                }));
                write!(out, "{}", format_table(&rows, &[false, false, true, false]))?;
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}
