use crate::blr::{BlrPosterior, Prior};
use crate::powertrain::Commanded;
use crate::rollout::{covariance_step, integrate, integrate_with_covariance, Integrator};
use drive_traits::step::{check_state, layout, ReplayStepper, StepOptions, Stepper};
use drive_traits::InvalidPart;
use drive_traits::{
    Baseline, BodyVelocity, BodyVelocityEstimator, CommandModel, FitError, FitPowertrain, Input,
    MotionError, MotionModel, PartTag, Pose, PoseCovariance, Powertrain, PowertrainStepper,
    StartState, Tagged, WindowSet,
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
#[serde(deny_unknown_fields)]
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
    /// One step of the velocity state: from `v[k]` (variance `var[k]`) and the input
    /// reached at sample k, `v[k+1]` and, with `variances`, `var[k+1]` (otherwise `var[k]`).
    #[inline]
    fn advance(
        &self,
        v: &BodyVelocity,
        var: &BodyVelocity,
        u: &Input,
        variances: bool,
    ) -> (BodyVelocity, BodyVelocity) {
        let f = self.vehicle.body_velocity(u);
        let (xx, xw) = ([f.x, v.x], [f.z, v.z]);
        let next = BodyVelocity::new(
            v.x + self.accel_x.predict_mean(&xx),
            0.0,
            v.z + self.accel_yaw.predict_mean(&xw),
        );
        if !variances {
            return (next, *var);
        }
        // v[k+1] = (1 + gamma_v) v[k] + gamma_f f[k] + noise: first-order propagation.
        let (gx, gw) = (1.0 + self.accel_x.mean[1], 1.0 + self.accel_yaw.mean[1]);
        let var = BodyVelocity::new(
            gx * gx * var.x + self.accel_x.predictive_variance(&xx),
            0.0,
            gw * gw * var.z + self.accel_yaw.predictive_variance(&xw),
        );
        (next, var)
    }

    /// The velocity state at the start: the measured forward speed and yaw rate.
    fn start_velocity(start: &StartState) -> BodyVelocity {
        BodyVelocity::new(start.body_velocity.x, 0.0, start.body_velocity.z)
    }

    fn body_velocities(
        &self,
        start: &StartState,
        commands: &[Input],
        mut variances: Option<&mut Vec<BodyVelocity>>,
    ) -> Vec<BodyVelocity> {
        let mut out = Vec::with_capacity(commands.len());
        let mut v = Self::start_velocity(start);
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
            (v, var) = self.advance(&v, &var, u, variances.is_some());
        }
        out
    }
}

/// acc-BLR stepped: after the header, the heading's cosine and sine, the velocity state and
/// its variance (three numbers each), then the powertrain's state.
struct AccBlrStepper<'a> {
    model: &'a AccBlrModel,
    powertrain: Box<dyn PowertrainStepper + 'a>,
    covariance: bool,
}

const TRIG: usize = layout::HEADER;
const VELOCITY: usize = TRIG + 2;
const VARIANCE: usize = VELOCITY + 3;
const POWERTRAIN: usize = VARIANCE + 3;

impl Stepper for AccBlrStepper<'_> {
    fn state_len(&self) -> usize {
        POWERTRAIN + self.powertrain.state_len()
    }

    fn with_covariance(&self) -> bool {
        self.covariance
    }

    fn init(
        &self,
        start: &StartState,
        history: &[Input],
        state: &mut [f64],
    ) -> Result<(), MotionError> {
        check_state(self.state_len(), state)?;
        state.fill(0.0);
        layout::write(
            state,
            &start.pose,
            &start.body_velocity,
            &PoseCovariance::zeros(),
            0,
        );
        let (sin, cos) = start.pose.z.sin_cos();
        (state[TRIG], state[TRIG + 1]) = (cos, sin);
        state[VELOCITY..VELOCITY + 3]
            .copy_from_slice(AccBlrModel::start_velocity(start).as_slice());
        self.powertrain
            .init(&start.input, history, &mut state[POWERTRAIN..]);
        Ok(())
    }

    fn step(&self, state: &mut [f64], command: &Input) -> Result<(), MotionError> {
        check_state(self.state_len(), state)?;
        let m = self.model;
        let pose = layout::pose(state);
        let k = layout::steps(state);
        let reached = self.powertrain.step(&mut state[POWERTRAIN..], command);
        let v = BodyVelocity::from_column_slice(&state[VELOCITY..VELOCITY + 3]);
        let var = BodyVelocity::from_column_slice(&state[VARIANCE..VARIANCE + 3]);
        let (next, next_var) = m.advance(&v, &var, &reached, self.covariance);
        if self.covariance {
            let p = covariance_step(&layout::covariance(state), &pose, &v, &var, m.dt);
            layout::write_covariance(state, &p);
        }
        let mut it = Integrator::resume(&pose, state[TRIG], state[TRIG + 1], m.dt);
        it.step(&v);
        let (cos, sin) = it.heading();
        (state[TRIG], state[TRIG + 1]) = (cos, sin);
        state[layout::POSE..layout::POSE + 3].copy_from_slice(it.pose().as_slice());
        state[layout::VELOCITY..layout::VELOCITY + 3].copy_from_slice(v.as_slice());
        state[layout::STEPS] = (k + 1) as f64;
        state[VELOCITY..VELOCITY + 3].copy_from_slice(next.as_slice());
        state[VARIANCE..VARIANCE + 3].copy_from_slice(next_var.as_slice());
        Ok(())
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
    fn check(&self) -> Result<(), InvalidPart> {
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
    /// The velocity state, its variance and the powertrain's state, stepped (by replay
    /// for a powertrain without a stepper).
    fn stepper(&self, options: StepOptions) -> Result<Box<dyn Stepper + '_>, MotionError> {
        match self.powertrain.stepper() {
            Some(powertrain) => Ok(Box::new(AccBlrStepper {
                model: self,
                powertrain,
                covariance: options.covariance,
            })),
            None => Ok(Box::new(ReplayStepper::new(self, options)?)),
        }
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
