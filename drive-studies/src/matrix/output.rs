//! The matrix's outputs: the tidy CSV and the Markdown summary.

use super::{Improvement, MatrixCell, MatrixResult};
use drive_eval::Summary;
use std::fmt::Write as _;

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn opt<T: std::fmt::Display>(v: Option<T>) -> String {
    v.map_or(String::new(), |v| v.to_string())
}

impl MatrixResult {
    /// The tidy CSV: one row per combination and metric (`translational_mrmse` in m,
    /// `rotational_mrmse` in rad), empty numbers and the reason in `failure` for a failed fit.
    pub fn to_csv(&self) -> String {
        let mut out = String::from(
            "dataset,robot,terrain,sampler,duration_s,split,seed,learner,powertrain,metric,unit,windows,median,q1,q3,train_windows,fit_s,failure\n",
        );
        for c in &self.cells {
            let s = &c.scenario;
            for (metric, unit, summary) in [
                ("translational_mrmse", "m", c.translational),
                ("rotational_mrmse", "rad", c.rotational),
            ] {
                let _ = writeln!(
                    out,
                    "{},{},{},{},{},{},{},{},{},{metric},{unit},{},{},{},{},{},{:.6},{}",
                    csv_field(&s.dataset),
                    csv_field(&s.robot),
                    opt(s.terrain.as_deref()),
                    opt(s.sampler.as_deref()),
                    opt(s.duration_s),
                    opt(s.split),
                    opt(c.seed),
                    csv_field(&c.model.learner),
                    csv_field(c.model.powertrain.as_deref().unwrap_or("")),
                    summary.map_or(0, |s| s.count),
                    opt(summary.map(|s| s.median)),
                    opt(summary.map(|s| s.q1)),
                    opt(summary.map(|s| s.q3)),
                    c.train_windows,
                    c.fit_seconds,
                    csv_field(c.failure.as_deref().unwrap_or("")),
                );
            }
        }
        out
    }

    /// The Markdown summary: per scenario and model, the median and IQR of both errors (every
    /// run's evaluation windows pooled) and the improvement over the baseline with its
    /// bootstrap confidence interval.
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        let level = 100.0 * self.bootstrap.level;
        let _ = writeln!(s, "# DRIVE evaluation matrix\n");
        let _ = writeln!(
            s,
            "{} combinations. MRMSE over each run's windows (paper eq. 8; DRIVE's are 2 s), median [IQR] of every evaluation window of the scenario's runs pooled. \
             Improvement: `100 (baseline - model) / baseline` of the medians, baseline **{}**, with a {level:.0}% paired bootstrap interval ({} resamples of the evaluation intervals). \
             Every prediction starts from the {} measurements.\n",
            self.cells.len(),
            self.baseline.canonical(),
            self.bootstrap.resamples,
            self.baseline.start.as_str(),
        );
        for r in &self.simulators {
            let _ = writeln!(s, "Simulator of {}: {}.\n", r.robot, r.simulator);
        }
        let _ = writeln!(
            s,
            "| scenario | model | runs | windows | transl. MRMSE [m] | vs baseline | rot. MRMSE [rad] | vs baseline |"
        );
        let _ = writeln!(s, "|---|---|---:|---:|---|---|---|---|");
        let cell = |x: Option<Summary>, digits: usize| {
            x.map_or("failed".into(), |x| {
                format!("{:.d$} [{:.d$}, {:.d$}]", x.median, x.q1, x.q3, d = digits)
            })
        };
        let imp = |i: Option<Improvement>, is_baseline: bool| match i {
            _ if is_baseline => "baseline".to_string(),
            Some(i) => format!("{:+.1}% [{:+.1}, {:+.1}]", i.percent, i.ci[0], i.ci[1]),
            None => "-".to_string(),
        };
        for r in &self.summary {
            let is_base = r.model == self.baseline;
            let _ = writeln!(
                s,
                "| {} | {} | {}{} | {} | {} | {} | {} | {} |",
                r.scenario.label(),
                r.model.canonical(),
                r.runs,
                if r.failed > 0 {
                    format!(" ({} failed)", r.failed)
                } else {
                    String::new()
                },
                r.windows,
                cell(r.translational, 4),
                imp(r.translational_improvement, is_base),
                cell(r.rotational, 4),
                imp(r.rotational_improvement, is_base),
            );
        }
        if !self.notes.is_empty() {
            let _ = writeln!(s, "\n## Notes\n");
            for n in &self.notes {
                let _ = writeln!(s, "- {n}");
            }
        }
        let failures: Vec<&MatrixCell> =
            self.cells.iter().filter(|c| c.failure.is_some()).collect();
        if !failures.is_empty() {
            let _ = writeln!(s, "\n## Failed fits\n");
            for c in failures {
                let _ = writeln!(
                    s,
                    "- {} {}{}: {}",
                    c.scenario.label(),
                    c.model.canonical(),
                    c.seed.map_or(String::new(), |k| format!(" seed {k}")),
                    c.failure.as_deref().unwrap_or("")
                );
            }
        }
        s
    }
}
