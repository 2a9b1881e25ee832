//! The localization's start velocity (`--start encoders+imu+localization`): derived from the
//! preceding window, used by the models whose state is a velocity, and fitted only when the
//! predictions will have it.

use crate::common;
use common::ok;

fn translational(json: &str, name: &str) -> f64 {
    let v: serde_json::Value = serde_json::from_str(json).unwrap();
    v["models"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["name"] == name)
        .unwrap()["translational_median_m"]
        .as_f64()
        .unwrap()
}

#[test]
fn the_bundled_windows_run_on_into_each_other_and_carry_a_plausible_start_velocity() {
    let data = drive::bundled::husky().unwrap();
    let linked: Vec<[f64; 2]> = data
        .windows
        .iter()
        .filter_map(|w| w.start_velocity)
        .collect();
    // The first window has none; a few follow a gap in the recording (a jump of the
    // encoders no step makes).
    assert!(data.windows[0].start_velocity.is_none());
    assert!(
        linked.len() > 9 * data.windows.len() / 10,
        "{} of {}",
        linked.len(),
        data.windows.len()
    );
    // A Husky drives at up to about 1 m/s, forward or backward, and barely sideways: the
    // median magnitudes say so even with the localization's glitches.
    let mut speed: Vec<f64> = linked.iter().map(|v| v[0].abs()).collect();
    let mut lateral: Vec<f64> = linked.iter().map(|v| v[1].abs()).collect();
    let (speed, lateral) = (
        drive::traits::median(&mut speed),
        drive::traits::median(&mut lateral),
    );
    assert!(speed > 0.2 && speed < 1.2, "{speed}");
    assert!(lateral < 0.25 * speed, "{lateral} vs {speed}");
}

#[test]
fn on_ice_slip_ipem_predicts_far_better_from_the_localization_start_and_slip_blr_the_same() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("ice.csv");
    let csv = csv.to_str().unwrap();
    ok(&[
        "simulate",
        "--robot",
        "warthog",
        "--terrain",
        "ice",
        "--duration",
        "300",
        "--seed",
        "4",
        "--out",
        csv,
    ]);
    let eval = |start: &str| {
        ok(&[
            "eval",
            "--data",
            csv,
            "--models",
            "slip-blr,slip-ipem",
            "--start",
            start,
            "--json",
        ])
    };
    let (imu, localization) = (eval("encoders+imu"), eval("encoders+imu+localization"));
    // slip-BLR has no velocity state: the start changes nothing.
    assert_eq!(
        translational(&imu, "slip-blr"),
        translational(&localization, "slip-blr")
    );
    // On ice the body lags its wheels by seconds: where it is going at the start is most of
    // the 2 s prediction.
    let (a, b) = (
        translational(&imu, "slip-ipem"),
        translational(&localization, "slip-ipem"),
    );
    assert!(b < 0.6 * a, "localization {b} vs encoders+imu {a}");
}

#[test]
fn a_model_is_fitted_for_the_start_its_predictions_will_have() {
    let dir = tempfile::tempdir().unwrap();
    let train = |start: &str| {
        let out = dir.path().join(format!("{start}.json"));
        let out = out.to_str().unwrap();
        ok(&[
            "train",
            "--model",
            "slip-ipem",
            "--split",
            "0.5",
            "--start",
            start,
            "--out",
            out,
        ]);
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out).unwrap()).unwrap();
        v
    };
    // By default the predictions start from the encoders and the IMU: no start velocity is
    // fitted, and the file is the one a model without it has.
    let default = train("encoders+imu");
    let slip = &default["model"]["model"]["slip"];
    assert_eq!(slip["type"], "slip-ipem");
    assert!(slip.get("velocity_logit").is_none(), "{slip}");
    let with = train("encoders+imu+localization");
    let trust = with["model"]["model"]["slip"]["velocity_logit"]
        .as_f64()
        .unwrap();
    // The bundled Husky's localization velocity is worth trusting for the most part.
    assert!(trust > 0.0, "{trust}");
}
