//! Batched rollouts (the MPPI case) give exactly the poses of the single rollout.

use drive::eval::split_by_interval;
use drive::models::batch::predict_batch_parallel;
use drive::traits::{Input, MotionError, Pose};

#[test]
fn batch_and_parallel_batch_equal_single_rollouts_for_every_model() {
    let data = drive::bundled::husky().unwrap();
    let (_, eval) = split_by_interval(&data, 0.5).unwrap();
    let vehicle = data.robot.vehicle.as_ref();
    // 1001 sequences: not a multiple of any chunk size, commands perturbed per sequence.
    let (n, horizon) = (1001, 40);
    let mut starts = Vec::new();
    let mut commands = Vec::new();
    for i in 0..n {
        let w = eval.windows[(i * 7) % eval.len()];
        let mut s = w.start_state(vehicle);
        s.pose = Pose::new(
            i as f64 * 0.01,
            -(i as f64) * 0.02,
            (i as f64 * 0.37).sin() * 3.0,
        );
        starts.push(s);
        let e = (i as f64 * 0.618).fract() - 0.5;
        commands.extend(
            w.command
                .iter()
                .map(|u| u + Input::new(3.0 * e, -2.0 * e, 0.0)),
        );
    }
    // Every registered combination of slip learner (or baseline) and powertrain.
    for (name, model) in crate::common::husky_half_models() {
        let mut batch = vec![Pose::zeros(); n * horizon];
        model
            .predict_batch_into(&starts, &commands, horizon, &mut batch)
            .unwrap();
        let mut parallel = vec![Pose::zeros(); n * horizon];
        predict_batch_parallel(
            model.as_ref(),
            &starts,
            &commands,
            horizon,
            &mut parallel,
            64,
        )
        .unwrap();
        for i in 0..n {
            let one = model.predict(&starts[i], &commands[i * horizon..(i + 1) * horizon]);
            assert_eq!(
                &batch[i * horizon..(i + 1) * horizon],
                one.as_slice(),
                "{name}, sequence {i}"
            );
            assert_eq!(
                &parallel[i * horizon..(i + 1) * horizon],
                one.as_slice(),
                "{name}, sequence {i} (parallel)"
            );
        }
    }
}

#[test]
fn batch_shape_mismatch_is_an_error() {
    let model = crate::common::husky_half_model("slip-blr");
    let starts = vec![drive::traits::StartState::at_rest(Pose::zeros()); 3];
    let commands = vec![Input::zeros(); 3 * 40];
    let mut short = vec![Pose::zeros(); 3 * 40 - 1];
    let err = model
        .predict_batch_into(&starts, &commands, 40, &mut short)
        .unwrap_err();
    assert!(matches!(
        err,
        MotionError::BatchShape {
            sequences: 3,
            horizon: 40,
            expected: 120,
            commands: 120,
            poses: 119
        }
    ));
    let err = predict_batch_parallel(
        model,
        &starts,
        &commands[1..],
        40,
        &mut vec![Pose::zeros(); 120],
        2,
    )
    .unwrap_err();
    assert!(matches!(err, MotionError::BatchShape { .. }));
}
