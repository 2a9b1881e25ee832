//! Batched rollouts on all cores: many command sequences (the MPPI case) split across the
//! rayon thread pool, each chunk rolled out by the model's own batch kernel; and batches of
//! stepped states ([`drive_traits::step`]) stepped or rolled out the same way.

use drive_traits::step::{check_states, StepOutputs, Stepper};
use drive_traits::{Input, MotionError, MotionModel, Pose, StartState};
use rayon::prelude::*;

/// Like [`MotionModel::predict_batch_into`], in parallel: the sequences are split into
/// chunks of `chunk` sequences (at least 1) rolled out on the rayon pool. The poses are the
/// same as the sequential call's.
///
/// ```
/// use drive_models::{batch::predict_batch_parallel, ComposedModel, DifferentialDrive};
/// use drive_models::{powertrain::CommandedPowertrain, slip::NoSlipModel};
/// use drive_traits::{Input, MotionModel, Pose, StartState};
/// use std::sync::Arc;
/// let model = ComposedModel { label: "naive".into(), vehicle: Arc::new(DifferentialDrive::new(0.1, 0.5)),
///     powertrain: Box::new(CommandedPowertrain), slip: Box::new(NoSlipModel), dt: 0.05 };
/// let (n, horizon) = (100, 40);
/// let starts = vec![StartState::at_rest(Pose::zeros()); n];
/// let commands: Vec<Input> = (0..n * horizon).map(|i| Input::new(1.0, (i % 7) as f64, 0.0)).collect();
/// let mut poses = vec![Pose::zeros(); n * horizon];
/// predict_batch_parallel(&model, &starts, &commands, horizon, &mut poses, 16).unwrap();
/// let one = model.predict(&starts[3], &commands[3 * horizon..4 * horizon]);
/// assert_eq!(&poses[3 * horizon..4 * horizon], one.as_slice());
/// ```
pub fn predict_batch_parallel(
    model: &dyn MotionModel,
    starts: &[StartState],
    commands: &[Input],
    horizon: usize,
    poses: &mut [Pose],
    chunk: usize,
) -> Result<(), MotionError> {
    MotionError::check_batch(starts.len(), horizon, commands.len(), poses.len())?;
    if horizon == 0 {
        return Ok(());
    }
    let chunk = chunk.max(1);
    poses
        .par_chunks_mut(chunk * horizon)
        .zip(starts.par_chunks(chunk))
        .zip(commands.par_chunks(chunk * horizon))
        .try_for_each(|((p, s), c)| model.predict_batch_into(s, c, horizon, p))
}

/// [`Stepper::step_batch`] in parallel: the states (consecutive, [`Stepper::state_len`]
/// numbers each) split into chunks of `chunk` states (at least 1) stepped on the rayon
/// pool, each by its own command. The states are the same as the sequential call's.
///
/// ```
/// use drive_models::{batch::step_batch_parallel, ComposedModel, DifferentialDrive};
/// use drive_models::{powertrain::CommandedPowertrain, slip::NoSlipModel};
/// use drive_traits::step::{layout, StepOptions};
/// use drive_traits::{Input, MotionModel, Pose, StartState};
/// use std::sync::Arc;
/// let model = ComposedModel { label: "naive".into(), vehicle: Arc::new(DifferentialDrive::new(0.1, 0.5)),
///     powertrain: Box::new(CommandedPowertrain), slip: Box::new(NoSlipModel), dt: 0.05 };
/// let stepper = model.stepper(StepOptions::default()).unwrap();
/// let (n, len) = (100, stepper.state_len());
/// let mut states = vec![0.0; n * len];
/// for s in states.chunks_exact_mut(len) {
///     stepper.init(&StartState::at_rest(Pose::zeros()), &[], s).unwrap();
/// }
/// // Wheels at 10 + i and 10 - i rad/s: 1 m/s, turning more and more.
/// let commands: Vec<Input> = (0..n).map(|i| Input::new(10.0 + i as f64, 10.0 - i as f64, 0.0)).collect();
/// step_batch_parallel(stepper.as_ref(), &mut states, &commands, 16).unwrap();
/// // 1 m/s for one step of 0.05 s, whatever the turn (the heading moves after the step).
/// assert!((layout::pose(&states[..len]).x - 0.05).abs() < 1e-12);
/// ```
pub fn step_batch_parallel(
    stepper: &dyn Stepper,
    states: &mut [f64],
    commands: &[Input],
    chunk: usize,
) -> Result<(), MotionError> {
    let len = stepper.state_len();
    check_states(len, states.len(), commands.len())?;
    if len == 0 {
        return Ok(());
    }
    let chunk = chunk.max(1);
    states
        .par_chunks_mut(chunk * len)
        .zip(commands.par_chunks(chunk))
        .try_for_each(|(s, c)| stepper.step_batch(s, c))
}

/// Rolls every state of `states` through its `horizon` commands
/// (`commands[b * horizon..(b + 1) * horizon]` for state `b`), in parallel over chunks of
/// `chunk` states, writing what `outputs` asks for after every step; the states are left
/// after their last step. What a controller that samples many command sequences from the
/// robot's current state (Nav2's MPPI) calls once per cycle.
///
/// ```
/// use drive_models::batch::rollout_states;
/// use drive_traits::step::StepOutputs;
/// use drive_models::{ComposedModel, DifferentialDrive};
/// use drive_models::{powertrain::CommandedPowertrain, slip::NoSlipModel};
/// use drive_traits::step::StepOptions;
/// use drive_traits::{BodyVelocity, Input, MotionModel, Pose, StartState};
/// use std::sync::Arc;
/// let model = ComposedModel { label: "naive".into(), vehicle: Arc::new(DifferentialDrive::new(0.1, 0.5)),
///     powertrain: Box::new(CommandedPowertrain), slip: Box::new(NoSlipModel), dt: 0.05 };
/// let stepper = model.stepper(StepOptions::default()).unwrap();
/// let (n, horizon, len) = (3, 4, stepper.state_len());
/// let mut states = vec![0.0; n * len];
/// for s in states.chunks_exact_mut(len) {
///     stepper.init(&StartState::at_rest(Pose::zeros()), &[], s).unwrap();
/// }
/// let commands = vec![Input::new(10.0, 10.0, 0.0); n * horizon];
/// let mut velocities = vec![BodyVelocity::zeros(); n * horizon];
/// let outputs = StepOutputs { velocities: Some(&mut velocities), ..Default::default() };
/// rollout_states(stepper.as_ref(), &mut states, &commands, horizon, outputs, 1).unwrap();
/// assert_eq!(velocities[5], BodyVelocity::new(1.0, 0.0, 0.0));
/// ```
pub fn rollout_states(
    stepper: &dyn Stepper,
    states: &mut [f64],
    commands: &[Input],
    horizon: usize,
    outputs: StepOutputs<'_>,
    chunk: usize,
) -> Result<(), MotionError> {
    let len = stepper.state_len();
    let n = states.len().checked_div(len).unwrap_or(0);
    check_states(len, states.len(), n)?;
    let total = n * horizon;
    let shape = |given: usize| MotionError::BatchShape {
        sequences: n,
        horizon,
        expected: total,
        commands: commands.len(),
        poses: given,
    };
    if commands.len() != total {
        return Err(shape(total));
    }
    let StepOutputs {
        poses,
        velocities,
        covariances,
    } = outputs;
    for given in [
        poses.as_ref().map(|p| p.len()),
        velocities.as_ref().map(|v| v.len()),
        covariances.as_ref().map(|c| c.len()),
    ]
    .into_iter()
    .flatten()
    {
        if given != total {
            return Err(shape(given));
        }
    }
    if total == 0 {
        return Ok(());
    }
    let chunk = chunk.max(1);
    let chunks = n.div_ceil(chunk);
    let (poses, velocities, covariances) = (
        split(poses, chunk * horizon, chunks),
        split(velocities, chunk * horizon, chunks),
        split(covariances, chunk * horizon, chunks),
    );
    states
        .par_chunks_mut(chunk * len)
        .zip(commands.par_chunks(chunk * horizon))
        .zip(poses.into_par_iter())
        .zip(velocities.into_par_iter())
        .zip(covariances.into_par_iter())
        .try_for_each(|((((s, c), p), v), cv)| {
            let (mut p, mut v, mut cv) = (p, v, cv);
            for (b, (state, cmds)) in s.chunks_exact_mut(len).zip(c.chunks(horizon)).enumerate() {
                let rows = b * horizon..(b + 1) * horizon;
                let outputs = StepOutputs {
                    poses: p.as_deref_mut().map(|p| &mut p[rows.clone()]),
                    velocities: v.as_deref_mut().map(|v| &mut v[rows.clone()]),
                    covariances: cv.as_deref_mut().map(|c| &mut c[rows.clone()]),
                };
                stepper.rollout(state, cmds, outputs)?;
            }
            Ok(())
        })
}

/// `v` in chunks of `size` (`count` of them), or `count` times `None`.
fn split<T>(v: Option<&mut [T]>, size: usize, count: usize) -> Vec<Option<&mut [T]>> {
    match v {
        Some(v) => v.chunks_mut(size).map(Some).collect(),
        None => (0..count).map(|_| None).collect(),
    }
}
