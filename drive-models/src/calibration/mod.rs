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
//!    default: the first and the second half; as equal in driven intervals where a block
//!    would hold under half its share of them, [`WindowSet::interval_folds`]); each block
//!    is held out in turn and the same
//!    model is fitted on the others (cross-conformal: every training window is scored
//!    once, out of sample);
//! 2. on every held-out window and step `k`, the error of that fit's prediction gets a
//!    score under the covariance the final model (fitted on all training windows) predicts
//!    for the same window: the squared Mahalanobis distance of the position error under
//!    the 2x2 position block, and the squared yaw error over the yaw variance;
//! 3. a difficulty of each prediction ([`crate::difficulty`]: what the prediction itself says,
//!    its speed, its turning, how far from the start's motion) is fitted per step on those
//!    scores, each score divided by the difficulty fitted without its own fold, the
//!    difficulty tempered by its out-of-fold calibration slope, its fit's ridge strength
//!    the one whose held-out regions are the sharpest (off with
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

use drive_traits::step::{check_state, layout, StepOptions, Stepper};
use drive_traits::UnknownName;
use drive_traits::{
    from_total_order_key, limits::Short, total_order_key, wrap_angle, FitError, Input, MotionError,
    MotionModel, Pose, PoseCovariance, StartInfo, StartState, Tagged, WindowSet,
};
use serde::{Deserialize, Serialize};

use crate::difficulty::{
    log_sizes, motion_features, FeatureWalk, Features, Row, StepDifficulty, StepSums, FEATURES,
    RIDGES,
};

/// What a region's sharpness is measured by: a position ellipse's area, a yaw interval's
/// width.
#[derive(Debug, Clone, Copy)]
enum Region {
    Area,
    Width,
}

mod model;
mod scores;
#[cfg(test)]
mod tests;

pub use model::{CalibratedModel, HorizonCalibration};
use scores::*;
pub use scores::{chi2_1, chi2_2, conformal_quantile, pose_errors, position_score};

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
    pub fn parse(name: &str) -> Result<Self, UnknownName> {
        match name {
            "calibrated" => Ok(Uncertainty::Calibrated),
            "paper" => Ok(Uncertainty::Paper),
            "horizon" => Ok(Uncertainty::Horizon),
            other => Err(UnknownName::from(format!(
                "unknown uncertainty method {other:?}; known: {}",
                Self::NAMES.join(", ")
            ))),
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
        fit: impl Fn(&WindowSet<'_>) -> Result<Box<dyn MotionModel>, FitError> + Sync,
    ) -> Result<Box<dyn MotionModel>, FitError> {
        use rayon::prelude::*;
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
        let dt = model.dt();
        let folds_count = folds.len();
        // Each fold on its own thread: its refit, and its held-out windows' rows; `None`
        // when its refit or a covariance fails (the model then comes back uncalibrated).
        let fold_rows: Vec<Option<FoldRows>> = folds
            .into_par_iter()
            .enumerate()
            .map(|(fold, (rest, held))| {
                let fold_model = fit(&rest).ok()?;
                let mut out = FoldRows::new(n);
                let (mut predicted, mut features) = (Vec::new(), Vec::new());
                let (mut poses, mut covs) = (Vec::new(), Vec::new());
                for w in held.windows.iter().filter(|w| w.len() >= 2) {
                    let s = w.start_state_with(vehicle, start);
                    fold_model.predict_into(&s, &w.command, &mut predicted);
                    model
                        .predict_with_covariance_into(&s, &w.command, &mut poses, &mut covs)
                        .ok()?;
                    out.windows += 1;
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
                        out.position[k].push(Row {
                            x,
                            score: position_score(e, &c),
                            fold,
                        });
                        out.along_across[k].push(heading_frame(e, predicted[k].z));
                        x[FEATURES - 1] = yaw_size;
                        out.yaw[k].push(Row {
                            x,
                            score: e.z * e.z / c[(2, 2)],
                            fold,
                        });
                    }
                }
                Some(out)
            })
            .collect();
        // The folds' rows in fold order, as one pass over the folds would append them.
        let mut position: Vec<Vec<Row>> = vec![Vec::new(); n];
        let mut yaw: Vec<Vec<Row>> = vec![Vec::new(); n];
        // Per step and position row: the error along and across the predicted heading.
        let mut along_across: Vec<Vec<[f64; 2]>> = vec![Vec::new(); n];
        let mut windows = 0;
        for rows in fold_rows {
            let Some(rows) = rows else {
                return Ok(model);
            };
            windows += rows.windows;
            for k in 0..n {
                position[k].extend_from_slice(&rows.position[k]);
                yaw[k].extend_from_slice(&rows.yaw[k]);
                along_across[k].extend_from_slice(&rows.along_across[k]);
            }
        }
        let chi2 = chi2_2(self.level);
        let model_size = |r: &Row| r.x[FEATURES - 1].exp();
        // The three fits below are independent: the model's shape and the yaw on other
        // threads beside the heading shape (the same numbers, sooner).
        let by_model_shape = || {
            let by_model =
                self.difficulties(&position, folds_count, chi2, Region::Area, model_size);
            let model_scale = self.scales(&by_model.scores, chi2);
            let model_area = mean_areas(&position, &by_model, &model_scale, 1.0, model_size);
            (by_model, model_scale, model_area)
        };
        // The yaw interval's width grows with the root of its variance.
        let yaw_fit = || {
            self.difficulties(&yaw, folds_count, chi2_1(self.level), Region::Width, |r| {
                (0.5 * r.x[FEATURES - 1]).exp()
            })
        };
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
        let by_heading_shape = || {
            let by_heading_rows: Vec<Vec<Row>> = (0..n)
                .into_par_iter()
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
            let by_heading =
                self.difficulties(&by_heading_rows, folds_count, chi2, Region::Area, |_| 1.0);
            let heading_scale = self.scales(&by_heading.scores, chi2);
            let heading_area =
                mean_areas(&by_heading_rows, &by_heading, &heading_scale, 1.0, |_| 1.0);
            (by_heading, heading_scale, heading_area)
        };
        let (
            (by_model, model_scale, model_area),
            ((by_heading, heading_scale, heading_area), yaw_fit),
        ) = rayon::join(by_model_shape, || rayon::join(by_heading_shape, yaw_fit));
        // The shape whose regions are smaller, step by step (geometric mean of the ratios),
        // at the same calibrated coverage.
        let log_ratio: f64 = heading_area
            .iter()
            .zip(&model_area)
            .filter(|(h, m)| h.is_finite() && m.is_finite() && **h > 0.0 && **m > 0.0)
            .map(|(h, m)| (h / m).ln())
            .sum();
        let (position_fit, position_scale, heading_shape) = if log_ratio < 0.0 {
            // The shape kept, estimated on every fold's errors (only when it is kept).
            let heading_shape: Vec<[f64; 3]> = (0..n)
                .into_par_iter()
                .map(|k| {
                    if k == 0 {
                        UNIT_SHAPE
                    } else {
                        shape_of(k, None)
                    }
                })
                .collect();
            (by_heading, heading_scale, heading_shape)
        } else {
            (by_model, model_scale, Vec::new())
        };
        let calibration = HorizonCalibration {
            level: self.level,
            shape_floor: self.shape_floor,
            windows,
            position_scale,
            yaw_scale: self.scales(&yaw_fit.scores, chi2_1(self.level)),
            position_difficulty: position_fit.difficulty,
            yaw_difficulty: yaw_fit.difficulty,
            heading_shape,
        };
        if calibration.check().is_err() {
            return Ok(model);
        }
        Ok(Box::new(CalibratedModel { model, calibration }))
    }

    /// [`Self::difficulties_with`] at each of the ridge strengths
    /// ([`crate::difficulty::RIDGES`]), keeping the one whose regions are the sharpest on
    /// the held-out windows at the level's coverage: the smallest geometric mean over the
    /// steps of the regions' mean area (position) or width (yaw), each region sized by its
    /// out-of-fold difficulty and the scale the out-of-fold scores give. `size` is the
    /// model's own size of a row's region (the root determinant of its position block, the
    /// yaw's standard deviation). A weaker ridge ranks the windows more sharply where the
    /// features say much about the errors (the bundled Husky's slip-BLR) and spends area
    /// on windows wrongly called hard where they say little (most Warthog runs): the
    /// held-out windows choose.
    fn difficulties(
        &self,
        rows: &[Vec<Row>],
        folds: usize,
        chi2: f64,
        region: Region,
        size: impl Fn(&Row) -> f64,
    ) -> Difficulties {
        if !self.difficulty {
            return self.difficulties_with(rows, &[], &[], 0);
        }
        let power = match region {
            Region::Area => 1.0,
            Region::Width => 0.5,
        };
        // Each row's log score, computed once for the many sums it enters and every ridge
        // strength's calibration slope; the rows' sums, gathered once for every strength.
        let logs = log_scores(rows);
        let fits = fit_steps(rows, &logs, folds);
        let mut best: Option<(f64, Difficulties)> = None;
        for ridge in 0..RIDGES.len() {
            let fit = self.difficulties_with(rows, &logs, &fits, ridge);
            let scale = self.scales(&fit.scores, chi2);
            let log_sharpness: f64 = mean_areas(rows, &fit, &scale, power, &size)
                .iter()
                .skip(1)
                .filter(|v| v.is_finite() && **v > 0.0)
                .map(|v| v.ln())
                .sum();
            if best.as_ref().is_none_or(|(b, _)| log_sharpness < *b) {
                best = Some((log_sharpness, fit));
            }
        }
        match best {
            Some((_, fit)) => fit,
            // Unreachable: RIDGES is not empty, and its first strength sets `best`.
            None => self.difficulties_with(rows, &logs, &fits, 0),
        }
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
    ///
    /// `logs` holds each row's log score, `fits` each step's fits ([`fit_steps`]), and
    /// `ridge` indexes the strength in [`crate::difficulty::RIDGES`].
    fn difficulties_with(
        &self,
        rows: &[Vec<Row>],
        logs: &[Vec<f64>],
        fits: &[StepFits],
        ridge: usize,
    ) -> Difficulties {
        let n = rows.len();
        let raw = || Difficulties {
            difficulty: Vec::new(),
            scores: rows
                .iter()
                .map(|r| r.iter().map(|r| r.score).collect())
                .collect(),
            multipliers: rows.iter().map(|r| vec![1.0; r.len()]).collect(),
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
            let out_of_fold: Vec<StepDifficulty> =
                fits[k].out_of_fold.iter().map(|f| f[ridge]).collect();
            // A step where a fold's fit has too few scores has none (its scores would be
            // scaled without the difficulty its regions are then given).
            if out_of_fold.contains(&StepDifficulty::NONE) {
                fitted.push(StepDifficulty::NONE);
                log_d.push(vec![0.0; rows[k].len()]);
                continue;
            }
            fitted.push(fits[k].all[ridge]);
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
        for ((step, l), log_scores) in rows.iter().zip(&log_d).zip(logs).skip(1) {
            let pairs: Vec<(f64, f64)> = step
                .iter()
                .zip(l)
                .zip(log_scores)
                .filter(|((r, l), _)| r.score > 0.0 && r.score.is_finite() && l.is_finite())
                .map(|((_, l), log_score)| (*l, *log_score))
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
        // Each row's multiplier, exp(gamma ln d) (1 where the step has no difficulty).
        let multipliers: Vec<Vec<f64>> = log_d
            .iter()
            .zip(rows)
            .map(|(l, step)| {
                if l.is_empty() {
                    vec![1.0; step.len()]
                } else {
                    l.iter().map(|l| (gamma * l).exp()).collect()
                }
            })
            .collect();
        let scores = rows
            .iter()
            .zip(&multipliers)
            .map(|(step, m)| step.iter().zip(m).map(|(r, m)| r.score / m).collect())
            .collect();
        Difficulties {
            difficulty: fitted.into_iter().map(|d| d.tempered(gamma)).collect(),
            scores,
            multipliers,
        }
    }

    /// Per step, the conformal quantile of the scores pooled over the steps within 10% of
    /// it, over the chi-square quantile `chi2` (1 at the start and where no score exists).
    fn scales(&self, scores: &[Vec<f64>], chi2: f64) -> Vec<f64> {
        let n = scores.len();
        let pools: Vec<(usize, usize)> = (1..n).map(|k| pooled_steps(k, n)).collect();
        let quantiles = pooled_conformal_quantiles(scores, &pools, self.level);
        std::iter::once(1.0)
            .chain(quantiles.iter().map(|q| q.map_or(1.0, |q| q / chi2)))
            .take(n)
            .collect()
    }
}

/// One fold's held-out rows, per step: the position and yaw scores and the position
/// errors along and across the predicted heading; and its held-out windows.
struct FoldRows {
    position: Vec<Vec<Row>>,
    yaw: Vec<Vec<Row>>,
    along_across: Vec<Vec<[f64; 2]>>,
    windows: usize,
}

impl FoldRows {
    fn new(n: usize) -> Self {
        FoldRows {
            position: vec![Vec::new(); n],
            yaw: vec![Vec::new(); n],
            along_across: vec![Vec::new(); n],
            windows: 0,
        }
    }
}

/// Per step, the difficulty fitted on its pooled rows ([`neighbour_steps`]) without each
/// fold and with all of them, at each ridge strength of [`RIDGES`].
struct StepFits {
    out_of_fold: Vec<[StepDifficulty; RIDGES.len()]>,
    all: [StepDifficulty; RIDGES.len()],
}

/// Each row's log score.
fn log_scores(rows: &[Vec<Row>]) -> Vec<Vec<f64>> {
    rows.iter()
        .map(|step| step.iter().map(|r| r.score.ln()).collect())
        .collect()
}

/// The fits of every step of `rows` (step 0, the start, has none: [`StepDifficulty::NONE`]),
/// `logs` holding each row's log score: each pool's sums gathered once, every ridge solved
/// from them.
fn fit_steps(rows: &[Vec<Row>], logs: &[Vec<f64>], folds: usize) -> Vec<StepFits> {
    use rayon::prelude::*;
    let n = rows.len();
    let none = [StepDifficulty::NONE; RIDGES.len()];
    (0..n)
        .into_par_iter()
        .map(|k| {
            if k == 0 {
                return StepFits {
                    out_of_fold: Vec::new(),
                    all: none,
                };
            }
            let (lo, hi) = neighbour_steps(k, n);
            let (rows, logs) = (&rows[lo..=hi], &logs[lo..=hi]);
            let fit =
                |skip| StepSums::new(rows, logs, skip).map_or(none, |s| s.solve_each(&RIDGES));
            StepFits {
                out_of_fold: (0..folds).map(|f| fit(Some(f))).collect(),
                all: fit(None),
            }
        })
        .collect()
}
