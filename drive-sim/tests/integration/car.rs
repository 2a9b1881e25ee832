//! The simulated car: characterization, the schedule's limits, the plant registry, and what
//! the powertrain learners recover from it.

use drive_models::powertrain::RateLimited;
use drive_models::vehicles::Ackermann;
use drive_samplers::{autorally, RobotSpec, RunnerState, StopReason};
use drive_sim::{builtin_plants, simulate, CarParams, Simulation, Terrain};
use drive_traits::{PowertrainLearner, WindowSet};

fn run(robot: RobotSpec, terrain: &str, intervals: usize, seed: u64) -> Simulation {
    let factory = crate::uniform(robot.clone(), seed);
    let config = crate::config(robot, terrain, seed, intervals, "car");
    simulate(config, &builtin_plants(), factory, None).unwrap()
}

/// A 1/10-scale car of other proportions (the F1TENTH platform's wheelbase and steering
/// limit), 3 m/s, given by its TOML file.
fn small_car() -> RobotSpec {
    RobotSpec::from_toml(
        "small.toml",
        "name = 'small'\nmass_kg = 3.5\nmax_speed = 3.0\ninput_rate_limits = [3.0, 6.0]\n\
         max_lateral_acceleration = 2.5\n[vehicle]\ntype = 'ackermann'\nwheelbase = 0.33\n\
         max_steering = 0.42\n",
    )
    .unwrap()
}

#[test]
fn characterization_recovers_the_speed_and_steering_limits_within_five_percent() {
    for (robot, speed, steering) in [(autorally(), 5.0, 0.3665191429), (small_car(), 3.0, 0.42)] {
        for terrain in ["tile", "gravel", "snow"] {
            let sim = run(robot.clone(), terrain, 1, 3);
            let c = sim.characterization.expect("a characterization");
            let within = |found: f64, truth: f64| (found - truth).abs() <= 0.05 * truth;
            let (lo, hi) = (c.space.min, c.space.max);
            assert!(
                within(hi.x, speed) && within(-lo.x, speed),
                "{} on {terrain}: speed [{}, {}]",
                robot.name,
                lo.x,
                hi.x
            );
            assert!(
                within(hi.y, steering) && within(-lo.y, steering),
                "{} on {terrain}: steering [{}, {}]",
                robot.name,
                lo.y,
                hi.y
            );
            // The effective wheelbase from the turning probes: the geometric one, longer
            // by the understeer of a slow circle.
            let l = c.geometry("wheelbase").unwrap();
            let geometric = robot.vehicle.geometry()[0].1;
            assert!(
                l > 0.97 * geometric && l < 1.3 * geometric,
                "{terrain}: {l}"
            );
            assert_eq!(sim.stop, RunnerState::Done(StopReason::Intervals));
        }
    }
}

#[test]
fn the_schedule_keeps_the_rate_and_lateral_acceleration_limits() {
    let robot = autorally();
    let rates = robot.input_rate_limits.unwrap();
    let limit = robot.max_lateral_acceleration.unwrap();
    let sim = run(robot.clone(), "tile", 20, 5);
    // Every command sent while driving the intervals (after the characterization's probes).
    let start = sim
        .states
        .iter()
        .find(|(_, s)| matches!(s, RunnerState::Driving { .. }))
        .unwrap()
        .0;
    let end = sim
        .states
        .iter()
        .find(|(_, s)| matches!(s, RunnerState::Done(_)))
        .unwrap()
        .0;
    // From rest when the driving starts (the probes' last command is dropped, not ramped),
    // to the stop.
    let first = (start * robot.rate_hz).round() as usize + 1;
    let last = (end * robot.rate_hz).round() as usize;
    let commands = &sim.commands[first..last];
    assert!(commands.len() >= 20 * 120 - 1, "{}", commands.len());
    let dt = 1.0 / robot.rate_hz;
    for i in 0..2 {
        assert!(
            commands[0][i].abs() <= rates[i] * dt + 1e-9,
            "{:?}",
            commands[0]
        );
    }
    for pair in commands.windows(2) {
        for i in 0..2 {
            assert!(
                (pair[1][i] - pair[0][i]).abs() <= rates[i] * dt + 1e-9,
                "axis {i}: {pair:?}"
            );
        }
    }
    for u in commands {
        let f = robot.vehicle.body_velocity(u);
        assert!((f.x * f.z).abs() <= limit + 1e-6, "{u:?}: {}", f.x * f.z);
    }
}

#[test]
fn the_rate_limited_powertrain_recovers_the_loaded_servo() {
    let robot = autorally();
    let truth = CarParams::from_spec(&robot, &Ackermann::new(0.57, 0.3665191429));
    for seed in 1..=3 {
        let sim = run(robot.clone(), "gravel", 44, seed);
        let set = WindowSet {
            robot: &sim.dataset.robot,
            windows: sim.dataset.windows.iter().collect(),
        };
        let fitted = RateLimited::default().fit(&set).unwrap();
        let [speed, steering] = fitted.axes[..] else {
            panic!("two axes")
        };
        let close = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol * b;
        // The servo's limit binds only on large steering changes: found, if loosely.
        assert!(
            steering.max_rate > 0.7 * truth.steering.max_rate
                && steering.max_rate < 1.6 * truth.steering.max_rate,
            "seed {seed}: {steering:?}"
        );
        assert!(
            close(steering.time_constant, truth.steering.time_constant, 0.15),
            "{steering:?}"
        );
        assert!(
            close(steering.delay, truth.steering.delay, 0.15),
            "{steering:?}"
        );
        // The speed loop's limit binds only when the runner stops the car: found near it,
        // or none.
        assert!(speed.max_rate > 0.7 * truth.speed.max_rate, "{speed:?}");
        assert!(
            close(speed.time_constant, truth.speed.time_constant, 0.1),
            "{speed:?}"
        );
        assert!(close(speed.delay, truth.speed.delay, 0.1), "{speed:?}");
    }
}

#[test]
fn the_skid_steer_plant_refuses_a_car() {
    let plants = builtin_plants();
    let skid = plants.get("differential").unwrap();
    let e = skid
        .part()
        .make(&autorally(), &Terrain::preset("tile").unwrap(), 0)
        .err()
        .expect("no skid-steer plant for a car");
    assert!(e.contains("needs a differential-drive vehicle"), "{e}");
    // And the car plant refuses a skid-steer.
    let husky = drive_samplers::builtin_robots()
        .get("husky")
        .unwrap()
        .part()
        .as_ref()
        .clone();
    let car = plants.get("ackermann").unwrap();
    let e = car
        .part()
        .make(&husky, &Terrain::preset("tile").unwrap(), 0)
        .err()
        .expect("no car plant for a skid-steer");
    assert!(e.contains("needs an ackermann vehicle"), "{e}");
}

#[test]
fn a_car_whose_physics_cannot_be_integrated_stops_with_a_reason() {
    // A wheelbase of 1e308 m: the yaw inertia overflows at once.
    let mut robot = small_car();
    robot.vehicle = std::sync::Arc::new(Ackermann::new(1e308, 0.42));
    let config = crate::config(robot, "gravel", 1, 2, "huge");
    let factory = crate::uniform(small_car(), 1);
    let Err(e) = simulate(config, &builtin_plants(), factory, None) else {
        panic!("no dataset from a diverged simulation");
    };
    assert!(matches!(e, drive_sim::SimError::Diverged { .. }), "{e}");
    assert!(e.to_string().contains("diverged"), "{e}");
}
