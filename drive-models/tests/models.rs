//! Each model on hand-computed cases, and each learner recovering known parameters.

use approx::assert_abs_diff_eq;
use drive_models::baselines::{AccBlr, AccBlrModel};
use drive_models::blr::BlrPosterior;
use drive_models::model_file::{model_from_json, model_to_json, ModelFileError};
use drive_models::powertrain::{
    Commanded, CommandedPowertrain, Fopdt, FopdtPowertrain, RateLimited, RateLimitedPowertrain,
    RateLimitedResponse, SideResponse,
};
use drive_models::slip::{car_slip_inputs, NoSlip, NoSlipModel, SlipBasis, SlipBlr, SlipBlrModel};
use drive_models::vehicles::Ackermann;
use drive_models::{Composed, ComposedModel, DifferentialDrive};
use drive_traits::{
    Baseline, BodyVelocity, CommandModel, Input, InputSpace, Learner, MotionModel, Phase, Pose,
    Powertrain, PowertrainLearner, RobotDescription, StartState, Window, WindowSet,
};
use std::sync::Arc;

fn robot() -> RobotDescription {
    RobotDescription::new("test", "", 20.0, 40, DifferentialDrive::new(0.1, 0.5))
}

fn vehicle() -> DifferentialDrive {
    DifferentialDrive::new(0.1, 0.5)
}

/// A composed model of the test vehicle.
fn composed(
    powertrain: impl Powertrain + 'static,
    slip: impl drive_traits::SlipModel + 'static,
    dt: f64,
) -> ComposedModel {
    ComposedModel {
        label: "test".into(),
        vehicle: Arc::new(vehicle()),
        powertrain: Box::new(powertrain),
        slip: Box::new(slip),
        dt,
    }
}

fn window(
    index: usize,
    phase: Phase,
    command: Vec<Input>,
    measured: Vec<Input>,
    pose: Vec<Pose>,
) -> Window {
    let n = pose.len();
    Window::new(
        index,
        index / 3,
        phase,
        command,
        measured,
        pose,
        vec![0.0; n],
    )
}

/// Exact poses of a constant body velocity (closed-form arc), sampled every dt.
fn arc(v: BodyVelocity, dt: f64, n: usize) -> Vec<Pose> {
    (0..n)
        .map(|k| {
            let t = k as f64 * dt;
            let th = v.z * t;
            let (px, py) = if v.z.abs() < 1e-12 {
                (v.x * t, v.y * t)
            } else {
                (
                    (v.x * th.sin() + v.y * (th.cos() - 1.0)) / v.z,
                    (v.x * (1.0 - th.cos()) + v.y * th.sin()) / v.z,
                )
            };
            Pose::new(px, py, th)
        })
        .collect()
}

#[test]
fn naive_turning_hand_computed() {
    let m = composed(CommandedPowertrain, NoSlipModel, 0.1);
    // Left 0, right 10 rad/s: v = 0.1 * 5 = 0.5 m/s, w = 0.1 * 10 / 0.5 = 2 rad/s.
    let p = m.predict(
        &StartState::at_rest(Pose::zeros()),
        &[Input::new(0.0, 10.0, 0.0); 3],
    );
    assert_abs_diff_eq!(p[1], Pose::new(0.05, 0.0, 0.2), epsilon = 1e-12);
    assert_abs_diff_eq!(
        p[2],
        Pose::new(0.05 + 0.05 * 0.2f64.cos(), 0.05 * 0.2f64.sin(), 0.4),
        epsilon = 1e-12
    );
}
#[test]
fn powertrain_aware_hand_computed() {
    // tau_c = dt / ln 2 halves the gap each step; no delay; limits +-4.
    let dt = 0.1;
    let side = SideResponse {
        time_constant: dt / 2f64.ln(),
        delay: 0.0,
    };
    let limits = InputSpace::new(Input::new(-4.0, -4.0, 0.0), Input::new(4.0, 4.0, 0.0)).unwrap();
    let pt = FopdtPowertrain {
        axes: vec![side, side],
        limits,
        dt,
    };
    let m = composed(pt, NoSlipModel, dt);
    // Command 8 saturates at 4: wheels 0 -> 2 -> 3; body speed 0, 0.2, 0.3 m/s.
    let p = m.predict(
        &StartState::at_rest(Pose::zeros()),
        &[Input::new(8.0, 8.0, 0.0); 3],
    );
    assert_abs_diff_eq!(p[1].x, 0.0, epsilon = 1e-12);
    assert_abs_diff_eq!(p[2].x, 0.2 * dt, epsilon = 1e-12);
}

#[test]
fn fopdt_fit_recovers_known_responses() {
    let truth = FopdtPowertrain {
        axes: vec![
            SideResponse {
                time_constant: 0.42,
                delay: 0.17,
            },
            SideResponse {
                time_constant: 0.55,
                delay: 0.06,
            },
        ],
        limits: InputSpace::new(Input::new(-6.0, -5.5, 0.0), Input::new(6.5, 6.0, 0.0)).unwrap(),
        dt: 0.05,
    };
    let mut windows = Vec::new();
    let mut wheels = Input::zeros();
    for i in 0..30 {
        let c = Input::new(
            ((i * 37) % 23) as f64 - 11.0,
            ((i * 53) % 19) as f64 - 9.0,
            0.0,
        );
        for w in 0..3 {
            let cmds = vec![c; 40];
            let enc = truth.predict(&wheels, &cmds);
            wheels = enc[39];
            let phase = if w == 0 {
                Phase::Transient
            } else {
                Phase::Steady
            };
            windows.push(window(
                windows.len(),
                phase,
                cmds,
                enc,
                vec![Pose::zeros(); 40],
            ));
        }
    }
    let r = robot();
    let fitted = Fopdt::default().fit(&WindowSet::new(&r, &windows)).unwrap();
    assert_abs_diff_eq!(fitted.axes[0].time_constant, 0.42, epsilon = 1e-3);
    assert_abs_diff_eq!(fitted.axes[0].delay, 0.17, epsilon = 1e-3);
    assert_abs_diff_eq!(fitted.axes[1].time_constant, 0.55, epsilon = 1e-3);
    assert_abs_diff_eq!(fitted.axes[1].delay, 0.06, epsilon = 1e-3);
    // The limits are the extremes seen; with these time constants the wheels reach them.
    assert_abs_diff_eq!(fitted.limits.max, Input::new(6.5, 6.0, 0.0), epsilon = 1e-3);
    assert_abs_diff_eq!(
        fitted.limits.min,
        Input::new(-6.0, -5.5, 0.0),
        epsilon = 1e-3
    );
}

/// Transient windows of 40 samples driven through `truth` from varied commands.
fn powertrain_windows(truth: &dyn Powertrain) -> Vec<Window> {
    let mut windows = Vec::new();
    let mut state = Input::zeros();
    for i in 0..30 {
        let target = Input::new(
            ((i * 37) % 17) as f64 - 8.0,
            ((i * 53) % 15) as f64 - 7.0,
            0.0,
        );
        let cmds = vec![target; 40];
        let measured = truth.predict(&state, &cmds);
        state = measured[39];
        windows.push(window(
            i,
            Phase::Transient,
            cmds,
            measured,
            vec![Pose::zeros(); 40],
        ));
    }
    windows
}

#[test]
fn rate_limited_fit_recovers_a_binding_rate_limit() {
    let truth = RateLimitedPowertrain {
        axes: vec![
            RateLimitedResponse {
                time_constant: 0.25,
                delay: 0.1,
                max_rate: 3.0,
            },
            RateLimitedResponse {
                time_constant: 0.4,
                delay: 0.15,
                max_rate: 6.0,
            },
        ],
        limits: InputSpace::new(Input::new(-8.0, -8.0, 0.0), Input::new(8.0, 8.0, 0.0)).unwrap(),
        dt: 0.05,
    };
    let windows = powertrain_windows(&truth);
    let r = robot();
    let fit = RateLimited::default()
        .fit(&WindowSet::new(&r, &windows))
        .unwrap();
    for (got, want) in fit.axes.iter().zip(&truth.axes) {
        assert!((got.max_rate / want.max_rate - 1.0).abs() < 0.02, "{got:?}");
        assert!(
            (got.time_constant / want.time_constant - 1.0).abs() < 0.05,
            "{got:?}"
        );
        assert_abs_diff_eq!(got.delay, want.delay, epsilon = 5e-3);
    }
    // The FOPDT cannot follow the ramps: its error on the same windows is larger.
    let fopdt = Fopdt::default().fit(&WindowSet::new(&r, &windows)).unwrap();
    let sse = |pt: &dyn Powertrain| -> f64 {
        windows
            .iter()
            .map(|w| {
                pt.predict(&w.measured[0], &w.command)
                    .iter()
                    .zip(&w.measured)
                    .map(|(p, m)| (p - m).norm_squared())
                    .sum::<f64>()
            })
            .sum()
    };
    assert!(
        sse(&fit) < 0.01 * sse(&fopdt),
        "{} vs {}",
        sse(&fit),
        sse(&fopdt)
    );
}

#[test]
fn without_a_binding_limit_the_rate_limited_fit_is_the_fopdt() {
    let truth = FopdtPowertrain {
        axes: vec![
            SideResponse {
                time_constant: 0.3,
                delay: 0.1,
            };
            2
        ],
        limits: InputSpace::new(Input::new(-8.0, -8.0, 0.0), Input::new(8.0, 8.0, 0.0)).unwrap(),
        dt: 0.05,
    };
    let windows = powertrain_windows(&truth);
    let r = robot();
    let fit = RateLimited::default()
        .fit(&WindowSet::new(&r, &windows))
        .unwrap();
    for a in &fit.axes {
        assert_abs_diff_eq!(a.time_constant, 0.3, epsilon = 2e-3);
        assert_abs_diff_eq!(a.delay, 0.1, epsilon = 2e-3);
    }
    // Whatever limit it reports never binds on the data: its predictions are the FOPDT's.
    for w in &windows {
        let (a, b) = (
            fit.predict(&w.measured[0], &w.command),
            truth.predict(&w.measured[0], &w.command),
        );
        for (a, b) in a.iter().zip(&b) {
            assert!((a - b).norm() < 5e-2, "{a} vs {b}: {:?}", fit.axes);
        }
    }
}

#[test]
fn fopdt_without_transient_window_is_refused() {
    let r = robot();
    let w = window(
        0,
        Phase::Steady,
        vec![Input::new(1.0, 1.0, 0.0); 40],
        (0..40)
            .map(|k| Input::new(k as f64 * 0.01, k as f64 * 0.01, 0.0))
            .collect(),
        vec![Pose::zeros(); 40],
    );
    let err = Fopdt::default()
        .fit(&WindowSet::new(&r, std::slice::from_ref(&w)))
        .unwrap_err();
    assert_eq!(err, drive_traits::FitError::NoTransientWindow);
}

/// Steady windows whose body velocity is `f - g` with the slip of known weights.
fn slip_windows(gx: f64, gy: f64, gw: [f64; 3]) -> Vec<Window> {
    let r = robot();
    let vehicle = vehicle();
    let mut out = Vec::new();
    for i in 0..40 {
        let u = Input::new(
            ((i * 7) % 13) as f64 - 6.0,
            ((i * 11) % 17) as f64 - 8.0,
            0.0,
        );
        let f = vehicle.eq4(&u);
        let psi = f.x * f.z;
        let g = BodyVelocity::new(gx * f.x, gy * psi, gw[0] * psi + gw[1] * f.x + gw[2] * f.z);
        let poses = arc(f - g, r.dt(), 40);
        out.push(window(i, Phase::Steady, vec![u; 40], vec![u; 40], poses));
    }
    out
}

#[test]
fn slip_blr_recovers_known_slip_weights() {
    let r = robot();
    let windows = slip_windows(0.2, -0.05, [0.03, 0.1, 0.4]);
    let set = WindowSet::new(&r, &windows);
    let data = drive_traits::SlipData::new(&set, &CommandedPowertrain);
    let m: SlipBlrModel = drive_traits::SlipLearner::fit(&SlipBlr::default(), &data).unwrap();
    // The labels come from a 0.2 s chord of an arc: exact up to sin(x)/x ~ 1e-3.
    assert_abs_diff_eq!(m.slip_x.mean[0], 0.2, epsilon = 5e-3);
    assert_abs_diff_eq!(m.slip_y.mean[0], -0.05, epsilon = 5e-3);
    for (got, want) in m.slip_yaw.mean.iter().zip([0.03, 0.1, 0.4]) {
        assert_abs_diff_eq!(*got, want, epsilon = 5e-3);
    }
}

/// Steady windows of a car whose body velocity is `f - g`, with the slip of known weights
/// on the car basis.
fn car_slip_windows(gx: [f64; 2], gy: [f64; 2], gw: [f64; 3]) -> (RobotDescription, Vec<Window>) {
    let car = Ackermann::new(0.5, 0.4);
    let r = RobotDescription::new("car", "", 20.0, 40, car.clone());
    let mut out = Vec::new();
    for i in 0..60 {
        // Forward and backward, left and right, at speeds of -3 to 3 m/s.
        let u = Input::new(
            ((i * 7) % 13) as f64 * 0.5 - 3.0,
            ((i * 11) % 17) as f64 * 0.05 - 0.4,
            0.0,
        );
        let f = car.body_velocity(&u);
        let s = car_slip_inputs(&f);
        let g = BodyVelocity::new(
            gx[0] * s.x[0] + gx[1] * s.x[1],
            gy[0] * s.y[0] + gy[1] * s.y[1],
            gw[0] * s.yaw[0] + gw[1] * s.yaw[1] + gw[2] * s.yaw[2],
        );
        out.push(window(
            i,
            Phase::Steady,
            vec![u; 40],
            vec![u; 40],
            arc(f - g, r.dt(), 40),
        ));
    }
    (r, out)
}

#[test]
fn slip_blr_on_a_car_uses_the_car_basis_and_recovers_its_weights() {
    let (gx, gy, gw) = ([0.05, 0.02], [0.1, 0.03], [0.08, 0.02, -0.02]);
    let (r, windows) = car_slip_windows(gx, gy, gw);
    let set = WindowSet::new(&r, &windows);
    let data = drive_traits::SlipData::new(&set, &CommandedPowertrain);
    let m: SlipBlrModel = drive_traits::SlipLearner::fit(&SlipBlr::default(), &data).unwrap();
    assert_eq!(m.basis, SlipBasis::Car);
    for (got, want) in m
        .slip_x
        .mean
        .iter()
        .chain(&m.slip_y.mean)
        .chain(&m.slip_yaw.mean)
        .zip(gx.iter().chain(&gy).chain(&gw))
    {
        assert_abs_diff_eq!(*got, *want, epsilon = 5e-3);
    }
    // The paper's skid-steer basis, forced on the car, cannot represent it.
    let skid = SlipBlr {
        basis: Some(SlipBasis::SkidSteer),
        ..SlipBlr::default()
    };
    let forced: SlipBlrModel = drive_traits::SlipLearner::fit(&skid, &data).unwrap();
    assert_eq!(forced.basis, SlipBasis::SkidSteer);
    let residual = |m: &SlipBlrModel| {
        data.samples(&Default::default())
            .iter()
            .map(|s| (s.slip() - drive_traits::SlipModel::slip(m, &s.commanded)).norm_squared())
            .sum::<f64>()
    };
    assert!(
        residual(&m) < 0.01 * residual(&forced),
        "{} vs {}",
        residual(&m),
        residual(&forced)
    );
}

#[test]
fn slip_blr_files_without_a_basis_are_the_papers() {
    // Model files of format 2 written before the car basis have no "basis": the skid-steer.
    let r = robot();
    let windows = slip_windows(0.2, -0.05, [0.03, 0.1, 0.4]);
    let set = WindowSet::new(&r, &windows);
    let m = Composed::new(Commanded, SlipBlr::default())
        .fit(&set)
        .unwrap();
    let text = model_to_json(&m, &r).unwrap();
    assert!(text.contains("\"basis\": \"skid-steer\""));
    let older = text.replace("\"basis\": \"skid-steer\",", "");
    assert!(!older.contains("basis"));
    let (back, _) = model_from_json("old.json", &older).unwrap();
    let cmds = vec![Input::new(3.0, 5.0, 0.0); 40];
    let start = StartState::at_rest(Pose::zeros());
    assert_eq!(back.predict(&start, &cmds), m.predict(&start, &cmds));
    // A car file whose weights do not match its basis is refused.
    let (cr, cw) = car_slip_windows([0.05, 0.02], [0.1, 0.03], [0.08, 0.02, -0.02]);
    let car = Composed::new(Commanded, SlipBlr::default())
        .fit(&WindowSet::new(&cr, &cw))
        .unwrap();
    let text = model_to_json(&car, &cr).unwrap();
    // A byte-order mark before the JSON is not part of it.
    assert!(model_from_json("m.json", &format!("\u{feff}{text}")).is_ok());
    let mislabelled = text.replace("\"basis\": \"car\"", "\"basis\": \"skid-steer\"");
    assert!(model_from_json("m.json", &mislabelled).is_err());
    // A model whose vehicle is not its robot's: the commands would be read as one and
    // rolled out as the other.
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["model"]["vehicle"] =
        serde_json::json!({"type": "differential", "wheel_radius": 0.165, "baseline": 0.55});
    let err = model_from_json("m.json", &v.to_string()).unwrap_err();
    assert!(err.to_string().contains("is not the robot's"), "{err}");
    // The same vehicle written with integers is the same vehicle.
    let car = serde_json::json!({"type": "ackermann", "wheelbase": 1, "max_steering": 0.4});
    v["model"]["vehicle"] = car.clone();
    v["robot"]["vehicle"] =
        serde_json::json!({"type": "ackermann", "wheelbase": 1.0, "max_steering": 0.4});
    assert!(model_from_json("m.json", &v.to_string()).is_ok());
}

#[test]
fn slip_blr_prediction_hand_computed() {
    let post = |m: Vec<f64>| BlrPosterior {
        covariance: vec![0.0; m.len() * m.len()],
        mean: m,
        a: 10.0,
        b: 1.0,
    };
    let m = composed(
        CommandedPowertrain,
        SlipBlrModel {
            basis: SlipBasis::SkidSteer,
            slip_x: post(vec![0.1]),
            slip_y: post(vec![0.0]),
            slip_yaw: post(vec![0.0, 0.0, 0.5]),
        },
        0.1,
    );
    // Wheels 10, 10: f = (1, 0, 0); g = (0.1, 0, 0); v = 0.9 m/s.
    let p = m.predict(
        &StartState::at_rest(Pose::zeros()),
        &[Input::new(10.0, 10.0, 0.0); 3],
    );
    assert_abs_diff_eq!(p[2], Pose::new(0.18, 0.0, 0.0), epsilon = 1e-12);
    // Wheels 0, 10: f = (0.5, 0, 2); g_w = 0.5 * 2 = 1; v = (0.45, 0, 1).
    let p = m.predict(
        &StartState::at_rest(Pose::zeros()),
        &[Input::new(0.0, 10.0, 0.0); 2],
    );
    assert_abs_diff_eq!(p[1], Pose::new(0.045, 0.0, 0.1), epsilon = 1e-12);
    // Covariance: b/a (1 + 0) * nu/(nu-2) = 0.1 * 20/18 per velocity, times dt^2.
    let (mut poses, mut cov) = (Vec::new(), Vec::new());
    m.predict_with_covariance_into(
        &StartState::at_rest(Pose::zeros()),
        &[Input::new(10.0, 10.0, 0.0); 2],
        &mut poses,
        &mut cov,
    )
    .unwrap();
    assert_abs_diff_eq!(cov[1][(0, 0)], 0.1 * 20.0 / 18.0 * 0.01, epsilon = 1e-15);
    assert_abs_diff_eq!(cov[1][(2, 2)], 0.1 * 20.0 / 18.0 * 0.01, epsilon = 1e-15);
}

#[test]
fn acc_blr_prediction_hand_computed() {
    let post = |m: Vec<f64>| BlrPosterior {
        covariance: vec![0.0; 4],
        mean: m,
        a: 10.0,
        b: 1.0,
    };
    // dv = 0.5 (f - v) in both dimensions.
    let m = AccBlrModel {
        label: "acc-blr+commanded".into(),
        vehicle: Arc::new(vehicle()),
        powertrain: Box::new(CommandedPowertrain),
        accel_x: post(vec![0.5, -0.5]),
        accel_yaw: post(vec![0.5, -0.5]),
        dt: 0.1,
    };
    let start = StartState {
        pose: Pose::zeros(),
        input: Input::zeros(),
        body_velocity: BodyVelocity::new(0.2, 0.3, 0.0),
        yaw_rate: None,
        velocity: None,
        observed: None,
    };
    // f = (1, 0, 0) from wheels 10, 10: v0 = 0.2 (lateral dropped), v1 = 0.6, v2 = 0.8.
    let p = m.predict(&start, &[Input::new(10.0, 10.0, 0.0); 4]);
    assert_abs_diff_eq!(p[1], Pose::new(0.02, 0.0, 0.0), epsilon = 1e-12);
    assert_abs_diff_eq!(p[2], Pose::new(0.08, 0.0, 0.0), epsilon = 1e-12);
    assert_abs_diff_eq!(p[3], Pose::new(0.16, 0.0, 0.0), epsilon = 1e-12);

    // On a powertrain that never moves the wheels (huge time constant, start at rest),
    // f stays 0: v1 = 0.2 + 0.5 (0 - 0.2) = 0.1, so the poses advance by 0.02 then 0.01.
    let frozen = SideResponse {
        time_constant: 1e12,
        delay: 0.0,
    };
    let on_fopdt = AccBlrModel {
        powertrain: Box::new(FopdtPowertrain {
            axes: vec![frozen, frozen],
            limits: drive_traits::InputSpace::new(
                Input::new(-20.0, -20.0, 0.0),
                Input::new(20.0, 20.0, 0.0),
            )
            .unwrap(),
            dt: 0.1,
        }),
        ..m.clone()
    };
    let p = on_fopdt.predict(&start, &[Input::new(10.0, 10.0, 0.0); 3]);
    assert_abs_diff_eq!(p[1], Pose::new(0.02, 0.0, 0.0), epsilon = 1e-9);
    assert_abs_diff_eq!(p[2], Pose::new(0.03, 0.0, 0.0), epsilon = 1e-9);
}

#[test]
fn acc_blr_recovers_first_order_body_dynamics() {
    // Body velocity relaxes towards the commanded one: v[k+1] = v[k] + 0.1 (f - v[k]).
    let r = robot();
    let vehicle = vehicle();
    let mut windows = Vec::new();
    let mut v = BodyVelocity::zeros();
    let mut pose = Pose::zeros();
    for i in 0..60 {
        let u = Input::new(
            ((i * 7) % 13) as f64 - 6.0,
            ((i * 11) % 17) as f64 - 8.0,
            0.0,
        );
        let f = vehicle.eq4(&u);
        let mut poses = Vec::new();
        let start = pose;
        for _ in 0..40 {
            let (s, c) = start.z.sin_cos();
            let (dx, dy) = (pose.x - start.x, pose.y - start.y);
            poses.push(Pose::new(
                c * dx + s * dy,
                -s * dx + c * dy,
                pose.z - start.z,
            ));
            // Fine integration of the continuous dynamics between samples.
            for _ in 0..10 {
                pose = drive_traits::euler_step(&pose, &v, r.dt() / 10.0);
                v += (f - v) * (1.0 - 0.9f64.powf(0.1));
            }
        }
        windows.push(window(
            i,
            if i % 3 == 0 {
                Phase::Transient
            } else {
                Phase::Steady
            },
            vec![u; 40],
            vec![u; 40],
            poses,
        ));
    }
    let m = AccBlr::default()
        .fit_on(
            &WindowSet::new(&r, &windows),
            Box::new(CommandedPowertrain),
            "acc-blr".into(),
        )
        .unwrap();
    assert_abs_diff_eq!(m.accel_x.mean[0], 0.1, epsilon = 5e-3);
    assert_abs_diff_eq!(m.accel_x.mean[1], -0.1, epsilon = 5e-3);
    assert_abs_diff_eq!(m.accel_yaw.mean[0], 0.1, epsilon = 5e-3);
    assert_abs_diff_eq!(m.accel_yaw.mean[1], -0.1, epsilon = 5e-3);
}

#[test]
fn straight_driving_only_gives_a_clear_error_not_a_nan_model() {
    let r = robot();
    let windows: Vec<Window> = (0..6)
        .map(|i| {
            let u = Input::new(5.0 + i as f64, 5.0 + i as f64, 0.0);
            let f = vehicle().eq4(&u);
            window(
                i,
                Phase::Steady,
                vec![u; 40],
                vec![u; 40],
                arc(f * 0.9, r.dt(), 40),
            )
        })
        .collect();
    let err = Composed::new(Commanded, SlipBlr::default())
        .fit(&WindowSet::new(&r, &windows))
        .unwrap_err();
    assert!(
        matches!(err, drive_traits::FitError::DegenerateInputs { .. }),
        "{err}"
    );
}

#[test]
fn model_files_round_trip_and_refuse_unknown_versions() {
    let r = robot();
    let windows = slip_windows(0.2, -0.05, [0.03, 0.1, 0.4]);
    let set = WindowSet::new(&r, &windows);
    let models: Vec<Box<dyn MotionModel>> = vec![
        Box::new(Composed::new(Commanded, NoSlip).fit(&set).unwrap()),
        Box::new(
            Composed::new(Commanded, SlipBlr::default())
                .fit(&set)
                .unwrap(),
        ),
        AccBlr::default().fit_with(&set, Some(&Commanded)).unwrap(),
    ];
    let start = StartState {
        pose: Pose::new(1.0, -2.0, 0.3),
        input: Input::new(1.0, 2.0, 0.0),
        body_velocity: BodyVelocity::new(0.1, 0.0, 0.1),
        yaw_rate: None,
        velocity: None,
        observed: None,
    };
    let cmds: Vec<Input> = (0..40)
        .map(|k| Input::new(k as f64 * 0.1, 3.0 - k as f64 * 0.05, 0.0))
        .collect();
    for m in &models {
        let text = model_to_json(m.as_ref(), &r).unwrap();
        let (back, robot_back) = model_from_json("m.json", &text).unwrap();
        assert_eq!(back.name(), m.name());
        assert_eq!(robot_back, r);
        assert_eq!(back.predict(&start, &cmds), m.predict(&start, &cmds));
        let newer = text.replace("\"format_version\": 2", "\"format_version\": 3");
        assert!(matches!(
            model_from_json("m.json", &newer),
            Err(ModelFileError::UnsupportedVersion { .. })
        ));
        // A field train never writes.
        let extra = text.replacen('{', "{\n  \"extra\": 1,", 1);
        assert!(matches!(
            model_from_json("m.json", &extra),
            Err(ModelFileError::UnknownField { ref field, .. }) if field == "extra"
        ));
        // Nor one inside a part (the powertrain, a slip regression).
        for part in ["\"powertrain\": {", "\"slip_x\": {"] {
            if text.contains(part) {
                let nested = text.replacen(part, &format!("{part}\n  \"extra\": 1,"), 1);
                // Refused (a unit part, the commanded powertrain, takes no field at all).
                let err = model_from_json("m.json", &nested).unwrap_err().to_string();
                assert!(
                    err.contains("unknown field `extra`") || err.contains("unit struct"),
                    "{part}: {err}"
                );
            }
        }
        let unversioned = text.replace("\"format_version\": 2,", "");
        assert!(matches!(
            model_from_json("m.json", &unversioned),
            Err(ModelFileError::MissingField {
                field: "format_version",
                ..
            })
        ));
    }
    assert!(matches!(
        model_from_json("m.json", "not json"),
        Err(ModelFileError::Parse { line: 1, .. })
    ));
    let unknown = model_to_json(models[0].as_ref(), &r)
        .unwrap()
        .replace("\"type\": \"no-slip\"", "\"type\": \"mystery\"");
    let err = model_from_json("m.json", &unknown).unwrap_err();
    assert!(
        matches!(err, ModelFileError::Model { .. }) && err.to_string().contains("mystery"),
        "{err}"
    );
}

/// The commands and start of the model-file fixtures' `*.predict.csv`: `drive predict
/// --commands` with `t,cmd_left,cmd_right` = `k/20, 2 + 0.1 k, 5` (k = 0..39), `--start
/// 0.5,-1.0,0.3 --start-wheels 1,2`.
fn fixture_commands_and_start(robot: &RobotDescription) -> (Vec<Input>, StartState) {
    let cmds = (0..40)
        .map(|k| Input::new(2.0 + 0.1 * k as f64, 5.0, 0.0))
        .collect();
    let start = StartState::measured(
        Pose::new(0.5, -1.0, 0.3),
        Input::new(1.0, 2.0, 0.0),
        &*robot.vehicle,
    );
    (cmds, start)
}

/// The version 1 files written by `drive train` before the models were composed of parts
/// (the previous release, on the bundled Husky data's training half), and what they
/// predicted, from `tests/data/v1/`.
#[test]
fn version_1_model_files_read_as_their_parts_and_predict_the_same() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/v1");
    for name in ["naive", "powertrain", "slip-blr", "acc-blr"] {
        let text = std::fs::read_to_string(dir.join(format!("{name}.json"))).unwrap();
        let (model, robot) = model_from_json(name, &text).unwrap();
        assert_eq!(robot.name, "husky-drive");
        assert_eq!(
            robot.vehicle.geometry(),
            vec![("wheel_radius", 0.165), ("baseline", 0.55)]
        );
        // What the previous release printed with `drive predict` for these commands.
        let expected = std::fs::read_to_string(dir.join(format!("{name}.predict.csv"))).unwrap();
        let (cmds, start) = fixture_commands_and_start(&robot);
        let poses = model.predict(&start, &cmds);
        for (line, p) in expected.lines().skip(1).zip(&poses) {
            let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
            assert!(
                (v[2] - p.x).abs() < 1e-12
                    && (v[3] - p.y).abs() < 1e-12
                    && (v[4] - p.z).abs() < 1e-12,
                "{name}: {line} vs {p:?}"
            );
        }
    }
}

/// A slip-ipem file written by the release before the yaw disturbance and the transport of
/// the body velocity (no such fields, a covariance of the weights and lags only), and what
/// it predicted then, from `tests/data/slip-ipem-v1/`: read by this build, it predicts the
/// same poses and covariances.
#[test]
fn slip_ipem_files_of_the_previous_release_predict_the_same() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/slip-ipem-v1");
    let text = std::fs::read_to_string(dir.join("slip-ipem.json")).unwrap();
    assert!(!text.contains("disturbance_logit") && !text.contains("transport"));
    let (model, robot) = model_from_json("slip-ipem.json", &text).unwrap();
    let expected = std::fs::read_to_string(dir.join("slip-ipem.predict.csv")).unwrap();
    // As `drive predict` starts: the encoders only. A measured yaw rate changes nothing
    // either: the file has no disturbance.
    let (cmds, start) = fixture_commands_and_start(&robot);
    for start in [start, start.with_yaw_rate(0.7)] {
        let (mut poses, mut covariances) = (Vec::new(), Vec::new());
        model
            .predict_with_covariance_into(&start, &cmds, &mut poses, &mut covariances)
            .unwrap();
        assert_eq!(poses, model.predict(&start, &cmds));
        let mut rows = 0;
        for ((line, p), c) in expected.lines().skip(1).zip(&poses).zip(&covariances) {
            let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * (1.0 + a.abs());
            assert!(
                close(v[2], p.x) && close(v[3], p.y) && close(v[4], p.z),
                "{line} vs {p:?}"
            );
            let cov = [
                c[(0, 0)],
                c[(0, 1)],
                c[(0, 2)],
                c[(1, 1)],
                c[(1, 2)],
                c[(2, 2)],
            ];
            for (a, b) in v[5..].iter().zip(cov) {
                assert!(
                    (a - b).abs() <= 1e-9 * (1e-6 + a.abs()),
                    "{line} vs {cov:?}"
                );
            }
            rows += 1;
        }
        assert_eq!(rows, 40);
    }
}

#[test]
fn malformed_model_files_are_refused() {
    let r = robot();
    let mut windows = slip_windows(0.2, -0.05, [0.03, 0.1, 0.4]);
    for w in windows.iter_mut().step_by(3) {
        w.phase = Phase::Transient;
    }
    let set = WindowSet::new(&r, &windows);
    let model = Composed::new(Fopdt::default(), SlipBlr::default())
        .fit(&set)
        .unwrap();
    let slip = model_to_json(&model, &r).unwrap();
    let v: serde_json::Value = serde_json::from_str(&slip).unwrap();
    let edits: [(&str, serde_json::Value); 6] = [
        ("/model/slip/slip_yaw/mean", serde_json::json!([0.1, 0.2])),
        (
            "/model/powertrain/axes/0/time_constant",
            serde_json::json!(-1.0),
        ),
        ("/model/dt", serde_json::json!(0.0)),
        ("/model/vehicle/baseline", serde_json::json!(-0.5)),
        ("/model/slip/slip_x/b", serde_json::json!(-3.0)),
        ("/model/vehicle/wheelbase", serde_json::json!(1.0)),
    ];
    for (pointer, value) in edits {
        let mut bad = v.clone();
        match bad.pointer_mut(pointer) {
            Some(slot) => *slot = value,
            None => {
                // A field the vehicle does not have.
                bad.pointer_mut("/model/vehicle")
                    .unwrap()
                    .as_object_mut()
                    .unwrap()
                    .insert("wheelbase".into(), value);
            }
        }
        let err = model_from_json("m.json", &bad.to_string()).unwrap_err();
        assert!(
            matches!(err, ModelFileError::Model { .. }),
            "{pointer}: {err}"
        );
    }
}

#[test]
fn commanded_powertrain_learner_needs_nothing() {
    let r = robot();
    let pt = Commanded
        .fit(&WindowSet {
            robot: &r,
            windows: vec![],
        })
        .unwrap();
    assert_eq!(
        pt.predict(&Input::zeros(), &[Input::new(1.0, 2.0, 0.0)]),
        vec![Input::new(1.0, 2.0, 0.0)]
    );
}

#[test]
fn a_composed_model_rolls_out_in_batch_as_one_by_one() {
    let m = composed(
        RateLimitedPowertrain {
            axes: vec![
                RateLimitedResponse {
                    time_constant: 0.3,
                    delay: 0.07,
                    max_rate: 5.0,
                };
                2
            ],
            limits: InputSpace::new(Input::new(-6.0, -6.0, 0.0), Input::new(6.0, 6.0, 0.0))
                .unwrap(),
            dt: 0.05,
        },
        NoSlipModel,
        0.05,
    );
    let starts: Vec<StartState> = (0..5)
        .map(|i| StartState {
            pose: Pose::new(i as f64, 0.0, 0.1 * i as f64),
            input: Input::new(0.5 * i as f64, 0.0, 0.0),
            body_velocity: BodyVelocity::zeros(),
            yaw_rate: None,
            velocity: None,
            observed: None,
        })
        .collect();
    let commands: Vec<Input> = (0..5 * 20)
        .map(|k| Input::new((k % 7) as f64, 3.0 - (k % 5) as f64, 0.0))
        .collect();
    let mut batch = vec![Pose::zeros(); commands.len()];
    m.predict_batch_into(&starts, &commands, 20, &mut batch)
        .unwrap();
    for (i, s) in starts.iter().enumerate() {
        let one = m.predict(s, &commands[i * 20..(i + 1) * 20]);
        assert_eq!(&batch[i * 20..(i + 1) * 20], one.as_slice());
    }
}
