//! What a prediction starts from (`--start`): never a sample after the window's start, and
//! the same information at the fit as at the prediction, for every start option and every
//! model.

use drive::eval::split_by_interval;
use drive::studies::Registries;
use drive::traits::{Input, Pose, StartInfo, Window};

/// A small simulated Husky run (the IMU, the encoders and the localization all recorded).
fn run() -> drive::traits::Dataset {
    drive::studies::simulate_protocol(&Registries::builtin(), "husky", "gravel", "uniform", 14, 5)
        .unwrap()
        .dataset
}

#[test]
fn a_start_state_reads_no_sample_after_the_start() {
    let data = run();
    let vehicle = data.robot.vehicle.as_ref();
    for w in data.windows.iter().take(12) {
        let mut future = w.clone();
        for k in 1..future.len() {
            future.pose[k] = Pose::new(9.0, -9.0, 3.0);
            future.measured[k] = Input::new(99.0, -99.0, 0.0);
            future.command[k] = Input::new(-50.0, 50.0, 0.0);
            future.imu_yaw_rate[k] = 42.0;
        }
        for info in [
            StartInfo::Encoders,
            StartInfo::EncodersImu,
            StartInfo::EncodersImuLocalization,
        ] {
            assert_eq!(
                w.start_state_with(vehicle, info),
                future.start_state_with(vehicle, info),
                "window {}, {info:?}",
                w.index
            );
        }
    }
}

/// Every window's predictions (the start from `start`) of the model `name` fitted on `train`.
fn predictions(
    name: &str,
    start: StartInfo,
    data: &drive::traits::Dataset,
    train: &[Window],
) -> Vec<Vec<Pose>> {
    let registries = Registries::builtin();
    let spec = registries
        .model(name)
        .unwrap()
        .with_uncertainty(drive::models::calibration::Uncertainty::Paper, start);
    let set = drive::traits::WindowSet::new(&data.robot, train);
    let model = spec.fit(&set).unwrap_or_else(|e| panic!("{name}: {e}"));
    let (_, eval) = split_by_interval(data, 0.5).unwrap();
    let vehicle = data.robot.vehicle.as_ref();
    eval.windows
        .iter()
        .map(|w| {
            let mut poses = Vec::new();
            model.predict_into(&w.start_state_with(vehicle, start), &w.command, &mut poses);
            poses
        })
        .collect()
}

#[test]
fn every_model_is_fitted_with_exactly_the_start_information_it_is_given() {
    let data = run();
    let (train, _) = split_by_interval(&data, 0.5).unwrap();
    let train: Vec<Window> = train.windows.iter().map(|w| (*w).clone()).collect();
    assert!(train.iter().any(|w| w.start_velocity.is_some()));
    // The same training windows with other IMU readings, and with other start velocities.
    let other_imu: Vec<Window> = train
        .iter()
        .map(|w| {
            let mut w = w.clone();
            let index = w.index as f64;
            for (k, v) in w.imu_yaw_rate.iter_mut().enumerate() {
                *v += (k as f64 + index).sin();
            }
            w
        })
        .collect();
    let other_velocity: Vec<Window> = train
        .iter()
        .map(|w| {
            let velocity = w.start_velocity.map(|[x, y]| [0.5 - x, y + 0.2]);
            w.clone().with_start_velocity(velocity)
        })
        .collect();
    let registries = Registries::builtin();
    for spec in registries.models().all() {
        let name = spec.canonical();
        // Without the IMU, a model does not depend on what the IMU read in training.
        assert_eq!(
            predictions(&name, StartInfo::Encoders, &data, &train),
            predictions(&name, StartInfo::Encoders, &data, &other_imu),
            "{name}, --start encoders"
        );
        // Without the localization, nor on the training windows' start velocities.
        for start in [StartInfo::Encoders, StartInfo::EncodersImu] {
            assert_eq!(
                predictions(&name, start, &data, &train),
                predictions(&name, start, &data, &other_velocity),
                "{name}, --start {}",
                start.as_str()
            );
        }
    }
    // The check can fail: slip-ipem does read the IMU when it is given.
    assert_ne!(
        predictions("slip-ipem", StartInfo::EncodersImu, &data, &train),
        predictions("slip-ipem", StartInfo::EncodersImu, &data, &other_imu),
    );
}

#[test]
fn the_calibration_scores_fits_that_never_saw_the_held_out_windows() {
    use drive::models::calibration::{Calibrator, Uncertainty};
    let data = run();
    let (train, eval) = split_by_interval(&data, 0.5).unwrap();
    let vehicle = data.robot.vehicle.as_ref();
    let registries = Registries::builtin();
    for name in ["slip-ipem", "slip-blr", "acc-blr"] {
        let spec = registries.model(name).unwrap();
        let calibrated = spec.fit(&train).unwrap();
        // The same calibration by hand: each fold a fit from scratch on the other intervals.
        let plain = spec
            .clone()
            .with_uncertainty(Uncertainty::Paper, spec.start);
        let by_hand = Calibrator::default()
            .calibrate(plain.fit(&train).unwrap(), &train, spec.start, |inner| {
                plain.fit(inner)
            })
            .unwrap();
        for w in eval.windows.iter().take(10) {
            let start = w.start_state_with(vehicle, spec.start);
            let (mut p1, mut c1, mut p2, mut c2) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
            calibrated
                .predict_with_covariance_into(&start, &w.command, &mut p1, &mut c1)
                .unwrap();
            by_hand
                .predict_with_covariance_into(&start, &w.command, &mut p2, &mut c2)
                .unwrap();
            assert_eq!((p1, c1), (p2, c2), "{name}, window {}", w.index);
        }
    }
}
