//! The composed model stepped one command at a time (eq. 1-5 sample by sample): the
//! powertrain's, the slip model's and the integrator's states one after the other in a
//! flat state (see [`drive_traits::step`]).

use crate::rollout::{covariance_step, Integrator};
use crate::ComposedModel;
use drive_traits::step::{check_state, layout, ReplayStepper, StepOptions, StepOutputs, Stepper};
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

    /// Stage by stage over the batch (the powertrain of every state, then the vehicle,
    /// then the slip model, then eq. 1): one call per part and batch, and independent
    /// states side by side in each loop. The same arithmetic as [`Stepper::step`].
    fn step_batch(&self, states: &mut [f64], commands: &[Input]) -> Result<(), MotionError> {
        drive_traits::step::check_states(self.len, states.len(), commands.len())?;
        if commands.is_empty() {
            return Ok(());
        }
        with_batch(|b| {
            let n = commands.len();
            b.reached.resize(n, Input::zeros());
            b.velocities.resize(n, BodyVelocity::zeros());
            // State 0's part starts at the part's offset, state i's `len` numbers on.
            self.powertrain.step_many(
                &mut states[self.powertrain_at..],
                self.len,
                commands,
                &mut b.reached,
            );
            self.model
                .vehicle
                .body_velocities_into(&b.reached, &mut b.commanded);
            self.slip.step_many(
                &mut states[self.slip_at..],
                self.len,
                &b.commanded,
                &mut b.velocities,
            );
            let dt = self.model.dt;
            for (i, state) in states.chunks_exact_mut(self.len).enumerate() {
                let (f, v) = (&b.commanded[i], &b.velocities[i]);
                let pose = layout::pose(state);
                self.covariance_step(state, &pose, f, v)?;
                integrate(state, &pose, v, dt);
            }
            Ok(())
        })
    }

    /// Each part over the whole sequence at once (as a prediction runs), then eq. 1 step
    /// by step: the same arithmetic as [`Stepper::step`] command after command.
    fn rollout(
        &self,
        state: &mut [f64],
        commands: &[Input],
        mut outputs: StepOutputs<'_>,
    ) -> Result<(), MotionError> {
        check_state(self.len, state)?;
        outputs.check(commands.len())?;
        if commands.is_empty() {
            return Ok(());
        }
        with_batch(|b| {
            let n = commands.len();
            b.reached.resize(n, Input::zeros());
            b.velocities.resize(n, BodyVelocity::zeros());
            self.powertrain.step_seq(
                &mut state[self.powertrain_at..self.slip_at],
                commands,
                &mut b.reached,
            );
            self.model
                .vehicle
                .body_velocities_into(&b.reached, &mut b.commanded);
            self.slip.step_seq(
                &mut state[self.slip_at..self.covariance_at],
                &b.commanded,
                &mut b.velocities,
            );
            let dt = self.model.dt;
            let off = matches!(self.covariance, Covariance::Off);
            let mut it = Integrator::resume(&layout::pose(state), state[TRIG], state[TRIG + 1], dt);
            for (k, (f, v)) in b.commanded.iter().zip(&b.velocities).enumerate() {
                if !off {
                    self.covariance_step(state, &it.pose(), f, v)?;
                    if let Some(c) = outputs.covariances.as_deref_mut() {
                        c[k] = layout::covariance(state);
                    }
                }
                it.step(v);
                if let Some(p) = outputs.poses.as_deref_mut() {
                    p[k] = it.pose();
                }
                if let Some(out) = outputs.velocities.as_deref_mut() {
                    out[k] = *v;
                }
            }
            let (cos, sin) = it.heading();
            (state[TRIG], state[TRIG + 1]) = (cos, sin);
            state[layout::POSE..layout::POSE + 3].copy_from_slice(it.pose().as_slice());
            state[layout::VELOCITY..layout::VELOCITY + 3]
                .copy_from_slice(b.velocities[n - 1].as_slice());
            state[layout::STEPS] += n as f64;
            Ok(())
        })
    }

    #[inline]
    fn step(&self, state: &mut [f64], command: &Input) -> Result<(), MotionError> {
        check_state(self.len, state)?;
        let pose = layout::pose(state);
        // Eq. 3, 4 and 2 at this sample.
        let reached = self
            .powertrain
            .step(&mut state[self.powertrain_at..self.slip_at], command);
        let f = self.model.vehicle.body_velocity(&reached);
        let v = self
            .slip
            .step(&mut state[self.slip_at..self.covariance_at], &f);
        self.covariance_step(state, &pose, &f, &v)?;
        integrate(state, &pose, &v, self.model.dt);
        Ok(())
    }
}

impl ComposedStepper<'_> {
    /// The covariance's step, when carried: from the pose before the step, at the
    /// commanded body velocity `f` and the actual `v`.
    #[inline]
    fn covariance_step(
        &self,
        state: &mut [f64],
        pose: &Pose,
        f: &BodyVelocity,
        v: &BodyVelocity,
    ) -> Result<(), MotionError> {
        match &self.covariance {
            Covariance::Off => {}
            Covariance::Variances => {
                let variance =
                    self.model
                        .slip
                        .slip_variance(f)
                        .ok_or_else(|| MotionError::NoUncertainty {
                            model: self.model.name(),
                        })?;
                let p = covariance_step(
                    &layout::covariance(state),
                    pose,
                    v,
                    &variance,
                    self.model.dt,
                );
                layout::write_covariance(state, &p);
            }
            Covariance::Correlated(c) => {
                let p = c.step(&mut state[self.covariance_at..], f);
                layout::write_covariance(state, &p);
            }
        }
        Ok(())
    }
}

/// Eq. 1 from `pose` at body velocity `v` with the heading's cosine and sine carried; the
/// header's pose, velocity and step count updated.
#[inline]
fn integrate(state: &mut [f64], pose: &Pose, v: &BodyVelocity, dt: f64) {
    let mut it = Integrator::resume(pose, state[TRIG], state[TRIG + 1], dt);
    it.step(v);
    let (cos, sin) = it.heading();
    (state[TRIG], state[TRIG + 1]) = (cos, sin);
    let next = it.pose();
    state[layout::POSE..layout::POSE + 3].copy_from_slice(next.as_slice());
    state[layout::VELOCITY..layout::VELOCITY + 3].copy_from_slice(v.as_slice());
    state[layout::STEPS] += 1.0;
}

/// The per-batch buffers of [`ComposedStepper::step_batch`]: the inputs reached, the
/// commanded and the actual body velocities.
#[derive(Default)]
struct Batch {
    reached: Vec<Input>,
    commanded: Vec<BodyVelocity>,
    velocities: Vec<BodyVelocity>,
}

thread_local! {
    static BATCH: std::cell::RefCell<Batch> = std::cell::RefCell::new(Batch::default());
}

/// Runs `f` with this thread's batch buffers (fresh ones if they are in use).
fn with_batch<R>(f: impl FnOnce(&mut Batch) -> R) -> R {
    BATCH.with(|cell| match cell.try_borrow_mut() {
        Ok(mut b) => f(&mut b),
        Err(_) => f(&mut Batch::default()),
    })
}
