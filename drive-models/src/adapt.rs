//! Models that adapt to the ground under them (issue 61): a fitted composed model whose
//! slip is corrected online from the windows the robot drives, for any slip model.
//!
//! The prior (a model fitted on other ground) keeps its powertrain and its slip model; on
//! top of its slip, an additional slip `Δ(f)` linear in the slip-BLR inputs of the
//! vehicle's basis (eq. 5) is fitted on what the prior got wrong on the windows driven so
//! far: `Δ = v̂ - v`, the prior's rolled-out body velocity minus the measured one. The
//! adapted body velocity is `v̂ - Δ(f)` (eq. 2 with the slip `g + Δ`). The correction is a
//! ridge regression (a Bayesian linear regression with a zero-mean prior) whose strength is
//! chosen per body dimension among [`CORRECTION_STRENGTHS`] and "no correction" by the
//! prequential error: each interval (one command, its windows alike) is predicted by every
//! candidate fitted on the intervals before it, and a correction is kept only when, after
//! [`MIN_INTERVALS`], it predicted the recent intervals (weighted by
//! [`AdapterConfig::selection_s`]) better than the prior beyond their spread from interval
//! to interval ([`KEEP_Z`] standard errors), the best such one. When the ground has not changed, no correction predicts better than the prior
//! and the prior is kept as it is; when it has, the correction that follows the new ground
//! without overfitting the few windows seen is. That choice is the detector of a change of
//! ground ([`SlipAdapter::changed`]). Each update costs `O(k^3)` per candidate and body
//! dimension (`k <= 3` inputs), whatever the data seen: bounded in time and memory.

use crate::slip::SlipBasis;
use crate::ComposedModel;
use drive_traits::{
    BodyVelocity, BodyVelocityEstimator, InvalidPart, MotionModel, PoseCovariance, SlipData,
    SlipModel, SlipStepper, StartInfo, StartState, Tagged, WindowSet,
};
use serde::{Deserialize, Serialize};

/// The correction's ridge strengths tried, in equivalent samples of "no extra slip" (the
/// prior's own answer) against the samples driven: from a prior held almost as it is to
/// one the new ground overrules after a few windows.
pub const CORRECTION_STRENGTHS: [f64; 10] =
    [1e5, 3e4, 1e4, 3e3, 1e3, 300.0, 100.0, 30.0, 10.0, 3.0];

/// The largest slip correction weight read or kept (in magnitude): a correction of a
/// million times its inputs is no ground's.
pub const MAX_CORRECTION_WEIGHT: f64 = 1e6;

/// The largest magnitude of an adapter's sums read back (a robot's squared speeds summed
/// over any driving stay far below it).
pub const MAX_ADAPTER_SUM: f64 = 1e30;

/// The fewest intervals (commands) scored before a correction may be kept: a correction
/// learned on fewer commands would extrapolate from them to the whole input space.
pub const MIN_INTERVALS: usize = 4;

/// An additional slip linear in the slip-BLR inputs of `basis` (eq. 5): `Δ_d(f) = x_d(f)^T
/// w_d` for the longitudinal, lateral and angular slip.
///
/// ```
/// use drive_models::adapt::SlipCorrection;
/// use drive_models::slip::SlipBasis;
/// use drive_traits::BodyVelocity;
/// // The skid-steer basis: x_x = [v], x_y = [v w], x_w = [v w, v, w].
/// let c = SlipCorrection { basis: SlipBasis::SkidSteer, weights: [vec![0.1], vec![0.0], vec![0.0, 0.0, 0.2]] };
/// let d = c.slip(&BodyVelocity::new(1.0, 0.0, 0.5));
/// assert!((d.x - 0.1).abs() < 1e-12 && (d.z - 0.1).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlipCorrection {
    /// The slip inputs.
    pub basis: SlipBasis,
    /// The weights of the three regressions (longitudinal, lateral, angular).
    pub weights: [Vec<f64>; 3],
}

impl SlipCorrection {
    /// No correction.
    pub fn zero(basis: SlipBasis) -> Self {
        SlipCorrection {
            weights: basis.dimensions().map(|k| vec![0.0; k]),
            basis,
        }
    }

    /// The additional slip at the commanded body velocity `f`.
    pub fn slip(&self, f: &BodyVelocity) -> BodyVelocity {
        // The basis's inputs in fixed-size arrays: no allocation per sample (this runs at
        // every step of a rollout).
        let dot = |x: &[f64], w: &[f64]| x.iter().zip(w).map(|(x, w)| x * w).sum::<f64>();
        let [wx, wy, ww] = &self.weights;
        match &self.basis {
            SlipBasis::Own(own) => {
                let rows = own.0.inputs(f);
                BodyVelocity::new(dot(&rows[0], wx), dot(&rows[1], wy), dot(&rows[2], ww))
            }
            SlipBasis::SkidSteer => {
                let s = crate::slip::slip_inputs(f);
                BodyVelocity::new(dot(&s.x, wx), dot(&s.y, wy), dot(&s.yaw, ww))
            }
            SlipBasis::Car | SlipBasis::Omnidirectional => {
                let s = self.basis.pair_inputs(f);
                BodyVelocity::new(dot(&s.x, wx), dot(&s.y, wy), dot(&s.yaw, ww))
            }
        }
    }

    /// True when every weight is zero.
    pub fn is_zero(&self) -> bool {
        self.weights.iter().flatten().all(|w| *w == 0.0)
    }

    fn check(&self) -> Result<(), InvalidPart> {
        self.basis.check()?;
        for (w, k) in self.weights.iter().zip(self.basis.dimensions()) {
            if w.len() != k {
                return Err(InvalidPart(format!(
                    "a slip correction has {} weights where its basis has {k} inputs",
                    w.len()
                )));
            }
            if w.iter()
                .any(|v| !(v.is_finite() && v.abs() <= MAX_CORRECTION_WEIGHT))
            {
                return Err(InvalidPart(format!(
                    "a slip correction's weight is not finite or beyond {MAX_CORRECTION_WEIGHT:e}"
                )));
            }
        }
        Ok(())
    }
}

/// A slip model corrected by [`SlipCorrection`]: the prior's body velocities minus the
/// additional slip (`v = v̂ - Δ(f)`); its uncertainty is the prior's.
///
/// ```
/// use drive_models::adapt::{CorrectedSlip, SlipCorrection};
/// use drive_models::slip::{NoSlipModel, SlipBasis};
/// use drive_traits::{BodyVelocity, SlipModel};
/// let c = CorrectedSlip {
///     prior: Box::new(NoSlipModel),
///     correction: SlipCorrection { basis: SlipBasis::SkidSteer, weights: [vec![0.25], vec![0.0], vec![0.0; 3]] },
/// };
/// let mut v = Vec::new();
/// c.body_velocities_into(&[BodyVelocity::new(2.0, 0.0, 0.0)], &mut v);
/// assert!((v[0].x - 1.5).abs() < 1e-12); // a quarter of the speed lost on this ground
/// ```
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CorrectedSlip {
    /// The prior's slip model.
    pub prior: Box<dyn SlipModel>,
    /// The additional slip learned on the ground driven.
    pub correction: SlipCorrection,
}

impl Tagged for CorrectedSlip {
    const TAG: &'static str = "corrected-slip";
}

#[typetag::serde(name = "corrected-slip")]
impl SlipModel for CorrectedSlip {
    fn slip(&self, f: &BodyVelocity) -> BodyVelocity {
        self.prior.slip(f) + self.correction.slip(f)
    }

    fn body_velocities_into(&self, f: &[BodyVelocity], out: &mut Vec<BodyVelocity>) {
        self.prior.body_velocities_into(f, out);
        for (v, f) in out.iter_mut().zip(f) {
            *v -= self.correction.slip(f);
        }
    }

    fn rollout_velocities_into(
        &self,
        start: &StartState,
        f: &[BodyVelocity],
        out: &mut Vec<BodyVelocity>,
    ) {
        self.prior.rollout_velocities_into(start, f, out);
        for (v, f) in out.iter_mut().zip(f) {
            *v -= self.correction.slip(f);
        }
    }

    fn slip_variance(&self, f: &BodyVelocity) -> Option<BodyVelocity> {
        self.prior.slip_variance(f)
    }

    fn slip_variances_into(&self, f: &[BodyVelocity], out: &mut Vec<BodyVelocity>) -> bool {
        self.prior.slip_variances_into(f, out)
    }

    fn rollout_covariances_into(
        &self,
        start: &StartState,
        f: &[BodyVelocity],
        dt: f64,
        out: &mut Vec<PoseCovariance>,
    ) -> bool {
        self.prior.rollout_covariances_into(start, f, dt, out)
    }

    fn check(&self) -> Result<(), InvalidPart> {
        self.prior.check()?;
        self.correction.check()
    }

    fn stepper(&self) -> Option<Box<dyn SlipStepper + '_>> {
        let prior = self.prior.stepper()?;
        Some(Box::new(CorrectedStepper {
            prior,
            correction: &self.correction,
        }))
    }

    fn covariance_stepper(
        &self,
        dt: f64,
    ) -> Option<Box<dyn drive_traits::SlipCovarianceStepper + '_>> {
        self.prior.covariance_stepper(dt)
    }

    fn step(&self) -> Option<f64> {
        self.prior.step()
    }

    /// The prior's parameters, then the correction's (`slip correction: x w[0]`, ...).
    fn parameters(&self) -> Vec<(String, f64)> {
        let mut p = self.prior.parameters();
        for (axis, w) in ["x", "y", "yaw"].iter().zip(&self.correction.weights) {
            for (i, v) in w.iter().enumerate() {
                p.push((format!("slip correction: {axis} w[{i}]"), *v));
            }
        }
        p
    }

    fn clone_box(&self) -> Box<dyn SlipModel> {
        Box::new(self.clone())
    }
}

/// [`CorrectedSlip`] stepped: the prior's stepper, the correction taken off each step.
struct CorrectedStepper<'a> {
    prior: Box<dyn SlipStepper + 'a>,
    correction: &'a SlipCorrection,
}

impl SlipStepper for CorrectedStepper<'_> {
    fn state_len(&self) -> usize {
        self.prior.state_len()
    }
    fn init(&self, start: &StartState, state: &mut [f64]) {
        self.prior.init(start, state)
    }
    fn step(&self, state: &mut [f64], f: &BodyVelocity) -> BodyVelocity {
        self.prior.step(state, f) - self.correction.slip(f)
    }
}

/// The settings of a [`SlipAdapter`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AdapterConfig {
    /// What a prediction starts from (as in the evaluation): the prior's rollouts on the
    /// windows driven start so.
    pub start: StartInfo,
    /// How the measured body velocities are derived from the poses (not saved: a saved
    /// adapter, [`SlipAdapter`]'s serde form, has the default).
    #[serde(skip)]
    pub velocity: BodyVelocityEstimator,
    /// The time constant (s) over which the candidates' prequential errors are weighted:
    /// the recent driving decides which correction is kept.
    pub selection_s: f64,
    /// The time constant (s) over which the correction forgets the windows driven (a robot
    /// that drives on to other ground again); `None`: it keeps them all.
    pub memory_s: Option<f64>,
}

impl Default for AdapterConfig {
    fn default() -> Self {
        AdapterConfig {
            start: StartInfo::default(),
            velocity: BodyVelocityEstimator::default(),
            selection_s: 30.0,
            memory_s: None,
        }
    }
}

/// How far (in standard errors over the intervals) a correction must predict the recent
/// intervals better than the prior to be kept: a one-sided test at 5% over the thirty
/// candidates (ten strengths, three body dimensions; Bonferroni: 0.05 / 30).
pub const KEEP_Z: f64 = 3.0;

/// The same for one candidate against one incumbent: a one-sided test at 5%.
pub const KEEP_Z_ONE: f64 = 1.645;

/// A candidate's prequential record against what it would replace: its improvement per
/// interval (what the incumbent got wrong minus what it got wrong, predicting data neither
/// was fitted on), as decayed weighted sums; [`PrequentialRecord::significant`] says
/// whether the candidate is better beyond the spread from interval to interval.
///
/// ```
/// use drive_models::adapt::PrequentialRecord;
/// let mut r = PrequentialRecord::default();
/// for d in [0.1, 0.12, 0.09, 0.11] {
///     r.add(d, 1.0);
/// }
/// assert!(r.significant().is_some());
/// let mut noisy = PrequentialRecord::default();
/// for d in [0.1, -0.12, 0.09, -0.11] {
///     noisy.add(d, 1.0);
/// }
/// assert!(noisy.significant().is_none());
/// ```
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PrequentialRecord {
    /// Sum of w d, of w d^2, of w and of w^2.
    wd: f64,
    wd2: f64,
    w: f64,
    w2: f64,
}

impl PrequentialRecord {
    /// Adds one improvement `d`, the earlier ones decayed by `keep` (in [0, 1]).
    pub fn add(&mut self, d: f64, keep: f64) {
        if !d.is_finite() {
            return;
        }
        self.wd = keep * self.wd + d;
        self.wd2 = keep * self.wd2 + d * d;
        self.w = keep * self.w + 1.0;
        self.w2 = keep * keep * self.w2 + 1.0;
    }

    /// The mean improvement, when it is beyond [`KEEP_Z`] standard errors (the intervals'
    /// effective number from their weights): the test of many candidates at once (ten
    /// strengths and three body dimensions).
    pub fn significant(&self) -> Option<f64> {
        self.significant_at(KEEP_Z)
    }

    /// Whether its sums are finite and its weights not negative (a record read back).
    pub fn is_valid(&self) -> bool {
        [self.wd, self.wd2, self.w, self.w2]
            .iter()
            .all(|v| v.is_finite())
            && self.w >= 0.0
            && self.w2 >= 0.0
            && self.wd2 >= 0.0
    }

    /// The mean improvement, when it is beyond `z` standard errors.
    pub fn significant_at(&self, z: f64) -> Option<f64> {
        if self.w <= 0.0 {
            return None;
        }
        let mean = self.wd / self.w;
        let var = (self.wd2 / self.w - mean * mean).max(0.0);
        let n = self.w * self.w / self.w2.max(1e-300);
        (mean > 0.0 && mean > z * (var / n).sqrt()).then_some(mean)
    }
}

/// One body dimension's correction: the weighted sums of its least squares, the rows of the
/// interval being driven, and each candidate's prequential record.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Regression {
    k: usize,
    /// X^T X (k x k, row-major), X^T r, and the weight of the samples in them: the
    /// intervals completed.
    xtx: Vec<f64>,
    xtr: Vec<f64>,
    weight: f64,
    /// The rows of the interval being driven (its windows share its command): scored as one
    /// when the next interval starts, then added.
    pending_x: Vec<f64>,
    pending_r: Vec<f64>,
    /// Per strength of [`CORRECTION_STRENGTHS`], its record against the prior.
    records: Vec<PrequentialRecord>,
    /// Intervals scored.
    intervals: usize,
}

impl Regression {
    fn new(k: usize) -> Self {
        Regression {
            k,
            xtx: vec![0.0; k * k],
            xtr: vec![0.0; k],
            weight: 0.0,
            pending_x: Vec::new(),
            pending_r: Vec::new(),
            records: vec![PrequentialRecord::default(); CORRECTION_STRENGTHS.len()],
            intervals: 0,
        }
    }

    /// The weights under the ridge of `strength` equivalent samples on the sums `xtx`,
    /// `xtr` of `weight` samples (each input's ridge scaled by its mean square, so the
    /// strength means the same whatever the inputs' units); zeros before any sample, or
    /// when the system cannot be solved.
    fn solve_on(k: usize, xtx: &[f64], xtr: &[f64], weight: f64, strength: f64) -> Vec<f64> {
        if weight <= 0.0 {
            return vec![0.0; k];
        }
        let mut a = nalgebra::DMatrix::from_row_slice(k, k, xtx);
        for j in 0..k {
            let scale = (xtx[j * k + j] / weight).max(1e-12);
            a[(j, j)] += strength * scale;
        }
        let b = nalgebra::DVector::from_column_slice(xtr);
        match a.cholesky() {
            Some(c) => {
                let w = c.solve(&b);
                if w.iter().all(|v| v.is_finite()) {
                    w.iter().copied().collect()
                } else {
                    vec![0.0; k]
                }
            }
            None => vec![0.0; k],
        }
    }

    /// Adds `x`, `r` (n x k row-major, n) to the sums.
    fn accumulate(
        k: usize,
        xtx: &mut [f64],
        xtr: &mut [f64],
        weight: &mut f64,
        x: &[f64],
        r: &[f64],
    ) {
        for (xi, ri) in x.chunks_exact(k).zip(r) {
            for i in 0..k {
                xtr[i] += xi[i] * ri;
                for j in 0..k {
                    xtx[i * k + j] += xi[i] * xi[j];
                }
            }
            *weight += 1.0;
        }
    }

    /// The weights under `strength` on every row seen, the interval being driven included.
    fn solve(&self, strength: f64) -> Vec<f64> {
        let (mut xtx, mut xtr, mut weight) = (self.xtx.clone(), self.xtr.clone(), self.weight);
        Self::accumulate(
            self.k,
            &mut xtx,
            &mut xtr,
            &mut weight,
            &self.pending_x,
            &self.pending_r,
        );
        Self::solve_on(self.k, &xtx, &xtr, weight, strength)
    }

    /// Adds one window's rows (`x` n x k row-major, residuals `r`); `new_interval` when it
    /// starts another interval than the previous window's, whose rows are then scored by
    /// every candidate fitted without them (earlier records decayed by `keep`) and added
    /// to the sums (decayed by `forget`).
    fn add_window(&mut self, x: &[f64], r: &[f64], new_interval: bool, keep: f64, forget: f64) {
        if new_interval {
            self.commit(keep, forget);
        }
        self.pending_x.extend_from_slice(x);
        self.pending_r.extend_from_slice(r);
    }

    fn commit(&mut self, keep: f64, forget: f64) {
        let k = self.k;
        let (x, r) = (
            std::mem::take(&mut self.pending_x),
            std::mem::take(&mut self.pending_r),
        );
        if r.is_empty() {
            return;
        }
        let prior: f64 = r.iter().map(|v| v * v).sum();
        for (record, &strength) in self.records.iter_mut().zip(&CORRECTION_STRENGTHS) {
            let w = Self::solve_on(k, &self.xtx, &self.xtr, self.weight, strength);
            let sse: f64 = x
                .chunks_exact(k)
                .zip(&r)
                .map(|(xi, ri)| {
                    let p: f64 = xi.iter().zip(&w).map(|(a, b)| a * b).sum();
                    (ri - p).powi(2)
                })
                .sum();
            // Per sample, so that intervals of any length weigh alike.
            record.add((prior - sse) / r.len() as f64, keep);
        }
        self.intervals += 1;
        for v in self.xtx.iter_mut().chain(self.xtr.iter_mut()) {
            *v *= forget;
        }
        self.weight *= forget;
        Self::accumulate(k, &mut self.xtx, &mut self.xtr, &mut self.weight, &x, &r);
    }

    /// The strength (its index) whose correction predicted the recent intervals better
    /// than the prior beyond their spread, the largest improvement among those; `None`: the
    /// prior is kept.
    fn chosen(&self) -> Option<usize> {
        if self.intervals < MIN_INTERVALS {
            return None;
        }
        let mut best: Option<(f64, usize)> = None;
        for (i, r) in self.records.iter().enumerate() {
            if let Some(m) = r.significant() {
                if best.is_none_or(|(b, _)| m > b) {
                    best = Some((m, i));
                }
            }
        }
        best.map(|(_, i)| i)
    }
}

/// A fitted composed model adapting to the ground it drives on: feed it the windows driven
/// ([`SlipAdapter::add`]), in time order; [`SlipAdapter::model`] is the prior with its slip
/// corrected (see the [module](self) docs), the prior itself until a correction predicts
/// the recent windows better.
///
/// ```
/// use drive_models::adapt::{AdapterConfig, SlipAdapter};
/// use drive_models::powertrain::Commanded;
/// use drive_models::slip::NoSlip;
/// use drive_models::{Composed, DifferentialDrive};
/// use drive_traits::{Input, Learner, MotionModel, Phase, Pose, RobotDescription, StartState, Window, WindowSet};
/// let robot = RobotDescription::new("toy", "", 10.0, 20, DifferentialDrive::new(0.1, 0.5));
/// // Straight at 10 rad/s on the wheels (1 m/s without slip), the ground keeping `share`.
/// let window = |i: usize, share: f64| {
///     let pose = (0..20).map(|k| Pose::new(share * 0.1 * k as f64, 0.0, 0.0)).collect();
///     Window::new(i, i, Phase::Steady, vec![Input::new(10.0, 10.0, 0.0); 20],
///         vec![Input::new(10.0, 10.0, 0.0); 20], pose, vec![0.0; 20])
/// };
/// // The prior: fitted where the wheels never slip.
/// let prior = Composed::new(Commanded, NoSlip).fit(&WindowSet::new(&robot, &[window(0, 1.0)])).unwrap();
/// let mut adapter = SlipAdapter::new(prior, &robot, AdapterConfig::default());
/// // Then ground that keeps 80% of the speed.
/// let driven: Vec<Window> = (1..=10).map(|i| window(i, 0.8)).collect();
/// for i in 0..driven.len() {
///     adapter.add(&WindowSet::new(&robot, &driven[i..=i]));
/// }
/// assert!(adapter.changed());
/// let poses = adapter.model().predict(&StartState::at_rest(Pose::zeros()), &[Input::new(10.0, 10.0, 0.0); 11]);
/// assert!((poses[10].x - 0.8).abs() < 0.02, "{}", poses[10].x); // 0.8 m/s for 1 s
/// ```
///
/// Its whole state (the prior, the sums behind each candidate correction and their records)
/// is saved and read back with serde: an adapter read back adapts on as the one saved
/// (with the default [`AdapterConfig::velocity`]).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlipAdapter {
    prior: ComposedModel,
    config: AdapterConfig,
    basis: SlipBasis,
    dims: [Regression; 3],
    windows: usize,
    /// The interval of the last window added, and the seconds driven in it so far.
    interval: Option<usize>,
    interval_s: f64,
}

impl SlipAdapter {
    /// Adapts `prior` (fitted for `robot`'s vehicle) with `config`.
    pub fn new(
        prior: ComposedModel,
        robot: &drive_traits::RobotDescription,
        config: AdapterConfig,
    ) -> Self {
        let basis = SlipBasis::for_vehicle(robot.vehicle.as_ref());
        SlipAdapter {
            prior,
            config,
            dims: basis.dimensions().map(Regression::new),
            basis,
            windows: 0,
            interval: None,
            interval_s: 0.0,
        }
    }

    /// The windows added so far.
    pub fn windows(&self) -> usize {
        self.windows
    }

    /// The prior, as given.
    pub fn prior(&self) -> &ComposedModel {
        &self.prior
    }

    /// Whether an adapter read back (serde) is whole: its prior a valid model, each body
    /// dimension's sums and records the size of its basis, every number finite and the
    /// weights not negative. An adapter that fails would misbehave (or panic) in `add`.
    pub fn check(&self) -> Result<(), InvalidPart> {
        self.prior.check()?;
        self.basis.check()?;
        let bad = |what: &str| Err(InvalidPart(format!("the adapter's {what}")));
        if SlipBasis::for_vehicle(self.prior.vehicle.as_ref()).dimensions()
            != self.basis.dimensions()
        {
            return bad("slip basis is not its vehicle's");
        }
        let finite = |v: &[f64]| {
            v.iter()
                .all(|x| x.is_finite() && x.abs() <= MAX_ADAPTER_SUM)
        };
        for (r, k) in self.dims.iter().zip(self.basis.dimensions()) {
            let sized = r.k == k
                && r.xtx.len() == k * k
                && r.xtr.len() == k
                && r.pending_x.len() == r.pending_r.len() * k
                && r.records.len() == CORRECTION_STRENGTHS.len();
            if !sized {
                return bad("sums are not the size of its slip basis");
            }
            if (0..k).any(|j| r.xtx[j * k + j] < 0.0) {
                return bad("sums of squares are negative");
            }
            let records = r.records.iter().flat_map(|p| [p.wd, p.wd2, p.w, p.w2]);
            if !(finite(&r.xtx)
                && finite(&r.xtr)
                && finite(&r.pending_x)
                && finite(&r.pending_r)
                && r.weight.is_finite()
                && r.weight >= 0.0
                && records.clone().all(f64::is_finite)
                && r.records.iter().all(PrequentialRecord::is_valid))
            {
                return bad(&format!(
                    "sums or records are not finite, beyond {MAX_ADAPTER_SUM:e}, or a weight is negative"
                ));
            }
        }
        // Counts a robot could reach (they only grow by one per window or interval).
        let count = |n: usize| n < (1 << 40);
        if !(count(self.windows) && self.dims.iter().all(|r| count(r.intervals))) {
            return bad("counts are beyond any robot's driving");
        }
        let c = &self.config;
        if !(self.interval_s.is_finite()
            && self.interval_s >= 0.0
            && c.selection_s.is_finite()
            && c.selection_s > 0.0
            && c.memory_s.is_none_or(|m| m.is_finite() && m > 0.0))
        {
            return bad("times are not finite and positive");
        }
        // The correction it keeps now, as its model would apply it.
        self.correction().check()
    }

    /// Its settings.
    pub fn config(&self) -> &AdapterConfig {
        &self.config
    }

    /// Adds windows just driven, in time order: each scored by every candidate correction
    /// before it is learned from.
    pub fn add(&mut self, driven: &WindowSet<'_>) {
        let data = SlipData::new(driven, self.prior.powertrain.as_ref());
        let dt = data.dt();
        let vehicle = driven.robot.vehicle.as_ref();
        let window_s = |w: &drive_traits::Window| w.len() as f64 * dt;
        let mut measured = Vec::new();
        let mut predicted = Vec::new();
        for sw in &data.windows {
            let w = sw.window;
            if w.len() < 2 {
                continue;
            }
            let start = w.start_state_with(vehicle, self.config.start);
            self.prior
                .slip
                .rollout_velocities_into(&start, &sw.commanded, &mut predicted);
            self.config.velocity.estimate(w, dt, &mut measured);
            let mut xs: [Vec<f64>; 3] = Default::default();
            let mut rs: [Vec<f64>; 3] = Default::default();
            for ((f, v), vhat) in sw.commanded.iter().zip(&measured).zip(&predicted) {
                let Some(v) = v else { continue };
                let r = vhat - v;
                if !(r.iter().all(|x| x.is_finite())) {
                    continue;
                }
                self.basis.push(f, &mut xs);
                for d in 0..3 {
                    rs[d].push(r[d]);
                }
            }
            let new_interval = self.interval != Some(w.interval);
            // The interval just completed weighs by its length.
            let span = self.interval_s;
            let keep = (-span / self.config.selection_s.max(1e-9)).exp();
            let forget = self
                .config
                .memory_s
                .map_or(1.0, |m| (-span / m.max(1e-9)).exp());
            for (d, reg) in self.dims.iter_mut().enumerate() {
                reg.add_window(&xs[d], &rs[d], new_interval, keep, forget);
            }
            if new_interval {
                self.interval = Some(w.interval);
                self.interval_s = 0.0;
            }
            self.interval_s += window_s(w);
            self.windows += 1;
        }
    }

    /// Per body dimension (longitudinal, lateral, angular), the correction's strength kept
    /// (equivalent samples, [`CORRECTION_STRENGTHS`]), or `None` where the prior is kept.
    pub fn strengths(&self) -> [Option<f64>; 3] {
        [0, 1, 2].map(|d| self.dims[d].chosen().map(|i| CORRECTION_STRENGTHS[i]))
    }

    /// The detector of a change of ground: true when a correction predicts the recent
    /// windows better than the prior in some body dimension.
    pub fn changed(&self) -> bool {
        self.strengths().iter().any(Option::is_some)
    }

    /// The correction kept now.
    pub fn correction(&self) -> SlipCorrection {
        let strengths = self.strengths();
        let mut c = SlipCorrection::zero(self.basis.clone());
        for ((weights, strength), dim) in c.weights.iter_mut().zip(strengths).zip(&self.dims) {
            if let Some(s) = strength {
                *weights = dim.solve(s);
            }
        }
        c
    }

    /// The adapted model: the prior itself while no correction is kept, else the prior
    /// with its slip corrected.
    pub fn model(&self) -> ComposedModel {
        let correction = self.correction();
        if correction.is_zero() {
            return self.prior.clone();
        }
        ComposedModel {
            slip: Box::new(CorrectedSlip {
                prior: self.prior.slip.clone_box(),
                correction,
            }),
            ..self.prior.clone()
        }
    }
}

/// The composed model inside `model` (itself, or the model a calibration wraps), read back
/// from its saved form; `None` for another kind of model.
///
/// ```
/// use drive_models::{Composed, DifferentialDrive};
/// use drive_models::powertrain::Commanded;
/// use drive_models::slip::NoSlip;
/// use drive_traits::{Input, Learner, Phase, Pose, RobotDescription, Window, WindowSet};
/// let robot = RobotDescription::new("toy", "", 10.0, 3, DifferentialDrive::new(0.1, 0.5));
/// let w = Window::new(0, 0, Phase::Transient, vec![Input::new(10.0, 10.0, 0.0); 3], vec![Input::zeros(); 3], vec![Pose::zeros(); 3], vec![0.0; 3]);
/// let model = Composed::new(Commanded, NoSlip).fit(&WindowSet::new(&robot, &[w])).unwrap();
/// assert_eq!(drive_models::adapt::composed_of(&model).unwrap().label, "no-slip+commanded");
/// ```
pub fn composed_of(model: &dyn MotionModel) -> Option<ComposedModel> {
    let mut value = serde_json::to_value(model).ok()?;
    loop {
        let fields = value.as_object_mut()?;
        match fields.get("type")?.as_str()? {
            "composed" => {
                fields.remove("type");
                return serde_json::from_value(value).ok();
            }
            "calibrated" => value = fields.remove("model")?,
            _ => return None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::powertrain::Commanded;
    use crate::slip::NoSlip;
    use crate::{Composed, DifferentialDrive};
    use drive_traits::step::{layout, StepOptions};
    use drive_traits::{Input, Learner, Phase, Pose, RobotDescription, Window};

    fn corrected() -> (ComposedModel, ComposedModel, RobotDescription) {
        let robot = RobotDescription::new("toy", "", 10.0, 3, DifferentialDrive::new(0.1, 0.5));
        let w = Window::new(
            0,
            0,
            Phase::Transient,
            vec![Input::new(10.0, 10.0, 0.0); 3],
            vec![Input::zeros(); 3],
            vec![Pose::zeros(); 3],
            vec![0.0; 3],
        );
        let prior = Composed::new(Commanded, NoSlip)
            .fit(&WindowSet::new(&robot, &[w]))
            .unwrap();
        let model = ComposedModel {
            slip: Box::new(CorrectedSlip {
                prior: prior.slip.clone_box(),
                correction: SlipCorrection {
                    basis: SlipBasis::SkidSteer,
                    weights: [vec![0.2], vec![0.1], vec![0.05, -0.1, 0.3]],
                },
            }),
            ..prior.clone()
        };
        (model, prior, robot)
    }

    #[test]
    fn a_corrected_model_steps_as_it_predicts_and_reads_back_the_same() {
        let (model, prior, robot) = corrected();
        let commands: Vec<Input> = (0..30)
            .map(|k| Input::new(8.0 + 0.1 * k as f64, 12.0 - 0.2 * k as f64, 0.0))
            .collect();
        let start = StartState::at_rest(Pose::new(1.0, -2.0, 0.3));
        let predicted = model.predict(&start, &commands);
        // The correction changes the motion (a fifth of the forward speed lost).
        assert!((prior.predict(&start, &commands)[29] - predicted[29]).norm() > 0.1);
        let stepper = model.stepper(StepOptions::default()).unwrap();
        let mut state = vec![0.0; stepper.state_len()];
        stepper.init(&start, &[], &mut state).unwrap();
        for (k, u) in commands.iter().enumerate().take(commands.len() - 1) {
            stepper.step(&mut state, u).unwrap();
            let p = layout::pose(&state);
            assert!(
                (p - predicted[k + 1]).norm() < 1e-12,
                "step {k}: {p} against {}",
                predicted[k + 1]
            );
        }
        // Saved and read back like any model (its type tag, the prior's slip inside).
        let json = crate::model_file::model_to_json(&model, &robot).unwrap();
        assert!(json.contains("\"corrected-slip\""), "{json}");
        let back = crate::model_file::read_model_file("corrected", &json).unwrap();
        assert_eq!(back.model.predict(&start, &commands), predicted);
        // A correction with the wrong number of weights is refused on reading.
        let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
        let yaw = &mut v["model"]["slip"]["correction"]["weights"][2];
        assert_eq!(yaw.as_array().map(Vec::len), Some(3), "{json}");
        *yaw = serde_json::json!([0.05, -0.1]);
        let err = crate::model_file::read_model_file("bad", &v.to_string()).unwrap_err();
        assert!(err.to_string().contains("2 weights"), "{err}");
    }
}
