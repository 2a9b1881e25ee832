//! Batched rollouts on all cores: many command sequences (the MPPI case) split across the
//! rayon thread pool, each chunk rolled out by the model's own batch kernel.

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
