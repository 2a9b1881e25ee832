//! How hard a prediction is: the learned difficulty score that makes a calibrated model's
//! regions larger where its errors are larger (locally weighted conformal prediction, Lei
//! et al. 2018, "Distribution-free predictive inference for regression", Sec. 5.2).
//!
//! A model's own covariance barely follows what makes a window hard: on the bundled Husky
//! data the rank correlation between slip-BLR's 2 s ellipse size and its error is about
//! -0.1. What does follow it is known when the prediction is made: how fast and how sharply
//! the model says the robot will move, and how far that is from how the robot moves at the
//! start (a command that has just changed: the transient window). At horizon step `k`
//! (time `t = k dt`), a prediction's [`Features`] are
//!
//! | feature | meaning |
//! |---|---|
//! | 1 | intercept |
//! | `s` | predicted path length to `k` over `t` (m/s) |
//! | `r` | predicted yaw change to `k`, absolute, over `t` (rad/s) |
//! | `ds` | `s` against the start speed (norm of the start body velocity), absolute (m/s) |
//! | `dr` | the signed predicted yaw rate against the start yaw rate, absolute (rad/s) |
//! | `ln c` | the log size of the model's own covariance at `k` (position: half the log determinant of its 2x2 block; yaw: the log variance) |
//!
//! The difficulty is `d = exp(beta_k . x)` with `beta_k` fitted per step by least squares
//! (with a ridge on standardized features, its strength chosen by the calibration among
//! four, see [`crate::calibration`]) of the log of the held-out windows'
//! scores (squared Mahalanobis distances under the model's covariance, see
//! [`crate::calibration`]) on the features: for a score that is a chi-square variable
//! scaled by the difficulty, `E[ln score] = ln d + const`. The conformal quantile is then
//! taken of `score / d`, so that the calibrated covariance `C d q` keeps the level's
//! coverage and grows where the errors do; the calibration tempers it to `d^gamma` by its
//! slope on held-out windows ([`crate::calibration`]). `d` is bounded to the range it took
//! on the training windows at that step: a prediction unlike any seen is not given a region
//! extrapolated without limit.

use drive_traits::InvalidPart;
use drive_traits::{
    from_total_order_key, total_order_key, wrap_angle, Pose, PoseCovariance, StartState,
};
use nalgebra::{SMatrix, SVector};
use serde::{Deserialize, Serialize};

/// Number of difficulty features (the intercept included).
pub const FEATURES: usize = 6;

/// A prediction's difficulty features at one step (see the module's table).
pub type Features = [f64; FEATURES];

/// Largest difficulty coefficient a file may hold (in the features' raw units). A fit's
/// are its standardized coefficients (a few units, under the ridge) over its features'
/// spreads, which are at least 1e-9: far below this.
const MAX_COEFFICIENT: f64 = 1e15;

/// Fewest scores a step's difficulty is fitted on (below: no difficulty at that step).
const MIN_ROWS: usize = 30;

/// Ridge strengths on the standardized features, per score, among which the calibration
/// chooses the one whose regions are sharpest on held-out windows (at 1, a feature as
/// informative as noise gets half the coefficient least squares would give it; the
/// calibration tries them in this order and keeps the first of equal sharpness).
pub(crate) const RIDGES: [f64; 4] = [1.0, 0.1, 0.3, 3.0];

/// The features shared by position and yaw at every step `k >= 1` of a prediction from
/// `start` whose mean poses are `poses` (sample period `dt`), without the covariance
/// feature (index 5 is left 0). `out[0]` (the start) is all zero.
///
/// ```
/// use drive_models::difficulty::motion_features;
/// use drive_traits::{Pose, StartState};
/// // 1 m/s straight ahead from rest, then a constant yaw rate of 0.5 rad/s.
/// let poses: Vec<Pose> = (0..5).map(|k| Pose::new(0.1 * k as f64, 0.0, 0.05 * k as f64)).collect();
/// let mut f = Vec::new();
/// motion_features(&StartState::at_rest(Pose::zeros()), &poses, 0.1, &mut f);
/// let x = f[4];
/// assert_eq!(x[0], 1.0);
/// assert!((x[1] - 1.0).abs() < 1e-12 && (x[2] - 0.5).abs() < 1e-12);
/// assert!((x[3] - 1.0).abs() < 1e-12 && (x[4] - 0.5).abs() < 1e-12);
/// ```
pub fn motion_features(start: &StartState, poses: &[Pose], dt: f64, out: &mut Vec<Features>) {
    out.clear();
    out.resize(poses.len(), [0.0; FEATURES]);
    let mut walk = FeatureWalk::new(start, dt);
    for k in 1..poses.len() {
        out[k] = walk.step(&poses[k - 1], &poses[k]);
    }
}

/// [`motion_features`] one step at a time, without a buffer: `step` is given the poses
/// `k - 1` and `k` for `k = 1, 2, ...` in turn and returns the features at `k`.
///
/// ```
/// use drive_models::difficulty::{motion_features, FeatureWalk};
/// use drive_traits::{Pose, StartState};
/// let poses: Vec<Pose> = (0..5).map(|k| Pose::new(0.1 * k as f64, 0.0, 0.05 * k as f64)).collect();
/// let start = StartState::at_rest(Pose::zeros());
/// let mut all = Vec::new();
/// motion_features(&start, &poses, 0.1, &mut all);
/// let mut walk = FeatureWalk::new(&start, 0.1);
/// for k in 1..poses.len() {
///     assert_eq!(walk.step(&poses[k - 1], &poses[k]), all[k]);
/// }
/// ```
#[derive(Debug, Clone, Copy)]
pub struct FeatureWalk {
    start_speed: f64,
    start_rate: f64,
    dt: f64,
    k: usize,
    path: f64,
    turn: f64,
}

impl FeatureWalk {
    /// A walk from `start` at sample period `dt`, before step 1.
    pub fn new(start: &StartState, dt: f64) -> Self {
        let v0 = start.body_velocity;
        FeatureWalk {
            start_speed: v0.x.hypot(v0.y),
            start_rate: v0.z,
            dt,
            k: 0,
            path: 0.0,
            turn: 0.0,
        }
    }

    /// The numbers a stepped state keeps the walk in ([`FeatureWalk::write`]).
    pub const NUMBERS: usize = 6;

    /// Writes the walk into `out` ([`FeatureWalk::NUMBERS`] numbers).
    pub fn write(&self, out: &mut [f64]) {
        out[..Self::NUMBERS].copy_from_slice(&[
            self.start_speed,
            self.start_rate,
            self.dt,
            self.k as f64,
            self.path,
            self.turn,
        ]);
    }

    /// The walk written by [`FeatureWalk::write`] (a step count that is not one reads 0).
    ///
    /// ```
    /// use drive_models::difficulty::FeatureWalk;
    /// use drive_traits::{Pose, StartState};
    /// let mut walk = FeatureWalk::new(&StartState::at_rest(Pose::zeros()), 0.1);
    /// walk.step(&Pose::zeros(), &Pose::new(0.1, 0.0, 0.0));
    /// let mut numbers = [0.0; FeatureWalk::NUMBERS];
    /// walk.write(&mut numbers);
    /// let mut back = FeatureWalk::read(&numbers);
    /// assert_eq!(back.step(&Pose::new(0.1, 0.0, 0.0), &Pose::new(0.2, 0.0, 0.0)),
    ///            walk.step(&Pose::new(0.1, 0.0, 0.0), &Pose::new(0.2, 0.0, 0.0)));
    /// ```
    pub fn read(s: &[f64]) -> Self {
        FeatureWalk {
            start_speed: s[0],
            start_rate: s[1],
            dt: s[2],
            k: drive_traits::step::index_of(s[3], usize::MAX),
            path: s[4],
            turn: s[5],
        }
    }

    /// The features at the next step, whose pose is `b` after `a`.
    pub fn step(&mut self, a: &Pose, b: &Pose) -> Features {
        self.k += 1;
        self.path += (b.x - a.x).hypot(b.y - a.y);
        self.turn += wrap_angle(b.z - a.z);
        let t = self.k as f64 * self.dt;
        let (s, rate) = (self.path / t, self.turn / t);
        [
            1.0,
            s,
            rate.abs(),
            (s - self.start_speed).abs(),
            (rate - self.start_rate).abs(),
            0.0,
        ]
    }
}

/// The log size of a position block (half its log determinant) and of the yaw variance,
/// both floored at `ln 1e-12`.
pub fn log_sizes(c: &PoseCovariance) -> (f64, f64) {
    let det = c[(0, 0)] * c[(1, 1)] - c[(0, 1)] * c[(1, 0)];
    let floor = 1e-12f64.ln();
    (
        (0.5 * det.max(0.0).ln()).max(floor),
        c[(2, 2)].max(0.0).ln().max(floor),
    )
}

/// A fitted difficulty per horizon step: coefficients and the range the difficulty took on
/// the training windows.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StepDifficulty {
    /// `beta` (raw feature units; 0 everywhere: no difficulty at the step).
    pub beta: Features,
    /// Smallest and largest `beta . x` on the training windows.
    pub range: [f64; 2],
}

impl StepDifficulty {
    /// No difficulty: `d = 1` whatever the prediction.
    pub const NONE: StepDifficulty = StepDifficulty {
        beta: [0.0; FEATURES],
        range: [0.0, 0.0],
    };

    /// `d = exp(beta . x)`, with `beta . x` clamped to the training range.
    ///
    /// ```
    /// use drive_models::difficulty::StepDifficulty;
    /// let d = StepDifficulty { beta: [0.0, 1.0, 0.0, 0.0, 0.0, 0.0], range: [-1.0, 2.0] };
    /// assert!((d.multiplier(&[1.0, 1.5, 9.0, 9.0, 9.0, 9.0]) - 1.5f64.exp()).abs() < 1e-12);
    /// assert!((d.multiplier(&[1.0, 7.0, 0.0, 0.0, 0.0, 0.0]) - 2.0f64.exp()).abs() < 1e-12);
    /// assert_eq!(StepDifficulty::NONE.multiplier(&[1.0; 6]), 1.0);
    /// ```
    pub fn multiplier(&self, x: &Features) -> f64 {
        let z: f64 = self.beta.iter().zip(x).map(|(b, x)| b * x).sum();
        if !z.is_finite() {
            return self.range[1].exp();
        }
        z.clamp(self.range[0], self.range[1]).exp()
    }

    /// The difficulty raised to `gamma` (`d^gamma`, its range likewise).
    ///
    /// ```
    /// use drive_models::difficulty::StepDifficulty;
    /// let d = StepDifficulty { beta: [1.0, 2.0, 0.0, 0.0, 0.0, 0.0], range: [-1.0, 3.0] };
    /// let t = d.tempered(0.5);
    /// let x = [1.0, 0.5, 0.0, 0.0, 0.0, 0.0];
    /// assert!((t.multiplier(&x) - d.multiplier(&x).sqrt()).abs() < 1e-12);
    /// ```
    pub fn tempered(&self, gamma: f64) -> StepDifficulty {
        StepDifficulty {
            beta: self.beta.map(|b| b * gamma),
            range: self.range.map(|r| r * gamma),
        }
    }

    /// Checks values read from a file.
    pub fn check(&self) -> Result<(), InvalidPart> {
        if self
            .beta
            .iter()
            .chain(&self.range)
            .any(|v| !(v.is_finite() && v.abs() <= MAX_COEFFICIENT))
        {
            return Err(InvalidPart::from(format!(
                "a difficulty coefficient or bound is not a number within +-{}",
                drive_traits::limits::Short(MAX_COEFFICIENT)
            )));
        }
        if self.range[0] > self.range[1] || self.range[0] < -50.0 || self.range[1] > 50.0 {
            return Err(InvalidPart::from(format!(
                "difficulty range [{}, {}] is not an ordered log range within +-50",
                self.range[0], self.range[1]
            )));
        }
        Ok(())
    }
}

/// One held-out score: its features, its value and its fold.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Row {
    pub x: Features,
    pub score: f64,
    pub fold: usize,
}

/// Least squares of `ln score` on the features of `rows` (excluding the fold `skip`),
/// with a ridge of strength `ridge` per row on standardized features;
/// [`StepDifficulty::NONE`] with too few rows. (The calibration gathers the sums once and
/// solves every ridge from them, [`StepSums`]; this one-off form is the tests'.)
#[cfg(test)]
pub(crate) fn fit_step<'a>(
    rows: impl Iterator<Item = &'a Row>,
    skip: Option<usize>,
    ridge: f64,
) -> StepDifficulty {
    let rows = [rows.copied().collect::<Vec<Row>>()];
    let logs = [rows[0].iter().map(|r| r.score.ln()).collect()];
    StepSums::new(&rows, &logs, skip).map_or(StepDifficulty::NONE, |s| s.solve(ridge))
}

/// What [`fit_step`] gathers from its rows before the ridge enters: the rows kept, the
/// features' means and spreads, and the normal equations of the standardized least
/// squares. One gathering serves every ridge strength (the same numbers as gathering
/// again).
pub(crate) struct StepSums<'a> {
    /// The rows kept, each with the logarithm of its score.
    kept: Vec<(&'a Row, f64)>,
    mean: Features,
    sd: Features,
    a: SMatrix<f64, FEATURES, FEATURES>,
    b: SVector<f64, FEATURES>,
}

impl<'a> StepSums<'a> {
    /// The sums of the rows of the steps `rows` pooled, without the fold `skip`; `None` with
    /// too few rows. `logs` holds each row's log score (computed once for the many sums a
    /// row enters).
    pub(crate) fn new(
        rows: &'a [Vec<Row>],
        logs: &[Vec<f64>],
        skip: Option<usize>,
    ) -> Option<Self> {
        // The rows fitted on, gathered once, step by step.
        let mut kept: Vec<(&Row, f64)> = Vec::with_capacity(rows.iter().map(Vec::len).sum());
        for (step, logs) in rows.iter().zip(logs) {
            for (r, log) in step.iter().zip(logs) {
                if Some(r.fold) != skip && r.score.is_finite() {
                    kept.push((r, *log));
                }
            }
        }
        if kept.len() < MIN_ROWS {
            return None;
        }
        // Scores of 0 (a prediction exactly right) are raised to a thousandth of the
        // median (the middle order statistic: the value a sort puts there).
        let middle = kept.len() / 2;
        let mut keys: Vec<i64> = kept.iter().map(|(r, _)| total_order_key(r.score)).collect();
        let (_, median, _) = keys.select_nth_unstable(middle);
        let floor = (from_total_order_key(*median) * 1e-3).max(1e-300);
        let log_floor = floor.ln();
        let n = kept.len() as f64;
        // Every feature's running sums side by side (each feature's sum in the rows' order,
        // so the same rounding as one feature at a time); the intercept's are not kept.
        let (mut mean, mut sq) = ([0.0; FEATURES], [0.0; FEATURES]);
        for (r, _) in &kept {
            for (m, x) in mean.iter_mut().zip(&r.x) {
                *m += x / n;
            }
        }
        mean[0] = 0.0;
        for (r, _) in &kept {
            for ((q, x), m) in sq.iter_mut().zip(&r.x).zip(&mean) {
                *q += (x - m).powi(2) / n;
            }
        }
        let sd: Features = std::array::from_fn(|j| if j == 0 { 1.0 } else { sq[j].sqrt() });
        let used: [bool; FEATURES] =
            std::array::from_fn(|j| j == 0 || sd[j] > 1e-9 * (1.0 + mean[j].abs()));
        // z z^T over all rows, the whole square (z_i z_j and z_j z_i are the same product,
        // so its two triangles agree to the bit), and z ln(score).
        let mut zz = [[0.0; FEATURES]; FEATURES];
        let mut b = SVector::<f64, FEATURES>::zeros();
        for &(r, log_score) in &kept {
            // Every feature standardized side by side, then the intercept's 1 and the unused
            // features' 0 put in.
            let mut z: [f64; FEATURES] = std::array::from_fn(|j| (r.x[j] - mean[j]) / sd[j]);
            for (z, used) in z.iter_mut().zip(&used) {
                if !used {
                    *z = 0.0;
                }
            }
            z[0] = 1.0;
            for (row, zi) in zz.iter_mut().zip(&z) {
                for (a, zj) in row.iter_mut().zip(&z) {
                    *a += zi * zj;
                }
            }
            // ln(max(score, floor)), from the logarithm computed once.
            let log = if r.score < floor {
                log_floor
            } else {
                log_score
            };
            for (b, z) in b.iter_mut().zip(&z) {
                *b += z * log;
            }
        }
        let a = SMatrix::<f64, FEATURES, FEATURES>::from_fn(|i, j| zz[i.min(j)][i.max(j)]);
        Some(StepSums {
            kept,
            mean,
            sd,
            a,
            b,
        })
    }

    /// The difficulty at ridge strength `ridge`.
    #[cfg(test)]
    pub(crate) fn solve(&self, ridge: f64) -> StepDifficulty {
        let [fitted] = self.solve_each(&[ridge]);
        fitted
    }

    /// The difficulty at each ridge strength of `ridges` ([`StepDifficulty::NONE`] where
    /// its normal equations are not positive definite), with one pass over the rows for
    /// every strength's range.
    pub(crate) fn solve_each<const R: usize>(&self, ridges: &[f64; R]) -> [StepDifficulty; R] {
        let (mean, sd) = (&self.mean, &self.sd);
        let used = |j: usize| j == 0 || sd[j] > 1e-9 * (1.0 + mean[j].abs());
        let n = self.kept.len() as f64;
        let betas: [Option<Features>; R] = std::array::from_fn(|i| {
            let mut a = self.a;
            for j in 0..FEATURES {
                a[(j, j)] += if j == 0 { 1e-9 } else { ridges[i] * n };
            }
            let g = a.cholesky()?.solve(&self.b);
            // Back to raw feature units: beta_j = g_j / sd_j, the intercept absorbing the
            // means.
            let mut beta = [0.0; FEATURES];
            beta[0] = g[0];
            for j in 1..FEATURES {
                if used(j) {
                    beta[j] = g[j] / sd[j];
                    beta[0] -= g[j] * mean[j] / sd[j];
                }
            }
            Some(beta)
        });
        // Each strength's range of beta^T x over the rows fitted on (a strength that failed
        // computes with zeros, its range unused); a NaN is passed over, as `min` and `max`
        // do, with one comparison each.
        let zero = [0.0; FEATURES];
        let coefficients: [&Features; R] =
            std::array::from_fn(|i| betas[i].as_ref().unwrap_or(&zero));
        let (mut lo, mut hi) = ([f64::INFINITY; R], [f64::NEG_INFINITY; R]);
        for (r, _) in &self.kept {
            for ((beta, lo), hi) in coefficients.iter().zip(&mut lo).zip(&mut hi) {
                let v: f64 = beta.iter().zip(&r.x).map(|(b, x)| b * x).sum();
                if v < *lo {
                    *lo = v;
                }
                if v > *hi {
                    *hi = v;
                }
            }
        }
        std::array::from_fn(|i| {
            let Some(beta) = betas[i] else {
                return StepDifficulty::NONE;
            };
            let fitted = StepDifficulty {
                beta,
                range: [lo[i].max(-50.0), hi[i].min(50.0)],
            };
            if fitted.check().is_err() {
                return StepDifficulty::NONE;
            }
            fitted
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_log_linear_difficulty() {
        let rows: Vec<Row> = (0..200)
            .map(|i| {
                let s = i as f64 / 100.0;
                Row {
                    x: [1.0, s, 0.0, 0.0, 0.0, 0.0],
                    score: (0.5 + 2.0 * s).exp(),
                    fold: i % 2,
                }
            })
            .collect();
        // score = exp(0.5 + 2 s) exactly, s = 0, 0.01, ..., 1.99: the ridge (as strong as the
        // data on a standardized feature) halves the least-squares slope, 2 -> 1, and the
        // intercept keeps the mean: 0.5 + 2 mean(s) - 1 mean(s) = 1.495.
        let d = fit_step(rows.iter(), None, 1.0);
        assert!((d.beta[1] - 1.0).abs() < 1e-9, "{:?}", d.beta);
        assert!((d.beta[0] - 1.495).abs() < 1e-9, "{:?}", d.beta);
        // Constant features get no coefficient; the range is what the training reached.
        assert_eq!(d.beta[2], 0.0);
        assert!((d.range[0] - 1.495).abs() < 1e-9 && (d.range[1] - 3.485).abs() < 1e-9);
        // Leaving a fold out (every other row) gives the same fit here.
        assert!((fit_step(rows.iter(), Some(0), 1.0).beta[1] - 1.0).abs() < 1e-3);
        assert_eq!(fit_step(rows[..20].iter(), None, 1.0), StepDifficulty::NONE);
    }

    #[test]
    fn coefficients_no_fit_writes_are_refused_on_load() {
        let mut d = StepDifficulty {
            beta: [0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
            range: [-1.0, 2.0],
        };
        assert!(d.check().is_ok());
        d.beta[1] = 1e300;
        assert!(d.check().unwrap_err().contains("within +-1e15"));
        d.beta[1] = 1.0;
        d.range = [3.0, 2.0];
        assert!(d.check().unwrap_err().contains("ordered"));
    }
}
