//! Calibrated predictive uncertainty: a model's own pose covariance, scaled per horizon
//! step by split-conformal calibration on held-out training intervals.
//!
//! The paper propagates slip-BLR's predictive variance (eq. 7) through eq. 1 as if the slip
//! error were independent at every step. Real slip errors are correlated along a rollout
//! (a terrain patch, a lagging powertrain), so the propagated covariance grows too slowly:
//! on the bundled Husky data its 95% ellipse holds about 65% of the measured positions at
//! 0.5 s and 30% at 2 s. [`Uncertainty::Calibrated`] (the default) keeps the model's
//! covariance *shape* and corrects its *size*, step by step:
//!
//! 1. the training intervals are cut into [`Calibrator::folds`] contiguous blocks (two by
//!    default: the first and the second half); each block is held out in turn and the same
//!    model is fitted on the others (cross-conformal: every training window is scored
//!    once, out of sample);
//! 2. on every held-out window and step `k`, the error of that fit's prediction gets a
//!    score under the covariance the final model (fitted on all training windows) predicts
//!    for the same window: the squared Mahalanobis distance of the position error under
//!    the 2x2 position block, and the squared yaw error over the yaw variance;
//! 3. per step, the conformal quantile of the scores (rank `ceil((n + 1) level)` of `n`,
//!    pooled over the steps within 10% of `k` to steady it) over the chi-square quantile
//!    of the same level is the step's scale (position: 2 degrees of freedom, yaw: 1);
//! 4. the model fitted on all training windows predicts, and its covariance at step `k` is
//!    `D C D` with `D = diag(sqrt(s_p), sqrt(s_p), sqrt(s_yaw))`, the scales first carried
//!    over from the held-out fit's covariance to the final one's by the ratio of their
//!    geometric mean sizes on the held-out windows (a model whose parameter uncertainty
//!    shrinks with more data would otherwise come out too confident).
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
/// assert!(Uncertainty::parse("bayes").unwrap_err().contains("calibrated, paper"));
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
}

impl Uncertainty {
    /// The names, as the command line takes them.
    pub const NAMES: [&'static str; 2] = ["calibrated", "paper"];

    /// The method of a name.
    pub fn parse(name: &str) -> Result<Self, String> {
        match name {
            "calibrated" => Ok(Uncertainty::Calibrated),
            "paper" => Ok(Uncertainty::Paper),
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
        }
    }
}

/// The conformal calibration's settings (validated hyperparameters).
///
/// ```
/// use drive_models::calibration::Calibrator;
/// let c = Calibrator::default();
/// assert_eq!((c.folds, c.level), (2, 0.95));
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
}

impl Default for Calibrator {
    fn default() -> Self {
        Calibrator {
            folds: 2,
            level: 0.95,
            shape_floor: 1e-2,
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
        let mut position: Vec<Vec<f64>> = vec![Vec::new(); n];
        let mut yaw: Vec<Vec<f64>> = vec![Vec::new(); n];
        let mut windows = 0;
        let mut predicted = Vec::new();
        for (rest, held) in folds {
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
                let errors = pose_errors(&predicted, &w.pose);
                for (k, e) in errors
                    .iter()
                    .enumerate()
                    .skip(1)
                    .take(covs.len().saturating_sub(1))
                {
                    let c = floored(&covs[k], self.shape_floor);
                    position[k].push(position_score(e, &c));
                    yaw[k].push(e.z * e.z / c[(2, 2)]);
                }
            }
        }
        let calibration = HorizonCalibration {
            level: self.level,
            shape_floor: self.shape_floor,
            windows,
            position_scale: self.scales(&mut position, chi2_2(self.level)),
            yaw_scale: self.scales(&mut yaw, chi2_1(self.level)),
        };
        if calibration.check().is_err() {
            return Ok(model);
        }
        Ok(Box::new(CalibratedModel { model, calibration }))
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
                let r = ((k as f64) * 0.1).round().max(1.0) as usize;
                let mut pooled: Vec<f64> = (k.saturating_sub(r).max(1)..=(k + r).min(n - 1))
                    .flat_map(|j| scores[j].iter().copied())
                    .filter(|s| !s.is_nan())
                    .collect();
                conformal_quantile(&mut pooled, self.level).map_or(1.0, |q| q / chi2)
            })
            .collect()
    }
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
        Ok(())
    }

    /// The calibrated covariance at step `k` (beyond the calibrated horizon: the last
    /// step's scales).
    pub fn apply(&self, k: usize, c: &PoseCovariance) -> PoseCovariance {
        if k == 0 {
            return *c;
        }
        let i = k.min(self.position_scale.len() - 1);
        let d = [
            self.position_scale[i].sqrt(),
            self.position_scale[i].sqrt(),
            self.yaw_scale[i].sqrt(),
        ];
        let f = floored(c, self.shape_floor);
        PoseCovariance::from_fn(|r, col| f[(r, col)] * d[r] * d[col])
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
        for (k, c) in covariances.iter_mut().enumerate() {
            *c = self.calibration.apply(k, c);
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
