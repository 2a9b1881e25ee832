//! The paper's Fig. 7 analysis: prediction error against training driving time.

use drive_eval::{evaluate_errors, quantile, split_by_interval, SplitError, Summary};
use drive_models::ModelSpec;
use drive_traits::{Dataset, MotionModel, Window, WindowSet};
use rand::rngs::Xoshiro256PlusPlus;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rayon::prelude::*;
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

/// How the curve is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ConvergenceConfig {
    /// Fraction of the intervals whose prefixes are trained on; the rest evaluates.
    pub split: f64,
    /// Thresholds on |d error / d training time|: (m/s, rad/s).
    pub thresholds: [f64; 2],
    /// At most this many training amounts on a curve: every amount when there are no more
    /// intervals; otherwise every amount up to half of it (the early curve, where the
    /// paper's rule is decided) and the other half evenly spaced up to all the intervals.
    pub max_points: usize,
    /// Random orders of the training intervals drawn besides the recording order (0: none).
    pub orders: usize,
    /// Seed of the random orders.
    pub seed: u64,
}

impl Default for ConvergenceConfig {
    fn default() -> Self {
        ConvergenceConfig {
            split: 0.5,
            thresholds: [0.01, 0.01],
            max_points: 100,
            orders: 30,
            seed: 0,
        }
    }
}

/// One training amount over the random orders: the minimum, median and maximum of the
/// median errors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SpreadPoint {
    /// Driving time of the training data (s).
    pub training_time_s: f64,
    /// Training intervals used.
    pub intervals: usize,
    /// Orders whose model could be fitted at this amount.
    pub orders: usize,
    /// Median translational MRMSE: minimum, median, maximum over the orders (m).
    pub translational_m: [f64; 3],
    /// Median rotational MRMSE: minimum, median, maximum over the orders (rad).
    pub rotational_rad: [f64; 3],
}

/// The convergence over random orders of the training intervals.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OrderSpread {
    /// Orders drawn.
    pub orders: usize,
    /// Their seed.
    pub seed: u64,
    /// Convergence time (s) by the paper's rule: minimum, median, maximum over the orders
    /// whose curve meets it.
    pub convergence_time_s: Option<[f64; 3]>,
    /// The median convergence time (s) over every order, an order that never converges
    /// counted as later than any: `None` when half of the orders or more never converge
    /// (the median of `convergence_time_s` is over the converging orders alone).
    pub median_convergence_time_s: Option<f64>,
    /// Orders whose curve never meets the rule.
    pub never_converged: usize,
    /// The curve's spread, in increasing training time.
    pub curve: Vec<SpreadPoint>,
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
    /// How the models were fitted along the curve: `online` (slip posterior updated
    /// interval by interval, powertrain refitted as the data grows by half) or `batch`
    /// (every amount fitted from scratch).
    pub fitting: &'static str,
    /// The curve in recording order, in increasing training time.
    pub curve: Vec<ConvergencePoint>,
    /// Amounts of training data that could not be fitted (too little excitation).
    pub skipped: Vec<SkippedPoint>,
    /// The same over random orders of the training intervals, when asked.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub random_orders: Option<OrderSpread>,
}

/// [`convergence_with`] with the default configuration (100 points at most) at `split` and
/// `thresholds`, and 30 random orders for a model that fits online (none for a model
/// fitted from scratch at every amount: 31 curves of it would take long).
pub fn convergence(
    data: &Dataset,
    split: f64,
    thresholds: [f64; 2],
    model: &ModelSpec,
) -> Result<Convergence, SplitError> {
    let config = ConvergenceConfig {
        split,
        thresholds,
        orders: if model.growing(&data.robot).is_some() {
            ConvergenceConfig::default().orders
        } else {
            0
        },
        ..ConvergenceConfig::default()
    };
    convergence_with(data, &config, model)
}

/// The model fitted at one amount, or why it could not be.
type FittedAt = Result<Box<dyn MotionModel>, String>;

/// One amount's outcome on one curve: the medians, or why the model could not be fitted.
type PointOutcome = (usize, Result<(f64, f64), String>);

/// Trains `model` on the first 1, 2, 3, ... intervals of the training part of the split (in
/// recording order, then in `config.orders` random orders) and evaluates every fit on the
/// same evaluation part (eq. 8 errors; the uncertainty is not scored). A composed model
/// whose slip learner fits online (slip-BLR, no slip) follows the data with
/// [`drive_models::GrowingFit`]: its cost grows linearly with the training data; other
/// models are fitted from scratch at every amount. The evaluations run in parallel.
pub fn convergence_with(
    data: &Dataset,
    config: &ConvergenceConfig,
    model: &ModelSpec,
) -> Result<Convergence, SplitError> {
    let (train, eval) = split_by_interval(data, config.split)?;
    let window_s = data.robot.window_len as f64 / data.robot.rate_hz;
    // The mean number of windows per interval of the whole dataset (3 in DRIVE).
    let interval_s = window_s * data.windows.len() as f64 / data.interval_count().max(1) as f64;
    // The training windows grouped by interval.
    let mut groups: Vec<Vec<&Window>> = Vec::new();
    for w in &train.windows {
        match groups.last_mut() {
            Some(g) if g[0].interval == w.interval => g.push(w),
            _ => groups.push(vec![w]),
        }
    }
    let n = groups.len();
    let amounts = training_amounts(n, config.max_points);
    let online = model.growing(&data.robot).is_some();
    let recording: Vec<usize> = (0..n).collect();
    let curve_of = |order: &[usize]| curve(&groups, order, &amounts, model, &train, &eval);
    let recorded = curve_of(&recording);
    let point = |n: usize, t: f64, r: f64| ConvergencePoint {
        training_time_s: n as f64 * interval_s,
        intervals: n,
        translational_median_m: t,
        rotational_median_rad: r,
    };
    let mut points = Vec::new();
    let mut skipped = Vec::new();
    for (n, outcome) in recorded {
        match outcome {
            Ok((t, r)) => points.push(point(n, t, r)),
            Err(reason) => skipped.push(SkippedPoint {
                intervals: n,
                reason,
            }),
        }
    }
    let random_orders = (config.orders > 0).then(|| {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(config.seed);
        let orders: Vec<Vec<usize>> = (0..config.orders)
            .map(|_| {
                let mut o = recording.clone();
                o.shuffle(&mut rng);
                o
            })
            .collect();
        let curves: Vec<Vec<PointOutcome>> = orders.par_iter().map(|o| curve_of(o)).collect();
        let mut times = Vec::new();
        for c in &curves {
            let pts: Vec<ConvergencePoint> = c
                .iter()
                .filter_map(|(n, o)| o.as_ref().ok().map(|(t, r)| point(*n, *t, *r)))
                .collect();
            if let Some(t) = convergence_time(&pts, config.thresholds) {
                times.push(t);
            }
        }
        let spread = |v: &mut Vec<f64>| -> [f64; 3] {
            v.sort_by(f64::total_cmp);
            [v[0], quantile(v, 0.5).unwrap_or(f64::NAN), v[v.len() - 1]]
        };
        let curve = amounts
            .iter()
            .enumerate()
            .filter_map(|(i, &a)| {
                let (mut t, mut r): (Vec<f64>, Vec<f64>) = curves
                    .iter()
                    .filter_map(|c| c[i].1.as_ref().ok().copied())
                    .unzip();
                (!t.is_empty()).then(|| SpreadPoint {
                    training_time_s: a as f64 * interval_s,
                    intervals: a,
                    orders: t.len(),
                    translational_m: spread(&mut t),
                    rotational_rad: spread(&mut r),
                })
            })
            .collect();
        OrderSpread {
            orders: config.orders,
            seed: config.seed,
            never_converged: config.orders - times.len(),
            median_convergence_time_s: median_with_never(&times, config.orders),
            convergence_time_s: (!times.is_empty()).then(|| spread(&mut times)),
            curve,
        }
    });
    Ok(Convergence {
        model: model.canonical(),
        convergence_time_s: convergence_time(&points, config.thresholds),
        thresholds: config.thresholds,
        interval_s,
        eval_windows: eval.len(),
        fitting: if online { "online" } else { "batch" },
        curve: points,
        skipped,
        random_orders,
    })
}

/// The training amounts (intervals) of a curve over `n` intervals with at most `max_points`
/// points (see [`ConvergenceConfig::max_points`]).
///
/// ```text
/// training_amounts(5, 100) = [1, 2, 3, 4, 5]
/// training_amounts(100, 10) = [1, 2, 3, 4, 5, 24, 43, 62, 81, 100]
/// ```
fn training_amounts(n: usize, max_points: usize) -> Vec<usize> {
    let max_points = max_points.max(2);
    if n <= max_points {
        return (1..=n).collect();
    }
    let early = max_points / 2;
    let late = max_points - early;
    let mut out: Vec<usize> = (1..=early).collect();
    for i in 1..=late {
        let a = early + ((n - early) as f64 * i as f64 / late as f64).round() as usize;
        if out.last().is_none_or(|l| a > *l) {
            out.push(a);
        }
    }
    out
}

/// The medians of `model` trained on the first `amounts` intervals of `groups` taken in
/// `order`.
fn curve(
    groups: &[Vec<&Window>],
    order: &[usize],
    amounts: &[usize],
    model: &ModelSpec,
    train: &WindowSet<'_>,
    eval: &WindowSet<'_>,
) -> Vec<PointOutcome> {
    let robot = train.robot;
    let seen_after = |n: usize| WindowSet {
        robot,
        windows: order[..n]
            .iter()
            .flat_map(|&g| groups[g].iter().copied())
            .collect(),
    };
    // The models at each amount (fitted online in sequence, or in batch in parallel).
    let models: Vec<(usize, FittedAt)> = match model.growing(robot) {
        Some(mut fit) => {
            let mut seen = WindowSet {
                robot,
                windows: Vec::new(),
            };
            let mut out = Vec::with_capacity(amounts.len());
            let mut next = amounts.iter().peekable();
            for (i, &g) in order.iter().enumerate() {
                let from = seen.windows.len();
                seen.windows.extend(groups[g].iter().copied());
                // The last amount is fitted as in batch (its powertrain on all of it).
                let state = if i + 1 == order.len() {
                    fit.settle(&seen)
                } else {
                    fit.grow(&seen, from)
                }
                .map_err(|e| e.to_string());
                if next.peek() == Some(&&(i + 1)) {
                    next.next();
                    let m = state.and_then(|()| {
                        fit.model(robot)
                            .map(|m| Box::new(m) as Box<dyn MotionModel>)
                            .map_err(|e| e.to_string())
                    });
                    out.push((i + 1, m));
                }
            }
            out
        }
        None => amounts
            .par_iter()
            .map(|&n| {
                (
                    n,
                    model
                        .fit_uncalibrated(&seen_after(n))
                        .map_err(|e| e.to_string()),
                )
            })
            .collect(),
    };
    models
        .into_par_iter()
        .map(|(n, m)| {
            let medians = m.and_then(|m| {
                let report = evaluate_errors(m.as_ref(), eval, model.start);
                match (report.translational(None), report.rotational(None)) {
                    (Some(Summary { median: t, .. }), Some(Summary { median: r, .. })) => {
                        Ok((t, r))
                    }
                    _ => Err("no evaluation window".to_string()),
                }
            });
            (n, medians)
        })
        .collect()
}

/// The paper's rule on a curve: the smallest training time from which the gradient of both
/// errors between every pair of consecutive later points stays under the thresholds in
/// absolute value.
///
/// ```
/// use drive_studies::{convergence_time, ConvergencePoint};
/// let p = |t: f64, e: f64| ConvergencePoint { training_time_s: t, intervals: 0, translational_median_m: e, rotational_median_rad: e };
/// // Gradients: -0.1, -0.05, -0.001, 0.002 per second.
/// let curve = [p(6.0, 2.0), p(12.0, 1.4), p(18.0, 1.1), p(24.0, 1.094), p(30.0, 1.106)];
/// assert_eq!(convergence_time(&curve, [0.01, 0.01]), Some(18.0));
/// assert_eq!(convergence_time(&curve[..2], [0.01, 0.01]), None);
/// // One point has no gradient: nothing is known about convergence.
/// assert_eq!(convergence_time(&curve[..1], [0.01, 0.01]), None);
/// ```
pub fn convergence_time(curve: &[ConvergencePoint], thresholds: [f64; 2]) -> Option<f64> {
    let steep = |a: &ConvergencePoint, b: &ConvergencePoint| {
        let dt = b.training_time_s - a.training_time_s;
        ((b.translational_median_m - a.translational_median_m) / dt).abs() >= thresholds[0]
            || ((b.rotational_median_rad - a.rotational_median_rad) / dt).abs() >= thresholds[1]
    };
    // The last steep step decides: convergence starts at the point after it. A point with
    // no later one has no gradient to meet the rule with.
    match curve.windows(2).rposition(|w| steep(&w[0], &w[1])) {
        None if curve.len() >= 2 => curve.first().map(|p| p.training_time_s),
        None => None,
        Some(i) if i + 1 < curve.len() - 1 => Some(curve[i + 1].training_time_s),
        Some(_) => None,
    }
}

/// The median of `orders` convergence times of which `times` are the orders that converge
/// (the others never do: later than any time); `None` when the median is one of those.
fn median_with_never(times: &[f64], orders: usize) -> Option<f64> {
    if orders == 0 || times.len() > orders {
        return None;
    }
    let mut sorted = times.to_vec();
    sorted.sort_by(f64::total_cmp);
    // The two middle ranks (equal for an odd count), 0-based.
    let (a, b) = ((orders - 1) / 2, orders / 2);
    Some(0.5 * (*sorted.get(a)? + *sorted.get(b)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orders_that_never_converge_count_in_the_median() {
        // 5 orders, 3 converge: the median is the third time.
        assert_eq!(median_with_never(&[30.0, 6.0, 12.0], 5), Some(30.0));
        // 30 orders, 12 converge at 6 s: most never do, so no median (was "6.0 s").
        assert_eq!(median_with_never(&[6.0; 12], 30), None);
        // 4 orders, 2 converge: the median needs the third, which never comes.
        assert_eq!(median_with_never(&[6.0, 12.0], 4), None);
        assert_eq!(median_with_never(&[6.0, 12.0, 18.0, 24.0], 4), Some(15.0));
        assert_eq!(median_with_never(&[], 0), None);
    }

    #[test]
    fn training_amounts_resolve_the_early_curve_and_end_at_all_the_data() {
        assert_eq!(training_amounts(5, 100), vec![1, 2, 3, 4, 5]);
        assert_eq!(
            training_amounts(100, 10),
            vec![1, 2, 3, 4, 5, 24, 43, 62, 81, 100]
        );
        let a = training_amounts(1005, 100);
        assert_eq!(a.len(), 100);
        assert_eq!((a[0], a[49], a[99]), (1, 50, 1005));
        assert!(a.windows(2).all(|w| w[0] < w[1]));
    }
}
