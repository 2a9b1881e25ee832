//! The same commands on robots with other geometry, five times the speed and another rate:
//! simulated with `drive simulate`, evaluated by `drive eval` from the CSV and sidecar alone.

use std::path::Path;
use std::process::Command;

fn drive(args: &[&str]) -> std::process::Output {
    let out = Command::new(env!("CARGO_BIN_EXE_drive"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "drive {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn eval_json(csv: &Path) -> serde_json::Value {
    let out = drive(&["eval", "--json", "--data", csv.to_str().unwrap()]);
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

/// 60 intervals of `robot` (a preset or TOML file) on gravel, evaluated on the second half.
fn check(robot: &str, name: &str, rate_hz: f64) {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join(format!("{name}.csv"));
    // Characterization takes 24 s, then 60 intervals of 6 s.
    let csv_arg = csv.to_str().unwrap();
    let args = [
        "simulate",
        "--robot",
        robot,
        "--terrain",
        "gravel",
        "--duration",
        "385",
    ];
    drive(&[&args[..], &["--seed", "3", "--out", csv_arg]].concat());
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(csv.with_extension("meta.json")).unwrap())
            .unwrap();
    assert_eq!(sidecar["rate_hz"], rate_hz);
    assert_eq!(sidecar["window_len"], (2.0 * rate_hz) as u64);
    let v = eval_json(&csv);
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
fn warthog_at_20_hz() {
    check("warthog", "warthog", 20.0);
}

#[test]
fn warthog_geometry_at_10_hz_from_a_robot_file() {
    let dir = tempfile::tempdir().unwrap();
    let toml = dir.path().join("slow-warthog.toml");
    std::fs::write(
        &toml,
        "name = 'slow-warthog'\nmass_kg = 470\nwheel_radius = 0.3\nbaseline = 1.1652\n\
         max_speed = 5.0\nrate_hz = 10\nmax_linear_acceleration = 5.0\n\
         max_angular_acceleration = 8.0\n",
    )
    .unwrap();
    check(toml.to_str().unwrap(), "warthog-10hz", 10.0);
}
