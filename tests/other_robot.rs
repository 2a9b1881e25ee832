//! The same command on a robot with other geometry, five times the speed and another rate,
//! from its CSV and sidecar alone.

mod common;

use common::SyntheticRobot;
use std::process::Command;

fn eval_json(csv: &std::path::Path) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_drive"))
        .args(["eval", "--json", "--data"])
        .arg(csv)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn medians(v: &serde_json::Value, name: &str) -> (f64, f64) {
    let m = v["models"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["name"] == name)
        .unwrap();
    (
        m["translational_median_m"].as_f64().unwrap(),
        m["rotational_median_rad"].as_f64().unwrap(),
    )
}

fn check(robot: SyntheticRobot, name: &str) {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join(format!("{name}.csv"));
    drive::data::write_dataset(&robot.record(name, 60, 3), &csv).unwrap();
    let v = eval_json(&csv);
    assert_eq!(v["dataset"], name);
    assert_eq!(v["train_windows"], 90);
    assert_eq!(v["eval_windows"], 90);
    let naive = medians(&v, "naive");
    let pt = medians(&v, "powertrain");
    let slip = medians(&v, "slip-blr");
    let acc = medians(&v, "acc-blr");
    eprintln!("{name}: naive {naive:?} powertrain {pt:?} slip-blr {slip:?} acc-blr {acc:?}");
    // The learned slip model must clearly beat the models that ignore slip.
    assert!(slip.0 < 0.5 * naive.0 && slip.1 < 0.5 * naive.1);
    assert!(slip.0 < pt.0 && slip.1 < pt.1);
    for (t, r) in [naive, pt, slip, acc] {
        assert!(t.is_finite() && r.is_finite() && t > 0.0 && r > 0.0);
    }
}

#[test]
fn warthog_like_robot_at_20_hz() {
    check(SyntheticRobot::warthog_like(), "synthetic-warthog");
}

#[test]
fn warthog_like_robot_at_10_hz() {
    let robot = SyntheticRobot {
        rate_hz: 10.0,
        window_len: 20,
        ..SyntheticRobot::warthog_like()
    };
    check(robot, "synthetic-warthog-10hz");
}
