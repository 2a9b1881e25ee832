//! The protocol runner with the simulator in the loop: characterization, dead-man pause
//! and resume, watchdog, geofence, convergence stop, determinism.

use drive_samplers::{
    builtin_robots, PauseReason, RobotSpec, RunnerConfig, RunnerState, StopReason,
};
use drive_sim::{
    builtin_plants, simulate, Event, Simulation, SimulationConfig, Simulator, Terrain,
};
use drive_traits::Phase;

fn run(
    terrain: &str,
    runner: RunnerConfig,
    events: Vec<Event>,
    seed: u64,
    converged: Option<Box<dyn FnMut(usize) -> bool>>,
) -> Simulation {
    run_on("husky", terrain, runner, events, seed, converged)
}

fn run_on(
    preset: &str,
    terrain: &str,
    runner: RunnerConfig,
    events: Vec<Event>,
    seed: u64,
    converged: Option<Box<dyn FnMut(usize) -> bool>>,
) -> Simulation {
    let robot = RobotSpec::load(&builtin_robots(), preset).unwrap();
    let factory = crate::uniform(robot.clone(), seed);
    let config = SimulationConfig {
        robot,
        terrain: Terrain::preset(terrain).unwrap(),
        seed,
        runner,
        events,
        name: "test".into(),
    };
    simulate(config, &builtin_plants(), factory, converged).unwrap()
}

/// `r (w_r - w_l) / yaw rate` of the plant's true state after 8 s turning in place at
/// `wheel` rad/s (the last second averaged).
fn effective_baseline(preset: &str, terrain: &str, wheel: f64) -> f64 {
    let robot = RobotSpec::load(&builtin_robots(), preset).unwrap();
    let geometry: drive_models::DifferentialDrive =
        drive_traits::vehicle_as(robot.vehicle.as_ref()).unwrap();
    let mut sim = Simulator::new(&robot, &geometry, Terrain::preset(terrain).unwrap(), 1);
    let (mut diff, mut yaw) = (0.0, 0.0);
    for k in 0..160 {
        sim.advance(drive_traits::Input::new(-wheel, wheel, 0.0));
        if k >= 140 {
            let s = sim.state();
            diff += geometry.wheel_radius * (s.wheels.y - s.wheels.x);
            yaw += s.velocity[2];
        }
    }
    diff / yaw
}

fn first_pause(sim: &Simulation) -> &(f64, RunnerState) {
    sim.states
        .iter()
        .find(|(_, s)| matches!(s, RunnerState::Paused { .. }))
        .expect("a pause")
}

fn states(sim: &Simulation) -> Vec<&RunnerState> {
    sim.states.iter().map(|(_, s)| s).collect()
}

#[test]
fn characterization_finds_the_true_input_space_and_geometry() {
    let sim = run(
        "tile",
        RunnerConfig {
            max_intervals: Some(2),
            ..RunnerConfig::default()
        },
        vec![],
        1,
        None,
    );
    let c = sim.characterization.unwrap();
    // The simulated Husky's wheels saturate at 1 m/s / 0.165 m = 6.06 rad/s.
    for v in [c.space.max.x, c.space.max.y, -c.space.min.x, -c.space.min.y] {
        assert!((v - 6.06).abs() < 0.1, "{v}");
    }
    let radius = c.geometry("wheel_radius").unwrap();
    assert!((radius - 0.165).abs() < 0.01, "{radius}");
    // Skid makes the effective baseline larger than the geometric one: it is the plant's,
    // measured here on the true state turning in place at half the top wheel speed (the
    // characterization's turn probe).
    let b = c.geometry("baseline").unwrap();
    let truth = effective_baseline("husky", "tile", 3.03);
    assert!(truth > 0.6, "{truth}");
    assert!((b - truth).abs() < 0.1 * truth, "{b} vs {truth}");
    assert_eq!(sim.stop, RunnerState::Done(StopReason::Intervals));
    assert_eq!(sim.dataset.windows.len(), 6);
}

#[test]
fn characterization_of_a_fast_turning_robot_unwraps_the_yaw() {
    // The Warthog turns in place at about 4 rad/s, more than half a turn in the averaged
    // second: a baseline from the wrapped yaw difference would come out negative.
    for terrain in Terrain::NAMES {
        let config = RunnerConfig {
            max_intervals: Some(1),
            ..RunnerConfig::default()
        };
        let sim = run_on("warthog", terrain, config, vec![], 1, None);
        let b = sim.characterization.unwrap().geometry("baseline").unwrap();
        assert!(b > 0.9 && b < 2.5, "{terrain}: {b}");
    }
}

#[test]
fn deadman_release_pauses_with_zero_command_and_resumes_the_interval_from_its_transient_window() {
    // Characterization takes 24 s; release the switch 3 s into the second interval.
    let (from, to) = (24.0 + 6.0 + 3.0, 24.0 + 6.0 + 5.0);
    let sim = run(
        "tile",
        RunnerConfig {
            max_intervals: Some(3),
            ..RunnerConfig::default()
        },
        vec![Event::DeadmanReleased { from, to }],
        2,
        None,
    );
    let paused = first_pause(&sim);
    assert!(matches!(
        paused.1,
        RunnerState::Paused {
            reason: PauseReason::DeadmanReleased,
            interval: 1
        }
    ));
    assert!((paused.0 - from).abs() < 0.1);
    // Zero command while released.
    for k in ((from * 20.0) as usize + 1)..((to * 20.0) as usize) {
        assert_eq!(sim.commands[k], drive_traits::Input::zeros(), "tick {k}");
    }
    // The interrupted interval was driven again in full: three complete intervals.
    assert_eq!(sim.dataset.windows.len(), 9);
    let phases: Vec<Phase> = sim.dataset.windows.iter().map(|w| w.phase).collect();
    assert_eq!(phases.iter().filter(|p| **p == Phase::Transient).count(), 3);
    assert!(phases
        .chunks(3)
        .all(|c| c == [Phase::Transient, Phase::Steady, Phase::Steady]));
    // Resumed with the same target: the second interval's commands converge to one input.
    let w = &sim.dataset.windows[5];
    assert_eq!(w.command[0], w.command[39]);
    assert_eq!(sim.stop, RunnerState::Done(StopReason::Intervals));
}

#[test]
fn stale_localization_pauses_and_the_run_resumes() {
    let sim = run(
        "snow",
        RunnerConfig {
            max_intervals: Some(2),
            ..RunnerConfig::default()
        },
        vec![Event::LocalizationLost {
            from: 27.0,
            to: 29.0,
        }],
        3,
        None,
    );
    let paused = first_pause(&sim);
    assert!(matches!(
        paused.1,
        RunnerState::Paused {
            reason: PauseReason::LocalizationStale,
            ..
        }
    ));
    // Paused once the data is older than the 0.5 s timeout.
    assert!(paused.0 > 27.4 && paused.0 < 27.7, "{}", paused.0);
    assert_eq!(sim.dataset.windows.len(), 6);
}

#[test]
fn leaving_the_geofence_stops_with_a_reason() {
    let sim = run(
        "tile",
        RunnerConfig {
            geofence_radius_m: Some(3.0),
            max_duration_s: Some(600.0),
            ..RunnerConfig::default()
        },
        vec![],
        4,
        None,
    );
    match &sim.stop {
        RunnerState::Done(StopReason::Geofence { distance }) => {
            assert!(*distance > 3.0 && *distance < 3.2)
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(*sim.commands.last().unwrap(), drive_traits::Input::zeros());
}

#[test]
fn convergence_stops_the_protocol() {
    let sim = run(
        "gravel",
        RunnerConfig {
            max_duration_s: Some(600.0),
            ..RunnerConfig::default()
        },
        vec![],
        5,
        Some(Box::new(|done| done >= 4)),
    );
    assert_eq!(sim.stop, RunnerState::Done(StopReason::Converged));
    assert_eq!(sim.dataset.windows.len(), 12);
    assert!(states(&sim)
        .iter()
        .any(|s| matches!(s, RunnerState::Characterizing { .. })));
}

#[test]
fn same_seed_same_log() {
    let write = |seed| {
        let sim = run(
            "snow",
            RunnerConfig {
                max_duration_s: Some(90.0),
                ..RunnerConfig::default()
            },
            vec![],
            seed,
            None,
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(format!("s{seed}.csv"));
        drive_data::write_dataset(&sim.dataset, &path).unwrap();
        std::fs::read(&path).unwrap()
    };
    assert_eq!(write(7), write(7));
    assert_ne!(write(7), write(8));
}
