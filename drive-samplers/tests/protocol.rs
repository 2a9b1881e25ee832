//! The protocol's schedule: deterministic, structured as DRIVE intervals, within the
//! acceleration limits; samplers behave as documented; robot files are validated.

use drive_models::DifferentialDrive;
use drive_samplers::{
    build_sampler, builtin_robots, builtin_samplers, next_command, schedule, schedule_csv,
    window_len, RobotError, RobotSpec, SamplerContext, SamplerError, SentCommand,
};
use drive_traits::{CommandModel, Input, InputSampler, Phase};

fn preset(name: &str) -> RobotSpec {
    RobotSpec::load(&builtin_robots(), name).unwrap()
}

fn sampler(
    robot: &RobotSpec,
    name: &str,
    seed: u64,
) -> Result<Box<dyn InputSampler>, SamplerError> {
    build_sampler(
        &builtin_samplers(std::sync::Arc::new(
            drive_models::slip::SlipBlrLeverage::default(),
        )),
        name,
        &SamplerContext::new(robot, seed),
    )
}

fn make(
    robot: &RobotSpec,
    name: &str,
    seed: u64,
    intervals: usize,
) -> Vec<drive_samplers::ScheduledCommand> {
    let mut s = sampler(robot, name, seed).unwrap();
    schedule(robot, s.as_mut(), intervals)
}

/// The preset's vehicle as the differential drive it is.
fn dd(robot: &RobotSpec) -> DifferentialDrive {
    drive_traits::vehicle_as(robot.vehicle.as_ref()).unwrap()
}

#[test]
fn same_seed_same_bytes_other_seed_other_schedule() {
    for name in ["husky", "hd2", "warthog"] {
        let robot = preset(name);
        for s in builtin_samplers(std::sync::Arc::new(
            drive_models::slip::SlipBlrLeverage::default(),
        ))
        .names()
        {
            let a = schedule_csv(&robot, &make(&robot, s, 11, 8));
            let b = schedule_csv(&robot, &make(&robot, s, 11, 8));
            assert_eq!(a, b, "{name} {s}");
            assert_ne!(
                a,
                schedule_csv(&robot, &make(&robot, s, 12, 8)),
                "{name} {s}"
            );
        }
    }
}

#[test]
fn every_interval_is_one_transient_and_two_steady_windows() {
    let robot = preset("husky");
    let rows = make(&robot, "uniform", 3, 10);
    let n = window_len(&robot);
    assert_eq!(n, 40);
    assert_eq!(rows.len(), 10 * 3 * n);
    for (i, chunk) in rows.chunks(3 * n).enumerate() {
        assert!(chunk
            .iter()
            .all(|r| r.interval == i && r.target == chunk[0].target));
        assert!(chunk[..n].iter().all(|r| r.phase == Phase::Transient));
        assert!(chunk[n..].iter().all(|r| r.phase == Phase::Steady));
    }
    for (k, r) in rows.iter().enumerate() {
        assert!((r.t - k as f64 / 20.0).abs() < 1e-12);
    }
}

#[test]
fn acceleration_limits_hold_and_targets_are_reached() {
    for name in ["husky", "warthog"] {
        let robot = preset(name);
        let dd = dd(&robot);
        let preset = name;
        let rows = make(&robot, "uniform", 5, 20);
        let dt = 1.0 / robot.rate_hz;
        let mut prev = dd.body_velocity(&drive_traits::Input::zeros());
        for r in &rows {
            let f = dd.body_velocity(&r.command);
            assert!(
                (f.x - prev.x).abs() <= robot.max_linear_acceleration * dt + 1e-9,
                "{preset}"
            );
            assert!(
                (f.z - prev.z).abs() <= robot.max_angular_acceleration * dt + 1e-9,
                "{preset}"
            );
            assert!(
                robot.input_space().contains(&r.command) || (r.command - r.target).norm() < 1e-9
            );
            prev = f;
        }
        // By the end of each interval the command has reached its target.
        let n = 3 * window_len(&robot);
        for chunk in rows.chunks(n) {
            assert!(
                (chunk[n - 1].command - chunk[n - 1].target).norm() < 1e-9,
                "{preset}"
            );
        }
    }
}

#[test]
fn uniform_respects_the_controller_limits_when_there_are_some() {
    let mut robot = preset("husky");
    robot.controller_max_linear = Some(0.5);
    robot.controller_max_angular = Some(1.0);
    let dd = dd(&robot);
    let mut s = sampler(&robot, "uniform", 9).unwrap();
    for _ in 0..2000 {
        let f = dd.body_velocity(&s.next_input());
        assert!(f.x.abs() <= 0.5 && f.z.abs() <= 1.0);
    }
    robot.controller_max_linear = Some(1e-9);
    robot.controller_max_angular = Some(1e-9);
    assert!(sampler(&robot, "uniform", 9).is_err());
}

#[test]
fn human_like_samplers_cover_what_they_say() {
    let robot = preset("husky");
    let dd = dd(&robot);
    let turn_in_place = 2.0 * robot.max_speed / dd.baseline;
    let mut linear = sampler(&robot, "linear", 1).unwrap();
    let body: Vec<_> = (0..2000)
        .map(|_| dd.body_velocity(&linear.next_input()))
        .collect();
    let forward = body.iter().filter(|f| f.x > 0.0).count() as f64 / body.len() as f64;
    assert!(forward > 0.85, "forward share {forward}");
    assert!(body
        .iter()
        .all(|f| f.z.abs() <= 0.15 * turn_in_place + 1e-9));
    let mut angular = sampler(&robot, "angular", 1).unwrap();
    let body: Vec<_> = (0..2000)
        .map(|_| dd.body_velocity(&angular.next_input()))
        .collect();
    assert!(body
        .iter()
        .all(|f| (f.x - 0.5 * robot.max_speed).abs() < 1e-9));
    let spread = body.iter().map(|f| f.z).fold(0.0f64, |m, w| m.max(w.abs()));
    assert!(spread > 0.45 * turn_in_place, "yaw-rate spread {spread}");
}

#[test]
fn robot_files_are_validated() {
    let good = "name = 'r'\nmass_kg = 30\nwheel_radius = 0.1\nbaseline = 0.4\nmax_speed = 1.5\nmax_linear_acceleration = 1.0\nmax_angular_acceleration = 3.0\n";
    assert!(RobotSpec::from_toml("r.toml", good).is_ok());
    let parse_errors = [
        good.replace("mass_kg = 30\n", ""),
        good.replace("baseline = 0.4", "baseline = 'wide'"),
        format!("{good}colour = 'red'\n"),
        "not = [toml".to_string(),
    ];
    for text in parse_errors {
        let err = RobotSpec::from_toml("r.toml", &text).unwrap_err();
        assert!(matches!(err, RobotError::Parse { .. }), "{err}");
        assert!(err.to_string().starts_with("r.toml"), "{err}");
    }
    let invalid = [
        (
            good.replace("wheel_radius = 0.1", "wheel_radius = -0.1"),
            "vehicle",
        ),
        // Both forms of the vehicle, an unknown vehicle type, no vehicle at all.
        (
            format!("{good}[vehicle]\ntype = 'differential'\nwheel_radius = 0.1\nbaseline = 0.4\n"),
            "vehicle",
        ),
        (
            good.replace("wheel_radius = 0.1\nbaseline = 0.4\n", "")
                + "[vehicle]\ntype = 'hovercraft'\n",
            "vehicle",
        ),
        (good.replace("wheel_radius = 0.1\n", ""), "wheel_radius"),
        (
            good.replace("wheel_radius = 0.1\nbaseline = 0.4\n", ""),
            "vehicle",
        ),
        (
            format!("{good}input_limits = [[-1.0, 1.0], [2.0, 2.0]]\n"),
            "input_limits",
        ),
        (
            format!(
                "{good}wheel_limits = [-1.0, 1.0]\ninput_limits = [[-1.0, 1.0], [-2.0, 2.0]]\n"
            ),
            "wheel_limits",
        ),
        // An overflowing top speed gives no finite input space.
        (
            good.replace("max_speed = 1.5", "max_speed = 1e308"),
            "max_speed",
        ),
        (
            good.replace("max_speed = 1.5", "max_speed = 0"),
            "max_speed",
        ),
        (
            format!("{good}wheel_limits = [3.0, -3.0]\n"),
            "wheel_limits",
        ),
        (format!("{good}rate_hz = nan\n"), "rate_hz"),
    ];
    for (text, field) in invalid {
        match RobotSpec::from_toml("r.toml", &text).unwrap_err() {
            RobotError::Invalid { field: f, .. } => assert_eq!(f, field),
            other => panic!("{field}: {other}"),
        }
    }
    let unknown = RobotSpec::load(&builtin_robots(), "rover").unwrap_err();
    assert!(
        matches!(unknown, RobotError::Registry(_))
            && unknown.to_string().contains("husky, hd2, warthog"),
        "{unknown}"
    );
    let hd2 = preset("hd2");
    let g = dd(&hd2);
    assert!(hd2.tracked && g.wheel_radius == 0.116 && g.baseline == 0.5927 && hd2.mass_kg == 80.0);
    let warthog = preset("warthog");
    assert!(warthog.max_speed == 5.0 && warthog.mass_kg == 470.0);
    // The vehicle table and the older form are the same robot; per-axis limits are kept.
    let table = good.replace("wheel_radius = 0.1\nbaseline = 0.4\n", "")
        + "input_limits = [[-3.0, 4.0], [-2.0, 5.0]]\n[vehicle]\ntype = 'differential'\nwheel_radius = 0.1\nbaseline = 0.4\n";
    let r = RobotSpec::from_toml("r.toml", &table).unwrap();
    assert_eq!(dd(&r), DifferentialDrive::new(0.1, 0.4));
    let j = r.input_space();
    assert_eq!((j.min.x, j.max.x, j.min.y, j.max.y), (-3.0, 4.0, -2.0, 5.0));
    assert_eq!(r.nominal_input_space.max.x, 15.0);
}

#[test]
fn car_robot_files_take_per_axis_rate_limits_and_a_lateral_acceleration_limit() {
    let car = "name = 'car'\nmass_kg = 5\nmax_speed = 3\ninput_rate_limits = [3.0, 6.0]\n\
               max_lateral_acceleration = 2.0\n[vehicle]\ntype = 'ackermann'\nwheelbase = 0.33\n\
               max_steering = 0.4\n";
    let r = RobotSpec::from_toml("car.toml", car).unwrap();
    assert_eq!(r.input_rate_limits, Some(Input::new(3.0, 6.0, 0.0)));
    // Speed and steering: the nominal space has each axis's own units.
    let j = r.input_space();
    assert_eq!((j.min.x, j.max.x, j.min.y, j.max.y), (-3.0, 3.0, -0.4, 0.4));
    // The body accelerations may be omitted when the rate limits replace them.
    assert!(r.max_linear_acceleration.is_infinite() && r.max_angular_acceleration.is_infinite());
    let limits = r.body_limits().unwrap();
    assert_eq!(limits.max_lateral_acceleration, 2.0);
    // The uniform sampler redraws beyond the lateral acceleration limit.
    let samplers = builtin_samplers(std::sync::Arc::new(
        drive_models::slip::SlipBlrLeverage::default(),
    ));
    let mut s = build_sampler(&samplers, "uniform", &SamplerContext::new(&r, 3)).unwrap();
    for _ in 0..2000 {
        let f = r.vehicle.body_velocity(&s.next_input());
        assert!((f.x * f.z).abs() <= 2.0 + 1e-12);
    }
    // And the schedule steers within it towards any target.
    let mut sent = SentCommand::default();
    for _ in 0..200 {
        let u = next_command(&r, &mut sent, &Input::new(3.0, 0.4, 0.0));
        let f = r.vehicle.body_velocity(&u);
        assert!((f.x * f.z).abs() <= 2.0 + 1e-9, "{u:?}");
    }
    // A target beyond the limit is approached up to it: the car turns at 2 m/s^2.
    let f = r.vehicle.body_velocity(&sent.input);
    assert!((f.x * f.z - 2.0).abs() < 1e-6, "{:?}", sent.input);
    let invalid = [
        (
            car.replace("input_rate_limits = [3.0, 6.0]\n", ""),
            "input_rate_limits",
        ),
        (
            car.replace("[3.0, 6.0]", "[3.0, -6.0]"),
            "input_rate_limits",
        ),
        (
            car.replace(
                "max_lateral_acceleration = 2.0",
                "max_lateral_acceleration = 0",
            ),
            "max_lateral_acceleration",
        ),
        (format!("wheel_limits = [-3.0, 3.0]\n{car}"), "wheel_limits"),
        (
            car.replace("max_steering = 0.4", "max_steering = 2.0"),
            "vehicle",
        ),
        // Not a number where JSON has none: named, not "invalid type: null".
        (
            car.replace("wheelbase = 0.33", "wheelbase = nan"),
            "vehicle",
        ),
        (
            format!("input_limits = [[-3.0, 3.0], [-2.0, 2.0]]\n{car}"),
            "input_limits",
        ),
        (
            format!("input_limits = [[-1e308, 1e308], [-0.4, 0.4]]\n{car}"),
            "input_limits",
        ),
    ];
    for (text, field) in invalid {
        match RobotSpec::from_toml("car.toml", &text).unwrap_err() {
            RobotError::Invalid {
                field: f, message, ..
            } => {
                assert_eq!(f, field, "{message}");
                assert!(
                    !message.contains("null") && message.len() < 200,
                    "{message}"
                );
            }
            other => panic!("{field}: {other}"),
        }
    }
    // A skid-steer without body accelerations nor rate limits is refused.
    let husky = "name = 'r'\nmass_kg = 30\nwheel_radius = 0.1\nbaseline = 0.4\nmax_speed = 1.5\n\
                 max_linear_acceleration = 1.0\n";
    match RobotSpec::from_toml("r.toml", husky).unwrap_err() {
        RobotError::Invalid { field, .. } => assert_eq!(field, "max_angular_acceleration"),
        other => panic!("{other}"),
    }
    let preset = drive_samplers::autorally();
    assert_eq!(preset.mass_kg, 23.92);
    assert!(preset.validate("autorally").is_ok());
}
