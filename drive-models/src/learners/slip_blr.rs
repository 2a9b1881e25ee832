use crate::blr::{BlrPosterior, Prior};
use crate::powertrain::Fopdt;
use crate::rollout::{integrate, integrate_with_covariance};
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

impl SlipBlrModel {
    /// Body velocities `v = f - g` (eq. 2) along the commands, and optionally their variances.
    fn body_velocities(
        &self,
        start: &StartState,
        commands: &[Input],
        variances: Option<&mut Vec<BodyVelocity>>,
    ) -> Vec<BodyVelocity> {
        let wheels = self.powertrain.predict(&start.input, commands);
        let mut out = Vec::with_capacity(wheels.len());
        let mut var_out = variances;
        if let Some(v) = var_out.as_deref_mut() {
            v.clear();
        }
        for u in &wheels {
            let f = self.vehicle.eq4(u);
            let s = slip_inputs(&f);
            let g = BodyVelocity::new(
                self.slip_x.predict_mean(&s.x),
                self.slip_y.predict_mean(&s.y),
                self.slip_yaw.predict_mean(&s.yaw),
            );
            out.push(f - g);
            if let Some(v) = var_out.as_deref_mut() {
                v.push(BodyVelocity::new(
                    self.slip_x.predictive_variance(&s.x),
                    self.slip_y.predictive_variance(&s.y),
                    self.slip_yaw.predictive_variance(&s.yaw),
                ));
            }
        }
        out
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
    fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>) {
        let v = self.body_velocities(start, commands, None);
        integrate(&start.pose, &v, self.dt, poses);
    }
    fn predict_with_covariance_into(
        &self,
        start: &StartState,
        commands: &[Input],
        poses: &mut Vec<Pose>,
        covariances: &mut Vec<PoseCovariance>,
    ) -> Result<(), MotionError> {
        let mut var = Vec::new();
        let v = self.body_velocities(start, commands, Some(&mut var));
        integrate_with_covariance(&start.pose, &v, &var, self.dt, poses, covariances);
        Ok(())
    }
}
