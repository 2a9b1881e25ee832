use crate::blr::{BlrPosterior, BlrStatistics, Prior};
use drive_traits::InvalidPart;
use drive_traits::{
    BodyVelocity, BodyVelocityEstimator, CommandModel, FitError, OnlineSlip, RobotDescription,
    SlipData, SlipFeatures, SlipLearner, SlipModel, SlipStepper, StartState, Steering, Tagged,
};
use serde::{Deserialize, Serialize};

/// The slip inputs of eq. 5 for a commanded body velocity `f`, per slip dimension
/// (Sec. III-B.2): longitudinal `[f_x]` (rolling resistance), lateral `[f_x f_w]`
/// (centrifugal force), angular `[f_x f_w, f_x, f_w]` (centrifugal force, asymmetry, skid).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlipInputs {
    /// x_x
    pub x: [f64; 1],
    /// x_y
    pub y: [f64; 1],
    /// x_w
    pub yaw: [f64; 3],
}

/// Slip inputs of a commanded body velocity.
///
/// ```
/// use drive_models::slip::slip_inputs;
/// use drive_traits::BodyVelocity;
/// let s = slip_inputs(&BodyVelocity::new(2.0, 0.0, 0.5));
/// assert_eq!(s.x, [2.0]);
/// assert_eq!(s.y, [1.0]);
/// assert_eq!(s.yaw, [1.0, 2.0, 0.5]);
/// ```
#[inline]
pub fn slip_inputs(f: &BodyVelocity) -> SlipInputs {
    let psi = f.x * f.z;
    SlipInputs {
        x: [f.x],
        y: [psi],
        yaw: [psi, f.x, f.z],
    }
}

/// The slip inputs of a car-like vehicle for a commanded body velocity `f = [v, 0, v
/// kappa]` (kappa the path curvature), per slip dimension ([`SlipBasis::Car`]):
/// longitudinal `[f_x, f_x f_w^2]`, lateral `[f_w, |f_x| f_x f_w]`, angular `[f_w, |f_x|
/// f_x f_w, f_x]`.
///
/// ```
/// use drive_models::slip::car_slip_inputs;
/// use drive_traits::BodyVelocity;
/// let s = car_slip_inputs(&BodyVelocity::new(2.0, 0.0, 0.5));
/// assert_eq!(s.x, [2.0, 0.5]);        // f_x, f_x f_w^2
/// assert_eq!(s.y, [0.5, 2.0]);        // f_w, |f_x| f_x f_w
/// assert_eq!(s.yaw, [0.5, 2.0, 2.0]); // f_w, |f_x| f_x f_w, f_x
/// // Backwards, the tyres still slip against the lateral acceleration.
/// let back = car_slip_inputs(&BodyVelocity::new(-2.0, 0.0, -0.5));
/// assert_eq!(back.y, [-0.5, 2.0]);
/// ```
#[inline]
pub fn car_slip_inputs(f: &BodyVelocity) -> CarSlipInputs {
    // The speed times the lateral acceleration: tyre slip angles grow with the lateral
    // acceleration, their sliding velocity with the speed.
    let cornering = f.x.abs() * f.x * f.z;
    CarSlipInputs {
        x: [f.x, f.x * f.z * f.z],
        y: [f.z, cornering],
        yaw: [f.z, cornering, f.x],
    }
}

/// The slip inputs of an omnidirectional base for a commanded body velocity `f = [v_x, v_y,
/// w]` ([`SlipBasis::Omnidirectional`]): longitudinal `[f_x, f_y f_w]`, lateral `[f_y, f_x
/// f_w]`, angular `[f_w, f_y, f_x]`.
///
/// ```
/// use drive_models::slip::omni_slip_inputs;
/// use drive_traits::BodyVelocity;
/// let s = omni_slip_inputs(&BodyVelocity::new(2.0, -1.0, 0.5));
/// assert_eq!(s.x, [2.0, -0.5]);        // f_x, f_y f_w
/// assert_eq!(s.y, [-1.0, 1.0]);        // f_y, f_x f_w
/// assert_eq!(s.yaw, [0.5, -1.0, 2.0]); // f_w, f_y, f_x
/// ```
#[inline]
pub fn omni_slip_inputs(f: &BodyVelocity) -> CarSlipInputs {
    CarSlipInputs {
        x: [f.x, f.y * f.z],
        y: [f.y, f.x * f.z],
        yaw: [f.z, f.y, f.x],
    }
}

/// The slip inputs of [`SlipBasis::Car`] (and of [`SlipBasis::Omnidirectional`]: two, two
/// and three per slip dimension), per slip dimension.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CarSlipInputs {
    /// x_x
    pub x: [f64; 2],
    /// x_y
    pub y: [f64; 2],
    /// x_w
    pub yaw: [f64; 3],
}

/// Which functions of the commanded body velocity `f` each slip dimension of slip-BLR is
/// linear in (eq. 5). The learner takes it from the vehicle ([`Steering`]) unless told.
///
/// - [`SlipBasis::SkidSteer`], the paper's (Sec. III-B.2): longitudinal `[f_x]` (rolling
///   resistance), lateral `[f_x f_w]` (centrifugal force), angular `[f_x f_w, f_x, f_w]`
///   (centrifugal force, asymmetry, skid: a skid-steer turns by scrubbing its tracks or
///   wheels sideways, so the yaw-rate slip grows with the commanded yaw rate itself).
/// - [`SlipBasis::Car`], for steered wheels (kinematic bicycle `f = [v, 0, v kappa]`, body
///   frame at the rear axle), from the steady-state linear bicycle model: the axle side
///   forces balance the lateral acceleration `a_y = f_x f_w` (`F_f = m a_y l_r / L`, `F_r =
///   m a_y l_f / L`), each tyre slides sideways at its slip angle `F / C` times the speed
///   `|v|`, in either direction of travel. Longitudinal `[f_x, f_x f_w^2]`: the driven
///   wheels' slip ratio times the speed, under rolling resistance and under the cornering
///   drag, which grows with the square of the yaw rate. Lateral `[f_w, |f_x| f_x f_w]`: the
///   offset between the body frame and the axle that does not slide (`d w`), and the rear
///   tyres' side-slip, `m l_f |v| a_y / (L C_r)`. Angular `[f_w, |f_x| f_x f_w, f_x]`: a
///   steering gain error (an effective wheelbase), the understeer gradient (`w = v delta /
///   (L + K v |v|)` with `K = m (l_r / C_f - l_f / C_r) / L`, which loses `K |f_x| f_x f_w
///   / L` to first order), and a steering trim. A car does not skid to turn: its yaw-rate
///   slip is not proportional to the yaw rate alone.
/// - [`SlipBasis::Omnidirectional`], for a base that drives sideways (mecanum or omni
///   wheels, [`Steering::Holonomic`]): each translation loses a share of itself (rolling
///   resistance forward, the rollers' slip sideways), and the body's rotation carries the
///   other translation into it, `f_y f_w` and `f_x f_w` (the centrifugal drift of eq. 5's
///   lateral input, in both directions); angular `[f_w, f_y, f_x]`: the scrub of turning,
///   and a yaw drift when the base crabs or drives with its weight off centre.
/// - [`SlipBasis::Own`], a vehicle's own ([`CommandModel::slip_features`]): the slip
///   inputs it gives ([`SlipFeatures`]), saved in the model file with it.
///
/// ```
/// use drive_models::slip::SlipBasis;
/// use drive_traits::Steering;
/// assert_eq!(SlipBasis::for_steering(Steering::Wheels), SlipBasis::Car);
/// assert_eq!(SlipBasis::SkidSteer.dimensions(), [1, 1, 3]);
/// assert_eq!(SlipBasis::Car.inputs()[0], ["f_x", "f_x f_w^2"]);
/// ```
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SlipBasis {
    /// The paper's basis for a skid-steer (eq. 5, Sec. III-B.2).
    #[default]
    SkidSteer,
    /// A basis for a car-like vehicle with steered wheels.
    Car,
    /// A basis for an omnidirectional base (three inputs, lateral motion commanded).
    Omnidirectional,
    /// A vehicle's own basis ([`CommandModel::slip_features`]).
    Own(OwnSlipBasis),
}

/// A vehicle's own slip basis ([`SlipFeatures`]), as [`SlipBasis::Own`] holds it: cloned
/// and compared by what it saves.
#[derive(Debug, Serialize, Deserialize)]
#[serde(transparent)]
pub struct OwnSlipBasis(pub Box<dyn SlipFeatures>);

impl Clone for OwnSlipBasis {
    fn clone(&self) -> Self {
        OwnSlipBasis(self.0.clone_box())
    }
}

impl PartialEq for OwnSlipBasis {
    fn eq(&self, other: &Self) -> bool {
        // Two bases are the same when they save the same (type tag and fields).
        match (serde_json::to_value(self), serde_json::to_value(other)) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        }
    }
}

impl SlipBasis {
    /// The basis for a vehicle that turns by `steering`: the car's for steered wheels, the
    /// paper's skid-steer basis otherwise (a slip in every component of the body velocity,
    /// as eq. 5 learns it for any vehicle that turns by skidding).
    pub fn for_steering(steering: Steering) -> Self {
        match steering {
            Steering::Wheels => SlipBasis::Car,
            Steering::Holonomic => SlipBasis::Omnidirectional,
            _ => SlipBasis::SkidSteer,
        }
    }

    /// The basis for `vehicle`: its own ([`CommandModel::slip_features`]) when it gives
    /// one, otherwise the one its steering chooses ([`SlipBasis::for_steering`]).
    pub fn for_vehicle(vehicle: &dyn CommandModel) -> Self {
        match vehicle.slip_features() {
            Some(own) => SlipBasis::Own(OwnSlipBasis(own)),
            None => SlipBasis::for_steering(vehicle.steering()),
        }
    }

    /// The number of slip inputs of the longitudinal, lateral and angular regressions.
    pub fn dimensions(&self) -> [usize; 3] {
        match self {
            SlipBasis::SkidSteer => [1, 1, 3],
            SlipBasis::Car | SlipBasis::Omnidirectional => [2, 2, 3],
            SlipBasis::Own(own) => own.0.dimensions(),
        }
    }

    /// The slip inputs of each regression, by name (for reports).
    pub fn inputs(&self) -> [Vec<String>; 3] {
        let named = |rows: [&[&str]; 3]| rows.map(|r| r.iter().map(|n| n.to_string()).collect());
        match self {
            SlipBasis::SkidSteer => named([&["f_x"], &["f_x f_w"], &["f_x f_w", "f_x", "f_w"]]),
            SlipBasis::Car => named([
                &["f_x", "f_x f_w^2"],
                &["f_w", "|f_x| f_x f_w"],
                &["f_w", "|f_x| f_x f_w", "f_x"],
            ]),
            SlipBasis::Omnidirectional => named([
                &["f_x", "f_y f_w"],
                &["f_y", "f_x f_w"],
                &["f_w", "f_y", "f_x"],
            ]),
            SlipBasis::Own(own) => own.0.names(),
        }
    }

    /// The basis's name in files and reports (`own` for a vehicle's own).
    pub fn as_str(&self) -> &'static str {
        match self {
            SlipBasis::SkidSteer => "skid-steer",
            SlipBasis::Car => "car",
            SlipBasis::Omnidirectional => "omnidirectional",
            SlipBasis::Own(_) => "own",
        }
    }

    /// `Err` when a vehicle's own basis has dimensions the regressions cannot take.
    pub fn check(&self) -> Result<(), InvalidPart> {
        match self {
            SlipBasis::Own(own) => drive_traits::check_slip_features(own.0.as_ref()),
            _ => Ok(()),
        }
    }

    /// The three regressions' design rows (slip inputs, row-major) and slip labels over
    /// every sample of `data`, the measured velocities from `velocity`.
    fn design_rows(
        &self,
        data: &SlipData<'_>,
        velocity: &BodyVelocityEstimator,
    ) -> ([Vec<f64>; 3], [Vec<f64>; 3]) {
        let mut xs: [Vec<f64>; 3] = Default::default();
        let mut gs: [Vec<f64>; 3] = Default::default();
        data.for_each_sample(velocity, |sample| {
            let g = sample.slip();
            self.push(&sample.commanded, &mut xs);
            for d in 0..3 {
                gs[d].push(g[d]);
            }
        });
        (xs, gs)
    }

    /// Appends the slip inputs of `f` to the three regressions' design rows.
    pub(crate) fn push(&self, f: &BodyVelocity, xs: &mut [Vec<f64>; 3]) {
        match self {
            SlipBasis::Own(own) => {
                let rows = own.0.inputs(f);
                for (d, k) in own.0.dimensions().into_iter().enumerate() {
                    xs[d].extend_from_slice(&rows[d][..k]);
                }
            }
            SlipBasis::SkidSteer => {
                let s = slip_inputs(f);
                xs[0].extend_from_slice(&s.x);
                xs[1].extend_from_slice(&s.y);
                xs[2].extend_from_slice(&s.yaw);
            }
            SlipBasis::Car | SlipBasis::Omnidirectional => {
                let s = self.pair_inputs(f);
                xs[0].extend_from_slice(&s.x);
                xs[1].extend_from_slice(&s.y);
                xs[2].extend_from_slice(&s.yaw);
            }
        }
    }

    /// The slip inputs of the bases of two, two and three inputs (car, omnidirectional).
    #[inline]
    pub(crate) fn pair_inputs(&self, f: &BodyVelocity) -> CarSlipInputs {
        match self {
            SlipBasis::Omnidirectional => omni_slip_inputs(f),
            _ => car_slip_inputs(f),
        }
    }
}

/// The paper's slip-based BLR learner (Sec. III-B.2): one Bayesian linear regression per
/// body dimension (eq. 5-7) of the slip `g = f - v` on the slip inputs of the commanded
/// body velocity `f`, with `v` the body velocity measured by localization (see
/// [`BodyVelocityEstimator`]). The commanded body velocity comes from the powertrain and the
/// vehicle it is composed with (`slip-blr+fopdt` is the paper's model).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SlipBlr {
    /// Priors of the x, y and yaw slip regressions (the paper's uninformative prior by default).
    pub priors: [Prior; 3],
    /// How the measured body velocities are derived from the poses.
    pub velocity: BodyVelocityEstimator,
    /// The slip inputs; `None` (the default): the basis of the data's vehicle
    /// ([`SlipBasis::for_steering`]).
    pub basis: Option<SlipBasis>,
}

impl SlipBlr {
    /// The same learner with the paper's uninformative prior of scale `phi` on every dimension.
    ///
    /// ```
    /// use drive_models::{blr::Prior, slip::SlipBlr};
    /// assert_eq!(SlipBlr::default().with_phi(1.0).priors[0], Prior::Uninformative { phi: 1.0 });
    /// ```
    pub fn with_phi(mut self, phi: f64) -> Self {
        self.priors = [
            Prior::Uninformative { phi },
            Prior::Uninformative { phi },
            Prior::Uninformative { phi },
        ];
        self
    }
}

/// Fitted slip-BLR: the posteriors of the three slip regressions on their basis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlipBlrModel {
    /// The slip inputs (the paper's skid-steer basis in files that do not say).
    #[serde(default)]
    pub basis: SlipBasis,
    /// Posterior of the longitudinal slip.
    pub slip_x: BlrPosterior,
    /// Posterior of the lateral slip.
    pub slip_y: BlrPosterior,
    /// Posterior of the angular slip.
    pub slip_yaw: BlrPosterior,
}

impl Tagged for SlipBlrModel {
    const TAG: &'static str = "slip-blr";
}

impl SlipBlr {
    /// The slip inputs of `vehicle`'s data: the learner's, or the vehicle's own.
    fn basis_for(&self, robot: &RobotDescription) -> SlipBasis {
        self.basis
            .clone()
            .unwrap_or_else(|| SlipBasis::for_vehicle(robot.vehicle.as_ref()))
    }

    fn validate(&self, basis: &SlipBasis) -> Result<(), FitError> {
        self.velocity.validate()?;
        basis.check().map_err(|e| FitError::InvalidPart(e.0))?;
        for (prior, k) in self.priors.iter().zip(basis.dimensions()) {
            prior.validate(k)?;
        }
        Ok(())
    }
}

impl SlipLearner for SlipBlr {
    type Fitted = SlipBlrModel;

    fn fit(&self, data: &SlipData<'_>) -> Result<SlipBlrModel, FitError> {
        let basis = self.basis_for(data.robot);
        let k = basis.dimensions();
        self.validate(&basis)?;
        if data.windows.is_empty() {
            return Err(FitError::EmptyTrainingSet);
        }
        let (xs, gs) = basis.design_rows(data, &self.velocity);
        let fit =
            |d: usize, name: &str| BlrPosterior::fit(&xs[d], k[d], &gs[d], &self.priors[d], name);
        Ok(SlipBlrModel {
            basis,
            slip_x: fit(0, "slip-BLR, longitudinal slip")?,
            slip_y: fit(1, "slip-BLR, lateral slip")?,
            slip_yaw: fit(2, "slip-BLR, angular slip")?,
        })
    }

    /// Online slip-BLR: the three regressions' [`BlrStatistics`], updated window by window.
    fn online(&self, robot: &RobotDescription) -> Option<Box<dyn OnlineSlip>> {
        let basis = self.basis_for(robot);
        Some(Box::new(SlipBlrOnline {
            learner: self.clone(),
            statistics: basis.dimensions().map(BlrStatistics::new),
            basis,
        }))
    }
}

/// Slip-BLR fitted recursively (online BLR): the sufficient statistics of its three
/// regressions, updated as windows arrive; [`OnlineSlip::fitted`] equals
/// [`SlipLearner::fit`] on the same windows (to rounding), whatever the order they came in.
///
/// ```
/// use drive_models::slip::SlipBlr;
/// use drive_traits::{SlipLearner, SlipData};
/// # fn demo(first: &SlipData<'_>, second: &SlipData<'_>) {
/// let mut online = SlipBlr::default().online(first.robot).expect("slip-BLR fits online");
/// online.add(first);
/// online.add(second);
/// let model = online.fitted().unwrap(); // the posterior of eq. 6 on both
/// # }
/// ```
#[derive(Debug, Clone)]
pub struct SlipBlrOnline {
    learner: SlipBlr,
    basis: SlipBasis,
    statistics: [BlrStatistics; 3],
}

impl OnlineSlip for SlipBlrOnline {
    fn add(&mut self, data: &SlipData<'_>) {
        let (xs, gs) = self.basis.design_rows(data, &self.learner.velocity);
        for d in 0..3 {
            self.statistics[d].add_rows(&xs[d], &gs[d]);
        }
    }

    fn fitted(&self) -> Result<Box<dyn SlipModel>, FitError> {
        self.learner.validate(&self.basis)?;
        // No rows: the posterior refuses with the batch fit's reason (0 usable samples).
        let fit =
            |d: usize, name: &str| self.statistics[d].posterior(&self.learner.priors[d], name);
        Ok(Box::new(SlipBlrModel {
            basis: self.basis.clone(),
            slip_x: fit(0, "slip-BLR, longitudinal slip")?,
            slip_y: fit(1, "slip-BLR, lateral slip")?,
            slip_yaw: fit(2, "slip-BLR, angular slip")?,
        }))
    }

    fn clone_box(&self) -> Box<dyn OnlineSlip> {
        Box::new(self.clone())
    }
}

/// The slip posterior means in fixed-size form, read once per rollout (the skid-steer
/// basis uses the first weight of x and y).
#[derive(Debug, Clone, Copy)]
struct SlipWeights {
    x: [f64; 2],
    y: [f64; 2],
    yaw: [f64; 3],
}

impl SlipWeights {
    /// The slip `g` of eq. 5 (posterior mean) at the skid-steer slip inputs `s`.
    #[inline]
    fn skid_steer(&self, s: &SlipInputs) -> BodyVelocity {
        BodyVelocity::new(
            self.x[0] * s.x[0],
            self.y[0] * s.y[0],
            self.yaw[0] * s.yaw[0] + self.yaw[1] * s.yaw[1] + self.yaw[2] * s.yaw[2],
        )
    }

    /// The slip at the car (or omnidirectional) slip inputs `s`.
    #[inline]
    fn car(&self, s: &CarSlipInputs) -> BodyVelocity {
        BodyVelocity::new(
            self.x[0] * s.x[0] + self.x[1] * s.x[1],
            self.y[0] * s.y[0] + self.y[1] * s.y[1],
            self.yaw[0] * s.yaw[0] + self.yaw[1] * s.yaw[1] + self.yaw[2] * s.yaw[2],
        )
    }
}

/// slip-BLR stepped: `v = f - g(f)` (eq. 2, 5) with the posterior means, as
/// [`SlipModel::body_velocities_into`] computes it.
struct SlipBlrStepper<'a> {
    weights: SlipWeights,
    /// The built-in basis, copied (no indirection per step); `None` for a vehicle's own.
    builtin: Option<BuiltinBasis>,
    model: &'a SlipBlrModel,
}

impl SlipBlrStepper<'_> {
    /// `v[k] = f[k] - g(f[k])` for every k, the basis chosen once.
    fn each(&self, f: &[BodyVelocity], v: &mut [BodyVelocity]) {
        let w = &self.weights;
        let pairs = f.iter().zip(v.iter_mut());
        match self.builtin {
            Some(BuiltinBasis::SkidSteer) => {
                pairs.for_each(|(f, v)| *v = f - w.skid_steer(&slip_inputs(f)))
            }
            Some(BuiltinBasis::Car) => pairs.for_each(|(f, v)| *v = f - w.car(&car_slip_inputs(f))),
            Some(BuiltinBasis::Omnidirectional) => {
                pairs.for_each(|(f, v)| *v = f - w.car(&omni_slip_inputs(f)))
            }
            None => pairs.for_each(|(f, v)| *v = f - self.model.slip(f)),
        }
    }
}

/// A built-in basis, as a stepper reads it at every step.
#[derive(Debug, Clone, Copy)]
enum BuiltinBasis {
    SkidSteer,
    Car,
    Omnidirectional,
}

impl SlipStepper for SlipBlrStepper<'_> {
    fn state_len(&self) -> usize {
        0
    }
    fn init(&self, _start: &StartState, _state: &mut [f64]) {}
    #[inline]
    fn step(&self, _state: &mut [f64], f: &BodyVelocity) -> BodyVelocity {
        let w = &self.weights;
        match self.builtin {
            Some(BuiltinBasis::SkidSteer) => f - w.skid_steer(&slip_inputs(f)),
            Some(BuiltinBasis::Car) => f - w.car(&car_slip_inputs(f)),
            Some(BuiltinBasis::Omnidirectional) => f - w.car(&omni_slip_inputs(f)),
            None => f - self.model.slip(f),
        }
    }

    /// The basis chosen once for the whole sequence, each loop its own (no state: every
    /// step is `f - g(f)`).
    fn step_seq(&self, _state: &mut [f64], f: &[BodyVelocity], v: &mut [BodyVelocity]) {
        self.each(f, v);
    }

    /// As [`step_seq`](SlipStepper::step_seq): the states are empty.
    fn step_many(
        &self,
        _states: &mut [f64],
        _stride: usize,
        f: &[BodyVelocity],
        v: &mut [BodyVelocity],
    ) {
        self.each(f, v);
    }
}

impl SlipBlrModel {
    /// The weight-uncertainty share of the slip's predictive variance at the commanded
    /// body velocity `f`, relative to each regression's noise and summed over the three
    /// ([`BlrPosterior::leverage`]): large where the data seen so far says little.
    pub fn leverage(&self, f: &BodyVelocity) -> f64 {
        let [x, y, yaw] = self.inputs(f);
        self.slip_x.leverage(&x) + self.slip_y.leverage(&y) + self.slip_yaw.leverage(&yaw)
    }

    /// The slip inputs of `f` on the model's basis, per regression.
    fn inputs(&self, f: &BodyVelocity) -> [Vec<f64>; 3] {
        match &self.basis {
            SlipBasis::Own(own) => {
                let rows = own.0.inputs(f);
                let k = own.0.dimensions();
                [0, 1, 2].map(|d| rows[d][..k[d]].to_vec())
            }
            SlipBasis::SkidSteer => {
                let s = slip_inputs(f);
                [s.x.to_vec(), s.y.to_vec(), s.yaw.to_vec()]
            }
            SlipBasis::Car | SlipBasis::Omnidirectional => {
                let s = self.basis.pair_inputs(f);
                [s.x.to_vec(), s.y.to_vec(), s.yaw.to_vec()]
            }
        }
    }

    /// The posterior means. The basis's dimensions hold by construction in `fit` and are
    /// checked by [`SlipModel::check`] for loaded files; a missing weight reads as NaN so
    /// that a malformed model can never predict plausible numbers (weights beyond the
    /// basis's read as zero and are never used).
    /// The built-in basis, `None` for a vehicle's own.
    fn builtin(&self) -> Option<BuiltinBasis> {
        match &self.basis {
            SlipBasis::SkidSteer => Some(BuiltinBasis::SkidSteer),
            SlipBasis::Car => Some(BuiltinBasis::Car),
            SlipBasis::Omnidirectional => Some(BuiltinBasis::Omnidirectional),
            SlipBasis::Own(_) => None,
        }
    }

    /// [`SlipModel::body_velocities_into`] on a vehicle's own basis (kept out of the
    /// built-in bases' loops).
    #[cold]
    #[inline(never)]
    fn own_velocities_into(&self, f: &[BodyVelocity], out: &mut Vec<BodyVelocity>) {
        out.clear();
        out.extend(f.iter().map(|f| f - self.slip(f)));
    }

    /// The slip (posterior mean) on a vehicle's own basis: each regression's mean weights
    /// times its inputs (a missing weight reads as NaN, as in [`Self::weights`]).
    #[cold]
    #[inline(never)]
    fn own_slip(&self, own: &OwnSlipBasis, f: &BodyVelocity) -> BodyVelocity {
        let rows = own.0.inputs(f);
        let k = own.0.dimensions();
        let dot = |p: &BlrPosterior, d: usize| {
            (0..k[d].min(drive_traits::MAX_SLIP_INPUTS))
                .map(|i| p.mean.get(i).copied().unwrap_or(f64::NAN) * rows[d][i])
                .sum::<f64>()
        };
        BodyVelocity::new(
            dot(&self.slip_x, 0),
            dot(&self.slip_y, 1),
            dot(&self.slip_yaw, 2),
        )
    }

    fn weights(&self) -> SlipWeights {
        let [kx, ky, _] = self.basis.dimensions();
        let at = |m: &[f64], i: usize, k: usize| {
            if i < k {
                m.get(i).copied().unwrap_or(f64::NAN)
            } else {
                0.0
            }
        };
        SlipWeights {
            x: [at(&self.slip_x.mean, 0, kx), at(&self.slip_x.mean, 1, kx)],
            y: [at(&self.slip_y.mean, 0, ky), at(&self.slip_y.mean, 1, ky)],
            yaw: [
                at(&self.slip_yaw.mean, 0, 3),
                at(&self.slip_yaw.mean, 1, 3),
                at(&self.slip_yaw.mean, 2, 3),
            ],
        }
    }
}

#[typetag::serde(name = "slip-blr")]
impl SlipModel for SlipBlrModel {
    fn slip(&self, f: &BodyVelocity) -> BodyVelocity {
        let w = self.weights();
        match &self.basis {
            SlipBasis::SkidSteer => w.skid_steer(&slip_inputs(f)),
            SlipBasis::Car => w.car(&car_slip_inputs(f)),
            SlipBasis::Omnidirectional => w.car(&omni_slip_inputs(f)),
            SlipBasis::Own(own) => self.own_slip(own, f),
        }
    }

    fn body_velocities_into(&self, f: &[BodyVelocity], out: &mut Vec<BodyVelocity>) {
        let Some(builtin) = self.builtin() else {
            return self.own_velocities_into(f, out);
        };
        let w = self.weights();
        out.clear();
        // The basis is chosen once per rollout, each loop has its own.
        match builtin {
            BuiltinBasis::SkidSteer => {
                out.extend(f.iter().map(|f| f - w.skid_steer(&slip_inputs(f))))
            }
            BuiltinBasis::Car => out.extend(f.iter().map(|f| f - w.car(&car_slip_inputs(f)))),
            BuiltinBasis::Omnidirectional => {
                out.extend(f.iter().map(|f| f - w.car(&omni_slip_inputs(f))))
            }
        }
    }

    /// The Student-t predictive variance of eq. 7 per slip dimension.
    fn slip_variance(&self, f: &BodyVelocity) -> Option<BodyVelocity> {
        let v = |p: &BlrPosterior, x: &[f64]| p.predictive_variance(x);
        Some(match &self.basis {
            SlipBasis::Own(_) => {
                let [x, y, yaw] = self.inputs(f);
                BodyVelocity::new(
                    v(&self.slip_x, &x),
                    v(&self.slip_y, &y),
                    v(&self.slip_yaw, &yaw),
                )
            }
            SlipBasis::SkidSteer => {
                let s = slip_inputs(f);
                BodyVelocity::new(
                    v(&self.slip_x, &s.x),
                    v(&self.slip_y, &s.y),
                    v(&self.slip_yaw, &s.yaw),
                )
            }
            SlipBasis::Car | SlipBasis::Omnidirectional => {
                let s = self.basis.pair_inputs(f);
                BodyVelocity::new(
                    v(&self.slip_x, &s.x),
                    v(&self.slip_y, &s.y),
                    v(&self.slip_yaw, &s.yaw),
                )
            }
        })
    }

    /// No state: the slip of eq. 5 at each step's commanded body velocity, with the
    /// posterior means read once.
    fn stepper(&self) -> Option<Box<dyn SlipStepper + '_>> {
        Some(Box::new(SlipBlrStepper {
            weights: self.weights(),
            builtin: self.builtin(),
            model: self,
        }))
    }

    fn check(&self) -> Result<(), InvalidPart> {
        self.basis.check()?;
        let [kx, ky, kw] = self.basis.dimensions();
        self.slip_x.check(kx, "slip_x")?;
        self.slip_y.check(ky, "slip_y")?;
        self.slip_yaw.check(kw, "slip_yaw")
    }

    /// The posterior mean weights (eq. 6) per slip dimension and basis input
    /// (`longitudinal slip: w[f_x]`, ...).
    fn parameters(&self) -> Vec<(String, f64)> {
        let names = self.basis.inputs();
        let mut out = Vec::new();
        for ((dimension, posterior), inputs) in [
            ("longitudinal", &self.slip_x),
            ("lateral", &self.slip_y),
            ("angular", &self.slip_yaw),
        ]
        .into_iter()
        .zip(names)
        {
            for (input, w) in inputs.iter().zip(posterior.mean.iter()) {
                out.push((format!("{dimension} slip: w[{input}]"), *w));
            }
        }
        out
    }

    fn clone_box(&self) -> Box<dyn SlipModel> {
        Box::new(self.clone())
    }
}
