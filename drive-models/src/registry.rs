//! The project's model parts by name, and model names resolved into parts.
//!
//! A model is named by its parts, `SLIP_LEARNER+POWERTRAIN` (`slip-blr+fopdt`) or
//! `BASELINE+POWERTRAIN` (`acc-blr+commanded`); the vehicle comes from the data. A learner
//! named alone runs on its default powertrain, and the paper's names are aliases:
//!
//! | name | means |
//! |---|---|
//! | `naive` | `no-slip+commanded`: eq. 4 on the commands |
//! | `powertrain` | `no-slip+fopdt`: the powertrain-aware model (eq. 3 + 4) |
//! | `slip-blr` | `slip-blr+fopdt`: the paper's slip-based BLR (eq. 3-7) |
//! | `acc-blr` | `acc-blr+commanded`: the acceleration-BLR baseline |

use crate::baselines::AccBlr;
use crate::calibration::{Calibrator, Uncertainty};
use crate::powertrain::{Commanded, Fopdt, RateLimited};
use crate::slip::{NoSlip, SlipBlr, SlipIpem};
use crate::vehicles::{Ackermann, Omnidirectional};
use crate::{Composed, DifferentialDrive};
use drive_traits::{
    Baseline, CommandModel, FitError, FitPowertrain, FitSlip, Learner, MotionModel, Registry,
    RegistryError, RegistryItem, StartInfo, Tagged, Window, WindowSet,
};
use serde::Serialize;
use std::sync::Arc;

/// The paper's powertrain, used by a slip learner named without one.
pub const DEFAULT_POWERTRAIN: &str = "fopdt";

/// A model name that stands for another (`naive` for `no-slip+commanded`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModelAlias {
    /// The model name it stands for.
    pub target: String,
}

impl RegistryItem for ModelAlias {}

/// The vehicles of this project: `differential` (eq. 4), `ackermann` (a car) and
/// `omnidirectional` (a mecanum base, three inputs).
pub fn builtin_vehicles() -> Registry<dyn CommandModel> {
    let mut r: Registry<dyn CommandModel> = Registry::new("vehicle");
    let parts: [(&str, &str, Arc<dyn CommandModel>); 3] = [
        (
            "differential",
            "ideal differential drive of a skid-steer robot (eq. 4); inputs: left and right wheel angular velocities [rad/s]; geometry: wheel_radius, baseline",
            Arc::new(DifferentialDrive::new(0.165, 0.55)),
        ),
        (
            "ackermann",
            "kinematic bicycle of a car-like robot, body frame at the rear axle; inputs: speed [m/s] and steering angle [rad]; geometry: wheelbase, max_steering",
            Arc::new(Ackermann::new(0.57, 0.3665)),
        ),
        (
            "omnidirectional",
            "omnidirectional (mecanum) base commanded in body velocity; inputs: v_x [m/s], v_y [m/s] and w [rad/s]; geometry: half_wheelbase, half_track",
            Arc::new(Omnidirectional::new(0.319, 0.2775)),
        ),
    ];
    for (name, description, part) in parts {
        // Distinct built-in names and tags.
        r.register_trusted(name, description, part)
            .expect("distinct built-in vehicles");
    }
    r
}

/// The powertrains of this project: `commanded`, `fopdt` (eq. 3), `rate-limited`.
pub fn builtin_powertrains() -> Registry<dyn FitPowertrain> {
    let mut r: Registry<dyn FitPowertrain> = Registry::new("powertrain");
    let parts: [(&str, &str, Arc<dyn FitPowertrain>); 3] = [
        (
            "commanded",
            "the commands, reached at once and unbounded (the manufacturer's assumption)",
            Arc::new(Commanded),
        ),
        (
            "fopdt",
            "first order plus dead time per input axis, saturated at the measured limits (eq. 3)",
            Arc::new(Fopdt::default()),
        ),
        (
            "rate-limited",
            "first order plus dead time with a rate (acceleration) limit per input axis",
            Arc::new(RateLimited::default()),
        ),
    ];
    for (name, description, part) in parts {
        // Distinct built-in names and tags.
        r.register_trusted(name, description, part)
            .expect("distinct built-in powertrains");
    }
    r
}

/// The slip learners of this project: `no-slip`, `slip-blr` (eq. 5-7), `slip-ipem`.
pub fn builtin_slip_learners() -> Registry<dyn FitSlip> {
    let mut r: Registry<dyn FitSlip> = Registry::new("slip learner");
    let parts: [(&str, &str, Arc<dyn FitSlip>); 3] = [
        (
            "no-slip",
            "no slip (g = 0): the vehicle moves at the commanded body velocity",
            Arc::new(NoSlip),
        ),
        (
            "slip-blr",
            "the paper's slip-based Bayesian linear regression (eq. 5-7)",
            Arc::new(SlipBlr::default()),
        ),
        (
            "slip-ipem",
            "slip nonlinear in the commanded body velocity, with a body lag and a yaw disturbance from the IMU, fitted with argmin on the multi-step (integrated) prediction error of its rollouts; ridge strength chosen on an inner split of the training windows",
            Arc::new(SlipIpem::default()),
        ),
    ];
    for (name, description, part) in parts {
        // Distinct built-in names and tags.
        r.register_trusted(name, description, part)
            .expect("distinct built-in slip learners");
    }
    r
}

/// The baselines of this project: `acc-blr`.
pub fn builtin_baselines() -> Registry<dyn Baseline> {
    let mut r: Registry<dyn Baseline> = Registry::new("baseline");
    // One built-in name: it cannot clash.
    r.register_trusted(
        "acc-blr",
        "acceleration-based BLR (McKinnon and Schoellig 2019), the paper's baseline; on the commanded powertrain by default",
        Arc::new(AccBlr::default()),
    )
    .expect("a fresh registry");
    r
}

/// The paper's model names: `naive` and `powertrain`.
pub fn builtin_aliases() -> Registry<ModelAlias> {
    let mut r: Registry<ModelAlias> = Registry::new("model alias");
    for (name, description, target) in [
        (
            "naive",
            "the manufacturer's model: eq. 4 on the commands",
            "no-slip+commanded",
        ),
        (
            "powertrain",
            "the paper's powertrain-aware model: eq. 4 on the FOPDT's predictions",
            "no-slip+fopdt",
        ),
    ] {
        r.register_trusted(
            name,
            description,
            Arc::new(ModelAlias {
                target: target.into(),
            }),
        )
        .expect("distinct built-in aliases");
    }
    r
}

/// What a model is built from.
#[derive(Clone)]
enum Parts {
    Composed(Arc<dyn FitPowertrain>, Arc<dyn FitSlip>),
    Baseline(Arc<dyn Baseline>, Option<Arc<dyn FitPowertrain>>),
}

/// Whether a model's learner is a slip learner (composed with the vehicle and a
/// powertrain) or a baseline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LearnerKind {
    /// A slip learner.
    Slip,
    /// A whole-model baseline.
    Baseline,
}

/// A resolved model name: its learner, its powertrain and the parts to fit.
#[derive(Clone, Serialize)]
pub struct ModelSpec {
    /// The name asked for (`slip-blr`, `naive`, `slip-blr+commanded`).
    pub name: String,
    /// The learner: a registered slip learner or baseline.
    pub learner: String,
    /// The powertrain (`None` for a baseline without one).
    pub powertrain: Option<String>,
    /// Slip learner or baseline.
    pub kind: LearnerKind,
    /// How the fitted model's pose covariance is made (calibrated by default).
    pub uncertainty: Uncertainty,
    /// The calibration's settings (with [`Uncertainty::Calibrated`]).
    pub calibrator: Calibrator,
    /// What the model's predictions start from, in its calibration and its evaluation.
    pub start: StartInfo,
    #[serde(skip)]
    parts: Parts,
}

impl std::fmt::Debug for ModelSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ModelSpec")
            .field("name", &self.name)
            .field("model", &self.canonical())
            .finish()
    }
}

impl PartialEq for ModelSpec {
    /// Two specs are the same model when their parts are (whatever they were called).
    fn eq(&self, other: &Self) -> bool {
        self.canonical() == other.canonical()
    }
}

impl ModelSpec {
    /// The model's full name, `learner+powertrain` (or the learner of a baseline without a
    /// powertrain).
    pub fn canonical(&self) -> String {
        match &self.powertrain {
            Some(p) => format!("{}+{p}", self.learner),
            None => self.learner.clone(),
        }
    }

    /// Fits the model on the training windows; with [`Uncertainty::Calibrated`] (the
    /// default) a model with a pose covariance is calibrated on held-out training intervals
    /// (see [`crate::calibration`]), which fits it once more on the intervals before them.
    ///
    /// The fit sees what the predictions will: the localization's start velocities
    /// ([`Window::start_velocity`]) only when [`ModelSpec::start`] gives them
    /// ([`StartInfo::EncodersImuLocalization`]), and the IMU ([`Window::imu_yaw_rate`]) only
    /// when it gives it (not with [`StartInfo::Encoders`]: the column is then NaN, "not
    /// measured"), so that no model is fitted for a start it will not have.
    ///
    /// A model that learns anything is refused on windows whose commands never drive one
    /// of the vehicle's input axes ([`undriven_axis`]): it would extrapolate to every
    /// command of that axis (an omnidirectional base trained by a protocol that never
    /// commands a lateral speed: slip weights of thousands on noise).
    pub fn fit(&self, train: &WindowSet<'_>) -> Result<Box<dyn MotionModel>, FitError> {
        self.check_driven(train)?;
        self.as_predicted(train, |train| self.fit_as_predicted(train))
    }

    /// `Err` when the model learns from the data and `train` never drives an input axis.
    fn check_driven(&self, train: &WindowSet<'_>) -> Result<(), FitError> {
        let learns = match &self.parts {
            Parts::Composed(powertrain, slip) => {
                powertrain.fitted_tag().tag != crate::powertrain::CommandedPowertrain::TAG
                    || slip.fitted_tag().tag != crate::slip::NoSlipModel::TAG
            }
            Parts::Baseline(..) => true,
        };
        match undriven_axis(train) {
            Some(detail) if learns => Err(FitError::DegenerateInputs {
                what: self.canonical(),
                detail,
            }),
            _ => Ok(()),
        }
    }

    /// Runs `fit` on the training windows as the predictions will see them: without their
    /// start velocities unless [`ModelSpec::start`] gives them, without the IMU (NaN) when
    /// it does not give it (a copy, when anything is taken away).
    fn as_predicted<R>(&self, train: &WindowSet<'_>, fit: impl FnOnce(&WindowSet<'_>) -> R) -> R {
        let drop_velocity = self.start != StartInfo::EncodersImuLocalization
            && train.windows.iter().any(|w| w.start_velocity.is_some());
        let drop_imu = self.start == StartInfo::Encoders;
        if !drop_velocity && !drop_imu {
            return fit(train);
        }
        let owned: Vec<Window> = train
            .windows
            .iter()
            .map(|&w| {
                let mut w = w.clone();
                if drop_velocity {
                    w.start_velocity = None;
                }
                if drop_imu {
                    w.imu_yaw_rate.fill(f64::NAN);
                }
                w
            })
            .collect();
        fit(&WindowSet {
            robot: train.robot,
            windows: owned.iter().collect(),
        })
    }

    /// [`ModelSpec::fit`] on windows that hold what the predictions will start from.
    fn fit_as_predicted(&self, train: &WindowSet<'_>) -> Result<Box<dyn MotionModel>, FitError> {
        if self.uncertainty == Uncertainty::Paper {
            return self.fit_uncalibrated(train);
        }
        let calibrator = Calibrator {
            difficulty: self.calibrator.difficulty && self.uncertainty == Uncertainty::Calibrated,
            ..self.calibrator
        };
        match &self.parts {
            Parts::Composed(powertrain, slip) => {
                let learner =
                    Composed::from_parts(self.canonical(), powertrain.clone(), slip.clone());
                let model = Learner::fit(&learner, train)?;
                // Each fold is fitted from scratch, hyperparameters included: nothing of the
                // held-out windows reaches the fits that score them.
                calibrator.calibrate(Box::new(model), train, self.start, |inner| {
                    Ok(Box::new(Learner::fit(&learner, inner)?))
                })
            }
            Parts::Baseline(..) => {
                let model = self.fit_uncalibrated(train)?;
                calibrator.calibrate(model, train, self.start, |inner| {
                    self.fit_uncalibrated(inner)
                })
            }
        }
    }

    /// Fits the model on the training windows with its own uncertainty (the paper's
    /// propagation), as [`Uncertainty::Paper`] does.
    pub fn fit_uncalibrated(
        &self,
        train: &WindowSet<'_>,
    ) -> Result<Box<dyn MotionModel>, FitError> {
        self.check_driven(train)?;
        self.as_predicted(train, |train| self.fit_parts(train))
    }

    /// [`ModelSpec::fit_uncalibrated`] on windows that hold what the predictions will start
    /// from.
    fn fit_parts(&self, train: &WindowSet<'_>) -> Result<Box<dyn MotionModel>, FitError> {
        match &self.parts {
            Parts::Composed(powertrain, slip) => Ok(Box::new(Learner::fit(
                &Composed::from_parts(self.canonical(), powertrain.clone(), slip.clone()),
                train,
            )?)),
            Parts::Baseline(baseline, powertrain) => {
                baseline.fit_with(train, powertrain.as_deref())
            }
        }
    }

    /// The same model with another uncertainty method, its predictions (in its calibration
    /// and its evaluation) starting from what `start` allows.
    ///
    /// ```
    /// use drive_models::calibration::Uncertainty;
    /// use drive_traits::StartInfo;
    /// # let (p, s, b, a) = (drive_models::registry::builtin_powertrains(), drive_models::registry::builtin_slip_learners(),
    /// #     drive_models::registry::builtin_baselines(), drive_models::registry::builtin_aliases());
    /// # let models = drive_models::Models { powertrains: &p, slip_learners: &s, baselines: &b, aliases: &a };
    /// let spec = models.resolve("slip-blr").unwrap().with_uncertainty(Uncertainty::Paper, StartInfo::Encoders);
    /// assert_eq!((spec.uncertainty, spec.start), (Uncertainty::Paper, StartInfo::Encoders));
    /// ```
    pub fn with_uncertainty(mut self, uncertainty: Uncertainty, start: StartInfo) -> Self {
        self.uncertainty = uncertainty;
        self.start = start;
        self
    }

    /// A fit of this model that grows with the training data ([`crate::GrowingFit`]), for a
    /// composed model whose slip learner fits online; `None` otherwise.
    pub fn growing(&self, robot: &drive_traits::RobotDescription) -> Option<crate::GrowingFit> {
        match &self.parts {
            Parts::Composed(powertrain, slip) => {
                Composed::from_parts(self.canonical(), powertrain.clone(), slip.clone())
                    .growing(robot)
            }
            Parts::Baseline(..) => None,
        }
    }

    /// The same model under another name.
    pub fn named(mut self, name: &str) -> Self {
        self.name = name.to_string();
        self
    }
}

/// The model-part registries, borrowed: resolves model names and lists every combination.
#[derive(Clone, Copy)]
pub struct Models<'a> {
    /// Powertrains.
    pub powertrains: &'a Registry<dyn FitPowertrain>,
    /// Slip learners.
    pub slip_learners: &'a Registry<dyn FitSlip>,
    /// Baselines.
    pub baselines: &'a Registry<dyn Baseline>,
    /// The paper's names and other aliases.
    pub aliases: &'a Registry<ModelAlias>,
}

impl<'a> Models<'a> {
    /// Resolves a model name: `learner+powertrain`, a learner alone (on its default
    /// powertrain) or an alias.
    ///
    /// ```
    /// use drive_models::registry::*;
    /// let (p, s, b, a) = (builtin_powertrains(), builtin_slip_learners(), builtin_baselines(), builtin_aliases());
    /// let models = Models { powertrains: &p, slip_learners: &s, baselines: &b, aliases: &a };
    /// assert_eq!(models.resolve("slip-blr").unwrap().canonical(), "slip-blr+fopdt");
    /// assert_eq!(models.resolve("naive").unwrap().canonical(), "no-slip+commanded");
    /// assert_eq!(models.resolve("acc-blr").unwrap().canonical(), "acc-blr+commanded");
    /// assert_eq!(models.resolve("slip-blr+rate-limited").unwrap().powertrain.as_deref(), Some("rate-limited"));
    /// assert!(models.resolve("slip-blr+turbo").is_err());
    /// assert!(models.resolve("magic").unwrap_err().to_string().starts_with("unknown model 'magic'"));
    /// ```
    pub fn resolve(&self, name: &str) -> Result<ModelSpec, RegistryError> {
        self.resolve_depth(name, 0)
    }

    fn resolve_depth(&self, name: &str, depth: usize) -> Result<ModelSpec, RegistryError> {
        let bad = |reason: String| RegistryError::BadModel {
            name: name.to_string(),
            reason,
        };
        // `/` is accepted for the sweep files written before `+`.
        if let Some((learner, powertrain)) = name.split_once(['+', '/']) {
            // An unknown learner makes the whole name unknown (a file path, `runs/m.json`,
            // is no learner and powertrain).
            if self.slip_learners.find(learner).is_none()
                && self.baselines.find(learner).is_none()
                && self.aliases.find(learner).is_none()
            {
                return Err(self.unknown(name));
            }
            let pt = self.powertrains.get(powertrain)?;
            if let Some(slip) = self.slip_learners.find(learner) {
                return Ok(ModelSpec {
                    name: name.to_string(),
                    learner: learner.to_string(),
                    powertrain: Some(powertrain.to_string()),
                    kind: LearnerKind::Slip,
                    uncertainty: Uncertainty::default(),
                    calibrator: Calibrator::default(),
                    start: StartInfo::default(),
                    parts: Parts::Composed(pt.part().clone(), slip.part().clone()),
                });
            }
            if let Some(b) = self.baselines.find(learner) {
                if b.part().default_powertrain().is_none() {
                    return Err(bad(format!(
                        "the baseline '{learner}' takes no powertrain; write '{learner}' alone"
                    )));
                }
                return Ok(ModelSpec {
                    name: name.to_string(),
                    learner: learner.to_string(),
                    powertrain: Some(powertrain.to_string()),
                    kind: LearnerKind::Baseline,
                    uncertainty: Uncertainty::default(),
                    calibrator: Calibrator::default(),
                    start: StartInfo::default(),
                    parts: Parts::Baseline(b.part().clone(), Some(pt.part().clone())),
                });
            }
            if let Some(a) = self.aliases.find(learner) {
                return Err(bad(format!(
                    "'{learner}' names a whole model ({}); write it alone, or name a slip learner and a powertrain",
                    a.part().target
                )));
            }
            return Err(self.unknown(name));
        }
        if let Some(a) = self.aliases.find(name) {
            if depth > 8 {
                return Err(bad("the alias refers to itself".into()));
            }
            return Ok(self.resolve_depth(&a.part().target, depth + 1)?.named(name));
        }
        if self.slip_learners.contains(name) {
            return Ok(self
                .resolve_depth(&format!("{name}+{DEFAULT_POWERTRAIN}"), depth + 1)?
                .named(name));
        }
        if let Some(b) = self.baselines.find(name) {
            return match b.part().default_powertrain() {
                Some(p) => Ok(self
                    .resolve_depth(&format!("{name}+{p}"), depth + 1)?
                    .named(name)),
                None => Ok(ModelSpec {
                    name: name.to_string(),
                    learner: name.to_string(),
                    powertrain: None,
                    kind: LearnerKind::Baseline,
                    uncertainty: Uncertainty::default(),
                    calibrator: Calibrator::default(),
                    start: StartInfo::default(),
                    parts: Parts::Baseline(b.part().clone(), None),
                }),
            };
        }
        Err(self.unknown(name))
    }

    fn unknown(&self, name: &str) -> RegistryError {
        let mut known: Vec<&str> = self.aliases.names();
        known.extend(self.slip_learners.names());
        known.extend(self.baselines.names());
        RegistryError::Unknown {
            kind: "model",
            name: name.to_string(),
            known: format!(
                "{}, or LEARNER+POWERTRAIN with the powertrains {}",
                known.join(", "),
                self.powertrains.names().join(", ")
            ),
        }
    }

    /// Every registered combination: each slip learner on each powertrain, each baseline on
    /// each powertrain (or alone when it takes none). Named by their full names.
    pub fn all(&self) -> Vec<ModelSpec> {
        let mut out = Vec::new();
        for s in self.slip_learners.names() {
            for p in self.powertrains.names() {
                // Both names are registered.
                if let Ok(m) = self.resolve(&format!("{s}+{p}")) {
                    out.push(m);
                }
            }
        }
        for b in self.baselines.entries() {
            if b.part().default_powertrain().is_some() {
                for p in self.powertrains.names() {
                    if let Ok(m) = self.resolve(&format!("{}+{p}", b.name())) {
                        out.push(m);
                    }
                }
            } else if let Ok(m) = self.resolve(b.name()) {
                out.push(m);
            }
        }
        out
    }

    /// Resolves a list of names; `all` stands for [`Models::all`].
    pub fn resolve_list<S: AsRef<str>>(
        &self,
        names: &[S],
    ) -> Result<Vec<ModelSpec>, RegistryError> {
        let mut out = Vec::new();
        for n in names {
            match n.as_ref() {
                "all" => out.extend(self.all()),
                n => out.push(self.resolve(n)?),
            }
        }
        Ok(out)
    }
}

/// Why `train` cannot identify a model over the vehicle's whole input space, if it cannot:
/// an input axis that is never commanded (its commands never leave zero by more than 1% of
/// the largest value measured on it: the measurements' noise). `None` for windows that
/// command every axis (a single held command does), and for an empty set (the fit says so
/// itself).
///
/// ```
/// use drive_models::registry::undriven_axis;
/// use drive_traits::{Input, Phase, Pose, RobotDescription, Window, WindowSet};
/// let robot = RobotDescription::new("omni", "", 20.0, 2, drive_models::vehicles::Omnidirectional::new(0.3, 0.25));
/// let window = |command: Input, measured: Input| {
///     Window::new(0, 0, Phase::Steady, vec![command; 2], vec![measured; 2], vec![Pose::zeros(); 2], vec![0.0; 2])
/// };
/// // Forward and turning, never sideways; the lateral odometry reads noise.
/// let straight = [window(Input::new(1.0, 0.0, 0.5), Input::new(0.9, 0.01, 0.4)),
///                 window(Input::new(-1.0, 0.0, -0.5), Input::new(-0.9, -0.02, -0.4))];
/// let set = WindowSet { robot: &robot, windows: straight.iter().collect() };
/// assert!(undriven_axis(&set).unwrap().contains("'v_y'"));
/// let sideways = window(Input::new(0.0, 0.5, 0.0), Input::new(0.0, 0.45, 0.0));
/// let set = WindowSet { robot: &robot, windows: straight.iter().chain([&sideways]).collect() };
/// assert_eq!(undriven_axis(&set), None);
/// ```
pub fn undriven_axis(train: &WindowSet<'_>) -> Option<String> {
    let axes = train.robot.vehicle.axes();
    for (i, axis) in axes.iter().enumerate().take(drive_traits::MAX_INPUTS) {
        let largest = |of: fn(&Window) -> &Vec<drive_traits::Input>| {
            train
                .windows
                .iter()
                .flat_map(|w| of(w).iter().map(|u| u[i].abs()))
                .fold(0.0f64, f64::max)
        };
        let (commanded, measured) = (largest(|w| &w.command), largest(|w| &w.measured));
        if train.windows.is_empty() || commanded > 0.01 * measured {
            continue;
        }
        return Some(format!(
            "the training commands never drive the input axis '{}' (they reach {} {} where {} {} is measured): a model fitted on them would extrapolate to every command of that axis; train on data that drives every axis (the uniform protocol does)",
            axis.name,
            drive_traits::limits::Short(commanded),
            axis.unit,
            drive_traits::limits::Short(measured),
            axis.unit
        ));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Builtin {
        p: Registry<dyn FitPowertrain>,
        s: Registry<dyn FitSlip>,
        b: Registry<dyn Baseline>,
        a: Registry<ModelAlias>,
    }
    impl Builtin {
        fn new() -> Self {
            Builtin {
                p: builtin_powertrains(),
                s: builtin_slip_learners(),
                b: builtin_baselines(),
                a: builtin_aliases(),
            }
        }
        fn models(&self) -> Models<'_> {
            Models {
                powertrains: &self.p,
                slip_learners: &self.s,
                baselines: &self.b,
                aliases: &self.a,
            }
        }
    }

    #[test]
    fn the_papers_names_mean_what_they_meant() {
        let b = Builtin::new();
        let m = b.models();
        for (name, canonical) in [
            ("naive", "no-slip+commanded"),
            ("powertrain", "no-slip+fopdt"),
            ("slip-blr", "slip-blr+fopdt"),
            ("acc-blr", "acc-blr+commanded"),
            ("slip-blr/commanded", "slip-blr+commanded"),
        ] {
            let spec = m.resolve(name).unwrap();
            assert_eq!(spec.canonical(), canonical);
            assert_eq!(spec.name, name);
        }
    }

    #[test]
    fn all_combinations_and_bad_names() {
        let b = Builtin::new();
        let m = b.models();
        let all: Vec<String> = m.all().iter().map(ModelSpec::canonical).collect();
        assert_eq!(all.len(), 3 * 3 + 3);
        assert!(all.contains(&"slip-blr+rate-limited".to_string()));
        assert!(all.contains(&"slip-ipem+fopdt".to_string()));
        assert!(all.contains(&"acc-blr+fopdt".to_string()));
        for (bad, needle) in [
            ("naive+fopdt", "names a whole model"),
            ("slip-blr+turbo", "unknown powertrain 'turbo'"),
            ("gp", "unknown model 'gp'"),
            ("gp+fopdt", "unknown model 'gp+fopdt'"),
            ("gp+turbo", "unknown model 'gp+turbo'"),
            // A path is no learner and powertrain.
            ("/tmp/runs/m.json", "unknown model '/tmp/runs/m.json'"),
        ] {
            let e = m.resolve(bad).unwrap_err().to_string();
            assert!(e.contains(needle), "{bad}: {e}");
        }
    }

    #[test]
    fn builtin_tags_are_checked_by_typetag() {
        let b = Builtin::new();
        b.p.check_tags().unwrap();
        b.s.check_tags().unwrap();
        b.b.check_tags().unwrap();
        builtin_vehicles().check_tags().unwrap();
    }
}
