//! The closed loop's outputs (`drive track --out DIR`): the paths each model drove against
//! the reference, per training source (PNG and SVG), every run and the summary as CSV, the
//! whole result as JSON and a Markdown table.

use crate::figures::{header, Key, COLOURS};
use crate::ReportError;
use drive_data::output::Outputs;
use drive_studies::{TrackResult, TrackRun};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

const FONT: &str = "sans-serif";
const LABEL: i32 = 16;

/// The figure's file stem for the training source `train` (`paths_uniform`): its letters,
/// digits, '-' and '_' kept, anything else as '_'.
pub fn figure_stem(train: &str) -> String {
    let clean: String = train
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    format!("paths_{clean}")
}

/// Stages `track.json`, `runs.csv`, `summary.csv`, `track.md` and, per training source,
/// the paths figure as PNG and SVG into `dir`; returns the files staged.
pub fn stage(
    result: &TrackResult,
    outputs: &mut Outputs,
    dir: &Path,
) -> Result<Vec<PathBuf>, ReportError> {
    crate::register_font();
    let mut files = Vec::new();
    let json = serde_json::to_string_pretty(result)
        .map_err(|e| ReportError::Draw(format!("track.json: {e}")))?;
    for (name, text) in [
        ("track.json", json),
        ("runs.csv", runs_csv(result)),
        ("summary.csv", summary_csv(result)),
        ("track.md", markdown(result)),
    ] {
        let path = dir.join(name);
        outputs.write(&path, text)?;
        files.push(path);
    }
    let size = figure_size(result);
    for train in &result.training {
        let stem = figure_stem(train);
        for ext in ["png", "svg"] {
            let path = dir.join(format!("{stem}.{ext}"));
            outputs.write_with(&path, |temp| {
                if ext == "png" {
                    crate::write_png(temp, size, |root| paths_figure(root, result, train))
                } else {
                    let root = SVGBackend::new(temp, size).into_drawing_area();
                    paths_figure(&root, result, train)
                }
            })?;
            files.push(path);
        }
    }
    Ok(files)
}

/// The panels of a figure: one per path and speed.
fn panels(result: &TrackResult) -> Vec<(String, f64)> {
    let mut p: Vec<(String, f64)> = Vec::new();
    for r in &result.runs {
        if !p
            .iter()
            .any(|(n, f)| *n == r.path && *f == r.speed_fraction)
        {
            p.push((r.path.clone(), r.speed_fraction));
        }
    }
    p
}

fn figure_size(result: &TrackResult) -> (u32, u32) {
    let n = panels(result).len().max(1) as u32;
    let cols = n.min(3);
    let rows = n.div_ceil(cols);
    ((460 * cols + 40).max(1000), 440 * rows + 110)
}

/// The reference path and each model's first-seed path, one panel per path and speed.
fn paths_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    result: &TrackResult,
    train: &str,
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let mut keys: Vec<(String, Key)> = vec![("reference".into(), Key::Line(BLACK, 2))];
    for (i, m) in result.models.iter().enumerate() {
        keys.push((m.clone(), Key::Line(COLOURS[i % COLOURS.len()], 2)));
    }
    let title = format!(
        "{} on {}, models fitted on {train} ({}; first seed)",
        result.robot, result.terrain, result.controller
    );
    let body = header(root, &title, &keys)?;
    let list = panels(result);
    let cols = list.len().clamp(1, 3);
    let rows = list.len().div_ceil(cols).max(1);
    let areas = body.split_evenly((rows, cols));
    for ((path, fraction), area) in list.iter().zip(areas.iter()) {
        let Some(reference) = result.paths.iter().find(|p| p.path == *path) else {
            continue;
        };
        let seed = result
            .runs
            .iter()
            .filter(|r| r.train == train && r.path == *path && r.speed_fraction == *fraction)
            .map(|r| r.seed)
            .min();
        let runs: Vec<(usize, &TrackRun)> = result
            .models
            .iter()
            .enumerate()
            .filter_map(|(i, m)| {
                result
                    .runs
                    .iter()
                    .find(|r| {
                        r.model == *m
                            && r.train == train
                            && r.path == *path
                            && r.speed_fraction == *fraction
                            && Some(r.seed) == seed
                    })
                    .map(|r| (i, r))
            })
            .collect();
        let xs = reference.points.iter().map(|p| p[0]).chain(
            runs.iter()
                .flat_map(|(_, r)| r.trajectory.iter().map(|p| p[0])),
        );
        let ys = reference.points.iter().map(|p| p[1]).chain(
            runs.iter()
                .flat_map(|(_, r)| r.trajectory.iter().map(|p| p[1])),
        );
        let bound = |v: &mut dyn Iterator<Item = f64>| {
            v.filter(|x| x.is_finite())
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                    (a.min(x), b.max(x))
                })
        };
        let (x0, x1) = bound(&mut xs.into_iter());
        let (y0, y1) = bound(&mut ys.into_iter());
        if !(x0.is_finite() && y0.is_finite()) {
            continue;
        }
        // Equal scales on both axes.
        let (pw, ph) = area.dim_in_pixel();
        let aspect = pw.saturating_sub(80) as f64 / ph.saturating_sub(90).max(1) as f64;
        let half = (((x1 - x0) / aspect).max(y1 - y0) * 1.08).max(0.2) / 2.0;
        let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
        let mut chart = ChartBuilder::on(area)
            .caption(
                format!("{path} at {:.0}% of the top speed", 100.0 * fraction),
                (FONT, LABEL),
            )
            .margin(8)
            .x_label_area_size(36)
            .y_label_area_size(48)
            .build_cartesian_2d(cx - half * aspect..cx + half * aspect, cy - half..cy + half)?;
        chart
            .configure_mesh()
            .x_desc("x [m]")
            .y_desc("y [m]")
            .axis_desc_style((FONT, LABEL - 2))
            .label_style((FONT, LABEL - 4))
            .draw()?;
        chart.draw_series(LineSeries::new(
            reference.points.iter().map(|p| (p[0], p[1])),
            BLACK.stroke_width(2),
        ))?;
        for (i, r) in runs {
            chart.draw_series(LineSeries::new(
                r.trajectory.iter().map(|p| (p[0], p[1])),
                COLOURS[i % COLOURS.len()].stroke_width(2),
            ))?;
        }
    }
    root.present()?;
    Ok(())
}

/// The closed loop as the terminal shows it (`drive track` without `--json`): per training,
/// path and speed, each model's scores, against the first model and against the powertrain
/// model, and whether the robot can drive the path at that speed.
///
/// ```no_run
/// # fn demo(result: &drive_studies::TrackResult) {
/// let text = drive_report::track::text(result);
/// assert!(text.starts_with("Closed loop: "));
/// # }
/// ```
pub fn text(r: &TrackResult) -> String {
    let seeds = r
        .runs
        .iter()
        .map(|x| x.seed)
        .collect::<std::collections::BTreeSet<_>>();
    let mut s = format!(
        "Closed loop: {} on {} with the {} controller; top speed on this ground {:.3} m/s (measured on the simulator); preset paths at scale {:.2} m; {} seed{}\n",
        r.robot,
        r.terrain,
        r.controller,
        r.top_speed_m_s,
        r.path_scale_m,
        seeds.len(),
        if seeds.len() == 1 { "" } else { "s, means over them" }
    );
    let _ = writeln!(s, "simulator: {}", r.simulator);
    if let Some(lead) = r.schedule_s {
        let _ = writeln!(
            s,
            "reference: on a schedule at the asked speed, within {lead} s of travel of the robot (--schedule)"
        );
    }
    let changes = !r.ground_changes.is_empty();
    if changes {
        let _ = writeln!(
            s,
            "ground along the path: {}{}; after change: the cross-track RMS from the first change on",
            r.terrain,
            r.ground_changes
                .iter()
                .map(|c| format!(
                    ", then {} from {}% of the path",
                    c.terrain,
                    drive_traits::limits::Short(100.0 * c.at)
                ))
                .collect::<String>()
        );
    }
    let mut last = None;
    for x in &r.summary {
        let key = (x.train.clone(), x.path.clone(), x.speed_fraction);
        if last.as_ref() != Some(&key) {
            let drivable = r
                .feasibility
                .iter()
                .find(|f| f.path == x.path && f.speed_fraction == x.speed_fraction)
                .map_or(String::new(), |f| match f.yaw_rate_reached_rad_s {
                    Some(reached) => format!(
                        "; {}: its sharpest turn needs {:.2} rad/s, the robot reaches {:.2} rad/s at this speed",
                        if reached >= f.yaw_rate_needed_rad_s {
                            "drivable"
                        } else {
                            "NOT drivable on this ground"
                        },
                        f.yaw_rate_needed_rad_s,
                        reached
                    ),
                    None => format!(
                        "; its sharpest turn needs {:.2} rad/s (what the robot reaches is unknown)",
                        f.yaw_rate_needed_rad_s
                    ),
                });
            let _ = writeln!(
                s,
                "\ntrained on {}, {} at {}% ({:.2} m/s){drivable}",
                x.train,
                x.path,
                drive_traits::limits::Short(100.0 * x.speed_fraction),
                x.speed_fraction * r.top_speed_m_s
            );
            let _ = writeln!(
                s,
                "  {:<18} {:>16} {:>10} {:>12} {:>10} {:>9} {:>7} {:>9} {:>11} {:>10} {:>15}",
                "model",
                "cross-track RMS",
                "max [m]",
                "heading RMS",
                "completed",
                "time [s]",
                "effort",
                "weave/m",
                "history [s]",
                format!("vs {}", r.models.first().map_or("", String::as_str)),
                "vs powertrain"
            );
            if changes {
                s.pop();
                s.push_str("   after change\n");
            }
            last = Some(key);
        }
        let _ = writeln!(
            s,
            "  {:<18} {:>14.3} m {:>10.3} {:>8.3} rad {:>9.0}% {:>9} {:>7.2} {:>9.2} {:>11.2} {:>10} {:>15}",
            x.model,
            x.cross_track_rms_m,
            x.cross_track_max_m,
            x.heading_rms_rad,
            100.0 * x.completed_share,
            x.duration_s.map_or("-".into(), |d| format!("{d:.1}")),
            x.effort,
            x.yaw_rate_sign_changes_per_m,
            x.history_s,
            x.improvement_over_first_percent
                .map_or("-".into(), |p| format!("{p:+.1}%")),
            x.improvement_over_powertrain_percent
                .map_or("-".into(), |p| format!("{p:+.1}%"))
        );
        if changes {
            s.pop();
            let _ = writeln!(
                s,
                " {:>12}",
                x.cross_track_rms_after_change_m
                    .map_or("-".into(), |v| format!("{v:.3} m"))
            );
        }
    }
    let ticks: Vec<f64> = {
        let mut t: Vec<f64> = r.runs.iter().map(|x| x.tick_ms_median).collect();
        t.sort_by(f64::total_cmp);
        t
    };
    if let Some(m) = ticks.get(ticks.len() / 2) {
        let _ = writeln!(
            s,
            "\ncontroller time per tick: median {} ms over the runs (runs in parallel; see BENCHMARKS.md for one core)",
            drive_traits::limits::Short(*m)
        );
    }
    s
}

/// Every run, one row each.
pub fn runs_csv(result: &TrackResult) -> String {
    let mut s = String::from(
        "model,train,path,speed_fraction,speed_m_s,seed,cross_track_rms_m,cross_track_max_m,heading_rms_rad,course_rms_rad,completed,duration_s,effort,command_change_rms,yaw_rate_sign_changes,yaw_rate_sign_changes_per_m,tick_ms_median,length_m,history_s,speed_kept\n",
    );
    for r in &result.runs {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.model,
            csv_text(&r.train),
            csv_text(&r.path),
            r.speed_fraction,
            r.speed_m_s,
            r.seed,
            r.cross_track_rms_m,
            r.cross_track_max_m,
            r.heading_rms_rad,
            r.course_rms_rad,
            r.completed,
            r.duration_s,
            r.effort,
            r.command_change_rms,
            r.yaw_rate_sign_changes,
            r.yaw_rate_sign_changes_per_m,
            r.tick_ms_median,
            r.length_m,
            r.history_s,
            r.speed_kept
        );
    }
    s
}

/// The summary, one row per model, training, path and speed.
pub fn summary_csv(result: &TrackResult) -> String {
    let mut s = String::from(
        "model,train,path,speed_fraction,runs,cross_track_rms_m,cross_track_max_m,heading_rms_rad,course_rms_rad,completed_share,duration_s,effort,command_change_rms,yaw_rate_sign_changes_per_m,feasible,improvement_over_first_percent,improvement_over_powertrain_percent,heading_rms_ratio_to_powertrain,open_loop_translational_median_m,open_loop_rotational_median_rad,history_s,speed_kept,speed_kept_ratio_to_powertrain\n",
    );
    for r in &result.summary {
        let opt = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.model,
            csv_text(&r.train),
            csv_text(&r.path),
            r.speed_fraction,
            r.runs,
            r.cross_track_rms_m,
            r.cross_track_max_m,
            r.heading_rms_rad,
            r.course_rms_rad,
            r.completed_share,
            opt(r.duration_s),
            r.effort,
            r.command_change_rms,
            r.yaw_rate_sign_changes_per_m,
            r.feasible.map_or(String::new(), |f| f.to_string()),
            opt(r.improvement_over_first_percent),
            opt(r.improvement_over_powertrain_percent),
            opt(r.heading_rms_ratio_to_powertrain),
            opt(r.open_loop_translational_median_m),
            opt(r.open_loop_rotational_median_rad),
            r.history_s,
            r.speed_kept,
            opt(r.speed_kept_ratio_to_powertrain)
        );
    }
    s
}

/// A CSV field: quoted when it holds a comma, a quote or a line break.
fn csv_text(v: &str) -> String {
    if v.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", v.replace('"', "\"\""))
    } else {
        v.to_string()
    }
}

/// The summary as Markdown (user text escaped).
pub fn markdown(result: &TrackResult) -> String {
    let esc = |v: &str| {
        v.chars()
            .flat_map(|c| match c {
                '|' | '<' | '>' | '*' | '_' | '`' | '[' | ']' | '\\' => vec!['\\', c],
                c if c.is_control() => vec![' '],
                c => vec![c],
            })
            .collect::<String>()
    };
    let mut s = format!(
        "# Closed loop: {} on {}\n\ncontroller {}; simulator {}; top speed on this terrain {:.3} m/s (measured); preset paths at scale {:.2} m\n\n",
        esc(&result.robot),
        esc(&result.terrain),
        esc(&result.controller),
        esc(&result.simulator.to_string()),
        result.top_speed_m_s,
        result.path_scale_m
    );
    s.push_str("| trained on | path | speed | model | cross-track RMS [m] | max [m] | heading RMS [rad] | completed | time [s] | yaw-rate sign changes per m | vs first model | vs powertrain |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for r in &result.summary {
        let _ = writeln!(
            s,
            "| {} | {} | {:.0}% | {} | {:.3} | {:.3} | {:.3} | {:.0}% | {} | {:.2} | {} | {} |",
            esc(&r.train),
            esc(&r.path),
            100.0 * r.speed_fraction,
            esc(&r.model),
            r.cross_track_rms_m,
            r.cross_track_max_m,
            r.heading_rms_rad,
            100.0 * r.completed_share,
            r.duration_s.map_or("-".into(), |d| format!("{d:.1}")),
            r.yaw_rate_sign_changes_per_m,
            r.improvement_over_first_percent
                .map_or("-".into(), |p| format!("{p:+.1}%")),
            r.improvement_over_powertrain_percent
                .map_or("-".into(), |p| format!("{p:+.1}%"))
        );
    }
    for n in &result.notes {
        let _ = writeln!(s, "\n- {}", esc(n));
    }
    s
}
