//! A vehicle of three inputs end to end on the command line: the built-in omnidirectional
//! (mecanum) base and its preset, the Ridgeback, listed, simulated with its
//! characterization, evaluated with every model, trained, used for predictions and
//! reported; and what a three-input vehicle cannot do said clearly.

use crate::common::{drive, ok, user_error};

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

fn median(text: &str, model: &str) -> (f64, f64) {
    // The first table (all evaluation windows): `model  median  [IQR]  vs naive  median ...`.
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with(&format!("{model} ")))
        .unwrap_or_else(|| panic!("no row for {model} in\n{text}"));
    let numbers: Vec<f64> = line
        .split_whitespace()
        .filter_map(|w| {
            w.trim_matches(|c| c == '[' || c == ']' || c == ',')
                .parse()
                .ok()
        })
        .collect();
    // median, iqr lo, iqr hi, then the rotational median after the percentage.
    (numbers[0], numbers[3])
}

#[test]
fn a_three_input_base_runs_the_whole_protocol_and_slip_blr_beats_naive() {
    let list: serde_json::Value = serde_json::from_str(&ok(&["list", "--json"])).unwrap();
    let omni = list["vehicles"]
        .as_array()
        .unwrap()
        .iter()
        .find(|v| v["name"] == "omnidirectional")
        .expect("the omnidirectional vehicle is listed");
    assert_eq!(omni["inputs"], 3);
    assert_eq!(omni["axes"][1], "v_y [m/s]");
    let preset = list["robots"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["vehicle"] == "omnidirectional")
        .expect("a robot preset uses it");
    assert_eq!(preset["name"], "ridgeback");
    assert_eq!(preset["inputs"], 3);

    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("o.csv");
    let csv = csv.to_str().unwrap();
    let run = drive(&[
        "simulate",
        "--robot",
        "ridgeback",
        "--terrain",
        "gravel",
        "--duration",
        "400",
        "--seed",
        "2",
        "--out",
        csv,
    ]);
    assert!(run.status.success());
    // The characterization found every axis's range.
    let summary = String::from_utf8_lossy(&run.stderr);
    assert!(
        summary.contains("v_x [") && summary.contains("v_y [") && summary.contains("w ["),
        "{summary}"
    );
    let header = std::fs::read_to_string(csv).unwrap();
    assert!(header.starts_with(
        "window,phase,k,t,cmd_vx,cmd_vy,cmd_w,meas_vx,meas_vy,meas_w,x,y,yaw,imu_yaw_rate\n"
    ));
    // The commands drive sideways too: the protocol samples all three axes.
    let lateral = header
        .lines()
        .skip(1)
        .filter_map(|l| l.split(',').nth(5)?.parse::<f64>().ok())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(lateral > 0.5, "largest lateral command {lateral}");

    // The data checks run on three axes (each measured axis against every command).
    let checked = ok(&["check", "--data", csv]);
    assert!(
        checked.contains("passed") || checked.contains("check"),
        "{checked}"
    );
    let eval = ok(&["eval", "--data", csv, "--models", "all"]);
    let (naive_t, naive_r) = median(&eval, "no-slip+commanded");
    let (blr_t, blr_r) = median(&eval, "slip-blr+fopdt");
    assert!(
        blr_t < 0.5 * naive_t,
        "slip-BLR {blr_t} m against naive {naive_t} m"
    );
    assert!(
        blr_r < 0.5 * naive_r,
        "slip-BLR {blr_r} rad against naive {naive_r} rad"
    );

    // Trained, saved, and predicting from a file of three command columns.
    let model = dir.path().join("m.json");
    let model = model.to_str().unwrap();
    ok(&[
        "train", "--data", csv, "--model", "slip-blr", "--out", model,
    ]);
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(model).unwrap()).unwrap();
    assert_eq!(saved["model"]["model"]["slip"]["basis"], "omnidirectional");
    assert_eq!(
        saved["model"]["model"]["powertrain"]["axes"]
            .as_array()
            .map(Vec::len),
        Some(3)
    );
    // A hand-edited file whose powertrain models two of the three axes is refused on load,
    // whichever way its limits are cut.
    let mut cut = saved.clone();
    let powertrain = &mut cut["model"]["model"]["powertrain"];
    powertrain["axes"].as_array_mut().unwrap().truncate(2);
    let edited = dir.path().join("cut.json");
    // `predict` with the edited model file: the error it gives on loading it.
    let refusal = |cut: &serde_json::Value| {
        std::fs::write(&edited, cut.to_string()).unwrap();
        user_error(&[
            "predict",
            "--model",
            edited.to_str().unwrap(),
            "--commands",
            "x.csv",
        ])
    };
    let e = refusal(&cut);
    assert!(e.contains("2 axis responses for limits of 3 axes"), "{e}");
    for limit in ["min", "max"] {
        cut["model"]["model"]["powertrain"]["limits"][limit]
            .as_array_mut()
            .unwrap()
            .truncate(2);
    }
    let e = refusal(&cut);
    assert!(
        e.contains("the powertrain models 2 input axes; the vehicle has 3"),
        "{e}"
    );
    let commands = dir.path().join("c.csv");
    let rows: String = (0..40)
        .map(|k| format!("{},0,0.5,0\n", k as f64 * 0.05))
        .collect();
    std::fs::write(&commands, format!("t,cmd_vx,cmd_vy,cmd_w\n{rows}")).unwrap();
    let commands = commands.to_str().unwrap();
    let predicted = ok(&["predict", "--model", model, "--commands", commands]);
    let last: Vec<f64> = predicted
        .lines()
        .last()
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    // Two seconds of 0.5 m/s to the left: it moved left, not forward.
    assert!(last[3] > 0.3 && last[2].abs() < 0.1, "{last:?}");
    // Two commanded columns for a base of three inputs: the header says what is expected.
    std::fs::write(dir.path().join("two.csv"), "t,cmd_vx,cmd_w\n0,0,0\n").unwrap();
    let e = user_error(&[
        "predict",
        "--model",
        model,
        "--commands",
        dir.path().join("two.csv").to_str().unwrap(),
    ]);
    assert!(e.contains("t,cmd_vx,cmd_vy,cmd_w"), "{e}");
    let e = user_error(&[
        "predict",
        "--model",
        model,
        "--commands",
        commands,
        "--start-wheels",
        "0.1,0",
    ]);
    assert!(e.contains("3 input axes"), "{e}");

    // The report shows the three axes and the base's geometry.
    let out = dir.path().join("report");
    ok(&["report", "--data", csv, "--out", out.to_str().unwrap()]);
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("axis 2 = w [rad/s]"), "{report}");
    assert!(report.contains("| half_track |"));
    assert!(report.contains("powertrain: axis 2 time constant [s]"));

    // A protocol that never commands a lateral speed cannot train a model of the base's
    // lateral motion: refused with the axis named (it fitted slip weights in the thousands
    // on odometry noise, 1e14 m errors), while the naive model, which learns nothing, runs.
    let linear = dir.path().join("linear.csv");
    let linear = linear.to_str().unwrap();
    ok(&[
        "simulate",
        "--robot",
        "ridgeback",
        "--terrain",
        "gravel",
        "--duration",
        "120",
        "--seed",
        "2",
        "--sampler",
        "linear",
        "--out",
        linear,
    ]);
    let e = user_error(&["eval", "--data", linear, "--models", "naive,slip-blr"]);
    assert!(e.contains("never drive the input axis 'v_y'"), "{e}");
    ok(&["eval", "--data", linear, "--models", "naive"]);

    // The logger's raw format holds a twist command: no raw log of a three-input base.
    let e = user_error(&[
        "simulate",
        "--robot",
        "ridgeback",
        "--terrain",
        "gravel",
        "--duration",
        "60",
        "--out",
        csv,
        "--raw-out",
        dir.path().join("raw.csv").to_str().unwrap(),
    ]);
    assert!(e.contains("3 input axes") && e.contains("twist"), "{e}");
}

#[test]
fn a_robot_file_gives_one_range_per_axis_of_its_vehicle() {
    let dir = tempfile::tempdir().unwrap();
    let robot = |name: &str, extra: &str| {
        let path = dir.path().join(name);
        std::fs::write(
            &path,
            format!(
                "name = \"omni\"\nmass_kg = 50\nmax_speed = 1.0\nmax_linear_acceleration = 1\nmax_angular_acceleration = 2\n[vehicle]\ntype = \"omnidirectional\"\nhalf_wheelbase = 0.3\nhalf_track = 0.25\n{extra}"
            ),
        )
        .unwrap();
        path.to_str().unwrap().to_string()
    };
    let csv = dir.path().join("o.csv");
    let sim = |file: &str| {
        vec![
            "simulate".to_string(),
            "--robot".into(),
            file.to_string(),
            "--terrain".into(),
            "tile".into(),
            "--duration".into(),
            "60".into(),
            "--out".into(),
            csv.to_str().unwrap().to_string(),
        ]
    };
    // Two ranges for a base of three axes.
    let file = dir.path().join("two.toml");
    std::fs::write(
        &file,
        "name = \"omni\"\nmass_kg = 50\nmax_speed = 1.0\nmax_linear_acceleration = 1\nmax_angular_acceleration = 2\ninput_limits = [[-1, 1], [-1, 1]]\n[vehicle]\ntype = \"omnidirectional\"\nhalf_wheelbase = 0.3\nhalf_track = 0.25\n",
    )
    .unwrap();
    let e = user_error(&strs(&sim(file.to_str().unwrap())));
    assert!(
        e.contains("input_limits")
            && e.contains("one [min, max] pair per input axis of the vehicle (3)"),
        "{e}"
    );
    // Three ranges: accepted, and the run stays inside them.
    std::fs::write(
        &file,
        "name = \"omni\"\nmass_kg = 50\nmax_speed = 1.0\nmax_linear_acceleration = 1\nmax_angular_acceleration = 2\ninput_limits = [[-1, 1], [-0.5, 0.5], [-1, 1]]\n[vehicle]\ntype = \"omnidirectional\"\nhalf_wheelbase = 0.3\nhalf_track = 0.25\n",
    )
    .unwrap();
    ok(&strs(&sim(file.to_str().unwrap())));
    let text = std::fs::read_to_string(&csv).unwrap();
    let lateral = text
        .lines()
        .skip(1)
        .filter_map(|l| l.split(',').nth(5)?.parse::<f64>().ok())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(lateral <= 0.5 + 1e-12 && lateral > 0.1, "{lateral}");
    // The robot's nominal space (no limits given) is the vehicle's.
    ok(&strs(&sim(&robot("nominal.toml", ""))));
}
