use crate::blr::{BlrPosterior, Prior};
use crate::learners::check_common;
use crate::powertrain::Fopdt;
use crate::rollout::{integrate_with_covariance, Integrator};
use crate::velocity::BodyVelocityEstimator;
use crate::DifferentialDrive;
use drive_traits::{
    BodyVelocity, FitError, Input, Learner, MotionError, MotionModel, Pose, PoseCovariance,
    Powertrain, PowertrainLearner, StartState, WindowSet,
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
/// use drive_models::learners::slip_inputs;
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

/// The paper's slip-based BLR learner (Sec. III-B): a powertrain (FOPDT by default) gives
/// the predicted wheel velocities, eq. 4 the commanded body velocity `f`, and one BLR per
/// body dimension (eq. 5-7) learns the slip `g = f - v` from the slip inputs, with `v` the
/// body velocity measured by localization (see [`BodyVelocityEstimator`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SlipBlr<P = Fopdt> {
    /// The powertrain learner.
    pub powertrain: P,
    /// Priors of the x, y and yaw slip regressions (the paper's uninformative prior by default).
    pub priors: [Prior; 3],
    /// How the measured body velocities are derived from the poses.
    pub velocity: BodyVelocityEstimator,
}

impl<P: Default> Default for SlipBlr<P> {
    fn default() -> Self {
        SlipBlr {
            powertrain: P::default(),
            priors: Default::default(),
            velocity: BodyVelocityEstimator::default(),
        }
    }
}

impl<P> SlipBlr<P> {
    /// The same learner with another powertrain learner.
    ///
    /// ```
    /// use drive_models::learners::SlipBlr;
    /// use drive_models::powertrain::{Fopdt, Ideal};
    /// let on_commands = SlipBlr::<Fopdt>::default().with_powertrain(Ideal);
    /// assert_eq!(on_commands.powertrain, Ideal);
    /// ```
    pub fn with_powertrain<Q>(self, powertrain: Q) -> SlipBlr<Q> {
        SlipBlr {
            powertrain,
            priors: self.priors,
            velocity: self.velocity,
        }
    }

    /// The same learner with the paper's uninformative prior of scale `phi` on every dimension.
    pub fn with_phi(mut self, phi: f64) -> Self {
        self.priors = [
            Prior::Uninformative { phi },
            Prior::Uninformative { phi },
            Prior::Uninformative { phi },
        ];
        self
    }
}

/// Fitted slip-BLR model.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SlipBlrModel {
    /// The vehicle's command model.
    pub vehicle: DifferentialDrive,
    /// The fitted powertrain.
    pub powertrain: Box<dyn Powertrain>,
    /// Posterior of the longitudinal slip.
    pub slip_x: BlrPosterior,
    /// Posterior of the lateral slip.
    pub slip_y: BlrPosterior,
    /// Posterior of the angular slip.
    pub slip_yaw: BlrPosterior,
    /// Step (s).
    pub dt: f64,
}

impl<P: PowertrainLearner> Learner for SlipBlr<P> {
    type Fitted = SlipBlrModel;

    fn fit(&self, train: &WindowSet<'_>) -> Result<SlipBlrModel, FitError> {
        self.velocity.validate()?;
        for (prior, k) in self.priors.iter().zip([1, 1, 3]) {
            prior.validate(k)?;
        }
        if train.is_empty() {
            return Err(FitError::EmptyTrainingSet);
        }
        let powertrain = self.powertrain.fit(train)?;
        let vehicle = DifferentialDrive::from_robot(train.robot);
        let dt = train.robot.dt();
        let mut xs: [Vec<f64>; 3] = Default::default();
        let mut gs: [Vec<f64>; 3] = Default::default();
        let mut wheels = Vec::new();
        let mut measured = Vec::new();
        for w in &train.windows {
            powertrain.predict_into(&w.encoder[0], &w.command, &mut wheels);
            self.velocity.estimate(w, dt, &mut measured);
            for (u, v) in wheels.iter().zip(&measured) {
                let Some(v) = v else { continue };
                let f = vehicle.eq4(u);
                let g = f - v;
                let s = slip_inputs(&f);
                xs[0].extend_from_slice(&s.x);
                xs[1].extend_from_slice(&s.y);
                xs[2].extend_from_slice(&s.yaw);
                for d in 0..3 {
                    gs[d].push(g[d]);
                }
            }
        }
        let fit = |d: usize, k: usize, name: &str| {
            BlrPosterior::fit(&xs[d], k, &gs[d], &self.priors[d], name)
        };
        Ok(SlipBlrModel {
            slip_x: fit(0, 1, "slip-BLR, longitudinal slip")?,
            slip_y: fit(1, 1, "slip-BLR, lateral slip")?,
            slip_yaw: fit(2, 3, "slip-BLR, angular slip")?,
            vehicle,
            powertrain: Box::new(powertrain),
            dt,
        })
    }
}

/// The slip posterior means in fixed-size form, read once per rollout.
#[derive(Debug, Clone, Copy)]
struct SlipWeights {
    x: f64,
    y: f64,
    yaw: [f64; 3],
}

impl SlipBlrModel {
    /// Predictive variance of eq. 7 of the slip (x, y, yaw) when the wheels turn steadily
    /// at `wheels` (rad/s): what the model is unsure of at that input.
    pub fn slip_variance(&self, wheels: &Input) -> BodyVelocity {
        let s = slip_inputs(&self.vehicle.eq4(wheels));
        BodyVelocity::new(
            self.slip_x.predictive_variance(&s.x),
            self.slip_y.predictive_variance(&s.y),
            self.slip_yaw.predictive_variance(&s.yaw),
        )
    }

    /// The weight-uncertainty share of the slip's predictive variance at steady wheel
    /// velocities `wheels`, relative to each regression's noise and summed over the three
    /// ([`BlrPosterior::leverage`]): large where the data seen so far says little.
    pub fn slip_leverage(&self, wheels: &Input) -> f64 {
        let s = slip_inputs(&self.vehicle.eq4(wheels));
        self.slip_x.leverage(&s.x) + self.slip_y.leverage(&s.y) + self.slip_yaw.leverage(&s.yaw)
    }

    /// The posterior means. The dimensions (1, 1, 3) hold by construction in `fit` and are
    /// checked by [`MotionModel::check`] for loaded files; a missing weight reads as NaN so
    /// that a malformed model can never predict plausible numbers.
    fn weights(&self) -> SlipWeights {
        let at = |m: &[f64], i: usize| m.get(i).copied().unwrap_or(f64::NAN);
        SlipWeights {
            x: at(&self.slip_x.mean, 0),
            y: at(&self.slip_y.mean, 0),
            yaw: [
                at(&self.slip_yaw.mean, 0),
                at(&self.slip_yaw.mean, 1),
                at(&self.slip_yaw.mean, 2),
            ],
        }
    }

    /// Body velocity `v = f - g` (eq. 2) at predicted wheel velocities `u`, with the slip
    /// `g` the posterior mean of eq. 7, and the slip inputs it used.
    #[inline]
    fn body_velocity(&self, w: &SlipWeights, u: &Input) -> (BodyVelocity, SlipInputs) {
        let f = self.vehicle.eq4(u);
        let s = slip_inputs(&f);
        let g = BodyVelocity::new(
            w.x * s.x[0],
            w.y * s.y[0],
            w.yaw[0] * s.yaw[0] + w.yaw[1] * s.yaw[1] + w.yaw[2] * s.yaw[2],
        );
        (f - g, s)
    }

    /// Rolls out predicted wheel velocities into `out` (one pose per wheel sample).
    #[inline]
    fn rollout_into(&self, w: &SlipWeights, start: &Pose, wheels: &[Input], out: &mut [Pose]) {
        let mut it = Integrator::new(start, self.dt);
        let n = out.len();
        for (k, (slot, u)) in out.iter_mut().zip(wheels).enumerate() {
            *slot = it.pose();
            if k + 1 < n {
                it.step(&self.body_velocity(w, u).0);
            }
        }
    }
}

#[typetag::serde(name = "slip-blr")]
impl MotionModel for SlipBlrModel {
    fn name(&self) -> &'static str {
        "slip-blr"
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn check(&self) -> Result<(), String> {
        check_common(self.dt, &self.vehicle)?;
        self.powertrain.check()?;
        self.slip_x.check(1, "slip_x")?;
        self.slip_y.check(1, "slip_y")?;
        self.slip_yaw.check(3, "slip_yaw")
    }
    fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>) {
        let wheels = self.powertrain.predict(&start.input, commands);
        poses.clear();
        poses.resize(commands.len(), Pose::zeros());
        self.rollout_into(&self.weights(), &start.pose, &wheels, poses);
    }

    fn predict_batch_into(
        &self,
        starts: &[StartState],
        commands: &[Input],
        horizon: usize,
        poses: &mut [Pose],
    ) -> Result<(), MotionError> {
        MotionError::check_batch(starts.len(), horizon, commands.len(), poses.len())?;
        let weights = self.weights();
        let mut wheels = Vec::with_capacity(horizon);
        for (i, start) in starts.iter().enumerate() {
            let range = i * horizon..(i + 1) * horizon;
            self.powertrain
                .predict_into(&start.input, &commands[range.clone()], &mut wheels);
            self.rollout_into(&weights, &start.pose, &wheels, &mut poses[range]);
        }
        Ok(())
    }

    fn predict_with_covariance_into(
        &self,
        start: &StartState,
        commands: &[Input],
        poses: &mut Vec<Pose>,
        covariances: &mut Vec<PoseCovariance>,
    ) -> Result<(), MotionError> {
        let wheels = self.powertrain.predict(&start.input, commands);
        let mut v = Vec::with_capacity(wheels.len());
        let mut var = Vec::with_capacity(wheels.len());
        let weights = self.weights();
        for u in &wheels {
            let (vel, s) = self.body_velocity(&weights, u);
            v.push(vel);
            var.push(BodyVelocity::new(
                self.slip_x.predictive_variance(&s.x),
                self.slip_y.predictive_variance(&s.y),
                self.slip_yaw.predictive_variance(&s.yaw),
            ));
        }
        integrate_with_covariance(&start.pose, &v, &var, self.dt, poses, covariances);
        Ok(())
    }
}
