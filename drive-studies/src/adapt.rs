//! Adaptation to new ground (`drive adapt`, issue 61): a prior fitted elsewhere, fed the
//! target run's training half in time order ([`drive_models::adapt::SlipAdapter`]), scored
//! on the target's evaluation half after t seconds of it, beside the prior alone
//! (`frozen`), a model fitted from scratch on the same t seconds (`scratch`) and one fitted
//! on the whole training half (`own`).

use crate::{ExperimentError, Registries};
use drive_eval::{evaluate_errors, split_by_interval};
use drive_models::adapt::{composed_of, AdapterConfig, PrequentialRecord, SlipAdapter};
use drive_models::calibration::Uncertainty;
use drive_models::ModelSpec;
use drive_traits::{Dataset, MotionModel, WindowSet};
use rayon::prelude::*;
use serde::Serialize;

/// The times (s of the target's training half) after which the adapted model is scored.
pub const ADAPT_TIMES_S: [f64; 6] = [0.0, 15.0, 30.0, 60.0, 120.0, 240.0];

/// The models adapted by default (`drive adapt --models`), comma-separated.
pub const ADAPT_MODELS: &str = "slip-blr,slip-ipem";

/// A target command beyond this share of the prior's largest commanded speed or yaw rate
/// is extrapolation ([`Extrapolation`]).
pub const EXTRAPOLATION_MARGIN: f64 = 1.1;

/// Where the prior comes from.
pub enum AdaptPrior<'a> {
    /// Fitted on every window of a dataset (each model listed).
    Data(&'a Dataset),
    /// A fitted model (a model file's): the only model adapted.
    Model(&'a dyn MotionModel),
}

/// The settings of an adaptation study ([`adapt`]).
#[derive(Debug, Clone, PartialEq)]
pub struct AdaptStudy {
    /// The target's share of intervals for its training half (the rest is scored on).
    pub split: f64,
    /// Seconds of the training half after which the models are scored (those beyond the
    /// half are left out).
    pub times_s: Vec<f64>,
    /// The adapter's settings (its start is each model's own).
    pub config: AdapterConfig,
    /// Datasets of the same robot on other grounds: when any is given, each learner's fit
    /// on each of them and the prior make a terrain library ([`crate::TerrainLibrary`],
    /// forgetting with `config.selection_s`), blended by their likelihood of the target's
    /// windows as they are driven (`library` in the curves).
    pub library: Vec<std::sync::Arc<Dataset>>,
}

impl Default for AdaptStudy {
    fn default() -> Self {
        AdaptStudy {
            split: 0.5,
            times_s: ADAPT_TIMES_S.to_vec(),
            config: AdapterConfig::default(),
            library: Vec::new(),
        }
    }
}

/// One point of a curve: a model's eq. 8 medians over the target's evaluation half.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AdaptPoint {
    /// The model adapted (`slip-blr`).
    pub learner: String,
    /// `adaptive`, `frozen`, `scratch`, `own` or `library`.
    pub model: &'static str,
    /// Seconds of the target's training half seen.
    pub t_s: f64,
    /// Median translational error (eq. 8), m; `None` when no model could be fitted.
    pub translational_median_m: Option<f64>,
    /// Median rotational error (eq. 8), rad.
    pub rotational_median_rad: Option<f64>,
    /// For `adaptive`: whether the detector found the ground changed (a correction kept).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ground_changed: Option<bool>,
    /// Why there is no model (`scratch` at t = 0, a fit refused on too few windows).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    /// For `library`: each library model's weight in the blend, in the order of
    /// [`Adaptation::library`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub weights: Option<Vec<f64>>,
}

/// How far the target's commands go beyond the prior's: there the prior extrapolates, and
/// what adaptation corrects is not the ground alone.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Extrapolation {
    /// The largest |commanded forward speed| (m/s) and |yaw rate| (rad/s) of the prior's
    /// data.
    pub prior_max: [f64; 2],
    /// The same of the target's training half.
    pub target_max: [f64; 2],
    /// The prior's commanded body velocities, per axis (forward, lateral m/s; yaw rad/s):
    /// `[min, max]`.
    pub prior_range: [[f64; 2]; 3],
    /// The same of the target's training half.
    pub target_range: [[f64; 2]; 3],
    /// The target's training windows with a command beyond the prior's in some axis and
    /// direction (beyond [`EXTRAPOLATION_MARGIN`] times the prior's largest that way, or
    /// that way at all where the prior never went: driving backward when it only drove
    /// forward).
    pub windows_beyond: usize,
    /// Their share of the training half.
    pub share_beyond: f64,
}

/// The most windows of the ground driven an [`AdaptiveFit`] keeps for its refits (the
/// last ones: 6 minutes of 2 s windows).
pub const REFIT_MEMORY_WINDOWS: usize = 180;

/// Growth of the windows driven, since the last refit, that refits (as
/// [`drive_models::GrowingFit`]): the refits cost `O(n)` in all, not one per window.
pub const REFIT_GROWTH: f64 = 1.5;

/// The fewest intervals a refit is scored on before it may take over.
pub const REFIT_MIN_SCORED: usize = 3;

/// A prior adapting to the ground it drives on, for any composed model: its slip corrected
/// online ([`SlipAdapter`]) and, beside it, the model refitted from scratch on the windows
/// driven (once [`drive_models::adapt::MIN_INTERVALS`] intervals are in, then each time
/// they grew by [`REFIT_GROWTH`], on the last [`REFIT_MEMORY_WINDOWS`]). Each interval is
/// predicted by both before either learns from it (eq. 8 errors of its windows); each refit
/// takes over once it predicted at least [`REFIT_MIN_SCORED`] intervals since it was made
/// better beyond their spread ([`PrequentialRecord`]), as the correction takes over from the
/// prior.
pub struct AdaptiveFit {
    spec: ModelSpec,
    robot: drive_traits::RobotDescription,
    adapter: SlipAdapter,
    selection_s: f64,
    /// The windows driven and kept for the refits.
    seen: Vec<drive_traits::Window>,
    /// The interval being driven: its windows, and the corrected prior before it.
    pending: Vec<drive_traits::Window>,
    before: Option<drive_models::ComposedModel>,
    refit: Option<(drive_models::ComposedModel, usize)>,
    refit_record: PrequentialRecord,
    /// Intervals the current refit was scored on.
    refit_scored: usize,
    intervals: usize,
    driven: usize,
    /// Whether the measured body velocities are the default estimator's (a saved state has
    /// it: [`AdaptiveFit::save`]).
    default_velocity: bool,
}

impl AdaptiveFit {
    /// Adapts `prior` (a composed model) with the learner `spec` for the refits, on
    /// `robot`'s data.
    pub fn new(
        prior: drive_models::ComposedModel,
        spec: &ModelSpec,
        robot: &drive_traits::RobotDescription,
        config: AdapterConfig,
    ) -> Self {
        AdaptiveFit {
            spec: spec.clone(),
            robot: robot.clone(),
            adapter: SlipAdapter::new(prior, robot, config),
            selection_s: config.selection_s,
            seen: Vec::new(),
            pending: Vec::new(),
            before: None,
            refit: None,
            refit_record: PrequentialRecord::default(),
            refit_scored: 0,
            intervals: 0,
            driven: 0,
            default_velocity: config.velocity == drive_traits::BodyVelocityEstimator::default(),
        }
    }

    /// Adds one window just driven (in time order).
    pub fn add(&mut self, window: &drive_traits::Window) {
        if self
            .pending
            .last()
            .is_some_and(|w| w.interval != window.interval)
        {
            self.commit();
        }
        if self.pending.is_empty() {
            self.before = Some(self.adapter.model());
        }
        self.adapter.add(&WindowSet {
            robot: &self.robot,
            windows: vec![window],
        });
        self.pending.push(window.clone());
        self.driven += 1;
    }

    /// Scores the interval just completed with the corrected prior and the refit as they
    /// were before it, then refits when the data has grown enough.
    fn commit(&mut self) {
        let pending = std::mem::take(&mut self.pending);
        let span: f64 = pending.len() as f64 * self.robot.window_len as f64 / self.robot.rate_hz;
        if let (Some(before), Some((refit, _))) = (&self.before, &self.refit) {
            let set = WindowSet::new(&self.robot, &pending);
            let start = self.spec.start;
            let (a, b) = (
                evaluate_errors(before, &set, start),
                evaluate_errors(refit, &set, start),
            );
            let mean_log_ratio = a
                .windows
                .iter()
                .zip(&b.windows)
                .map(|(a, b)| {
                    let r = |x: f64, y: f64| (x.max(1e-9) / y.max(1e-9)).ln();
                    0.5 * (r(a.error.translational, b.error.translational)
                        + r(a.error.rotational, b.error.rotational))
                })
                .sum::<f64>()
                / a.windows.len().max(1) as f64;
            let keep = (-span / self.selection_s.max(1e-9)).exp();
            self.refit_record.add(mean_log_ratio, keep);
            self.refit_scored += 1;
        }
        self.intervals += 1;
        self.seen.extend(pending);
        if self.seen.len() > REFIT_MEMORY_WINDOWS {
            let extra = self.seen.len() - REFIT_MEMORY_WINDOWS;
            self.seen.drain(..extra);
        }
        let grown = self
            .refit
            .as_ref()
            .is_none_or(|(_, n)| self.driven as f64 >= REFIT_GROWTH * *n as f64);
        if self.intervals >= drive_models::adapt::MIN_INTERVALS && grown {
            let fitted = self
                .spec
                .fit(&WindowSet::new(&self.robot, &self.seen))
                .ok()
                .and_then(|m| composed_of(m.as_ref()));
            if let Some(m) = fitted {
                // A new refit proves itself afresh: the record was the previous one's.
                self.refit = Some((m, self.driven));
                self.refit_record = PrequentialRecord::default();
                self.refit_scored = 0;
            }
        }
    }

    /// The windows added so far.
    pub fn windows(&self) -> usize {
        self.driven
    }

    /// The robot whose windows it adapts to.
    pub fn robot(&self) -> &drive_traits::RobotDescription {
        &self.robot
    }

    /// What its predictions start from.
    pub fn start(&self) -> drive_traits::StartInfo {
        self.spec.start
    }

    /// The prior, as given.
    pub fn prior(&self) -> &drive_models::ComposedModel {
        self.adapter.prior()
    }

    /// Whether the ground looks changed: the prior's slip corrected, or the refit kept.
    pub fn changed(&self) -> bool {
        self.adapter.changed() || self.refit_kept()
    }

    /// True when the refit predicted the recent intervals better than the corrected prior.
    pub fn refit_kept(&self) -> bool {
        self.refit.is_some()
            && self.refit_scored >= REFIT_MIN_SCORED
            && self
                .refit_record
                .significant_at(drive_models::adapt::KEEP_Z_ONE)
                .is_some()
    }

    /// The adapted model now: the refit where it is kept, else the corrected prior.
    pub fn model(&self) -> drive_models::ComposedModel {
        match &self.refit {
            Some((m, _)) if self.refit_kept() => m.clone(),
            _ => self.adapter.model(),
        }
    }
}

/// The format name of a saved adaptive state ([`AdaptiveFit::save`]).
pub const ADAPTIVE_STATE_FORMAT: &str = "drive-adaptive-state";

/// The largest saved adaptive state read (bytes): [`REFIT_MEMORY_WINDOWS`] windows of a
/// few hundred samples each and the models, with room to spare.
pub const MAX_ADAPTIVE_STATE_BYTES: u64 = 256 << 20;

/// A window as a saved state holds it (an IMU sample not given to a model, NaN, as null).
#[derive(serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct SavedWindow {
    index: usize,
    interval: usize,
    phase: drive_traits::Phase,
    command: Vec<drive_traits::Input>,
    measured: Vec<drive_traits::Input>,
    pose: Vec<drive_traits::Pose>,
    imu_yaw_rate: Vec<Option<f64>>,
    start_velocity: Option<[f64; 2]>,
}

impl SavedWindow {
    fn of(w: &drive_traits::Window) -> Self {
        SavedWindow {
            index: w.index,
            interval: w.interval,
            phase: w.phase,
            command: w.command.clone(),
            measured: w.measured.clone(),
            pose: w.pose.clone(),
            imu_yaw_rate: w
                .imu_yaw_rate
                .iter()
                .map(|v| v.is_finite().then_some(*v))
                .collect(),
            start_velocity: w.start_velocity,
        }
    }

    /// The window, or why it is not one (samples of unequal counts, fewer than two, or not
    /// finite).
    fn window(self) -> Result<drive_traits::Window, String> {
        let n = self.command.len();
        if n < 2 || self.measured.len() != n || self.pose.len() != n || self.imu_yaw_rate.len() != n
        {
            return Err(format!(
                "window {} has unequal sample counts (or fewer than two)",
                self.index
            ));
        }
        let finite = self
            .command
            .iter()
            .chain(&self.measured)
            .chain(&self.pose)
            .flat_map(|v| v.iter())
            .chain(self.start_velocity.iter().flatten())
            .all(|v| v.is_finite());
        if !finite {
            return Err(format!(
                "window {} holds a number that is not finite",
                self.index
            ));
        }
        let imu = self
            .imu_yaw_rate
            .iter()
            .map(|v| v.unwrap_or(f64::NAN))
            .collect();
        Ok(drive_traits::Window::new(
            self.index,
            self.interval,
            self.phase,
            self.command,
            self.measured,
            self.pose,
            imu,
        )
        .with_start_velocity(self.start_velocity))
    }
}

/// The whole state of an [`AdaptiveFit`], as saved.
#[derive(serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct SavedState {
    format: String,
    format_version: u32,
    /// The learner refitted: its registered name, start and uncertainty.
    model: String,
    start: drive_traits::StartInfo,
    uncertainty: Uncertainty,
    robot: drive_traits::RobotDescription,
    selection_s: f64,
    adapter: SlipAdapter,
    seen: Vec<SavedWindow>,
    pending: Vec<SavedWindow>,
    before: Option<drive_models::ComposedModel>,
    refit: Option<(drive_models::ComposedModel, usize)>,
    refit_record: PrequentialRecord,
    refit_scored: usize,
    intervals: usize,
    driven: usize,
}

impl AdaptiveFit {
    /// The whole adaptive state as JSON (format [`ADAPTIVE_STATE_FORMAT`]): the prior, the
    /// correction's sums and records, the windows kept for the refits, the refit and its
    /// record. [`AdaptiveFit::load`] reads it back into a fit that adapts on exactly as this
    /// one. An error for a fit whose measured velocities are not the default estimator's
    /// (the state does not hold it).
    ///
    /// ```
    /// use drive_studies::{AdaptiveFit, Registries};
    /// use drive_models::adapt::{composed_of, AdapterConfig};
    /// use drive_traits::Learner;
    /// let registries = Registries::builtin();
    /// let data = drive_data::bundled::load("warthog_grass_2024-08-08").unwrap();
    /// let spec = registries.models().resolve("slip-blr").unwrap();
    /// let prior = composed_of(spec.fit(&data.all()).unwrap().as_ref()).unwrap();
    /// let mut fit = AdaptiveFit::new(prior, &spec, &data.robot, AdapterConfig::default());
    /// for w in &data.windows[..30] {
    ///     fit.add(w);
    /// }
    /// let saved = fit.save().unwrap();
    /// let mut again = AdaptiveFit::load(&saved, &registries).unwrap();
    /// for w in &data.windows[30..60] {
    ///     fit.add(w);
    ///     again.add(w);
    /// }
    /// assert_eq!(fit.save().unwrap(), again.save().unwrap());
    /// ```
    pub fn save(&self) -> Result<String, ExperimentError> {
        if !self.default_velocity {
            return Err(ExperimentError::Incompatible(
                "an adaptive state is saved with the default body-velocity estimator only".into(),
            ));
        }
        // Never a state load refuses (serde_json writes a number that is not finite as null).
        self.adapter.check().map_err(|e| {
            ExperimentError::Incompatible(format!("the adaptive state is not saved: {e}"))
        })?;
        let windows = |w: &[drive_traits::Window]| w.iter().map(SavedWindow::of).collect();
        let state = SavedState {
            format: ADAPTIVE_STATE_FORMAT.into(),
            format_version: 1,
            model: self.spec.name.clone(),
            start: self.spec.start,
            uncertainty: self.spec.uncertainty,
            robot: self.robot.clone(),
            selection_s: self.selection_s,
            adapter: self.adapter.clone(),
            seen: windows(&self.seen),
            pending: windows(&self.pending),
            before: self.before.clone(),
            refit: self.refit.clone(),
            refit_record: self.refit_record.clone(),
            refit_scored: self.refit_scored,
            intervals: self.intervals,
            driven: self.driven,
        };
        serde_json::to_string(&state)
            .map_err(|e| ExperimentError::Incompatible(format!("saving the adaptive state: {e}")))
    }

    /// An adaptive fit from its saved state ([`AdaptiveFit::save`]), its learner resolved in
    /// `registries`; an error naming what is wrong in a state `save` would not write.
    pub fn load(text: &str, registries: &Registries) -> Result<AdaptiveFit, ExperimentError> {
        let bad =
            |what: String| ExperimentError::Incompatible(format!("an adaptive state: {what}"));
        // With the path of the field at fault (the file is one line).
        let mut de = serde_json::Deserializer::from_str(text.trim_start_matches('\u{feff}'));
        let state: SavedState = serde_path_to_error::deserialize(&mut de)
            .map_err(|e| bad(format!("{} (at {})", e.inner(), e.path())))?;
        de.end().map_err(|e| bad(e.to_string()))?;
        if state.format != ADAPTIVE_STATE_FORMAT || state.format_version != 1 {
            return Err(bad(format!(
                "format '{}' version {}, where {ADAPTIVE_STATE_FORMAT} version 1 is read",
                state.format, state.format_version
            )));
        }
        let spec = registries
            .models()
            .resolve(&state.model)?
            .with_uncertainty(state.uncertainty, state.start);
        let robot = &state.robot;
        use drive_traits::limits::{MAX_RATE_HZ, MAX_WINDOW_LEN, MIN_RATE_HZ};
        if !((MIN_RATE_HZ..=MAX_RATE_HZ).contains(&robot.rate_hz)
            && (2..=MAX_WINDOW_LEN).contains(&robot.window_len))
        {
            return Err(bad(format!(
                "its robot's rate ({} Hz) or window length ({}) is out of range",
                robot.rate_hz, robot.window_len
            )));
        }
        robot.vehicle.check().map_err(|e| bad(e.to_string()))?;
        state.adapter.check().map_err(|e| bad(e.to_string()))?;
        let prior = state.adapter.prior();
        // Its parts agree: the learner refitted is the prior's, every model steps at the
        // robot's rate on its vehicle type, the refit (fitted on the robot's windows) on its
        // very vehicle, the prior's start is the adapter's.
        if spec.canonical() != prior.label {
            return Err(bad(format!(
                "its learner {} is not its prior's ({})",
                spec.canonical(),
                prior.label
            )));
        }
        if state.adapter.config().start != state.start {
            return Err(bad("its start is not its adapter's".into()));
        }
        if !state.refit_record.is_valid() {
            return Err(bad(
                "its refit's record is not finite, or a weight is negative".into(),
            ));
        }
        let kind =
            |v: &dyn drive_traits::CommandModel| drive_traits::vehicle_tag(v).unwrap_or_default();
        let dt = robot.dt();
        let models = std::iter::once(prior)
            .chain(state.before.iter())
            .chain(state.refit.iter().map(|(m, _)| m));
        for m in models {
            m.check().map_err(|e| bad(e.to_string()))?;
            if (m.dt - dt).abs() > 1e-9 * dt {
                return Err(bad(format!(
                    "a model steps {} s, its robot's data {dt} s",
                    m.dt
                )));
            }
            if kind(m.vehicle.as_ref()) != kind(robot.vehicle.as_ref()) {
                return Err(bad("a model's vehicle type is not its robot's".into()));
            }
        }
        if let Some((refit, _)) = &state.refit {
            if vehicle_json(refit.vehicle.as_ref()) != vehicle_json(robot.vehicle.as_ref())
                || refit.label != prior.label
            {
                return Err(bad(
                    "its refit is not its learner fitted on its robot's vehicle".into(),
                ));
            }
        }
        let count = |n: usize| n < (1 << 40);
        let counted = [state.refit_scored, state.intervals, state.driven]
            .into_iter()
            .chain(state.refit.as_ref().map(|(_, n)| *n));
        if !counted.into_iter().all(count) {
            return Err(bad("its counts are beyond any robot's driving".into()));
        }
        if !(state.selection_s.is_finite() && state.selection_s > 0.0) {
            return Err(bad("its selection time is not finite and positive".into()));
        }
        if state.seen.len() > REFIT_MEMORY_WINDOWS {
            return Err(bad(format!(
                "{} windows kept for the refits, where at most {REFIT_MEMORY_WINDOWS} are",
                state.seen.len()
            )));
        }
        let windows = |w: Vec<SavedWindow>| -> Result<Vec<drive_traits::Window>, ExperimentError> {
            let w: Vec<drive_traits::Window> = w
                .into_iter()
                .map(SavedWindow::window)
                .collect::<Result<_, _>>()
                .map_err(bad)?;
            if w.iter().any(|w| w.len() != state.robot.window_len) {
                return Err(bad(format!(
                    "a window is not {} samples long, as its robot's",
                    state.robot.window_len
                )));
            }
            Ok(w)
        };
        let seen = windows(state.seen)?;
        let pending = windows(state.pending)?;
        let fit = AdaptiveFit {
            spec,
            robot: state.robot,
            adapter: state.adapter,
            selection_s: state.selection_s,
            seen,
            pending,
            before: state.before,
            refit: state.refit,
            refit_record: state.refit_record,
            refit_scored: state.refit_scored,
            intervals: state.intervals,
            driven: state.driven,
            default_velocity: true,
        };
        if fit.driven < fit.seen.len() + fit.pending.len() || fit.adapter.windows() > fit.driven {
            return Err(bad(format!(
                "{} windows driven, fewer than it keeps ({} and {}) or than its adapter saw ({})",
                fit.driven,
                fit.seen.len(),
                fit.pending.len(),
                fit.adapter.windows()
            )));
        }
        fit.model().check().map_err(|e| bad(e.to_string()))?;
        Ok(fit)
    }
}

/// An adaptation study's result ([`adapt`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Adaptation {
    /// The prior's name (its dataset, or its model).
    pub prior: String,
    /// The target dataset's name.
    pub target: String,
    /// The target's training share.
    pub split: f64,
    /// Seconds in the target's training half.
    pub train_s: f64,
    /// Windows in the target's training half.
    pub train_windows: usize,
    /// Windows of the target's evaluation half.
    pub evaluation_windows: usize,
    /// Every learner's four curves, point by point (`frozen` and `own` repeated at every t).
    pub curve: Vec<AdaptPoint>,
    /// Where the target's commands leave the prior's; `None` for a model-file prior (its
    /// training data is not known).
    pub extrapolation: Option<Extrapolation>,
    /// The terrain library's models, when one was given ([`AdaptStudy::library`]): the
    /// prior, then each library dataset.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub library: Vec<String>,
    /// What the numbers should be read with (the prior's vehicle geometry other than the
    /// target's, ...).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

/// The commanded body velocities' `[min, max]` per axis over `windows`.
fn commanded_range(windows: &WindowSet<'_>) -> [[f64; 2]; 3] {
    let vehicle = windows.robot.vehicle.as_ref();
    let mut r = [[0.0f64; 2]; 3];
    for w in &windows.windows {
        for u in &w.command {
            let f = vehicle.body_velocity(u);
            for (a, v) in r.iter_mut().zip([f.x, f.y, f.z]) {
                if v.is_finite() {
                    a[0] = a[0].min(v);
                    a[1] = a[1].max(v);
                }
            }
        }
    }
    r
}

/// Whether the range `got` leaves `within` in some axis and direction: beyond
/// [`EXTRAPOLATION_MARGIN`] times the prior's extreme that way, where it went that way
/// (more than 2% of its largest either way); any way at all where it did not.
fn beyond(got: &[[f64; 2]; 3], within: &[[f64; 2]; 3]) -> bool {
    got.iter().zip(within).any(|(g, w)| {
        let scale = w[0].abs().max(w[1].abs());
        let floor = 0.02 * scale + 1e-6;
        let (lo, hi) = (
            (EXTRAPOLATION_MARGIN * w[0]).min(-floor),
            (EXTRAPOLATION_MARGIN * w[1]).max(floor),
        );
        g[0] < lo || g[1] > hi
    })
}

/// `data` (named `what`, its vehicle `whose`) checked against the target: the same rate
/// and window length, the same vehicle type, and not the target's own windows (a tenth of
/// them or more, by content).
fn same_robot(
    data: &Dataset,
    target: &Dataset,
    what: &str,
    whose: &str,
) -> Result<(), ExperimentError> {
    let (p, t) = (&data.robot, &target.robot);
    let incompatible = |why: String| Err(ExperimentError::Incompatible(why));
    if p.rate_hz != t.rate_hz || p.window_len != t.window_len {
        return incompatible(format!(
            "{what} is {} Hz x {} samples per window, the target's {} Hz x {}: a model of one does not predict the other",
            p.rate_hz, p.window_len, t.rate_hz, t.window_len
        ));
    }
    let (a, b) = (crate::vehicle_type(data), crate::vehicle_type(target));
    if a != b {
        return incompatible(format!(
            "{whose}'s vehicle type is {a}, the target's {b}: adaptation follows a change of ground, not of vehicle"
        ));
    }
    let (pa, pb) = (
        crate::bench::window_prints(data),
        crate::bench::window_prints(target),
    );
    let (shared, smaller) = crate::bench::shared_windows(&pa, &pb);
    if crate::bench::same_run((shared, smaller)) {
        return incompatible(format!(
            "{what} holds the target's own windows ({shared} of the {smaller} of the one with fewer are in both): it would be scored on windows it was fitted on"
        ));
    }
    Ok(())
}

/// The vehicle's saved form, to tell two geometries apart.
fn vehicle_json(v: &dyn drive_traits::CommandModel) -> String {
    serde_json::to_string(v).unwrap_or_default()
}

/// Adapts each model of `models` (or the prior model alone) to `target`: the target's
/// training half streamed in time order into an [`AdaptiveFit`], scored on its evaluation
/// half after each of `study.times_s` beside the prior alone (`frozen`), a fit from scratch
/// on the same seconds (`scratch`) and the fit on the whole half (`own`). Models are fitted with the paper's uncertainty (the study scores
/// eq. 8 errors only).
///
/// ```no_run
/// use drive_studies::{adapt, AdaptPrior, AdaptStudy, Registries};
/// let r = Registries::builtin();
/// let prior = drive_data::bundled::load("warthog_asphalt_a").unwrap();
/// let target = drive_data::bundled::load("warthog_grass_2024-08-08").unwrap();
/// let models = r.models().resolve_list(&["slip-blr"]).unwrap();
/// let a = adapt(&r, &AdaptPrior::Data(&prior), &target, &models, &AdaptStudy::default()).unwrap();
/// for p in &a.curve {
///     println!("{} {} {} s: {:?} m", p.learner, p.model, p.t_s, p.translational_median_m);
/// }
/// ```
pub fn adapt(
    registries: &Registries,
    prior: &AdaptPrior<'_>,
    target: &Dataset,
    models: &[ModelSpec],
    study: &AdaptStudy,
) -> Result<Adaptation, ExperimentError> {
    adapt_with(Some(registries), prior, target, models, study, None, &|| {})
}

/// [`adapt`], calling `progress` once per model of `models` as its curve is done (what a
/// progress bar counts, and where a caller that is asked to stop can).
///
/// ```no_run
/// use drive_studies::{adapt_with_progress, AdaptPrior, AdaptStudy, Registries};
/// use std::sync::atomic::{AtomicUsize, Ordering};
/// let r = Registries::builtin();
/// let prior = drive_data::bundled::load("warthog_asphalt_a").unwrap();
/// let target = drive_data::bundled::load("warthog_grass_2024-08-08").unwrap();
/// let models = r.models().resolve_list(&["slip-blr", "slip-ipem"]).unwrap();
/// let done = AtomicUsize::new(0);
/// let progress = || {
///     done.fetch_add(1, Ordering::Relaxed);
/// };
/// adapt_with_progress(&r, &AdaptPrior::Data(&prior), &target, &models, &AdaptStudy::default(), &progress).unwrap();
/// assert_eq!(done.load(Ordering::Relaxed), 2);
/// ```
pub fn adapt_with_progress(
    registries: &Registries,
    prior: &AdaptPrior<'_>,
    target: &Dataset,
    models: &[ModelSpec],
    study: &AdaptStudy,
    progress: &(dyn Fn() + Sync),
) -> Result<Adaptation, ExperimentError> {
    adapt_with(
        Some(registries),
        prior,
        target,
        models,
        study,
        None,
        progress,
    )
}

/// [`adapt_with_progress`]; `registries` tells a model-file prior's own kind (to refuse
/// other models beside it), and is not needed for a dataset's prior. `fitted_library`, for
/// one model: the terrain library's members already fitted (the prior's first, calibrated,
/// as [`library_members`] fits them), used instead of fitting `study.library`'s (the
/// benchmark fits each run once for all its pairs).
pub(crate) fn adapt_with(
    registries: Option<&Registries>,
    prior: &AdaptPrior<'_>,
    target: &Dataset,
    models: &[ModelSpec],
    study: &AdaptStudy,
    fitted_library: Option<&NamedModels>,
    progress: &(dyn Fn() + Sync),
) -> Result<Adaptation, ExperimentError> {
    if models.is_empty() {
        return Err(ExperimentError::Empty("models"));
    }
    for (i, m) in models.iter().enumerate() {
        if models[..i].iter().any(|o| o.canonical() == m.canonical()) {
            return Err(ExperimentError::Incompatible(format!(
                "{} is listed twice among the models (as {})",
                m.canonical(),
                m.name
            )));
        }
    }
    let mut notes = Vec::new();
    let incompatible = |what: String| Err(ExperimentError::Incompatible(what));
    let target_vehicle = target.robot.vehicle.as_ref();
    match prior {
        AdaptPrior::Data(data) => {
            let p = &data.robot;
            same_robot(data, target, "the prior's data", "the prior")?;
            if vehicle_json(p.vehicle.as_ref()) != vehicle_json(target_vehicle) {
                notes.push(format!(
                    "the prior's vehicle ({}) is not the target's ({}): the prior predicts with its own geometry",
                    vehicle_json(p.vehicle.as_ref()),
                    vehicle_json(target_vehicle)
                ));
            }
        }
        AdaptPrior::Model(m) => {
            let dt = target.robot.dt();
            if (m.dt() - dt).abs() > 1e-9 * dt {
                return incompatible(format!(
                    "the prior model steps {} s, the target's data {} s",
                    m.dt(),
                    dt
                ));
            }
            if let Some(c) = composed_of(*m) {
                let (a, b) = (
                    drive_traits::vehicle_tag(c.vehicle.as_ref()).unwrap_or_default(),
                    drive_traits::vehicle_tag(target_vehicle).unwrap_or_default(),
                );
                if a != b {
                    return incompatible(format!(
                        "the prior model's vehicle type is {a}, the target's {b}: adaptation follows a change of ground, not of vehicle"
                    ));
                }
                if vehicle_json(c.vehicle.as_ref()) != vehicle_json(target_vehicle) {
                    notes.push(format!(
                        "the prior model's vehicle ({}) is not the target's ({}): the prior predicts with its own geometry",
                        vehicle_json(c.vehicle.as_ref()),
                        vehicle_json(target_vehicle)
                    ));
                }
            }
            // The model fitted from scratch, on the target and refitted beside it is the
            // prior's own kind.
            if let Some(Ok(own)) = registries.map(|r| r.models().resolve(&m.name())) {
                if let Some(other) = models.iter().find(|s| s.canonical() != own.canonical()) {
                    return incompatible(format!(
                        "the prior is a {} model: the models fitted from scratch, on the target and refitted beside it must be the same, not {}",
                        own.canonical(),
                        other.name
                    ));
                }
            }
        }
    }
    for data in &study.library {
        let what = format!("library dataset {}", data.robot.name);
        same_robot(data, target, &what, &what)?;
        if vehicle_json(data.robot.vehicle.as_ref()) != vehicle_json(target_vehicle) {
            notes.push(format!(
                "{what}'s vehicle ({}) is not the target's ({}): its model predicts with its own geometry",
                vehicle_json(data.robot.vehicle.as_ref()),
                vehicle_json(target_vehicle)
            ));
        }
    }
    let (train, eval) = split_by_interval(target, study.split)
        .map_err(|e| ExperimentError::NotEnoughData(e.to_string()))?;
    let window_s = target.robot.window_len as f64 / target.robot.rate_hz;
    let train_s = train.windows.len() as f64 * window_s;
    let mut times: Vec<f64> = study
        .times_s
        .iter()
        .copied()
        .filter(|t| t.is_finite() && *t >= 0.0 && *t <= train_s + 1e-9)
        .collect();
    times.sort_by(f64::total_cmp);
    times.dedup();
    if times.is_empty() {
        return Err(ExperimentError::NotEnoughData(format!(
            "no time of {:?} s is within the target's training half of {train_s} s",
            study.times_s
        )));
    }
    let seen = |t: f64| ((t / window_s) + 1e-9).floor() as usize;
    let score = |model: &dyn MotionModel, start| {
        let report = evaluate_errors(model, &eval, start);
        (
            report.translational(None).map(|s| s.median),
            report.rotational(None).map(|s| s.median),
        )
    };
    let mut curve = Vec::new();
    let mut library_names = Vec::new();
    for spec in models {
        let spec = spec
            .clone()
            .with_uncertainty(Uncertainty::Paper, spec.start);
        let fit_on = |windows: &WindowSet<'_>, name: &str| {
            spec.fit(windows).map_err(|reason| ExperimentError::Fit {
                model: spec.name.clone(),
                data: name.to_string(),
                reason,
            })
        };
        let fit = |windows: &WindowSet<'_>| fit_on(windows, &target.robot.name);
        let fitted;
        let prior_model: &dyn MotionModel = match prior {
            AdaptPrior::Data(data) => {
                fitted = fit_on(&data.all(), &format!("the prior, {}", data.robot.name))?;
                fitted.as_ref()
            }
            AdaptPrior::Model(m) => *m,
        };
        let composed = composed_of(prior_model).ok_or_else(|| {
            ExperimentError::Incompatible(format!(
                "{}: only a model composed of a powertrain and a slip model adapts",
                prior_model.name()
            ))
        })?;
        let own = fit(&train)?;
        let frozen_scores = score(prior_model, spec.start);
        let own_scores = score(own.as_ref(), spec.start);
        // The adapted model after each time: the windows streamed one at a time.
        let mut adaptive = AdaptiveFit::new(
            composed,
            &spec,
            &target.robot,
            AdapterConfig {
                start: spec.start,
                ..study.config
            },
        );
        let mut adapted = Vec::new();
        let mut fed = 0;
        for &t in &times {
            let n = seen(t).min(train.windows.len());
            while fed < n {
                adaptive.add(train.windows[fed]);
                fed += 1;
            }
            adapted.push((adaptive.model(), adaptive.changed()));
        }
        // The terrain library, blended by the likelihood of the windows driven so far.
        let mut blends = Vec::new();
        if fitted_library.is_some() || !study.library.is_empty() {
            let members = match fitted_library {
                Some(m) => m.clone(),
                None => library_members(prior, &study.library, &spec)?,
            };
            if library_names.is_empty() {
                library_names = members.iter().map(|(n, _)| n.clone()).collect();
            }
            let mut library = crate::TerrainLibrary::new(
                members,
                &target.robot,
                spec.start,
                study.config.selection_s,
            )?;
            let mut fed = 0;
            for &t in &times {
                let n = seen(t).min(train.windows.len());
                while fed < n {
                    library.add(train.windows[fed]);
                    fed += 1;
                }
                blends.push((library.model(), library.weights()));
            }
        }
        // The scratch fits are independent: on rayon's threads.
        let scratch: Vec<Result<Box<dyn MotionModel>, String>> = times
            .par_iter()
            .map(|&t| {
                let n = seen(t).min(train.windows.len());
                if n == 0 {
                    return Err("no window yet".to_string());
                }
                fit(&WindowSet {
                    robot: &target.robot,
                    windows: train.windows[..n].to_vec(),
                })
                .map_err(|e| e.to_string())
            })
            .collect();
        let learner = spec.name.clone();
        for (i, &t) in times.iter().enumerate() {
            let point = |model: &'static str, scores: (Option<f64>, Option<f64>)| AdaptPoint {
                learner: learner.clone(),
                model,
                t_s: t,
                translational_median_m: scores.0,
                rotational_median_rad: scores.1,
                ground_changed: None,
                note: None,
                weights: None,
            };
            let (model, changed) = &adapted[i];
            curve.push(AdaptPoint {
                ground_changed: Some(*changed),
                ..point("adaptive", score(model, spec.start))
            });
            curve.push(point("frozen", frozen_scores));
            curve.push(match &scratch[i] {
                Ok(m) => point("scratch", score(m.as_ref(), spec.start)),
                Err(why) => AdaptPoint {
                    note: Some(why.clone()),
                    ..point("scratch", (None, None))
                },
            });
            curve.push(point("own", own_scores));
            if let Some((blend, weights)) = blends.get(i) {
                curve.push(AdaptPoint {
                    weights: Some(weights.clone()),
                    ..point("library", score(blend, spec.start))
                });
            }
        }
        progress();
    }
    let extrapolation = match prior {
        AdaptPrior::Data(data) => {
            let prior_range = commanded_range(&data.all());
            let windows_beyond = train
                .windows
                .iter()
                .filter(|w| {
                    let one = WindowSet {
                        robot: &target.robot,
                        windows: vec![**w],
                    };
                    beyond(&commanded_range(&one), &prior_range)
                })
                .count();
            let target_range = commanded_range(&train);
            let abs_max = |r: &[[f64; 2]; 3], a: usize| r[a][0].abs().max(r[a][1].abs());
            Some(Extrapolation {
                prior_max: [abs_max(&prior_range, 0), abs_max(&prior_range, 2)],
                target_max: [abs_max(&target_range, 0), abs_max(&target_range, 2)],
                prior_range,
                target_range,
                windows_beyond,
                share_beyond: windows_beyond as f64 / train.windows.len().max(1) as f64,
            })
        }
        AdaptPrior::Model(_) => None,
    };
    Ok(Adaptation {
        prior: match prior {
            AdaptPrior::Data(d) => d.robot.name.clone(),
            AdaptPrior::Model(m) => m.name(),
        },
        target: target.robot.name.clone(),
        split: study.split,
        train_s,
        train_windows: train.windows.len(),
        evaluation_windows: eval.windows.len(),
        curve,
        extrapolation,
        library: library_names,
        notes,
    })
}

/// Models by name.
pub(crate) type NamedModels = Vec<(String, std::sync::Arc<dyn MotionModel>)>;

/// `spec` fitted on all of `data` with the calibrated uncertainty: a terrain library's
/// member (its predictive Gaussian scores the windows driven).
pub(crate) fn library_member(
    data: &Dataset,
    spec: &ModelSpec,
) -> Result<std::sync::Arc<dyn MotionModel>, ExperimentError> {
    spec.clone()
        .with_uncertainty(Uncertainty::Calibrated, spec.start)
        .fit(&data.all())
        .map(std::sync::Arc::<dyn MotionModel>::from)
        .map_err(|reason| ExperimentError::Fit {
            model: spec.name.clone(),
            data: data.robot.name.clone(),
            reason,
        })
}

/// The terrain library of `spec` for a study: the prior (fitted on its data with the
/// calibrated uncertainty, or the prior model as it is) and `spec` fitted so on each of
/// `library`, named by their data (or model).
fn library_members(
    prior: &AdaptPrior<'_>,
    library: &[std::sync::Arc<Dataset>],
    spec: &ModelSpec,
) -> Result<NamedModels, ExperimentError> {
    let fit = |data: &Dataset| library_member(data, spec);
    let first = match prior {
        AdaptPrior::Data(data) => (data.robot.name.clone(), fit(data)?),
        AdaptPrior::Model(m) => {
            // A model borrowed is copied through its saved form (as a model file holds it).
            let copy: Box<dyn MotionModel> = serde_json::to_value(*m)
                .and_then(serde_json::from_value)
                .map_err(|e| {
                    ExperimentError::Incompatible(format!(
                        "the prior model {} cannot be copied into the library: {e}",
                        m.name()
                    ))
                })?;
            (m.name(), std::sync::Arc::from(copy))
        }
    };
    let others: Vec<_> = library
        .par_iter()
        .map(|d| fit(d).map(|m| (d.robot.name.clone(), m)))
        .collect::<Result<_, _>>()?;
    Ok(std::iter::once(first).chain(others).collect())
}
