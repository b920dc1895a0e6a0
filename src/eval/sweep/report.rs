//! A sweep's outputs: `sweep.csv` and `sweep.svg` (error against bake and frame time, one
//! curve per knob).

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{Row, SweepError};

/// The rows as CSV with a header line; empty fields where a figure was not measured.
pub fn to_csv(rows: &[Row]) -> String {
    let mut s = String::from(
        "knob,value,bake_seconds,stage_seconds,bundle_bytes,frame_ms,gpu_ms,rmse,rel_rmse,psnr_db,max_error\n",
    );
    let opt = |v: Option<f64>, digits: usize| v.map_or(String::new(), |v| format!("{v:.digits$}"));
    for r in rows {
        let m = &r.metrics;
        s += &format!(
            "{},{},{:.4},{},{},{},{},{:.6},{:.6},{:.3},{:.6}\n",
            r.knob,
            r.value,
            r.bake_seconds,
            opt(r.stage_seconds, 4),
            r.bundle_bytes,
            opt(r.frame_ms, 3),
            opt(r.gpu_ms, 3),
            m.rmse,
            m.rel_rmse,
            m.psnr_db,
            m.max_error
        );
    }
    s
}

/// The plot as SVG (plotters): relative RMSE against bake time and, when view knobs were
/// timed, against frame time; log axes, one curve per knob, each point labelled with its
/// value.
pub fn plot_svg(title: &str, rows: &[Row]) -> Result<String, SweepError> {
    // Frame time is the cost of a view knob; stage knobs barely change it (it is in the CSV).
    let timed = rows
        .iter()
        .any(|r| r.frame_ms.is_some() && r.knob.starts_with("view."));
    let mut svg = String::new();
    {
        let size = if timed { (1200, 480) } else { (640, 480) };
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let root = root
            .titled(
                &format!("{title}: error vs time, one curve per knob"),
                ("sans-serif", 18),
            )
            .map_err(plot_err)?;
        let mut knobs: Vec<&str> = Vec::new();
        for r in rows {
            if !knobs.contains(&r.knob.as_str()) {
                knobs.push(&r.knob);
            }
        }
        if timed {
            let panels = root.split_evenly((1, 2));
            // View knobs change no bake: they are plotted against frame time only.
            panel(&panels[0], rows, &knobs, "bake time (s, log)", |r| {
                r.stage_seconds.map(|_| r.bake_seconds)
            })?;
            panel(&panels[1], rows, &knobs, "frame time (ms, log)", |r| {
                r.frame_ms
            })?;
        } else {
            panel(&root, rows, &knobs, "bake time (s, log)", |r| {
                Some(r.bake_seconds)
            })?;
        }
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}

fn plot_err(e: impl std::fmt::Display) -> SweepError {
    SweepError::Plot(e.to_string())
}

/// Colours of the curves (Tableau 10).
const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    rows: &[Row],
    knobs: &[&str],
    x_desc: &str,
    x: impl Fn(&Row) -> Option<f64>,
) -> Result<(), SweepError> {
    // Log axes need positive values: a 0 s bake (a view knob's) sits at 0.1 ms.
    let pts: Vec<(&Row, f64, f64)> = rows
        .iter()
        .filter_map(|r| Some((r, x(r)?.max(1e-4), r.metrics.rel_rmse.max(1e-6))))
        .collect();
    let xr = log_range(pts.iter().map(|p| p.1));
    let yr = log_range(pts.iter().map(|p| p.2));
    // Head room for the legend, one line per knob.
    let yr = yr.start..yr.end * 1.25f64.powi(knobs.len() as i32);
    let mut chart = ChartBuilder::on(area)
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(
            xr.clone().log_scale().with_key_points(ticks(xr)),
            yr.clone().log_scale().with_key_points(ticks(yr)),
        )
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc("relative RMSE vs reference (log)")
        .x_label_formatter(&|v| short(*v))
        .y_label_formatter(&|v| short(*v))
        .draw()
        .map_err(plot_err)?;
    for (k, name) in knobs.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        let mine: Vec<(f64, f64, &str)> = pts
            .iter()
            .filter(|p| p.0.knob == *name)
            .map(|p| (p.1, p.2, p.0.value.as_str()))
            .collect();
        if mine.is_empty() {
            continue;
        }
        chart
            .draw_series(LineSeries::new(
                mine.iter().map(|p| (p.0, p.1)),
                colour.stroke_width(2),
            ))
            .map_err(plot_err)?
            .label(*name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        chart
            .draw_series(mine.iter().map(|&(x, y, v)| {
                EmptyElement::at((x, y))
                    + Circle::new((0, 0), 4, colour.filled())
                    + Text::new(
                        v.to_string(),
                        (6, -16),
                        ("sans-serif", 12).into_font().color(&colour),
                    )
            }))
            .map_err(plot_err)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(plot_err)?;
    Ok(())
}

/// A log axis range around the values: 30% beyond them, at least a factor 4 wide.
fn log_range(v: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = v.fold((f64::INFINITY, 0.0f64), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    });
    if !lo.is_finite() {
        return 0.1..1.0;
    }
    let widen = (4.0 / (hi / lo)).sqrt().max(1.3);
    lo / widen..hi * widen
}

/// 1-2-5 ticks per decade inside `r`; 1 … 9 when that gives fewer than three.
fn ticks(r: std::ops::Range<f64>) -> Vec<f64> {
    let within = |mantissas: &[f64]| {
        let mut v = Vec::new();
        for d in (r.start.log10().floor() as i32)..=(r.end.log10().ceil() as i32) {
            for &m in mantissas {
                let t = m * 10f64.powi(d);
                if r.contains(&t) {
                    v.push(t);
                }
            }
        }
        v
    };
    let v = within(&[1.0, 2.0, 5.0]);
    if v.len() >= 3 {
        return v;
    }
    within(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
}

/// A tick label: a few significant digits, no trailing zeros.
fn short(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    if (1e-3..1e5).contains(&v.abs()) {
        let digits = (3 - v.abs().log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{v:.1e}")
    }
}
