use crate::blr::{BlrPosterior, Prior};
use crate::powertrain::Commanded;
use crate::rollout::{integrate, integrate_with_covariance};
use drive_traits::{
    Baseline, BodyVelocity, BodyVelocityEstimator, CommandModel, FitError, FitPowertrain, Input,
    MotionError, MotionModel, PartTag, Pose, PoseCovariance, Powertrain, StartState, Tagged,
    WindowSet,
};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// The acceleration-based BLR baseline (McKinnon and Schoellig 2019, as compared in the
/// paper's Fig. 6): for the longitudinal and the angular dimension separately, BLR of the
/// one-step velocity change `v[k+1] - v[k]` on `[f[k], v[k]]`, with `f` the commanded body
/// velocity and `v` the measured body velocity. The lateral velocity is zero. Rolled out
/// from the body velocity measured at the start.
///
/// It is not a slip model (its state is a velocity), so it is a [`Baseline`]: fitted on a
/// powertrain whose predicted inputs give `f` through the vehicle (eq. 4), the commanded
/// powertrain by default as in McKinnon and Schoellig (`acc-blr` is `acc-blr+commanded`).
///
/// ```
/// use drive_models::baselines::AccBlr;
/// use drive_traits::Baseline;
/// assert_eq!(AccBlr::default().default_powertrain(), Some("commanded"));
/// ```
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AccBlr {
    /// Priors of the longitudinal and angular regressions.
    pub priors: [Prior; 2],
    /// How the measured body velocities are derived from the poses.
    pub velocity: BodyVelocityEstimator,
}

/// Fitted acceleration-BLR model.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct AccBlrModel {
    /// The model's name (`acc-blr+commanded`).
    pub label: String,
    /// The vehicle.
    pub vehicle: Arc<dyn CommandModel>,
    /// The fitted powertrain.
    pub powertrain: Box<dyn Powertrain>,
    /// Posterior of the longitudinal velocity change on `[f_x, v_x]`.
    pub accel_x: BlrPosterior,
    /// Posterior of the angular velocity change on `[f_w, v_w]`.
    pub accel_yaw: BlrPosterior,
    /// Step (s).
    pub dt: f64,
}

impl Tagged for AccBlrModel {
    const TAG: &'static str = "acc-blr";
}

impl AccBlr {
    /// Fits the regressions on `train` with a fitted `powertrain` whose predictions give `f`;
    /// `label` names the fitted model.
    pub fn fit_on(
        &self,
        train: &WindowSet<'_>,
        powertrain: Box<dyn Powertrain>,
        label: String,
    ) -> Result<AccBlrModel, FitError> {
        self.velocity.validate()?;
        for prior in &self.priors {
            prior.validate(2)?;
        }
        if train.is_empty() {
            return Err(FitError::EmptyTrainingSet);
        }
        let vehicle = Arc::clone(&train.robot.vehicle);
        let dt = train.robot.dt();
        let mut xs: [Vec<f64>; 2] = Default::default();
        let mut gs: [Vec<f64>; 2] = Default::default();
        let mut measured = Vec::new();
        let mut inputs = Vec::new();
        for w in &train.windows {
            self.velocity.estimate(w, dt, &mut measured);
            powertrain.predict_into(&w.measured[0], &w.command, &mut inputs);
            for k in 0..w.len().saturating_sub(1) {
                let (Some(v0), Some(v1)) = (measured[k], measured[k + 1]) else {
                    continue;
                };
                let f = vehicle.body_velocity(&inputs[k]);
                for (j, d) in [0usize, 2].into_iter().enumerate() {
                    xs[j].extend_from_slice(&[f[d], v0[d]]);
                    gs[j].push(v1[d] - v0[d]);
                }
            }
        }
        Ok(AccBlrModel {
            label,
            accel_x: BlrPosterior::fit(
                &xs[0],
                2,
                &gs[0],
                &self.priors[0],
                "acc-BLR, longitudinal",
            )?,
            accel_yaw: BlrPosterior::fit(&xs[1], 2, &gs[1], &self.priors[1], "acc-BLR, angular")?,
            vehicle,
            powertrain,
            dt,
        })
    }
}

impl Baseline for AccBlr {
    fn fit_with(
        &self,
        train: &WindowSet<'_>,
        powertrain: Option<&dyn FitPowertrain>,
    ) -> Result<Box<dyn MotionModel>, FitError> {
        let learner: &dyn FitPowertrain = powertrain.unwrap_or(&Commanded);
        let label = format!("acc-blr+{}", learner.fitted_tag().tag);
        if train.is_empty() {
            return Err(FitError::EmptyTrainingSet);
        }
        let fitted = learner.fit_boxed(train)?;
        Ok(Box::new(self.fit_on(train, fitted, label)?))
    }

    fn default_powertrain(&self) -> Option<&str> {
        Some("commanded")
    }

    fn fitted_tag(&self) -> Option<PartTag> {
        Some(PartTag::of::<AccBlrModel, Box<dyn MotionModel>>(
            "MotionModel",
        ))
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
        let inputs = self.powertrain.predict(&start.input, commands);
        for u in &inputs {
            out.push(v);
            if let Some(vs) = variances.as_deref_mut() {
                vs.push(var);
            }
            let f = self.vehicle.body_velocity(u);
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
    fn name(&self) -> String {
        self.label.clone()
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn check(&self) -> Result<(), String> {
        drive_traits::check_step(self.dt)?;
        self.vehicle.check()?;
        self.powertrain.check()?;
        crate::powertrain::check_vehicle_axes(self.powertrain.as_ref(), self.vehicle.as_ref())?;
        crate::check_same_step("powertrain", self.powertrain.step(), self.dt)?;
        self.accel_x.check(2, "accel_x")?;
        self.accel_yaw.check(2, "accel_yaw")
    }
    /// The powertrain's parameters (`powertrain: ...`), then the two regressions' posterior
    /// mean weights.
    fn parameters(&self) -> Vec<(String, f64)> {
        let mut out: Vec<_> =
            crate::composed::prefixed_parameters(self.powertrain.as_ref()).collect();
        for (change, inputs, posterior) in [
            ("forward velocity change", ["f_x", "v_x"], &self.accel_x),
            ("yaw-rate change", ["f_w", "v_w"], &self.accel_yaw),
        ] {
            for (input, w) in inputs.iter().zip(posterior.mean.iter()) {
                out.push((format!("{change}: w[{input}]"), *w));
            }
        }
        out
    }
    fn powertrain(&self) -> Option<&dyn Powertrain> {
        Some(self.powertrain.as_ref())
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
