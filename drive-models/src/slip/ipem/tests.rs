//! slip-ipem's tests.

use super::*;
use crate::powertrain::{Commanded, CommandedPowertrain};
use crate::rollout::integrate;
use crate::{Composed, DifferentialDrive};
use drive_traits::CommandModel;
use drive_traits::{
    Input, Learner, MotionModel, Phase, RobotDescription, StartState, Window, WindowSet,
};

/// A slip model with known weights and lag: 20% longitudinal slip, a centrifugal drift,
/// a skid that saturates with the yaw rate, and a lag of 0.3 per step on the yaw rate.
fn truth() -> SlipIpemModel {
    let mut w = [
        vec![0.0; FEATURES],
        vec![0.0; FEATURES],
        vec![0.0; FEATURES],
    ];
    w[0][0] = 0.2; // a
    w[1][2] = 0.05; // a b
    w[2][1] = 1.0; // b
    w[2][8] = -0.4; // b|b|
    SlipIpemModel {
        scale: [1.0, 2.0],
        weights: w,
        lag_logit: [8.0, 8.0, (0.3f64 / 0.7).ln()],
        disturbance_logit: Some([-30.0, 0.0]),
        velocity_logit: Some(-30.0),
        transport: true,
        dt: 0.05,
        ridge: 0.0,
        weight_covariance: vec![0.0; PARAMETERS * PARAMETERS],
        bias_variance: [0.0; 3],
    }
}

/// Windows of 40 samples at 20 Hz driven by `truth` through a differential drive whose
/// wheels do what they are told (the commanded powertrain), with commands from a
/// deterministic pseudo-random sequence.
fn windows(n: usize, seed: u64) -> (RobotDescription, Vec<Window>) {
    let vehicle = DifferentialDrive::new(0.1, 0.5);
    let robot = RobotDescription::new("synthetic", "", 20.0, 40, vehicle.clone());
    let model = truth();
    let mut state = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut draw = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    };
    let mut out = Vec::new();
    for i in 0..n {
        let u = Input::new(10.0 * draw(), 10.0 * draw(), 0.0);
        let command = vec![u; 40];
        let mut f = Vec::new();
        vehicle.body_velocities_into(&command, &mut f);
        let mut v = Vec::new();
        model.body_velocities_into(&f, &mut v);
        let mut pose = Vec::new();
        let start = Pose::new(draw(), draw(), 3.0 * draw());
        integrate(&start, &v, 0.05, &mut pose);
        // An IMU that measures the yaw rate.
        let imu_yaw_rate = v.iter().map(|v| v.z).collect();
        out.push(Window::new(
            i,
            i / 3,
            if i % 3 == 0 {
                Phase::Transient
            } else {
                Phase::Steady
            },
            command.clone(),
            command,
            pose,
            imu_yaw_rate,
        ));
    }
    (robot, out)
}

fn mean_error(model: &dyn MotionModel, windows: &[Window]) -> f64 {
    let mut total = 0.0;
    for w in windows {
        let p = model.predict(&StartState::at_rest(w.pose[0]), &w.command);
        total += p
            .iter()
            .zip(&w.pose)
            .map(|(p, m)| (p.x - m.x).hypot(p.y - m.y))
            .sum::<f64>()
            / w.len() as f64;
    }
    total / windows.len() as f64
}

#[test]
fn seeded_slip_is_the_automatic_derivative_of_the_slip() {
    let theta: [f64; PARAMETERS] = std::array::from_fn(|j| 0.01 * j as f64 - 0.2);
    let unit = [1.5, 1.5, 3.0];
    let u: [f64; PARAMETERS] = std::array::from_fn(|j| {
        if j < WEIGHTS {
            theta[j] / unit[j / FEATURES]
        } else {
            theta[j]
        }
    });
    // Every weight a dual variable: num-dual differentiates the weighted sum itself.
    let theta_d: [DualSVec64<PARAMETERS>; PARAMETERS] = std::array::from_fn(|j| {
        let s = if j < WEIGHTS { unit[j / FEATURES] } else { 1.0 };
        DualSVec64::from(u[j]).derivative(j) * s
    });
    let phi = slip_features(&BodyVelocity::new(0.7, 0.0, -1.3), &[1.0, 2.0]);
    let automatic = slip_of(&theta_d, &phi);
    let seeded = seeded_slip::<PARAMETERS>(&theta, &phi, &unit, None);
    for d in 0..3 {
        assert!((automatic[d].re - seeded[d].re).abs() < 1e-14);
        let a = automatic[d].eps.unwrap_generic(Const::<PARAMETERS>, U1);
        let b = seeded[d].eps.unwrap_generic(Const::<PARAMETERS>, U1);
        assert!((a - b).norm() < 1e-14, "dimension {d}");
    }
}

#[test]
fn gradient_matches_central_finite_differences() {
    let (robot, ws) = windows(12, 1);
    let set = WindowSet::new(&robot, &ws);
    let data = SlipData::new(&set, &CommandedPowertrain);
    let (tracks, scale) = SlipIpem::default().tracks(&data).unwrap();
    let all: Vec<&Track> = tracks.iter().collect();
    let weights = error_scales(&all, 0.05).map(|s| 1.0 / s);
    let problem = Ipem::new(all, weights, [scale[0], scale[0], scale[1]], 0.01, 0.05);
    let u = DVector::from_fn(PARAMETERS, |j, _| {
        if j < WEIGHTS {
            0.05 * ((j * 7 % 11) as f64 - 5.0)
        } else {
            1.0 + 0.3 * (j - WEIGHTS) as f64
        }
    });
    let g = problem.gradient(&u).unwrap();
    for j in [
        0,
        5,
        14,
        27,
        38,
        WEIGHTS,
        WEIGHTS + 2,
        WEIGHTS + 3,
        WEIGHTS + 4,
    ] {
        let h = 1e-6;
        let (mut up, mut down) = (u.clone(), u.clone());
        up[j] += h;
        down[j] -= h;
        let fd = (problem.cost(&up).unwrap() - problem.cost(&down).unwrap()) / (2.0 * h);
        assert!(
            (fd - g[j]).abs() <= 1e-6 * (1.0 + fd.abs()),
            "variable {j}: {fd} vs {}",
            g[j]
        );
    }
}

#[test]
fn learns_a_nonlinear_slip_with_lag_and_predicts_new_windows() {
    let (robot, train) = windows(150, 2);
    let (_, test) = windows(30, 3);
    let learner = Composed::new(Commanded, SlipIpem::default());
    let model = learner.fit(&WindowSet::new(&robot, &train)).unwrap();
    let no_slip = Composed::new(Commanded, crate::slip::NoSlip)
        .fit(&WindowSet::new(&robot, &train))
        .unwrap();
    let (fitted, reference) = (mean_error(&model, &test), mean_error(&no_slip, &test));
    assert!(
        fitted < 0.1 * reference,
        "slip-ipem {fitted} m vs no slip {reference} m"
    );
    let slip = format!("{:?}", model.slip);
    assert!(slip.contains("SlipIpemModel"));
}

#[test]
fn fit_is_deterministic_and_round_trips_through_json() {
    let (robot, train) = windows(60, 4);
    let set = WindowSet::new(&robot, &train);
    let data = SlipData::new(&set, &CommandedPowertrain);
    let a = SlipIpem::default().fit(&data).unwrap();
    let b = SlipIpem::default().fit(&data).unwrap();
    assert_eq!(a, b);
    let boxed: Box<dyn SlipModel> = Box::new(a.clone());
    let json = serde_json::to_string(&boxed).unwrap();
    let back: Box<dyn SlipModel> = serde_json::from_str(&json).unwrap();
    assert!(back.check().is_ok());
    let f = [BodyVelocity::new(0.4, 0.0, 0.9); 5];
    let (mut va, mut vb) = (Vec::new(), Vec::new());
    boxed.body_velocities_into(&f, &mut va);
    back.body_velocities_into(&f, &mut vb);
    assert_eq!(va, vb);
}

#[test]
fn rollout_covariance_is_symmetric_positive_and_starts_at_zero() {
    let (robot, train) = windows(60, 5);
    let set = WindowSet::new(&robot, &train);
    let model = SlipIpem::default()
        .fit(&SlipData::new(&set, &CommandedPowertrain))
        .unwrap();
    let f = vec![BodyVelocity::new(0.6, 0.0, 0.8); 40];
    let mut cov = Vec::new();
    let start = StartState::at_rest(Pose::zeros()).with_yaw_rate(0.5);
    assert!(model.rollout_covariances_into(&start, &f, 0.05, &mut cov));
    assert_eq!(cov.len(), 40);
    assert_eq!(cov[0], PoseCovariance::zeros());
    for c in &cov {
        assert!((c - c.transpose()).norm() < 1e-15);
        assert!(c.symmetric_eigenvalues().iter().all(|e| *e >= -1e-15));
    }
    assert!(cov[39].trace() > cov[10].trace());
}

#[test]
fn refuses_data_without_motion_and_bad_hyperparameters() {
    let (robot, mut ws) = windows(6, 6);
    for w in &mut ws {
        w.command.iter_mut().for_each(|c| *c = Input::zeros());
    }
    let set = WindowSet::new(&robot, &ws);
    let data = SlipData::new(&set, &CommandedPowertrain);
    assert!(matches!(
        SlipIpem::default().fit(&data),
        Err(FitError::DegenerateInputs { .. })
    ));
    for bad in [
        SlipIpem {
            ridge: vec![],
            ..SlipIpem::default()
        },
        SlipIpem {
            ridge: vec![0.1, -1.0],
            ..SlipIpem::default()
        },
        SlipIpem {
            validation: 1.0,
            ..SlipIpem::default()
        },
        SlipIpem {
            max_iterations: 0,
            ..SlipIpem::default()
        },
        SlipIpem {
            path_iterations: 0,
            ..SlipIpem::default()
        },
        SlipIpem {
            ridge: vec![1e-3, 1e-2],
            ..SlipIpem::default()
        },
        SlipIpem {
            tolerance: f64::NAN,
            ..SlipIpem::default()
        },
    ] {
        assert!(matches!(
            bad.fit(&data),
            Err(FitError::InvalidHyperparameter { .. })
        ));
    }
}

#[test]
fn a_malformed_model_file_is_refused() {
    let mut m = truth();
    assert!(m.check().is_ok());
    m.weights[1].pop();
    assert!(m.check().unwrap_err().contains("y weights"));
    let mut m = truth();
    m.weight_covariance[1] = 1.0; // not symmetric
    assert!(m.check().is_err());
    let mut m = truth();
    m.lag_logit[0] = f64::NAN;
    assert!(m.check().is_err());
    // Magnitudes no fit writes, which would make the covariance not a number: refused
    // with the value, not left for a prediction to fail on.
    let refused = |edit: &dyn Fn(&mut SlipIpemModel), says: &str| {
        let mut m = truth();
        edit(&mut m);
        let e = m.check().unwrap_err();
        assert!(e.contains(says), "{e}");
    };
    refused(&|m| m.lag_logit[1] = -1e308, "lag logit -1e308");
    refused(
        &|m| m.disturbance_logit = Some([0.0, 800.0]),
        "disturbance logit 800",
    );
    refused(&|m| m.weights[2][4] = 1e308, "yaw weight 1e308");
    refused(
        &|m| m.weight_covariance[0] = -1.5,
        "weight variance 0 is -1.5",
    );
    refused(&|m| m.bias_variance[2] = 1e300, "bias variance 1e300");
    refused(
        &|m| m.dt = 0.0,
        "dt (the step its body dynamics were fitted at) is 0: missing",
    );
    // A file written before the transport does not record its step.
    let mut m = truth();
    m.transport = false;
    m.dt = 0.0;
    assert!(m.check().is_ok() && m.step().is_none());
    assert_eq!(truth().step(), Some(0.05));
}

#[test]
fn a_model_whose_slip_step_is_not_its_own_is_refused() {
    let (robot, train) = windows(30, 9);
    let model = Composed::new(Commanded, SlipIpem::default())
        .fit(&WindowSet::new(&robot, &train))
        .unwrap();
    assert!(model.check().is_ok());
    let text = crate::model_file::model_to_json(&model, &robot).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    *v.pointer_mut("/model/slip/dt").unwrap() = serde_json::json!(0.1);
    let err = crate::model_file::model_from_json("m.json", &v.to_string()).unwrap_err();
    assert!(
        err.to_string()
            .contains("the slip model's step 0.1 s is not the model's 0.05 s"),
        "{err}"
    );
}

#[test]
fn a_symmetric_weight_covariance_with_a_negative_eigenvalue_is_refused() {
    let (robot, train) = windows(30, 9);
    let model = Composed::new(Commanded, SlipIpem::default())
        .fit(&WindowSet::new(&robot, &train))
        .unwrap();
    let text = crate::model_file::model_to_json(&model, &robot).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let c = v.pointer_mut("/model/slip/weight_covariance").unwrap();
    let n = (c.as_array().unwrap().len() as f64).sqrt() as usize;
    // [[a, b], [b, d]] with b^2 > a d: symmetric, every variance valid, yet indefinite.
    let (a, d) = (c[0].as_f64().unwrap(), c[n + 1].as_f64().unwrap());
    let b = 2.0 * (a * d).sqrt() + 1.0;
    c[1] = serde_json::json!(b);
    c[n] = serde_json::json!(b);
    let err = crate::model_file::model_from_json("m.json", &v.to_string()).unwrap_err();
    assert!(
        err.to_string().contains("not positive semi-definite"),
        "{err}"
    );
}

/// A model without slip whose body dynamics are given by their logits.
fn dynamics_only(lag: [f64; 3], disturbance: [f64; 2], transport: bool) -> SlipIpemModel {
    SlipIpemModel {
        scale: [1.0, 1.0],
        weights: [
            vec![0.0; FEATURES],
            vec![0.0; FEATURES],
            vec![0.0; FEATURES],
        ],
        lag_logit: lag,
        disturbance_logit: Some(disturbance),
        velocity_logit: Some(-30.0),
        transport,
        dt: 0.05,
        ridge: 0.0,
        weight_covariance: vec![0.0; PARAMETERS * PARAMETERS],
        bias_variance: [0.0; 3],
    }
}

#[test]
fn transport_keeps_a_sliding_velocity_fixed_in_the_world() {
    // No grip at all (lag shares of e^-40): the body turns at 1 rad/s under a velocity
    // that nothing changes. In the world it keeps going straight along x at 1 m/s.
    let f = vec![BodyVelocity::new(1.0, 0.0, 1.0); 40];
    let start = StartState::at_rest(Pose::zeros());
    let (mut v, mut poses) = (Vec::new(), Vec::new());
    dynamics_only([-40.0; 3], [-40.0, 0.0], true).rollout_velocities_into(&start, &f, &mut v);
    integrate(&Pose::zeros(), &v, 0.05, &mut poses);
    for (k, p) in poses.iter().enumerate() {
        assert!((p.x - 0.05 * k as f64).abs() < 1e-12, "{k}: {p:?}");
        assert!(p.y.abs() < 1e-12, "{k}: {p:?}");
        assert!((p.z - 0.05 * k as f64).abs() < 1e-12, "{k}: {p:?}");
    }
    // In the body frame the velocity turned the other way: after 1 s by -1 rad.
    assert!((v[20].x - (-1.0f64).cos()).abs() < 1e-12);
    assert!((v[20].y - (-1.0f64).sin()).abs() < 1e-12);
    // Without the transport the velocity turns with the body: a circle of radius 1 m.
    dynamics_only([-40.0; 3], [-40.0, 0.0], false).rollout_velocities_into(&start, &f, &mut v);
    integrate(&Pose::zeros(), &v, 0.05, &mut poses);
    assert!(poses[39].y > 0.5);
}

#[test]
fn a_measured_start_yaw_rate_sets_a_decaying_disturbance() {
    // No lag; the whole disturbance trusted (e^40), decaying by 0.8 per step.
    let model = dynamics_only([40.0; 3], [40.0, (0.8f64 / 0.2).ln()], true);
    let f = vec![BodyVelocity::new(0.5, 0.0, 0.2); 12];
    let mut v = Vec::new();
    let start = StartState::at_rest(Pose::zeros()).with_yaw_rate(1.0);
    model.rollout_velocities_into(&start, &f, &mut v);
    for (k, v) in v.iter().enumerate() {
        let expected = 0.2 + (1.0 - 0.2) * 0.8f64.powi(k as i32);
        assert!((v.z - expected).abs() < 1e-12, "{k}: {} vs {expected}", v.z);
        assert!((v.x - 0.5).abs() < 1e-12);
    }
    // Without a measured yaw rate (the encoders only, or the mean prediction), none.
    model.rollout_velocities_into(&StartState::at_rest(Pose::zeros()), &f, &mut v);
    assert!(v.iter().all(|v| (v.z - 0.2).abs() < 1e-12));
    model.body_velocities_into(&f, &mut v);
    assert!(v.iter().all(|v| (v.z - 0.2).abs() < 1e-12));
}

#[test]
fn the_motion_observed_at_a_later_step_is_the_lagging_velocity_there() {
    // A yaw lag of 0.1 per step, a fifth of the x and y's; no disturbance; no transport
    // (so that x and y follow their own lag only).
    let (lag_xy, lag_yaw) = ((0.5f64 / 0.5).ln(), (0.1f64 / 0.9).ln());
    let model = dynamics_only([lag_xy, lag_xy, lag_yaw], [-40.0, 0.0], false);
    // At rest for 10 steps, then commanded to turn at 1 rad/s and drive at 1 m/s.
    let mut f = vec![BodyVelocity::zeros(); 10];
    f.extend(vec![BodyVelocity::new(1.0, 0.0, 1.0); 20]);
    let start = StartState::at_rest(Pose::zeros());
    let (mut free, mut v) = (Vec::new(), Vec::new());
    model.rollout_velocities_into(&start, &f, &mut free);
    // Running free, step 15 has covered 1 - 0.9^6 of the way to 1 rad/s.
    assert!((free[15].z - (1.0 - 0.9f64.powi(6))).abs() < 1e-12);
    // The IMU measures 0.8 rad/s before step 15: the lag goes on from there.
    let observed = start.with_observed(15, Some(0.8), None);
    model.rollout_velocities_into(&observed, &f, &mut v);
    assert_eq!(v[..15], free[..15]);
    for k in 15..30 {
        let expected = 1.0 - 0.2 * 0.9f64.powi((k - 14) as i32);
        assert!(
            (v[k].z - expected).abs() < 1e-12,
            "{k}: {} vs {expected}",
            v[k].z
        );
        // x and y, not measured, run as they did.
        assert_eq!((v[k].x, v[k].y), (free[k].x, free[k].y));
    }
    // The localization's velocity before step 12, likewise for x and y.
    let observed = start.with_observed(12, None, Some([0.2, 0.1]));
    model.rollout_velocities_into(&observed, &f, &mut v);
    assert!(
        (v[12].x - (0.2 + 0.5 * (1.0 - 0.2))).abs() < 1e-12,
        "{}",
        v[12].x
    );
    assert!((v[12].y - 0.05).abs() < 1e-12, "{}", v[12].y);
    assert_eq!(v[12].z, free[12].z);
    // A glitch departs from the steady velocity by at most the limits (scale 1: 1 rad/s
    // of yaw rate): 2 rad/s, then the lag.
    let glitch = start.with_observed(15, Some(1e9), None);
    model.rollout_velocities_into(&glitch, &f, &mut v);
    assert!((v[15].z - (2.0 - 0.1 * 1.0)).abs() < 1e-12, "{}", v[15].z);
    // Nothing finite measured, or measured at the start or past the last step: the free run.
    for o in [
        start.with_observed(15, Some(f64::NAN), None),
        start.with_observed(0, Some(0.8), None),
        start.with_observed(99, Some(0.8), None),
    ] {
        model.rollout_velocities_into(&o, &f, &mut v);
        assert_eq!(v, free);
    }
    // The covariance rollout takes it too, and stays finite and symmetric.
    let mut c = Vec::new();
    assert!(model.rollout_covariances_into(
        &start.with_observed(15, Some(0.8), None),
        &f,
        0.05,
        &mut c
    ));
    assert_eq!(c.len(), f.len());
    assert!(c
        .iter()
        .all(|c| c.iter().all(|x| x.is_finite()) && (c - c.transpose()).norm() < 1e-12));
}

#[test]
fn a_measured_start_velocity_starts_the_lagging_velocity() {
    // Lag 0.25 per step along x and y, none in yaw, no transport (no turning anyway);
    // the start velocity trusted at 0.75.
    let mut model = dynamics_only(
        [(0.25f64 / 0.75).ln(), (0.25f64 / 0.75).ln(), 40.0],
        [-40.0, 0.0],
        false,
    );
    model.velocity_logit = Some(3f64.ln());
    let f = vec![BodyVelocity::new(1.0, 0.0, 0.0); 10];
    let mut v = Vec::new();
    let start = StartState::at_rest(Pose::zeros()).with_velocity([0.2, 0.4]);
    model.rollout_velocities_into(&start, &f, &mut v);
    for (k, v) in v.iter().enumerate() {
        // Starts 0.75 of the way from the steady (1, 0) to the measured (0.2, 0.4), then
        // covers a quarter of the remaining way each step.
        let share = 0.75 * 0.75f64.powi(k as i32);
        let expected = [1.0 + share * (0.2 - 1.0), share * 0.4];
        assert!(
            (v.x - expected[0]).abs() < 1e-12,
            "{k}: {} vs {:?}",
            v.x,
            expected
        );
        assert!(
            (v.y - expected[1]).abs() < 1e-12,
            "{k}: {} vs {:?}",
            v.y,
            expected
        );
    }
    // A localization glitch departs by at most the largest commanded speed (scale 1).
    let glitch = StartState::at_rest(Pose::zeros()).with_velocity([-1e9, 0.0]);
    model.rollout_velocities_into(&glitch, &f, &mut v);
    assert!((v[0].x - (1.0 - 0.75)).abs() < 1e-12, "{}", v[0].x);
    // A non-finite measurement is no measurement.
    let broken = StartState::at_rest(Pose::zeros()).with_velocity([0.2, f64::NAN]);
    model.rollout_velocities_into(&broken, &f, &mut v);
    assert!(v.iter().all(|v| v.x == 1.0 && v.y == 0.0));
    // Without a measured velocity, the steady one; and a file without the trust (written
    // before it) ignores a measured one.
    model.rollout_velocities_into(&StartState::at_rest(Pose::zeros()), &f, &mut v);
    assert!(v.iter().all(|v| v.x == 1.0 && v.y == 0.0));
    model.velocity_logit = None;
    model.weight_covariance = vec![0.0; PARAMETERS_V2 * PARAMETERS_V2];
    assert!(model.check().is_ok());
    model.rollout_velocities_into(&start, &f, &mut v);
    assert!(v.iter().all(|v| v.x == 1.0 && v.y == 0.0));
}

#[test]
fn the_start_velocity_is_fitted_only_when_the_training_windows_have_it() {
    let (robot, mut ws) = windows(40, 5);
    let learner = Composed::new(Commanded, SlipIpem::default());
    let without = learner.fit(&WindowSet::new(&robot, &ws)).unwrap();
    let json = |m: &dyn MotionModel| serde_json::to_value(m).unwrap();
    assert!(json(&without)["slip"].get("velocity_logit").is_none());
    // The windows start at their steady velocity (the generator's), measured with an
    // error: the trust is fitted, and a fit with it has the longer covariance.
    for (i, w) in ws.iter_mut().enumerate() {
        w.start_velocity = Some([0.1 * ((i % 5) as f64 - 2.0), 0.0]);
    }
    let with = learner.fit(&WindowSet::new(&robot, &ws)).unwrap();
    let slip = &json(&with)["slip"];
    assert!(slip["velocity_logit"].as_f64().unwrap().is_finite());
    assert_eq!(
        slip["weight_covariance"].as_array().unwrap().len(),
        PARAMETERS * PARAMETERS
    );
}

#[test]
fn one_standard_error_picks_the_strongest_strength_the_held_out_intervals_cannot_tell_apart() {
    let point = |ridge: f64, losses: [f64; 4]| PathPoint {
        ridge,
        losses: losses.to_vec(),
        u: DVector::from_element(1, ridge),
    };
    // Best: 1e-3 (4.0). 1e-2 is worse by 0.025 per interval on average, with a paired
    // standard error of 0.075: within. 1e-1 is worse by 0.5 everywhere: beyond.
    let path = [
        point(1e-2, [1.1, 0.9, 1.2, 0.9]),
        point(1e-3, [1.0; 4]),
        point(1e-4, [1.0, 1.0, 1.0, 1.05]),
        point(1e-1, [1.5; 4]),
    ];
    let (ridge, u) = one_standard_error(&path).unwrap();
    assert_eq!((ridge, u[0]), (1e-2, 1e-2));
    // With 1e-2 clearly worse too, the best.
    let path = [point(1e-2, [1.5; 4]), point(1e-3, [1.0; 4])];
    assert_eq!(one_standard_error(&path).unwrap().0, 1e-3);
    // A strength whose held-out loss is not finite is never chosen; none finite: none.
    let path = [point(1e-1, [f64::NAN; 4]), point(1e-3, [1.0; 4])];
    assert_eq!(one_standard_error(&path).unwrap().0, 1e-3);
    assert!(one_standard_error(&[point(1e-1, [f64::INFINITY; 4])]).is_none());
}

#[test]
fn the_ridge_path_starts_in_the_middle_and_walks_both_ways() {
    let (robot, ws) = windows(24, 7);
    let set = WindowSet::new(&robot, &ws);
    let data = SlipData::new(&set, &CommandedPowertrain);
    let learner = SlipIpem {
        ridge: vec![1e-1, 1e-2, 1e-3, 1e-4, 1e-5],
        ..SlipIpem::default()
    };
    let Prepared {
        tracks,
        weights,
        unit,
        dt,
        ..
    } = learner.prepare(&data).unwrap();
    let (fit_on, check_on): (Vec<&Track>, Vec<&Track>) =
        tracks.iter().partition(|t| t.interval < 6);
    let u0 = DVector::from_fn(PARAMETERS, |j, _| {
        if j < WEIGHTS {
            0.0
        } else {
            DYNAMICS_PRIOR[j - WEIGHTS]
        }
    });
    let path = learner
        .ridge_path(&fit_on, &check_on, weights, unit, dt, u0)
        .unwrap();
    let ridges: Vec<f64> = path.iter().map(|p| p.ridge).collect();
    assert_eq!(ridges[0], 1e-3, "{ridges:?}");
    let weaker = ridges.iter().take_while(|r| **r <= 1e-3).count();
    assert!(
        ridges[..weaker].windows(2).all(|w| w[1] < w[0]),
        "{ridges:?}"
    );
    assert!(
        ridges[weaker..].windows(2).all(|w| w[1] > w[0]),
        "{ridges:?}"
    );
    assert_eq!(ridges[weaker], 1e-2, "{ridges:?}");
    assert!(path.iter().all(|p| p.losses.len() == 2));
}

/// The training windows `ws` as slip-ipem's fit prepares them (on the commanded powertrain).
fn prepared(robot: &RobotDescription, ws: &[Window]) -> Prepared {
    let set = WindowSet::new(robot, ws);
    SlipIpem::default()
        .prepare(&SlipData::new(&set, &CommandedPowertrain))
        .unwrap()
}

#[test]
fn jacobian_in_two_groups_equals_the_forward_mode_jacobian_of_every_parameter() {
    let (robot, mut ws) = windows(6, 8);
    // Start velocities measured at some windows (off the steady ones, within and beyond
    // the bound), so that their trust's column is checked too.
    for (i, w) in ws.iter_mut().enumerate().filter(|(i, _)| i % 3 != 2) {
        w.start_velocity = Some([0.3 * i as f64 - 0.4, 0.1 - 0.5 * i as f64]);
    }
    let Prepared {
        tracks,
        weights,
        unit,
        dt,
        ..
    } = prepared(&robot, &ws);
    let all: Vec<&Track> = tracks.iter().collect();
    let problem = Ipem::new(all.clone(), weights, unit, 0.01, dt);
    let u: Vec<f64> = (0..PARAMETERS)
        .map(|j| {
            if j < WEIGHTS {
                0.07 * ((j * 5 % 13) as f64 - 6.0)
            } else {
                [0.5, -1.0, 1.5, 0.3, 1.2, 0.4][j - WEIGHTS]
            }
        })
        .collect();
    let theta = theta_of(&u, &unit);
    let dynamics = seeded_dynamics::<PARAMETERS>(&theta, [true, true], [unit[0], unit[2]], true);
    let mut checked = 0;
    problem.jacobians(&u, |i, jt, r| {
        let t = all[i];
        let slip = |k: usize| {
            split(seeded_slip::<PARAMETERS>(
                &theta,
                &t.features[k],
                &unit,
                None,
            ))
        };
        let mut col = 0;
        t.rollout(dt, &dynamics, slip, |k, xy, yaw| {
            let ([rx, ry], rz) = residual(xy, yaw, &t.target[k], &weights);
            for ri in [rx, ry, rz] {
                let w = robust_weight(ri.re * ri.re).sqrt();
                assert!((r[col] - ri.re * w).abs() < 1e-12);
                let g = ri.eps.unwrap_generic(Const::<PARAMETERS>, U1);
                for j in 0..PARAMETERS {
                    let (a, b) = (jt[(j, col)], g[j] * w);
                    assert!(
                        (a - b).abs() <= 1e-12 * (1.0 + b.abs()),
                        "{j}, {col}: {a} vs {b}"
                    );
                }
                col += 1;
                checked += 1;
            }
        });
    });
    assert_eq!(checked, 6 * 39 * 3);
}

#[test]
fn a_faulty_imu_does_not_wreck_the_fit() {
    // The IMU reads 1e6 rad/s at every window start: no disturbance the ground could
    // cause. The fit must still learn the slip (the deviation is bounded by the largest
    // commanded yaw rate, and the trust then falls).
    let (robot, mut train) = windows(150, 2);
    for w in &mut train {
        w.imu_yaw_rate[0] = 1e6;
    }
    let (_, test) = windows(30, 3);
    let model = Composed::new(Commanded, SlipIpem::default())
        .fit(&WindowSet::new(&robot, &train))
        .unwrap();
    let no_slip = Composed::new(Commanded, crate::slip::NoSlip)
        .fit(&WindowSet::new(&robot, &train))
        .unwrap();
    let (fitted, reference) = (mean_error(&model, &test), mean_error(&no_slip, &test));
    assert!(
        fitted < 0.1 * reference,
        "slip-ipem {fitted} m vs no slip {reference} m"
    );
}

#[test]
fn the_linearization_is_the_same_on_any_number_of_threads_and_sums_every_window() {
    // More windows than one parallel chunk, so that the chunks' sums are added.
    let (robot, ws) = windows(40, 9);
    let Prepared {
        tracks,
        weights,
        unit,
        dt,
        ..
    } = prepared(&robot, &ws);
    let all: Vec<&Track> = tracks.iter().collect();
    assert!(all.len() > 2 * LINEARIZE_CHUNK);
    let u = DVector::from_fn(PARAMETERS, |j, _| 0.05 * ((j * 7 % 11) as f64 - 5.0));
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| Ipem::new(all.clone(), weights, unit, 0.01, dt).linearize(&u))
    };
    let one = on(1);
    for threads in [2, 3] {
        let other = on(threads);
        assert_eq!(one.gradient, other.gradient, "{threads} threads");
        assert_eq!(one.hessian, other.hessian, "{threads} threads");
    }
    // The gradient is J^T r over every window, plus the penalty's.
    let problem = Ipem::new(all.clone(), weights, unit, 0.01, dt);
    let mut jtr = vec![0.0; PARAMETERS];
    problem.jacobians(u.as_slice(), |_, jt, r| {
        for (c, rc) in r.iter().enumerate() {
            for (acc, g) in jtr.iter_mut().zip(jt.col_as_slice(c)) {
                *acc += g * rc;
            }
        }
    });
    for (j, sum) in jtr.iter().enumerate() {
        let want = sum / problem.count + problem.penalty_gradient(&u, j);
        assert!(
            (one.gradient[j] - want).abs() <= 1e-12 * (1.0 + want.abs()),
            "{j}: {} vs {want}",
            one.gradient[j]
        );
    }
}
