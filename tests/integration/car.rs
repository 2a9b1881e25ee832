//! A car-like robot end to end through the command line: the `autorally` preset simulated,
//! evaluated, trained, predicted, reported, swept, compared, imported from its raw log; and
//! the clear errors where car and skid-steer parts do not fit together.

use crate::common;

use common::{drive, ok, user_error};
use std::path::Path;

/// The run: the car preset on gravel, uniform sampling, 300 s, seed 1.
fn simulate(dir: &Path) -> (String, String) {
    let csv = dir.join("car.csv").display().to_string();
    let raw = dir.join("car-raw.csv").display().to_string();
    let out = drive(&[
        "simulate",
        "--robot",
        "autorally",
        "--terrain",
        "gravel",
        "--sampler",
        "uniform",
        "--duration",
        "300",
        "--seed",
        "1",
        "--out",
        &csv,
        "--raw-out",
        &raw,
    ]);
    // The summary goes to stderr.
    let text = String::from_utf8(out.stderr).unwrap();
    assert!(out.status.success(), "{text}");
    assert!(text.contains("speed [-5.00, 5.00] m/s"), "{text}");
    assert!(text.contains("steering [-0.37, 0.37] rad"), "{text}");
    (csv, raw)
}

fn median(v: &serde_json::Value, model: &str, key: &str) -> f64 {
    v["models"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["name"] == model)
        .unwrap_or_else(|| panic!("no {model}"))[key]
        .as_f64()
        .unwrap()
}

#[test]
fn the_car_preset_runs_through_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let (csv, raw) = simulate(dir.path());
    // The window CSV and its sidecar name the car's axes and vehicle.
    let header = std::fs::read_to_string(&csv).unwrap();
    assert!(header
        .starts_with("window,phase,k,t,cmd_speed,cmd_steering,meas_speed,meas_steering,x,y,yaw"));
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("car.meta.json")).unwrap())
            .unwrap();
    assert_eq!(sidecar["vehicle"]["type"], "ackermann");
    assert_eq!(sidecar["vehicle"]["wheelbase"], 0.57);

    // eval: slip-BLR at least 30% below naive in translation.
    let v: serde_json::Value = serde_json::from_str(&ok(&[
        "eval",
        "--data",
        &csv,
        "--models",
        "naive,slip-blr,slip-blr+rate-limited",
        "--json",
    ]))
    .unwrap();
    let naive = median(&v, "naive", "translational_median_m");
    for m in ["slip-blr", "slip-blr+rate-limited"] {
        let t = median(&v, m, "translational_median_m");
        assert!(t <= 0.7 * naive, "{m}: {t} against naive {naive}");
        assert!(
            median(&v, m, "rotational_median_rad") < median(&v, "naive", "rotational_median_rad")
        );
    }

    // train on the car's basis, predict from a command file in the car's columns.
    let model = dir.path().join("m.json").display().to_string();
    ok(&[
        "train", "--data", &csv, "--model", "slip-blr", "--out", &model,
    ]);
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    // A default train calibrates the covariance: the composed model inside its wrapper.
    assert_eq!(saved["model"]["type"], "calibrated");
    assert_eq!(saved["model"]["model"]["slip"]["basis"], "car");
    let commands = dir.path().join("cmds.csv");
    let mut text = String::from("t,cmd_speed,cmd_steering\n");
    for k in 0..40 {
        text.push_str(&format!("{},2.0,0.2\n", k as f64 * 0.05));
    }
    std::fs::write(&commands, text).unwrap();
    let poses = ok(&[
        "predict",
        "--model",
        &model,
        "--commands",
        &commands.display().to_string(),
        "--start-input",
        "2.0,0.2",
    ]);
    let last: Vec<f64> = poses
        .lines()
        .last()
        .unwrap()
        .split(',')
        .map(|x| x.parse().unwrap())
        .collect();
    // 2 m/s on a 0.57 m wheelbase at 0.2 rad: a left turn of about 1.4 rad in 2 s, less
    // the slip.
    assert!(last[2] > 0.5 && last[4] > 0.8 && last[4] < 1.5, "{last:?}");
    // The skid-steer's columns are refused by name.
    std::fs::write(&commands, "t,cmd_left,cmd_right\n0,1,1\n").unwrap();
    let e = user_error(&[
        "predict",
        "--model",
        &model,
        "--commands",
        &commands.display().to_string(),
    ]);
    assert!(e.contains("t,cmd_speed,cmd_steering"), "{e}");

    // converge, report (figures with the car's axes), protocols on the recording.
    assert!(ok(&["converge", "--data", &csv]).contains("convergence time"));
    let out = dir.path().join("report");
    ok(&[
        "report",
        "--data",
        &csv,
        "--out",
        &out.display().to_string(),
    ]);
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    // slip-BLR's parameters in the car's basis, the car's axes and geometry.
    assert!(
        report.contains("| longitudinal slip: w[f_x f_w^2] |"),
        "{report}"
    );
    assert!(report.contains("axis 0 = speed [m/s], axis 1 = steering [rad]"));
    assert!(report.contains("| wheelbase |"), "{report}");
    let svg = std::fs::read_to_string(out.join("powertrain.svg")).unwrap();
    assert!(svg.contains("steering [rad]") && svg.contains("speed [m/s]"));
    let real = ok(&["compare-protocols", "--real", "--data", &csv]);
    assert!(
        real.contains("linear") && real.contains("angular"),
        "{real}"
    );

    // The raw log has the car's measured columns and imports back to the same windows.
    let raw_header = std::fs::read_to_string(&raw).unwrap();
    assert!(raw_header
        .lines()
        .next()
        .unwrap()
        .contains("meas_speed,meas_steering"));
    let imported = dir.path().join("imported.csv").display().to_string();
    let text = ok(&[
        "import",
        "--raw",
        &raw,
        "--robot",
        "autorally",
        "--out",
        &imported,
    ]);
    assert!(text.contains("132 windows kept"), "{text}");
    // A car's raw log given the Husky: its encoder columns are missing.
    let e = user_error(&[
        "import", "--raw", &raw, "--robot", "husky", "--out", &imported,
    ]);
    assert!(e.contains("meas_left_vel"), "{e}");
}

#[test]
fn the_car_in_the_matrix_and_table_one() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = dir.path().join("sweep.toml");
    std::fs::write(
        &sweep,
        "learners = ['no-slip', 'slip-blr']\npowertrains = ['fopdt', 'rate-limited']\n\
         baseline = 'powertrain'\n\
         [simulated]\nrobots = ['autorally']\nterrains = ['gravel']\nsamplers = ['uniform']\n\
         durations = [60]\nseeds = [1]\ntest_duration = 60\n",
    )
    .unwrap();
    let out = dir.path().join("mx");
    let text = ok(&[
        "matrix",
        "--config",
        &sweep.display().to_string(),
        "--out",
        &out.display().to_string(),
    ]);
    assert!(text.contains("4 combinations"), "{text}");
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(summary.contains("autorally/gravel uniform 60 s | slip-blr+rate-limited"));
    let v: serde_json::Value = serde_json::from_str(&ok(&[
        "compare-protocols",
        "--robot",
        "autorally",
        "--terrain",
        "gravel",
        "--duration",
        "60",
        "--test-duration",
        "60",
        "--json",
    ]))
    .unwrap();
    // 3 training samplers x (3 test runs + mixed).
    assert_eq!(v["rows"].as_array().map(Vec::len), Some(12), "{v}");
}

#[test]
fn car_and_skid_steer_parts_that_do_not_fit_are_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let robot = |name: &str, extra: &str| {
        let path = dir.path().join(name);
        std::fs::write(
            &path,
            format!(
                "name = 'car'\nmass_kg = 5\nmax_speed = 3\n{extra}[vehicle]\ntype = 'ackermann'\n\
                 wheelbase = 0.33\nmax_steering = 0.4\n"
            ),
        )
        .unwrap();
        path.display().to_string()
    };
    let sim = |robot: &str| {
        vec![
            "simulate".to_string(),
            "--robot".into(),
            robot.into(),
            "--terrain".into(),
            "tile".into(),
            "--duration".into(),
            "60".into(),
            "--out".into(),
            dir.path().join("x.csv").display().to_string(),
        ]
    };
    let run = |args: Vec<String>| user_error(&args.iter().map(String::as_str).collect::<Vec<_>>());
    // One range for both "wheels" of a car: speed and steering have other units.
    let e = run(sim(&robot(
        "a.toml",
        "input_rate_limits = [3, 6]\nwheel_limits = [-3, 3]\n",
    )));
    assert!(
        e.contains("wheel_limits") && e.contains("input_limits"),
        "{e}"
    );
    // A car without per-axis rate limits: its steering would jump.
    let e = run(sim(&robot("b.toml", "max_linear_acceleration = 3\n")));
    assert!(e.contains("input_rate_limits"), "{e}");
    // Car data read with a skid-steer sidecar: the columns it expects are named.
    let csv = dir.path().join("car.csv");
    let small = robot("c.toml", "input_rate_limits = [3, 6]\n");
    ok(&[
        "simulate",
        "--robot",
        &small,
        "--terrain",
        "tile",
        "--duration",
        "60",
        "--out",
        &csv.display().to_string(),
    ]);
    let husky_sidecar = dir.path().join("husky.meta.json");
    std::fs::write(
        &husky_sidecar,
        "{\"name\": \"h\", \"robot\": \"husky\", \"rate_hz\": 20, \"window_len\": 40, \
         \"vehicle\": {\"type\": \"differential\", \"wheel_radius\": 0.165, \"baseline\": 0.55}}",
    )
    .unwrap();
    let e = user_error(&[
        "eval",
        "--data",
        &csv.display().to_string(),
        "--sidecar",
        &husky_sidecar.display().to_string(),
    ]);
    assert!(e.contains("cmd_left"), "{e}");
    // A skid-steer's manufacturer limits drawn over a car's data.
    let e = user_error(&[
        "report",
        "--data",
        &csv.display().to_string(),
        "--robot",
        "husky",
        "--out",
        &dir.path().join("rep").display().to_string(),
    ]);
    assert!(e.contains("differential") && e.contains("ackermann"), "{e}");
    assert!(!dir.path().join("rep").exists());
}
