//! Every kind of bad window-CSV or sidecar input gives a typed error naming the file, the
//! line and the column (or the sidecar field). None panics.

use drive_data::{parse_dataset, read_dataset, DataErrorKind};

const SIDECAR: &str =
    r#"{"name": "t", "rate_hz": 20, "window_len": 3, "wheel_radius": 0.1, "baseline": 0.5}"#;
const HEADER: &str =
    "window,calib_step,phase,k,t,cmd_left,cmd_right,enc_left,enc_right,x,y,yaw,imu_yaw_rate";

fn row(window: usize, phase: &str, k: usize) -> String {
    format!(
        "{window},0,{phase},{k},{},1,1,0.5,0.5,{},0,0,0",
        k as f64 * 0.05,
        0.01 * k as f64
    )
}

fn good() -> Vec<String> {
    let mut lines = vec![HEADER.to_string()];
    for w in 0..3 {
        for k in 0..3 {
            lines.push(row(w, if w == 0 { "transient" } else { "steady" }, k));
        }
    }
    lines
}

fn parse(lines: &[String]) -> Result<drive_traits::Dataset, drive_data::DataError> {
    parse_dataset("d.csv", &(lines.join("\n") + "\n"), "d.json", SIDECAR)
}

/// Asserts the error's kind, line and column, and that the message names the file.
fn expect(
    lines: &[String],
    line: Option<usize>,
    column: Option<&str>,
    kind: fn(&DataErrorKind) -> bool,
) {
    let err = parse(lines).expect_err("bad input must be refused");
    assert!(kind(&err.kind), "unexpected kind: {err}");
    assert_eq!(err.location.line, line, "{err}");
    assert_eq!(err.location.field.as_deref(), column, "{err}");
    assert!(err.to_string().starts_with("d.csv"), "{err}");
}

#[test]
fn good_input_parses_with_intervals() {
    let d = parse(&good()).unwrap();
    assert_eq!(d.windows.len(), 3);
    assert_eq!(d.interval_count(), 1);
    assert!((d.windows[1].pose[2].x - 0.02).abs() < 1e-15);
}

#[test]
fn missing_column() {
    let mut l = good();
    l[0] = l[0].replace(",imu_yaw_rate", "");
    expect(&l, Some(1), Some("imu_yaw_rate"), |k| {
        matches!(k, DataErrorKind::MissingColumn(_))
    });
}

#[test]
fn unknown_column() {
    let mut l = good();
    l[0] = l[0].replace("imu_yaw_rate", "imu_yaw");
    expect(&l, Some(1), Some("imu_yaw"), |k| {
        matches!(k, DataErrorKind::UnknownColumn(_))
    });
}

#[test]
fn duplicate_column() {
    let mut l = good();
    l[0] = l[0].replace("calib_step", "x");
    expect(&l, Some(1), Some("x"), |k| {
        matches!(k, DataErrorKind::DuplicateColumn)
    });
}

#[test]
fn non_numeric_value() {
    let mut l = good();
    l[5] = l[5].replace(",1,1,", ",1,abc,");
    expect(
        &l,
        Some(6),
        Some("cmd_right"),
        |k| matches!(k, DataErrorKind::NotANumber(v) if v == "abc"),
    );
}

#[test]
fn nan_value() {
    let mut l = good();
    l[2] = l[2].replace(",0.5,0.5,", ",NaN,0.5,");
    expect(&l, Some(3), Some("enc_left"), |k| {
        matches!(k, DataErrorKind::NotFinite(_))
    });
}

#[test]
fn infinite_value() {
    let mut l = good();
    l[4] = format!("{},inf", l[4].rsplit_once(',').unwrap().0);
    expect(&l, Some(5), Some("imu_yaw_rate"), |k| {
        matches!(k, DataErrorKind::NotFinite(_))
    });
}

#[test]
fn window_with_too_few_samples() {
    let mut l = good();
    l.remove(5); // window 1, k = 1
    expect(&l, Some(6), Some("k"), |k| {
        matches!(
            k,
            DataErrorKind::SampleOutOfOrder {
                window: 1,
                expected: 1,
                found: 2
            }
        )
    });
    let mut l = good();
    l.remove(6); // window 1, k = 2: the window ends short
    expect(&l, Some(6), None, |k| {
        matches!(
            k,
            DataErrorKind::WrongWindowLength {
                window: 1,
                expected: 3,
                found: 2
            }
        )
    });
}

#[test]
fn window_with_too_many_samples() {
    let mut l = good();
    l.insert(4, row(0, "transient", 3));
    expect(&l, Some(5), Some("k"), |k| {
        matches!(
            k,
            DataErrorKind::WrongWindowLength {
                window: 0,
                expected: 3,
                found: 4
            }
        )
    });
}

#[test]
fn samples_out_of_order() {
    let mut l = good();
    l.swap(2, 3);
    expect(&l, Some(3), Some("k"), |k| {
        matches!(
            k,
            DataErrorKind::SampleOutOfOrder {
                window: 0,
                expected: 1,
                found: 2
            }
        )
    });
}

#[test]
fn windows_out_of_order() {
    let mut l = good();
    for k in 0..3 {
        l[7 + k] = row(0, "steady", k);
    }
    expect(&l, Some(8), Some("window"), |k| {
        matches!(
            k,
            DataErrorKind::WindowOutOfOrder {
                previous: 1,
                found: 0
            }
        )
    });
}

#[test]
fn phase_changes_inside_a_window() {
    let mut l = good();
    l[3] = l[3].replace("transient", "steady");
    expect(&l, Some(4), Some("phase"), |k| {
        matches!(k, DataErrorKind::PhaseChangesInWindow(0))
    });
}

#[test]
fn unknown_phase() {
    let mut l = good();
    l[1] = l[1].replace("transient", "warmup");
    expect(&l, Some(2), Some("phase"), |k| {
        matches!(k, DataErrorKind::BadPhase(_))
    });
}

#[test]
fn wrong_field_count() {
    let mut l = good();
    l[3].push_str(",9");
    expect(&l, Some(4), None, |k| {
        matches!(
            k,
            DataErrorKind::FieldCount {
                expected: 13,
                found: 14
            }
        )
    });
}

#[test]
fn fractional_index() {
    let mut l = good();
    l[2] = l[2].replacen("0,0,transient,1", "0,0,transient,1.5", 1);
    expect(&l, Some(3), Some("k"), |k| {
        matches!(k, DataErrorKind::NotAnInteger(_))
    });
}

#[test]
fn empty_file() {
    expect(&[], None, None, |k| matches!(k, DataErrorKind::Empty));
    expect(&[HEADER.to_string()], None, None, |k| {
        matches!(k, DataErrorKind::Empty)
    });
}

#[test]
fn time_inconsistent_with_the_sidecar_rate() {
    let side = SIDECAR.replace("\"rate_hz\": 20", "\"rate_hz\": 10");
    let err = parse_dataset("d.csv", &good().join("\n"), "d.json", &side).unwrap_err();
    assert!(
        matches!(err.kind, DataErrorKind::TimeMismatch { .. }),
        "{err}"
    );
    assert_eq!(
        (err.location.line, err.location.field.as_deref()),
        (Some(4), Some("t"))
    );
}

#[test]
fn sidecar_window_count_inconsistent() {
    let side = SIDECAR.replace("\"baseline\": 0.5", "\"baseline\": 0.5, \"windows\": 4");
    let err = parse_dataset("d.csv", &good().join("\n"), "d.json", &side).unwrap_err();
    assert!(matches!(err.kind, DataErrorKind::Inconsistent(_)), "{err}");
    assert_eq!(err.location.field.as_deref(), Some("windows"));
    assert!(
        err.to_string().starts_with("d.json, field 'windows'"),
        "{err}"
    );
}

#[test]
fn sidecar_window_len_inconsistent() {
    let side = SIDECAR.replace("\"window_len\": 3", "\"window_len\": 4");
    let err = parse_dataset("d.csv", &good().join("\n"), "d.json", &side).unwrap_err();
    assert!(
        matches!(
            err.kind,
            DataErrorKind::SampleOutOfOrder { .. } | DataErrorKind::WrongWindowLength { .. }
        ),
        "{err}"
    );
}

#[test]
fn sidecar_bad_or_missing_fields() {
    let cases = [
        (
            SIDECAR.replace("\"wheel_radius\": 0.1, ", ""),
            "wheel_radius",
        ),
        (
            SIDECAR.replace("\"baseline\": 0.5", "\"baseline\": -0.5"),
            "baseline",
        ),
        (
            SIDECAR.replace("\"rate_hz\": 20", "\"rate_hz\": \"fast\""),
            "rate_hz",
        ),
        (
            SIDECAR.replace("\"window_len\": 3", "\"window_len\": 1"),
            "window_len",
        ),
        (SIDECAR.replace("\"name\": \"t\", ", ""), "name"),
        // The vehicle object form: an unknown type, a geometry field the type does not have,
        // an invalid geometry, and both forms at once.
        (
            VEHICLE_SIDECAR.replace("\"differential\"", "\"hovercraft\""),
            "vehicle",
        ),
        (
            VEHICLE_SIDECAR.replace("\"baseline\": 0.5", "\"baseline\": 0.5, \"wheelbase\": 1"),
            "vehicle",
        ),
        (
            VEHICLE_SIDECAR.replace("\"wheel_radius\": 0.1", "\"wheel_radius\": 0"),
            "vehicle",
        ),
        (
            VEHICLE_SIDECAR.replace("\"window_len\": 3", "\"window_len\": 3, \"baseline\": 0.5"),
            "baseline",
        ),
    ];
    for (side, field) in cases {
        let err = parse_dataset("d.csv", &good().join("\n"), "d.json", &side).unwrap_err();
        assert!(matches!(err.kind, DataErrorKind::BadSidecar(_)), "{err}");
        assert_eq!(err.location.field.as_deref(), Some(field), "{err}");
        assert_eq!(err.location.file, "d.json");
    }
}

/// The same robot as [`SIDECAR`], with the vehicle named.
const VEHICLE_SIDECAR: &str = r#"{"name": "t", "rate_hz": 20, "window_len": 3, "vehicle": {"type": "differential", "wheel_radius": 0.1, "baseline": 0.5}}"#;

#[test]
fn the_vehicle_form_and_the_older_form_give_the_same_dataset() {
    let a = parse_dataset("d.csv", &good().join("\n"), "d.json", SIDECAR).unwrap();
    let b = parse_dataset("d.csv", &good().join("\n"), "d.json", VEHICLE_SIDECAR).unwrap();
    assert_eq!(a, b);
    // The writer names the vehicle.
    let text = drive_data::sidecar_json(&a.robot, a.windows.len(), None).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["vehicle"]["type"], "differential");
    assert_eq!(v["vehicle"]["baseline"], 0.5);
}

#[test]
fn sidecar_not_json() {
    let err = parse_dataset("d.csv", &good().join("\n"), "d.json", "{\"name\": ").unwrap_err();
    assert!(matches!(err.kind, DataErrorKind::BadSidecar(_)), "{err}");
    assert_eq!(err.location.line, Some(1));
}

#[test]
fn sidecar_missing_on_disk() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("run.csv");
    std::fs::write(&csv, good().join("\n")).unwrap();
    let err = read_dataset(&csv, None).unwrap_err();
    assert!(
        matches!(err.kind, DataErrorKind::MissingSidecar(_)),
        "{err}"
    );
    assert!(err.to_string().contains("run.meta.json"), "{err}");
    // The earlier releases' name, read when it is the only one.
    std::fs::write(dir.path().join("run.json"), SIDECAR).unwrap();
    assert_eq!(read_dataset(&csv, None).unwrap().windows.len(), 3);
    // Given explicitly, it is found.
    let side = dir.path().join("robot.json");
    std::fs::write(&side, SIDECAR).unwrap();
    assert_eq!(read_dataset(&csv, Some(&side)).unwrap().windows.len(), 3);
}

#[test]
fn windows_round_trip_through_the_writer() {
    let d = parse(&good()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("rt.csv");
    drive_data::write_dataset(&d, &csv).unwrap();
    let back = read_dataset(&csv, None).unwrap();
    assert_eq!(back, d);
}

#[test]
fn a_csv_beside_another_runs_sidecar_is_refused() {
    let d = parse(&good()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("rt.csv");
    drive_data::write_dataset(&d, &csv).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    // One sample changed by another run (same rows, same windows).
    let lines: Vec<&str> = text.lines().collect();
    let mut fields: Vec<&str> = lines[2].split(',').collect();
    fields[8] = "9";
    let edited = text.replacen(lines[2], &fields.join(","), 1);
    assert_ne!(edited, text);
    std::fs::write(&csv, &edited).unwrap();
    let err = read_dataset(&csv, None).unwrap_err();
    assert_eq!(err.location.field.as_deref(), Some("csv"), "{err}");
    assert!(
        err.to_string()
            .contains("not the CSV this sidecar was written with"),
        "{err}"
    );
    // Without the digest (an edit on purpose), the pair is read.
    let side = dir.path().join("rt.meta.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&side).unwrap()).unwrap();
    assert_eq!(v["csv"]["rows"], lines.len() - 1);
    v.as_object_mut().unwrap().remove("csv");
    std::fs::write(&side, v.to_string()).unwrap();
    assert!(read_dataset(&csv, None).is_ok());
    // A malformed digest is named.
    v["csv"] = serde_json::json!({"rows": 3, "fnv1a64": "xyz"});
    std::fs::write(&side, v.to_string()).unwrap();
    let err = read_dataset(&csv, None).unwrap_err();
    assert_eq!(err.location.field.as_deref(), Some("csv"), "{err}");
}

#[test]
fn a_byte_order_mark_is_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("bom.csv");
    std::fs::write(&csv, format!("\u{feff}{}", good().join("\n"))).unwrap();
    std::fs::write(dir.path().join("bom.json"), format!("\u{feff}{SIDECAR}")).unwrap();
    assert_eq!(read_dataset(&csv, None).unwrap().windows.len(), 3);
}
