//! How the stage tools print what a bake did: `glint-bake`'s stage table, the materials
//! stage's lobe and environment-map tables and the SRDM stage's view table. Each report
//! prints its own table (`Display`); the tools only choose between it and JSON.

use std::fmt;
use std::path::PathBuf;

use super::materials::Report as MaterialsReport;
use super::srdm_stage::ViewReport;
use super::{StageReport, StageStatus};
use crate::bundle::stats::{format_table, human_bytes};

/// What `glint-bake` did: every stage, in dependency order.
#[derive(Clone, Debug, PartialEq)]
pub struct BakeReport {
    /// The scene's name.
    pub scene: String,
    /// The bundle baked into.
    pub bundle: PathBuf,
    /// One line per stage.
    pub stages: Vec<StageReport>,
}

impl BakeReport {
    /// The status column: a stage that found nothing to bake says why; a stage not needed
    /// says it in the reason column.
    fn status(r: &StageReport) -> String {
        match &r.status {
            StageStatus::Skipped { reason } if *reason != r.plan.reason => {
                format!("skipped: {reason}")
            }
            s => s.to_string(),
        }
    }

    /// `{"bundle", "stages": [{"stage", "needed", "status", "reason"}]}`.
    pub fn to_json(&self) -> serde_json::Value {
        let stages: Vec<_> = self
            .stages
            .iter()
            .map(|r| {
                serde_json::json!({
                    "stage": r.plan.stage,
                    "needed": r.plan.needed,
                    "status": Self::status(r),
                    "reason": r.plan.reason,
                })
            })
            .collect();
        serde_json::json!({ "bundle": crate::lossy_path::json(&self.bundle), "stages": stages })
    }
}

impl fmt::Display for BakeReport {
    /// `SCENE: BUNDLE`, then a table: stage, needed, status, reason.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut rows = vec![[
            "stage".to_string(),
            "needed".into(),
            "status".into(),
            "reason".into(),
        ]];
        rows.extend(self.stages.iter().map(|r| {
            [
                r.plan.stage.name().to_string(),
                if r.plan.needed { "yes" } else { "no" }.into(),
                Self::status(r),
                r.plan.reason.clone(),
            ]
        }));
        writeln!(f, "{}: {}", self.scene, self.bundle.display())?;
        write!(f, "{}", format_table(&rows, &[false; 4]))
    }
}

/// A roughness for a table: 4 significant digits (0.010000001 → 0.01).
fn short(m: f32) -> String {
    let v: f64 = format!("{m:.3e}").parse().unwrap_or(m as f64);
    v.to_string()
}

impl fmt::Display for MaterialsReport {
    /// One row per lobe (kernel, R maps, pattern, bytes per material), then the environment
    /// maps or why there are none.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut rows = vec![[
            "material".to_string(),
            "lobe".into(),
            "mx × my".into(),
            "kernel K".into(),
            "R maps".into(),
            "pattern".into(),
            "size".into(),
        ]];
        for m in &self.materials {
            for (i, l) in m.lobes.iter().enumerate() {
                let first = |s: String| if i == 0 { s } else { String::new() };
                rows.push([
                    first(m.name.clone()),
                    if l.model.is_kurt() {
                        l.lobe.to_string()
                    } else {
                        format!("{} ({})", l.lobe, l.model.name())
                    },
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
                    first(human_bytes(m.bytes)),
                ]);
            }
        }
        write!(
            f,
            "{}",
            format_table(&rows, &[false, true, false, false, false, false, true])
        )?;
        if let Some(reason) = &self.env_maps_skipped {
            return writeln!(f, "environment maps skipped: {reason}");
        }
        let mut rows = vec![[
            "reflector".to_string(),
            "material".into(),
            "face".into(),
            "levels".into(),
            "filter".into(),
            "size".into(),
        ]];
        if let Some(reason) = &self.probes_skipped {
            writeln!(f, "reflection probes skipped: {reason}")?;
        }
        rows.extend(self.env_maps.iter().chain(&self.probes).map(|e| {
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
            f,
            "{}",
            format_table(&rows, &[false, false, true, true, false, true])
        )
    }
}

/// The SRDM stage's views as a table: coverage, times, errors and bytes per view.
pub struct SrdmViews<'a>(pub &'a [ViewReport]);

impl fmt::Display for SrdmViews<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut rows = vec![[
            "impostor".to_string(),
            "view".into(),
            "coverage".into(),
            "capture ms".into(),
            "build ms".into(),
            "rel. z error".into(),
            "max row error".into(),
            "rows dropping spans".into(),
            "srdm".into(),
            "capture".into(),
        ]];
        for v in self.0 {
            rows.push([
                v.impostor.clone(),
                v.view.to_string(),
                format!("{:.1} %", 100.0 * v.coverage),
                format!("{:.1}", 1e3 * v.capture_seconds),
                format!("{:.1}", 1e3 * v.build_seconds),
                format!("{:.3} %", 100.0 * v.errors.mean_relative_z_error),
                format!("{:.2e}", v.errors.max_row_error),
                v.errors.rows_dropping_spans.to_string(),
                human_bytes(v.srdm_bytes),
                human_bytes(v.capture_bytes),
            ]);
        }
        let mut right = [true; 10];
        right[0] = false;
        write!(f, "{}", format_table(&rows, &right))
    }
}
