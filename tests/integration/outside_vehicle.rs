//! A vehicle written outside the crates, through the public API only: a robot commanded in
//! body velocity (v, omega), as a `cmd_vel` interface is. It is registered, simulated
//! (the kinematic plant stands in for physics it has none of), characterized, written as a
//! window CSV with its own columns and read back, and every model combination is trained and
//! evaluated on it and saved and loaded as a file.

use drive::models::model_file::{model_from_json, model_to_json};
use drive::samplers::RobotSpec;
use drive::studies::{compare, simulate_protocol};
use drive::traits::{
    BodyVelocity, CommandModel, Input, InputAxis, InputSpace, Probe, ProbeResult, Tagged,
};
use drive::Registries;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Commanded in body velocity: inputs (v, omega); the yaw-rate range is its own.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Unicycle {
    /// Top yaw rate (rad/s).
    max_yaw_rate: f64,
}

impl Tagged for Unicycle {
    const TAG: &'static str = "unicycle";
}

#[typetag::serde(name = "unicycle")]
impl CommandModel for Unicycle {
    fn body_velocity(&self, u: &Input) -> BodyVelocity {
        BodyVelocity::new(u.x, 0.0, u.y)
    }
    fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
        (v.y == 0.0).then(|| Input::new(v.x, v.z, 0.0))
    }
    fn axes(&self) -> Vec<InputAxis> {
        vec![
            InputAxis {
                name: "v",
                unit: "m/s",
                command_column: "cmd_v",
                measured_column: "meas_v",
            },
            InputAxis {
                name: "omega",
                unit: "rad/s",
                command_column: "cmd_omega",
                measured_column: "meas_omega",
            },
        ]
    }
    fn nominal_input_space(&self, top_speed: f64) -> Option<InputSpace> {
        InputSpace::new(
            Input::new(-top_speed, -self.max_yaw_rate, 0.0),
            Input::new(top_speed, self.max_yaw_rate, 0.0),
        )
    }
    /// Forward and backward at twice the top speed, then turning both ways at twice the
    /// top yaw rate.
    fn probe(&self, index: usize, top_speed: f64, _done: &[ProbeResult]) -> Option<Probe> {
        let (name, command) = match index {
            0 => ("forward", Input::new(2.0 * top_speed, 0.0, 0.0)),
            1 => ("backward", Input::new(-2.0 * top_speed, 0.0, 0.0)),
            2 => ("left", Input::new(0.0, 2.0 * self.max_yaw_rate, 0.0)),
            3 => ("right", Input::new(0.0, -2.0 * self.max_yaw_rate, 0.0)),
            _ => return None,
        };
        Some(Probe {
            name,
            command,
            needs_localization: false,
        })
    }
    fn clone_box(&self) -> Box<dyn CommandModel> {
        Box::new(self.clone())
    }
}

fn registries() -> Registries {
    let mut r = Registries::builtin();
    let vehicle = Unicycle { max_yaw_rate: 1.5 };
    r.vehicles
        .register(
            "unicycle",
            "body-velocity commands",
            Arc::new(vehicle.clone()),
        )
        .unwrap();
    let mut robot = r.robot("husky").unwrap();
    robot.name = "cmd-vel-robot".into();
    robot.nominal_input_space = vehicle.nominal_input_space(robot.max_speed).unwrap();
    robot.vehicle = Arc::new(vehicle);
    r.robots
        .register(
            "cmd-vel-robot",
            "a robot driven by cmd_vel",
            Arc::new(robot),
        )
        .unwrap();
    r
}

#[test]
fn an_outside_vehicle_is_simulated_characterized_trained_evaluated_and_saved() {
    let r = registries();
    let sim = simulate_protocol(&r, "cmd-vel-robot", "gravel", "uniform", 30, 3).unwrap();
    // The kinematic plant saturates at the robot's input space: 1 m/s and 1.5 rad/s, which
    // the characterization (its own probes) finds.
    let c = sim.characterization.expect("characterized");
    for (got, want) in [
        (c.space.max.x, 1.0),
        (-c.space.min.x, 1.0),
        (c.space.max.y, 1.5),
        (-c.space.min.y, 1.5),
    ] {
        assert!((got - want).abs() < 0.05, "{got} vs {want}");
    }
    let data = sim.dataset;
    assert_eq!(data.windows.len(), 90);

    // Written with the vehicle's columns and type, read back the same.
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("cmdvel.csv");
    drive::data::write_dataset(&data, &csv).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text
        .starts_with("window,phase,k,t,cmd_v,cmd_omega,meas_v,meas_omega,x,y,yaw,imu_yaw_rate\n"));
    let sidecar: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("cmdvel.meta.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(sidecar["vehicle"]["type"], "unicycle");
    let back = drive::data::read_dataset(&csv, None).unwrap();
    assert_eq!(back, data);

    // The command line evaluates it with the vehicle registered, and refuses it without
    // (a part is never used unregistered, issue 32).
    let eval = |registries: &Registries| {
        drive::cli::run_status(
            [
                "drive",
                "eval",
                "--models",
                "naive",
                "--data",
                csv.to_str().unwrap(),
            ],
            registries,
        )
    };
    assert_eq!(eval(&Registries::builtin()), 1);
    assert_eq!(eval(&r), 0);
    // The same in a benchmark suite.
    let suite = dir.path().join("suite.toml");
    std::fs::write(&suite, "[[dataset]]\npath = \"cmdvel.csv\"\n").unwrap();
    let bench = |registries: &Registries| {
        drive::cli::run_status(
            [
                "drive",
                "bench",
                "--suite",
                suite.to_str().unwrap(),
                "--models",
                "naive,slip-blr",
            ],
            registries,
        )
    };
    assert_eq!(bench(&Registries::builtin()), 1);
    assert_eq!(bench(&r), 0);

    // Every combination trains and evaluates on it; learning the slip pays.
    let cmp = compare(&r, &back, 0.5, &["all"]).unwrap();
    assert_eq!(cmp.models.len(), r.models().all().len());
    assert_eq!(cmp.vehicle, "unicycle");
    let median = |name: &str| {
        let m = cmp.models.iter().find(|m| m.model == name).unwrap();
        (m.translational_median_m, m.rotational_median_rad)
    };
    let (naive, slip) = (median("no-slip+commanded"), median("slip-blr+fopdt"));
    assert!(
        slip.0 < 0.7 * naive.0 && slip.1 < 0.7 * naive.1,
        "{naive:?} {slip:?}"
    );

    // Saved and loaded as a file, the vehicle with it.
    let (train, _) = drive::eval::split_by_interval(&back, 0.5).unwrap();
    let model = r
        .model("slip-blr+rate-limited")
        .unwrap()
        .fit(&train)
        .unwrap();
    let json = model_to_json(model.as_ref(), &back.robot).unwrap();
    let (loaded, robot) = model_from_json("m.json", &json).unwrap();
    assert_eq!(robot, back.robot);
    let w = &back.windows[60];
    let start = w.start_state(robot.vehicle.as_ref());
    assert_eq!(
        loaded.predict(&start, &w.command),
        model.predict(&start, &w.command)
    );
}

#[test]
fn a_vehicle_whose_characterization_cannot_move_an_axis_stops_with_the_reason() {
    // The same robot, with probes that never turn: the yaw-rate range cannot be found, and
    // the run says so instead of making one up.
    #[derive(Debug, Clone, Serialize, Deserialize)]
    struct StraightOnly(Unicycle);
    #[typetag::serde(name = "straight-only")]
    impl CommandModel for StraightOnly {
        fn body_velocity(&self, u: &Input) -> BodyVelocity {
            self.0.body_velocity(u)
        }
        fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
            self.0.input_for(v)
        }
        fn axes(&self) -> Vec<InputAxis> {
            self.0.axes()
        }
        fn nominal_input_space(&self, top_speed: f64) -> Option<InputSpace> {
            self.0.nominal_input_space(top_speed)
        }
        fn clone_box(&self) -> Box<dyn CommandModel> {
            Box::new(self.clone())
        }
    }
    let mut r = registries();
    let mut robot: RobotSpec = r.robot("cmd-vel-robot").unwrap();
    robot.vehicle = Arc::new(StraightOnly(Unicycle { max_yaw_rate: 1.5 }));
    robot.name = "straight".into();
    r.robots.register("straight", "", Arc::new(robot)).unwrap();
    let sim = simulate_protocol(&r, "straight", "tile", "uniform", 5, 1).unwrap();
    match &sim.stop {
        drive::samplers::RunnerState::Done(
            drive::samplers::StopReason::CharacterizationFailed(why),
        ) => assert!(why.contains("never command the axis 'omega'"), "{why}"),
        other => panic!("{other:?}"),
    }
    assert!(sim.dataset.windows.is_empty());
}

#[test]
fn a_vehicle_of_an_unsupported_number_of_inputs_is_refused_at_registration() {
    // Four axes (beyond MAX_INPUTS), and axes that disagree with input_dim().
    #[derive(Debug, Clone, Serialize, Deserialize)]
    struct Axes(usize, usize);
    #[typetag::serde(name = "many-axes")]
    impl CommandModel for Axes {
        fn body_velocity(&self, u: &Input) -> BodyVelocity {
            *u
        }
        fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
            Some(*v)
        }
        fn axes(&self) -> Vec<InputAxis> {
            let axis = Unicycle { max_yaw_rate: 1.0 }.axes()[0];
            vec![axis; self.0]
        }
        fn input_dim(&self) -> usize {
            self.1
        }
        fn clone_box(&self) -> Box<dyn CommandModel> {
            Box::new(self.clone())
        }
    }
    impl Tagged for Axes {
        const TAG: &'static str = "many-axes";
    }
    let mut r = Registries::builtin();
    let e = r
        .vehicles
        .register("many-axes", "", Arc::new(Axes(4, 4)))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("has 4 input axes") && e.contains("2 or 3"),
        "{e}"
    );
    let e = r
        .vehicles
        .register("many-axes", "", Arc::new(Axes(3, 2)))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("lists 3 input axes") && e.contains("says 2"),
        "{e}"
    );
    let e = r
        .vehicles
        .register("many-axes", "", Arc::new(Axes(1, 1)))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("has 1 input axes"), "{e}");
    // Three, consistent: registered.
    r.vehicles
        .register("many-axes", "", Arc::new(Axes(3, 3)))
        .unwrap();
}

/// A four-wheel-steered rover of wheelbase 1 m commanded in (speed, front steer, rear
/// steer): its velocity is along the mean of the two axles' steering, its yaw rate the
/// speed times their difference. The corner of its box where every input is highest is a
/// pure crab (no yaw at all).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Rover;

impl Tagged for Rover {
    const TAG: &'static str = "rover-4ws";
}

#[typetag::serde(name = "rover-4ws")]
impl CommandModel for Rover {
    fn body_velocity(&self, u: &Input) -> BodyVelocity {
        let (front, rear) = (u.y.tan(), u.z.tan());
        let heading = (0.5 * (front + rear)).atan();
        BodyVelocity::new(
            u.x * heading.cos(),
            u.x * heading.sin(),
            u.x * heading.cos() * (front - rear),
        )
    }
    /// Without crabbing: the axles steered opposite, `tan(front) = w / (2 v)`.
    fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
        if v.y != 0.0 {
            return None;
        }
        if v.x == 0.0 {
            return (v.z == 0.0).then(Input::zeros);
        }
        let front = (v.z / (2.0 * v.x)).atan();
        Some(Input::new(v.x, front, -front))
    }
    fn axes(&self) -> Vec<InputAxis> {
        let axis = |name, unit, command_column, measured_column| InputAxis {
            name,
            unit,
            command_column,
            measured_column,
        };
        vec![
            axis("speed", "m/s", "cmd_speed", "meas_speed"),
            axis("front", "rad", "cmd_front", "meas_front"),
            axis("rear", "rad", "cmd_rear", "meas_rear"),
        ]
    }
    fn nominal_input_space(&self, top_speed: f64) -> Option<InputSpace> {
        InputSpace::new(
            Input::new(-top_speed, -0.5, -0.5),
            Input::new(top_speed, 0.5, 0.5),
        )
    }
    /// Its own slip-BLR basis: none of the built-in ones has a crab's own slip.
    fn slip_features(&self) -> Option<Box<dyn drive::traits::SlipFeatures>> {
        Some(Box::new(RoverSlip))
    }
    fn clone_box(&self) -> Box<dyn CommandModel> {
        Box::new(self.clone())
    }
}

/// The rover's slip inputs: forward `[f_x]`, sideways `[f_y, f_x f_w]` (its crab, and the
/// drift outwards in turns), in yaw `[f_w, f_y]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct RoverSlip;

#[typetag::serde(name = "rover-slip")]
impl drive::traits::SlipFeatures for RoverSlip {
    fn dimensions(&self) -> [usize; 3] {
        [1, 2, 2]
    }
    fn names(&self) -> [Vec<String>; 3] {
        [
            vec!["f_x".into()],
            vec!["f_y".into(), "f_x f_w".into()],
            vec!["f_w".into(), "f_y".into()],
        ]
    }
    fn inputs(&self, f: &BodyVelocity) -> drive::traits::SlipInputRows {
        [
            [f.x, 0.0, 0.0, 0.0],
            [f.y, f.x * f.z, 0.0, 0.0],
            [f.z, f.y, 0.0, 0.0],
        ]
    }
    fn clone_box(&self) -> Box<dyn drive::traits::SlipFeatures> {
        Box::new(RoverSlip)
    }
}

/// The built-in parts with the rover registered, and a robot with it (the Husky's mass and
/// rates, the rover's box as its limits, no controller limits), not yet registered.
fn rover_registries() -> (Registries, RobotSpec) {
    let mut r = Registries::builtin();
    r.vehicles
        .register("rover-4ws", "four-wheel steered", Arc::new(Rover))
        .unwrap();
    let mut robot: RobotSpec = r.robot("husky").unwrap();
    robot.name = "rover".into();
    robot.nominal_input_space = Rover.nominal_input_space(robot.max_speed).unwrap();
    robot.input_limits = Some(robot.nominal_input_space);
    robot.vehicle = Arc::new(Rover);
    (robot.controller_max_linear, robot.controller_max_angular) = (None, None);
    robot.max_lateral_acceleration = None;
    (r, robot)
}

#[test]
fn a_vehicle_brings_its_own_slip_basis_which_slip_blr_fits_saves_and_steps() {
    let (mut r, robot) = rover_registries();
    r.robots
        .register("rover", "a rover", Arc::new(robot))
        .unwrap();
    let data = simulate_protocol(&r, "rover", "gravel", "uniform", 60, 4)
        .unwrap()
        .dataset;
    let (train, eval) = drive::eval::split_by_interval(&data, 0.5).unwrap();
    let model = r.model("slip-blr+fopdt").unwrap().fit(&train).unwrap();
    // Fitted on the vehicle's own basis, named in its parameters and its file.
    let parameters = model.parameters();
    let weight = |name: &str| parameters.iter().find(|(n, _)| n == name).map(|p| p.1);
    assert!(weight("angular slip: w[f_y]").is_some(), "{parameters:?}");
    // The stand-in keeps the rover's crab: of a commanded sideways velocity, only the
    // gravel's rolling loss slips (a plant that dropped it would slip all of it, w = 1).
    let crab = weight("lateral slip: w[f_y]").unwrap();
    assert!((0.0..0.3).contains(&crab), "{parameters:?}");
    let json = model_to_json(model.as_ref(), &data.robot).unwrap();
    assert!(json.contains("\"rover-slip\""), "{json}");
    let (loaded, robot) = model_from_json("m.json", &json).unwrap();
    let w = &eval.windows[7];
    let start = w.start_state(robot.vehicle.as_ref());
    let predicted = model.predict(&start, &w.command);
    assert_eq!(loaded.predict(&start, &w.command), predicted);
    // Stepped one command at a time, natively (not by replay), with the covariance, it
    // predicts what it rolls out.
    use drive::traits::step::{layout, StepOptions};
    let stepper = loaded.stepper(StepOptions::with_covariance(true)).unwrap();
    assert!(!stepper.is_replay());
    let (mut poses, mut covariances) = (Vec::new(), Vec::new());
    loaded
        .predict_with_covariance_into(&start, &w.command, &mut poses, &mut covariances)
        .unwrap();
    let mut state = vec![0.0; stepper.state_len()];
    stepper.init(&start, &[], &mut state).unwrap();
    for (k, u) in w.command.iter().enumerate() {
        let p = layout::pose(&state);
        assert!(
            (p - poses[k]).norm() < 1e-9,
            "step {k}: {p} vs {}",
            poses[k]
        );
        let c = layout::covariance(&state);
        assert!(
            (c - covariances[k]).norm() < 1e-9 * (1.0 + c.norm()),
            "step {k}"
        );
        stepper.step(&mut state, u).unwrap();
    }
    // The skid-steer fit is a differential drive's, refused by name (`drive sim-fit`
    // fits its ground instead: the test below).
    let e = drive::sim::sim_fit(&data, &r.robot("rover").unwrap(), "twin")
        .unwrap_err()
        .to_string();
    assert!(e.contains("'rover-4ws'") && e.contains("skid-steer"), "{e}");
    // Its own basis learns the crab's slip: better than no slip at all.
    let cmp = compare(&r, &data, 0.5, &["naive", "slip-blr"]).unwrap();
    let (naive, slip) = (
        &cmp.models[0].translational_median_m,
        &cmp.models[1].translational_median_m,
    );
    assert!(slip < &(0.7 * naive), "{naive} {slip}");
}

#[test]
fn the_human_like_samplers_and_the_regions_ask_a_rover_what_it_reaches_not_its_box_corner() {
    let (mut r, robot) = rover_registries();
    let space = robot.nominal_input_space;
    // Top speed at the box's top corner, and the hardest turn with the axles steered apart
    // (the corner asked before turned at exactly 0).
    let reach = Rover.reach(&space);
    assert!(Rover.body_velocity(&space.max).z.abs() < 1e-12);
    let top = robot.max_speed;
    assert!((reach.top_speed() - top).abs() < 1e-9, "{reach:?}");
    assert!(
        (reach.top_yaw_rate() - 2.0 * top * 0.5_f64.tan()).abs() < 1e-9,
        "{reach:?}"
    );
    assert_eq!(reach.left.input, Input::new(top, 0.5, -0.5));
    // The angular sampler steers it, both ways, up to a half of full lock at half speed.
    let ctx = drive::samplers::SamplerContext::new(&robot, 5);
    for (sampler, least) in [("angular", 0.15), ("linear", 0.02)] {
        let mut s = drive::samplers::build_sampler(&r.samplers, sampler, &ctx).unwrap();
        let steer: Vec<f64> = (0..200).map(|_| s.next_input().y).collect();
        let (lo, hi) = steer
            .iter()
            .fold((0.0_f64, 0.0_f64), |(a, b), &x| (a.min(x), b.max(x)));
        assert!(hi > least && -lo > least, "{sampler}: {lo} .. {hi}");
        assert!(hi <= 0.5 && lo >= -0.5, "{sampler}: {lo} .. {hi}");
    }
    // A vehicle that only crabs (no yaw rate anywhere in its box) has nothing for the
    // angular sampler to draw: refused, naming what it lacks.
    #[derive(Debug, Clone, Serialize, Deserialize)]
    struct Crab;
    #[typetag::serde(name = "crab-only")]
    impl CommandModel for Crab {
        fn body_velocity(&self, u: &Input) -> BodyVelocity {
            let v = Rover.body_velocity(&Input::new(u.x, u.y, u.y));
            BodyVelocity::new(v.x, v.y, 0.0)
        }
        fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
            (v.z == 0.0 && v.y == 0.0).then(|| Input::new(v.x, 0.0, 0.0))
        }
        fn axes(&self) -> Vec<InputAxis> {
            Rover.axes()
        }
        fn clone_box(&self) -> Box<dyn CommandModel> {
            Box::new(self.clone())
        }
    }
    let mut crab = robot.clone();
    crab.vehicle = Arc::new(Crab);
    let ctx = drive::samplers::SamplerContext::new(&crab, 5);
    let e = drive::samplers::build_sampler(&r.samplers, "angular", &ctx)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("angular sampler") && e.contains("yaw rate") && e.contains("crab-only"),
        "{e}"
    );

    // The regions of the protocol comparison on its data: the linear region's yaw-rate
    // bound is a fraction of the rover's real turn rate, not of the crab corner's zero.
    r.robots
        .register("rover", "a rover", Arc::new(robot))
        .unwrap();
    let data = simulate_protocol(&r, "rover", "gravel", "uniform", 40, 2)
        .unwrap()
        .dataset;
    assert_eq!(data.windows.len(), 120);
    let table = drive::studies::compare_regions(
        &r,
        &data,
        &drive::studies::RegionStudy {
            model: "no-slip+commanded".into(),
            draws: 3,
            ..Default::default()
        },
    )
    .unwrap();
    let linear = &table.regions[0].definition;
    let bound: f64 = linear
        .split("<= ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap();
    assert!(bound > 0.15 * 0.5 * reach.top_yaw_rate(), "{linear}");
    // Its input space has all three axes (the rear steer was dropped).
    assert_eq!(table.input_space.len(), 3, "{:?}", table.input_space);
    assert!(table.input_space[2][1] > 0.3, "{:?}", table.input_space);
}

/// `drive sim-fit` on a vehicle the skid-steer fit does not cover: the rover (no simulator
/// registered: the kinematic stand-in, named) and the built-in mecanum base. The ground is
/// fitted on the run's own motion, the twin passes its check and is written, and `--twin`
/// checks it again on the same refusals a fit makes.
#[test]
fn sim_fit_fits_the_ground_of_a_vehicle_of_any_type_and_says_which_simulator() {
    let (mut r, robot) = rover_registries();
    r.robots
        .register("rover", "a rover", Arc::new(robot))
        .unwrap();
    let dir = tempfile::tempdir().unwrap();
    for (robot, ground, simulator, stand_in) in [
        ("rover", "snow", "kinematic", true),
        ("ridgeback", "gravel", "omnidirectional", false),
    ] {
        let data = simulate_protocol(&r, robot, ground, "uniform", 40, 5)
            .unwrap()
            .dataset;
        let csv = dir.path().join(format!("{robot}.csv"));
        drive::data::write_dataset(&data, &csv).unwrap();
        let twin = dir.path().join(format!("{robot}-twin.toml"));
        let status = |args: &[&str]| {
            let mut all = vec!["drive"];
            all.extend_from_slice(args);
            drive::cli::run_status(all, &r)
        };
        let (csv_s, twin_s) = (csv.to_str().unwrap(), twin.to_str().unwrap());
        // The fit's result is read back from the twin file and checked again with --twin.
        assert_eq!(
            status(&[
                "sim-fit",
                "--data",
                csv_s,
                "--robot",
                robot,
                "--out",
                twin_s,
                "--check-seeds",
                "1"
            ]),
            0,
            "{robot}"
        );
        let fitted =
            drive::sim::Terrain::from_toml("twin", &std::fs::read_to_string(&twin).unwrap())
                .unwrap();
        // The ground only: the simulator's own powertrain, controller and sensors; the
        // vehicle it is a twin of recorded, and another robot refused it.
        assert!(
            fitted.powertrain.is_none() && fitted.controller.is_none() && fitted.protocol.is_none()
        );
        let fitted_for = fitted.fitted_for.as_ref().unwrap();
        let other = r
            .robot(if robot == "rover" {
                "ridgeback"
            } else {
                "husky"
            })
            .unwrap();
        assert!(fitted_for
            .refuses(r.robot(robot).unwrap().vehicle.as_ref())
            .is_none());
        let why = fitted_for.refuses(other.vehicle.as_ref()).unwrap();
        assert!(why.contains("it is a twin of a vehicle of type"), "{why}");
        let moved = dir.path().join(format!("{robot}-elsewhere.csv"));
        let moved = moved.to_str().unwrap();
        let args = [
            "simulate",
            "--robot",
            &other.name,
            "--terrain",
            twin_s,
            "--duration",
            "30",
            "--out",
            moved,
        ];
        assert_eq!(status(&args), 1, "{robot}: its twin drives another robot");
        // The fit itself, from the library: the simulator named, the motion matched.
        let spec = r.robot(robot).unwrap();
        let fit = drive::sim::fit_any_vehicle(&r.simulators, &data, &spec, "t").unwrap();
        assert_eq!(
            (fit.report.simulator.as_str(), fit.report.stand_in),
            (simulator, stand_in)
        );
        assert!(fit.report.cost <= fit.report.cost_start, "{:?}", fit.report);
        assert!(fit.report.intervals_compared >= 30, "{:?}", fit.report);
        // The written twin checked on the same data passes.
        assert_eq!(
            status(&[
                "sim-fit",
                "--data",
                csv_s,
                "--robot",
                robot,
                "--twin",
                twin_s,
                "--check-seeds",
                "1"
            ]),
            0,
            "{robot}"
        );
        // Another vehicle type's robot is refused, naming both.
        let other = if robot == "rover" {
            "ridgeback"
        } else {
            "husky"
        };
        let e = drive::sim::check_real_run(&data, &r.robot(other).unwrap()).unwrap_err();
        assert!(
            e.to_string()
                .contains("give the robot the data was recorded with"),
            "{e}"
        );
    }
}

/// Issue 62's acceptance, through the whole command line with the outside parts: the
/// four-wheel-steered rover (no simulator of its own: the kinematic stand-in) and a robot
/// commanded in (v, omega) as a tracked robot is, each written in this file. Every sampler
/// plans its protocol (the angular one steers), two runs on two grounds simulate, the twin
/// of one is fitted, each is evaluated, the two are benchmarked as one robot (a transfer
/// pair both ways), the robot tracks a path on a model fitted on one, and the report draws.
#[test]
fn outside_vehicles_run_every_command_of_the_workflow() {
    let (mut rover_parts, rover) = rover_registries();
    rover_parts
        .robots
        .register("rover", "a rover", Arc::new(rover))
        .unwrap();
    let vehicles = [(rover_parts, "rover"), (registries(), "cmd-vel-robot")];
    std::thread::scope(|scope| {
        for (r, robot) in &vehicles {
            scope.spawn(move || workflow(r, robot));
        }
    });
}

/// The workflow of [`outside_vehicles_run_every_command_of_the_workflow`] for `robot`.
fn workflow(r: &Registries, robot: &str) {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).display().to_string();
    let run = |args: &[&str]| {
        let mut all = vec!["drive"];
        all.extend_from_slice(args);
        assert_eq!(drive::cli::run_status(all, r), 0, "{robot}: {args:?}");
    };
    // Every sampler plans a protocol; the angular one turns (its largest second input, the
    // rover's front steer or the yaw rate, well away from 0).
    for sampler in r.samplers.names() {
        let out = path(&format!("{sampler}.csv"));
        run(&[
            "protocol",
            "--robot",
            robot,
            "--sampler",
            sampler,
            "--intervals",
            "6",
            "--out",
            &out,
        ]);
        let text = std::fs::read_to_string(&out).unwrap();
        let second: f64 = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(4).unwrap().parse::<f64>().unwrap().abs())
            .fold(0.0, f64::max);
        if sampler == "angular" {
            assert!(
                second > 0.1,
                "{robot}: the angular sampler never turns ({second})"
            );
        }
    }
    // Two runs, two grounds.
    let (a, b) = (path("gravel.csv"), path("snow.csv"));
    for (terrain, seed, out) in [("gravel", "1", &a), ("snow", "2", &b)] {
        run(&[
            "simulate",
            "--robot",
            robot,
            "--terrain",
            terrain,
            "--duration",
            "150",
            "--seed",
            seed,
            "--out",
            out,
        ]);
    }
    run(&[
        "sim-fit",
        "--data",
        &a,
        "--robot",
        robot,
        "--out",
        &path("twin.toml"),
        "--check-seeds",
        "1",
    ]);
    run(&["eval", "--data", &a, "--models", "naive,slip-blr"]);
    // The two runs are one robot's: a transfer pair each way.
    let suite = path("suite.toml");
    std::fs::write(
        &suite,
        format!("[[dataset]]\npath = \"{a}\"\n[[dataset]]\npath = \"{b}\"\n"),
    )
    .unwrap();
    let bench = path("bench");
    run(&[
        "bench",
        "--suite",
        &suite,
        "--models",
        "naive,slip-blr",
        "--out",
        &bench,
    ]);
    let v: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("bench/bench.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(
        v["transfer"].as_array().unwrap().len(),
        2 * 2,
        "{robot}: {}",
        v["transfer_skipped"]
    );
    run(&[
        "track",
        "--robot",
        robot,
        "--terrain",
        "gravel",
        "--train-data",
        &a,
        "--models",
        "powertrain,slip-blr",
        "--path",
        "line",
        "--speed",
        "0.5",
        "--samples",
        "128",
        "--out",
        &path("track"),
    ]);
    run(&[
        "report",
        "--data",
        &a,
        "--models",
        "naive,slip-blr",
        "--out",
        &path("report"),
    ]);
    assert!(dir.path().join("report/report.md").exists());
}

/// The report's input-space figure outlines what the rover reaches: at every forward speed
/// its hardest turn, `2 tan(0.5) v_x` with the axles steered apart (an outside check drew a
/// sawtooth a fraction of it: the grid's speed levels left bands only crabs reached).
#[test]
fn the_report_outlines_a_rover_s_turns_at_every_forward_speed() {
    let space = Rover.nominal_input_space(1.0).unwrap();
    let outline = drive::studies::report::analysis::body_polygon(&Rover, &space);
    let hardest = |v_x: f64| 2.0 * 0.5f64.tan() * v_x.abs();
    let upper: Vec<_> = outline
        .iter()
        .filter(|v| v.z > 0.0 && (0.2..=0.9).contains(&v.x))
        .collect();
    assert!(upper.len() >= 20, "{outline:?}");
    for v in upper {
        assert!(
            v.z >= 0.9 * hardest(v.x) && v.z <= hardest(v.x) + 1e-9,
            "at {:.3} m/s the outline turns at {:.3} rad/s, the rover at {:.3}",
            v.x,
            v.z,
            hardest(v.x)
        );
    }
}
