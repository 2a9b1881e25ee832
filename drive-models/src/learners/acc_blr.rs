use crate::blr::{BlrPosterior, Prior};
use crate::learners::check_common;
use crate::powertrain::{Ideal, IdealPowertrain};
use crate::rollout::{integrate, integrate_with_covariance};
use crate::velocity::BodyVelocityEstimator;
use crate::DifferentialDrive;
use drive_traits::{
    BodyVelocity, FitError, Input, Learner, MotionError, MotionModel, Pose, PoseCovariance,
    Powertrain, PowertrainLearner, StartState, WindowSet,
};
use serde::{Deserialize, Serialize};

/// The acceleration-based BLR baseline (McKinnon and Schoellig 2019, as compared in the
/// paper's Fig. 6): for the longitudinal and the angular dimension separately, BLR of the
/// one-step velocity change `v[k+1] - v[k]` on `[f[k], v[k]]`, with `f` the commanded body
/// velocity (eq. 4 on the commanded wheel velocities) and `v` the measured body velocity.
/// The lateral velocity is zero. Rolled out from the body velocity measured at the start.
///
/// As in the paper, `f` comes from the commands themselves ([`Ideal`], the default); with
/// another powertrain learner (for instance [`Fopdt`](crate::powertrain::Fopdt)) `f` is eq. 4
/// on the powertrain's predicted wheel velocities instead.
///
/// ```
/// use drive_models::learners::AccBlr;
/// use drive_models::powertrain::{Fopdt, Ideal};
/// assert_eq!(AccBlr::<Ideal>::default().powertrain, Ideal);
/// let on_fopdt = AccBlr::<Ideal>::default().with_powertrain(Fopdt::default());
/// assert_eq!(on_fopdt.powertrain, Fopdt::default());
/// ```
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AccBlr<P = Ideal> {
    /// The powertrain learner whose predicted wheel velocities give `f`.
    pub powertrain: P,
    /// Priors of the longitudinal and angular regressions.
    pub priors: [Prior; 2],
    /// How the measured body velocities are derived from the poses.
    pub velocity: BodyVelocityEstimator,
}

impl<P> AccBlr<P> {
    /// The same learner with another powertrain learner.
    pub fn with_powertrain<Q>(self, powertrain: Q) -> AccBlr<Q> {
        AccBlr {
            powertrain,
            priors: self.priors,
            velocity: self.velocity,
        }
    }
}

fn ideal_powertrain() -> Box<dyn Powertrain> {
    Box::new(IdealPowertrain)
}

/// Fitted acceleration-BLR model.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct AccBlrModel {
    /// The vehicle's command model.
    pub vehicle: DifferentialDrive,
    /// The fitted powertrain (the commands themselves by default; files written before the
    /// powertrain option read as such).
    #[serde(default = "ideal_powertrain")]
    pub powertrain: Box<dyn Powertrain>,
    /// Posterior of the longitudinal velocity change on `[f_x, v_x]`.
    pub accel_x: BlrPosterior,
    /// Posterior of the angular velocity change on `[f_w, v_w]`.
    pub accel_yaw: BlrPosterior,
    /// Step (s).
    pub dt: f64,
}

impl<P: PowertrainLearner> Learner for AccBlr<P> {
    type Fitted = AccBlrModel;

    fn fit(&self, train: &WindowSet<'_>) -> Result<AccBlrModel, FitError> {
        self.velocity.validate()?;
        for prior in &self.priors {
            prior.validate(2)?;
        }
        if train.is_empty() {
            return Err(FitError::EmptyTrainingSet);
        }
        let powertrain = self.powertrain.fit(train)?;
        let vehicle = DifferentialDrive::from_robot(train.robot);
        let dt = train.robot.dt();
        let mut xs: [Vec<f64>; 2] = Default::default();
        let mut gs: [Vec<f64>; 2] = Default::default();
        let mut measured = Vec::new();
        let mut wheels = Vec::new();
        for w in &train.windows {
            self.velocity.estimate(w, dt, &mut measured);
            powertrain.predict_into(&w.encoder[0], &w.command, &mut wheels);
            for k in 0..w.len().saturating_sub(1) {
                let (Some(v0), Some(v1)) = (measured[k], measured[k + 1]) else {
                    continue;
                };
                let f = vehicle.eq4(&wheels[k]);
                for (j, d) in [0usize, 2].into_iter().enumerate() {
                    xs[j].extend_from_slice(&[f[d], v0[d]]);
                    gs[j].push(v1[d] - v0[d]);
                }
            }
        }
        Ok(AccBlrModel {
            accel_x: BlrPosterior::fit(
                &xs[0],
                2,
                &gs[0],
                &self.priors[0],
                "acc-BLR, longitudinal",
            )?,
            accel_yaw: BlrPosterior::fit(&xs[1], 2, &gs[1], &self.priors[1], "acc-BLR, angular")?,
            vehicle,
            powertrain: Box::new(powertrain),
            dt,
        })
    }
}

impl AccBlrModel {
    fn body_velocities(
        &self,
        start: &StartState,
        commands: &[Input],
        mut variances: Option<&mut Vec<BodyVelocity>>,
    ) -> Vec<BodyVelocity> {
        let mut out = Vec::with_capacity(commands.len());
        let mut v = BodyVelocity::new(start.body_velocity.x, 0.0, start.body_velocity.z);
        let mut var = BodyVelocity::zeros();
        if let Some(vs) = variances.as_deref_mut() {
            vs.clear();
        }
        let wheels = self.powertrain.predict(&start.input, commands);
        for u in &wheels {
            out.push(v);
            if let Some(vs) = variances.as_deref_mut() {
                vs.push(var);
            }
            let f = self.vehicle.eq4(u);
            let (xx, xw) = ([f.x, v.x], [f.z, v.z]);
            let next = BodyVelocity::new(
                v.x + self.accel_x.predict_mean(&xx),
                0.0,
                v.z + self.accel_yaw.predict_mean(&xw),
            );
            if variances.is_some() {
                // v[k+1] = (1 + gamma_v) v[k] + gamma_f f[k] + noise: first-order propagation.
                let (gx, gw) = (1.0 + self.accel_x.mean[1], 1.0 + self.accel_yaw.mean[1]);
                var = BodyVelocity::new(
                    gx * gx * var.x + self.accel_x.predictive_variance(&xx),
                    0.0,
                    gw * gw * var.z + self.accel_yaw.predictive_variance(&xw),
                );
            }
            v = next;
        }
        out
    }
}

#[typetag::serde(name = "acc-blr")]
impl MotionModel for AccBlrModel {
    fn name(&self) -> &'static str {
        "acc-blr"
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn check(&self) -> Result<(), String> {
        check_common(self.dt, &self.vehicle)?;
        self.powertrain.check()?;
        self.accel_x.check(2, "accel_x")?;
        self.accel_yaw.check(2, "accel_yaw")
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
