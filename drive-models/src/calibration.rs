//! Calibrated predictive uncertainty: a model's own pose covariance, scaled per horizon
//! step by split-conformal calibration on held-out training intervals.
//!
//! The paper propagates slip-BLR's predictive variance (eq. 7) through eq. 1 as if the slip
//! error were independent at every step. Real slip errors are correlated along a rollout
//! (a terrain patch, a lagging powertrain), so the propagated covariance grows too slowly:
//! on the bundled Husky data its 95% ellipse holds about 65% of the measured positions at
//! 0.5 s and 30% at 2 s. [`Uncertainty::Calibrated`] (the default) corrects its *size*,
//! step by step, and its *shape* where the errors say it is wrong:
//!
//! 1. the training intervals are cut into [`Calibrator::folds`] contiguous blocks (two by
//!    default: the first and the second half); each block is held out in turn and the same
//!    model is fitted on the others (cross-conformal: every training window is scored
//!    once, out of sample);
//! 2. on every held-out window and step `k`, the error of that fit's prediction gets a
//!    score under the covariance the final model (fitted on all training windows) predicts
//!    for the same window: the squared Mahalanobis distance of the position error under
//!    the 2x2 position block, and the squared yaw error over the yaw variance;
//! 3. a difficulty of each prediction ([`crate::difficulty`]: what the prediction itself says,
//!    its speed, its turning, how far from the start's motion) is fitted per step on those
//!    scores, each score divided by the difficulty fitted without its own fold, the
//!    difficulty tempered by its out-of-fold calibration slope (off with
//!    [`Calibrator::difficulty`] or [`Uncertainty::Horizon`]);
//! 4. the region's shape: the model's covariance, or, where it gives smaller regions on
//!    the held-out windows at the same coverage (geometric mean over the steps of the mean
//!    area), the held-out errors' own shape in the frame of the predicted heading
//!    (along and across the path; Tyler's scale-free estimate over the neighbouring steps);
//!    on the bundled Husky data slip-ipem's errors are longer along its path than its
//!    covariance says. Steps 2 and 3 are made for both shapes and the choice is stored;
//! 5. per step, the conformal quantile of the scores over their difficulty (rank
//!    `ceil((n + 1) level)`, pooled over the steps within 10% of `k`, as many on each side,
//!    to steady it) over the chi-square quantile of the same level is the step's scale
//!    (position: 2 degrees of freedom, yaw: 1);
//! 6. the model fitted on all training windows predicts, and its covariance at step `k` is
//!    `D C D` with `D = diag(sqrt(s_p d_p), sqrt(s_p d_p), sqrt(s_yaw d_yaw))`: the step's
//!    scales times the prediction's difficulties (with the heading shape, its position
//!    block is `s_p d_p R S R^T`, `R` the predicted heading's rotation, uncorrelated with
//!    the yaw).
//!
//! Under exchangeable windows, split conformal gives the level's coverage on new windows
//! with a finite-sample guarantee (Vovk et al. 2005; Angelopoulos and Bates 2021); cross-
//! conformal over folds scores every training window at the cost of one fit per fold, and
//! keeps its coverage close to the level in practice (Vovk 2015). Scoring the folds' errors
//! against the final model's covariance sizes the output for the model actually used (a
//! model whose parameter uncertainty shrinks with more data is not left overconfident). A covariance thinner than 1:100 (position axes, variance ratio) is widened to
//! that before scoring and in the output, so that a near-singular propagation (acc-BLR's)
//! gets a usable ellipse rather than a huge one along its long axis; a zero covariance
//! becomes the held-out errors' own spread.
//!
//! [`Uncertainty::Paper`] keeps the model's propagation as published (eq. 7 for the BLRs).

use drive_traits::{
    limits::Short, wrap_angle, FitError, Input, MotionError, MotionModel, Pose, PoseCovariance,
    StartInfo, StartState, Tagged, WindowSet,
};
use serde::{Deserialize, Serialize};

use crate::difficulty::{
    fit_step, log_sizes, motion_features, FeatureWalk, Features, Row, StepDifficulty, FEATURES,
};

/// The chi-square quantile of 2 degrees of freedom at `level`: `-2 ln(1 - level)`.
///
/// ```
/// assert!((drive_models::calibration::chi2_2(0.95) - 5.991464547107979).abs() < 1e-12);
/// ```
pub fn chi2_2(level: f64) -> f64 {
    -2.0 * (1.0 - level).ln()
}

/// The chi-square quantile of 1 degree of freedom at `level` (the square of the standard
/// normal quantile at `(1 + level) / 2`), by bisection on the error function.
///
/// ```
/// assert!((drive_models::calibration::chi2_1(0.95) - 3.841458820694124).abs() < 1e-9);
/// ```
pub fn chi2_1(level: f64) -> f64 {
    // P(|Z| <= z) = erf(z / sqrt 2); increasing in z.
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if erf(mid / std::f64::consts::SQRT_2) < level {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let z = 0.5 * (lo + hi);
    z * z
}

/// The error function: its Maclaurin series below 2.5, the continued fraction of `erfc`
/// above (both to about 1e-15).
fn erf(x: f64) -> f64 {
    if x < 0.0 {
        return -erf(-x);
    }
    if x < 2.5 {
        // Maclaurin series: sum (-1)^n x^(2n+1) / (n! (2n+1)), converges fast for x < 2.5.
        let (mut term, mut sum, x2) = (x, x, x * x);
        let mut n = 0.0;
        loop {
            n += 1.0;
            term *= -x2 / n;
            let add = term / (2.0 * n + 1.0);
            sum += add;
            if add.abs() < 1e-17 * sum.abs() {
                break;
            }
        }
        sum * 2.0 / std::f64::consts::PI.sqrt()
    } else {
        // Continued fraction of erfc (Lentz), accurate for x >= 2.5.
        let mut f = x;
        for k in (1..60).rev() {
            f = x + (k as f64 / 2.0) / f;
        }
        1.0 - (-x * x).exp() / (f * std::f64::consts::PI.sqrt())
    }
}

/// How a fitted model's pose covariance is produced.
///
/// ```
/// use drive_models::calibration::Uncertainty;
/// assert_eq!(Uncertainty::parse("paper").unwrap(), Uncertainty::Paper);
/// assert_eq!(Uncertainty::default(), Uncertainty::Calibrated);
/// assert!(Uncertainty::parse("bayes").unwrap_err().contains("calibrated, paper, horizon"));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Uncertainty {
    /// The model's covariance scaled per horizon step by split-conformal calibration on
    /// held-out training intervals (the module's method).
    #[default]
    Calibrated,
    /// The model's own propagation as published (eq. 7 propagated through eq. 1 for the
    /// BLRs), without calibration.
    Paper,
    /// The model's covariance scaled per horizon step only, without the learned difficulty
    /// (the calibration of the previous release: regions whose size says little about which
    /// window is hard).
    Horizon,
}

impl Uncertainty {
    /// The names, as the command line takes them.
    pub const NAMES: [&'static str; 3] = ["calibrated", "paper", "horizon"];

    /// The method of a name.
    pub fn parse(name: &str) -> Result<Self, String> {
        match name {
            "calibrated" => Ok(Uncertainty::Calibrated),
            "paper" => Ok(Uncertainty::Paper),
            "horizon" => Ok(Uncertainty::Horizon),
            other => Err(format!(
                "unknown uncertainty method {other:?}; known: {}",
                Self::NAMES.join(", ")
            )),
        }
    }

    /// The method's name.
    pub fn as_str(self) -> &'static str {
        match self {
            Uncertainty::Calibrated => "calibrated",
            Uncertainty::Paper => "paper",
            Uncertainty::Horizon => "horizon",
        }
    }
}

/// The conformal calibration's settings (validated hyperparameters).
///
/// ```
/// use drive_models::calibration::Calibrator;
/// let c = Calibrator::default();
/// assert_eq!((c.folds, c.level, c.difficulty), (2, 0.95, true));
/// assert!(Calibrator { level: 1.5, ..c }.check().is_err());
/// assert!(Calibrator { folds: 1, ..c }.check().is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Calibrator {
    /// Contiguous blocks of training intervals, each held out once (>= 2).
    pub folds: usize,
    /// Coverage the regions are calibrated to, in (0, 1).
    pub level: f64,
    /// Smallest ratio of the position covariance's eigenvalues, in [0, 1).
    pub shape_floor: f64,
    /// Whether the regions also follow a learned difficulty of each prediction
    /// ([`crate::difficulty`]); without it, one scale per horizon step.
    #[serde(default = "yes")]
    pub difficulty: bool,
}

fn yes() -> bool {
    true
}

impl Default for Calibrator {
    fn default() -> Self {
        Calibrator {
            folds: 2,
            level: 0.95,
            shape_floor: 1e-2,
            difficulty: true,
        }
    }
}

/// Variance below which a covariance is treated as zero (m^2, rad^2).
const TINY_VARIANCE: f64 = 1e-12;

/// Most folds (each one more fit).
const MAX_FOLDS: usize = 20;

impl Calibrator {
    /// Checks the settings.
    pub fn check(&self) -> Result<(), FitError> {
        let bad = |name: &'static str, value: f64, expected: &'static str| {
            Err(FitError::InvalidHyperparameter {
                name,
                value,
                expected,
            })
        };
        if !(2..=MAX_FOLDS).contains(&self.folds) {
            return bad("calibration folds", self.folds as f64, "2 to 20 folds");
        }
        if !(self.level > 0.0 && self.level < 1.0) {
            return bad("calibration level", self.level, "a coverage in (0, 1)");
        }
        if !(self.shape_floor >= 0.0 && self.shape_floor < 1.0) {
            return bad(
                "calibration shape_floor",
                self.shape_floor,
                "a ratio in [0, 1)",
            );
        }
        Ok(())
    }

    /// Calibrates `model` (fitted on all of `train`): `fit`, the same learner, is refitted
    /// with each block of training intervals held out, and the held-out windows' errors
    /// under those fits, scored against `model`'s own covariance at the same windows, set
    /// the per-step scales. Predictions start from what `start` allows (as in the
    /// evaluation). The model comes back unchanged when it has no covariance, when the
    /// training windows span fewer intervals than folds, or when a refit fails (the model
    /// is then not a [`CalibratedModel`]).
    pub fn calibrate(
        &self,
        model: Box<dyn MotionModel>,
        train: &WindowSet<'_>,
        start: StartInfo,
        mut fit: impl FnMut(&WindowSet<'_>) -> Result<Box<dyn MotionModel>, FitError>,
    ) -> Result<Box<dyn MotionModel>, FitError> {
        self.check()?;
        let vehicle = train.robot.vehicle.as_ref();
        let Some(first) = train.windows.iter().find(|w| w.len() >= 2) else {
            return Ok(model);
        };
        let (mut poses, mut covs) = (Vec::new(), Vec::new());
        if model
            .predict_with_covariance_into(
                &first.start_state_with(vehicle, start),
                &first.command,
                &mut poses,
                &mut covs,
            )
            .is_err()
        {
            return Ok(model);
        }
        let Some(folds) = train.interval_folds(self.folds) else {
            return Ok(model);
        };
        let n = train.windows.iter().map(|w| w.len()).max().unwrap_or(0);
        let mut position: Vec<Vec<Row>> = vec![Vec::new(); n];
        let mut yaw: Vec<Vec<Row>> = vec![Vec::new(); n];
        // Per step and position row: the error along and across the predicted heading.
        let mut along_across: Vec<Vec<[f64; 2]>> = vec![Vec::new(); n];
        let mut windows = 0;
        let (mut predicted, mut features) = (Vec::new(), Vec::new());
        let dt = model.dt();
        let folds_count = folds.len();
        for (fold, (rest, held)) in folds.into_iter().enumerate() {
            let Ok(fold_model) = fit(&rest) else {
                return Ok(model);
            };
            for w in held.windows.iter().filter(|w| w.len() >= 2) {
                let s = w.start_state_with(vehicle, start);
                fold_model.predict_into(&s, &w.command, &mut predicted);
                if model
                    .predict_with_covariance_into(&s, &w.command, &mut poses, &mut covs)
                    .is_err()
                {
                    return Ok(model);
                }
                windows += 1;
                motion_features(&s, &poses, dt, &mut features);
                let errors = pose_errors(&predicted, &w.pose);
                for (k, e) in errors
                    .iter()
                    .enumerate()
                    .skip(1)
                    .take(covs.len().saturating_sub(1))
                {
                    let c = floored(&covs[k], self.shape_floor);
                    let (size, yaw_size) = log_sizes(&c);
                    let mut x = features[k];
                    x[FEATURES - 1] = size;
                    position[k].push(Row {
                        x,
                        score: position_score(e, &c),
                        fold,
                    });
                    along_across[k].push(heading_frame(e, predicted[k].z));
                    x[FEATURES - 1] = yaw_size;
                    yaw[k].push(Row {
                        x,
                        score: e.z * e.z / c[(2, 2)],
                        fold,
                    });
                }
            }
        }
        let chi2 = chi2_2(self.level);
        let by_model = self.difficulties(&position, folds_count);
        let model_scale = self.scales(&mut by_model.scores.clone(), chi2);
        let model_area = mean_areas(&position, &by_model, &model_scale, |r| {
            r.x[FEATURES - 1].exp()
        });
        // The same with the errors' own shape in the predicted heading's frame.
        // Each held-out error is scored under the shape estimated without its own fold
        // (as the difficulty: no error shapes its own region); the shape kept is estimated
        // on all of them.
        let shape_of = |k: usize, skip: Option<usize>| -> [f64; 3] {
            let (lo, hi) = neighbour_steps(k, n);
            let kept = (lo..=hi).flat_map(|j| {
                position[j]
                    .iter()
                    .zip(&along_across[j])
                    .filter(move |(r, _)| Some(r.fold) != skip)
                    .map(|(_, u)| u)
            });
            error_shape(kept, self.shape_floor).unwrap_or(UNIT_SHAPE)
        };
        let heading_shape: Vec<[f64; 3]> = (0..n)
            .map(|k| {
                if k == 0 {
                    UNIT_SHAPE
                } else {
                    shape_of(k, None)
                }
            })
            .collect();
        let by_heading_rows: Vec<Vec<Row>> = (0..n)
            .map(|k| {
                if k == 0 {
                    return position[0].clone();
                }
                let out_of_fold: Vec<[f64; 3]> =
                    (0..folds_count).map(|f| shape_of(k, Some(f))).collect();
                position[k]
                    .iter()
                    .zip(&along_across[k])
                    .map(|(r, u)| Row {
                        score: shape_score(u, &out_of_fold[r.fold]),
                        ..*r
                    })
                    .collect()
            })
            .collect();
        let by_heading = self.difficulties(&by_heading_rows, folds_count);
        let heading_scale = self.scales(&mut by_heading.scores.clone(), chi2);
        let heading_area = mean_areas(&by_heading_rows, &by_heading, &heading_scale, |_| 1.0);
        // The shape whose regions are smaller, step by step (geometric mean of the ratios),
        // at the same calibrated coverage.
        let log_ratio: f64 = heading_area
            .iter()
            .zip(&model_area)
            .filter(|(h, m)| h.is_finite() && m.is_finite() && **h > 0.0 && **m > 0.0)
            .map(|(h, m)| (h / m).ln())
            .sum();
        let (position_fit, position_scale, heading_shape) = if log_ratio < 0.0 {
            (by_heading, heading_scale, heading_shape)
        } else {
            (by_model, model_scale, Vec::new())
        };
        let mut yaw_fit = self.difficulties(&yaw, folds_count);
        let calibration = HorizonCalibration {
            level: self.level,
            shape_floor: self.shape_floor,
            windows,
            position_scale,
            yaw_scale: self.scales(&mut yaw_fit.scores, chi2_1(self.level)),
            position_difficulty: position_fit.difficulty,
            yaw_difficulty: yaw_fit.difficulty,
            heading_shape,
        };
        if calibration.check().is_err() {
            return Ok(model);
        }
        Ok(Box::new(CalibratedModel { model, calibration }))
    }

    /// Per step, the difficulty fitted on the rows of its [`neighbour_steps`] (none without
    /// [`Calibrator::difficulty`], and none at a step where a fold's fit has too few rows),
    /// and the scores divided by the difficulty fitted without their own fold (cross-fitting:
    /// no score sizes its own region).
    ///
    /// The difficulty is then tempered, `d^gamma` with one `gamma` in `[0, 1]` for all steps:
    /// the slope of the out-of-fold log scores on the out-of-fold log difficulties (each
    /// centred per step), the calibration slope of the difficulty. A difficulty that ranks
    /// the windows well but overstates how much harder the hard ones are (fitted noise) gets
    /// a slope under 1 and is flattened (never steepened: the ridge's shrinkage is kept);
    /// `gamma = 0` is one size per step. With the slope, a window of twice the difficulty of
    /// another gets, on held-out windows, errors twice as large, so that each kind of
    /// window (transient or steady, slow or fast) keeps close to the level's coverage.
    fn difficulties(&self, rows: &[Vec<Row>], folds: usize) -> Difficulties {
        let n = rows.len();
        let raw = || Difficulties {
            difficulty: Vec::new(),
            scores: rows
                .iter()
                .map(|r| r.iter().map(|r| r.score).collect())
                .collect(),
            log_multipliers: rows.iter().map(|r| vec![0.0; r.len()]).collect(),
        };
        if !self.difficulty {
            return raw();
        }
        let mut fitted = Vec::with_capacity(n);
        // Per step and row: the log of the out-of-fold difficulty.
        let mut log_d: Vec<Vec<f64>> = Vec::with_capacity(n);
        for k in 0..n {
            if k == 0 {
                fitted.push(StepDifficulty::NONE);
                log_d.push(Vec::new());
                continue;
            }
            let (lo, hi) = neighbour_steps(k, n);
            let pooled = || rows[lo..=hi].iter().flatten();
            let out_of_fold: Vec<StepDifficulty> =
                (0..folds).map(|f| fit_step(pooled(), Some(f))).collect();
            // A step where a fold's fit has too few scores has none (its scores would be
            // scaled without the difficulty its regions are then given).
            if out_of_fold.contains(&StepDifficulty::NONE) {
                fitted.push(StepDifficulty::NONE);
                log_d.push(vec![0.0; rows[k].len()]);
                continue;
            }
            fitted.push(fit_step(pooled(), None));
            log_d.push(
                rows[k]
                    .iter()
                    .map(|r| out_of_fold[r.fold].multiplier(&r.x).ln())
                    .collect(),
            );
        }
        if fitted.iter().all(|d| *d == StepDifficulty::NONE) {
            return raw();
        }
        let (mut sxy, mut sxx) = (0.0, 0.0);
        for (step, l) in rows.iter().zip(&log_d).skip(1) {
            let pairs: Vec<(f64, f64)> = step
                .iter()
                .zip(l)
                .filter(|(r, l)| r.score > 0.0 && r.score.is_finite() && l.is_finite())
                .map(|(r, l)| (*l, r.score.ln()))
                .collect();
            let m = pairs.len().max(1) as f64;
            let (lx, ly) = pairs
                .iter()
                .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / m, b + y / m));
            for (x, y) in &pairs {
                sxy += (x - lx) * (y - ly);
                sxx += (x - lx) * (x - lx);
            }
        }
        let gamma = if sxx > 1e-12 {
            (sxy / sxx).clamp(0.0, 1.0)
        } else {
            0.0
        };
        if gamma == 0.0 {
            return raw();
        }
        let log_multipliers: Vec<Vec<f64>> = log_d
            .iter()
            .zip(rows)
            .map(|(l, step)| {
                if l.is_empty() {
                    vec![0.0; step.len()]
                } else {
                    l.iter().map(|l| gamma * l).collect()
                }
            })
            .collect();
        let scores = rows
            .iter()
            .zip(&log_multipliers)
            .map(|(step, l)| step.iter().zip(l).map(|(r, l)| r.score / l.exp()).collect())
            .collect();
        Difficulties {
            difficulty: fitted.into_iter().map(|d| d.tempered(gamma)).collect(),
            scores,
            log_multipliers,
        }
    }

    /// Per step, the conformal quantile of the scores pooled over the steps within 10% of
    /// it, over the chi-square quantile `chi2` (1 at the start and where no score exists).
    fn scales(&self, scores: &mut [Vec<f64>], chi2: f64) -> Vec<f64> {
        let n = scores.len();
        (0..n)
            .map(|k| {
                if k == 0 {
                    return 1.0;
                }
                let (lo, hi) = pooled_steps(k, n);
                let mut pooled: Vec<f64> = (lo..=hi)
                    .flat_map(|j| scores[j].iter().copied())
                    .filter(|s| !s.is_nan())
                    .collect();
                conformal_quantile(&mut pooled, self.level).map_or(1.0, |q| q / chi2)
            })
            .collect()
    }
}

/// The steps pooled with step `k >= 1` of `n`: those within 10% of it (at least one each
/// side), as many on each side (errors grow along a window: steps on one side only would
/// bias the step's quantile), the start excluded.
fn pooled_steps(k: usize, n: usize) -> (usize, usize) {
    let r = ((k as f64) * 0.1).round().max(1.0) as usize;
    let r = r.min(k - 1).min(n - 1 - k);
    (k - r, k + r)
}

/// The steps whose held-out errors shape the difficulty and the heading shape of step
/// `k >= 1` of `n`: those within 10% of it (at least one each side), the start excluded.
/// Unlike [`pooled_steps`], not as many on each side: a difficulty and a shape are relative
/// (the step's quantile sets the size), and the last step gets its neighbours' errors.
fn neighbour_steps(k: usize, n: usize) -> (usize, usize) {
    let r = ((k as f64) * 0.1).round().max(1.0) as usize;
    ((k - r).max(1), (k + r).min(n - 1))
}

/// A calibration's difficulty per step, and per step and held-out row its score over its
/// out-of-fold difficulty and the log of that difficulty.
struct Difficulties {
    difficulty: Vec<StepDifficulty>,
    scores: Vec<Vec<f64>>,
    log_multipliers: Vec<Vec<f64>>,
}

/// Per step, the mean over the held-out rows of the calibrated region's area over
/// `pi chi2` (scale times out-of-fold difficulty times the root determinant of the shape,
/// `root_det`); NaN at a step without rows.
fn mean_areas(
    rows: &[Vec<Row>],
    fit: &Difficulties,
    scale: &[f64],
    root_det: impl Fn(&Row) -> f64,
) -> Vec<f64> {
    rows.iter()
        .zip(&fit.log_multipliers)
        .zip(scale)
        .map(|((step, l), s)| {
            let sum: f64 = step
                .iter()
                .zip(l)
                .map(|(r, l)| s * l.exp() * root_det(r))
                .sum();
            sum / step.len() as f64
        })
        .collect()
}

/// The unit shape `[a, b, d]` (the symmetric 2x2 `[[a, b], [b, d]]`, determinant 1).
const UNIT_SHAPE: [f64; 3] = [1.0, 0.0, 1.0];

/// A position error `e` in the frame of the heading `yaw`: `[along, across]`.
fn heading_frame(e: &Pose, yaw: f64) -> [f64; 2] {
    let (s, c) = yaw.sin_cos();
    [c * e.x + s * e.y, -s * e.x + c * e.y]
}

/// `u^T S^-1 u` for the shape `s` (`[a, b, d]`).
fn shape_score(u: &[f64; 2], s: &[f64; 3]) -> f64 {
    let [a, b, d] = *s;
    let det = a * d - b * b;
    (d * u[0] * u[0] - 2.0 * b * u[0] * u[1] + a * u[1] * u[1]) / det
}

/// The shape of the errors `u` whatever their sizes: Tyler's M-estimator of scatter (Tyler
/// 1987, "A distribution-free M-estimator of multivariate scatter"), the fixed point of
/// `S = 2 mean(u u^T / u^T S^-1 u)`, scaled to determinant 1, its smaller eigenvalue raised
/// to at least `floor` times the larger. Each error counts by its direction only, so a few
/// large errors (the hard windows, sized by the difficulty) do not set the shape of all.
/// `None` with fewer than 3 non-zero errors or all along one line.
fn error_shape<'a>(u: impl Iterator<Item = &'a [f64; 2]> + Clone, floor: f64) -> Option<[f64; 3]> {
    let nonzero =
        move |u: &&[f64; 2]| u[0].is_finite() && u[1].is_finite() && u[0].hypot(u[1]) > 1e-12;
    if u.clone().filter(nonzero).count() < 3 {
        return None;
    }
    let mut s = UNIT_SHAPE;
    for _ in 0..100 {
        let (mut a, mut b, mut d, mut m) = (0.0, 0.0, 0.0, 0.0);
        for u in u.clone().filter(nonzero) {
            let w = 1.0 / shape_score(u, &s);
            a += w * u[0] * u[0];
            b += w * u[0] * u[1];
            d += w * u[1] * u[1];
            m += 1.0;
        }
        let det = (a * d - b * b) / (m * m);
        if !(det > 1e-300 && det.is_finite()) {
            return None;
        }
        let root = det.sqrt();
        let next = [a / m / root, b / m / root, d / m / root];
        let change = next
            .iter()
            .zip(&s)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        s = next;
        if change < 1e-10 {
            break;
        }
    }
    // The eigenvalue floor, then determinant 1 again.
    let [a, b, d] = s;
    let mean = 0.5 * (a + d);
    let spread = (0.25 * (a - d) * (a - d) + b * b).sqrt();
    let lift = (floor * (mean + spread) - (mean - spread)).max(0.0);
    let (a, d) = (a + lift, d + lift);
    let root = (a * d - b * b).sqrt();
    Some([a / root, b / root, d / root])
}

/// The split-conformal quantile of `scores` at `level`: the `ceil((n + 1) level)`-th
/// smallest (the largest when that rank exceeds `n`); `None` for no score. Sorts `scores`.
///
/// ```
/// let mut s: Vec<f64> = (1..=19).map(f64::from).collect();
/// assert_eq!(drive_models::calibration::conformal_quantile(&mut s, 0.95), Some(19.0));
/// let mut s: Vec<f64> = (1..=99).map(f64::from).collect();
/// assert_eq!(drive_models::calibration::conformal_quantile(&mut s, 0.9), Some(90.0));
/// ```
pub fn conformal_quantile(scores: &mut [f64], level: f64) -> Option<f64> {
    if scores.is_empty() {
        return None;
    }
    scores.sort_by(f64::total_cmp);
    let n = scores.len();
    let rank = (((n + 1) as f64) * level).ceil() as usize;
    Some(scores[rank.clamp(1, n) - 1])
}

/// The measured minus the predicted pose at each step (yaw unwrapped along the measurement
/// and the difference wrapped to `[-pi, pi]`, as in eq. 8).
///
/// ```
/// use drive_traits::Pose;
/// let e = drive_models::calibration::pose_errors(
///     &[Pose::zeros(), Pose::new(1.0, 0.0, 3.1)],
///     &[Pose::zeros(), Pose::new(1.5, 0.5, -3.1)],
/// );
/// assert!((e[1].x - 0.5).abs() < 1e-12 && (e[1].z - (2.0 * std::f64::consts::PI - 6.2)).abs() < 1e-9);
/// ```
pub fn pose_errors(predicted: &[Pose], measured: &[Pose]) -> Vec<Pose> {
    let n = predicted.len().min(measured.len());
    let mut yaw: Vec<f64> = measured[..n].iter().map(|p| p.z).collect();
    drive_traits::unwrap_angles(&mut yaw);
    (0..n)
        .map(|k| {
            let (p, m) = (&predicted[k], &measured[k]);
            Pose::new(m.x - p.x, m.y - p.y, wrap_angle(yaw[k] - p.z))
        })
        .collect()
}

/// `e^T C^-1 e` of the position error `e` under the 2x2 position block of `c` (infinite
/// when that block is not positive definite).
///
/// ```
/// use drive_traits::{Pose, PoseCovariance};
/// let c = PoseCovariance::from_diagonal(&drive_traits::BodyVelocity::new(4.0, 1.0, 1.0));
/// assert_eq!(drive_models::calibration::position_score(&Pose::new(2.0, 1.0, 0.0), &c), 2.0);
/// ```
pub fn position_score(e: &Pose, c: &PoseCovariance) -> f64 {
    let (a, b, d) = (c[(0, 0)], c[(0, 1)], c[(1, 1)]);
    let det = a * d - b * b;
    if !(a > 0.0 && det > 0.0 && det.is_finite()) {
        return f64::INFINITY;
    }
    (d * e.x * e.x - 2.0 * b * e.x * e.y + a * e.y * e.y) / det
}

/// `c` with its position block's smaller eigenvalue raised to at least `ratio` times the
/// larger (by adding a multiple of the identity) and its variances to at least 1e-12.
fn floored(c: &PoseCovariance, ratio: f64) -> PoseCovariance {
    let (a, b, d) = (c[(0, 0)], c[(0, 1)], c[(1, 1)]);
    let mean = 0.5 * (a + d);
    let spread = (0.25 * (a - d) * (a - d) + b * b).sqrt();
    let (large, small) = (mean + spread, mean - spread);
    let lift = (ratio * large - small).max(TINY_VARIANCE - small).max(0.0);
    let mut out = *c;
    out[(0, 0)] += lift;
    out[(1, 1)] += lift;
    out[(2, 2)] = out[(2, 2)].max(TINY_VARIANCE);
    out
}

/// The per-horizon-step scales of a calibrated model's covariance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HorizonCalibration {
    /// The coverage calibrated to.
    pub level: f64,
    /// Smallest ratio of the position covariance's eigenvalues.
    pub shape_floor: f64,
    /// Held-out windows the scales come from.
    pub windows: usize,
    /// Scale of the position block at each step (index 0, the start, is 1).
    pub position_scale: Vec<f64>,
    /// Scale of the yaw variance at each step.
    pub yaw_scale: Vec<f64>,
    /// The learned difficulty of the position at each step ([`crate::difficulty`]; empty:
    /// none, every prediction's region sized alike).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub position_difficulty: Vec<StepDifficulty>,
    /// The learned difficulty of the yaw at each step (empty: none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub yaw_difficulty: Vec<StepDifficulty>,
    /// The shape of the position region at each step in the frame of the predicted heading,
    /// `[a, b, d]` for `[[along^2, along across], [along across, across^2]]` scaled to
    /// determinant 1, where the held-out errors' own shape gave smaller regions than the
    /// model's covariance (empty: the model's covariance shapes the region).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub heading_shape: Vec<[f64; 3]>,
}

impl HorizonCalibration {
    /// Checks values read from a file.
    pub fn check(&self) -> Result<(), String> {
        if !(self.level > 0.0 && self.level < 1.0) {
            return Err(format!(
                "calibration level {} is not in (0, 1)",
                Short(self.level)
            ));
        }
        if !(self.shape_floor >= 0.0 && self.shape_floor < 1.0) {
            return Err(format!(
                "calibration shape_floor {} is not in [0, 1)",
                Short(self.shape_floor)
            ));
        }
        if self.position_scale.is_empty() || self.position_scale.len() != self.yaw_scale.len() {
            return Err("calibration scales are empty or of different lengths".into());
        }
        if let Some(s) = self
            .position_scale
            .iter()
            .chain(&self.yaw_scale)
            .find(|s| !(s.is_finite() && **s > 0.0))
        {
            return Err(format!(
                "calibration scale {} is not a finite number > 0",
                Short(*s)
            ));
        }
        for d in [&self.position_difficulty, &self.yaw_difficulty] {
            if !d.is_empty() && d.len() != self.position_scale.len() {
                return Err("calibration difficulties and scales are of different lengths".into());
            }
            d.iter().try_for_each(StepDifficulty::check)?;
        }
        if !self.heading_shape.is_empty() {
            if self.heading_shape.len() != self.position_scale.len() {
                return Err(
                    "calibration heading shapes and scales are of different lengths".into(),
                );
            }
            for &[a, b, d] in &self.heading_shape {
                let det = a * d - b * b;
                if !(a > 0.0 && d > 0.0 && (det - 1.0).abs() < 1e-6 && a < 1e6 && d < 1e6) {
                    return Err(format!(
                        "calibration heading shape [{}, {}, {}] is not positive definite of determinant 1",
                        Short(a),
                        Short(b),
                        Short(d)
                    ));
                }
            }
        }
        Ok(())
    }

    /// The calibrated covariance at step `k` (beyond the calibrated horizon: the last
    /// step's scales) of a prediction whose motion features at `k` are `x`
    /// ([`crate::difficulty::motion_features`]; unused without a difficulty) and whose
    /// predicted heading at `k` is `yaw` (unused without a heading shape). With a heading
    /// shape, the position block is that shape turned to `yaw` and scaled, and the position
    /// is uncorrelated with the yaw.
    pub fn apply(&self, k: usize, c: &PoseCovariance, x: &Features, yaw: f64) -> PoseCovariance {
        if k == 0 {
            return *c;
        }
        let i = k.min(self.position_scale.len() - 1);
        let f = floored(c, self.shape_floor);
        let (mut sp, mut sy) = (self.position_scale[i], self.yaw_scale[i]);
        if let (Some(dp), Some(dy)) = (self.position_difficulty.get(i), self.yaw_difficulty.get(i))
        {
            let (size, yaw_size) = log_sizes(&f);
            let mut x = *x;
            x[FEATURES - 1] = size;
            sp *= dp.multiplier(&x);
            x[FEATURES - 1] = yaw_size;
            sy *= dy.multiplier(&x);
        }
        let d = [sp.sqrt(), sp.sqrt(), sy.sqrt()];
        let mut out = PoseCovariance::from_fn(|r, col| f[(r, col)] * d[r] * d[col]);
        if let Some(&[a, b, d]) = self.heading_shape.get(i) {
            // R S R^T with R the rotation by `yaw`.
            let (s, c) = yaw.sin_cos();
            let xx = c * c * a - 2.0 * c * s * b + s * s * d;
            let xy = c * s * (a - d) + (c * c - s * s) * b;
            let yy = s * s * a + 2.0 * c * s * b + c * c * d;
            out[(0, 0)] = sp * xx;
            out[(0, 1)] = sp * xy;
            out[(1, 0)] = sp * xy;
            out[(1, 1)] = sp * yy;
            for j in 0..2 {
                out[(j, 2)] = 0.0;
                out[(2, j)] = 0.0;
            }
        }
        out
    }

    /// Whether the regions follow a learned difficulty.
    pub fn has_difficulty(&self) -> bool {
        !self.position_difficulty.is_empty()
    }
}

/// A fitted model whose pose covariance is calibrated per horizon step
/// ([`Uncertainty::Calibrated`]); its mean prediction is the inner model's.
///
/// ```
/// use drive_models::calibration::{CalibratedModel, HorizonCalibration};
/// use drive_traits::{Input, MotionError, MotionModel, Pose, PoseCovariance, StartState, Tagged};
/// # use serde::{Deserialize, Serialize};
/// /// Stands still, unsure by 1 m^2 and 1 rad^2 at every step after the start.
/// #[derive(Debug, Serialize, Deserialize)]
/// struct Unsure;
/// #[typetag::serde(name = "unsure-doc")]
/// impl MotionModel for Unsure {
///     fn name(&self) -> String { "unsure".into() }
///     fn dt(&self) -> f64 { 0.1 }
///     fn predict_into(&self, s: &StartState, c: &[Input], p: &mut Vec<Pose>) { p.clear(); p.resize(c.len(), s.pose); }
///     fn predict_with_covariance_into(&self, s: &StartState, c: &[Input], p: &mut Vec<Pose>,
///         cov: &mut Vec<PoseCovariance>) -> Result<(), MotionError> {
///         self.predict_into(s, c, p);
///         cov.clear();
///         cov.extend((0..c.len()).map(|k| if k == 0 { PoseCovariance::zeros() } else { PoseCovariance::identity() }));
///         Ok(())
///     }
/// }
/// let calibration = HorizonCalibration {
///     level: 0.95, shape_floor: 0.0, windows: 20,
///     position_scale: vec![1.0, 4.0], yaw_scale: vec![1.0, 9.0],
///     position_difficulty: vec![], yaw_difficulty: vec![], heading_shape: vec![],
/// };
/// let model = CalibratedModel { model: Box::new(Unsure), calibration };
/// let (mut p, mut c) = (vec![], vec![]);
/// model.predict_with_covariance_into(&StartState::at_rest(Pose::zeros()), &[Input::zeros(); 3], &mut p, &mut c).unwrap();
/// assert_eq!(c[0], PoseCovariance::zeros());
/// assert_eq!((c[1][(0, 0)], c[1][(1, 1)], c[1][(2, 2)]), (4.0, 4.0, 9.0));
/// assert_eq!(c[2][(2, 2)], 9.0); // beyond the calibrated horizon: the last step's scales
/// assert_eq!(model.name(), "unsure");
/// ```
#[derive(Debug, Serialize, Deserialize)]
pub struct CalibratedModel {
    /// The model (its mean prediction and covariance shape).
    pub model: Box<dyn MotionModel>,
    /// The per-step scales.
    pub calibration: HorizonCalibration,
}

impl Tagged for CalibratedModel {
    const TAG: &'static str = "calibrated";
}

#[typetag::serde(name = "calibrated")]
impl MotionModel for CalibratedModel {
    fn name(&self) -> String {
        self.model.name()
    }

    fn dt(&self) -> f64 {
        self.model.dt()
    }

    fn check(&self) -> Result<(), String> {
        self.model.check()?;
        self.calibration.check()
    }

    fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>) {
        self.model.predict_into(start, commands, poses)
    }

    fn predict_batch_into(
        &self,
        starts: &[StartState],
        commands: &[Input],
        horizon: usize,
        poses: &mut [Pose],
    ) -> Result<(), MotionError> {
        self.model
            .predict_batch_into(starts, commands, horizon, poses)
    }

    fn predict_with_covariance_into(
        &self,
        start: &StartState,
        commands: &[Input],
        poses: &mut Vec<Pose>,
        covariances: &mut Vec<PoseCovariance>,
    ) -> Result<(), MotionError> {
        self.model
            .predict_with_covariance_into(start, commands, poses, covariances)?;
        // The difficulty's features walked along the prediction (no buffer per call).
        let mut walk = FeatureWalk::new(start, self.model.dt());
        for (k, c) in covariances.iter_mut().enumerate() {
            let x = match (k, poses.get(k)) {
                (1.., Some(p)) if self.calibration.has_difficulty() => walk.step(&poses[k - 1], p),
                _ => [0.0; FEATURES],
            };
            let yaw = poses.get(k).map_or(start.pose.z, |p| p.z);
            *c = self.calibration.apply(k, c, &x, yaw);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::DifferentialDrive;
    use drive_traits::{Phase, RobotDescription, Window};

    /// Predicts the start pose, with a unit covariance on every axis after the start.
    #[derive(Debug, Serialize, Deserialize)]
    struct Still;
    #[typetag::serde(name = "still-calibration-test")]
    impl MotionModel for Still {
        fn name(&self) -> String {
            "still".into()
        }
        fn dt(&self) -> f64 {
            0.05
        }
        fn predict_into(&self, s: &StartState, c: &[Input], p: &mut Vec<Pose>) {
            p.clear();
            p.resize(c.len(), s.pose);
        }
        fn predict_with_covariance_into(
            &self,
            s: &StartState,
            c: &[Input],
            p: &mut Vec<Pose>,
            cov: &mut Vec<PoseCovariance>,
        ) -> Result<(), MotionError> {
            self.predict_into(s, c, p);
            cov.clear();
            cov.extend((0..c.len()).map(|k| {
                if k == 0 {
                    PoseCovariance::zeros()
                } else {
                    PoseCovariance::identity()
                }
            }));
            Ok(())
        }
    }

    /// Standard normal draws from a fixed linear congruential sequence (Box-Muller).
    fn normals(count: usize, seed: u64) -> Vec<f64> {
        let mut state = seed;
        let mut uniform = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..count)
            .map(|_| (-2.0 * uniform().ln()).sqrt() * (std::f64::consts::TAU * uniform()).cos())
            .collect()
    }

    /// Windows whose measured poses scatter around the start with standard deviations
    /// `sd` (x, y) and `sd_yaw`, growing linearly along the window.
    fn windows(count: usize, sd: f64, sd_yaw: f64, seed: u64) -> Vec<Window> {
        let z = normals(count * 3, seed);
        (0..count)
            .map(|i| Window {
                index: i,
                interval: i / 3,
                phase: if i % 3 == 0 {
                    Phase::Transient
                } else {
                    Phase::Steady
                },
                command: vec![Input::zeros(); 40],
                measured: vec![Input::zeros(); 40],
                pose: (0..40)
                    .map(|k| {
                        let g = k as f64 / 39.0;
                        Pose::new(
                            g * sd * z[3 * i],
                            g * sd * z[3 * i + 1],
                            g * sd_yaw * z[3 * i + 2],
                        )
                    })
                    .collect(),
                imu_yaw_rate: vec![0.0; 40],
                start_velocity: None,
            })
            .collect()
    }

    #[test]
    fn scales_restore_the_level_on_new_windows_of_the_same_kind() {
        let robot = RobotDescription::new("t", "", 20.0, 40, DifferentialDrive::new(0.1, 0.5));
        // Errors reach 3 m and 0.5 rad at the last step, under a unit covariance.
        let train = windows(600, 3.0, 0.5, 1);
        let set = WindowSet::new(&robot, &train);
        let model = Calibrator::default()
            .calibrate(Box::new(Still), &set, StartInfo::default(), |_| {
                Ok(Box::new(Still))
            })
            .unwrap();
        let test = windows(3000, 3.0, 0.5, 2);
        let (mut p, mut c) = (Vec::new(), Vec::new());
        let (mut inside, mut yaw_inside) = (0, 0);
        for w in &test {
            model
                .predict_with_covariance_into(
                    &w.start_state(robot.vehicle.as_ref()),
                    &w.command,
                    &mut p,
                    &mut c,
                )
                .unwrap();
            let e = pose_errors(&p, &w.pose);
            inside += usize::from(position_score(&e[39], &c[39]) <= chi2_2(0.95));
            yaw_inside += usize::from(e[39].z * e[39].z / c[39][(2, 2)] <= chi2_1(0.95));
            // The scale follows the spread: at the last step about 3^2 = 9 for position.
            assert!((6.0..13.0).contains(&c[39][(0, 0)]), "{}", c[39][(0, 0)]);
        }
        let (f, fy) = (inside as f64 / 3000.0, yaw_inside as f64 / 3000.0);
        assert!((0.93..=0.975).contains(&f), "position coverage {f}");
        assert!((0.93..=0.975).contains(&fy), "yaw coverage {fy}");
        assert_eq!(model.name(), "still");
        // Fewer intervals than folds: the model comes back as it was.
        let one = windows(3, 1.0, 1.0, 3);
        let back = Calibrator::default()
            .calibrate(
                Box::new(Still),
                &WindowSet::new(&robot, &one),
                StartInfo::default(),
                |_| Ok(Box::new(Still)),
            )
            .unwrap();
        let mut c1 = Vec::new();
        back.predict_with_covariance_into(
            &StartState::at_rest(Pose::zeros()),
            &[Input::zeros(); 3],
            &mut p,
            &mut c1,
        )
        .unwrap();
        assert_eq!(c1[2], PoseCovariance::identity());
    }

    /// Drives straight ahead at the first command's x (m/s), with a unit covariance on every
    /// axis after the start.
    #[derive(Debug, Serialize, Deserialize)]
    struct Ahead;
    #[typetag::serde(name = "ahead-calibration-test")]
    impl MotionModel for Ahead {
        fn name(&self) -> String {
            "ahead".into()
        }
        fn dt(&self) -> f64 {
            0.05
        }
        fn predict_into(&self, s: &StartState, c: &[Input], p: &mut Vec<Pose>) {
            let v = c.first().map_or(0.0, |u| u.x);
            p.clear();
            p.extend((0..c.len()).map(|k| s.pose + Pose::new(v * 0.05 * k as f64, 0.0, 0.0)));
        }
        fn predict_with_covariance_into(
            &self,
            s: &StartState,
            c: &[Input],
            p: &mut Vec<Pose>,
            cov: &mut Vec<PoseCovariance>,
        ) -> Result<(), MotionError> {
            Still.predict_with_covariance_into(s, c, p, cov)?;
            self.predict_into(s, c, p);
            Ok(())
        }
    }

    /// Windows driven at 0.2 or 2 m/s (alternating by interval), whose errors around the
    /// straight path grow with the speed: standard deviation 0.1 + speed / 2 (m, rad) at
    /// the end, growing linearly along the window.
    fn speed_windows(count: usize, seed: u64) -> Vec<Window> {
        let z = normals(count * 3, seed);
        (0..count)
            .map(|i| {
                let v = if (i / 3) % 2 == 0 { 0.2 } else { 2.0 };
                let sd = 0.1 + 0.5 * v;
                Window {
                    index: i,
                    interval: i / 3,
                    phase: Phase::Steady,
                    command: vec![Input::new(v, v); 40],
                    measured: vec![Input::new(v, v); 40],
                    pose: (0..40)
                        .map(|k| {
                            let g = k as f64 / 39.0;
                            Pose::new(
                                v * 0.05 * k as f64 + g * sd * z[3 * i],
                                g * sd * z[3 * i + 1],
                                g * sd * z[3 * i + 2],
                            )
                        })
                        .collect(),
                    imu_yaw_rate: vec![0.0; 40],
                    start_velocity: None,
                }
            })
            .collect()
    }

    #[test]
    fn the_learned_difficulty_sizes_each_prediction_by_how_hard_it_is() {
        let robot = RobotDescription::new("t", "", 20.0, 40, DifferentialDrive::new(0.1, 0.5));
        let train = speed_windows(1200, 4);
        let set = WindowSet::new(&robot, &train);
        let calibrate = |difficulty: bool| {
            Calibrator {
                difficulty,
                ..Calibrator::default()
            }
            .calibrate(Box::new(Ahead), &set, StartInfo::default(), |_| {
                Ok(Box::new(Ahead))
            })
            .unwrap()
        };
        let test = speed_windows(3000, 5);
        // Per speed: coverage of the position and the yaw at the last step, and the mean
        // ellipse area.
        let score = |model: &dyn MotionModel| {
            let (mut p, mut c) = (Vec::new(), Vec::new());
            let mut out = [[0.0; 3]; 2];
            for w in &test {
                model
                    .predict_with_covariance_into(
                        &w.start_state(robot.vehicle.as_ref()),
                        &w.command,
                        &mut p,
                        &mut c,
                    )
                    .unwrap();
                let e = pose_errors(&p, &w.pose);
                let fast = usize::from(w.command[0].x > 1.0);
                out[fast][0] += f64::from(u8::from(position_score(&e[39], &c[39]) <= chi2_2(0.95)));
                out[fast][1] +=
                    f64::from(u8::from(e[39].z * e[39].z / c[39][(2, 2)] <= chi2_1(0.95)));
                out[fast][2] += c[39][(0, 0)];
            }
            out.map(|g| g.map(|v| v / 1500.0))
        };
        let [slow, fast] = score(calibrate(true).as_ref());
        let [slow_h, fast_h] = score(calibrate(false).as_ref());
        // One size per step covers the slow windows always and the fast ones too rarely.
        assert!(
            slow_h[0] > 0.99 && fast_h[0] < 0.92,
            "{slow_h:?} {fast_h:?}"
        );
        // With the difficulty, the slow windows' regions shrink towards their errors (0.2 /
        // 1.1 the fast ones'; by less, the ridge shrinks the difficulty towards one size)
        // while the fast windows keep at least their coverage, and the mean area falls.
        let ratio = (slow[2] / fast[2]).sqrt();
        assert!(ratio < 0.6, "radius ratio {ratio}");
        for (i, what) in ["position", "yaw"].iter().enumerate() {
            assert!(slow[i] >= 0.92, "slow {what} {}", slow[i]);
            assert!(
                fast[i] >= fast_h[i] - 0.005,
                "fast {what} {} against {}",
                fast[i],
                fast_h[i]
            );
        }
        assert!(slow[2] + fast[2] < slow_h[2] + fast_h[2]);
    }

    /// Windows started at headings spread over the circle, whose position errors at the end
    /// have standard deviations 3 m along the start heading and 0.5 m across it (growing
    /// linearly along the window), yaw error 0.2 rad.
    fn heading_windows(count: usize, seed: u64) -> Vec<Window> {
        let z = normals(count * 3, seed);
        (0..count)
            .map(|i| {
                let heading = (i as f64 * 2.399_963) % std::f64::consts::TAU - std::f64::consts::PI;
                let (s, c) = heading.sin_cos();
                let (along, across) = (3.0 * z[3 * i], 0.5 * z[3 * i + 1]);
                Window {
                    index: i,
                    interval: i / 3,
                    phase: Phase::Steady,
                    command: vec![Input::zeros(); 40],
                    measured: vec![Input::zeros(); 40],
                    pose: (0..40)
                        .map(|k| {
                            let g = k as f64 / 39.0;
                            Pose::new(
                                g * (c * along - s * across),
                                g * (s * along + c * across),
                                heading + g * 0.2 * z[3 * i + 2],
                            )
                        })
                        .collect(),
                    imu_yaw_rate: vec![0.0; 40],
                    start_velocity: None,
                }
            })
            .collect()
    }

    #[test]
    fn errors_longer_along_the_heading_get_regions_of_their_shape() {
        let robot = RobotDescription::new("t", "", 20.0, 40, DifferentialDrive::new(0.1, 0.5));
        let train = heading_windows(900, 6);
        // `Still`'s unit covariance is round: the errors' own shape, turned with each
        // prediction's heading, gives smaller regions and is chosen.
        let model = Calibrator::default()
            .calibrate(
                Box::new(Still),
                &WindowSet::new(&robot, &train),
                StartInfo::default(),
                |_| Ok(Box::new(Still)),
            )
            .unwrap();
        let test = heading_windows(3000, 7);
        let (mut p, mut c) = (Vec::new(), Vec::new());
        let (mut inside, mut area, mut radius) = (0, 0.0, Vec::new());
        for w in &test {
            model
                .predict_with_covariance_into(
                    &w.start_state(robot.vehicle.as_ref()),
                    &w.command,
                    &mut p,
                    &mut c,
                )
                .unwrap();
            let e = pose_errors(&p, &w.pose);
            inside += usize::from(position_score(&e[39], &c[39]) <= chi2_2(0.95));
            let det = c[39][(0, 0)] * c[39][(1, 1)] - c[39][(0, 1)].powi(2);
            area += std::f64::consts::PI * chi2_2(0.95) * det.sqrt() / 3000.0;
            radius.push(e[39].x.hypot(e[39].y));
            // The long axis follows the heading: along it the variance is about 36 times
            // the one across it (3^2 / 0.5^2).
            let (s, co) = w.pose[0].z.sin_cos();
            let along =
                co * co * c[39][(0, 0)] + 2.0 * s * co * c[39][(0, 1)] + s * s * c[39][(1, 1)];
            let across =
                s * s * c[39][(0, 0)] - 2.0 * s * co * c[39][(0, 1)] + co * co * c[39][(1, 1)];
            assert!(
                (20.0..60.0).contains(&(along / across)),
                "{along} / {across}"
            );
        }
        let f = inside as f64 / 3000.0;
        assert!((0.93..=0.975).contains(&f), "position coverage {f}");
        // Against the smallest circle holding as many errors: the ellipse of these errors
        // has about a quarter of its area (pi 5.99 * 3 * 0.5 = 28 m^2 against pi 5.9^2).
        radius.sort_by(f64::total_cmp);
        let circle = std::f64::consts::PI * radius[inside.saturating_sub(1)].powi(2);
        assert!(area / circle < 0.4, "area ratio {}", area / circle);
    }

    #[test]
    fn tylers_shape_ignores_the_errors_sizes() {
        // Directions on an ellipse of axes 2 and 0.5 turned by 30 degrees, each at a size
        // from 0.01 to 100: the shape is the ellipse's, of determinant 1.
        let (s, c) = (30f64.to_radians()).sin_cos();
        let u: Vec<[f64; 2]> = (0..400)
            .map(|i| {
                let t = i as f64 * 0.7;
                let size = 10f64.powf((i % 5) as f64 - 2.0);
                let (a, b) = (2.0 * t.cos() * size, 0.5 * t.sin() * size);
                [c * a - s * b, s * a + c * b]
            })
            .collect();
        let [a, b, d] = error_shape(u.iter(), 0.0).unwrap();
        // R diag(4, 0.25) R^T over its root determinant 1.
        let expected = [
            c * c * 4.0 + s * s * 0.25,
            c * s * (4.0 - 0.25),
            s * s * 4.0 + c * c * 0.25,
        ];
        for (got, want) in [a, b, d].iter().zip(expected) {
            assert!(
                (got - want).abs() < 0.05,
                "{:?} against {expected:?}",
                [a, b, d]
            );
        }
        // The floor rounds a line into a thin ellipse; too few errors give none.
        let line: Vec<[f64; 2]> = (1..10).map(|i| [i as f64, 0.0]).collect();
        assert_eq!(error_shape(line.iter(), 0.01), None);
        assert_eq!(error_shape([[1.0, 0.0], [0.0, 1.0]].iter(), 0.01), None);
        let near_line: Vec<[f64; 2]> = (1..10)
            .map(|i| [i as f64, 1e-3 * if i % 2 == 0 { 1.0 } else { -1.0 }])
            .collect();
        let thin = error_shape(near_line.iter(), 0.01).unwrap();
        // Raised to a hundredth of the larger eigenvalue before the lift (as `floored`).
        assert!((0.0098..0.0101).contains(&(thin[2] / thin[0])), "{thin:?}");
    }

    #[test]
    fn a_heading_shape_turns_with_the_predicted_heading() {
        let calibration = HorizonCalibration {
            level: 0.95,
            shape_floor: 0.01,
            windows: 10,
            position_scale: vec![1.0, 2.0],
            yaw_scale: vec![1.0, 3.0],
            position_difficulty: vec![],
            yaw_difficulty: vec![],
            heading_shape: vec![UNIT_SHAPE, [4.0, 0.0, 0.25]],
        };
        assert_eq!(calibration.check(), Ok(()));
        let c = PoseCovariance::identity();
        let x = [0.0; FEATURES];
        // Heading along y: the long axis (4, times the scale 2) is y.
        let turned = calibration.apply(1, &c, &x, std::f64::consts::FRAC_PI_2);
        assert!((turned[(1, 1)] - 8.0).abs() < 1e-12 && (turned[(0, 0)] - 0.5).abs() < 1e-12);
        assert!(turned[(0, 1)].abs() < 1e-12 && (turned[(2, 2)] - 3.0).abs() < 1e-12);
        let ahead = calibration.apply(1, &c, &x, 0.0);
        assert!((ahead[(0, 0)] - 8.0).abs() < 1e-12);
        // A shape not of determinant 1 is refused on load.
        let bad = HorizonCalibration {
            heading_shape: vec![UNIT_SHAPE, [4.0, 0.0, 1.0]],
            ..calibration
        };
        assert!(bad.check().unwrap_err().contains("determinant 1"));
    }

    #[test]
    fn a_step_whose_fold_fits_lack_scores_has_no_difficulty() {
        // Scores that grow with the speed feature, 100 in fold 0 and 10 in fold 1: the fit
        // without fold 0 has too few, so the step has no difficulty at all (its fit on all
        // 110 would be applied to regions whose scale was set without it).
        let rows: Vec<Row> = (0..110)
            .map(|i| {
                let s = (i % 10) as f64;
                Row {
                    x: [1.0, s, 0.0, 0.0, 0.0, 0.0],
                    score: (0.3 * s).exp() * (1.0 + 0.1 * (i % 7) as f64),
                    fold: usize::from(i >= 100),
                }
            })
            .collect();
        assert_ne!(fit_step(rows.iter(), None), StepDifficulty::NONE);
        let fit = Calibrator::default().difficulties(&[Vec::new(), rows.clone()], 2);
        assert!(fit.difficulty.is_empty());
        let raw: Vec<f64> = rows.iter().map(|r| r.score).collect();
        assert_eq!(fit.scores[1], raw);
        // With the folds balanced, the difficulty is learned.
        let balanced: Vec<Row> = rows
            .iter()
            .enumerate()
            .map(|(i, r)| Row { fold: i % 2, ..*r })
            .collect();
        let fit = Calibrator::default().difficulties(&[Vec::new(), balanced], 2);
        assert!(fit.difficulty[1].beta[1] > 0.0, "{:?}", fit.difficulty);
    }

    #[test]
    fn steps_are_pooled_symmetrically() {
        assert_eq!(pooled_steps(20, 40), (18, 22));
        assert_eq!(pooled_steps(39, 40), (39, 39));
        assert_eq!(pooled_steps(38, 40), (37, 39));
        assert_eq!(pooled_steps(1, 40), (1, 1));
        assert_eq!(pooled_steps(3, 40), (2, 4));
    }

    #[test]
    fn a_thin_covariance_is_widened_to_the_shape_floor() {
        let c = PoseCovariance::from_diagonal(&drive_traits::BodyVelocity::new(1.0, 0.0, 0.0));
        let f = floored(&c, 1e-2);
        assert!((f[(1, 1)] - 1e-2).abs() < 1e-12 && (f[(0, 0)] - 1.01).abs() < 1e-12);
        assert_eq!(f[(2, 2)], TINY_VARIANCE);
        // A round one is left alone.
        let round = PoseCovariance::identity();
        assert_eq!(floored(&round, 1e-2), round);
    }

    #[test]
    fn chi_square_quantiles() {
        assert!((chi2_1(0.5) - 0.454_936_423_119_572_7).abs() < 1e-9);
        assert!((chi2_1(0.99) - 6.634_896_601_021_214).abs() < 1e-8);
        assert!((chi2_2(0.5) - 1.386_294_361_119_890_6).abs() < 1e-12);
    }
}
