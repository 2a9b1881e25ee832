//! DRIVE reports for one dataset: the model comparison, the convergence time and the fitted
//! parameters in `report.md`, and the paper's figures as PNG and SVG (plotters, with an
//! embedded DejaVu Sans font so that no system font is needed):
//!
//! | file | shows | paper |
//! |---|---|---|
//! | `input_space` | naive and true input spaces, commands sent, measured body velocities | Fig. 1 |
//! | `powertrain` | commanded, encoder-measured and modeled inputs (the analysed model's own powertrain: the FOPDT for slip-BLR) | Fig. 3 |
//! | `errors_per_model` | MRMSE box plots per model | Fig. 6 |
//! | `errors_per_protocol` | MRMSE box plots per data-gathering protocol (regions vs uniform) | Fig. 5 |
//! | `convergence` | error against training time (log-log), convergence time marked | Fig. 7 |
//! | `trajectories` | predicted and measured paths with 95% ellipses | |
//! | `calibration` | reliability diagrams: observed against nominal coverage (50-99%) of the predicted position and yaw regions, over every window, the transient and the steady ones | |
//!
//! ```no_run
//! # fn demo(data: &drive_traits::Dataset) -> Result<(), Box<dyn std::error::Error>> {
//! let registries = drive_studies::Registries::builtin();
//! let options = drive_report::ReportOptions::default();
//! // The studies fit and evaluate; the report draws and writes.
//! let analysis = drive_studies::report::ReportAnalysis::build(&registries, data, &options)?;
//! let report = drive_report::Report::new(analysis);
//! let files = report.write(std::path::Path::new("report-out"))?;
//! assert!(files.iter().any(|f| f.ends_with("report.md")));
//! # Ok(()) }
//! ```

#![warn(missing_docs)]

pub mod adapt;
pub mod bench;
pub mod figures;
pub mod track;

use drive_data::output::{OutputError, Outputs};
use drive_eval::Mrmse;
/// What the figures show (computed by the studies: [`drive_studies::report::analysis`]).
pub use drive_studies::report::analysis;
pub use drive_studies::report::{FittedParameters, ReportAnalysis, ReportOptions};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why a report could not be drawn or written.
#[derive(Debug, Error)]
pub enum ReportError {
    /// A file could not be written (nothing was replaced), or an output would replace an
    /// input.
    #[error(transparent)]
    Write(#[from] OutputError),
    /// A figure or a document could not be made.
    #[error("drawing {0}")]
    Draw(String),
}

/// A report: the analyses of [`drive_studies::report`] ([`ReportAnalysis`]), drawn and
/// written. Reads as the analysis it draws (`report.comparison`, `report.convergence`).
pub struct Report {
    analysis: ReportAnalysis,
}

impl std::ops::Deref for Report {
    type Target = ReportAnalysis;
    fn deref(&self) -> &ReportAnalysis {
        &self.analysis
    }
}

impl From<ReportAnalysis> for Report {
    fn from(analysis: ReportAnalysis) -> Self {
        Report { analysis }
    }
}

/// A negative log-likelihood for reading: plain below 10^4, scientific above (an
/// overconfident model's NLL runs to astronomical values).
pub fn nll_text(nll: f64) -> String {
    if !nll.is_finite() {
        "not finite".into()
    } else if nll.abs() < 1e4 {
        format!("{nll:.2}")
    } else {
        format!("{nll:.2e}")
    }
}

/// A fitted parameter for reading: four decimals, scientific notation for values under
/// 10^-3 or from 10^5 on.
fn parameter_text(v: f64) -> String {
    if v == 0.0 || (1e-3..1e5).contains(&v.abs()) {
        format!("{v:.4}")
    } else {
        format!("{v:.3e}")
    }
}

/// Registers the embedded font once (plotters' ab_glyph text renderer has no font of its own).
pub(crate) fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // The font file is part of this crate and parses (tested).
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            include_bytes!("../fonts/DejaVuSans.ttf"),
        );
    });
}

impl Report {
    /// The report of `analysis` (computed by [`ReportAnalysis::build`]).
    pub fn new(analysis: ReportAnalysis) -> Self {
        Report { analysis }
    }

    /// The analyses drawn.
    pub fn analysis(&self) -> &ReportAnalysis {
        &self.analysis
    }

    /// Writes `report.md` and every figure as PNG and SVG into `dir` (created if missing),
    /// all of them or none; returns the files written.
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
        let mut outputs = Outputs::new(&[]);
        self.stage(&mut outputs, dir)?;
        Ok(outputs.publish()?)
    }

    /// Stages `report.md` and every figure as PNG and SVG in `dir` into `outputs` (which
    /// the caller publishes); returns the files staged.
    pub fn stage(&self, outputs: &mut Outputs, dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
        register_font();
        let mut files = Vec::new();
        for (name, _) in self.figures() {
            for ext in ["png", "svg"] {
                let path = dir.join(format!("{name}.{ext}"));
                outputs.write_with(&path, |temp| {
                    if ext == "png" {
                        write_png(temp, self.options.size, |root| self.draw(name, root))
                    } else {
                        let root = SVGBackend::new(temp, self.options.size).into_drawing_area();
                        self.draw(name, &root)
                    }
                })?;
                files.push(path);
            }
        }
        let md = dir.join("report.md");
        outputs.write(&md, self.markdown())?;
        files.push(md);
        Ok(files)
    }

    /// The figures this report draws: file stem and caption.
    pub fn figures(&self) -> Vec<(&'static str, &'static str)> {
        let mut f = vec![
            ("input_space", "Input space (paper Fig. 1)"),
            ("powertrain", "Powertrain (paper Fig. 3)"),
            (
                "errors_per_model",
                "Prediction errors per model (paper Fig. 6)",
            ),
        ];
        if self.protocols.is_ok() {
            f.push((
                "errors_per_protocol",
                "Prediction errors per data-gathering protocol (paper Fig. 5)",
            ));
        }
        f.extend([
            ("convergence", "Convergence (paper Fig. 7)"),
            ("trajectories", "Predicted and measured paths"),
        ]);
        if !self.calibration.is_empty() {
            f.push(("calibration", "Reliability of the predicted uncertainty"));
        }
        f
    }

    fn draw<DB: DrawingBackend>(
        &self,
        name: &str,
        root: &DrawingArea<DB, Shift>,
    ) -> figures::DrawResult
    where
        DB::ErrorType: 'static,
    {
        match name {
            "input_space" => figures::input_space(root, &self.input_space, self.vehicle.as_ref()),
            "powertrain" => figures::powertrain(root, &self.powertrain),
            "errors_per_model" => {
                let groups: Vec<(String, Vec<Mrmse>)> = self
                    .comparison
                    .models
                    .iter()
                    .map(|m| {
                        (
                            m.name.clone(),
                            m.report.windows.iter().map(|w| w.error).collect(),
                        )
                    })
                    .collect();
                figures::error_boxes(
                    root,
                    &format!(
                        "Prediction errors per model ({} evaluation windows, 2 s horizon, eq. 8)",
                        self.comparison.eval_windows
                    ),
                    &groups,
                )
            }
            "errors_per_protocol" => {
                let Ok(p) = &self.protocols else {
                    return Ok(());
                };
                let mut groups = Vec::new();
                for r in &p.regions {
                    groups.push((format!("{} region", r.region), r.region_errors.clone()));
                    groups.push((
                        format!("uniform (as {})", r.region),
                        r.uniform_errors.clone(),
                    ));
                }
                figures::error_boxes(
                    root,
                    &format!(
                        "Prediction errors per protocol ({} trained on a region or on as many uniform intervals)",
                        p.model
                    ),
                    &groups,
                )
            }
            "convergence" => figures::convergence(root, &self.options.model, &self.convergence),
            "trajectories" => figures::trajectories(root, &self.trajectories),
            "calibration" => figures::calibration(root, &self.calibration, self.dt),
            other => Err(format!("no figure named {other}").into()),
        }
    }

    /// The terrain's unpredictability and how each model's error grows with it.
    fn unpredictability_section(&self, s: &mut String) {
        let u = &self.unpredictability;
        let _ = writeln!(s, "\n## The terrain's unpredictability\n");
        let _ = writeln!(
            s,
            "How far the motion the robot made is from the motion it was commanded, as kinetic energy (the T-FR 2025 follow-up's metric: 0 when the robot moves as commanded, 1 when it does not move; median over the {} windows' samples; see docs/benchmark.md).\n",
            u.pooled
        );
        let cell = |v: Option<drive_eval::UnpredictabilitySummary>| {
            v.map_or("-".to_string(), |v| {
                format!(
                    "{:.3} [{:.3}, {:.3}] ({} samples)",
                    v.median, v.iqr[0], v.iqr[1], v.samples
                )
            })
        };
        let _ = writeln!(s, "| kind | median [IQR] |\n|---|---|");
        let _ = writeln!(s, "| translational | {} |", cell(u.translational));
        let _ = writeln!(s, "| rotational | {} |", cell(u.rotational));
        let _ = writeln!(
            s,
            "| total | {} |",
            match (&self.options.body, u.total) {
                (Some((from, _)), Some(t)) => format!("{} (body: {from})", cell(Some(t))),
                _ => "- (needs the robot's body size: --robot with body_length and body_width)"
                    .to_string(),
            }
        );
        let _ = writeln!(
            s,
            "\nEach model's error against its evaluation windows' unpredictability: Spearman's correlation (translational error with translational unpredictability, rotational with rotational) and the median errors in the thirds of the windows sorted by their {} unpredictability.\n",
            if u.total.is_some() { "total" } else { "translational" }
        );
        let _ = writeln!(
            s,
            "| model | Spearman t | Spearman r | low third (t / r) | middle third | high third |\n|---|---|---|---|---|---|"
        );
        for m in &self.comparison.models {
            let g = drive_studies::ErrorGrowth::of(&m.report, u);
            let r = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:+.2}"));
            let third = |i: usize| {
                g.thirds.get(i).map_or("-".to_string(), |t| {
                    format!(
                        "{:.4} / {:.4}",
                        t.translational_median_m, t.rotational_median_rad
                    )
                })
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} |",
                m.name,
                r(g.spearman_translational),
                r(g.spearman_rotational),
                third(0),
                third(1),
                third(2)
            );
        }
    }

    /// The Markdown report.
    pub fn markdown(&self) -> String {
        let mut s = String::new();
        let c = &self.comparison;
        let _ = writeln!(s, "# DRIVE report: {}\n", self.dataset);
        let _ = writeln!(
            s,
            "Training: first {} intervals ({} windows); evaluation: last {} intervals ({} windows); split {}. Positions in the {} frame ({}).\n",
            c.train_intervals,
            c.train_windows,
            c.eval_intervals,
            c.eval_windows,
            c.split,
            c.position_frame,
            if c.position_frame == "paper-mean5" {
                "the paper parser's, as published; --frame corrected rotates them"
            } else {
                "each window's first sample, like yaw"
            }
        );
        if !self.data_checks.is_empty() {
            let _ = writeln!(
                s,
                "**The data checks found** (`drive check` says more; the numbers below are read with them):\n"
            );
            for f in &self.data_checks {
                let _ = writeln!(s, "- {f}");
            }
            let _ = writeln!(s);
        }
        let _ = writeln!(
            s,
            "## Model comparison (MRMSE over {} s windows, eq. 8)\n",
            drive_traits::limits::Short(c.window_s)
        );
        let _ = writeln!(
            s,
            "| model | powertrain | transl. median [m] | transl. IQR [m] | rot. median [rad] | rot. IQR [rad] | vs naive (transl. / rot.) |"
        );
        let _ = writeln!(s, "|---|---|---:|---|---:|---|---|");
        for m in &c.models {
            let _ = writeln!(
                s,
                "| {} | {} | {:.4} | [{:.4}, {:.4}] | {:.4} | [{:.4}, {:.4}] | {:+.1}% / {:+.1}% |",
                m.name,
                m.powertrain.as_deref().unwrap_or("-"),
                m.translational_median_m,
                m.translational_iqr_m[0],
                m.translational_iqr_m[1],
                m.rotational_median_rad,
                m.rotational_iqr_rad[0],
                m.rotational_iqr_rad[1],
                m.all.translational_m.improvement_over_naive_percent,
                m.all.rotational_rad.improvement_over_naive_percent,
            );
        }
        self.unpredictability_section(&mut s);
        let conv = &self.convergence;
        let _ = writeln!(s, "\n## Convergence (Fig. 7)\n");
        match conv.convergence_time_s {
            Some(t) => {
                let _ = writeln!(
                    s,
                    "{} converges after **{t:.1} s** of training driving (every later gradient under {} m/s and {} rad/s; the paper found 46 s for slip-BLR).",
                    conv.model, conv.thresholds[0], conv.thresholds[1]
                );
            }
            None => {
                let _ = writeln!(
                    s,
                    "{}'s curve never meets the convergence rule on this data.",
                    conv.model
                );
            }
        }
        if let Some(o) = &conv.random_orders {
            let _ = match (o.convergence_time_s, o.median_convergence_time_s) {
                (Some([lo, _, hi]), Some(med)) => writeln!(
                    s,
                    "\nOver {} random orders of the training intervals (seed {}), the same rule gives a median of **{med:.1} s** (range {lo:.1} to {hi:.1} s){}: how much the recording order's figure owes to the order the commands came in.",
                    o.orders,
                    o.seed,
                    if o.never_converged > 0 {
                        format!("; {} orders never converge", o.never_converged)
                    } else {
                        String::new()
                    }
                ),
                (Some([lo, _, hi]), None) => writeln!(
                    s,
                    "\nOver {} random orders of the training intervals (seed {}), {} never meet the rule, so their median is never (the others converge after {lo:.1} to {hi:.1} s).",
                    o.orders, o.seed, o.never_converged
                ),
                (None, _) => writeln!(
                    s,
                    "\nNone of {} random orders of the training intervals meets the rule.",
                    o.orders
                ),
            };
        }
        let _ = writeln!(
            s,
            "\nFitting along the curve: {}.",
            if conv.fitting == "online" {
                "online (the slip posterior updated interval by interval from its sufficient statistics, the powertrain refitted each time the data grew by half, the last amount fitted as in batch)"
            } else {
                "every amount fitted from scratch"
            }
        );
        let _ = writeln!(s, "\n## Fitted parameters (training part)\n");
        let _ = writeln!(
            s,
            "The vehicle's geometry and each compared model's parameters, as its parts list them (a plug-in part lists its own). Input axes: {}.\n",
            self.vehicle
                .axes()
                .iter()
                .enumerate()
                .map(|(i, a)| format!("axis {i} = {} [{}]", a.name, a.unit))
                .collect::<Vec<_>>()
                .join(", ")
        );
        let _ = writeln!(s, "| vehicle geometry | value |\n|---|---:|");
        for (name, v) in self.vehicle.geometry() {
            let _ = writeln!(s, "| {name} | {} |", parameter_text(v));
        }
        for f in &self.fitted {
            let _ = writeln!(s, "\n**{}**\n", f.model);
            if f.parameters.is_empty() {
                let _ = writeln!(s, "No fitted parameter (the vehicle's geometry only).");
                continue;
            }
            let _ = writeln!(s, "| parameter | value |\n|---|---:|");
            for (name, v) in &f.parameters {
                let _ = writeln!(s, "| {name} | {} |", parameter_text(*v));
            }
        }
        let _ = writeln!(s, "\n## Uncertainty calibration\n");
        if self.calibration.is_empty() {
            let _ = writeln!(s, "No model gives covariances.");
        }
        if !self.calibration.is_empty() {
            let _ = writeln!(
                s,
                "Uncertainty: {}; predictions start from {}. Share of the measured poses inside the predicted 95% regions (a calibrated model holds 95%), and the reliability diagrams (`calibration.png`: observed against nominal coverage, 50% to 99%, over every window, then the transient and the steady ones).\n",
                self.options.uncertainty.as_str(),
                self.options.start.as_str()
            );
            // A calibration asked for but not made: said, with the models it concerns.
            let uncalibrated: Vec<&str> = self
                .comparison
                .models
                .iter()
                .filter(|m| m.uncertainty.is_some_and(|u| u != self.options.uncertainty))
                .map(|m| m.name.as_str())
                .collect();
            if !uncalibrated.is_empty() {
                let _ = writeln!(
                    s,
                    "**Not calibrated**: {} (the calibration holds out blocks of training intervals: too few training intervals, or a fold's refit failed); their regions are the model's own covariance, with no promise of 95%.\n",
                    uncalibrated.join(", ")
                );
            }
            let _ = writeln!(
                s,
                "| model | position 0.5 / 1 / 2 s | yaw 0.5 / 1 / 2 s | all steps (position) | NLL [nats/step] |"
            );
            let _ = writeln!(s, "|---|---|---|---|---|");
        }
        for cal in &self.calibration {
            let at = |c: &std::collections::BTreeMap<String, f64>| {
                ["0.5", "1.0", "2.0"]
                    .map(|h| {
                        c.get(h)
                            .map_or("-".to_string(), |f| format!("{:.1}%", 100.0 * f))
                    })
                    .join(" / ")
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.1}% | {}{} |",
                cal.model,
                at(&cal.coverage95),
                at(&cal.yaw_coverage95),
                100.0 * cal.inside_overall,
                nll_text(cal.mean_nll),
                if cal.degenerate > 0 {
                    format!(
                        " ({} steps with a degenerate covariance counted as outside)",
                        cal.degenerate
                    )
                } else {
                    String::new()
                }
            );
        }
        // The last horizon the windows reach (2 s for the paper's; a 1 s window's is 1 s):
        // where the figures below are taken.
        let last = self
            .calibration
            .first()
            .and_then(|c| c.coverage95.keys().last().cloned())
            .unwrap_or_else(|| "2.0".into());
        let last_s = last.parse::<f64>().map_or(last.clone(), |h| format!("{h}"));
        if !self.calibration.is_empty() {
            let _ = writeln!(
                s,
                "\nWhich predictions the regions say are hard, at {last_s} s: position coverage per phase (the diagram's second and third panels) and per third of the commanded speed; the mean region area over the smallest constant circle of the same coverage (under 1: the regions say more than one radius would); the rank correlation of each window's predicted spread with its error.\n"
            );
            let _ = writeln!(
                s,
                "| model | transient / steady | speed low / mid / high | area ratio | rank corr. position / yaw |"
            );
            let _ = writeln!(s, "|---|---|---|---|---|");
        }
        for cal in &self.calibration {
            let at = |groups: &drive_eval::GroupCoverage, keys: &[&str]| {
                keys.iter()
                    .map(|k| {
                        groups
                            .get(*k)
                            .and_then(|h| h.get(&last))
                            .map_or("-".to_string(), |f| format!("{:.1}%", 100.0 * f))
                    })
                    .collect::<Vec<_>>()
                    .join(" / ")
            };
            let rank = |k: &str| {
                cal.error_rank_correlation
                    .get(k)
                    .map_or("-".to_string(), |v| format!("{v:+.2}"))
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} / {} |",
                cal.model,
                at(&cal.coverage95_by_phase, &["transient", "steady"]),
                at(&cal.coverage95_by_speed, &["low", "mid", "high"]),
                if cal.area_ratio_to_constant.is_finite() {
                    format!("{:.2}", cal.area_ratio_to_constant)
                } else {
                    "-".to_string()
                },
                rank("position"),
                rank("yaw")
            );
        }
        let _ = writeln!(s, "\n## Data-gathering protocols on this data (Fig. 5)\n");
        match &self.protocols {
            Ok(p) => {
                for r in &p.regions {
                    let _ = writeln!(
                        s,
                        "- {} region ({}, {} intervals): {:.4} m / {:.4} rad; as many uniform intervals ({} draws): {:.4} m / {:.4} rad.",
                        r.region,
                        r.definition,
                        r.intervals,
                        r.region_translational.median,
                        r.region_rotational.median,
                        p.draws,
                        r.uniform_translational_median_m,
                        r.uniform_rotational_median_rad
                    );
                }
            }
            Err(e) => {
                let _ = writeln!(s, "Not drawn: {e}.");
            }
        }
        let _ = writeln!(s, "\n## Figures\n");
        for (name, caption) in self.figures() {
            let _ = writeln!(
                s,
                "### {caption}\n\n![{caption}]({name}.png)\n\n([SVG]({name}.svg))\n"
            );
        }
        s
    }
}

/// Writes a PNG figure of `size` (pixels) at `path`: drawn by `draw` into an RGB buffer,
/// then encoded with the `png` crate.
pub(crate) fn write_png(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> figures::DrawResult,
) -> figures::DrawResult {
    let (w, h) = size;
    let mut pixels = vec![0u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, size).into_drawing_area();
        draw(&root)?;
        root.present()?;
    }
    let file = std::io::BufWriter::new(std::fs::File::create(path)?);
    let mut encoder = png::Encoder::new(file, w, h);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(&pixels)?;
    writer.finish()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_embedded_font_parses() {
        assert!(plotters::style::register_font(
            "test-font",
            plotters::style::FontStyle::Normal,
            include_bytes!("../fonts/DejaVuSans.ttf"),
        )
        .is_ok());
    }
}
