//! Model files keep every setting a model was fitted with (`fitted_with`: its start among
//! them) and give back the same model, for every registered model and every start.

use crate::common::ok;
use drive::eval::split_by_interval;
use drive::models::calibration::Uncertainty;
use drive::models::model_file::{model_file_to_json, read_model_file, FitSettings};
use drive::traits::StartInfo;
use drive::Registries;

#[test]
fn every_model_and_start_round_trips_through_its_model_file() {
    let data = drive::bundled::husky().unwrap();
    let (train, eval) = split_by_interval(&data, 0.3).unwrap();
    let vehicle = data.robot.vehicle.as_ref();
    for spec in Registries::builtin().models().all() {
        for start in [
            StartInfo::Encoders,
            StartInfo::EncodersImu,
            StartInfo::EncodersImuLocalization,
        ] {
            let spec = spec.clone().with_uncertainty(Uncertainty::Paper, start);
            let name = format!("{} from {}", spec.canonical(), start.as_str());
            let model = spec.fit(&train).unwrap();
            let settings = FitSettings {
                split: Some(0.3),
                training_windows: train.len(),
                ..FitSettings::of(&spec)
            };
            let text = model_file_to_json(model.as_ref(), &data.robot, Some(&settings)).unwrap();
            let back = read_model_file("m.json", &text).unwrap();
            assert_eq!(back.fitted_with.as_ref(), Some(&settings), "{name}");
            assert_eq!(back.fitted_with.unwrap().start, start, "{name}");
            // The same predictions from the start it was fitted for.
            for w in eval.windows.iter().step_by(50) {
                let s = w.start_state_with(vehicle, start);
                assert_eq!(
                    back.model.predict(&s, &w.command),
                    model.predict(&s, &w.command),
                    "{name}"
                );
            }
        }
    }
}

#[test]
fn train_writes_what_the_model_was_fitted_with_and_a_bad_setting_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.json");
    let out = out.to_str().unwrap();
    ok(&[
        "train",
        "--model",
        "slip-blr",
        "--split",
        "0.5",
        "--start",
        "encoders+imu+localization",
        "--uncertainty",
        "paper",
        "--out",
        out,
    ]);
    let text = std::fs::read_to_string(out).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let f = &v["fitted_with"];
    assert_eq!(f["model"], "slip-blr");
    assert_eq!(f["canonical"], "slip-blr+fopdt");
    assert_eq!(f["start"], "encoders+imu+localization");
    assert_eq!(f["uncertainty"], "paper");
    assert_eq!(f["split"], 0.5);
    assert_eq!(f["training_windows"], 300);
    // A setting that is not one is refused with its path, not read as a default.
    for (field, value) in [
        ("start", serde_json::json!("gps")),
        ("uncertainty", serde_json::json!("magic")),
        ("split", serde_json::json!(7.0)),
    ] {
        let mut bad = v.clone();
        bad["fitted_with"][field] = value;
        let e = read_model_file("m.json", &bad.to_string()).unwrap_err();
        assert!(e.to_string().contains("fitted_with"), "{field}: {e}");
    }
    // A file without the settings (written before them) still loads.
    let mut old = v.clone();
    old.as_object_mut().unwrap().remove("fitted_with");
    assert!(read_model_file("m.json", &old.to_string())
        .unwrap()
        .fitted_with
        .is_none());
    // A calibrated model whose settings say it is not: one or the other was edited.
    let calibrated = dir.path().join("c.json");
    ok(&[
        "train",
        "--model",
        "slip-blr",
        "--split",
        "0.5",
        "--out",
        calibrated.to_str().unwrap(),
    ]);
    let mut c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&calibrated).unwrap()).unwrap();
    assert_eq!(c["fitted_with"]["uncertainty"], "calibrated");
    assert!(read_model_file("c.json", &c.to_string()).is_ok());
    c["fitted_with"]["uncertainty"] = serde_json::json!("paper");
    let e = read_model_file("c.json", &c.to_string()).unwrap_err();
    assert!(e.to_string().contains("but the model is calibrated"), "{e}");
}
