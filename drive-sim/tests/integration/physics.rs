//! The skid-steer physics: the friction ellipse bounds every contact force, turning costs
//! more the longer the contact, the motors' torque limit and asymmetric loop take the
//! wheels out of the first-order class, localization latency, and terrain files.

use drive_models::DifferentialDrive;
use drive_samplers::{builtin_robots, RobotSpec};
use drive_sim::{builtin_terrains, contact_force, Simulator, Terrain, TerrainError};
use drive_traits::{vehicle_as, Input};

fn husky() -> (RobotSpec, DifferentialDrive) {
    let robot = RobotSpec::load(&builtin_robots(), "husky").unwrap();
    let geometry = vehicle_as(robot.vehicle.as_ref()).unwrap();
    (robot, geometry)
}

/// Holds `command` for `seconds`; returns the simulator.
fn hold(sim: &mut Simulator, command: Input, seconds: f64) {
    for _ in 0..(seconds * 20.0).round() as usize {
        sim.advance(command);
    }
}

#[test]
fn contact_forces_stay_on_or_inside_the_friction_ellipse() {
    let t = Terrain::preset("gravel").unwrap();
    let n = 100.0;
    for (surface, vx, vy) in [
        (1.0, 0.0, 0.0),
        (0.0, 1.0, 0.0),
        (2.0, 0.5, 0.7),
        (-1.0, 0.3, -2.0),
        (0.1, 0.1, 0.0),
        (5.0, -5.0, 5.0),
    ] {
        let [fx, fy] = contact_force(&t, n, surface, vx, vy);
        let e = (fx / (t.traction * n)).powi(2) + (fy / (t.lateral * n)).powi(2);
        assert!(e <= 1.0 + 1e-12, "{surface} {vx} {vy}: {e}");
        // Traction pushes the way the wheel surface slides; lateral force opposes drift.
        assert!(fx * (surface - vx) >= 0.0 && fy * vy <= 0.0);
    }
    // A wheel spinning on the spot (slip ratio 1) is on the Janosi-Hanamoto curve there.
    let [fx, fy] = contact_force(&t, n, 10.0, 0.0, 0.0);
    let expected = t.traction * n * (1.0 - (-1.0 / t.slip_modulus).exp());
    assert!(
        (fx - expected).abs() < 1e-9 * n && fy == 0.0,
        "{fx} {expected}"
    );
    assert_eq!(contact_force(&t, n, 1.0, 1.0, 0.0), [0.0, 0.0]);
}

#[test]
fn turning_costs_more_slip_the_longer_the_contact() {
    // The same robot with its axles 0.9 x the baseline apart (the default) and 1.3 x: the
    // wheels scrub sideways over a longer lever, so it turns in place more slowly.
    let (robot, geometry) = husky();
    let yaw_rate = |length: f64| {
        let mut sim = Simulator::new(&robot, &geometry, Terrain::preset("tile").unwrap(), 1);
        sim.params.contacts = vec![length * 0.555 / 2.0, -length * 0.555 / 2.0];
        hold(&mut sim, Input::new(-3.0, 3.0, 0.0), 8.0);
        sim.state().velocity[2]
    };
    let (short, long) = (yaw_rate(0.9), yaw_rate(1.3));
    let ideal = 0.165 * 6.0 / 0.555;
    assert!(long < short && short < ideal, "{long} {short} {ideal}");
    // The slip is large: the effective baseline is well above the geometric one.
    assert!(ideal / short > 1.3, "{}", ideal / short);
    // Tracks (five contact points spread along 1.1 x the baseline) scrub less than two
    // axles at the ends of a contact of the same length: Wong's uniform pressure gives
    // mu W l / 4 against mu W l / 2.
    let mut tracked = robot.clone();
    tracked.tracked = true;
    let mut sim = Simulator::new(&tracked, &geometry, Terrain::preset("tile").unwrap(), 1);
    assert_eq!(sim.params.contacts.len(), 5);
    hold(&mut sim, Input::new(-3.0, 3.0, 0.0), 8.0);
    assert!(sim.state().velocity[2] > short);
}

#[test]
fn a_torque_limit_takes_the_wheels_out_of_the_first_order_class() {
    let (robot, geometry) = husky();
    let terrain = Terrain::preset("tile").unwrap();
    let mut free = Simulator::new(&robot, &geometry, terrain.clone(), 1);
    let mut weak = Simulator::new(&robot, &geometry, terrain, 1);
    weak.params.powertrain.torque_limit *= 0.25;
    // Turning in place on tile: the weak motors stall below the target, the default ones
    // reach it.
    for sim in [&mut free, &mut weak] {
        hold(sim, Input::new(-5.0, 5.0, 0.0), 6.0);
    }
    assert!(
        (free.state().wheels.x + 5.0).abs() < 0.1,
        "{:?}",
        free.state().wheels
    );
    assert!(weak.state().wheels.x > -4.0, "{:?}", weak.state().wheels);
    // Straight ahead the weak motors reach the target too (the load is only rolling
    // resistance once moving): a limit that depends on the manoeuvre, not a gain.
    hold(&mut weak, Input::new(5.0, 5.0, 0.0), 8.0);
    assert!(
        (weak.state().wheels.x - 5.0).abs() < 0.2,
        "{:?}",
        weak.state().wheels
    );
}

#[test]
fn the_velocity_loop_slows_down_faster_than_it_speeds_up() {
    let (robot, geometry) = husky();
    let mut sim = Simulator::new(&robot, &geometry, Terrain::preset("tile").unwrap(), 1);
    assert!(sim.params.powertrain.time_constant[1] < sim.params.powertrain.time_constant[0]);
    // 1 s after the dead time of a step up, and of a step down.
    hold(&mut sim, Input::new(4.0, 4.0, 0.0), 1.3);
    let up = sim.state().wheels.x / 4.0;
    hold(&mut sim, Input::new(4.0, 4.0, 0.0), 8.0);
    hold(&mut sim, Input::zeros(), 1.3);
    let down = 1.0 - sim.state().wheels.x / 4.0;
    assert!(down > up + 0.02, "{up} {down}");
}

#[test]
fn localization_latency_delays_the_pose() {
    let (robot, geometry) = husky();
    let mut on_time = Simulator::new(&robot, &geometry, Terrain::preset("tile").unwrap(), 1);
    let mut late_terrain = Terrain::preset("tile").unwrap();
    late_terrain.sensors = Some(drive_sim::Sensors {
        icp_latency: 0.2,
        icp_noise: [0.0, 0.0],
        ..Default::default()
    });
    let mut late = Simulator::new(&robot, &geometry, late_terrain, 1);
    on_time.instruments.sensors.icp_noise = [0.0, 0.0];
    let (mut a, mut b) = (0.0, 0.0);
    for _ in 0..100 {
        on_time.advance(Input::new(4.0, 4.0, 0.0));
        late.advance(Input::new(4.0, 4.0, 0.0));
        a = on_time.measure().pose.x;
        b = late.measure().pose.x;
    }
    // About 0.2 s of driving behind (the robot moves at ~0.6 m/s by then).
    assert!(a - b > 0.05 && a - b < 0.25, "{a} {b}");
}

#[test]
fn terrain_files_round_trip_and_refuse_bad_values() {
    let mut t = Terrain::preset("snow").unwrap();
    t.name = "twin".into();
    t.protocol = Some(drive_sim::TwinProtocol {
        baseline: 0.3,
        input_limits: [[-10.0, 10.0], [-9.0, 11.0]],
        max_linear_acceleration: None,
        max_angular_acceleration: Some(4.0),
        body_limits: Some([[-1.0, 1.5], [-2.0, 2.0]]),
        robot_wheel_radius: 0.165,
        robot_baseline: 0.55,
    });
    t.sensors = Some(drive_sim::Sensors::default());
    let back = Terrain::from_toml("t.toml", &t.to_toml()).unwrap();
    assert_eq!(back, t);
    let text = t.to_toml();
    for (bad, field) in [
        (
            text.replace("traction = 0.3", "traction = -0.3"),
            "traction",
        ),
        (text.replace("name = \"twin\"", "name = \"\""), "name"),
        (
            text.replace("name = \"twin\"", "name = \"a\\nb\""),
            "name",
        ),
        (
            text.replace("name = \"twin\"", &format!("name = \"{}\"", "x".repeat(201))),
            "name",
        ),
        (
            text.replace("slip_modulus = 0.2", "slip_modulus = nan"),
            "slip_modulus",
        ),
        (
            text.replace("icp_rate_hz = 10.0", "icp_rate_hz = 0.0"),
            "sensors.icp_rate_hz",
        ),
        (
            text.replace(
                "imu_bias = 0.005",
                "imu_bias = 0.005\nicp_gaps = [0.5, -0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]",
            ),
            "sensors.icp_gaps",
        ),
        (
            text.replace("[-9.0, 11.0]", "[11.0, -9.0]"),
            "protocol.input_limits",
        ),
        (
            text.replace("[-2.0, 2.0]", "[2.0, inf]"),
            "protocol.body_limits",
        ),
        (
            text.replace("baseline = 0.3", "baseline = 0.0"),
            "protocol.baseline",
        ),
        // Forward speeds of 3-4 m/s, where the box reaches at most 0.165 * 10.5 = 1.7 m/s.
        (
            text.replace("[-1.0, 1.5]", "[3.0, 4.0]"),
            "protocol.body_limits",
        ),
    ] {
        match Terrain::from_toml("t.toml", &bad) {
            Err(TerrainError::Invalid { field: f, .. }) => assert_eq!(f, field),
            other => panic!("{field}: {other:?}"),
        }
    }
    assert!(matches!(
        Terrain::from_toml("t.toml", &format!("{text}\nwetness = 3\n")),
        Err(TerrainError::Parse { .. })
    ));
    // The sensors' arrays hold exactly their number of values: a longer one is refused,
    // not cut short.
    let twenty_one = format!("[{}]", ["0.05"; 21].join(", "));
    for (bad, what) in [
        (
            text.replace(
                "imu_bias = 0.005",
                &format!("imu_bias = 0.005\nicp_gaps = {twenty_one}"),
            ),
            "invalid length 21, expected 20",
        ),
        (
            text.replace(
                "icp_mount = [0.0, 0.0, 0.0]",
                "icp_mount = [0.0, 0.0, 0.0, 1.0]",
            ),
            "invalid length 4, expected 3",
        ),
    ] {
        assert_ne!(bad, text, "{what}: the replacement must apply");
        match Terrain::from_toml("t.toml", &bad) {
            Err(e @ TerrainError::Parse { .. }) => {
                let e = e.to_string();
                assert!(e.contains(what), "{e}");
            }
            other => panic!("{what}: {other:?}"),
        }
    }
    // A preset by name, a file by path, and neither.
    let terrains = builtin_terrains();
    assert_eq!(
        Terrain::load(&terrains, "ice").unwrap(),
        Terrain::preset("ice").unwrap()
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("twin.toml");
    std::fs::write(&path, t.to_toml()).unwrap();
    assert_eq!(Terrain::load(&terrains, path.to_str().unwrap()).unwrap(), t);
    let err = Terrain::load(&terrains, "mud").unwrap_err().to_string();
    assert!(err.contains("mud") && err.contains("tile"), "{err}");
}

#[test]
fn a_plant_driven_onto_another_ground_drives_as_one_made_on_it_and_keeps_its_robot() {
    use drive_sim::Plant;
    let (robot, g) = husky();
    let (gravel, snow) = (
        Terrain::preset("gravel").unwrap(),
        Terrain::preset("snow").unwrap(),
    );
    // A turn held: the yaw rate a ground lets the robot reach differs most between grounds.
    let turn = Input::new(2.0, 6.0, 0.0);
    let yaw_over_last_2_s = |sim: &mut Simulator| {
        let a = sim.true_pose().unwrap().z;
        hold(sim, turn, 2.0);
        (sim.true_pose().unwrap().z - a) / 2.0
    };
    let mut stays = Simulator::new(&robot, &g, gravel.clone(), 3);
    let mut changes = Simulator::new(&robot, &g, gravel.clone(), 3);
    let mut made_on_snow = Simulator::new(&robot, &g, snow.clone(), 3);
    hold(&mut stays, turn, 4.0);
    hold(&mut changes, turn, 4.0);
    changes.change_ground(&snow).unwrap();
    assert_eq!(changes.terrain.name, "snow");
    hold(&mut stays, turn, 6.0);
    hold(&mut changes, turn, 6.0);
    hold(&mut made_on_snow, turn, 10.0);
    let (on_gravel, changed, on_snow) = (
        yaw_over_last_2_s(&mut stays),
        yaw_over_last_2_s(&mut changes),
        yaw_over_last_2_s(&mut made_on_snow),
    );
    assert!(
        (on_gravel - on_snow).abs() > 0.05 * on_gravel.abs(),
        "the presets should turn differently: {on_gravel} {on_snow}"
    );
    assert!(
        (changed - on_snow).abs() < 0.2 * (on_gravel - on_snow).abs(),
        "changed onto snow {changed}, made on snow {on_snow}, gravel {on_gravel}"
    );
    // A twin's robot stays the twin's: its powertrain is kept across the change.
    let mut twin = gravel.clone();
    let mut slow = drive_sim::PowertrainParams::for_robot(&robot, g.wheel_radius);
    slow.wheel_limit = 3.0;
    twin.powertrain = Some(slow);
    let mut sim = Simulator::new(&robot, &g, twin, 3);
    sim.change_ground(&snow).unwrap();
    assert_eq!(sim.params.powertrain.wheel_limit, 3.0);
    assert_eq!(sim.terrain.powertrain.map(|p| p.wheel_limit), Some(3.0));
}
