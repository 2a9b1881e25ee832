//! The raw logger CSV: what real logs contain is read, every unusable interval is dropped
//! with its reason, and the bench log says that it has no localization.

use drive_data::{
    import_raw, parse_raw_log, read_raw_log, write_raw_log, CalibState, DataErrorKind, DropReason,
    ImportConfig, RawLog, RawRow, RAW_COLUMNS,
};
use drive_traits::RobotDescription;
use std::path::Path;

fn warthog() -> RobotDescription {
    RobotDescription::new(
        "bench",
        "warthog",
        20.0,
        40,
        drive_traits::vehicles::DifferentialDrive::new(0.3, 1.1652),
    )
}

/// `n` ticks of driving interval `step` at 1 m/s straight ahead, localized at 10 Hz.
fn drive(rows: &mut Vec<RawRow>, step: u64, n: usize) {
    for _ in 0..n {
        let (t, x, icp) = match rows.last() {
            Some(r) => (r.time_ns + 50_000_000, r.position[0] + 0.05, r.icp_index),
            None => (1_000_000_000, 0.0, 0),
        };
        let mut r = RawRow::at_rest(rows.len() + 2, t);
        r.calib_state = CalibState::Calib;
        r.calib_step = step;
        r.body_command = [1.0, 0.0];
        r.measured = drive_traits::Input::new(3.3, 3.3, 0.0);
        // The pose is held between 10 Hz updates.
        let update = rows.len() % 2 == 0;
        r.icp_index = icp + u64::from(update);
        r.position = [
            if update {
                x
            } else {
                rows.last().map_or(0.0, |p| p.position[0])
            },
            0.0,
            0.0,
        ];
        rows.push(r);
    }
}

fn import(rows: Vec<RawRow>) -> (drive_traits::Dataset, drive_data::ImportReport) {
    let log = RawLog {
        file: "log.csv".into(),
        rows,
        extra_columns: vec![],
        placeholder_rows: 0,
    };
    import_raw(&log, &warthog(), &ImportConfig::default()).unwrap()
}

#[test]
fn clean_intervals_are_cut_into_one_transient_and_two_steady_windows() {
    let mut rows = Vec::new();
    drive(&mut rows, 0, 121);
    drive(&mut rows, 1, 121);
    let (data, report) = import(rows);
    assert_eq!(report.windows_kept(), 6);
    assert_eq!(data.windows.len(), 6);
    let phases: Vec<_> = data.windows.iter().map(|w| w.phase.as_str()).collect();
    assert_eq!(
        phases,
        [
            "transient",
            "steady",
            "steady",
            "transient",
            "steady",
            "steady"
        ]
    );
    for w in &data.windows {
        assert_eq!(w.len(), 40);
        assert_eq!(w.pose[0].x, 0.0);
        // 1 m/s on 0.3 m wheels; the held poses advance 0.1 m every other sample.
        assert!((w.command[0].x - 1.0 / 0.3).abs() < 1e-12);
        assert!((w.pose[39].x - w.pose[38].x).abs() < 0.11);
    }
}

#[test]
fn every_unusable_interval_is_dropped_with_its_reason() {
    let mut rows = Vec::new();
    // 0: the operator takes over 2 s in and hands back; 6 s follow: kept.
    drive(&mut rows, 0, 40);
    for r in rows.iter_mut().skip(30) {
        r.joy_switch = true;
    }
    drive(&mut rows, 0, 125);
    let n = rows.len();
    for r in &mut rows[40..n] {
        r.joy_switch = false;
    }
    for r in &mut rows[30..45] {
        r.joy_switch = true;
    }
    // 1: a 0.6 s gap in the middle.
    let start = rows.len();
    drive(&mut rows, 1, 121);
    for r in &mut rows[start + 60..] {
        r.time_ns += 600_000_000;
    }
    // 2: localization frozen for 1 s.
    let start = rows.len();
    drive(&mut rows, 2, 121);
    let frozen = rows[start + 50].clone();
    for r in &mut rows[start + 51..start + 71] {
        r.icp_index = frozen.icp_index;
        r.position = frozen.position;
    }
    // 3: cut short at 4 s.
    drive(&mut rows, 3, 80);
    let (data, report) = import(rows);
    let outcomes: Vec<_> = report.steps.iter().map(|s| s.outcome).collect();
    assert_eq!(outcomes[0], Ok(0), "{}", report.to_text());
    assert!(
        matches!(outcomes[1], Err(DropReason::TimeGap { gap_s, .. }) if (gap_s - 0.65).abs() < 1e-6)
    );
    assert!(
        matches!(outcomes[2], Err(DropReason::LocalizationFrozen { for_s, .. }) if for_s > 1.0)
    );
    assert!(
        matches!(outcomes[3], Err(DropReason::TooShort { lasted_s }) if (lasted_s - 4.0).abs() < 1e-6)
    );
    assert_eq!(data.windows.len(), 3);
    assert_eq!(report.windows_dropped(), 9);
    assert_eq!(
        report.dropped_by_reason(),
        [
            ("time_gap", 3),
            ("localization_frozen", 3),
            ("too_short", 3)
        ]
    );
    // The kept interval is the stretch after the takeover, starting with its first row.
    assert_eq!(data.windows[0].measured.len(), 40);
    assert!(
        report.notes[0].contains("calib_step 0 lasts"),
        "{:?}",
        report.notes
    );
}

#[test]
fn the_bench_log_has_no_localization_and_says_so() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/raw_log_warthog_bench.csv");
    let log = read_raw_log(&path, &RAW_COLUMNS).unwrap();
    assert_eq!(log.placeholder_rows, 1);
    assert_eq!(log.rows.len(), 1037);
    assert_eq!(log.extra_columns.len(), 7);
    assert!(log.rows.iter().all(|r| !r.joy_switch));
    assert_eq!(log.rows[0].calib_state, CalibState::Unset);
    let (data, report) = import_raw(&log, &warthog(), &ImportConfig::default()).unwrap();
    assert!(data.windows.is_empty());
    assert_eq!(report.steps.len(), 3);
    assert!(report
        .steps
        .iter()
        .all(|s| s.outcome == Err(DropReason::LocalizationMissing)));
    assert!((report.steps[2].lasted_s - 19.55).abs() < 0.01);
    let why = report.nothing_usable().unwrap();
    assert!(why.contains("localization is all zeros"), "{why}");
    assert!(report.notes[0].contains("calib_step 2 lasts 19.55 s"));
}

#[test]
fn written_logs_read_back_the_same() {
    let mut rows = Vec::new();
    drive(&mut rows, 0, 10);
    rows[3].joy_switch = true;
    rows[4].calib_state = CalibState::Unset;
    rows[5].extra = vec![Some(1.5), None];
    for r in &mut rows {
        r.extra.resize(2, None);
    }
    let extra = vec!["volts".to_string(), "amps".to_string()];
    let mut text = String::new();
    write_raw_log(&rows, &RAW_COLUMNS, &extra, &mut text);
    let log = parse_raw_log("w.csv", &text, &RAW_COLUMNS).unwrap();
    assert_eq!(log.rows, rows);
    assert_eq!(log.extra_columns, extra);
}

#[test]
fn messy_values_of_real_logs_are_read() {
    let header = drive_data::RAW_COLUMNS.join(",");
    let text = format!(
        "{header}\n0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0\n\
         1720641663279670820,False,0.0,,2.0,0.5,0.5,0.0,0.0,0,0,0,0,0,0,1,0,0,0\r\n\
         1.7206416633e18,true,1,calib,2,0.5,0.5,0.1,0.0,0,0,0,0,0,0,1,0,0,0\n"
    );
    let log = parse_raw_log("m.csv", &text, &RAW_COLUMNS).unwrap();
    assert_eq!(log.rows.len(), 2);
    assert_eq!(log.rows[0].calib_step, 2);
    assert_eq!(log.rows[0].calib_state, CalibState::Unset);
    assert!(log.rows[1].joy_switch);
    assert_eq!(log.rows[1].time_ns, 1_720_641_663_300_000_000);
}

type KindCheck = fn(&DataErrorKind) -> bool;

#[test]
fn bad_raw_logs_are_refused_with_line_and_column() {
    let header = drive_data::RAW_COLUMNS.join(",");
    let row = "1000,False,0,calib,0,0,0,0,0,0,0,0,0,0,0,1,0,0,0";
    let cases: [(String, usize, &str, KindCheck); 6] = [
        (
            format!("{header}\n{}", row.replace("False", "maybe")),
            2,
            "joy_switch",
            |k| matches!(k, DataErrorKind::NotABoolean(_)),
        ),
        (
            format!("{header}\n{}", row.replace(",calib,0,", ",calib,1.5,")),
            2,
            "calib_step",
            |k| matches!(k, DataErrorKind::NotAnInteger(_)),
        ),
        (
            format!("{header}\n{row}\n{}", row.replace("1000,", "999,")),
            3,
            "ros_time",
            |k| matches!(k, DataErrorKind::Inconsistent(m) if m.contains("goes back")),
        ),
        (
            format!("{header}\n{}", row.replace(",1,0,0,0", ",NaN,0,0,0")),
            2,
            "icp_quat_w",
            |k| matches!(k, DataErrorKind::NotFinite(_)),
        ),
        (header.replace(",imu_z", ""), 1, "imu_z", |k| {
            matches!(k, DataErrorKind::MissingColumn(_))
        }),
        (format!("{header}\n{row},7"), 2, "", |k| {
            matches!(
                k,
                DataErrorKind::FieldCount {
                    expected: 19,
                    found: 20
                }
            )
        }),
    ];
    for (text, line, column, kind) in cases {
        let err = parse_raw_log("bad.csv", &text, &RAW_COLUMNS).unwrap_err();
        assert_eq!(err.location.line, Some(line), "{err}");
        if !column.is_empty() {
            assert_eq!(err.location.field.as_deref(), Some(column), "{err}");
        }
        assert!(kind(&err.kind), "{err}");
    }
}

#[test]
fn a_robot_too_slow_for_two_samples_per_window_is_refused() {
    let mut rows = Vec::new();
    drive(&mut rows, 0, 10);
    let log = RawLog {
        file: "log.csv".into(),
        rows,
        extra_columns: vec![],
        placeholder_rows: 0,
    };
    let robot = RobotDescription {
        rate_hz: 0.4,
        window_len: 1,
        ..warthog()
    };
    let err = import_raw(&log, &robot, &ImportConfig::default()).unwrap_err();
    assert!(err.to_string().contains("at least 2 are needed"), "{err}");
}
