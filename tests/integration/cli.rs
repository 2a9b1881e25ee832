//! End-to-end tests of the `drive` command line on the bundled Husky data.

use crate::common;

use common::{drive, ok, user_error};
use std::path::Path;

fn model<'a>(v: &'a serde_json::Value, name: &str) -> &'a serde_json::Value {
    v["models"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["name"] == name)
        .unwrap_or_else(|| panic!("no {name}"))
}

fn f(v: &serde_json::Value) -> f64 {
    v.as_f64().unwrap()
}

#[test]
fn eval_json_reproduces_the_paper_comparison_on_the_bundled_data() {
    let v: serde_json::Value = serde_json::from_str(&ok(&["eval", "--json"])).unwrap();
    assert_eq!(v["dataset"], "husky-drive");
    assert_eq!(v["train_windows"], 300);
    assert_eq!(v["eval_windows"], 303);
    let names: Vec<&str> = v["models"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["naive", "powertrain", "slip-blr", "acc-blr"]);
    // The naive anchor of the data README: depends only on the data, eq. 4, eq. 1 and eq. 8.
    let naive = model(&v, "naive");
    assert!((f(&naive["translational_median_m"]) / 0.3306 - 1.0).abs() < 0.02);
    assert!((f(&naive["rotational_median_rad"]) / 1.4416 - 1.0).abs() < 0.02);
    let slip = model(&v, "slip-blr");
    let pt = model(&v, "powertrain");
    let (st, sr) = (
        f(&slip["translational_median_m"]),
        f(&slip["rotational_median_rad"]),
    );
    assert!(st <= 0.15 && sr <= 0.15, "slip-blr {st} {sr}");
    for other in [naive, pt] {
        assert!(
            st < f(&other["translational_median_m"]) && sr < f(&other["rotational_median_rad"])
        );
    }
    // The powertrain alone already improves on naive (paper Fig. 6).
    assert!(f(&pt["translational_median_m"]) < f(&naive["translational_median_m"]));
    for m in v["models"].as_array().unwrap() {
        let (q1, q3) = (
            f(&m["translational_iqr_m"][0]),
            f(&m["translational_iqr_m"][1]),
        );
        assert!(q1 <= f(&m["translational_median_m"]) && f(&m["translational_median_m"]) <= q3);
        let (q1, q3) = (
            f(&m["rotational_iqr_rad"][0]),
            f(&m["rotational_iqr_rad"][1]),
        );
        assert!(q1 <= f(&m["rotational_median_rad"]) && f(&m["rotational_median_rad"]) <= q3);
        assert_eq!(
            m["transient"]["windows"].as_u64().unwrap() + m["steady"]["windows"].as_u64().unwrap(),
            303
        );
    }
}

#[test]
fn eval_table_subset_split_and_per_window_file() {
    let dir = tempfile::tempdir().unwrap();
    let per_window = dir.path().join("errors.csv");
    let table = ok(&[
        "eval",
        "--models",
        "naive,slip-blr",
        "--split",
        "0.3",
        "--per-window",
        per_window.to_str().unwrap(),
    ]);
    assert!(table.contains("husky-drive"), "{table}");
    assert!(
        table.contains("first 60 intervals (180 windows)"),
        "{table}"
    );
    assert!(
        table.contains("slip-blr") && !table.contains("acc-blr"),
        "{table}"
    );
    assert!(table.contains("transient windows") && table.contains("steady windows"));
    let csv = std::fs::read_to_string(&per_window).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(
        lines[0],
        "model,window,interval,phase,translational_m,rotational_rad"
    );
    assert_eq!(lines.len(), 1 + 2 * (603 - 180));
    assert!(lines[1].starts_with("naive,180,60,transient,"));
}

#[test]
fn slip_ipem_is_a_tenth_better_than_slip_blr_on_both_errors() {
    let v: serde_json::Value =
        serde_json::from_str(&ok(&["eval", "--json", "--models", "slip-blr,slip-ipem"])).unwrap();
    let (blr, ipem) = (model(&v, "slip-blr"), model(&v, "slip-ipem"));
    assert_eq!(ipem["model"], "slip-ipem+fopdt");
    for key in ["translational_median_m", "rotational_median_rad"] {
        assert!(
            f(&ipem[key]) <= 0.9 * f(&blr[key]),
            "{key}: slip-ipem {} vs slip-blr {}",
            ipem[key],
            blr[key]
        );
    }
}

#[test]
fn calibrated_95_percent_regions_hold_90_to_98_percent_and_the_papers_do_not() {
    // Issue 14: on the evaluation half, which the calibration never sees.
    let v: serde_json::Value = serde_json::from_str(&ok(&[
        "eval",
        "--json",
        "--models",
        "naive,slip-blr,slip-ipem",
    ]))
    .unwrap();
    assert!(model(&v, "naive").get("coverage95").is_none()); // no covariance, no figure
    for name in ["slip-blr", "slip-ipem"] {
        let m = model(&v, name);
        assert_eq!(m["uncertainty"], "calibrated");
        for key in ["coverage95", "yaw_coverage95"] {
            let c = m[key].as_object().unwrap();
            assert_eq!(c.keys().collect::<Vec<_>>(), ["0.5", "1.0", "2.0"]);
            for (h, f) in c {
                let f = f.as_f64().unwrap();
                // Cross-conformal on two halves errs on the safe side at the end of the
                // horizon (each fold's model saw half the training windows): slip-BLR's yaw
                // at 2 s holds 302 of 303, its steady windows all of theirs (issue 29 keeps
                // it open); at 0.5 and 1 s within 94-98%.
                let most = if h == "2.0" { 0.997 } else { 0.98 };
                assert!((0.90..=most).contains(&f), "{name} {key} at {h} s: {f}");
            }
        }
        assert!(f(&m["nll"]).is_finite());
        // Issue 29: which predictions the regions say are hard, in the JSON the issue names.
        for (key, groups) in [
            ("coverage95_by_phase", &["steady", "transient"][..]),
            ("yaw_coverage95_by_phase", &["steady", "transient"][..]),
            ("coverage95_by_speed", &["high", "low", "mid"][..]),
        ] {
            let g = m[key].as_object().unwrap();
            assert_eq!(g.keys().collect::<Vec<_>>(), groups, "{name} {key}");
            for horizons in g.values() {
                let h = horizons.as_object().unwrap();
                assert_eq!(h.keys().collect::<Vec<_>>(), ["0.5", "1.0", "2.0"]);
                assert!(h.values().all(|v| (0.0..=1.0).contains(&f(v))));
            }
        }
        assert!(f(&m["area_ratio_to_constant"]) > 0.0);
        for axis in ["position", "yaw"] {
            let r = f(&m["error_rank_correlation"][axis]);
            assert!((-1.0..=1.0).contains(&r), "{name} {axis} {r}");
        }
        for phase in ["transient", "steady"] {
            let diagram = m["reliability_by_phase"][phase].as_array().unwrap();
            assert_eq!(diagram.len(), 8);
            assert_eq!(f(&diagram[5]["nominal"]), 0.95);
        }
    }
    // The paper's propagation (eq. 7, independent steps) is far too confident at 2 s.
    let paper: serde_json::Value = serde_json::from_str(&ok(&[
        "eval",
        "--json",
        "--models",
        "slip-blr",
        "--uncertainty",
        "paper",
    ]))
    .unwrap();
    let m = model(&paper, "slip-blr");
    assert_eq!(m["uncertainty"], "paper");
    assert!(f(&m["coverage95"]["2.0"]) < 0.5, "{}", m["coverage95"]);
    // The means do not depend on the uncertainty method.
    assert_eq!(
        m["translational_median_m"],
        model(&v, "slip-blr")["translational_median_m"]
    );
}

#[test]
fn start_information_is_the_same_for_every_model_and_moves_only_velocity_state_models() {
    let eval = |start: &str| -> serde_json::Value {
        serde_json::from_str(&ok(&[
            "eval",
            "--json",
            "--models",
            "slip-blr,acc-blr",
            "--start",
            start,
        ]))
        .unwrap()
    };
    let (imu, enc) = (eval("encoders+imu"), eval("encoders"));
    assert_eq!(model(&enc, "acc-blr")["start"], "encoders");
    // slip-BLR's rollout does not use the start body velocity: identical errors.
    for key in ["translational_median_m", "rotational_median_rad"] {
        assert_eq!(model(&imu, "slip-blr")[key], model(&enc, "slip-blr")[key]);
    }
    // acc-BLR integrates from it: without the IMU's yaw rate it turns worse, and slip-BLR
    // wins rotation (as in the paper).
    let acc = |v: &serde_json::Value| f(&model(v, "acc-blr")["rotational_median_rad"]);
    assert!(acc(&enc) > acc(&imu));
    assert!(f(&model(&enc, "slip-blr")["rotational_median_rad"]) < acc(&enc));
    assert!(user_error(&["eval", "--start", "gps"]).contains("gps"));
}

#[test]
fn eval_gives_paired_bootstrap_intervals_over_naive_and_over_slip_blr() {
    let v: serde_json::Value = serde_json::from_str(&ok(&[
        "eval",
        "--json",
        "--models",
        "naive,slip-blr,slip-ipem",
    ]))
    .unwrap();
    assert_eq!(v["bootstrap"]["resamples"], 1000);
    let imp = |m: &str, over: &str, kind: &str| -> (f64, f64, f64) {
        let i = &model(&v, m)[over][kind];
        (f(&i["percent"]), f(&i["ci"][0]), f(&i["ci"][1]))
    };
    for m in ["naive", "slip-blr", "slip-ipem"] {
        for over in ["improvement_over_naive", "improvement_over_slip_blr"] {
            for kind in ["translational", "rotational"] {
                let (p, lo, hi) = imp(m, over, kind);
                assert!(lo <= p && p <= hi, "{m} {over} {kind}: {p} [{lo}, {hi}]");
            }
        }
    }
    // The reference against itself: exactly zero on every draw.
    assert_eq!(
        imp("slip-blr", "improvement_over_slip_blr", "translational"),
        (0.0, 0.0, 0.0)
    );
    assert_eq!(
        imp("naive", "improvement_over_naive", "rotational"),
        (0.0, 0.0, 0.0)
    );
    // The point figure is the one of the medians.
    let (p, _, _) = imp("slip-blr", "improvement_over_naive", "translational");
    let t = |m: &str| f(&model(&v, m)["translational_median_m"]);
    assert!((p - 100.0 * (t("naive") - t("slip-blr")) / t("naive")).abs() < 1e-9);
    // slip-BLR is far better than naive in rotation, beyond doubt.
    assert!(imp("slip-blr", "improvement_over_naive", "rotational").1 > 80.0);
    // The text shows the same intervals.
    let text = ok(&["eval", "--models", "naive,slip-blr"]);
    assert!(text.contains("paired bootstrap, 1000 resamples of the evaluation intervals"));
}

#[test]
fn frame_corrected_rotates_the_bundled_positions_and_leaves_yaw_and_first_sample_data_alone() {
    let eval = |data: &[&str], frame: &str| -> (serde_json::Value, String) {
        let mut args = vec![
            "eval",
            "--json",
            "--models",
            "naive,slip-blr",
            "--frame",
            frame,
        ];
        args.extend_from_slice(data);
        let out = drive(&args);
        assert!(out.status.success());
        (
            serde_json::from_slice(&out.stdout).unwrap(),
            String::from_utf8(out.stderr).unwrap(),
        )
    };
    let (published, note) = eval(&[], "as-published");
    let (corrected, note_c) = eval(&[], "corrected");
    // The bundled sidecar declares the paper parser's frame: noted in one line.
    assert_eq!(note.lines().count(), 1, "{note}");
    assert!(note.contains("paper parser's frame") && note.contains("--frame corrected"));
    assert!(note_c.contains("rotated"), "{note_c}");
    // Positions move (the paper's numbers stay the default), yaw does not.
    let t = |v: &serde_json::Value, m: &str| f(&model(v, m)["translational_median_m"]);
    assert!((t(&published, "naive") - 0.3306).abs() < 5e-5);
    assert!((t(&published, "naive") - t(&corrected, "naive")).abs() > 1e-4);
    for m in ["naive", "slip-blr"] {
        assert_eq!(
            model(&published, m)["rotational_median_rad"],
            model(&corrected, m)["rotational_median_rad"]
        );
    }
    // Data already in the first sample's frame (the simulator's) is unchanged, and not noted.
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("sim.csv");
    ok(&[
        "simulate",
        "--robot",
        "husky",
        "--terrain",
        "snow",
        "--duration",
        "120",
        "--seed",
        "3",
        "--out",
        csv.to_str().unwrap(),
    ]);
    let side: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(csv.with_extension("meta.json")).unwrap())
            .unwrap();
    assert_eq!(side["position_frame"], "first-sample");
    let data = ["--data", csv.to_str().unwrap()];
    let ((a, na), (b, nb)) = (eval(&data, "as-published"), eval(&data, "corrected"));
    for m in ["naive", "slip-blr"] {
        for key in [
            "translational_median_m",
            "rotational_median_rad",
            "coverage95",
        ] {
            assert_eq!(model(&a, m)[key], model(&b, m)[key]);
        }
    }
    // No note of the frame (its 8 evaluation intervals get the note of too few).
    assert!(!na.contains("frame") && !nb.contains("frame"), "{na}{nb}");
    assert!(user_error(&["eval", "--frame", "map"]).contains("map"));
}

#[test]
fn train_then_predict_matches_the_library() {
    let dir = tempfile::tempdir().unwrap();
    let commands = dir.path().join("cmds.csv");
    let mut text = String::from("t,cmd_left,cmd_right\n");
    for k in 0..40 {
        text += &format!("{},{},{}\n", k as f64 / 20.0, 2.0 + 0.1 * k as f64, 5.0);
    }
    std::fs::write(&commands, text).unwrap();
    for name in ["naive", "powertrain", "slip-blr", "acc-blr", "slip-ipem"] {
        let file = dir.path().join(format!("{name}.json"));
        ok(&[
            "train",
            "--model",
            name,
            "--split",
            "0.5",
            "--out",
            file.to_str().unwrap(),
        ]);
        let out = ok(&[
            "predict",
            "--model",
            file.to_str().unwrap(),
            "--commands",
            commands.to_str().unwrap(),
            "--start",
            "1,-1,0.5",
            "--start-wheels",
            "2,5",
        ]);
        let lines: Vec<&str> = out.lines().collect();
        assert_eq!(lines.len(), 41);
        let with_cov = name.ends_with("blr") || name == "slip-ipem";
        assert_eq!(
            lines[0].split(',').count(),
            if with_cov { 11 } else { 5 },
            "{}",
            lines[0]
        );
        assert_eq!(
            lines[1].split(',').take(5).collect::<Vec<_>>(),
            ["0", "0", "1", "-1", "0.5"]
        );
        // Same numbers as the library on the same model file.
        let (m, robot) = drive::models::model_file::model_from_json(
            "m",
            &std::fs::read_to_string(&file).unwrap(),
        )
        .unwrap();
        let wheels = drive::traits::Input::new(2.0, 5.0, 0.0);
        let start = drive::traits::StartState::measured(
            drive::traits::Pose::new(1.0, -1.0, 0.5),
            wheels,
            &*robot.vehicle,
        );
        let cmds: Vec<_> = (0..40)
            .map(|k| drive::traits::Input::new(2.0 + 0.1 * k as f64, 5.0, 0.0))
            .collect();
        let poses = m.predict(&start, &cmds);
        let last: Vec<f64> = lines[40]
            .split(',')
            .skip(2)
            .take(3)
            .map(|x| x.parse().unwrap())
            .collect();
        assert_eq!(last, [poses[39].x, poses[39].y, poses[39].z]);
    }
}

/// Issue 63 (a second sweep): `predict` refused the schedule `drive protocol` writes (its
/// interval and phase columns); it predicts it as the same commands in a plain file.
#[test]
fn predict_takes_a_schedule_from_protocol() {
    let dir = tempfile::tempdir().unwrap();
    let at = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    ok(&["train", "--model", "slip-blr", "--out", &at("m.json")]);
    ok(&[
        "protocol",
        "--robot",
        "husky",
        "--intervals",
        "2",
        "--out",
        &at("proto.csv"),
    ]);
    let schedule = std::fs::read_to_string(at("proto.csv")).unwrap();
    assert!(
        schedule.starts_with("t,interval,phase,cmd_left,cmd_right\n"),
        "{schedule}"
    );
    let plain: String = schedule
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            format!("{},{},{}\n", f[0], f[3], f[4])
        })
        .collect();
    std::fs::write(at("plain.csv"), plain).unwrap();
    let predict = |file: &str| ok(&["predict", "--model", &at("m.json"), "--commands", &at(file)]);
    let out = predict("proto.csv");
    assert_eq!(out.lines().count(), schedule.lines().count());
    assert_eq!(out, predict("plain.csv"));
}

/// Issue 63: a model file keeps the commands it was trained on, and `predict` says so when
/// it is given commands beyond them (a command in another unit: 1e8 rad/s went through a
/// naive model to 58,500 km, and through slip-BLR's saturating powertrain without a word).
#[test]
fn predict_notes_commands_beyond_what_the_model_was_trained_on() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, value: f64| {
        let path = dir.path().join(name);
        let mut text = String::from("t,cmd_left,cmd_right\n");
        for k in 0..10 {
            text += &format!("{},{value},{}\n", k as f64 / 20.0, 1.0);
        }
        std::fs::write(&path, text).unwrap();
        path
    };
    let (within, beyond) = (write("within.csv", 2.0), write("beyond.csv", 1e8));
    for name in ["naive", "acc-blr", "slip-blr"] {
        let file = dir.path().join(format!("{name}.json"));
        ok(&["train", "--model", name, "--out", file.to_str().unwrap()]);
        let saved: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
        // The bundled Husky run's commands: about -14.5 to 12.7 rad/s on each side.
        let range = &saved["fitted_with"]["commanded"];
        assert!(
            f(&range["min"][0]) < -14.0 && f(&range["max"][0]) > 12.0,
            "{range}"
        );
        let run = |commands: &Path| {
            drive(&[
                "predict",
                "--model",
                file.to_str().unwrap(),
                "--commands",
                commands.to_str().unwrap(),
            ])
        };
        let out = run(&within);
        assert!(out.status.success());
        assert!(!String::from_utf8_lossy(&out.stderr).contains("beyond"));
        let out = run(&beyond);
        assert!(out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("command 0 holds 1e8 rad/s on axis 'cmd_left', beyond the commands it was trained on"),
            "{name}: {err}"
        );
        let consequence = if name == "slip-blr" {
            "its powertrain saturates it"
        } else {
            "the model extrapolates beyond its data"
        };
        assert!(err.contains(consequence), "{name}: {err}");
        // A start beyond them (a tenth outside sweep: --start-wheels 1e6 went to 1e7 m, and
        // --start-velocity 1e8 to 1.8e7 m, without a word) is noted; one within is not.
        let started = |flag: &str, value: &str| {
            let out = drive(&[
                "predict",
                "--model",
                file.to_str().unwrap(),
                "--commands",
                within.to_str().unwrap(),
                &format!("{flag}={value}"),
            ]);
            assert!(out.status.success(), "{name} {flag}");
            String::from_utf8_lossy(&out.stderr).into_owned()
        };
        let err = started("--start-wheels", "1e6,1e6");
        assert!(
            err.contains("--start-wheels holds 1e6 rad/s on axis 'enc_left', beyond the commands it was trained on"),
            "{name}: {err}"
        );
        assert!(
            !started("--start-wheels", "3,4").contains("beyond"),
            "{name}"
        );
        let err = started("--start-velocity", "1e8,0");
        assert!(
            err.contains("--start-velocity is 1e8 m/s, over twice the fastest"),
            "{name}: {err}"
        );
        assert!(
            !started("--start-velocity", "0.5,0").contains("over twice"),
            "{name}"
        );
        // A yaw rate of 50 rad/s (a second sweep of issue 63: taken without a word).
        let err = started("--start-yaw-rate", "50");
        assert!(
            err.contains("--start-yaw-rate is 50 rad/s, over twice the fastest"),
            "{name}: {err}"
        );
        assert!(
            !started("--start-yaw-rate", "0.5").contains("over twice"),
            "{name}"
        );
        assert!(
            !started("--start", "0,0,0").contains("no robot moves so"),
            "{name}"
        );
    }
    // A model file whose slip weight was edited to 1e6 (the same sweep: a yaw of 637,557
    // rad in two seconds, without a word): refused where it is read, as a model that moves
    // more than five times what its commands ask (before, its prediction was noted as no
    // robot's).
    let file = dir.path().join("slip-blr.json");
    let mut saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let weight = saved
        .pointer_mut("/model/model/slip/slip_yaw/mean/2")
        .expect("slip-BLR's yaw weights");
    *weight = serde_json::json!(1e6);
    let edited = dir.path().join("edited.json");
    std::fs::write(&edited, saved.to_string()).unwrap();
    let err = user_error(&[
        "predict",
        "--model",
        edited.to_str().unwrap(),
        "--commands",
        within.to_str().unwrap(),
    ]);
    assert!(err.contains("moves more than 5 times"), "{err}");
}

fn write_small_dataset(dir: &Path) -> std::path::PathBuf {
    let csv = dir.join("small.csv");
    let registries = drive::Registries::builtin();
    let mut data =
        drive::studies::simulate_protocol(&registries, "warthog", "gravel", "uniform", 4, 1)
            .unwrap()
            .dataset;
    data.robot.name = "small".into();
    drive::data::write_dataset(&data, &csv).unwrap();
    csv
}

#[test]
fn bad_data_is_a_one_line_error_naming_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let csv = write_small_dataset(dir.path());
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let fields: Vec<&str> = lines[10].split(',').collect();
    let mut bad = fields.clone();
    bad[6] = "NaN"; // enc_left
    lines[10] = bad.join(",");
    std::fs::write(&csv, lines.join("\n")).unwrap();
    let err = user_error(&["eval", "--data", csv.to_str().unwrap()]);
    assert!(
        err.contains("small.csv, line 11, column 'enc_left'")
            && err.contains("not a finite number"),
        "{err}"
    );
    std::fs::remove_file(dir.path().join("small.meta.json")).unwrap();
    let err = user_error(&["eval", "--data", csv.to_str().unwrap()]);
    assert!(err.contains("small.meta.json"), "{err}");
}

#[test]
fn other_user_errors() {
    let dir = tempfile::tempdir().unwrap();
    assert!(user_error(&["eval", "--models", "naive,magic"]).contains("unknown model 'magic'"));
    assert!(user_error(&["train", "--model", "naive"]).contains("--out"));
    assert!(user_error(&["eval", "--split", "half"]).contains("--split"));
    assert!(user_error(&[
        "predict",
        "--model",
        "m.json",
        "--commands",
        "c.csv",
        "--start",
        "1,2"
    ])
    .contains("expected 3 comma-separated numbers"));
    assert!(drive(&["--help"]).status.success());
    assert!(user_error(&["eval", "--split", "1"]).contains("split fraction 1"));
    assert!(
        user_error(&["eval", "--data", "/nonexistent/run.csv"]).contains("/nonexistent/run.csv")
    );
    let out = dir.path().join("m.json");
    assert!(
        user_error(&["train", "--model", "magic", "--out", out.to_str().unwrap()])
            .contains("unknown model")
    );
    // A model file from a newer format.
    ok(&["train", "--model", "naive", "--out", out.to_str().unwrap()]);
    let newer = std::fs::read_to_string(&out)
        .unwrap()
        .replace("\"format_version\": 2", "\"format_version\": 7");
    std::fs::write(&out, newer).unwrap();
    let cmds = dir.path().join("c.csv");
    std::fs::write(&cmds, "t,cmd_left,cmd_right\n0,1,1\n0.05,1,1\n").unwrap();
    assert!(user_error(&[
        "predict",
        "--model",
        out.to_str().unwrap(),
        "--commands",
        cmds.to_str().unwrap()
    ])
    .contains("version 7 is not supported"));
    // Bad command files.
    ok(&["train", "--model", "naive", "--out", out.to_str().unwrap()]);
    for (text, needle) in [
        ("t,left,right\n0,1,1\n", "expected the header"),
        (
            "t,cmd_left,cmd_right\n0,1,x\n",
            "line 2, column 'cmd_right'",
        ),
        (
            "t,cmd_left,cmd_right\n0,1,1\n0.5,1,1\n",
            "line 3, column 't'",
        ),
        ("t,cmd_left,cmd_right\n", "no command rows"),
    ] {
        std::fs::write(&cmds, text).unwrap();
        let err = user_error(&[
            "predict",
            "--model",
            out.to_str().unwrap(),
            "--commands",
            cmds.to_str().unwrap(),
        ]);
        assert!(err.contains(needle), "{err}");
    }
}

#[test]
fn converge_on_the_bundled_data_meets_the_papers_rule_within_a_minute() {
    let v: serde_json::Value = serde_json::from_str(&ok(&["converge", "--json"])).unwrap();
    let t = v["convergence_time_s"]
        .as_f64()
        .expect("the curve converges");
    assert!(t <= 60.0, "convergence time {t}");
    let curve = v["curve"].as_array().unwrap();
    // 100 training intervals of 6 s, each evaluated on the same 303 windows.
    assert_eq!(curve.len() + v["skipped"].as_array().unwrap().len(), 100);
    assert_eq!(v["eval_windows"], 303);
    let last = curve.last().unwrap();
    assert_eq!(last["training_time_s"], 600.0);
    // The last point is the full training half: the same numbers as `drive eval`.
    let e: serde_json::Value =
        serde_json::from_str(&ok(&["eval", "--json", "--models", "slip-blr"])).unwrap();
    for key in ["translational_median_m", "rotational_median_rad"] {
        assert!(
            (f(&last[key]) - f(&e["models"][0][key])).abs() < 1e-9,
            "{key}"
        );
    }
    // slip-BLR follows the data online; 30 random orders give a spread around the
    // recording order's curve and all meet at the full training half.
    assert_eq!(v["fitting"], "online");
    let orders = &v["random_orders"];
    assert_eq!(orders["orders"], 30);
    let spread = orders["curve"].as_array().unwrap();
    let end = spread.last().unwrap();
    assert_eq!(end["intervals"], 100);
    let [lo, med, hi] = [0, 1, 2].map(|i| f(&end["translational_m"][i]));
    // (The powertrain's Nelder-Mead fit sums the windows in the order given: 1e-8 apart.)
    assert!((hi - lo).abs() < 1e-6 && (med - f(&last["translational_median_m"])).abs() < 1e-6);
    let first = &spread[0];
    assert!(f(&first["translational_m"][0]) < f(&first["translational_m"][2]));
    let times = orders["convergence_time_s"].as_array().unwrap();
    assert!(f(&times[0]) <= f(&times[1]) && f(&times[1]) <= f(&times[2]));
    // A baseline without an online fit is fitted from scratch at every amount.
    let b: serde_json::Value = serde_json::from_str(&ok(&[
        "converge", "--json", "--model", "acc-blr", "--orders", "0",
    ]))
    .unwrap();
    assert_eq!(b["fitting"], "batch");
    assert!(b.get("random_orders").is_none());
    // From the convergence time on, every gradient is under the thresholds.
    let pts: Vec<(f64, f64, f64)> = curve
        .iter()
        .map(|p| {
            (
                f(&p["training_time_s"]),
                f(&p["translational_median_m"]),
                f(&p["rotational_median_rad"]),
            )
        })
        .collect();
    for w in pts.windows(2).filter(|w| w[0].0 >= t) {
        let dt = w[1].0 - w[0].0;
        assert!(((w[1].1 - w[0].1) / dt).abs() < 0.01 && ((w[1].2 - w[0].2) / dt).abs() < 0.01);
    }
}

#[test]
fn protocol_schedule_is_byte_identical_for_a_seed() {
    let dir = tempfile::tempdir().unwrap();
    let path = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let robot_file = path("mine.toml");
    std::fs::write(
        &robot_file,
        "name = 'mine'\nmass_kg = 30\nwheel_radius = 0.1\nbaseline = 0.4\nmax_speed = 1.5\nmax_linear_acceleration = 1.0\nmax_angular_acceleration = 3.0\nrate_hz = 10\n",
    )
    .unwrap();
    for robot in ["husky", "hd2", "warthog", robot_file.as_str()] {
        for sampler in ["uniform", "grid", "linear", "angular"] {
            let (a, b, c) = (path("a.csv"), path("b.csv"), path("c.csv"));
            let schedule = |seed: &str, out: &str| {
                ok(&[
                    "protocol",
                    "--robot",
                    robot,
                    "--sampler",
                    sampler,
                    "--intervals",
                    "5",
                    "--seed",
                    seed,
                    "--out",
                    out,
                ]);
            };
            schedule("3", &a);
            schedule("3", &b);
            schedule("4", &c);
            let (ta, tb, tc) = (
                std::fs::read(&a).unwrap(),
                std::fs::read(&b).unwrap(),
                std::fs::read(&c).unwrap(),
            );
            assert_eq!(ta, tb, "{robot} {sampler}");
            assert_ne!(ta, tc, "{robot} {sampler}");
            let text = String::from_utf8(ta).unwrap();
            let rate = if robot == robot_file { 10 } else { 20 };
            assert_eq!(text.lines().count(), 1 + 5 * 6 * rate, "{robot} {sampler}");
            assert!(text.starts_with("t,interval,phase,cmd_left,cmd_right\n0,0,transient,"));
        }
    }
    assert!(user_error(&[
        "protocol",
        "--robot",
        "rover",
        "--intervals",
        "2",
        "--out",
        &path("x.csv")
    ])
    .contains("unknown robot"));
    std::fs::write(&robot_file, "name = 'bad'\n").unwrap();
    assert!(user_error(&[
        "protocol",
        "--robot",
        &robot_file,
        "--intervals",
        "2",
        "--out",
        &path("x.csv")
    ])
    .contains("mine.toml"));
}

#[test]
fn simulate_then_eval_works_on_the_simulated_windows() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("sim.csv");
    let csv = csv.to_str().unwrap();
    let sim = |seed: &str| {
        ok(&[
            "simulate",
            "--robot",
            "warthog",
            "--terrain",
            "gravel",
            "--duration",
            "150",
            "--seed",
            seed,
            "--out",
            csv,
        ]);
        std::fs::read(csv).unwrap()
    };
    let first = sim("2");
    assert_eq!(first, sim("2"), "same seed, same bytes");
    let v: serde_json::Value =
        serde_json::from_str(&ok(&["eval", "--json", "--data", csv])).unwrap();
    assert!(v["dataset"]
        .as_str()
        .unwrap()
        .starts_with("sim-warthog-gravel-uniform"));
    // 150 s: 24 s of characterization, then 21 complete intervals of 6 s.
    assert_eq!(
        v["train_windows"].as_u64().unwrap() + v["eval_windows"].as_u64().unwrap(),
        63
    );
    let get = |name: &str| {
        v["models"]
            .as_array()
            .unwrap()
            .iter()
            .find(|m| m["name"] == name)
            .unwrap()["rotational_median_rad"]
            .as_f64()
            .unwrap()
    };
    assert!(get("slip-blr") < get("naive"));
    assert!(user_error(&[
        "simulate",
        "--robot",
        "husky",
        "--terrain",
        "mud",
        "--duration",
        "60",
        "--out",
        csv
    ])
    .contains("unknown terrain 'mud'"));
    assert!(user_error(&[
        "simulate",
        "--robot",
        "husky",
        "--terrain",
        "ice",
        "--duration",
        "10",
        "--out",
        csv
    ])
    .contains("no complete interval"));
}

#[test]
fn compare_protocols_on_the_simulator_json_and_table_agree() {
    let args = [
        "compare-protocols",
        "--robot",
        "husky",
        "--terrain",
        "snow,ice",
        "--duration",
        "30",
        "--test-duration",
        "60",
    ];
    let v: serde_json::Value =
        serde_json::from_str(&ok(&[&args[..], &["--json"]].concat())).unwrap();
    assert_eq!(v["model"], "slip-blr");
    assert_eq!(v["reference"], "uniform");
    assert_eq!(
        v["test_sets"],
        serde_json::json!(["uniform", "linear", "angular", "mixed"])
    );
    let rows = v["rows"].as_array().unwrap();
    // 2 terrains x 4 test sets x 3 training samplers: the cross table.
    assert_eq!(rows.len(), 2 * 4 * 3);
    let pairs: std::collections::BTreeSet<(String, String)> = rows
        .iter()
        .map(|r| {
            (
                r["train_sampler"].as_str().unwrap().to_string(),
                r["test_sampler"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    assert_eq!(pairs.len(), 12);
    let table = ok(&args);
    for r in rows {
        assert_eq!(r["seeds"], 1);
        // Each row is in the table with its medians to four decimals.
        let cell = format!(
            "{:.4} / {:.4}",
            f(&r["translational_median_m"]),
            f(&r["rotational_median_rad"])
        );
        assert!(table.contains(&cell), "{cell} not in\n{table}");
        if r["train_sampler"] != "uniform" {
            let imp = &r["reference_improvement_translational"];
            let line = format!(
                "tested on {:<10} {:+.1}% [{:+.1}, {:+.1}]",
                r["test_sampler"].as_str().unwrap(),
                f(&imp["percent"]),
                f(&imp["ci"][0]),
                f(&imp["ci"][1])
            );
            assert!(table.contains(&line), "{line} not in\n{table}");
        }
    }
    assert!(table
        .contains("tested on uniform: mean improvement of uniform over angular in translation"));
    assert!(table.contains(&format!("  tested on {:<10} translation best", "mixed")));
}

#[test]
fn compare_protocols_on_the_bundled_data() {
    let v: serde_json::Value = serde_json::from_str(&ok(&[
        "compare-protocols",
        "--real",
        "--draws",
        "5",
        "--json",
    ]))
    .unwrap();
    assert_eq!(v["dataset"], "husky-drive");
    assert_eq!(v["train_intervals"], 100);
    assert_eq!(v["eval_windows"], 303);
    let regions = v["regions"].as_array().unwrap();
    assert_eq!(regions[0]["region"], "linear");
    assert_eq!(regions[1]["region"], "angular");
    for r in regions {
        let n = r["intervals"].as_u64().unwrap();
        assert!((2..100).contains(&n), "{r}");
        for key in ["region_translational", "region_rotational"] {
            let m = f(&r[key]["median"]);
            assert!(m > 0.0 && m < 1.0, "{key} {m}");
        }
    }
    let table = ok(&["compare-protocols", "--real", "--draws", "5"]);
    assert!(table.contains("linear region: |yaw rate| <="), "{table}");
}

#[test]
fn compare_protocols_user_errors() {
    for (args, says) in [
        (
            &["compare-protocols", "--terrain", "mud"][..],
            "unknown terrain 'mud'",
        ),
        (
            &["compare-protocols", "--samplers", "uniform,zigzag"][..],
            "unknown sampler 'zigzag'",
        ),
        (
            &["compare-protocols", "--duration", "3"][..],
            "shorter than one 6 s DRIVE interval",
        ),
        (
            &["compare-protocols", "--duration", "-30"][..],
            "--duration must be positive",
        ),
        (
            &["compare-protocols", "--seeds", "0"][..],
            "--seeds must be at least 1",
        ),
        (
            &["compare-protocols", "--model", "gp"][..],
            "unknown model 'gp'",
        ),
        (
            &["compare-protocols", "--real", "--split", "1.5"][..],
            "split fraction 1.5",
        ),
    ] {
        let err = user_error(args);
        assert!(err.contains(says), "{args:?}: {err}");
    }
}

#[test]
fn a_twin_whose_robot_cannot_move_is_refused_not_scored() {
    // Values a twin file accepts (positive, in range) but with which nothing is driven:
    // before, compare-protocols ranked the protocols on all-zero errors.
    let dir = tempfile::tempdir().unwrap();
    let twin = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/husky_twin.toml"
    ))
    .unwrap();
    let edit = |key: &str, value: &str| {
        let line = twin
            .lines()
            .find(|l| l.starts_with(&format!("{key} = ")))
            .unwrap();
        twin.replacen(line, &format!("{key} = {value}"), 1)
    };
    for (name, text, says) in [
        (
            "stuck.toml",
            edit("wheel_limit", "1e-300"),
            "neither the encoders nor localization saw a tenth of it",
        ),
        (
            "still.toml",
            edit("input_limits", "[[-1e-300, 1e-300], [-1e-300, 1e-300]]"),
            "nothing was driven",
        ),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let twins = format!("husky={}", path.display());
        let err = user_error(&[
            "compare-protocols",
            "--twins",
            &twins,
            "--duration",
            "60",
            "--test-duration",
            "60",
        ]);
        assert!(
            err.contains("simulated run") && err.contains(says),
            "{name}: {err}"
        );
    }
}

#[test]
fn simulate_raw_log_then_import_then_eval() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    ok(&[
        "simulate",
        "--robot",
        "husky",
        "--terrain",
        "snow",
        "--duration",
        "93",
        "--seed",
        "6",
        "--out",
        &p("sim.csv"),
        "--raw-out",
        &p("raw.csv"),
    ]);
    let v: serde_json::Value = serde_json::from_str(&ok(&[
        "import",
        "--raw",
        &p("raw.csv"),
        "--robot",
        "husky",
        "--out",
        &p("windows.csv"),
        "--json",
    ]))
    .unwrap();
    // 24 s of characterization, then 11 intervals: the last one is cut by the end of the run.
    assert_eq!(v["windows_kept"], 33, "{v}");
    assert_eq!(v["windows_dropped"], 3, "{v}");
    assert_eq!(v["dropped_by_reason"]["too_short"], 3, "{v}");
    assert_eq!(v["out"], p("windows.csv"));
    let imported: serde_json::Value =
        serde_json::from_str(&ok(&["eval", "--json", "--data", &p("windows.csv")])).unwrap();
    let direct: serde_json::Value =
        serde_json::from_str(&ok(&["eval", "--json", "--data", &p("sim.csv")])).unwrap();
    assert_eq!(imported["eval_windows"], direct["eval_windows"]);
    for name in ["naive", "slip-blr"] {
        let (a, b) = (model(&imported, name), model(&direct, name));
        assert!((f(&a["translational_median_m"]) - f(&b["translational_median_m"])).abs() < 1e-9);
    }
    // Without --json the report is text on stdout.
    let text = ok(&[
        "import",
        "--raw",
        &p("raw.csv"),
        "--robot",
        "husky",
        "--out",
        &p("w2.csv"),
    ]);
    assert!(text.contains("33 windows kept, 3 dropped"), "{text}");
}

#[test]
fn list_names_every_registered_part() {
    let v: serde_json::Value = serde_json::from_str(&ok(&["list", "--json"])).unwrap();
    let names = |kind: &str| -> Vec<String> {
        v[kind]
            .as_array()
            .unwrap_or_else(|| panic!("no list {kind}"))
            .iter()
            .map(|e| {
                assert!(!e["description"].as_str().unwrap().is_empty(), "{e}");
                e["name"].as_str().unwrap().to_string()
            })
            .collect()
    };
    assert_eq!(
        names("vehicles"),
        ["differential", "ackermann", "omnidirectional"]
    );
    assert_eq!(names("powertrains"), ["commanded", "fopdt", "rate-limited"]);
    let learners = names("learners");
    for paper in ["naive", "powertrain", "slip-blr", "acc-blr"] {
        assert!(learners.contains(&paper.to_string()), "{learners:?}");
    }
    assert!(names("samplers").len() >= 6);
    assert_eq!(names("terrains"), ["tile", "gravel", "snow", "ice"]);
    assert_eq!(
        names("robots"),
        ["husky", "hd2", "warthog", "autorally", "ridgeback"]
    );
    for r in v["robots"].as_array().unwrap() {
        let (vehicle, inputs) = match r["name"].as_str() {
            Some("autorally") => ("ackermann", 2),
            Some("ridgeback") => ("omnidirectional", 3),
            _ => ("differential", 2),
        };
        assert_eq!(
            (&r["vehicle"], &r["inputs"]),
            (&vehicle.into(), &inputs.into()),
            "{r}"
        );
    }
    assert_eq!(
        names("simulators"),
        ["differential", "ackermann", "omnidirectional"]
    );
    // The text form lists the same.
    let text = ok(&["list"]);
    assert!(text.contains("rate-limited") && text.contains("= no-slip+commanded"));
}

#[test]
fn eval_all_scores_every_combination_and_names_combine_in_every_command() {
    let v: serde_json::Value =
        serde_json::from_str(&ok(&["eval", "--json", "--models", "all"])).unwrap();
    let models = v["models"].as_array().unwrap();
    assert!(models.len() >= 8, "{}", models.len());
    let of = |name: &str| model(&v, name);
    // The paper's names keep their numbers under their full names.
    let paper: serde_json::Value = serde_json::from_str(&ok(&["eval", "--json"])).unwrap();
    for (short, full) in [
        ("naive", "no-slip+commanded"),
        ("powertrain", "no-slip+fopdt"),
        ("slip-blr", "slip-blr+fopdt"),
        ("acc-blr", "acc-blr+commanded"),
    ] {
        assert_eq!(model(&paper, short)["model"], full);
        assert_eq!(
            model(&paper, short)["translational_median_m"],
            of(full)["translational_median_m"]
        );
    }
    // `--powertrain` is the same as naming it.
    let on_commands: serde_json::Value = serde_json::from_str(&ok(&[
        "eval",
        "--json",
        "--models",
        "slip-blr",
        "--powertrain",
        "commanded",
    ]))
    .unwrap();
    assert_eq!(
        on_commands["models"][0]["rotational_median_rad"],
        of("slip-blr+commanded")["rotational_median_rad"]
    );
    // A combined name in train, converge and compare-protocols.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("m.json");
    ok(&[
        "train",
        "--model",
        "slip-blr+rate-limited",
        "--split",
        "0.5",
        "--out",
        file.to_str().unwrap(),
    ]);
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    assert_eq!(saved["model"]["model"]["label"], "slip-blr+rate-limited");
    assert_eq!(
        saved["model"]["model"]["powertrain"]["type"],
        "rate-limited"
    );
    let c: serde_json::Value = serde_json::from_str(&ok(&[
        "converge",
        "--json",
        "--model",
        "slip-blr+commanded",
    ]))
    .unwrap();
    assert_eq!(c["model"], "slip-blr+commanded");
    let last = c["curve"].as_array().unwrap().last().unwrap().clone();
    // The curve's online fit equals the batch fit to rounding.
    assert!(
        (f(&last["translational_median_m"])
            - f(&of("slip-blr+commanded")["translational_median_m"]))
        .abs()
            < 1e-9
    );
    let t: serde_json::Value = serde_json::from_str(&ok(&[
        "compare-protocols",
        "--real",
        "--json",
        "--model",
        "no-slip+fopdt",
        "--draws",
        "2",
    ]))
    .unwrap();
    assert_eq!(t["model"], "no-slip+fopdt");
    // Bad names name what exists.
    let err = user_error(&["eval", "--models", "slip-blr+turbo"]);
    assert!(
        err.contains("unknown powertrain 'turbo'") && err.contains("rate-limited"),
        "{err}"
    );
    let err = user_error(&["eval", "--models", "naive+fopdt"]);
    assert!(err.contains("names a whole model"), "{err}");
}

#[test]
fn a_model_trained_on_too_few_intervals_to_calibrate_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.json");
    let train = |split: &str, uncertainty: &str| {
        let o = drive(&[
            "train",
            "--model",
            "slip-blr",
            "--split",
            split,
            "--uncertainty",
            uncertainty,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success());
        String::from_utf8(o.stderr).unwrap()
    };
    // One training interval: no block to hold out.
    let err = train("0.005", "calibrated");
    assert!(
        err.contains("note: slip-blr's uncertainty is not calibrated")
            && err.contains("span 1 interval(s)"),
        "{err}"
    );
    // Calibrated when it can be, and the paper's uncertainty is asked for as such.
    assert!(!train("0.5", "calibrated").contains("not calibrated"));
    assert!(!train("0.005", "paper").contains("not calibrated"));
}

#[test]
fn a_command_beyond_1e9_is_refused_as_a_corrupted_number() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("m.json");
    ok(&[
        "train",
        "--model",
        "naive",
        "--out",
        model.to_str().unwrap(),
    ]);
    let commands = dir.path().join("c.csv");
    let args = [
        "predict",
        "--model",
        model.to_str().unwrap(),
        "--commands",
        commands.to_str().unwrap(),
    ];
    let predict = || ok(&args);
    let refused = || user_error(&args);
    std::fs::write(&commands, "t,cmd_left,cmd_right\n0,1e15,1\n0.05,1,1\n").unwrap();
    let err = refused();
    assert!(
        err.contains("c.csv, line 2, column 'cmd_left' = 1e15 is more than the limit of 1e9"),
        "{err}"
    );
    // A negative one keeps its sign.
    std::fs::write(&commands, "t,cmd_left,cmd_right\n0,-2e9,1\n0.05,1,1\n").unwrap();
    let err = refused();
    assert!(
        err.contains("the magnitude of ")
            && err.contains("column 'cmd_left' (= -2e9) = 2e9 is more than the limit of 1e9"),
        "{err}"
    );
    // Valid commands from t = 100: the output's t runs on the file's clock.
    std::fs::write(
        &commands,
        "t,cmd_left,cmd_right\n100,1,1\n100.05,1,1\n100.1,1,1\n",
    )
    .unwrap();
    let out = predict();
    let t: Vec<&str> = out
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap())
        .collect();
    assert_eq!(t, ["100", "100.05", "100.1"], "{out}");
    // A clock since the Unix epoch (a ROS recording's) is read as it is; a time off its grid
    // is named with the digits that tell it from its neighbours.
    std::fs::write(
        &commands,
        "t,cmd_left,cmd_right\n1733300000,1,1\n1733300000.05,1,1\n",
    )
    .unwrap();
    let out = predict();
    assert_eq!(
        out.lines().nth(2).unwrap().split(',').nth(1),
        Some("1733300000.05"),
        "{out}"
    );
    std::fs::write(
        &commands,
        "t,cmd_left,cmd_right\n1733300000,1,1\n1733300000.07,1,1\n",
    )
    .unwrap();
    let err = refused();
    assert!(
        err.contains("t = 1733300000.07 but") && err.contains("expected t = 1733300000.05)"),
        "{err}"
    );
    // A time off the model's grid by more than 1% of a period is refused, named, never
    // moved onto the grid; within it (a printed time's rounding) it is read as on it.
    std::fs::write(&commands, "t,cmd_left,cmd_right\n0,1,1\n0.06,1,1\n").unwrap();
    let err = refused();
    assert!(
        err.contains("c.csv, line 3, column 't': t = 0.06") && err.contains("expected t = 0.05"),
        "{err}"
    );
    std::fs::write(&commands, "t,cmd_left,cmd_right\n0,1,1\n0.0502,1,1\n").unwrap();
    let out = predict();
    assert_eq!(
        out.lines().nth(2).unwrap().split(',').nth(1),
        Some("0.05"),
        "{out}"
    );
}

#[test]
fn a_model_named_twice_is_refused_as_bench_refuses_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let out = out.to_str().unwrap();
    for args in [
        &["eval", "--models", "naive,slip-blr,naive"][..],
        &["report", "--models", "naive,slip-blr,naive", "--out", out][..],
    ] {
        let err = user_error(args);
        assert!(
            err.contains("the model 'naive' is named twice"),
            "{args:?}: {err}"
        );
    }
    assert!(!dir.path().join("r").exists());
}

#[test]
fn eval_says_when_the_regions_are_far_wider_than_one_circle() {
    // The grass run (15 training intervals): slip-ipem's calibrated regions at 2 s are many
    // times the area of one circle holding as many positions, and eval says so.
    let out = drive(&[
        "eval",
        "--data",
        "bundled:warthog_grass_2024-08-08",
        "--models",
        "slip-ipem",
        "--json",
    ]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let ratio = f(&v["models"][0]["area_ratio_to_constant"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(ratio > 2.0, "{ratio}");
    assert!(
        err.contains(&format!(
            "slip-ipem's 95% regions at 2 s are {ratio:.1}x the area"
        )) && err.contains("over-cautious"),
        "{err}"
    );
}

#[test]
fn eval_on_a_handful_of_intervals_says_its_figures_are_no_evidence() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("tiny.csv");
    let data = data.to_str().unwrap();
    ok(&[
        "simulate",
        "--robot",
        "husky",
        "--terrain",
        "gravel",
        "--duration",
        "60",
        "--seed",
        "1",
        "--out",
        data,
    ]);
    // 6 intervals: 1 trained on, 5 evaluated.
    let out = drive(&["eval", "--data", data, "--split", "0.2"]);
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("note: 5 evaluation interval(s)") && err.contains("too few to be evidence"),
        "{err}"
    );
    assert!(
        err.contains("note: 1 training interval(s): no uncertainty is calibrated"),
        "{err}"
    );
    // The JSON says what each model's covariance is: its own (`paper`), not `calibrated`
    // as asked.
    let v: serde_json::Value = serde_json::from_str(&ok(&[
        "eval",
        "--data",
        data,
        "--split",
        "0.2",
        "--models",
        "slip-blr,acc-blr",
        "--json",
    ]))
    .unwrap();
    for m in v["models"].as_array().unwrap() {
        assert_eq!(m["uncertainty"], "paper", "{m}");
    }
    // The paper's propagation is not calibrated anyway: only the first note.
    let out = drive(&[
        "eval",
        "--data",
        data,
        "--split",
        "0.2",
        "--uncertainty",
        "paper",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("too few to be evidence") && !err.contains("calibrated"),
        "{err}"
    );
    // The bundled run is evidence, and passes the data checks: no note of any kind.
    let out = drive(&["eval"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !err.contains("evidence") && !err.contains("calibrated") && !err.contains("drive check"),
        "{err}"
    );
    // The simulated run with `columns` set to `value` in every row, and its sidecar without
    // the recorded checksum (the file is no longer the one recorded).
    let edited = |name: &str, columns: &[&str], value: &str| {
        let text = std::fs::read_to_string(data).unwrap();
        let mut lines = text.lines();
        let header = lines.next().unwrap();
        let at: Vec<usize> = columns
            .iter()
            .map(|c| header.split(',').position(|h| h == *c).unwrap())
            .collect();
        let mut out = format!("{header}\n");
        for line in lines {
            let mut cells: Vec<&str> = line.split(',').collect();
            for &i in &at {
                cells[i] = value;
            }
            out += &cells.join(",");
            out.push('\n');
        }
        let path = dir.path().join(name);
        std::fs::write(&path, out).unwrap();
        let sidecar = |p: &Path| p.with_extension("meta.json");
        let mut meta: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(sidecar(Path::new(data))).unwrap())
                .unwrap();
        meta.as_object_mut().unwrap().remove("csv");
        std::fs::write(sidecar(&path), meta.to_string()).unwrap();
        path.to_str().unwrap().to_string()
    };
    // An IMU that never changes (not recorded): eval says what the data check warns of.
    let constant = edited("constant.csv", &["imu_yaw_rate"], "1.2345");
    let out = drive(&["eval", "--data", &constant, "--split", "0.2"]);
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("(imu-constant; drive check says more)"),
        "{err}"
    );
    // A frozen localization: refused, the finding named; with --allow-useless scored, the
    // finding said first.
    let frozen = edited("frozen.csv", &["x", "y", "yaw"], "0");
    let out = drive(&["eval", "--data", &frozen, "--split", "0.2"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success()
            && err.contains("the data checks call it useless")
            && err.contains("(not-moving; drive check says more"),
        "{err}"
    );
    let out = drive(&[
        "eval",
        "--data",
        &frozen,
        "--split",
        "0.2",
        "--allow-useless",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("(not-moving, which drive check calls fatal; drive check says more)"),
        "{err}"
    );
    // What train writes, the loader reads: slip-BLR fitted on a frozen localization has no
    // noise, a model the loader refuses, so it is not written.
    let model = std::path::Path::new(&frozen).with_file_name("frozen.json");
    let out = drive(&[
        "train",
        "--data",
        &frozen,
        "--model",
        "slip-blr",
        "--allow-useless",
        "--out",
        model.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success()
            && err.contains("is not a model the loader accepts, so it is not written")
            && err.contains("must be positive"),
        "{err}"
    );
    assert!(!model.exists());
    // A report asked for anyway says it in report.md, beside its numbers.
    let report = std::path::Path::new(&frozen).with_file_name("frozen-report");
    let out = drive(&[
        "report",
        "--data",
        &frozen,
        "--models",
        "naive",
        "--model",
        "naive",
        "--allow-useless",
        "--out",
        report.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{out:?}");
    let md = std::fs::read_to_string(report.join("report.md")).unwrap();
    assert!(
        md.contains("- check not-moving (fatal: the data is useless): "),
        "{md}"
    );
}

/// Issue 62: `drive simulate` says which simulator ran (the one registered for the robot's
/// vehicle type).
#[test]
fn simulate_says_which_simulator_ran() {
    let dir = tempfile::tempdir().unwrap();
    for (robot, simulator) in [("husky", "differential"), ("autorally", "ackermann")] {
        let csv = dir.path().join(format!("{robot}.csv"));
        let out = common::drive(&[
            "simulate",
            "--robot",
            robot,
            "--terrain",
            "gravel",
            "--duration",
            "60",
            "--seed",
            "1",
            "--out",
            csv.to_str().unwrap(),
        ]);
        assert!(out.status.success());
        let said = String::from_utf8_lossy(&out.stderr);
        assert!(
            said.contains(&format!(
                "simulator: {simulator} (registered for the vehicle type {simulator})"
            )),
            "{said}"
        );
    }
}

/// An outside check: the targeted sampler, planned offline, held its warm-up draws (the
/// uniform sampler's) without a word; it now says so, and the coverage one (which needs
/// no windows) does not.
#[test]
fn a_sampler_that_learns_from_windows_says_what_an_offline_schedule_holds() {
    let dir = tempfile::tempdir().unwrap();
    for (sampler, says) in [
        ("targeted", true),
        ("targeted-coverage", false),
        ("uniform", false),
    ] {
        let out = dir.path().join(format!("{sampler}.csv"));
        let run = std::process::Command::new(env!("CARGO_BIN_EXE_drive"))
            .args([
                "protocol",
                "--robot",
                "husky",
                "--sampler",
                sampler,
                "--intervals",
                "3",
            ])
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert!(run.status.success(), "{sampler}");
        let err = String::from_utf8_lossy(&run.stderr);
        assert_eq!(
            err.contains("holds its warm-up draws"),
            says,
            "{sampler}: {err}"
        );
    }
}

/// Issue 63: a raw log whose ros_time is in seconds (the logger writes nanoseconds) had
/// every interval dropped as "too short" without a hint; the error now names the unit.
#[test]
fn a_raw_log_timed_in_seconds_is_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let (sim, raw) = (dir.path().join("sim.csv"), dir.path().join("raw.csv"));
    ok(&[
        "simulate",
        "--robot",
        "husky",
        "--terrain",
        "gravel",
        "--duration",
        "60",
        "--seed",
        "1",
        "--out",
        sim.to_str().unwrap(),
        "--raw-out",
        raw.to_str().unwrap(),
    ]);
    common::rewrite_csv_column(&raw, &raw, "ros_time", |_, ns| {
        format!("{}", ns.parse::<f64>().unwrap() / 1e9)
    });
    // (Its keep/drop report is printed on stdout before the error.)
    let out = drive(&[
        "import",
        "--raw",
        raw.to_str().unwrap(),
        "--robot",
        "husky",
        "--out",
        dir.path().join("out.csv").to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("ros_time in seconds or milliseconds (the logger writes nanoseconds)"),
        "{err}"
    );
}

/// A tenth outside sweep: `converge`, `adapt` and `report` gave their figures on 1-9
/// evaluation windows without the note `eval` prints there. They say it now.
#[test]
fn converge_adapt_and_report_say_when_their_evaluation_windows_are_too_few() {
    let few = drive(&[
        "converge",
        "--data",
        "bundled:warthog_grass_2024-08-08",
        "--split",
        "0.97",
        "--orders",
        "2",
    ]);
    assert!(few.status.success());
    let err = String::from_utf8_lossy(&few.stderr);
    assert!(
        err.contains("3 evaluation window(s): the medians rest on too few to be evidence"),
        "{err}"
    );
    let enough = drive(&[
        "converge",
        "--data",
        "bundled:warthog_grass_2024-08-08",
        "--orders",
        "2",
    ]);
    assert!(enough.status.success());
    assert!(!String::from_utf8_lossy(&enough.stderr).contains("too few to be evidence"));
    let adapted = drive(&[
        "adapt",
        "--prior",
        "bundled:warthog_asphalt_a",
        "--data",
        "bundled:warthog_grass_2024-08-08",
        "--split",
        "0.97",
        "--times",
        "0",
        "--models",
        "slip-blr",
    ]);
    let err = String::from_utf8_lossy(&adapted.stderr);
    assert!(adapted.status.success(), "{err}");
    assert!(err.contains("too few to be evidence"), "{err}");
    let dir = tempfile::tempdir().unwrap();
    let reported = drive(&[
        "report",
        "--data",
        "bundled:warthog_grass_2024-08-08",
        "--split",
        "0.9",
        "--out",
        dir.path().join("r").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&reported.stderr);
    assert!(reported.status.success(), "{err}");
    assert!(
        err.contains("evaluation window(s) in 3 interval(s): the medians rest on too few"),
        "{err}"
    );
}

/// An eleventh outside sweep: `compare-protocols --real` and `matrix` gave their figures on
/// 15 evaluation windows without the note the other commands print there. They say it now.
#[test]
fn compare_protocols_and_matrix_say_when_their_evaluation_windows_are_too_few() {
    let few = drive(&[
        "compare-protocols",
        "--real",
        "--data",
        "bundled:warthog_grass_2024-08-08",
        "--split",
        "0.95",
        "--draws",
        "2",
    ]);
    let err = String::from_utf8_lossy(&few.stderr);
    assert!(few.status.success(), "{err}");
    assert!(
        err.contains("the medians rest on too few to be evidence"),
        "{err}"
    );
    let dir = tempfile::tempdir().unwrap();
    let sweep = dir.path().join("sweep.toml");
    std::fs::write(
        &sweep,
        "baseline = \"no-slip+fopdt\"\nlearners = [\"no-slip\"]\npowertrains = [\"fopdt\"]\n[simulated]\nrobots = [\"husky\"]\nterrains = [\"gravel\"]\nsamplers = [\"uniform\"]\ndurations = [60]\nseeds = [1]\ntest_duration = 30\n",
    )
    .unwrap();
    let out = drive(&[
        "matrix",
        "--config",
        sweep.to_str().unwrap(),
        "--out",
        dir.path().join("m").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("interval(s): its medians rest on too few to be evidence"),
        "{err}"
    );
}

/// A tenth outside sweep: `adapt --prior model.json` with a model fitted on the target
/// itself scored it as a prior (`frozen` on the windows it was fitted on) without a word,
/// where a dataset prior of the target is refused. A prior fitted on a dataset named as the
/// target is said to be so.
#[test]
fn adapt_says_when_a_model_file_prior_was_fitted_on_a_dataset_named_as_the_target() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("grass.json");
    ok(&[
        "train",
        "--data",
        "bundled:warthog_grass_2024-08-08",
        "--model",
        "slip-blr",
        "--uncertainty",
        "paper",
        "--out",
        file.to_str().unwrap(),
    ]);
    let adapt = |data: &str| {
        let out = drive(&[
            "adapt",
            "--prior",
            file.to_str().unwrap(),
            "--data",
            data,
            "--times",
            "0",
        ]);
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{err}");
        err
    };
    let itself = adapt("bundled:warthog_grass_2024-08-08");
    assert!(
        itself.contains("the prior was fitted on a dataset named as the target is (warthog-grass-2024-08-08, 90 windows; the target has 90 windows)"),
        "{itself}"
    );
    assert!(!adapt("bundled:warthog_asphalt_slow_2024-08-08").contains("named as the target"));
}

/// The twelfth outside sweep: a real run whose robot stands for the last quarter of the
/// training half (commands 0, the sensors' noise alone) got calibrated 95% regions 1e25
/// times the area of the constant circle: the calibration's first fold held every moving
/// interval and its second only the stop, whose model predicts no motion and no spread.
/// The folds are cut as equal in driven intervals where one would hold under half its
/// share; the regions are then the size of the errors.
#[test]
fn a_long_stop_in_the_training_half_leaves_the_calibrated_regions_sane() {
    let mut run = drive::bundled::load("warthog_asphalt_2024-09-20a").unwrap();
    let mut noise = 0x2545_f491_4f6c_dd1d_u64;
    let mut draw = move || {
        noise ^= noise << 13;
        noise ^= noise >> 7;
        noise ^= noise << 17;
        (noise >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    for w in run
        .windows
        .iter_mut()
        .filter(|w| (25..50).contains(&w.interval))
    {
        for k in 0..w.len() {
            w.command[k] = drive::traits::Input::zeros();
            w.measured[k] = drive::traits::Input::new(0.02 * draw(), 0.02 * draw(), 0.0);
            w.pose[k] = drive::traits::Pose::new(0.002 * draw(), 0.002 * draw(), 0.001 * draw());
            w.imu_yaw_rate[k] = 0.006 * draw();
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("stop.csv");
    drive::data::write_dataset(&run, &csv).unwrap();
    let out = ok(&[
        "eval",
        "--data",
        csv.to_str().unwrap(),
        "--models",
        "slip-blr",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let ratio = f(&v["models"][0]["area_ratio_to_constant"]);
    assert!((0.3..5.0).contains(&ratio), "{ratio}");
}
