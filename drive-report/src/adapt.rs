//! The adaptation study's outputs (`drive adapt --out DIR`): the whole result as JSON, the
//! curves as CSV, and their figure (PNG and SVG): per learner, the translational and the
//! rotational median against the seconds of the target driven, one line per model.

use crate::figures::{header, Key, COLOURS};
use crate::ReportError;
use drive_data::output::Outputs;
use drive_studies::Adaptation;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

const FONT: &str = "sans-serif";
const LABEL: i32 = 16;

/// The models of a curve, in the order drawn (`library` only where a terrain library was
/// given).
const MODELS: [&str; 5] = ["adaptive", "frozen", "scratch", "own", "library"];

/// Stages `adapt.json`, `curve.csv` and `curves.png` / `curves.svg` into `dir`; returns
/// the files staged.
pub fn stage(
    result: &Adaptation,
    outputs: &mut Outputs,
    dir: &Path,
) -> Result<Vec<PathBuf>, ReportError> {
    crate::register_font();
    let mut files = Vec::new();
    let json = serde_json::to_string_pretty(result)
        .map_err(|e| ReportError::Draw(format!("adapt.json: {e}")))?;
    for (name, text) in [("adapt.json", json), ("curve.csv", curve_csv(result))] {
        let path = dir.join(name);
        outputs.write(&path, text)?;
        files.push(path);
    }
    let size = (1000, 380 * learners(result).len().max(1) as u32 + 110);
    for ext in ["png", "svg"] {
        let path = dir.join(format!("curves.{ext}"));
        outputs.write_with(&path, |temp| {
            if ext == "png" {
                crate::write_png(temp, size, |root| curves_figure(root, result))
            } else {
                let root = SVGBackend::new(temp, size).into_drawing_area();
                curves_figure(&root, result)
            }
        })?;
        files.push(path);
    }
    Ok(files)
}

/// The curves as CSV: one row per learner, model and time.
///
/// ```
/// # use drive_studies::{Adaptation, AdaptPoint};
/// let a = Adaptation { prior: "a".into(), target: "b".into(), split: 0.5, train_s: 60.0, train_windows: 30,
///     evaluation_windows: 30, extrapolation: None, notes: Vec::new(), library: Vec::new(),
///     curve: vec![AdaptPoint { learner: "slip-blr".into(), model: "frozen", t_s: 0.0,
///         translational_median_m: Some(0.25), rotational_median_rad: Some(0.5),
///         ground_changed: None, note: None, weights: None }] };
/// assert_eq!(drive_report::adapt::curve_csv(&a).lines().nth(1), Some("slip-blr,frozen,0,0.25,0.5,"));
/// ```
pub fn curve_csv(result: &Adaptation) -> String {
    let mut s = String::from(
        "learner,model,t_s,translational_median_m,rotational_median_rad,ground_changed\n",
    );
    let num = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
    for p in &result.curve {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{}",
            p.learner,
            p.model,
            p.t_s,
            num(p.translational_median_m),
            num(p.rotational_median_rad),
            p.ground_changed.map_or(String::new(), |c| c.to_string())
        );
    }
    s
}

fn learners(result: &Adaptation) -> Vec<&str> {
    let mut l: Vec<&str> = Vec::new();
    for p in &result.curve {
        if !l.contains(&p.learner.as_str()) {
            l.push(&p.learner);
        }
    }
    l
}

/// Per learner, two panels (translational, rotational median) of the four models' curves.
fn curves_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    result: &Adaptation,
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let keys: Vec<(String, Key)> = MODELS
        .iter()
        .enumerate()
        .filter(|(_, m)| result.curve.iter().any(|p| p.model == **m))
        .map(|(i, m)| (m.to_string(), Key::Line(COLOURS[i % COLOURS.len()], 2)))
        .collect();
    let title = format!(
        "{} adapting to {} (eq. 8 medians over its evaluation half)",
        result.prior, result.target
    );
    let body = header(root, &title, &keys)?;
    let list = learners(result);
    let areas = body.split_evenly((list.len().max(1), 2));
    for (row, learner) in list.iter().enumerate() {
        for (col, (what, unit)) in [("translational", "m"), ("rotational", "rad")]
            .iter()
            .enumerate()
        {
            let area = &areas[row * 2 + col];
            let value = |p: &drive_studies::AdaptPoint| {
                if col == 0 {
                    p.translational_median_m
                } else {
                    p.rotational_median_rad
                }
            };
            let points: Vec<(&str, f64, f64)> = result
                .curve
                .iter()
                .filter(|p| p.learner == *learner)
                .filter_map(|p| value(p).map(|v| (p.model, p.t_s, v)))
                .filter(|(_, t, v)| t.is_finite() && v.is_finite())
                .collect();
            let t1 = points.iter().map(|p| p.1).fold(1.0f64, f64::max);
            let v1 = points.iter().map(|p| p.2).fold(1e-6f64, f64::max) * 1.1;
            let mut chart = ChartBuilder::on(area)
                .caption(format!("{learner}: {what} median"), (FONT, LABEL))
                .margin(8)
                .x_label_area_size(36)
                .y_label_area_size(56)
                .build_cartesian_2d(0.0..t1, 0.0..v1)?;
            chart
                .configure_mesh()
                .x_desc("target driven [s]")
                .y_desc(format!("median [{unit}]"))
                .axis_desc_style((FONT, LABEL - 2))
                .label_style((FONT, LABEL - 4))
                .draw()?;
            for (i, model) in MODELS.iter().enumerate() {
                let line: Vec<(f64, f64)> = points
                    .iter()
                    .filter(|p| p.0 == *model)
                    .map(|p| (p.1, p.2))
                    .collect();
                let colour = COLOURS[i % COLOURS.len()];
                chart.draw_series(LineSeries::new(line.clone(), colour.stroke_width(2)))?;
                chart.draw_series(line.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
            }
        }
    }
    root.present()?;
    Ok(())
}
