//! The paper's Fig. 7 analysis: prediction error against training driving time.

use crate::{run_cells, split_by_interval, Setting, SplitError, Summary};
use drive_models::ModelSpec;
use drive_traits::{Dataset, WindowSet};
use serde::Serialize;

/// One point of the convergence curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ConvergencePoint {
    /// Driving time of the training data (s): intervals x interval duration.
    pub training_time_s: f64,
    /// Training intervals used.
    pub intervals: usize,
    /// Median translational MRMSE on the evaluation windows (m).
    pub translational_median_m: f64,
    /// Median rotational MRMSE on the evaluation windows (rad).
    pub rotational_median_rad: f64,
}

/// An amount of training data the model could not be fitted on.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SkippedPoint {
    /// Training intervals.
    pub intervals: usize,
    /// Why the fit failed.
    pub reason: String,
}

/// The convergence analysis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Convergence {
    /// The model (its full name).
    pub model: String,
    /// The paper's rule (Sec. IV-C): the smallest training time from which every later
    /// step's gradient of both errors with respect to training time stays under the
    /// thresholds; `None` when the curve never meets it.
    pub convergence_time_s: Option<f64>,
    /// Thresholds on |d error / d training time|: (m/s, rad/s).
    pub thresholds: [f64; 2],
    /// Duration of one training interval (s).
    pub interval_s: f64,
    /// Evaluation windows (always the same).
    pub eval_windows: usize,
    /// The curve, in increasing training time.
    pub curve: Vec<ConvergencePoint>,
    /// Amounts of training data that could not be fitted (too little excitation).
    pub skipped: Vec<SkippedPoint>,
}

/// Trains `model` on the first 1, 2, 3, ... intervals of the training part of the `split`
/// (in recording order) and evaluates every fit on the same evaluation part; the fits run in
/// parallel (the experiment engine).
pub fn convergence(
    data: &Dataset,
    split: f64,
    thresholds: [f64; 2],
    model: &ModelSpec,
) -> Result<Convergence, SplitError> {
    let (train, eval) = split_by_interval(data, split)?;
    let train_intervals = train.windows.last().map_or(0, |w| w.interval + 1);
    let window_s = data.robot.window_len as f64 / data.robot.rate_hz;
    // The mean number of windows per interval of the whole dataset (3 in DRIVE).
    let interval_s = window_s * data.windows.len() as f64 / data.interval_count().max(1) as f64;
    let settings: Vec<Setting<'_>> = (1..=train_intervals)
        .map(|n| {
            let cut = train.windows.partition_point(|w| w.interval < n);
            Setting {
                train: WindowSet {
                    robot: train.robot,
                    windows: train.windows[..cut].to_vec(),
                },
                eval: eval.clone(),
            }
        })
        .collect();
    let cells = run_cells(&settings, std::slice::from_ref(model), false, &|| {});
    let mut curve = Vec::new();
    let mut skipped = Vec::new();
    for cell in cells {
        let n = cell.setting + 1;
        match cell.outcome {
            Ok(scored) => {
                // The evaluation set is non-empty (guaranteed by the split).
                let (t, r) = (
                    scored.report.translational(None),
                    scored.report.rotational(None),
                );
                if let (Some(Summary { median: tm, .. }), Some(Summary { median: rm, .. })) = (t, r)
                {
                    curve.push(ConvergencePoint {
                        training_time_s: n as f64 * interval_s,
                        intervals: n,
                        translational_median_m: tm,
                        rotational_median_rad: rm,
                    });
                }
            }
            Err(e) => skipped.push(SkippedPoint {
                intervals: n,
                reason: e.to_string(),
            }),
        }
    }
    Ok(Convergence {
        model: model.canonical(),
        convergence_time_s: convergence_time(&curve, thresholds),
        thresholds,
        interval_s,
        eval_windows: eval.len(),
        curve,
        skipped,
    })
}

/// The paper's rule on a curve: the smallest training time from which the gradient of both
/// errors between every pair of consecutive later points stays under the thresholds in
/// absolute value.
///
/// ```
/// use drive_eval::{convergence_time, ConvergencePoint};
/// let p = |t: f64, e: f64| ConvergencePoint { training_time_s: t, intervals: 0, translational_median_m: e, rotational_median_rad: e };
/// // Gradients: -0.1, -0.05, -0.001, 0.002 per second.
/// let curve = [p(6.0, 2.0), p(12.0, 1.4), p(18.0, 1.1), p(24.0, 1.094), p(30.0, 1.106)];
/// assert_eq!(convergence_time(&curve, [0.01, 0.01]), Some(18.0));
/// assert_eq!(convergence_time(&curve[..2], [0.01, 0.01]), None);
/// ```
pub fn convergence_time(curve: &[ConvergencePoint], thresholds: [f64; 2]) -> Option<f64> {
    let steep = |a: &ConvergencePoint, b: &ConvergencePoint| {
        let dt = b.training_time_s - a.training_time_s;
        ((b.translational_median_m - a.translational_median_m) / dt).abs() >= thresholds[0]
            || ((b.rotational_median_rad - a.rotational_median_rad) / dt).abs() >= thresholds[1]
    };
    // The last steep step decides: convergence starts at the point after it.
    match curve.windows(2).rposition(|w| steep(&w[0], &w[1])) {
        None => curve.first().map(|p| p.training_time_s),
        Some(i) if i + 1 < curve.len() - 1 => Some(curve[i + 1].training_time_s),
        Some(_) => None,
    }
}
