//! The step API (`drive::traits::step`): stepping a fitted model one command at a time
//! equals its prediction, for every registered model on each built-in vehicle, with and
//! without its covariance, calibrated or not; the commands already sent act inside the
//! powertrain's dead time; batches stepped in parallel equal states stepped one by one.

use crate::common::ok;
use drive::eval::split_by_interval;
use drive::models::batch::{rollout_states, step_batch_parallel};
use drive::models::calibration::Uncertainty;
use drive::traits::step::StepOutputs;
use drive::traits::step::{layout, StepOptions};
use drive::traits::{
    BodyVelocity, Dataset, Input, MotionError, MotionModel, Pose, PoseCovariance, StartInfo,
    StartState,
};
use drive::Registries;

/// A simulated run of the robot preset `robot` (`drive simulate`), loaded.
fn simulated(robot: &str, seconds: u32) -> Dataset {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("run.csv");
    ok(&[
        "simulate",
        "--robot",
        robot,
        "--terrain",
        "gravel",
        "--duration",
        &seconds.to_string(),
        "--seed",
        "3",
        "--out",
        csv.to_str().unwrap(),
    ]);
    drive::data::read_dataset(&csv, None).unwrap()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * b.abs().max(1.0)
}

/// The starts and 2 s command sequences of `count` evaluation windows, each start with
/// what `start` measures, the pose moved off the origin.
fn cases(data: &Dataset, start: StartInfo, count: usize) -> Vec<(StartState, Vec<Input>)> {
    let (_, eval) = split_by_interval(data, 0.5).unwrap();
    let vehicle = data.robot.vehicle.as_ref();
    (0..count)
        .map(|i| {
            let w = eval.windows[(i * 17) % eval.len()];
            let mut s = w.start_state_with(vehicle, start);
            s.pose = Pose::new(1.0 + i as f64, -2.0, 0.3 * i as f64 - 1.0);
            (s, w.command.clone())
        })
        .collect()
}

/// Stepping `model` equals predicting it on every case, row by row, with and without the
/// covariance; the built-in models step natively (no replay).
fn steps_as_it_predicts(name: &str, model: &dyn MotionModel, cases: &[(StartState, Vec<Input>)]) {
    for covariance in [false, true] {
        let stepper = match model.stepper(StepOptions::with_covariance(covariance)) {
            Ok(s) => s,
            Err(MotionError::NoUncertainty { .. }) if covariance => {
                // Only for a model whose prediction has no covariance either.
                assert!(
                    model
                        .predict_with_covariance_into(
                            &cases[0].0,
                            &cases[0].1,
                            &mut Vec::new(),
                            &mut Vec::new()
                        )
                        .is_err(),
                    "{name}: predicts a covariance but refuses to step it"
                );
                continue;
            }
            Err(e) => panic!("{name}: {e}"),
        };
        assert!(!stepper.is_replay(), "{name} is stepped by replay");
        assert_eq!(stepper.with_covariance(), covariance);
        let mut state = vec![0.0; stepper.state_len()];
        for (case, (start, commands)) in cases.iter().enumerate() {
            let (mut poses, mut covariances) = (Vec::new(), Vec::new());
            if covariance {
                model
                    .predict_with_covariance_into(start, commands, &mut poses, &mut covariances)
                    .unwrap();
            } else {
                model.predict_into(start, commands, &mut poses);
            }
            stepper.init(start, &[], &mut state).unwrap();
            for (k, u) in commands.iter().enumerate() {
                let (p, q) = (layout::pose(&state), poses[k]);
                assert!(
                    (0..3).all(|i| close(p[i], q[i])),
                    "{name}, covariance {covariance}, case {case}, step {k}: stepped {p:?}, predicted {q:?}"
                );
                assert_eq!(layout::steps(&state), k);
                if covariance {
                    let (c, d) = (layout::covariance(&state), covariances[k]);
                    assert!(
                        c.iter().zip(d.iter()).all(|(a, b)| close(*a, *b)),
                        "{name}, case {case}, step {k}: stepped covariance {c}, predicted {d}"
                    );
                }
                stepper.step(&mut state, u).unwrap();
            }
        }
    }
}

/// [`steps_as_it_predicts`] for every registered model fitted with each of `uncertainties`
/// on the first `train_share` of `data`'s intervals; a calibration asked of a model with a
/// covariance is made (so that its stepping is the calibrated one).
fn every_model_steps_as_it_predicts(
    data: &Dataset,
    uncertainties: &[Uncertainty],
    train_share: f64,
) {
    let (train, _) = split_by_interval(data, train_share).unwrap();
    // The richest start: slip-ipem's lagging velocity and yaw disturbance both read it.
    let start = StartInfo::EncodersImuLocalization;
    let cases = cases(data, start, 6);
    for spec in Registries::builtin().models().all() {
        for &uncertainty in uncertainties {
            let spec = spec.clone().with_uncertainty(uncertainty, start);
            let name = format!(
                "{} ({}, {})",
                spec.canonical(),
                uncertainty.as_str(),
                data.robot.name
            );
            let model = spec.fit(&train).unwrap_or_else(|e| panic!("{name}: {e}"));
            if uncertainty == Uncertainty::Calibrated {
                let (start, commands) = &cases[0];
                let has_covariance = model
                    .predict_with_covariance_into(start, commands, &mut Vec::new(), &mut Vec::new())
                    .is_ok();
                assert!(
                    !has_covariance || model.typetag_name() == "calibrated",
                    "{name}: not calibrated ({})",
                    model.typetag_name()
                );
            }
            steps_as_it_predicts(&name, model.as_ref(), &cases);
        }
    }
}

#[test]
fn every_model_steps_as_it_predicts_on_a_skid_steer() {
    // Fitted on the first quarter of the intervals (50 of them): enough for every fit and
    // calibration, half the fitting time of the training half.
    let data = drive::bundled::husky().unwrap();
    every_model_steps_as_it_predicts(&data, &[Uncertainty::Paper, Uncertainty::Calibrated], 0.25);
}

#[test]
fn every_model_steps_as_it_predicts_on_a_car_and_an_omnidirectional_base() {
    for robot in ["autorally", "ridgeback"] {
        let data = simulated(robot, 150);
        every_model_steps_as_it_predicts(
            &data,
            &[Uncertainty::Paper, Uncertainty::Calibrated],
            0.5,
        );
    }
}

#[test]
fn the_commands_already_sent_act_inside_the_dead_time() {
    let data = drive::bundled::husky().unwrap();
    let (_, eval) = split_by_interval(&data, 0.5).unwrap();
    for name in [
        "powertrain",
        "slip-blr",
        "slip-blr+rate-limited",
        "acc-blr+fopdt",
    ] {
        let model = crate::common::husky_half_model(name);
        let stepper = model.stepper(StepOptions::default()).unwrap();
        let powertrain = model.powertrain().unwrap();
        let w = eval.windows[5];
        let vehicle = data.robot.vehicle.as_ref();
        // A run of 30 commands: the powertrain's inputs from its start through all of them.
        let sent: Vec<Input> = eval.windows[4].command[10..].to_vec();
        let then: Vec<Input> = w.command.clone();
        let all: Vec<Input> = sent.iter().chain(&then).copied().collect();
        let inputs = powertrain.predict(&eval.windows[4].measured[10], &all);
        // Stepped from the input reached at the joint, with what was sent before it, the
        // powertrain goes on as the whole run's prediction (whose dead time lies within
        // the commands sent).
        let joint = inputs[sent.len()];
        let mut state = vec![0.0; stepper.state_len()];
        let start = StartState::measured(Pose::zeros(), joint, vehicle);
        stepper.init(&start, &sent, &mut state).unwrap();
        let mut without = vec![0.0; stepper.state_len()];
        stepper.init(&start, &[], &mut without).unwrap();
        let mut differs = false;
        for (k, u) in then.iter().enumerate().take(then.len() - 1) {
            stepper.step(&mut state, u).unwrap();
            stepper.step(&mut without, u).unwrap();
            differs |= layout::pose(&state) != layout::pose(&without);
            // Without slip, the velocity over each step is the vehicle's (eq. 4) at the input
            // the whole run's powertrain reaches then.
            if name == "powertrain" {
                let v = vehicle.body_velocity(&inputs[sent.len() + k]);
                let stepped = layout::body_velocity(&state);
                assert!(
                    (stepped - v).norm() < 1e-12,
                    "{name}, step {k}: {stepped} against {v}"
                );
            }
        }
        assert!(differs, "{name}: the commands sent changed nothing");
        // A history of commands equal to the measured inputs is no history at all.
        let held = vec![start.input; 40];
        let mut a = vec![0.0; stepper.state_len()];
        let mut b = vec![0.0; stepper.state_len()];
        stepper.init(&start, &held, &mut a).unwrap();
        stepper.init(&start, &[], &mut b).unwrap();
        for u in &then {
            stepper.step(&mut a, u).unwrap();
            stepper.step(&mut b, u).unwrap();
        }
        // (The held input is within the limits: a history is saturated as commands are.)
        assert_eq!(layout::pose(&a), layout::pose(&b), "{name}");
    }
}

#[test]
fn batches_stepped_in_parallel_equal_states_stepped_one_by_one() {
    let data = drive::bundled::husky().unwrap();
    let cases = cases(&data, StartInfo::EncodersImuLocalization, 37);
    for name in ["slip-blr", "slip-ipem"] {
        let model = crate::common::husky_half_model(name);
        let stepper = model.stepper(StepOptions::with_covariance(true)).unwrap();
        let len = stepper.state_len();
        let n = cases.len();
        let horizon = 39;
        let mut states = vec![0.0; n * len];
        for (s, (start, _)) in states.chunks_exact_mut(len).zip(&cases) {
            stepper.init(start, &[], s).unwrap();
        }
        let mut one_by_one = states.clone();
        let mut rolled = states.clone();
        for t in 0..horizon {
            let commands: Vec<Input> = cases.iter().map(|(_, c)| c[t]).collect();
            step_batch_parallel(stepper.as_ref(), &mut states, &commands, 5).unwrap();
            for (s, u) in one_by_one.chunks_exact_mut(len).zip(&commands) {
                stepper.step(s, u).unwrap();
            }
        }
        assert_eq!(states, one_by_one, "{name}");
        let commands: Vec<Input> = cases
            .iter()
            .flat_map(|(_, c)| c[..horizon].to_vec())
            .collect();
        let mut poses = vec![Pose::zeros(); n * horizon];
        let mut velocities = vec![BodyVelocity::zeros(); n * horizon];
        let mut covariances = vec![PoseCovariance::zeros(); n * horizon];
        rollout_states(
            stepper.as_ref(),
            &mut rolled,
            &commands,
            horizon,
            StepOutputs {
                poses: Some(&mut poses),
                velocities: Some(&mut velocities),
                covariances: Some(&mut covariances),
            },
            4,
        )
        .unwrap();
        assert_eq!(rolled, states, "{name}");
        // The rollout's rows are the prediction's, one step on.
        for (b, (start, c)) in cases.iter().enumerate() {
            let (mut p, mut cv) = (Vec::new(), Vec::new());
            model
                .predict_with_covariance_into(start, &c[..=horizon], &mut p, &mut cv)
                .unwrap();
            for t in 0..horizon {
                let i = b * horizon + t;
                assert!((poses[i] - p[t + 1]).norm() < 1e-12, "{name} {b} {t}");
                assert!(
                    (covariances[i] - cv[t + 1]).norm() < 1e-12,
                    "{name} {b} {t}"
                );
            }
        }
        // A wrong buffer is an error, not a panic.
        assert!(
            step_batch_parallel(stepper.as_ref(), &mut states[1..], &commands[..n], 5).is_err()
        );
        assert!(stepper
            .step(&mut vec![0.0; len - 1], &Input::zeros())
            .is_err());
    }
}

#[test]
fn a_state_changed_by_hand_never_panics() {
    for name in ["slip-blr", "slip-ipem", "acc-blr", "slip-blr+rate-limited"] {
        let model = crate::common::husky_half_model(name);
        let stepper = model.stepper(StepOptions::with_covariance(true)).unwrap();
        for garbage in [f64::NAN, -1.0, 1e300, f64::INFINITY, 7.5] {
            let mut state = vec![garbage; stepper.state_len()];
            for _ in 0..3 {
                stepper
                    .step(&mut state, &Input::new(1.0, 2.0, 0.0))
                    .unwrap();
            }
        }
    }
}

#[test]
fn rollouts_in_pieces_equal_steps_one_by_one_with_a_history() {
    // A rollout runs each part over the whole sequence (the powertrain's delayed commands
    // read from the sequence itself, the ring of commands rebuilt at its end): pieces
    // shorter and longer than the dead time, from a start with commands already sent, leave
    // the same states as steps one by one, number for number.
    let data = drive::bundled::husky().unwrap();
    let (_, eval) = split_by_interval(&data, 0.5).unwrap();
    let vehicle = data.robot.vehicle.as_ref();
    for name in [
        "slip-blr",
        "slip-ipem",
        "slip-blr+rate-limited",
        "acc-blr+fopdt",
        "naive",
    ] {
        let model = crate::common::husky_half_model(name);
        let stepper = model
            .stepper(StepOptions::with_covariance(name != "naive"))
            .unwrap();
        let len = stepper.state_len();
        let w = eval.windows[9];
        let sent: Vec<Input> = eval.windows[8].command[25..].to_vec();
        let start = w.start_state_with(vehicle, StartInfo::EncodersImuLocalization);
        let (mut rolled, mut stepped) = (vec![0.0; len], vec![0.0; len]);
        stepper.init(&start, &sent, &mut rolled).unwrap();
        stepper.init(&start, &sent, &mut stepped).unwrap();
        let mut at = 0;
        for piece in [1, 2, 3, 20, 5, 9] {
            let commands = &w.command[at..at + piece];
            at += piece;
            let mut poses = vec![Pose::zeros(); piece];
            stepper
                .rollout(
                    &mut rolled,
                    commands,
                    StepOutputs {
                        poses: Some(&mut poses),
                        ..Default::default()
                    },
                )
                .unwrap();
            for (k, u) in commands.iter().enumerate() {
                stepper.step(&mut stepped, u).unwrap();
                assert_eq!(
                    poses[k],
                    layout::pose(&stepped),
                    "{name}, piece of {piece}, step {k}"
                );
            }
            assert_eq!(rolled, stepped, "{name}, after a piece of {piece}");
        }
    }
}
