//! `glint-bundle`'s command line: `stats`, `verify`, `merge`, `export` and `ls` of a bundle. The binary parses
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
    after_help = "Examples:\n  glint-bundle stats out/cornell-box.glint\n  glint-bundle merge out/glossy-room.glint shards/*.glint\n  glint-bundle stats out/cornell-box.glint --json | jq .total\n  glint-bundle verify out/cornell-box.glint && echo intact\n  glint-bundle ls out/cornell-box.glint\n  glint-bundle export out/glossy-room.glint out/glossy-room.glb"
)]
/// `glint-bundle`'s arguments: one subcommand.
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Bytes and file counts per stage and per asset kind, and each stage's figures; checks
    /// that every asset is a file inside the bundle with its recorded size, and that the
    /// scene's files name only files of their stage, and exits 1 with a warning per problem
    /// if not (hashes are checked by `verify`).
    Stats {
        /// The bundle folder.
        bundle: PathBuf,
        /// Print JSON for scripts instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Check the manifest, every asset's size and BLAKE3 hash, and that the scene's files and
    /// the stages' index files name only listed files of their stage; exit 0 only if all match.
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
    /// Every stage is committed at once: the bundle is the old one or the new one, whole,
    /// whatever happens meanwhile.
    Merge {
        /// The bundle to write (new, empty, or a bundle whose stages are replaced).
        out: PathBuf,
        /// Every unit's shard.
        #[arg(required = true)]
        shards: Vec<PathBuf>,
        /// Print a JSON report.
        #[arg(long)]
        json: bool,
        /// Replace a bundle of another scene (by name); a bundle of an earlier version of
        /// the same scene is replaced without it.
        #[arg(long)]
        force: bool,
    },
    /// Write the scene as a binary glTF with the radiosity stage's D as lightmaps: TEXCOORD_1,
    /// MSFT_lightmap and the same binding in extras (docs/export.md).
    Export {
        /// The bundle folder.
        bundle: PathBuf,
        /// The .glb to write (replaced whole, never half-written).
        out: PathBuf,
        /// Largest lightmap page side in texels (larger pages are box-filtered down; 0: as baked).
        #[arg(long, value_name = "TEXELS", default_value_t = 0)]
        page_size: u32,
        /// Lightmap encoding: rgbd (HDR, RGBA PNG) or srgb (LDR RGB PNG, clipped at the scale).
        #[arg(long, default_value = "rgbd")]
        format: crate::export::lightmap::LightmapFormat,
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
                    "warning: {} of {} assets are missing, of the wrong size, not a file inside the bundle, or name a file outside their stage; the figures above are the manifest's (run `glint-bundle verify`, then re-bake)",
                    stats.damaged.len(),
                    stats.total.files
                )?;
                return Ok(ExitCode::FAILURE);
            }
        }
        Command::Verify { bundle, json } => {
            let b = open(&bundle)?;
            let mut problems: Vec<String> = b.verify().iter().map(|p| p.to_string()).collect();
            if problems.is_empty() {
                problems = index_references(&b);
            }
            let assets = b.manifest().assets().count();
            if json {
                let report = serde_json::json!({
                    "bundle": bundle.display().to_string(),
                    "assets": assets,
                    "ok": problems.is_empty(),
                    "problems": problems,
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
                writeln!(out, "{} problems found in {assets} assets", problems.len())?;
            }
            if !problems.is_empty() {
                return Ok(ExitCode::FAILURE);
            }
        }
        Command::Merge {
            out: bundle,
            shards,
            json,
            force,
        } => {
            // Ctrl-C stops the merge before its commit, which then exits 130.
            crate::progress::install_interrupt_handler();
            let options = crate::bake::merge::MergeOptions {
                force,
                ..Default::default()
            };
            let report = crate::bake::merge::merge(&bundle, &shards, options)?;
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
        Command::Export {
            bundle,
            out: glb,
            page_size,
            format,
            json,
        } => {
            let options = crate::export::ExportOptions {
                max_page: page_size,
                format,
            };
            let report = crate::export::export(&bundle, &glb, &options)?;
            if json {
                writeln!(out, "{}", serde_json::to_string_pretty(&report)?)?;
            } else {
                writeln!(
                    out,
                    "ok: {} — {} triangles, {} lightmap page(s) ({}, scale {}), auto exposure {:+.2} EV, {}",
                    glb.display(),
                    report.triangles,
                    report.pages.len(),
                    report.encoding,
                    report.scale,
                    report.exposure_ev,
                    human_bytes(report.bytes)
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

/// The files the stages' index files name (`materials/index.json`, `srdm/index.json`, each
/// radiance reflector's `cameras.json`), each of which must be a listed asset of its stage, as
/// the viewer's readers require: one message per file an index names that is not, naming
/// the index, the field and the path.
fn index_references(b: &Bundle) -> Vec<String> {
    use crate::materials::index as materials;
    use crate::radiance::index as radiance;
    use crate::srdm::index as srdm;
    let mut problems = Vec::new();
    let mut need = |stage: &str, index: &str, field: String, rel: &str| {
        if let Err(e) = b.stage_asset(stage, rel) {
            problems.push(format!("{stage}/{index}: field `{field}` is {rel:?}: {e}"));
        }
    };
    let mut unreadable = Vec::new();
    match crate::materials::MaterialsIndex::load(b) {
        Ok(Some(ix)) => {
            let at = materials::INDEX_FILE;
            for (i, m) in ix.materials.iter().enumerate() {
                for (j, l) in m.lobes.iter().enumerate() {
                    let f = |name: &str| format!("materials[{i}].lobes[{j}].{name}.path");
                    need(materials::STAGE, at, f("kernel"), &l.kernel.path);
                    need(
                        materials::STAGE,
                        at,
                        f("reflectance_sphere"),
                        &l.reflectance_sphere.path,
                    );
                    if let Some(r) = &l.reflectance_1d {
                        need(materials::STAGE, at, f("reflectance_1d"), &r.path);
                    }
                    need(materials::STAGE, at, f("pattern"), &l.pattern.path);
                }
            }
            for (i, e) in ix.env_maps.iter().enumerate() {
                for (k, level) in e.levels.iter().enumerate() {
                    need(
                        materials::STAGE,
                        at,
                        format!("env_maps[{i}].levels[{k}]"),
                        level,
                    );
                }
            }
            for (i, p) in ix.probes.iter().enumerate() {
                for (k, level) in p.levels.iter().enumerate() {
                    need(
                        materials::STAGE,
                        at,
                        format!("probes[{i}].levels[{k}]"),
                        level,
                    );
                }
            }
        }
        Ok(None) => {}
        Err(e) => unreadable.push(e.to_string()),
    }
    if b.stage(srdm::STAGE).is_some() {
        let index = b
            .read_stage_file(srdm::STAGE, srdm::INDEX_FILE)
            .map_err(|e| e.to_string())
            .and_then(|bytes| {
                serde_json::from_slice::<srdm::SrdmIndex>(&bytes)
                    .map_err(|e| format!("{}/{}: {e}", srdm::STAGE, srdm::INDEX_FILE))
            });
        match index {
            Ok(ix) => {
                for (i, v) in ix.views.iter().enumerate() {
                    need(
                        srdm::STAGE,
                        srdm::INDEX_FILE,
                        format!("views[{i}].srdm"),
                        &v.srdm,
                    );
                    need(
                        srdm::STAGE,
                        srdm::INDEX_FILE,
                        format!("views[{i}].capture"),
                        &v.capture,
                    );
                }
            }
            Err(e) => unreadable.push(e),
        }
    }
    let cameras = b
        .stage(radiance::STAGE)
        .into_iter()
        .flat_map(|s| s.assets.iter())
        .filter(|a| a.kind == "radiance-cameras");
    for a in cameras {
        let rel = a.path.strip_prefix("radiance/").unwrap_or(&a.path);
        let folder = rel.rsplit_once('/').map_or("", |(f, _)| f);
        let file = b
            .read_asset(a)
            .map_err(|e| e.to_string())
            .and_then(|bytes| {
                serde_json::from_slice::<radiance::CamerasFile>(&bytes)
                    .map_err(|e| format!("{}: {e}", a.path))
            });
        match file {
            Ok(c) => {
                for (i, m) in c.maps.iter().enumerate() {
                    for ext in ["exr", "qtree"] {
                        let path = format!("{folder}/{}.{ext}", m.file);
                        need(radiance::STAGE, rel, format!("maps[{i}].file"), &path);
                    }
                }
            }
            Err(e) => unreadable.push(e),
        }
    }
    problems.extend(unreadable);
    problems
}
