//! `glint-materials`: bake how each glossy material reflects: kernel and reflectance textures,
//! regular sample patterns, and prefiltered environment maps of glossy curved objects.

use std::io::Write;
use std::process::ExitCode;

use anyhow::Context;
use clap::Parser;
use glint::bake::materials::{self, MaterialsError, MaterialsSettings, Outcome};
use glint::bundle::stats::{format_table, human_bytes};
use glint::cli::BakeArgs;
use glint::progress::TerminalProgress;
use glint::scene::Scene;

#[derive(Parser)]
#[command(
    name = "glint-materials",
    version,
    about = "Bake the materials stage: per glossy material the kernel texture K (D·G), the reflectance maps R (sphere map and grazing-dense 1D map), the regular sample pattern closest to the sample budget, and MIP-filtered environment maps of glossy curved reflectors (these need the bundle's radiosity stage). A scene without glossy materials is skipped with the reason.",
    after_help = "Example:\n  glint-materials scenes/glossy-room/scene.json --bundle out/glossy-room.glint --quality draft\n  glint-bundle stats out/glossy-room.glint"
)]
struct Args {
    #[command(flatten)]
    bake: BakeArgs,
}

fn main() -> ExitCode {
    glint::cli::init_logging();
    glint::cli::exit_code(run(Args::parse().bake))
}

fn run(args: BakeArgs) -> anyhow::Result<ExitCode> {
    let scene = Scene::load(&args.scene)?;
    let quality = args.quality.unwrap_or(scene.desc.bake.quality);
    let settings = MaterialsSettings::resolve(quality, &scene.desc.bake.materials).map_err(
        |(field, message)| MaterialsError::Setting {
            path: scene.path.clone(),
            field,
            message,
        },
    )?;
    let progress = TerminalProgress::new();
    let outcome = materials::bake(&scene, &args.bundle, &settings, args.force, &progress);
    progress.finish();
    let outcome =
        outcome.with_context(|| format!("stage materials of {}", args.bundle.display()))?;
    let mut out = std::io::stdout().lock();
    match outcome {
        Outcome::Skipped(reason) => {
            if args.json {
                let v = serde_json::json!({
                    "bundle": args.bundle, "stage": "materials", "status": "skipped", "reason": reason,
                });
                writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
            } else {
                writeln!(out, "{}: materials skipped: {reason}", scene.name)?;
            }
        }
        Outcome::Baked(report) => {
            if args.json {
                let v = serde_json::json!({
                    "bundle": args.bundle, "stage": "materials", "status": "baked",
                    "quality": quality.name(), "bake_seconds": report.record.bake_seconds,
                    "report": &*report,
                });
                writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
                return Ok(ExitCode::SUCCESS);
            }
            writeln!(
                out,
                "{}: materials baked into {} in {:.2} s ({} quality; {})",
                scene.name,
                args.bundle.display(),
                report.record.bake_seconds,
                quality.name(),
                report.reason
            )?;
            let mut rows = vec![[
                "material".to_string(),
                "lobe".into(),
                "mx × my".into(),
                "kernel K".into(),
                "R maps".into(),
                "pattern".into(),
                "size".into(),
            ]];
            for m in &report.materials {
                for (i, l) in m.lobes.iter().enumerate() {
                    rows.push([
                        if i == 0 {
                            m.name.clone()
                        } else {
                            String::new()
                        },
                        l.lobe.to_string(),
                        format!("{} × {}", short(l.mx), short(l.my)),
                        if l.kernel_size == 1 {
                            "identity".into()
                        } else {
                            format!("{0}×{0} @ {1:.3}°", l.kernel_size, l.kernel_texel_deg)
                        },
                        match l.map_1d_size {
                            Some(n) => format!("{0}² sphere + {n} 1D", l.sphere_map_size),
                            None => format!("{0}² sphere", l.sphere_map_size),
                        },
                        format!(
                            "{} samples ({}, {} circles)",
                            l.pattern_samples, l.pattern_spacing, l.pattern_circles
                        ),
                        if i == 0 {
                            human_bytes(m.bytes)
                        } else {
                            String::new()
                        },
                    ]);
                }
            }
            write!(
                out,
                "{}",
                format_table(&rows, &[false, true, false, false, false, false, true])
            )?;
            if let Some(reason) = &report.env_maps_skipped {
                writeln!(out, "environment maps skipped: {reason}")?;
            } else {
                let mut rows = vec![[
                    "reflector".to_string(),
                    "material".into(),
                    "face".into(),
                    "levels".into(),
                    "filter".into(),
                    "size".into(),
                ]];
                rows.extend(report.env_maps.iter().map(|e| {
                    [
                        e.reflector.clone(),
                        e.material.clone(),
                        e.face_size.to_string(),
                        e.levels.to_string(),
                        e.filter.to_string(),
                        human_bytes(e.bytes),
                    ]
                }));
                write!(
                    out,
                    "{}",
                    format_table(&rows, &[false, false, true, true, false, true])
                )?;
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// A roughness for the table: 4 significant digits (0.010000001 → 0.01).
fn short(m: f32) -> String {
    let v: f64 = format!("{:.3e}", m).parse().unwrap_or(m as f64);
    v.to_string()
}
