//! Stepping a fitted model one command at a time (eq. 1 sample by sample): the model's whole
//! internal state as a flat vector of numbers that a controller creates from a start, steps
//! by one command and copies.
//!
//! A prediction ([`MotionModel::predict_into`]) rolls a whole command sequence out from a
//! start. A sampling-based controller (MPPI in Nav2, `pytorch_mppi`) instead calls
//! `dynamics(state, action) -> next_state`, so the state must hold everything the model
//! remembers: the pose, the powertrain's wheels and the commands still inside its dead time
//! (eq. 3), the slip model's own state (slip-ipem's lagging body velocity), the pose
//! covariance and whatever a calibration needs. A [`Stepper`] (from
//! [`MotionModel::stepper`]) keeps all of it in one `[f64]` of [`Stepper::state_len`]
//! numbers per state, so that a batch of states is one contiguous buffer that C, numpy and
//! the Rust batch functions share without copies.
//!
//! Every state starts with the same [`layout`] header (pose, the body velocity of the last
//! step, the pose covariance, the number of steps taken); what follows belongs to the model.
//! Stepping `k` times from a start gives the pose of row `k` of the prediction from the same
//! start and commands (and its covariance), to rounding: a test holds every built-in model
//! to 1e-12.
//!
//! ```
//! use drive_traits::step::{layout, StepOptions};
//! use drive_traits::{euler_step, BodyVelocity, Input, MotionModel, Pose, StartState, Tagged};
//! use serde::{Deserialize, Serialize};
//!
//! /// Moves at the commanded speed (input 0) and yaw rate (input 1) at once.
//! #[derive(Debug, Serialize, Deserialize)]
//! struct Unicycle;
//! #[typetag::serde(name = "unicycle-step-doc")]
//! impl MotionModel for Unicycle {
//!     fn name(&self) -> String { "unicycle".into() }
//!     fn dt(&self) -> f64 { 0.1 }
//!     fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>) {
//!         poses.clear();
//!         let mut q = start.pose;
//!         for u in commands {
//!             poses.push(q);
//!             q = euler_step(&q, &BodyVelocity::new(u.x, 0.0, u.y), 0.1);
//!         }
//!     }
//! }
//! impl Tagged for Unicycle { const TAG: &'static str = "unicycle-step-doc"; }
//!
//! let model = Unicycle;
//! // A model without a stepper of its own is stepped by replaying its prediction.
//! let stepper = model.stepper(StepOptions::default()).unwrap();
//! let mut state = vec![0.0; stepper.state_len()];
//! stepper.init(&StartState::at_rest(Pose::zeros()), &[], &mut state).unwrap();
//! let commands = [Input::new(1.0, 0.5, 0.0); 4];
//! for u in &commands {
//!     stepper.step(&mut state, u).unwrap();
//! }
//! let poses = model.predict(&StartState::at_rest(Pose::zeros()), &[commands.as_slice(), &[Input::zeros()]].concat());
//! assert!((layout::pose(&state) - poses[4]).norm() < 1e-12);
//! assert_eq!(layout::steps(&state), 4);
//! ```

use crate::{BodyVelocity, Input, MotionError, MotionModel, Pose, PoseCovariance, StartState};

/// Where the values every state holds are: the first [`layout::HEADER`] numbers of a state.
pub mod layout {
    use crate::{BodyVelocity, Pose, PoseCovariance};

    /// The pose x, y, yaw (m, m, rad): numbers 0-2.
    pub const POSE: usize = 0;
    /// The body velocity over the last step (v_x, v_y, w; m/s, m/s, rad/s), the one that
    /// moved the previous pose to this one (eq. 1); at the start, the start's body velocity:
    /// numbers 3-5.
    pub const VELOCITY: usize = 3;
    /// The pose covariance, row-major 3 x 3 (zero at the start, and zero throughout when
    /// the stepper does not carry it): numbers 6-14.
    pub const COVARIANCE: usize = 6;
    /// The number of steps taken since the start: number 15.
    pub const STEPS: usize = 15;
    /// The header's length: the model's own numbers follow it.
    pub const HEADER: usize = 16;

    /// The pose of a state.
    ///
    /// ```
    /// let mut s = [0.0; drive_traits::step::layout::HEADER];
    /// s[2] = 0.5;
    /// assert_eq!(drive_traits::step::layout::pose(&s).z, 0.5);
    /// ```
    #[inline]
    pub fn pose(state: &[f64]) -> Pose {
        Pose::from_column_slice(&state[POSE..POSE + 3])
    }

    /// The body velocity over the last step of a state.
    #[inline]
    pub fn body_velocity(state: &[f64]) -> BodyVelocity {
        BodyVelocity::from_column_slice(&state[VELOCITY..VELOCITY + 3])
    }

    /// The pose covariance of a state.
    #[inline]
    pub fn covariance(state: &[f64]) -> PoseCovariance {
        PoseCovariance::from_row_slice(&state[COVARIANCE..COVARIANCE + 9])
    }

    /// The number of steps a state has taken (0 for a value that is not a count).
    #[inline]
    pub fn steps(state: &[f64]) -> usize {
        let k = state[STEPS];
        if k.is_finite() && k >= 0.0 {
            k as usize
        } else {
            0
        }
    }

    /// Writes the header of a state: its pose, body velocity and covariance, and the
    /// number of steps.
    #[inline]
    pub fn write(
        state: &mut [f64],
        pose: &Pose,
        velocity: &BodyVelocity,
        covariance: &PoseCovariance,
        steps: usize,
    ) {
        state[POSE..POSE + 3].copy_from_slice(pose.as_slice());
        state[VELOCITY..VELOCITY + 3].copy_from_slice(velocity.as_slice());
        write_covariance(state, covariance);
        state[STEPS] = steps as f64;
    }

    /// Writes the pose covariance of a state (row-major).
    #[inline]
    pub fn write_covariance(state: &mut [f64], covariance: &PoseCovariance) {
        for r in 0..3 {
            for c in 0..3 {
                state[COVARIANCE + 3 * r + c] = covariance[(r, c)];
            }
        }
    }
}

/// The most steps a state stepped by replay holds by default (a minute at 20 Hz):
/// [`StepOptions::max_steps`].
pub const DEFAULT_REPLAY_STEPS: usize = 1200;

/// What a stepper carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepOptions {
    /// Whether the states carry the pose covariance (for a model with an uncertainty; a
    /// stepper of a model without one is refused, [`MotionError::NoUncertainty`]).
    pub covariance: bool,
    /// For a model stepped by replay only (one without a stepper of its own): the most
    /// steps a state can take, since it holds every command so far. Built-in models ignore
    /// it.
    pub max_steps: usize,
}

impl Default for StepOptions {
    fn default() -> Self {
        StepOptions {
            covariance: false,
            max_steps: DEFAULT_REPLAY_STEPS,
        }
    }
}

impl StepOptions {
    /// The default options with the covariance carried or not.
    ///
    /// ```
    /// assert!(drive_traits::step::StepOptions::with_covariance(true).covariance);
    /// ```
    pub fn with_covariance(covariance: bool) -> Self {
        StepOptions {
            covariance,
            ..StepOptions::default()
        }
    }
}

/// A fitted model stepped one command at a time (see the [module](self)): what
/// [`MotionModel::stepper`] returns. A state is a `[f64]` of [`Stepper::state_len`] numbers
/// with the [`layout`] header first.
///
/// The contract: from [`Stepper::init`] at a start with no history, `k` calls of
/// [`Stepper::step`] with the commands `u_0 .. u_{k-1}` leave the pose (and covariance) of
/// row `k` of [`MotionModel::predict_into`] from that start through any command sequence
/// beginning with them. A state whose numbers were changed by hand never makes a stepper
/// panic: an index read from it is bounded, and a number that is not finite gives poses
/// that are not.
pub trait Stepper: Send + Sync {
    /// The numbers in one state.
    fn state_len(&self) -> usize;

    /// Whether the states carry the pose covariance.
    fn with_covariance(&self) -> bool;

    /// Whether the model is stepped by replaying its prediction ([`ReplayStepper`]: each
    /// step costs a prediction as long as the steps so far); `false` by default.
    fn is_replay(&self) -> bool {
        false
    }

    /// Writes the state at `start` into `state`, with `history` the commands already sent
    /// before it (oldest first; those still inside a powertrain's dead time act in the
    /// first steps, eq. 3; without it, the commands before the start are taken to be the
    /// measured inputs, as a prediction takes them).
    fn init(
        &self,
        start: &StartState,
        history: &[Input],
        state: &mut [f64],
    ) -> Result<(), MotionError>;

    /// Moves `state` one step of the model's period under `command`.
    fn step(&self, state: &mut [f64], command: &Input) -> Result<(), MotionError>;

    /// Steps every state of `states` (consecutive states of [`Stepper::state_len`]
    /// numbers) by its own command of `commands`, one call for the batch. The default
    /// calls [`Stepper::step`] on each in turn.
    fn step_batch(&self, states: &mut [f64], commands: &[Input]) -> Result<(), MotionError> {
        check_states(self.state_len(), states.len(), commands.len())?;
        for (s, u) in states.chunks_exact_mut(self.state_len()).zip(commands) {
            self.step(s, u)?;
        }
        Ok(())
    }

    /// Steps `state` through every command of `commands` in turn, recording what `outputs`
    /// asks for after each step (row k after command k). The same states as that many calls
    /// of [`Stepper::step`], which the default makes; a stepper overrides it to run each
    /// part over the whole sequence at once (as a prediction runs).
    fn rollout(
        &self,
        state: &mut [f64],
        commands: &[Input],
        mut outputs: StepOutputs<'_>,
    ) -> Result<(), MotionError> {
        check_state(self.state_len(), state)?;
        outputs.check(commands.len())?;
        for (k, u) in commands.iter().enumerate() {
            self.step(state, u)?;
            outputs.record(k, state);
        }
        Ok(())
    }
}

/// What a rollout of one state records after each of its steps, each optional: one row
/// per command ([`Stepper::rollout`]).
#[derive(Default)]
pub struct StepOutputs<'a> {
    /// The pose after each step.
    pub poses: Option<&'a mut [Pose]>,
    /// The body velocity over each step.
    pub velocities: Option<&'a mut [BodyVelocity]>,
    /// The pose covariance after each step (of a stepper that carries it).
    pub covariances: Option<&'a mut [PoseCovariance]>,
}

impl StepOutputs<'_> {
    /// Records row `k` from `state`.
    #[inline]
    pub fn record(&mut self, k: usize, state: &[f64]) {
        if let Some(p) = self.poses.as_deref_mut() {
            p[k] = layout::pose(state);
        }
        if let Some(v) = self.velocities.as_deref_mut() {
            v[k] = layout::body_velocity(state);
        }
        if let Some(c) = self.covariances.as_deref_mut() {
            c[k] = layout::covariance(state);
        }
    }

    /// `Err` unless every output given has `rows` rows.
    pub fn check(&self, rows: usize) -> Result<(), MotionError> {
        for given in [
            self.poses.as_ref().map(|p| p.len()),
            self.velocities.as_ref().map(|v| v.len()),
            self.covariances.as_ref().map(|c| c.len()),
        ]
        .into_iter()
        .flatten()
        {
            if given != rows {
                return Err(MotionError::BatchShape {
                    sequences: 1,
                    horizon: rows,
                    expected: rows,
                    commands: rows,
                    poses: given,
                });
            }
        }
        Ok(())
    }
}

/// `Err` unless `state` holds exactly `len` numbers.
///
/// ```
/// assert!(drive_traits::step::check_state(3, &[0.0; 3]).is_ok());
/// assert!(drive_traits::step::check_state(3, &[0.0; 2]).is_err());
/// ```
#[inline]
pub fn check_state(len: usize, state: &[f64]) -> Result<(), MotionError> {
    if state.len() == len {
        Ok(())
    } else {
        Err(MotionError::StateShape {
            expected: len,
            found: state.len(),
        })
    }
}

/// `Err` unless a batch buffer of `numbers` holds `commands` states of `len` numbers.
///
/// ```
/// assert!(drive_traits::step::check_states(4, 8, 2).is_ok());
/// assert!(drive_traits::step::check_states(4, 8, 3).is_err());
/// ```
#[inline]
pub fn check_states(len: usize, numbers: usize, commands: usize) -> Result<(), MotionError> {
    if commands.checked_mul(len) == Some(numbers) {
        Ok(())
    } else {
        Err(MotionError::StateShape {
            expected: commands.saturating_mul(len),
            found: numbers,
        })
    }
}

/// An index kept in a state as a number, read back within `0..len` (0 for a number that is
/// not an index): a state changed by hand never indexes out of its buffer.
///
/// ```
/// use drive_traits::step::index_of;
/// assert_eq!(index_of(2.0, 4), 2);
/// assert_eq!((index_of(9.0, 4), index_of(f64::NAN, 4), index_of(-1.0, 4)), (0, 0, 0));
/// ```
#[inline]
pub fn index_of(value: f64, len: usize) -> usize {
    // `as` saturates (NaN and negatives to 0, beyond to usize::MAX): anything out of range
    // reads 0.
    let i = value as usize;
    if i < len {
        i
    } else {
        0
    }
}

/// A [`Stepper`] for any model, by replaying its prediction: the state holds the start and
/// every command so far (up to [`StepOptions::max_steps`]), and each step predicts from the
/// start through all of them. Exact for any model whose poses depend only on the commands
/// before them, but each step costs a prediction as long as the steps taken: what
/// [`MotionModel::stepper`] gives a model without a stepper of its own. It cannot take a
/// command history (a prediction has none): [`Stepper::init`] refuses one.
pub struct ReplayStepper<'a, M: ?Sized> {
    model: &'a M,
    options: StepOptions,
}

/// Offsets of the replayed start after the header: pose 3, input 3, body velocity 3, the
/// yaw rate's flag and value, the velocity's flag and value (2).
const REPLAY_START: usize = layout::HEADER;
const REPLAY_COMMANDS: usize = REPLAY_START + 14;

impl<'a, M: MotionModel + ?Sized> ReplayStepper<'a, M> {
    /// The replay stepper of `model`; with the covariance, only for a model that predicts
    /// one.
    pub fn new(model: &'a M, options: StepOptions) -> Result<Self, MotionError> {
        if options.covariance {
            model.predict_with_covariance_into(
                &StartState::at_rest(Pose::zeros()),
                &[Input::zeros(); 2],
                &mut Vec::new(),
                &mut Vec::new(),
            )?;
        }
        Ok(ReplayStepper { model, options })
    }

    fn start(state: &[f64]) -> StartState {
        let s = &state[REPLAY_START..REPLAY_COMMANDS];
        let v3 = |i: usize| crate::Pose::new(s[i], s[i + 1], s[i + 2]);
        StartState {
            pose: v3(0),
            input: v3(3),
            body_velocity: v3(6),
            yaw_rate: (s[9] != 0.0).then_some(s[10]),
            velocity: (s[11] != 0.0).then_some([s[12], s[13]]),
            observed: None,
        }
    }
}

impl<M: MotionModel + ?Sized> Stepper for ReplayStepper<'_, M> {
    fn state_len(&self) -> usize {
        REPLAY_COMMANDS + 3 * self.options.max_steps
    }

    fn with_covariance(&self) -> bool {
        self.options.covariance
    }

    fn is_replay(&self) -> bool {
        true
    }

    fn init(
        &self,
        start: &StartState,
        history: &[Input],
        state: &mut [f64],
    ) -> Result<(), MotionError> {
        check_state(self.state_len(), state)?;
        if !history.is_empty() {
            return Err(MotionError::NoHistory {
                model: self.model.name(),
            });
        }
        state.fill(0.0);
        layout::write(
            state,
            &start.pose,
            &start.body_velocity,
            &PoseCovariance::zeros(),
            0,
        );
        let s = &mut state[REPLAY_START..REPLAY_COMMANDS];
        s[0..3].copy_from_slice(start.pose.as_slice());
        s[3..6].copy_from_slice(start.input.as_slice());
        s[6..9].copy_from_slice(start.body_velocity.as_slice());
        if let Some(w) = start.yaw_rate {
            (s[9], s[10]) = (1.0, w);
        }
        if let Some([x, y]) = start.velocity {
            (s[11], s[12], s[13]) = (1.0, x, y);
        }
        Ok(())
    }

    fn step(&self, state: &mut [f64], command: &Input) -> Result<(), MotionError> {
        check_state(self.state_len(), state)?;
        let k = layout::steps(state);
        if k >= self.options.max_steps {
            return Err(MotionError::ReplayFull {
                model: self.model.name(),
                max_steps: self.options.max_steps,
            });
        }
        let at = REPLAY_COMMANDS + 3 * k;
        state[at..at + 3].copy_from_slice(command.as_slice());
        // Commands 0..=k and one more (the last command of a prediction moves nothing).
        let mut commands: Vec<Input> = state[REPLAY_COMMANDS..at + 3]
            .chunks_exact(3)
            .map(Input::from_column_slice)
            .collect();
        commands.push(*command);
        let start = Self::start(state);
        let (mut poses, mut covariances) = (Vec::new(), Vec::new());
        if self.options.covariance {
            self.model.predict_with_covariance_into(
                &start,
                &commands,
                &mut poses,
                &mut covariances,
            )?;
        } else {
            self.model.predict_into(&start, &commands, &mut poses);
        }
        let (Some(before), Some(after)) = (poses.get(k), poses.get(k + 1)) else {
            return Err(MotionError::NotFinite {
                model: self.model.name(),
                step: k + 1,
                t: (k + 1) as f64 * self.model.dt(),
            });
        };
        // The body velocity of the step: eq. 1 solved for v.
        let dt = self.model.dt();
        let (s, c) = before.z.sin_cos();
        let (dx, dy) = (after.x - before.x, after.y - before.y);
        let velocity = BodyVelocity::new(
            (c * dx + s * dy) / dt,
            (c * dy - s * dx) / dt,
            (after.z - before.z) / dt,
        );
        let covariance = covariances
            .get(k + 1)
            .copied()
            .unwrap_or_else(PoseCovariance::zeros);
        layout::write(state, after, &velocity, &covariance, k + 1);
        Ok(())
    }
}
