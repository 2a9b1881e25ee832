//! MPPI and the tracker in closed loop on a plant that is exactly the model: what a
//! perfect model buys.

use drive_control::{ControlSetup, InputMap, Mppi, Observation, PathShape, Tracker, TrackerConfig};
use drive_models::powertrain::CommandedPowertrain;
use drive_models::slip::NoSlipModel;
use drive_models::ComposedModel;
use drive_traits::{Input, MotionModel, Pose, StartInfo, StartState};
use std::sync::Arc;

fn husky() -> drive_traits::robot::RobotSpec {
    drive_traits::robot::builtin_robots()
        .get("husky")
        .unwrap()
        .part()
        .as_ref()
        .clone()
}

/// The naive model of `robot`: eq. 4 on the commands.
fn naive(robot: &drive_traits::robot::RobotSpec) -> Arc<dyn MotionModel> {
    Arc::new(ComposedModel {
        label: "naive".into(),
        vehicle: robot.vehicle.clone(),
        powertrain: Box::new(CommandedPowertrain),
        slip: Box::new(NoSlipModel),
        dt: 0.05,
    })
}

/// A tracker of the Husky's naive model on `path` at `speed` m/s, its MPPI with `samples`
/// candidates, starting from the encoders.
fn naive_tracker(path: drive_control::ReferencePath, speed: f64, samples: usize) -> Tracker {
    let robot = husky();
    let setup = ControlSetup {
        model: naive(&robot),
        robot: robot.clone(),
        to_vehicle: InputMap::identity(),
        speed,
        seed: 0,
    };
    let config = TrackerConfig {
        start: StartInfo::Encoders,
        ..TrackerConfig::new(speed)
    };
    Tracker::new(
        &Mppi {
            samples,
            ..Mppi::default()
        },
        &setup,
        path,
        config,
        robot.vehicle.clone(),
    )
    .unwrap()
}

/// Runs the tracker on a plant that moves exactly as the naive model predicts; returns
/// the poses and whether it finished.
fn follow(shape: PathShape, speed: f64, seconds: f64) -> (Vec<Pose>, bool, f64) {
    let robot = husky();
    let model = naive(&robot);
    let setup = ControlSetup {
        model: model.clone(),
        robot: robot.clone(),
        to_vehicle: InputMap::identity(),
        speed,
        seed: 0,
    };
    let path = shape.at_scale(2.0).unwrap();
    let config = TrackerConfig {
        start: StartInfo::Encoders,
        ..TrackerConfig::new(speed)
    };
    let mut tracker = Tracker::new(
        &Mppi::default(),
        &setup,
        path.clone(),
        config,
        robot.vehicle.clone(),
    )
    .unwrap();
    let mut pose = Pose::zeros();
    let mut input = Input::zeros();
    let mut poses = vec![pose];
    let mut worst: f64 = 0.0;
    let steps = (seconds * 20.0) as usize;
    for k in 0..steps {
        let tick = tracker
            .tick(&Observation {
                t: k as f64 * 0.05,
                input,
                pose: Some(pose),
                imu_yaw_rate: None,
                pose_time: None,
            })
            .unwrap();
        if tick.done {
            return (poses, true, worst);
        }
        let start = StartState::measured(pose, input, robot.vehicle.as_ref());
        let p = model.predict(&start, &[tick.command, tick.command]);
        pose = p[1];
        input = tick.command;
        poses.push(pose);
        let near = path.project(
            [pose.x, pose.y],
            tracker.progress() - 1.0,
            tracker.progress() + 1.0,
        );
        worst = worst.max(near.cross_track.abs());
    }
    (poses, false, worst)
}

#[test]
fn a_perfect_model_follows_every_preset_closely() {
    // The shapes are independent: followed side by side, checked in their order.
    let followed: Vec<_> = std::thread::scope(|s| {
        let runs: Vec<_> = PathShape::ALL
            .iter()
            .map(|&shape| s.spawn(move || (shape, follow(shape, 0.5, 120.0))))
            .collect();
        runs.into_iter()
            .map(|run| run.join().expect("a shape's run panicked"))
            .collect()
    });
    for (shape, (poses, done, worst)) in followed {
        let last = poses.last().unwrap();
        eprintln!(
            "{shape:?}: done {done}, {} ticks, worst cross-track {worst:.3} m, end {:?}",
            poses.len(),
            last.as_slice()
        );
        assert!(done, "{shape:?} not finished");
        // Sharp zigzag corners are cut at most by a few tens of centimetres at 0.5 m/s.
        let bound = if shape == PathShape::Zigzag {
            0.35
        } else {
            0.1
        };
        assert!(worst < bound, "{shape:?}: worst cross-track {worst}");
    }
}

#[test]
fn a_robot_that_does_not_move_never_reaches_the_end_of_a_path_through_its_start() {
    // A small figure-eight and a path out and back both pass the start again: where the
    // robot is on them is where it continues from, never the far part that also passes by.
    let back = drive_control::ReferencePath::new("back", vec![[0.0, 0.0], [2.0, 0.0], [0.0, 0.0]])
        .unwrap();
    for path in [PathShape::FigureEight.at_scale(0.5).unwrap(), back] {
        let mut tracker = naive_tracker(path.clone(), 1.0, 32);
        for k in 0..100 {
            let tick = tracker
                .tick(&Observation {
                    t: k as f64 * 0.05,
                    input: Input::zeros(),
                    pose: Some(Pose::new(0.0, if k % 2 == 0 { 3e-3 } else { -3e-3 }, 0.0)),
                    imu_yaw_rate: None,
                    pose_time: None,
                })
                .unwrap();
            assert!(!tick.done, "{}: done at tick {k}", path.name());
            assert!(
                tick.progress_m < 0.1,
                "{}: progress {} at tick {k}",
                path.name(),
                tick.progress_m
            );
        }
    }
}

/// A fix stamped a second or more after the tick is on another clock (it was clamped to
/// the tick's time without a word): refused, named; a few milliseconds ahead is taken.
#[test]
fn a_fix_stamped_after_the_tick_by_a_second_is_refused() {
    let path = PathShape::Circle.at_scale(2.0).unwrap();
    let mut tracker = naive_tracker(path, 0.5, 32);
    let at = |pose_time: f64| Observation {
        t: 10.0,
        input: Input::zeros(),
        pose: Some(Pose::zeros()),
        imu_yaw_rate: None,
        pose_time: Some(pose_time),
    };
    assert!(tracker.tick(&at(10.004)).is_ok());
    let e = tracker.tick(&at(110.0)).unwrap_err();
    assert!(
        e.to_string()
            .contains("stamped 110 s, 100 s after the tick's t = 10"),
        "{e}"
    );
}

/// The first ten commands of MPPI with the run seed `seed`, on a plant that never moves.
fn first_commands(seed: u64) -> Vec<Input> {
    let robot = husky();
    let setup = ControlSetup {
        model: naive(&robot),
        robot: robot.clone(),
        to_vehicle: InputMap::identity(),
        speed: 0.5,
        seed,
    };
    let config = TrackerConfig {
        start: StartInfo::Encoders,
        ..TrackerConfig::new(0.5)
    };
    let path = PathShape::Circle.at_scale(2.0).unwrap();
    let mut tracker = Tracker::new(
        &Mppi::default(),
        &setup,
        path,
        config,
        robot.vehicle.clone(),
    )
    .unwrap();
    (0..10)
        .map(|k| {
            tracker
                .tick(&Observation {
                    t: k as f64 * 0.05,
                    input: Input::zeros(),
                    pose: Some(Pose::zeros()),
                    imu_yaw_rate: None,
                    pose_time: None,
                })
                .unwrap()
                .command
        })
        .collect()
}

#[test]
fn the_run_seed_varies_the_sampling_and_the_same_seed_repeats_it() {
    // The same run seed: the same commands, bit for bit; another: other samples, other
    // commands (what `drive track --seeds` varies besides the plant's noise).
    assert_eq!(first_commands(3), first_commands(3));
    assert_ne!(first_commands(3), first_commands(4));
    assert_ne!(first_commands(0), first_commands(1));
}

/// The naive model, with a pose covariance that grows with how hard it is asked to turn:
/// a model that is unsure of its turns.
#[derive(Debug, serde::Serialize, serde::Deserialize)]
struct UnsureOfTurns {
    #[serde(skip)]
    naive: Option<Arc<dyn MotionModel>>,
}

#[typetag::serde(name = "unsure-of-turns")]
impl MotionModel for UnsureOfTurns {
    fn name(&self) -> String {
        "unsure-of-turns".into()
    }
    fn dt(&self) -> f64 {
        0.05
    }
    fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>) {
        self.naive
            .as_ref()
            .unwrap()
            .predict_into(start, commands, poses)
    }
    fn predict_with_covariance_into(
        &self,
        start: &StartState,
        commands: &[Input],
        poses: &mut Vec<Pose>,
        covariances: &mut Vec<drive_traits::PoseCovariance>,
    ) -> Result<(), drive_traits::MotionError> {
        self.predict_into(start, commands, poses);
        covariances.clear();
        let mut c = drive_traits::PoseCovariance::zeros();
        for u in commands {
            covariances.push(c);
            // Each step's variance: the wheel speed difference's square, in m^2 and rad^2.
            let turn = (u.y - u.x).powi(2);
            c += drive_traits::PoseCovariance::from_diagonal(&drive_traits::Pose::new(
                0.01 * turn,
                0.01 * turn,
                0.01 * turn,
            ));
        }
        Ok(())
    }
}

/// The first `ticks` commands of MPPI weighing the predicted variance by `weight`, with
/// `model`, on a plant that follows the naive model exactly, along a circle; and the
/// tracker's notes.
fn commands_on_a_circle(
    model: Arc<dyn MotionModel>,
    weight: f64,
    ticks: usize,
) -> (Vec<Input>, Vec<String>) {
    let robot = husky();
    let plant = naive(&robot);
    let setup = ControlSetup {
        model,
        robot: robot.clone(),
        to_vehicle: InputMap::identity(),
        speed: 0.5,
        seed: 3,
    };
    let config = TrackerConfig {
        start: StartInfo::Encoders,
        ..TrackerConfig::new(0.5)
    };
    let mppi = Mppi {
        samples: 256,
        uncertainty_weight: weight,
        ..Mppi::default()
    };
    let path = PathShape::Circle.at_scale(2.0).unwrap();
    let mut tracker = Tracker::new(&mppi, &setup, path, config, robot.vehicle.clone()).unwrap();
    let (mut pose, mut input, mut sent) = (Pose::zeros(), Input::zeros(), Vec::new());
    for k in 0..ticks {
        let tick = tracker
            .tick(&Observation {
                t: k as f64 * 0.05,
                input,
                pose: Some(pose),
                imu_yaw_rate: None,
                pose_time: None,
            })
            .unwrap();
        let start = StartState::measured(pose, input, robot.vehicle.as_ref());
        pose = plant.predict(&start, &[tick.command, tick.command])[1];
        input = tick.command;
        sent.push(tick.command);
    }
    (sent, tracker.notes())
}

#[test]
fn the_predicted_variance_steers_away_from_what_the_model_is_unsure_of() {
    let robot = husky();
    let unsure: Arc<dyn MotionModel> = Arc::new(UnsureOfTurns {
        naive: Some(naive(&robot)),
    });
    let turning = |commands: &[Input]| -> f64 {
        commands.iter().map(|u| (u.y - u.x).abs()).sum::<f64>() / commands.len() as f64
    };
    // Scored on its mean poses, the unsure model drives as the naive one it predicts as.
    let (plain, notes) = commands_on_a_circle(Arc::clone(&unsure), 0.0, 60);
    assert!(notes.is_empty(), "{notes:?}");
    assert_eq!(plain, commands_on_a_circle(naive(&robot), 0.0, 60).0);
    // With its variance weighed, it turns less: the turns it is unsure of cost more.
    let (careful, notes) = commands_on_a_circle(Arc::clone(&unsure), 1.0, 60);
    assert!(notes.is_empty(), "{notes:?}");
    let (a, b) = (turning(&plain), turning(&careful));
    assert!(
        b < 0.9 * a,
        "mean wheel speed difference {a} without, {b} with"
    );
    // A model without a covariance: the same commands whatever the weight, and a note.
    let (without, notes) = commands_on_a_circle(naive(&robot), 1.0, 60);
    assert_eq!(without, plain);
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(notes[0].contains("no predictive covariance"), "{notes:?}");
}

/// The naive model, recording what was observed in every start it is given.
#[derive(Debug, Default, serde::Serialize, serde::Deserialize)]
struct RecordsStarts {
    #[serde(skip)]
    naive: Option<Arc<dyn MotionModel>>,
    #[serde(skip)]
    seen: std::sync::Mutex<Vec<Option<drive_traits::ObservedMotion>>>,
}

#[typetag::serde(name = "records-starts")]
impl MotionModel for RecordsStarts {
    fn name(&self) -> String {
        "records-starts".into()
    }
    fn dt(&self) -> f64 {
        0.05
    }
    fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>) {
        self.seen.lock().unwrap().push(start.observed);
        self.naive
            .as_ref()
            .unwrap()
            .predict_into(start, commands, poses)
    }
}

#[test]
fn the_motion_measured_now_is_handed_to_the_rollouts_after_the_history() {
    use drive_control::{ControlState, Controller, MppiController};
    use drive_traits::ObservedMotion;
    let robot = husky();
    let model = Arc::new(RecordsStarts {
        naive: Some(naive(&robot)),
        ..RecordsStarts::default()
    });
    let setup = ControlSetup {
        model: model.clone(),
        robot: robot.clone(),
        to_vehicle: InputMap::identity(),
        speed: 0.5,
        seed: 1,
    };
    let reference: Vec<Pose> = (1..=40)
        .map(|k| Pose::new(0.025 * k as f64, 0.0, 0.0))
        .collect();
    let past_commands = vec![Input::new(1.0, 1.2, 0.0); 12];
    let past = StartState::at_rest(Pose::zeros()).with_yaw_rate(0.0);
    let now = StartState::at_rest(Pose::new(0.3, 0.0, 0.1))
        .with_yaw_rate(0.25)
        .with_velocity([0.5, 0.01]);
    let observed = |observe_now: bool, history: bool| {
        let mppi = Mppi {
            samples: 8,
            observe_now,
            ..Mppi::default()
        };
        let mut controller = MppiController::new(mppi, &setup).unwrap();
        model.seen.lock().unwrap().clear();
        let state = ControlState {
            past: history.then_some((past, past_commands.as_slice())),
            ..ControlState::at(now)
        };
        controller.command(&state, &reference).unwrap();
        let seen = std::mem::take(&mut *model.seen.lock().unwrap());
        assert_eq!(seen.len(), 8, "one rollout per candidate");
        assert!(seen.windows(2).all(|w| w[0] == w[1]));
        seen[0]
    };
    // After the 12 commands replayed, the yaw rate and velocity measured now.
    assert_eq!(
        observed(true, true),
        Some(ObservedMotion {
            step: 12,
            yaw_rate: Some(0.25),
            velocity: Some([0.5, 0.01])
        })
    );
    // Not asked, or no history (the rollouts start now, from what is measured now).
    assert_eq!(observed(false, true), None);
    assert_eq!(observed(true, false), None);
    assert!(Mppi::default().observe_now);
}

/// The tracker's estimate of a robot driving straight at 1 m/s, whose localization publishes
/// every fourth tick a fix measured 0.3 s before, and again (the same fix) at the ticks in
/// between once in two: carried forward from when each fix was measured (its stamp), the
/// estimate is where the robot is; taken as measured when it arrives, 0.3 m behind, and the
/// fix published again reads as the robot standing still.
#[test]
fn a_late_fix_is_carried_forward_from_when_it_was_measured() {
    let path = PathShape::Line.at_scale(20.0).unwrap();
    let worst_error = |stamped: bool| -> f64 {
        let mut tracker = naive_tracker(path.clone(), 0.5, 64);
        let (latency, period) = (0.3, 4);
        let mut worst: f64 = 0.0;
        let mut last_fix = None;
        for k in 0..60 {
            let t = k as f64 * 0.05;
            if k % period == 0 {
                let measured = (t - latency).max(0.0);
                last_fix = Some((measured, Pose::new(measured, 0.0, 0.0)));
            }
            // Published at its update, and again every other tick in between.
            let fix = last_fix.filter(|_| k % 2 == 0);
            let tick = tracker
                .tick(&Observation {
                    t,
                    input: Input::zeros(),
                    pose: fix.map(|f| f.1),
                    imu_yaw_rate: Some(0.0),
                    pose_time: fix.filter(|_| stamped).map(|f| f.0),
                })
                .unwrap();
            // Once the first fixes have given a velocity.
            if t >= 1.0 {
                worst = worst.max((tick.estimate.x - t).abs());
            }
        }
        worst
    };
    let (stamped, unstamped) = (worst_error(true), worst_error(false));
    assert!(stamped < 0.02, "stamped: {stamped} m off");
    assert!(unstamped > 0.25, "unstamped: {unstamped} m off");
}

/// The seconds a tracker of the naive model takes along a 4 m line at 0.4 m/s on a plant
/// that keeps `kept` of every commanded body velocity, with the reference's timing
/// `schedule_s`; `None` when it does not reach the end in a minute.
fn line_time(kept: f64, schedule_s: Option<f64>) -> Option<f64> {
    let robot = husky();
    let model = naive(&robot);
    let speed = 0.4;
    let setup = ControlSetup {
        model: model.clone(),
        robot: robot.clone(),
        to_vehicle: InputMap::identity(),
        speed,
        seed: 0,
    };
    let path = drive_control::ReferencePath::new("line", vec![[0.0, 0.0], [4.0, 0.0]]).unwrap();
    let config = TrackerConfig {
        start: StartInfo::Encoders,
        schedule_s,
        ..TrackerConfig::new(speed)
    };
    let mut tracker = Tracker::new(
        &Mppi {
            samples: 256,
            ..Mppi::default()
        },
        &setup,
        path,
        config,
        robot.vehicle.clone(),
    )
    .unwrap();
    let (mut pose, mut input) = (Pose::zeros(), Input::zeros());
    for k in 0..1200 {
        let t = k as f64 * 0.05;
        let tick = tracker
            .tick(&Observation {
                t,
                input,
                pose: Some(pose),
                imu_yaw_rate: None,
                pose_time: None,
            })
            .unwrap();
        if tick.done {
            return Some(t);
        }
        // The wheels turn as commanded; the body keeps `kept` of it (a slip the naive
        // model does not know).
        let start = StartState::measured(pose, input * kept, robot.vehicle.as_ref());
        pose = model.predict(&start, &[tick.command * kept, tick.command * kept])[1];
        input = tick.command;
    }
    None
}

#[test]
fn a_schedule_holds_a_model_that_misjudges_the_speed_to_the_asked_speed() {
    // The model takes the wheels' speed for the body's; the ground keeps 60% of it.
    let (free, held) = std::thread::scope(|s| {
        let free = s.spawn(|| line_time(0.6, None));
        let held = s.spawn(|| line_time(0.6, Some(1.0)));
        (free.join().unwrap(), held.join().unwrap())
    });
    let (free, held) = (
        free.expect("free run finished"),
        held.expect("held run finished"),
    );
    eprintln!("4 m at 0.4 m/s asked, 60% kept: {free:.2} s free, {held:.2} s on a schedule");
    // At the asked speed the 4 m (less the goal tolerance) take 9.5 s after the start's
    // ramp; the free run drives at about 60% of it.
    assert!(free > 13.0, "free run {free} s");
    assert!(held < 12.0, "scheduled run {held} s");
    // A perfect model is not slowed or hurried by the schedule.
    let exact = [
        line_time(1.0, None).unwrap(),
        line_time(1.0, Some(1.0)).unwrap(),
    ];
    assert!((exact[0] - exact[1]).abs() < 1.0, "{exact:?}");
}
