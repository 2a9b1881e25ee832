//! `drive report` and `drive matrix` through the real command line: the files exist and
//! parse (PNG, SVG, CSV, JSON), and the matrix's numbers are those of `drive eval` for the
//! same combination.

use std::path::Path;
use std::process::{Command, Output};

fn drive(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_drive"))
        .args(args)
        .output()
        .expect("the drive binary runs")
}

fn ok(args: &[&str]) -> String {
    let out = drive(args);
    assert!(
        out.status.success(),
        "drive {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Decodes a PNG fully and returns its size.
fn png_size(path: &Path) -> (u32, u32) {
    let file = std::fs::File::open(path).unwrap();
    let mut reader = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    // Not a blank canvas: more than one colour.
    let first = &buf[..3];
    assert!(
        buf.chunks(3).any(|px| px != first),
        "{} is one flat colour",
        path.display()
    );
    (info.width, info.height)
}

/// Parses an SVG as XML and returns its number of text elements.
fn svg_texts(path: &Path) -> usize {
    let text = std::fs::read_to_string(path).unwrap();
    let doc =
        roxmltree::Document::parse(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(doc.root_element().tag_name().name(), "svg");
    doc.descendants().filter(|n| n.has_tag_name("text")).count()
}

const FIGURES: [&str; 7] = [
    "input_space",
    "powertrain",
    "errors_per_model",
    "errors_per_protocol",
    "convergence",
    "trajectories",
    "calibration",
];

#[test]
fn report_on_the_bundled_data_writes_every_figure_as_png_and_svg() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    ok(&["report", "--out", out.to_str().unwrap()]);
    for name in FIGURES {
        assert_eq!(
            png_size(&out.join(format!("{name}.png"))),
            (1200, 800),
            "{name}"
        );
        // Titles, axis labels, tick labels and legends are text.
        assert!(svg_texts(&out.join(format!("{name}.svg"))) > 10, "{name}");
    }
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    // The comparison, the convergence time and the fitted parameters, as `drive eval` and
    // `drive converge` give them.
    assert!(md.contains("| slip-blr | fopdt | 0.1357 |"), "{md}");
    assert!(md.contains("converges after **12.0 s**"), "{md}");
    // The FOPDT's left time constant (the paper's 1.02 s) and slip-BLR's yaw-rate weight,
    // as the models list them, under the vehicle's axes.
    assert!(
        md.contains("| powertrain: axis 0 time constant [s] | 1.0188 |")
            && md.contains("| angular slip: w[f_w] | 0.7428 |")
            && md.contains("axis 0 = left [rad/s]"),
        "{md}"
    );
    assert!(md.contains("inside the predicted 95% regions"), "{md}");
    assert!(md.contains("| slip-blr | 9"), "{md}"); // coverage at 0.5 s in the 90s
    assert!(md.contains("random orders"), "{md}");
    for name in FIGURES {
        assert!(md.contains(&format!("]({name}.png)")), "{name} not linked");
    }
}

#[test]
fn report_works_on_another_robots_data_without_a_robot_description() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("warthog.csv");
    ok(&[
        "simulate",
        "--robot",
        "warthog",
        "--terrain",
        "snow",
        "--duration",
        "150",
        "--seed",
        "3",
        "--out",
        csv.to_str().unwrap(),
    ]);
    let out = dir.path().join("report");
    ok(&[
        "report",
        "--data",
        csv.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    for name in [
        "input_space",
        "powertrain",
        "errors_per_model",
        "convergence",
        "trajectories",
    ] {
        png_size(&out.join(format!("{name}.png")));
        svg_texts(&out.join(format!("{name}.svg")));
    }
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("# DRIVE report: sim-warthog-snow"), "{md}");
}

fn eval_median(powertrain: Option<&str>, model: &str) -> (f64, f64) {
    let mut args = vec!["eval", "--json", "--models", model];
    if let Some(p) = powertrain {
        args.extend(["--powertrain", p]);
    }
    let v: serde_json::Value = serde_json::from_str(&ok(&args)).unwrap();
    let m = &v["models"][0];
    (
        m["translational_median_m"].as_f64().unwrap(),
        m["rotational_median_rad"].as_f64().unwrap(),
    )
}

#[test]
fn matrix_numbers_equal_drive_eval_and_every_combination_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = dir.path().join("sweep.toml");
    std::fs::write(
        &sweep,
        r#"
        learners = ["naive", "slip-blr", "acc-blr"]
        powertrains = ["commanded", "fopdt"]
        baseline = "naive"
        [[datasets]]
        bundled = "husky"
        [simulated]
        robots = ["husky"]
        terrains = ["gravel", "ice"]
        samplers = ["uniform", "angular"]
        durations = [60]
        seeds = [1, 2]
        test_duration = 60
        [bootstrap]
        resamples = 200
        "#,
    )
    .unwrap();
    let out = dir.path().join("m");
    let json = ok(&[
        "matrix",
        "--config",
        sweep.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let cells = v["cells"].as_array().unwrap();
    // 5 models (naive, slip-blr x 2, acc-blr x 2) x (1 recorded split + 2 terrains x 2
    // samplers x 2 seeds).
    assert_eq!(cells.len(), 5 * (1 + 2 * 2 * 2));
    let csv = std::fs::read_to_string(out.join("matrix.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 2 * cells.len());
    let on_file = |learner: &str, pt: Option<&str>| -> (f64, f64) {
        let c = cells
            .iter()
            .find(|c| {
                c["scenario"]["dataset"] == "husky"
                    && c["model"]["learner"] == learner
                    && c["model"]["powertrain"].as_str() == pt
            })
            .unwrap();
        (
            c["translational"]["median"].as_f64().unwrap(),
            c["rotational"]["median"].as_f64().unwrap(),
        )
    };
    assert_eq!(
        on_file("slip-blr", Some("fopdt")),
        eval_median(None, "slip-blr")
    );
    assert_eq!(
        on_file("slip-blr", Some("commanded")),
        eval_median(Some("commanded"), "slip-blr")
    );
    assert_eq!(
        on_file("acc-blr", Some("commanded")),
        eval_median(None, "acc-blr")
    );
    assert_eq!(
        on_file("acc-blr", Some("fopdt")),
        eval_median(Some("fopdt"), "acc-blr")
    );
    // The naive model is no slip on the commanded powertrain.
    assert_eq!(
        on_file("no-slip", Some("commanded")),
        eval_median(None, "naive")
    );
    // The CSV row of a combination carries the same median.
    let (t, _) = on_file("slip-blr", Some("fopdt"));
    assert!(csv.lines().any(|l| l
        .starts_with("husky,Clearpath Husky,,,,0.5,,slip-blr,fopdt,translational_mrmse,m,303,")
        && l.contains(&format!(",{t},"))));
    // The summary: one row per scenario and model, the baseline marked, intervals around
    // each improvement.
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    let rows: Vec<&str> = md.lines().filter(|l| l.starts_with("| husky")).collect();
    assert_eq!(rows.len(), 5 * (1 + 2 * 2));
    assert!(rows.iter().filter(|r| r.contains("| baseline |")).count() == 5);
    let summary = v["summary"].as_array().unwrap();
    for r in summary {
        if r["model"]["learner"] == "no-slip" && r["model"]["powertrain"] == "commanded" {
            continue;
        }
        let i = &r["translational_improvement"];
        let (p, lo, hi) = (
            i["percent"].as_f64().unwrap(),
            i["ci"][0].as_f64().unwrap(),
            i["ci"][1].as_f64().unwrap(),
        );
        assert!(lo <= hi, "{r}");
        // A percentile interval of a paired bootstrap brackets the point estimate but for
        // resampling noise; it never sits entirely far off it.
        assert!(lo - 5.0 <= p && p <= hi + 5.0, "{r}");
    }
}

/// The sweep's `start` and a dataset's `frame` are the command line's `--start` and
/// `--frame`: the matrix cells equal `drive eval` with them.
#[test]
fn matrix_start_and_frame_equal_drive_eval_with_the_same_options() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = dir.path().join("sweep.toml");
    std::fs::write(
        &sweep,
        r#"
        learners = ["acc-blr", "slip-blr"]
        powertrains = ["fopdt"]
        baseline = "slip-blr"
        start = "encoders"
        [[datasets]]
        bundled = "husky"
        frame = "corrected"
        [bootstrap]
        resamples = 50
        "#,
    )
    .unwrap();
    let out = dir.path().join("m");
    let args = ["matrix", "--config", sweep.to_str().unwrap(), "--out"];
    let v: serde_json::Value =
        serde_json::from_str(&ok(
            &[args.as_slice(), &[out.to_str().unwrap(), "--json"]].concat()
        ))
        .unwrap();
    let eval: serde_json::Value = serde_json::from_str(&ok(&[
        "eval",
        "--json",
        "--models",
        "acc-blr+fopdt,slip-blr",
        "--start",
        "encoders",
        "--frame",
        "corrected",
    ]))
    .unwrap();
    for (learner, model) in [("acc-blr", 0), ("slip-blr", 1)] {
        let cell = v["cells"]
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["model"]["learner"] == learner)
            .unwrap();
        assert_eq!(cell["scenario"]["dataset"], "husky, corrected frame");
        assert_eq!(cell["model"]["start"], "encoders");
        let m = &eval["models"][model];
        assert_eq!(
            cell["translational"]["median"], m["translational_median_m"],
            "{learner}"
        );
        assert_eq!(cell["rotational"]["median"], m["rotational_median_rad"]);
    }
    // Not the defaults: acc-blr's start from the IMU and the published frame differ.
    let default = eval_median(Some("fopdt"), "acc-blr");
    assert_ne!(
        eval["models"][0]["translational_median_m"]
            .as_f64()
            .unwrap(),
        default.0
    );
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(md.contains("starts from the encoders measurements"), "{md}");
}

#[test]
fn matrix_refuses_a_bad_sweep_with_one_clear_line() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("learners = [\"gp\"]\n[[datasets]]\nbundled = \"husky\"\n", "unknown model 'gp'"),
        (
            "learners = [\"slip-blr\"]\n[[datasets]]\nbundled = \"husky\"\n",
            "the baseline 'naive' (no-slip+commanded) is not one of the sweep's models",
        ),
        (
            "powertrains = [\"turbo\"]\n[[datasets]]\nbundled = \"husky\"\n",
            "unknown powertrain 'turbo'",
        ),
        ("colour = 3\n", "unknown field `colour`"),
        ("learners = [\"naive\"]\n", "the sweep has no dataset"),
        (
            "[simulated]\nrobots = [\"husky\"]\nterrains = [\"mud\"]\nsamplers = [\"uniform\"]\ndurations = [60]\nseeds = [1]\n",
            "unknown terrain 'mud'",
        ),
        ("[[datasets]]\nfile = \"missing.csv\"\n", "dataset missing"),
        (
            "[[datasets]]\nbundled = \"husky\"\n[[datasets]]\nbundled = \"husky\"\nframe = \"corrected\"\nname = \"husky\"\n",
            "two datasets are labelled 'husky'",
        ),
    ];
    for (i, (text, expected)) in cases.iter().enumerate() {
        let sweep = dir.path().join(format!("bad{i}.toml"));
        std::fs::write(&sweep, text).unwrap();
        let out_dir = dir.path().join(format!("out{i}"));
        let out = drive(&[
            "matrix",
            "--config",
            sweep.to_str().unwrap(),
            "--out",
            out_dir.to_str().unwrap(),
        ]);
        assert!(!out.status.success());
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains(expected), "case {i}: {err}");
        assert!(!out_dir.join("matrix.csv").exists());
    }
}

#[test]
fn a_sweeps_robot_file_is_read_relative_to_the_sweep_file() {
    // Run from elsewhere: the robot file beside the sweep is found, as its datasets are.
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("study");
    std::fs::create_dir(&sub).unwrap();
    std::fs::write(
        sub.join("myrobot.toml"),
        "name = 'x'\nmass_kg = 75\nmax_speed = 1\nmax_linear_acceleration = 1\nmax_angular_acceleration = 1\nwheel_radius = 0.3\nbaseline = 1.2\n",
    )
    .unwrap();
    let sweep = "learners = [\"no-slip\"]\npowertrains = [\"commanded\"]\n[simulated]\nrobots = [\"myrobot.toml\"]\nterrains = [\"tile\"]\nsamplers = [\"uniform\"]\ndurations = [30]\nseeds = [1]\ntest_duration = 30\n";
    std::fs::write(sub.join("sweep.toml"), sweep).unwrap();
    let config = sub.join("sweep.toml");
    let out = dir.path().join("out");
    ok(&[
        "matrix",
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(summary.contains("x/tile uniform 30 s"), "{summary}");
    // A seed listed twice is refused, not pooled as a second run.
    std::fs::write(&config, sweep.replace("seeds = [1]", "seeds = [1, 1]")).unwrap();
    let refused = drive(&[
        "matrix",
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("lists seed 1 twice"));
}
