//! Simulate -> raw log -> import gives the simulator's own windows: the proof that import
//! cuts, resamples and re-bases correctly (the real raw logs available have no
//! localization).

use drive_data::{import_raw, parse_raw_log, write_raw_log, DropReason, ImportConfig, RAW_COLUMNS};
use drive_samplers::{builtin_robots, RobotSpec};
use drive_sim::{builtin_plants, simulate, Event, Simulation, SimulationConfig};

fn run(events: Vec<Event>, max_intervals: usize) -> Simulation {
    let robot = RobotSpec::load(&builtin_robots(), "husky").unwrap();
    let factory = crate::uniform(robot.clone(), 4);
    let config = SimulationConfig {
        events,
        ..crate::config(robot, "gravel", 4, max_intervals, "round-trip")
    };
    simulate(config, &builtin_plants(), factory, None).unwrap()
}

#[test]
fn simulate_raw_log_import_gives_the_simulators_windows() {
    // Characterization takes 24 s; interval k starts at 24 + 6k s (before any pause).
    let events = vec![
        // Released 3 s into interval 1 for 2 s: the operator takes over.
        Event::DeadmanReleased {
            from: 33.0,
            to: 35.0,
        },
        // Localization lost 1 s into interval 3 (which starts at 41 s) for 1.5 s.
        Event::LocalizationLost {
            from: 42.0,
            to: 43.5,
        },
    ];
    let sim = run(events, 6);
    assert_eq!(sim.dataset.windows.len(), 18);
    let mut text = String::new();
    write_raw_log(&sim.raw, &RAW_COLUMNS, &[], &mut text);
    let log = parse_raw_log("sim.csv", &text, &RAW_COLUMNS).unwrap();
    assert!(log.rows.iter().any(|r| r.joy_switch));
    let (data, report) = import_raw(&log, &sim.dataset.robot, &ImportConfig::default()).unwrap();
    assert_eq!(report.windows_kept(), 18, "{}", report.to_text());
    assert_eq!(report.windows_dropped(), 0, "{}", report.to_text());
    // The two interrupted intervals last longer than 6 s and are noted.
    assert_eq!(report.notes.len(), 2, "{:?}", report.notes);
    assert_eq!(data.windows.len(), sim.dataset.windows.len());
    for (a, b) in data.windows.iter().zip(&sim.dataset.windows) {
        assert_eq!(
            (a.index, a.interval, a.phase),
            (b.index, b.interval, b.phase)
        );
        assert_eq!(a.measured, b.measured);
        assert_eq!(a.imu_yaw_rate, b.imu_yaw_rate);
        for (u, v) in a.command.iter().zip(&b.command) {
            assert!((u - v).norm() < 1e-9, "{u} {v}");
        }
        for (p, q) in a.pose.iter().zip(&b.pose) {
            assert!((p - q).norm() < 1e-9, "{p} {q}");
        }
    }
}

#[test]
fn a_takeover_without_a_full_interval_after_it_is_reported() {
    // Released 3 s into interval 2 and never pressed again before the run ends.
    let sim = run(
        vec![Event::DeadmanReleased {
            from: 39.0,
            to: 1e9,
        }],
        4,
    );
    let mut text = String::new();
    write_raw_log(&sim.raw, &RAW_COLUMNS, &[], &mut text);
    let log = parse_raw_log("sim.csv", &text, &RAW_COLUMNS).unwrap();
    let (data, report) = import_raw(&log, &sim.dataset.robot, &ImportConfig::default()).unwrap();
    assert_eq!(data.windows.len(), 6);
    let last = report.steps.last().unwrap();
    assert_eq!(last.calib_step, 2);
    assert!(
        matches!(last.outcome, Err(DropReason::OperatorTakeover { .. })),
        "{:?}",
        last.outcome
    );
}
