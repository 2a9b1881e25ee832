//! `sim_fit` and `drive sim-fit`: a twin fitted on a run of a known simulated robot recovers
//! the parameters the data can tell (controller, powertrain, protocol, sensors,
//! variability) and the ground's behaviour (the ground's parameters trade off against each
//! other: what is checked is that the twin drives like the generator); degenerate data is
//! refused with a reason; the command line writes a terrain file `drive simulate` runs, the
//! same on every run.

use crate::common;

use common::{ok, user_error};
use drive::eval::{evaluate_model, split_by_interval};
use drive::models::powertrain::Fopdt;
use drive::models::slip::{NoSlip, SlipBlr};
use drive::models::Composed;
use drive::samplers::{builtin_robots, RobotSpec, RunnerConfig, UniformSampler};
use drive::sim::{
    builtin_plants, scatter, sim_fit, simulate, ControllerParams, PowertrainParams, Sensors,
    SimFitError, SimulationConfig, Terrain, TwinProtocol, Variability,
};
use drive::traits::{vehicle_as, Dataset, InputSampler, Learner, Phase};

fn husky() -> RobotSpec {
    RobotSpec::load(&builtin_robots(), "husky").unwrap()
}

/// A robot unlike the presets: a controller with gains, caps and acceleration limits, an
/// asymmetric motor loop, a protocol in another geometry that steps its commands, a ground
/// whose turning resistance varies.
fn generator() -> Terrain {
    let mut powertrain = PowertrainParams::for_robot(&husky(), 0.165);
    powertrain.time_constant = [0.25, 0.35];
    powertrain.dead_time = 0.15;
    powertrain.right_lag = 1.0;
    powertrain.right_gain = 1.0;
    powertrain.wheel_limit = 6.0;
    Terrain {
        name: "generator".into(),
        traction: 0.5,
        slip_modulus: 0.12,
        lateral_slip_modulus: None,
        lateral: 0.45,
        rolling: 0.05,
        contact_spread: None,
        powertrain: Some(powertrain),
        controller: Some(ControllerParams {
            linear_gain: 1.5,
            angular_gain: 0.7,
            max_linear: Some(0.9),
            max_angular: Some(1.6),
            max_linear_acceleration: Some(1.5),
            max_angular_acceleration: Some(2.5),
        }),
        sensors: Some(Sensors {
            encoder_noise: 0.1,
            icp_rate_hz: 10.0,
            icp_noise: [0.01, 0.01],
            icp_latency: 0.0,
            icp_jitter: 0.0,
            icp_mount: [0.08, 0.0, -0.03],
            imu_noise: 0.03,
            imu_bias: 0.002,
            icp_gaps: [0.0; drive::sim::ICP_GAP_BINS],
        }),
        variability: Some(Variability {
            traction: 0.0,
            lateral: 0.3,
            rolling: 0.0,
            correlation_time: 3.0,
        }),
        turn_stall: None,
        protocol: Some(TwinProtocol {
            baseline: 0.3,
            input_limits: [[-6.0, 6.0], [-6.0, 6.0]],
            max_linear_acceleration: None,
            max_angular_acceleration: None,
            body_limits: None,
            robot_wheel_radius: 0.165,
            robot_baseline: 0.55,
        }),
        fitted_for: None,
    }
}

fn run(terrain: &Terrain, intervals: usize, seed: u64) -> Dataset {
    let config = SimulationConfig {
        robot: husky(),
        terrain: terrain.clone(),
        seed,
        runner: RunnerConfig {
            max_intervals: Some(intervals),
            ..RunnerConfig::default()
        },
        events: Vec::new(),
        name: format!("{}-s{seed}", terrain.name),
    };
    let sampler =
        move |space| Box::new(UniformSampler::new(space, seed).unwrap()) as Box<dyn InputSampler>;
    simulate(config, &builtin_plants(), sampler, None)
        .unwrap()
        .dataset
}

/// Median translational and rotational errors of the powertrain model and of slip-BLR.
fn medians(data: &Dataset) -> [f64; 4] {
    let (train, eval) = split_by_interval(data, 0.5).unwrap();
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let mut out = [0.0; 4];
    let powertrain = Learner::fit(&Composed::new(Fopdt::default(), NoSlip), &train).unwrap();
    let slip = Learner::fit(&Composed::new(Fopdt::default(), SlipBlr::default()), &train).unwrap();
    for (i, report) in [
        evaluate_model(&powertrain, &eval),
        evaluate_model(&slip, &eval),
    ]
    .into_iter()
    .enumerate()
    {
        out[2 * i] = median(
            report
                .windows
                .iter()
                .map(|w| w.error.translational)
                .collect(),
        );
        out[2 * i + 1] = median(report.windows.iter().map(|w| w.error.rotational).collect());
    }
    out
}

fn close(what: &str, got: f64, want: f64, relative: f64) {
    assert!(
        (got - want).abs() <= relative * want.abs(),
        "{what}: fitted {got}, generated with {want} (tolerance {relative})"
    );
}

/// The whole twin of a simulated robot, every stage against the generator's parameters (35 s
/// of CPU, nearly all of it the ground stage's thousands of simulated runs of 170
/// intervals, which the test needs: at 120 the twin's slip-BLR error leaves its tolerance).
/// Like the Husky twin fit below, it is left out of the README's test command (issue 60:
/// 120 s for every test) and run by CI's `--ignored` stage; the stages' own tests in
/// `drive-sim` and the short command-line fit below run with every test.
#[test]
#[ignore = "a whole twin fit (35 s of CPU): CI runs it with --ignored in its own stage"]
fn a_twin_of_a_simulated_robot_recovers_what_the_data_can_tell() {
    let truth = generator();
    let data = run(&truth, 170, 7);
    let fit = sim_fit(&data, &husky(), "twin").unwrap();
    let t = &fit.terrain;
    // No turn held at its start on this ground: none counted, none fitted.
    assert_eq!(t.turn_stall, None);
    let stall = &fit.report.turn_stall;
    assert!(stall.stalled_starts < 3 && stall.starts > 20, "{stall:?}");
    // Controller: gains and caps from the steady encoders, acceleration limits from the
    // transients.
    let (c, want) = (t.controller.unwrap(), truth.controller.unwrap());
    close("linear gain", c.linear_gain, want.linear_gain, 0.03);
    close("angular gain", c.angular_gain, want.angular_gain, 0.03);
    close("max linear", c.max_linear.unwrap(), 0.9, 0.03);
    close("max angular", c.max_angular.unwrap(), 1.6, 0.03);
    close(
        "linear acceleration",
        c.max_linear_acceleration.unwrap(),
        1.5,
        0.1,
    );
    close(
        "angular acceleration",
        c.max_angular_acceleration.unwrap(),
        2.5,
        0.1,
    );
    // Powertrain: the motors' loop.
    let p = t.powertrain.unwrap();
    close("rising time constant", p.time_constant[0], 0.25, 0.15);
    close("falling time constant", p.time_constant[1], 0.35, 0.15);
    assert!(
        (p.dead_time - 0.15).abs() < 0.04,
        "dead time {}",
        p.dead_time
    );
    close("wheel limit", p.wheel_limit, 6.0, 0.03);
    close("right gain", p.right_gain, 1.0, 0.03);
    // Protocol: the geometry and box it sampled, stepped commands.
    let q = t.protocol.unwrap();
    close("protocol baseline", q.baseline, 0.3, 0.1);
    for axis in q.input_limits {
        close("protocol lower limit", axis[0], -6.0, 0.05);
        close("protocol upper limit", axis[1], 6.0, 0.05);
    }
    assert_eq!(q.max_linear_acceleration, None);
    // Sensors: the localization's rate and noise, the encoders' noise.
    let s = t.sensors.unwrap();
    assert!((9.0..=10.5).contains(&s.icp_rate_hz), "{}", s.icp_rate_hz);
    close("position noise", s.icp_noise[0], 0.01, 0.3);
    // Its timestamps are on time: no jitter invented from the motion's own spread; it
    // updates at its rate, never held longer.
    assert!(s.icp_jitter < 0.05, "{}", s.icp_jitter);
    assert_eq!(s.icp_gaps, [0.0; drive::sim::ICP_GAP_BINS]);
    close("encoder noise", s.encoder_noise, 0.1, 0.2);
    // The localization's mount: ahead of the centre, yawed.
    assert!((s.icp_mount[0] - 0.08).abs() < 0.02, "{:?}", s.icp_mount);
    assert!((s.icp_mount[2] + 0.03).abs() < 0.01, "{:?}", s.icp_mount);
    // Variability: the turning resistance's, with its correlation time.
    let v = t.variability.unwrap();
    close("lateral variability", v.lateral, 0.3, 0.35);
    close("correlation time", v.correlation_time, 3.0, 0.35);
    let report = fit.report.scatter.unwrap();
    close(
        "the twin's yaw-rate scatter",
        report.twin.rms[1],
        report.real.rms[1],
        0.2,
    );
    // The ground, by behaviour: on new runs (another seed, the same for both), the twin's
    // model errors are the generator's.
    let (real, twin) = (medians(&run(&truth, 200, 11)), medians(&run(t, 200, 11)));
    for (i, what) in [
        "powertrain translational",
        "powertrain rotational",
        "slip-BLR translational",
        "slip-BLR rotational",
    ]
    .into_iter()
    .enumerate()
    {
        close(what, twin[i], real[i], 0.15);
    }
}

#[test]
fn the_scatter_statistic_is_the_spread_around_a_smooth_function_of_the_wheel_speeds() {
    // Without variability or noise the steady windows lie on a smooth function of the wheel
    // speeds; the variability spreads them.
    let mut calm = generator();
    calm.variability = None;
    calm.sensors = Some(Sensors {
        encoder_noise: 0.0,
        icp_noise: [0.0, 0.0],
        imu_noise: 0.0,
        ..Sensors::default()
    });
    let g = vehicle_as(husky().vehicle.as_ref()).unwrap();
    let quiet = scatter(&run(&calm, 100, 3), &g).unwrap();
    let mut varied = calm.clone();
    varied.variability = generator().variability;
    let spread = scatter(&run(&varied, 100, 3), &g).unwrap();
    assert!(spread.rms[1] > 3.0 * quiet.rms[1], "{quiet:?} {spread:?}");
    assert!(spread.within_interval > 0.3, "{spread:?}");
    // Fewer than 30 steady windows: no statistic.
    assert!(scatter(&run(&calm, 10, 3), &g).is_none());
}

#[test]
fn data_that_cannot_tell_a_twin_is_refused_with_what_to_look_at() {
    let good = run(&generator(), 60, 2);
    // Encoder columns swapped: the encoders no longer follow the commands.
    let mut swapped = good.clone();
    for w in &mut swapped.windows {
        for u in &mut w.measured {
            *u = drive::traits::Input::new(u.y, u.x, 0.0);
        }
    }
    let err = sim_fit(&swapped, &husky(), "twin").unwrap_err().to_string();
    assert!(err.contains("encoder"), "{err}");
    // Localization mirrored: the yaw turns against the wheels.
    let mut mirrored = good.clone();
    for w in &mut mirrored.windows {
        for p in &mut w.pose {
            p.y = -p.y;
            p.z = -p.z;
        }
    }
    let err = sim_fit(&mirrored, &husky(), "twin")
        .unwrap_err()
        .to_string();
    assert!(err.contains("localization"), "{err}");
    // A robot that did not move under its commands.
    let mut still = good;
    for w in &mut still.windows {
        for p in &mut w.pose {
            *p = drive::traits::Pose::zeros();
        }
    }
    let err = sim_fit(&still, &husky(), "twin").unwrap_err().to_string();
    assert!(err.contains("not-moving"), "{err}");
    // A given twin is checked only against data a twin could be fitted on.
    let err = drive::sim::check_real_run(&still, &husky())
        .unwrap_err()
        .to_string();
    assert!(err.contains("not-moving"), "{err}");
}

#[test]
fn a_given_twin_is_refused_on_data_a_fit_is_refused_on() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("checked.toml");
    let twin = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/husky_twin.toml");
    // The Husky's twin against a Warthog run, allowed to be poor: the geometry refuses it,
    // as it refuses a fit, and nothing is written.
    let err = user_error(&[
        "sim-fit",
        "--robot",
        "husky",
        "--data",
        "bundled:warthog_asphalt_a",
        "--twin",
        twin,
        "--allow-poor-twin",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(err.contains("wheel radius 0.165 m"), "{err}");
    assert!(!out.exists());
}

#[test]
fn degenerate_data_is_refused_with_its_reason() {
    let data = run(&generator(), 4, 1);
    match sim_fit(&data, &husky(), "twin") {
        Err(SimFitError::TooFew { needed, found, .. }) => assert!(found < needed),
        other => panic!("{other:?}"),
    }
    // Only transient windows (the steady ones dropped).
    let mut transient_only = run(&generator(), 30, 1);
    transient_only
        .windows
        .retain(|w| w.phase == Phase::Transient);
    let err = sim_fit(&transient_only, &husky(), "twin").unwrap_err();
    assert!(err.to_string().contains("steady windows"), "{err}");
    // Positions in millimetres: refused by the data check, before any fit runs.
    let mut millimetres = run(&generator(), 30, 1);
    for w in &mut millimetres.windows {
        for p in &mut w.pose {
            p.x *= 1000.0;
            p.y *= 1000.0;
        }
    }
    let err = sim_fit(&millimetres, &husky(), "twin").unwrap_err();
    assert!(err.to_string().contains("(encoder-units)"), "{err}");
}

/// The whole `drive sim-fit --robot husky` (about 150 s on two cores, 280 s of CPU: four
/// ground fits of a 20-minute run, each thousands of simulated runs of its windows) and its
/// output byte for byte the shipped twin. Too slow for the README's test command (issue 60:
/// 120 s for every test), so it is ignored there and CI runs it in a stage of its own
/// (`cargo test --workspace --release -- --ignored`, `.ci/run`); the fit's command-line
/// output on a short run is checked by the next test.
#[test]
#[ignore = "the whole Husky twin fit (150 s): CI runs it with --ignored in its own stage"]
fn the_command_line_writes_a_twin_that_simulate_runs_and_the_same_twin_every_time() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let (a, c) = (path("a.toml"), path("c.toml"));
    // One fit (most of this test's time), written whatever its check; one seed of the check
    // (its default is three): the same check, a third of the time.
    let fitted = common::drive(&[
        "sim-fit",
        "--robot",
        "husky",
        "--out",
        &a,
        "--allow-poor-twin",
        "--check-seeds",
        "1",
    ]);
    assert!(fitted.status.success());
    let text = String::from_utf8_lossy(&fitted.stdout).to_string();
    assert!(
        text.contains("controller:") && text.contains("twin check") && text.contains("saved to"),
        "{text}"
    );
    assert!(
        text.contains("wheels around a smooth function of the commands (steady): real "),
        "{text}"
    );
    // The bundled Husky's turns always follow: none held at its start.
    assert!(text.contains("turn stall: none (0 of "), "{text}");
    // Its twin with the vehicle's own contact spread is as close to the real run as with
    // any other tried (within the margin): the geometry stays, and the four are listed.
    assert!(
        text.contains(
            "contact spread: 0.90 of the baseline (the vehicle's: no other came clearly closer)"
        ),
        "{text}"
    );
    let line = text
        .lines()
        .find(|l| l.starts_with("contact spread:"))
        .unwrap();
    for tried in ["0.90 (the vehicle's): ", "0.60: ", "0.75: ", "1.20: "] {
        assert!(line.contains(tried), "{line}");
    }
    // The twin checked again (--twin: no fit), without --allow-poor-twin: the check decides
    // whether it is written; a twin whose medians are more than 30% from the real run's is
    // refused, saying which. With --json the check is printed either way.
    let checked = common::drive(&[
        "sim-fit",
        "--robot",
        "husky",
        "--twin",
        &a,
        "--out",
        &c,
        "--json",
        "--check-seeds",
        "1",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&checked.stdout).unwrap();
    assert_eq!(v["fitted"], false);
    assert!(
        v.get("report").is_none() && v.get("contact_spread_choice").is_none(),
        "a checked twin has no fit report"
    );
    for p in v["parameters"].as_array().unwrap() {
        assert!(p["name"].is_string() && p["value"].is_number() && p["at_bound"].is_boolean());
    }
    let check = v["check"].as_array().unwrap();
    let models: Vec<&str> = check.iter().map(|c| c["model"].as_str().unwrap()).collect();
    assert_eq!(models, ["naive", "powertrain", "slip-blr", "slip-ipem"]);
    let mut outside = 0;
    for c in check {
        for (real, twin) in [
            ("real_translational_m", "twin_translational_m"),
            ("real_rotational_rad", "twin_rotational_rad"),
        ] {
            let (r, t) = (c[real].as_f64().unwrap(), c[twin].as_f64().unwrap());
            assert!(r > 0.0 && t > 0.0, "{c}");
            // The real median's bootstrap interval (its evaluation intervals resampled)
            // holds it, and is not a point: the real run's own sampling spread.
            let ci = &c[real.replace("_m", "_ci_m").replace("_rad", "_ci_rad")];
            let (lo, hi) = (ci[0].as_f64().unwrap(), ci[1].as_f64().unwrap());
            assert!(0.0 < lo && lo < r && r < hi && hi < 2.0 * r, "{c}");
            outside += usize::from(((t - r) / r).abs() > 0.3);
            // The same twin, data and seed: the fit's check, number for number.
            assert!(text.contains(&format!("{t:.4}")), "{t:.4} not in\n{text}");
        }
    }
    // The real run's medians are `drive eval`'s (the paper's anchors for the naive model).
    assert!((check[0]["real_translational_m"].as_f64().unwrap() - 0.3306).abs() < 1e-4);
    let poor = v["poor"].as_array().unwrap();
    assert_eq!(poor.len(), outside, "{v}");
    assert_eq!(v["written"], poor.is_empty());
    let printed: Terrain = serde_json::from_value(v["terrain"].clone()).unwrap();
    let written = std::fs::read_to_string(&a).unwrap();
    assert_eq!(printed.to_toml(), written, "the checked twin is the file's");
    if poor.is_empty() {
        assert!(checked.status.success());
        assert_eq!(std::fs::read_to_string(&c).unwrap(), written);
    } else {
        let err = String::from_utf8_lossy(&checked.stderr);
        assert!(
            !checked.status.success() && err.contains("--allow-poor-twin"),
            "{err}"
        );
        for p in poor {
            assert!(err.contains(p.as_str().unwrap()), "{err}");
            assert!(p.as_str().unwrap().contains("95% interval"), "{p}");
        }
        assert!(
            !std::path::Path::new(&c).exists(),
            "a poor twin was written"
        );
        let note = String::from_utf8_lossy(&fitted.stderr);
        assert!(
            note.contains("a poor twin, written with --allow-poor-twin"),
            "{note}"
        );
    }
    let text = std::fs::read_to_string(&a).unwrap();
    // The README's twin is this command's output.
    let shipped = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/husky_twin.toml");
    assert_eq!(
        text,
        std::fs::read_to_string(shipped).unwrap(),
        "examples/husky_twin.toml is stale: cargo run --release -- sim-fit --robot husky --out examples/husky_twin.toml"
    );
}

/// `drive sim-fit` on a short run (the bundled Husky's first 60 windows: 20 commands, 2
/// minutes of driving) with the vehicle's own contact spread only (`--contact-spread own`:
/// one ground fit instead of four), in about 8 s: the fit's text names each stage
/// and the spread as asked, its file is the twin `--twin --json` checks again number for
/// number, and that check writes the twin or refuses it as its medians say. The whole
/// Husky fit and its byte-for-byte twin are the test above (CI's own stage).
#[test]
fn the_command_line_fits_a_short_run_with_one_contact_spread_and_checks_it_again() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let (csv, a, c) = (path("short.csv"), path("a.toml"), path("c.toml"));
    let mut short = drive::bundled::load("husky_drive").unwrap();
    short.windows.truncate(60);
    drive::data::write_dataset(&short, csv.as_ref()).unwrap();
    let fitted = common::drive(&[
        "sim-fit",
        "--data",
        &csv,
        "--robot",
        "husky",
        "--out",
        &a,
        "--allow-poor-twin",
        "--check-seeds",
        "1",
        "--contact-spread",
        "own",
    ]);
    assert!(fitted.status.success(), "{fitted:?}");
    let text = String::from_utf8_lossy(&fitted.stdout).to_string();
    for stage in [
        "turn stall: ",
        "controller: ",
        "powertrain: ",
        "ground: ",
        "sensors: ",
        "twin check (1 runs",
        "saved to",
        "wheels around a smooth function of the commands (steady): real ",
    ] {
        assert!(text.contains(stage), "{stage} not in\n{text}");
    }
    // One spread, the vehicle's, with its distance on the choice's two seeds.
    let line = text
        .lines()
        .find(|l| l.starts_with("contact spread:"))
        .unwrap();
    assert!(
        line.starts_with(
            "contact spread: 0.90 of the baseline (the vehicle's, as asked: no other tried)"
        ) && line.contains("(seeds 1000001, 1000002): 0.90 (the vehicle's): ")
            && !line.contains("0.60"),
        "{line}"
    );
    // The written twin checked again: the same file, the same medians as the fit printed.
    let checked = common::drive(&[
        "sim-fit",
        "--data",
        &csv,
        "--robot",
        "husky",
        "--twin",
        &a,
        "--out",
        &c,
        "--json",
        "--check-seeds",
        "1",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&checked.stdout).unwrap();
    assert_eq!(v["fitted"], false);
    assert!(v.get("contact_spread_choice").is_none());
    let check = v["check"].as_array().unwrap();
    let models: Vec<&str> = check.iter().map(|c| c["model"].as_str().unwrap()).collect();
    assert_eq!(models, ["naive", "powertrain", "slip-blr", "slip-ipem"]);
    let mut outside = 0;
    for c in check {
        for (real, twin) in [
            ("real_translational_m", "twin_translational_m"),
            ("real_rotational_rad", "twin_rotational_rad"),
        ] {
            let (r, t) = (c[real].as_f64().unwrap(), c[twin].as_f64().unwrap());
            assert!(r > 0.0 && t > 0.0, "{c}");
            outside += usize::from(((t - r) / r).abs() > 0.3);
            assert!(text.contains(&format!("{t:.4}")), "{t:.4} not in\n{text}");
            assert!(text.contains(&format!("{r:.4}")), "{r:.4} not in\n{text}");
        }
    }
    let written = std::fs::read_to_string(&a).unwrap();
    let printed: Terrain = serde_json::from_value(v["terrain"].clone()).unwrap();
    assert_eq!(printed.to_toml(), written, "the checked twin is the file's");
    // The vehicle's own spread: the file has none.
    assert!(!written.contains("contact_spread"), "{written}");
    let poor = v["poor"].as_array().unwrap();
    assert_eq!(poor.len(), outside, "{v}");
    assert_eq!(v["written"], poor.is_empty());
    assert_eq!(checked.status.success(), poor.is_empty());
    assert_eq!(std::path::Path::new(&c).exists(), poor.is_empty());
    // A spread is a positive share within the simulator's range, and a fit's choice only.
    for value in ["wide", "-0.5", "nan"] {
        let out = common::drive(&[
            "sim-fit",
            "--data",
            &csv,
            "--robot",
            "husky",
            "--out",
            &c,
            &format!("--contact-spread={value}"),
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success()
                && err.contains("a contact spread is choose, own or a positive share"),
            "{value}: {err}"
        );
    }
    let err = user_error(&[
        "sim-fit",
        "--data",
        &csv,
        "--robot",
        "husky",
        "--out",
        &c,
        "--contact-spread",
        "5",
    ]);
    assert!(err.contains("outside the simulator's"), "{err}");
    let out = common::drive(&[
        "sim-fit",
        "--data",
        &csv,
        "--robot",
        "husky",
        "--twin",
        &a,
        "--contact-spread",
        "own",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot be used with"));
}

#[test]
fn table_one_across_twins_pairs_each_twin_with_its_robot() {
    let husky = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/husky_twin.toml");
    let warthog = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/twins/warthog_asphalt_a.toml"
    );
    let robot = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/warthog_1080.toml");
    let twins = format!("husky={husky},{robot}={warthog}");
    let out = ok(&["compare-protocols", "--twins", &twins, "--duration", "60"]);
    assert!(out.contains("husky on husky-drive twin, 60 s:"), "{out}");
    assert!(
        out.contains("warthog on warthog-asphalt-a twin, 60 s:"),
        "{out}"
    );
    assert!(out.contains("wins over the 2 twins"), "{out}");
    let v: serde_json::Value = serde_json::from_str(&ok(&[
        "compare-protocols",
        "--twins",
        &twins,
        "--duration",
        "60",
        "--json",
    ]))
    .unwrap();
    let terrains: std::collections::BTreeSet<&str> = v["rows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["terrain"].as_str().unwrap())
        .collect();
    assert_eq!(terrains.len(), 2);
    // The winners the text shows are the JSON's: each block's best samplers and each
    // sampler's wins, two blocks' worth of wins per test set and error.
    let winners = &v["winners"];
    for b in winners["blocks"].as_array().unwrap() {
        let mut line = format!(
            "  {} on {}, {:.0} s:",
            b["robot"].as_str().unwrap(),
            b["terrain"].as_str().unwrap(),
            b["driving_s"].as_f64().unwrap()
        );
        for best in b["best"].as_array().unwrap() {
            line += &format!(
                " on {} {} / {};",
                best["test_sampler"].as_str().unwrap(),
                best["translational"].as_str().unwrap(),
                best["rotational"].as_str().unwrap()
            );
        }
        assert!(out.contains(&format!("{line}\n")), "{line} not in\n{out}");
    }
    let tests: Vec<&str> = v["test_sets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_str().unwrap())
        .collect();
    let wins = winners["wins"].as_array().unwrap();
    for test in &tests {
        let of_test = wins.iter().filter(|w| w["test_sampler"] == *test);
        let (t, r) = of_test.fold((0, 0), |(t, r), w| {
            (
                t + w["translational"].as_u64().unwrap(),
                r + w["rotational"].as_u64().unwrap(),
            )
        });
        assert_eq!((t, r), (2, 2), "{winners}");
    }
    // A twin with another robot's geometry, a preset terrain and a malformed pair are
    // refused.
    let err = user_error(&["compare-protocols", "--twins", &format!("husky={warthog}")]);
    assert!(
        err.contains("twin of a robot with wheel radius 0.3"),
        "{err}"
    );
    let err = user_error(&["compare-protocols", "--twins", "husky=gravel"]);
    assert!(err.contains("not a twin"), "{err}");
    let err = user_error(&["compare-protocols", "--twins", husky]);
    assert!(err.contains("ROBOT=TWIN"), "{err}");
    let err = user_error(&[
        "compare-protocols",
        "--twins",
        &format!("husky={husky},husky={husky}"),
    ]);
    assert!(err.contains("twice"), "{err}");
}

#[test]
fn the_check_gives_the_twin_the_real_runs_commands_unless_asked_to_draw() {
    // A "real" run of the shipped Husky twin, checked against that same twin: only the
    // simulator's noise differs. With the run's own commands replayed (the default) the
    // twin is within the tolerance on every median; the real medians do not depend on what
    // the twin is commanded.
    let dir = tempfile::tempdir().unwrap();
    let real = dir.path().join("real.csv").to_str().unwrap().to_string();
    let twin = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/husky_twin.toml");
    ok(&[
        "simulate",
        "--robot",
        "husky",
        "--terrain",
        twin,
        "--duration",
        "600",
        "--seed",
        "12",
        "--out",
        &real,
    ]);
    let base = [
        "sim-fit", "--data", &real, "--robot", "husky", "--twin", twin,
    ];
    let check = |commands: Option<&str>| {
        let mut args = base.to_vec();
        args.extend(["--json", "--check-seeds", "2"]);
        if let Some(c) = commands {
            args.extend(["--check-commands", c]);
        }
        let out = common::drive(&args);
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let (replayed, drawn) = (check(None), check(Some("draw")));
    assert_eq!(replayed["check_commands"], "replay");
    assert_eq!(drawn["check_commands"], "draw");
    assert_eq!(replayed["poor"].as_array().unwrap().len(), 0, "{replayed}");
    // How consistently the wheels follow the commands: the same powertrain, the same
    // scatter around the commands (within 30%, none named off).
    let c = &replayed["command_scatter"];
    for axis in 0..2 {
        let (r, t) = (
            c["real"][axis].as_f64().unwrap(),
            c["twin"][axis].as_f64().unwrap(),
        );
        assert!(r > 0.0 && (t / r - 1.0).abs() < 0.3, "{c}");
    }
    assert_eq!(replayed["command_scatter_off"], serde_json::json!([]));
    // The twin of itself keeps the real run's share of its commanded speed and yaw rate
    // (the shipped Husky twin keeps a seventh of its commanded yaw rate: not the 1 a
    // naive twin would keep).
    let k = &replayed["speed_kept"];
    for axis in 0..2 {
        let (r, t) = (
            k["real"][axis].as_f64().unwrap(),
            k["twin"][axis].as_f64().unwrap(),
        );
        assert!(r > 0.0 && (t / r - 1.0).abs() < 0.15, "{k}");
    }
    assert!(k["real"][1].as_f64().unwrap() < 0.5, "{k}");
    assert_eq!(replayed["speed_kept_off"], serde_json::json!([]));
    for (a, b) in replayed["check"]
        .as_array()
        .unwrap()
        .iter()
        .zip(drawn["check"].as_array().unwrap())
    {
        assert_eq!(a["real_translational_m"], b["real_translational_m"]);
        assert_eq!(a["real_rotational_ci_rad"], b["real_rotational_ci_rad"]);
        assert_ne!(a["twin_translational_m"], b["twin_translational_m"]);
    }
    let err = user_error(&[&base[..], &["--check-commands", "fresh"]].concat());
    assert!(err.contains("replay") && err.contains("draw"), "{err}");
}

/// The shipped twin (`examples/husky_twin.toml`, which the test above checks is `drive
/// sim-fit`'s output byte for byte) used as a terrain file: apart from that fit, so that both
/// run side by side.
#[test]
fn a_fitted_twin_runs_in_simulate_and_is_refused_where_it_does_not_apply() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let a = path("a.toml");
    let shipped = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/husky_twin.toml");
    std::fs::copy(shipped, &a).unwrap();
    let text = std::fs::read_to_string(&a).unwrap();
    let written = text.clone();
    // A twin that is not the robot (its wheels' grip a quarter of the fitted one's, against
    // the same resistance to turning) is refused whatever the fitted one's check said: each
    // median off named, nothing written; with --allow-poor-twin written, with a note. (Grip
    // and turning resistance scaled together, a quarter each, turn this robot much as before:
    // a skid-steer's turning follows their ratio at these speeds, and that twin's medians
    // stay within 26% of the real run's. The steady scatter, reported, shows it: +100%.)
    // A seventh outside sweep: the twin with its [protocol] section taken away drove any
    // differential robot with the Husky's motors; refused now, the section named.
    let mut bare = Terrain::from_toml("a.toml", &written).unwrap();
    bare.protocol = None;
    let bare_file = path("bare.toml");
    std::fs::write(&bare_file, bare.to_toml()).unwrap();
    let err = common::user_error(&[
        "simulate",
        "--robot",
        "warthog",
        "--terrain",
        &bare_file,
        "--duration",
        "60",
        "--out",
        &path("bare.csv"),
    ]);
    assert!(
        err.contains("field 'protocol'") && err.contains("needs the [protocol] section"),
        "{err}"
    );
    let mut slippery = Terrain::from_toml("a.toml", &written).unwrap();
    slippery.traction *= 0.25;
    let (b, d) = (path("slippery.toml"), path("d.toml"));
    std::fs::write(&b, slippery.to_toml()).unwrap();
    let check_slippery = |allow: bool| {
        let mut args = vec![
            "sim-fit",
            "--robot",
            "husky",
            "--twin",
            &b,
            "--out",
            &d,
            "--check-seeds",
            "1",
        ];
        if allow {
            args.push("--allow-poor-twin");
        }
        common::drive(&args)
    };
    let refused = check_slippery(false);
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success() && err.contains("--allow-poor-twin") && err.contains("median"),
        "{err}"
    );
    // Each median off with the real one's interval: whether the real run's own sampling
    // could explain the miss.
    assert!(err.contains("whose 95% interval is ["), "{err}");
    assert!(
        !std::path::Path::new(&d).exists(),
        "a poor twin was written"
    );
    let allowed = check_slippery(true);
    let note = String::from_utf8_lossy(&allowed.stderr);
    assert!(allowed.status.success(), "{note}");
    assert!(
        note.contains("a poor twin, written with --allow-poor-twin"),
        "{note}"
    );
    assert_eq!(std::fs::read_to_string(&d).unwrap(), slippery.to_toml());
    // A twin to check that does not exist: named, before any work.
    let err = user_error(&["sim-fit", "--robot", "husky", "--twin", &path("none.toml")]);
    assert!(err.contains("none.toml"), "{err}");
    let twin = Terrain::from_toml("a.toml", &text).unwrap();
    assert!(twin.protocol.is_some() && twin.controller.is_some());
    // The twin runs the protocol in its real run's input space.
    let csv = path("twin.csv");
    ok(&[
        "simulate",
        "--robot",
        "husky",
        "--terrain",
        &a,
        "--duration",
        "120",
        "--seed",
        "1",
        "--out",
        &csv,
    ]);
    ok(&["eval", "--data", &csv, "--models", "naive"]);
    // A car's data is not a Husky's (a car's twin is its ground's: tests/integration/
    // outside_vehicle.rs); the output never replaces the data.
    let car = path("car.csv");
    ok(&[
        "simulate",
        "--robot",
        "autorally",
        "--terrain",
        "gravel",
        "--duration",
        "200",
        "--seed",
        "1",
        "--out",
        &car,
    ]);
    let err = user_error(&["sim-fit", "--data", &car, "--robot", "husky", "--out", &a]);
    assert!(
        err.contains("'ackermann'") && err.contains("'differential'"),
        "{err}"
    );
    let err = user_error(&["sim-fit", "--data", &csv, "--robot", "husky", "--out", &csv]);
    assert!(err.contains("--out"), "{err}");
    // The twin's protocol is a skid-steer's: refused for another vehicle, and for a
    // skid-steer of another geometry.
    let err = user_error(&[
        "simulate",
        "--robot",
        "autorally",
        "--terrain",
        &a,
        "--duration",
        "60",
        "--out",
        &path("x.csv"),
    ]);
    assert!(err.contains("protocol"), "{err}");
    let err = user_error(&[
        "simulate",
        "--robot",
        "hd2",
        "--terrain",
        &a,
        "--duration",
        "60",
        "--out",
        &path("x.csv"),
    ]);
    assert!(
        err.contains("twin of a robot with wheel radius 0.165"),
        "{err}"
    );
    // Two terrains under one name would be pooled.
    let b = path("b.toml");
    std::fs::copy(&a, &b).unwrap();
    let err = user_error(&[
        "compare-protocols",
        "--robot",
        "husky",
        "--terrain",
        &format!("{a},{b}"),
        "--duration",
        "60",
    ]);
    assert!(err.contains("twice"), "{err}");
    // A run that never turns in place cannot tell a twin's turning.
    let straight = path("straight.csv");
    ok(&[
        "simulate",
        "--robot",
        "husky",
        "--terrain",
        "gravel",
        "--sampler",
        "linear",
        "--duration",
        "300",
        "--seed",
        "1",
        "--out",
        &straight,
    ]);
    let err = user_error(&[
        "sim-fit", "--data", &straight, "--robot", "husky", "--out", &a,
    ]);
    assert!(err.contains("turn more than they drive"), "{err}");
    // A name refused says why: blank, too long, or a control character.
    for (name, why) in [
        ("", "--name is blank"),
        ("  ", "--name is blank"),
        ("a\tb", "--name holds a control character"),
        (&"x".repeat(201), "--name is longer than 200 characters"),
    ] {
        let err = user_error(&["sim-fit", "--robot", "husky", "--out", &a, "--name", name]);
        assert!(err.contains(why), "{name:?}: {err}");
    }
}

#[test]
fn a_twin_is_checked_only_on_data_a_fit_accepts_and_an_immobile_twin_is_refused() {
    // The fit's own refusals, asked before checking a given twin (no fit runs): encoder
    // columns swapped, a mirrored localization.
    let data = run(&generator(), 30, 1);
    drive::sim::check_real_run(&data, &husky()).unwrap();
    let mut swapped = data.clone();
    for w in &mut swapped.windows {
        for m in &mut w.measured {
            *m = drive::traits::Input::new(m.y, m.x, m.z);
        }
    }
    let err = drive::sim::check_real_run(&swapped, &husky()).unwrap_err();
    assert!(
        err.to_string().contains("measured columns swapped"),
        "{err}"
    );
    let mut mirrored = data.clone();
    for w in &mut mirrored.windows {
        for p in &mut w.pose {
            p.y = -p.y;
            p.z = -p.z;
        }
        for r in &mut w.imu_yaw_rate {
            *r = -*r;
        }
    }
    let err = drive::sim::check_real_run(&mirrored, &husky()).unwrap_err();
    assert!(err.to_string().contains("mirrored"), "{err}");
    // Through the command line: sim-fit --twin on the mirrored run is refused so, with or
    // without --allow-poor-twin.
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("mirrored.csv");
    drive::data::write_dataset(&mirrored, &csv).unwrap();
    let twin = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/husky_twin.toml");
    let err = user_error(&[
        "sim-fit",
        "--data",
        csv.to_str().unwrap(),
        "--robot",
        "husky",
        "--twin",
        twin,
        "--allow-poor-twin",
        "--check-seeds",
        "1",
    ]);
    assert!(err.contains("mirrored"), "{err}");
    // A twin whose wheels cannot turn (a wheel limit of 1e-300): its replayed runs are
    // refused as the data checks refuse a robot that does not move, never scored as zeros.
    let text = std::fs::read_to_string(twin).unwrap();
    let limit = text
        .lines()
        .find(|l| l.trim_start().starts_with("wheel_limit"))
        .unwrap()
        .to_string();
    let frozen = dir.path().join("frozen.toml");
    std::fs::write(&frozen, text.replace(&limit, "wheel_limit = 1e-300")).unwrap();
    let err = user_error(&[
        "sim-fit",
        "--robot",
        "husky",
        "--twin",
        frozen.to_str().unwrap(),
        "--allow-poor-twin",
        "--check-seeds",
        "1",
    ]);
    assert!(
        err.contains("not-moving") || err.contains("encoders-zero"),
        "{err}"
    );
}
