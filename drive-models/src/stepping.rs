//! The composed model stepped one command at a time (eq. 1-5 sample by sample): the
//! powertrain's, the slip model's and the integrator's states one after the other in a
//! flat state (see [`drive_traits::step`]).

use crate::rollout::{covariance_step, Integrator};
use crate::ComposedModel;
use drive_traits::step::{check_state, layout, ReplayStepper, StepOptions, Stepper};
use drive_traits::{
    BodyVelocity, Input, MotionError, MotionModel, Pose, PoseCovariance, PowertrainStepper,
    SlipCovarianceStepper, SlipStepper, StartState,
};

/// How a stepped composed model carries its covariance.
enum Covariance<'a> {
    /// Not at all.
    Off,
    /// The slip's per-step variances (eq. 7) propagated through eq. 1.
    Variances,
    /// The slip model's own correlated covariance, stepped.
    Correlated(Box<dyn SlipCovarianceStepper + 'a>),
}

/// The stepper of a [`ComposedModel`] whose parts all step: after the header, the
/// heading's cosine and sine (the integrator's), the powertrain's state, the slip model's,
/// and the slip covariance's when carried.
pub(crate) struct ComposedStepper<'a> {
    model: &'a ComposedModel,
    powertrain: Box<dyn PowertrainStepper + 'a>,
    slip: Box<dyn SlipStepper + 'a>,
    covariance: Covariance<'a>,
    powertrain_at: usize,
    slip_at: usize,
    covariance_at: usize,
    len: usize,
}

/// The heading's cosine and sine after the header.
const TRIG: usize = layout::HEADER;

/// The stepper of `model`: its parts' steppers when they all have one, otherwise the
/// replay of its prediction.
pub(crate) fn composed_stepper(
    model: &ComposedModel,
    options: StepOptions,
) -> Result<Box<dyn Stepper + '_>, MotionError> {
    match ComposedStepper::new(model, options)? {
        Some(s) => Ok(Box::new(s)),
        None => Ok(Box::new(ReplayStepper::new(model, options)?)),
    }
}

impl<'a> ComposedStepper<'a> {
    /// `None` when a part has no stepper (or carries a correlated covariance without one):
    /// the model is then stepped by replay.
    fn new(model: &'a ComposedModel, options: StepOptions) -> Result<Option<Self>, MotionError> {
        let (Some(powertrain), Some(slip)) = (model.powertrain.stepper(), model.slip.stepper())
        else {
            return Ok(None);
        };
        let covariance = if options.covariance {
            if let Some(c) = model.slip.covariance_stepper(model.dt) {
                Covariance::Correlated(c)
            } else if model.slip.rollout_covariances_into(
                &StartState::at_rest(Pose::zeros()),
                &[],
                model.dt,
                &mut Vec::new(),
            ) {
                return Ok(None);
            } else if model.slip.slip_variance(&BodyVelocity::zeros()).is_some() {
                Covariance::Variances
            } else {
                return Err(MotionError::NoUncertainty {
                    model: model.name(),
                });
            }
        } else {
            Covariance::Off
        };
        let powertrain_at = TRIG + 2;
        let slip_at = powertrain_at + powertrain.state_len();
        let covariance_at = slip_at + slip.state_len();
        let len = covariance_at
            + match &covariance {
                Covariance::Correlated(c) => c.state_len(),
                _ => 0,
            };
        Ok(Some(ComposedStepper {
            model,
            powertrain,
            slip,
            covariance,
            powertrain_at,
            slip_at,
            covariance_at,
            len,
        }))
    }
}

impl Stepper for ComposedStepper<'_> {
    fn state_len(&self) -> usize {
        self.len
    }

    fn with_covariance(&self) -> bool {
        !matches!(self.covariance, Covariance::Off)
    }

    fn init(
        &self,
        start: &StartState,
        history: &[Input],
        state: &mut [f64],
    ) -> Result<(), MotionError> {
        check_state(self.len, state)?;
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
        self.powertrain.init(
            &start.input,
            history,
            &mut state[self.powertrain_at..self.slip_at],
        );
        self.slip
            .init(start, &mut state[self.slip_at..self.covariance_at]);
        if let Covariance::Correlated(c) = &self.covariance {
            c.init(start, &mut state[self.covariance_at..]);
        }
        Ok(())
    }

    #[inline]
    fn step(&self, state: &mut [f64], command: &Input) -> Result<(), MotionError> {
        check_state(self.len, state)?;
        let dt = self.model.dt;
        let pose = layout::pose(state);
        let k = layout::steps(state);
        // Eq. 3, 4 and 2 at this sample.
        let reached = self
            .powertrain
            .step(&mut state[self.powertrain_at..self.slip_at], command);
        let f = self.model.vehicle.body_velocity(&reached);
        let v = self
            .slip
            .step(&mut state[self.slip_at..self.covariance_at], &f);
        match &self.covariance {
            Covariance::Off => {}
            Covariance::Variances => {
                let variance = self.model.slip.slip_variance(&f).ok_or_else(|| {
                    MotionError::NoUncertainty {
                        model: self.model.name(),
                    }
                })?;
                let p = covariance_step(&layout::covariance(state), &pose, &v, &variance, dt);
                layout::write_covariance(state, &p);
            }
            Covariance::Correlated(c) => {
                let p = c.step(&mut state[self.covariance_at..], &f);
                layout::write_covariance(state, &p);
            }
        }
        // Eq. 1.
        let mut it = Integrator::resume(&pose, state[TRIG], state[TRIG + 1], dt);
        it.step(&v);
        let (cos, sin) = it.heading();
        (state[TRIG], state[TRIG + 1]) = (cos, sin);
        let next = it.pose();
        state[layout::POSE..layout::POSE + 3].copy_from_slice(next.as_slice());
        state[layout::VELOCITY..layout::VELOCITY + 3].copy_from_slice(v.as_slice());
        state[layout::STEPS] = (k + 1) as f64;
        Ok(())
    }
}
