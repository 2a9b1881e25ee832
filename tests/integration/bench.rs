//! `drive bench`: a suite of window CSVs, raw logs and bags gives, per dataset, exactly the
//! medians of `drive eval` on the same file; transfer, leaderboard and unpredictability are
//! in the JSON; outputs never replace inputs; bad suites fail in one line.

use crate::common;
use common::{ok, user_error};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `drive adapt --json` of slip-BLR from one bundled run to another, scored after 0, 30 and
/// 60 s, with `more` arguments: what the benchmark's adaptation track gives each pair.
fn adapt_alone(prior: &str, target: &str, more: &[&str]) -> Value {
    let (prior, target) = (format!("bundled:{prior}"), format!("bundled:{target}"));
    let args = [
        &["adapt", "--prior", &prior, "--data", &target][..],
        more,
        &["--models", "slip-blr", "--times", "0,30,60", "--json"],
    ]
    .concat();
    serde_json::from_str(&ok(&args)).unwrap()
}

/// The `axis` median of `model`'s point at `t` in a pair's curve.
fn curve_median(pair: &Value, model: &str, t: f64, axis: &str) -> f64 {
    pair["curve"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["model"] == model && c["t_s"].as_f64() == Some(t))
        .unwrap()[axis]
        .as_f64()
        .unwrap()
}

/// Gaussian noise of the standard deviation it is called with (Box-Muller on a generator
/// seeded with `seed`): the same draws for a seed.
fn gaussian(seed: u64) -> impl FnMut(f64) -> f64 {
    let mut state = seed;
    let mut uniform = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    move |sd: f64| {
        let (u, v) = (uniform(), uniform());
        sd * (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// `drive bench --models naive --json` on the suite file `text` (written in `dir`, paths
/// relative to it): its `transfer_skipped`, as JSON text.
fn transfer_skipped(dir: &Path, text: &str) -> String {
    let suite = dir.join("suite.toml");
    std::fs::write(&suite, text).unwrap();
    let v: Value = serde_json::from_str(&ok(&[
        "bench",
        "--suite",
        s(&suite),
        "--models",
        "naive",
        "--json",
    ]))
    .unwrap();
    v["transfer_skipped"].to_string()
}

/// Writes a bundled dataset out as a window CSV and its sidecar.
fn export(name: &str, to: &Path) -> PathBuf {
    let data = drive::bundled::load(name).unwrap();
    drive::data::write_dataset(&data, to).unwrap();
    to.to_path_buf()
}

/// Each model's (translational, rotational) medians from `drive eval --json`.
fn eval_medians(data: &str, models: &str) -> Vec<(String, f64, f64)> {
    let v: Value =
        serde_json::from_str(&ok(&["eval", "--json", "--data", data, "--models", models])).unwrap();
    bench_medians(&v)
}

/// Each model's (translational, rotational) medians from an object with `models` (a
/// dataset of `drive bench --json`, or `drive eval --json`).
fn bench_medians(dataset: &Value) -> Vec<(String, f64, f64)> {
    dataset["models"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            (
                m["name"].as_str().unwrap().to_string(),
                m["translational_median_m"].as_f64().unwrap(),
                m["rotational_median_rad"].as_f64().unwrap(),
            )
        })
        .collect()
}

const MODELS: &str = "naive,slip-blr,acc-blr";

#[test]
fn a_suite_of_window_csvs_raw_logs_and_bags_gives_the_medians_of_eval() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("runs")).unwrap();
    let grass = export("warthog_grass_2024-08-08", &d.join("runs/grass.csv"));
    let slow = export("warthog_asphalt_slow_2024-08-08", &d.join("runs/slow.csv"));
    let (raw, bag) = common::bag_fixtures(d, "snow_raw.csv", "snow_bag");
    let suite = d.join("suite.toml");
    std::fs::write(
        &suite,
        "[[dataset]]\npath = \"runs/grass.csv\"\n\
         [[dataset]]\npath = \"runs/slow.csv\"\nterrain = \"asphalt (slow)\"\n\
         [[dataset]]\nraw = \"snow_raw.csv\"\nrobot = \"husky\"\nterrain = \"snow\"\n\
         [[dataset]]\nbag = \"snow_bag\"\nrobot = \"husky\"\nterrain = \"snow\"\nname = \"snow-bag\"\n",
    )
    .unwrap();
    let v: Value = serde_json::from_str(&ok(&[
        "bench",
        "--suite",
        s(&suite),
        "--json",
        "--models",
        MODELS,
    ]))
    .unwrap();
    let datasets = v["datasets"].as_array().unwrap();
    let names: Vec<&str> = datasets
        .iter()
        .map(|d| d["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["grass", "slow", "snow_raw", "snow-bag"]);
    let terrains: Vec<&str> = datasets
        .iter()
        .map(|d| d["terrain"].as_str().unwrap())
        .collect();
    // The sidecar's terrain, or the suite's.
    assert_eq!(terrains, ["grass", "asphalt (slow)", "snow", "snow"]);
    assert_eq!(datasets[0]["robot"], "warthog"); // recognised in "Clearpath Warthog (wheels)"
    assert_eq!(datasets[2]["robot"], "husky");
    // The window CSVs: the same numbers as drive eval on the file.
    assert_eq!(bench_medians(&datasets[0]), eval_medians(s(&grass), MODELS));
    assert_eq!(bench_medians(&datasets[1]), eval_medians(s(&slow), MODELS));
    // The raw log and the bag: the same numbers as drive eval on what drive import writes.
    for (i, (flag, source)) in [(2, ("--raw", &raw)), (3, ("--bag", &bag))] {
        let out = d.join(format!("imported{i}.csv"));
        ok(&[
            "import",
            flag,
            s(source),
            "--robot",
            "husky",
            "--out",
            s(&out),
        ]);
        assert_eq!(
            bench_medians(&datasets[i]),
            eval_medians(s(&out), MODELS),
            "{flag}"
        );
    }
    // Each dataset reports its unpredictability, within [0, 1]; the total with a body size.
    for d in datasets {
        let u = &d["unpredictability"];
        for kind in ["translational", "rotational", "total"] {
            let m = u[kind]["median"]
                .as_f64()
                .unwrap_or_else(|| panic!("{kind}: {u}"));
            assert!((0.0..=1.0).contains(&m), "{kind}: {m}");
        }
    }
    // Transfer: two ordered pairs for the Warthog's two runs, three models each; the
    // Husky's raw log and bag are one recording (the same windows), so no transfer between
    // them: each model would be scored on the windows it was fitted on.
    let transfer = v["transfer"].as_array().unwrap();
    assert_eq!(transfer.len(), 2 * 3);
    let skipped: Vec<&str> = v["transfer_skipped"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_str().unwrap())
        .collect();
    for pair in ["snow_raw -> snow-bag", "snow-bag -> snow_raw"] {
        assert!(
            skipped
                .iter()
                .any(|x| x.starts_with(pair) && x.contains("the same windows")),
            "{skipped:?}"
        );
    }
    let cell = transfer
        .iter()
        .find(|c| c["model"] == "slip-blr" && c["train"] == "grass" && c["test"] == "slow")
        .unwrap();
    assert_eq!(cell["same_terrain"], false);
    assert_eq!(
        cell["own_translational_median_m"].as_f64().unwrap(),
        bench_medians(&datasets[1])[1].1
    );
    // The naive model fits nothing: between runs of one geometry it transfers without a loss.
    for c in transfer.iter().filter(|c| c["model"] == "naive") {
        assert_eq!(c["same_geometry"], true);
        assert_eq!(c["loss_translational_percent"].as_f64().unwrap(), 0.0);
    }
    // The leaderboard: every model once, ranked.
    let board = v["leaderboard"].as_array().unwrap();
    assert_eq!(board.len(), 3);
    let ranks: Vec<f64> = board
        .iter()
        .map(|r| r["mean_rank"].as_f64().unwrap())
        .collect();
    assert!(ranks.windows(2).all(|w| w[0] <= w[1]), "{ranks:?}");
    let blr = board.iter().find(|r| r["model"] == "slip-blr").unwrap();
    assert_eq!(
        blr["ratio_to_slip_blr"]["translational"].as_f64(),
        Some(1.0)
    );
    assert_eq!(blr["wins_over_slip_blr"], 0);
    let naive = board.iter().find(|r| r["model"] == "naive").unwrap();
    assert_eq!(naive["mean_rank"].as_f64(), Some(3.0));
    assert!(naive["ratio_to_slip_blr"]["rotational"].as_f64().unwrap() > 1.0);
}

#[test]
fn the_default_bench_ranks_five_models_on_every_bundled_dataset() {
    let v: Value = serde_json::from_str(&ok(&["bench", "--json"])).unwrap();
    let datasets = v["datasets"].as_array().unwrap();
    assert_eq!(datasets.len(), drive::bundled::BUNDLED.len());
    let models: Vec<&str> = datasets[0]["models"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        models,
        ["naive", "powertrain", "slip-blr", "acc-blr", "slip-ipem"]
    );
    // The same numbers as drive eval on one of them, by its bundled name.
    let asphalt = datasets
        .iter()
        .find(|d| d["name"] == "warthog_asphalt_a")
        .unwrap();
    assert_eq!(asphalt["terrain"], "asphalt");
    assert_eq!(
        bench_medians(asphalt),
        eval_medians(
            "bundled:warthog_asphalt_a",
            "naive,powertrain,slip-blr,acc-blr,slip-ipem"
        )
    );
    // Seven Warthog runs: 42 ordered pairs per model; the Husky has no partner. The paper's
    // run has another baseline than the doughnut_calib runs: its 12 pairs say so.
    let transfer = v["transfer"].as_array().unwrap();
    assert_eq!(transfer.len(), 42 * 5);
    for c in transfer {
        let paper = c["train"] == "warthog_drive" || c["test"] == "warthog_drive";
        assert_eq!(c["same_geometry"], !paper, "{c}");
        // Two asphalt runs share their terrain; the grass run shares it with none.
        let named = |d: &str| c["train"] == d || c["test"] == d;
        if named("warthog_asphalt_a") && named("warthog_asphalt_2024-08-07") {
            assert_eq!(c["same_terrain"], true, "{c}");
        }
        if named("warthog_grass_2024-08-08") && named("warthog_asphalt_a") {
            assert_eq!(c["same_terrain"], false, "{c}");
        }
    }
    assert_eq!(v["leaderboard"].as_array().unwrap().len(), 5);
    let text = ok(&["bench", "--models", "naive,slip-blr", "--no-transfer"]);
    assert!(text.contains("leaderboard over 8 datasets"), "{text}");
    assert!(text.contains("warthog_grass_2024-08-08"), "{text}");
}

#[test]
fn out_writes_tables_and_a_page_and_never_replaces_an_input() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let suite = d.join("suite.toml");
    std::fs::write(
        &suite,
        "[[dataset]]\npath = \"bundled:warthog_grass_2024-08-08\"\n\
         [[dataset]]\nbundled = \"warthog_asphalt_slow_2024-08-08\"\n",
    )
    .unwrap();
    let out = d.join("out");
    ok(&[
        "bench",
        "--suite",
        s(&suite),
        "--models",
        "naive,slip-blr",
        "--out",
        s(&out),
    ]);
    for f in [
        "bench.md",
        "bench.html",
        "datasets.csv",
        "transfer.csv",
        "leaderboard.csv",
        "windows.csv",
        "bench.json",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let html = std::fs::read_to_string(out.join("bench.html")).unwrap();
    assert_eq!(html.matches("<svg").count(), 5, "five figures");
    // A name is text, in the page and in the Markdown.
    std::fs::write(
        &suite,
        "[[dataset]]\nbundled = \"warthog_grass_2024-08-08\"\nname = \"<b>grass</b> & co\"\n",
    )
    .unwrap();
    let escaped = d.join("escaped");
    ok(&[
        "bench",
        "--suite",
        s(&suite),
        "--models",
        "naive",
        "--out",
        s(&escaped),
    ]);
    let page = std::fs::read_to_string(escaped.join("bench.html")).unwrap();
    let md = std::fs::read_to_string(escaped.join("bench.md")).unwrap();
    for text in [&page, &md] {
        assert!(!text.contains("<b>grass"), "markup passed through");
        assert!(text.contains("&lt;b&gt;grass&lt;/b&gt; &amp; co"));
    }
    assert!(html.contains("Content-Security-Policy"));
    let csv = std::fs::read_to_string(out.join("datasets.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 2 * 2);
    // 45 evaluation windows x 2 models, 45 training windows of the grass run; 150 x 2 and
    // 150 of the slow run.
    let windows = std::fs::read_to_string(out.join("windows.csv")).unwrap();
    assert_eq!(windows.lines().count(), 1 + 45 * 2 + 45 + 150 * 2 + 150);
    // A window CSV of the suite where an output would go: refused, the file intact.
    let runs = d.join("runs");
    std::fs::create_dir(&runs).unwrap();
    let csv_in = export("warthog_grass_2024-08-08", &runs.join("datasets.csv"));
    let before = std::fs::read(&csv_in).unwrap();
    std::fs::write(&suite, "[[dataset]]\npath = \"runs/datasets.csv\"\n").unwrap();
    let err = user_error(&["bench", "--suite", s(&suite), "--out", s(&runs)]);
    assert!(err.contains("datasets.csv"), "{err}");
    assert_eq!(std::fs::read(&csv_in).unwrap(), before);
}

/// A tenth outside sweep: `robot = "husky"` on a Warthog run (1.08 m baseline, 0.3 m wheels
/// against the Husky's 0.55 m and 0.165 m) was taken without a word: the run's
/// unpredictability computed with the Husky's body. `check --robot` said "is it the right
/// robot?"; bench says it now, and takes no body of another geometry.
#[test]
fn a_robot_named_for_data_of_another_geometry_is_said_and_lends_no_body() {
    let d = tempfile::tempdir().unwrap();
    let suite = d.path().join("suite.toml");
    let json = |text: &str| {
        std::fs::write(&suite, text).unwrap();
        let out = common::drive(&["bench", "--suite", s(&suite), "--models", "naive", "--json"]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let named = json("[[dataset]]\nbundled = \"warthog_grass_2024-08-08\"\nrobot = \"husky\"\n");
    let text = named.to_string();
    assert!(
        text.contains("is not the robot husky's") && text.contains("is it the right robot?"),
        "{text}"
    );
    assert!(
        named["datasets"][0]["unpredictability"]["body_source"]
            .as_str()
            .is_some_and(|b| b.contains("no body size")),
        "{}",
        named["datasets"][0]
    );
    // Its own robot (a registered Warthog within a tenth of its geometry): no such note.
    let own = json("[[dataset]]\nbundled = \"warthog_grass_2024-08-08\"\nrobot = \"warthog\"\n");
    assert!(!own.to_string().contains("right robot"), "{own}");
}

#[test]
fn bad_suites_fail_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let suite = dir.path().join("suite.toml");
    let cases = [
        ("[[dataset]]\nraw = \"log.csv\"\n", "robot"),
        (
            "[[dataset]]\npath = \"a.csv\"\nraw = \"b.csv\"\n",
            "exactly one",
        ),
        ("", "no dataset"),
        (
            "[[dataset]]\npath = \"bundled:mars\"\n",
            "warthog_grass_2024-08-08",
        ),
        (
            "[[dataset]]\npath = \"bundled:husky\"\n[[dataset]]\nbundled = \"husky_drive\"\n",
            "two datasets are named 'husky_drive'",
        ),
        ("[[dataset]]\npath = \"missing.csv\"\n", "missing.csv"),
        ("[[dataset]]\npaht = \"a.csv\"\n", "paht"),
        (
            "[[dataset]]\npath = \"bundled:husky\"\nframe = \"rotated\"\n",
            "frame",
        ),
        (
            "[[dataset]]\nbundled = \"warthog_grass_2024-08-08\"\nrobot = \"autorally\"\n",
            "the robot autorally's vehicle is ackermann and the data's is differential",
        ),
        (
            "[[dataset]]\npath = \"/dev/zero\"\nsidecar = \"s.json\"\n",
            "not a regular file",
        ),
        (
            "[[dataset]]\nbundled = \"husky\"\nname = \"a\\u001b[31mb\"\n",
            "control character",
        ),
        ("[[dataset]]\npath = \"\"\n", "path must be non-empty"),
    ];
    for (text, expected) in cases {
        std::fs::write(&suite, text).unwrap();
        let err = user_error(&["bench", "--suite", s(&suite), "--models", "naive"]);
        assert!(err.contains(expected), "{text:?}: {err}");
        // The cause is said once (not again as the error's source).
        assert!(err.matches("cannot read").count() <= 1, "{err}");
    }
    // One run listed twice: benchmarked twice, but no transfer between its two names (each
    // model would be scored on the windows it was fitted on).
    std::fs::write(
        &suite,
        "[[dataset]]\nbundled = \"husky_drive\"\nname = \"a\"\n[[dataset]]\nbundled = \"husky_drive\"\nname = \"b\"\n",
    )
    .unwrap();
    let out = ok(&["bench", "--suite", s(&suite), "--models", "naive,slip-blr"]);
    assert!(
        out.contains("transfer skipped: a -> b: the same windows")
            && out.contains("transfer skipped: b -> a: the same windows"),
        "{out}"
    );
    let err = user_error(&["bench", "--suite", "/dev/zero"]);
    assert!(err.contains("not a regular file"), "{err}");
    let err = user_error(&["bench", "--models", "naive,slip-blr,naive"]);
    assert!(err.contains("'naive' is named twice"), "{err}");
    let err = user_error(&["bench", "--models", "naive", "--split", "1"]);
    assert!(err.contains("--split"), "{err}");
}

#[test]
fn a_dataset_of_few_evaluation_intervals_counts_for_no_win_or_loss() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The first four intervals of the grass run: two evaluation intervals.
    let mut data = drive::bundled::load("warthog_grass_2024-08-08").unwrap();
    data.windows.truncate(12);
    let csv = d.join("short.csv");
    drive::data::write_dataset(&data, &csv).unwrap();
    let suite = d.join("suite.toml");
    std::fs::write(&suite, "[[dataset]]\npath = \"short.csv\"\n").unwrap();
    let args = ["bench", "--suite", s(&suite), "--models", "naive,slip-blr"];
    let v: Value = serde_json::from_str(&ok(&[&args[..], &["--json"]].concat())).unwrap();
    let dataset = &v["datasets"][0];
    assert_eq!(dataset["eval_intervals"], 2);
    assert_eq!(dataset["evidence"], false);
    // The interval of two resampled intervals is no evidence: the naive model loses nowhere.
    let naive = v["leaderboard"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["model"] == "naive")
        .unwrap();
    assert_eq!(naive["losses_to_slip_blr"], 0);
    let text = ok(&[&args[..], &["--no-transfer"]].concat());
    assert!(text.contains("too few evaluation intervals"), "{text}");
    assert!(text.contains("short (2)"), "{text}");
    assert!(text.contains("transfer: not run (--no-transfer)"), "{text}");
    assert!(
        !text
            .lines()
            .any(|l| l.starts_with("  short") && l.contains('!')),
        "{text}"
    );
}

#[test]
fn a_useless_or_degenerate_dataset_is_skipped_with_why_and_the_suite_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The grass run with its localization frozen (what drive check calls not-moving), and
    // its first three intervals (too few to fit slip-BLR's powertrain on half of them).
    common::write_frozen_grass_run(&d.join("frozen.csv"));
    let mut tiny = drive::bundled::load("warthog_grass_2024-08-08").unwrap();
    tiny.windows.truncate(9);
    drive::data::write_dataset(&tiny, &d.join("tiny.csv")).unwrap();
    let suite = d.join("suite.toml");
    std::fs::write(
        &suite,
        "[[dataset]]\nbundled = \"warthog_grass_2024-08-08\"\n\
         [[dataset]]\npath = \"frozen.csv\"\n\
         [[dataset]]\npath = \"tiny.csv\"\n\
         [[dataset]]\nbundled = \"warthog_asphalt_slow_2024-08-08\"\n",
    )
    .unwrap();
    let args = ["bench", "--suite", s(&suite), "--models", "naive,slip-blr"];
    let v: Value = serde_json::from_str(&ok(&[&args[..], &["--json"]].concat())).unwrap();
    let names: Vec<&str> = v["datasets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d["name"].as_str().unwrap())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
    let skipped = v["skipped"].as_array().unwrap();
    assert_eq!(skipped.len(), 2, "{skipped:?}");
    assert_eq!(skipped[0]["dataset"], "frozen");
    let why = skipped[0]["reason"].as_str().unwrap();
    assert!(
        why.contains("useless") && why.contains("not-moving"),
        "{why}"
    );
    assert_eq!(skipped[1]["dataset"], "tiny");
    assert!(
        skipped[1]["reason"]
            .as_str()
            .unwrap()
            .contains("degenerate"),
        "{skipped:?}"
    );
    // The transfer runs between the two kept runs only.
    assert_eq!(v["transfer"].as_array().unwrap().len(), 2 * 2);
    let text = ok(&[&args[..], &["--no-transfer"]].concat());
    assert!(
        text.contains("dataset skipped: frozen: the data checks call it useless"),
        "{text}"
    );
    assert!(text.contains("dataset skipped: tiny: "), "{text}");
    // --allow-useless ranks the frozen run; a suite of nothing usable fails, saying why.
    let v: Value = serde_json::from_str(&ok(&[
        &args[..],
        &["--json", "--no-transfer", "--allow-useless"],
    ]
    .concat()))
    .unwrap();
    assert_eq!(v["datasets"].as_array().unwrap().len(), 3);
    // Ranked, but never without a word: the finding is the dataset's note.
    let frozen = v["datasets"]
        .as_array()
        .unwrap()
        .iter()
        .find(|d| d["name"] == "frozen")
        .unwrap();
    assert!(
        frozen["notes"].as_array().unwrap().iter().any(|n| n
            .as_str()
            .unwrap()
            .starts_with("check not-moving: ")
            && n.as_str()
                .unwrap()
                .contains("ranked because of --allow-useless")),
        "{frozen}"
    );
    // A raw log whose localization is frozen is skipped the same way (it failed the whole
    // benchmark, even with --allow-useless).
    let (sim, raw) = (d.join("sim.csv"), d.join("raw.csv"));
    ok(&[
        "simulate",
        "--robot",
        "warthog",
        "--terrain",
        "gravel",
        "--duration",
        "150",
        "--seed",
        "3",
        "--out",
        s(&sim),
        "--raw-out",
        s(&raw),
    ]);
    let text = std::fs::read_to_string(&raw).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let frozen_columns: Vec<(usize, &str)> = [
        ("icp_pos_x", "5"),
        ("icp_pos_y", "3"),
        ("icp_quat_z", "0"),
        ("icp_quat_w", "1"),
    ]
    .iter()
    .map(|(c, v)| (header.iter().position(|h| h == c).unwrap(), *v))
    .collect();
    let mut frozen_raw = header.join(",") + "\n";
    for line in lines {
        let mut cells: Vec<&str> = line.split(',').collect();
        for &(i, v) in &frozen_columns {
            cells[i] = v;
        }
        frozen_raw += &(cells.join(",") + "\n");
    }
    std::fs::write(d.join("frozen_raw.csv"), frozen_raw).unwrap();
    std::fs::write(
        &suite,
        "[[dataset]]\nbundled = \"warthog_grass_2024-08-08\"\n\
         [[dataset]]\nraw = \"frozen_raw.csv\"\nrobot = \"warthog\"\n",
    )
    .unwrap();
    let v: Value = serde_json::from_str(&ok(&[&args[..], &["--json"]].concat())).unwrap();
    assert_eq!(v["datasets"].as_array().unwrap().len(), 1, "{v}");
    let skipped = v["skipped"].as_array().unwrap();
    assert_eq!(skipped[0]["dataset"], "frozen_raw", "{skipped:?}");
    assert!(
        skipped[0]["reason"]
            .as_str()
            .unwrap()
            .contains("not-moving"),
        "{skipped:?}"
    );
    // Issue 63: a dataset that cannot be read (a NaN cell in a window CSV or a raw log)
    // is skipped and named too; the others are ranked.
    let nan_cell = |from: &Path, to: &Path, column: &str| {
        common::rewrite_csv_column(from, to, column, |row, old| {
            if row == 2 {
                "NaN".into()
            } else {
                old.to_string()
            }
        });
    };
    nan_cell(&d.join("tiny.csv"), &d.join("nan.csv"), "x");
    std::fs::copy(d.join("tiny.meta.json"), d.join("nan.meta.json")).unwrap();
    nan_cell(&raw, &d.join("nan_raw.csv"), "meas_left_vel");
    std::fs::write(
        &suite,
        "[[dataset]]\nbundled = \"warthog_grass_2024-08-08\"\n\
         [[dataset]]\npath = \"nan.csv\"\n\
         [[dataset]]\nraw = \"nan_raw.csv\"\nrobot = \"warthog\"\n",
    )
    .unwrap();
    let v: Value = serde_json::from_str(&ok(&[&args[..], &["--json"]].concat())).unwrap();
    assert_eq!(v["datasets"].as_array().unwrap().len(), 1, "{v}");
    let skipped = v["skipped"].as_array().unwrap();
    let names: Vec<&str> = skipped
        .iter()
        .map(|s| s["dataset"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["nan", "nan_raw"], "{skipped:?}");
    for s in skipped {
        assert!(
            s["reason"]
                .as_str()
                .unwrap()
                .contains("not a finite number"),
            "{skipped:?}"
        );
    }
    std::fs::write(&suite, "[[dataset]]\npath = \"frozen.csv\"\n").unwrap();
    let err = user_error(&args);
    assert!(
        err.contains("no dataset could be benchmarked: 'frozen': the data checks call it useless"),
        "{err}"
    );
}

#[test]
fn a_run_and_a_part_of_itself_or_a_copy_off_by_rounding_are_never_a_transfer_pair() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run = drive::bundled::load("warthog_grass_2024-08-08").unwrap();
    // Its first half, and a copy whose positions moved by 1e-15 (a raw log and its
    // imported window CSV differ so).
    let mut half = run.clone();
    half.windows.truncate(run.windows.len() / 2);
    drive::data::write_dataset(&half, &d.join("half.csv")).unwrap();
    let mut copy = run.clone();
    for w in &mut copy.windows {
        for p in &mut w.pose {
            p.x += 1e-15;
        }
    }
    drive::data::write_dataset(&copy, &d.join("copy.csv")).unwrap();
    // And a copy written with five significant digits (a spreadsheet's export).
    let five = |v: f64| -> f64 { format!("{v:.4e}").parse().unwrap() };
    let mut rounded = run.clone();
    for w in &mut rounded.windows {
        for u in w.command.iter_mut().chain(w.measured.iter_mut()) {
            u.iter_mut().for_each(|v| *v = five(*v));
        }
        for p in &mut w.pose {
            p.iter_mut().for_each(|v| *v = five(*v));
        }
    }
    drive::data::write_dataset(&rounded, &d.join("rounded.csv")).unwrap();
    // And a copy re-exported with its inputs recalibrated (third and fourth outside sweeps):
    // encoders 5% faster and a bias, commands 2% faster, the localization written to the
    // millimetre and the milliradian.
    let mut recalibrated = run.clone();
    let mm = |v: f64| (v * 1000.0).round() / 1000.0;
    for w in &mut recalibrated.windows {
        w.measured
            .iter_mut()
            .for_each(|u| *u = *u * 1.05 + drive::traits::Input::new(0.05, 0.05, 0.0));
        w.command.iter_mut().for_each(|u| *u *= 1.02);
        w.pose
            .iter_mut()
            .for_each(|p| p.iter_mut().for_each(|v| *v = mm(*v)));
    }
    drive::data::write_dataset(&recalibrated, &d.join("recalibrated.csv")).unwrap();
    // And its mirror image (a sixth outside sweep: y, yaw and the IMU negated, the sides
    // swapped: the same drive, scored as a transfer at -4% both ways before).
    let mut mirrored = run.clone();
    for w in &mut mirrored.windows {
        for u in w.command.iter_mut().chain(w.measured.iter_mut()) {
            (u.x, u.y) = (u.y, u.x);
        }
        for p in &mut w.pose {
            (p.y, p.z) = (-p.y, -p.z);
        }
        w.imu_yaw_rate.iter_mut().for_each(|r| *r = -*r);
    }
    drive::data::write_dataset(&mirrored, &d.join("mirrored.csv")).unwrap();
    // Issue 63: and a copy whose localization alone was altered (positions doubled, noise of
    // up to 5 cm on every sample): its commands, encoders and IMU are the run's.
    let mut relocalized = run.clone();
    let mut state: u64 = 7;
    let mut noise = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.1
    };
    for w in &mut relocalized.windows {
        for p in &mut w.pose {
            p.x = 2.0 * p.x + noise();
            p.y = 2.0 * p.y + noise();
        }
    }
    drive::data::write_dataset(&relocalized, &d.join("relocalized.csv")).unwrap();
    // And a copy with noise on every column (a tenth outside sweep: 5% of each column's
    // largest value on every sample, commands, encoders, positions, headings and IMU alike,
    // was scored as a transfer; with that much on the positions and headings the data checks
    // now refuse it, so a tenth of it on those here): it keeps the run's commands window after window.
    let mut noisy = run.clone();
    let largest = |f: &dyn Fn(&drive::traits::Window) -> Vec<f64>| {
        run.windows
            .iter()
            .flat_map(f)
            .fold(0.0f64, |m, v| m.max(v.abs()))
    };
    let scale = [
        largest(&|w| w.command.iter().map(|u| u.x.abs().max(u.y.abs())).collect()),
        largest(&|w| {
            w.measured
                .iter()
                .map(|u| u.x.abs().max(u.y.abs()))
                .collect()
        }),
        largest(&|w| w.pose.iter().map(|p| p.x.abs().max(p.y.abs())).collect()),
        largest(&|w| w.pose.iter().map(|p| p.z).collect()),
        largest(&|w| w.imu_yaw_rate.clone()),
    ];
    let mut state: u64 = 11;
    // Uniform with a standard deviation of 5% of `of`.
    let mut noise = move |of: f64| {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.05 * 12f64.sqrt() * of
    };
    for w in &mut noisy.windows {
        for u in &mut w.command {
            u.x += noise(scale[0]);
            u.y += noise(scale[0]);
        }
        for u in &mut w.measured {
            u.x += noise(scale[1]);
            u.y += noise(scale[1]);
        }
        for p in &mut w.pose {
            p.x += noise(0.1 * scale[2]);
            p.y += noise(0.1 * scale[2]);
            p.z += noise(0.1 * scale[3]);
        }
        w.imu_yaw_rate
            .iter_mut()
            .for_each(|r| *r += noise(scale[4]));
    }
    drive::data::write_dataset(&noisy, &d.join("noisy.csv")).unwrap();
    let suite = d.join("suite.toml");
    std::fs::write(
        &suite,
        "[[dataset]]\nbundled = \"warthog_grass_2024-08-08\"\nname = \"run\"\n\
         [[dataset]]\npath = \"half.csv\"\n\
         [[dataset]]\npath = \"copy.csv\"\n\
         [[dataset]]\npath = \"rounded.csv\"\n\
         [[dataset]]\npath = \"recalibrated.csv\"\n\
         [[dataset]]\npath = \"mirrored.csv\"\n\
         [[dataset]]\npath = \"relocalized.csv\"\n\
         [[dataset]]\npath = \"noisy.csv\"\n\
         [[dataset]]\nbundled = \"warthog_asphalt_slow_2024-08-08\"\nname = \"other\"\n",
    )
    .unwrap();
    let v: Value = serde_json::from_str(&ok(&[
        "bench",
        "--suite",
        s(&suite),
        "--models",
        "naive",
        "--json",
    ]))
    .unwrap();
    let skipped: Vec<&str> = v["transfer_skipped"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_str().unwrap())
        .collect();
    for pair in [
        "run -> half",
        "half -> run",
        "run -> copy",
        "copy -> run",
        "half -> copy",
        "copy -> half",
        "run -> rounded",
        "rounded -> run",
        "half -> rounded",
        "run -> recalibrated",
        "recalibrated -> run",
        "half -> recalibrated",
        "run -> mirrored",
        "mirrored -> run",
        "half -> mirrored",
        "run -> relocalized",
        "relocalized -> run",
        "half -> relocalized",
        "run -> noisy",
        "noisy -> run",
        "half -> noisy",
    ] {
        assert!(
            skipped
                .iter()
                .any(|x| x.starts_with(pair) && x.contains("the same windows")),
            "{pair}: {skipped:?}"
        );
    }
    // Each of the eight with the other run: both ways, none skipped.
    let pairs: Vec<(String, String)> = v["transfer"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            (
                c["train"].as_str().unwrap().to_string(),
                c["test"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    assert_eq!(pairs.len(), 16, "{pairs:?}");
    assert!(
        pairs.iter().all(|(a, b)| a == "other" || b == "other"),
        "{pairs:?}"
    );
}

/// Issue 62: two simulated runs of a registered robot whose name has hyphens are one robot
/// (a transfer pair), whatever ground each ran on; before, the sidecar's text was split at
/// the hyphens and each run became a robot of its own.
#[test]
fn runs_of_a_robot_named_with_hyphens_are_one_robot() {
    let mut registries = drive::Registries::builtin();
    let mut rover = registries.robot("husky").unwrap();
    rover.name = "tracked-rover".into();
    registries
        .robots
        .register("tracked-rover", "a rover", std::sync::Arc::new(rover))
        .unwrap();
    let run = |terrain: &str, seed: u64| {
        drive::studies::simulate_protocol(
            &registries,
            "tracked-rover",
            terrain,
            "uniform",
            12,
            seed,
        )
        .unwrap()
        .dataset
    };
    let (gravel, snow) = (run("gravel", 1), run("snow", 2));
    assert_ne!(gravel.robot.robot, snow.robot.robot);
    for data in [&gravel, &snow] {
        let of = drive::suite::robot_of(&registries, data, None).unwrap();
        assert_eq!(of.name, "tracked-rover", "{}", of.source);
    }
}

/// Issue 62: the registered robot's name is written into a simulated run's sidecar and a
/// benchmark pairs the runs by it exactly, whatever the free robot text says; a robot left
/// without a pair is listed with why.
#[test]
fn runs_are_paired_by_the_registered_robot_their_sidecar_names_and_a_lone_robot_is_listed() {
    let mut registries = drive::Registries::builtin();
    let mut rover = registries.robot("husky").unwrap();
    rover.name = "rover-7".into();
    registries
        .robots
        .register("rover-7", "a rover", std::sync::Arc::new(rover))
        .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut suite = String::new();
    for (robot, terrain, seed) in [
        ("rover-7", "gravel", 1),
        ("rover-7", "snow", 2),
        ("husky", "tile", 3),
    ] {
        let mut data =
            drive::studies::simulate_protocol(&registries, robot, terrain, "uniform", 12, seed)
                .unwrap()
                .dataset;
        assert_eq!(data.robot.registered_robot, robot);
        // Free text that names no registered robot, or the wrong one.
        data.robot.robot = format!("unit {seed} of the husky family");
        let csv = dir.path().join(format!("{robot}-{terrain}.csv"));
        drive::data::write_dataset(&data, &csv).unwrap();
        let sidecar = std::fs::read_to_string(drive::data::sidecar_path(&csv)).unwrap();
        assert!(
            sidecar.contains(&format!("\"registered_robot\": \"{robot}\"")),
            "{sidecar}"
        );
        let back = drive::data::read_dataset(&csv, None).unwrap();
        let of = drive::suite::robot_of(&registries, &back, None).unwrap();
        assert_eq!(of.name, robot, "{}", of.source);
        suite += &format!("[[dataset]]\npath = \"{robot}-{terrain}.csv\"\n");
    }
    let suite_path = dir.path().join("suite.toml");
    std::fs::write(&suite_path, suite).unwrap();
    let status = drive::cli::run_status(
        [
            "drive",
            "bench",
            "--suite",
            suite_path.to_str().unwrap(),
            "--models",
            "naive",
            "--json",
            "--out",
            dir.path().join("out").to_str().unwrap(),
        ],
        &registries,
    );
    assert_eq!(status, 0);
    let bench: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("out").join("bench.json")).unwrap(),
    )
    .unwrap();
    // The two rover runs are one robot (a pair each way); the husky run stands alone.
    assert_eq!(bench["transfer"].as_array().unwrap().len(), 2, "{bench}");
    let unpaired = &bench["transfer_unpaired"];
    assert_eq!(unpaired.as_array().unwrap().len(), 1, "{unpaired}");
    assert_eq!(unpaired[0]["robot"], "husky");
    assert!(unpaired[0]["reason"]
        .as_str()
        .unwrap()
        .contains("only one dataset"));
}

#[test]
fn the_adaptation_track_gives_each_pair_the_curves_of_drive_adapt_and_names_what_cannot_adapt() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let suite = d.join("suite.toml");
    std::fs::write(
        &suite,
        "[[dataset]]\nbundled = \"warthog_grass_2024-08-08\"\n\
         [[dataset]]\nbundled = \"warthog_asphalt_slow_2024-08-08\"\n",
    )
    .unwrap();
    let out = d.join("out");
    let v: Value = serde_json::from_str(&ok(&[
        "bench",
        "--suite",
        s(&suite),
        "--models",
        "slip-blr,acc-blr",
        "--no-transfer",
        "--adapt",
        "--adapt-times",
        "0,30,60",
        "--json",
        "--out",
        s(&out),
    ]))
    .unwrap();
    assert!(out.join("adapt.csv").is_file());
    let a = &v["adaptation"];
    // Both ordered pairs, slip-BLR only: acc-BLR is not composed of a powertrain and a slip
    // model, and is named once.
    let pairs = a["pairs"].as_array().unwrap();
    assert_eq!(pairs.len(), 2, "{a}");
    let skipped = a["skipped"].as_array().unwrap();
    assert_eq!(skipped.len(), 1, "{skipped:?}");
    assert!(skipped[0].as_str().unwrap().starts_with("acc-blr: "));
    // Each pair's curves are those of drive adapt on the same two runs.
    for p in pairs {
        let (prior, target) = (p["prior"].as_str().unwrap(), p["target"].as_str().unwrap());
        let alone = adapt_alone(prior, target, &[]);
        assert_eq!(p["curve"], alone["curve"], "{prior} -> {target}");
        assert_eq!(p["same_terrain"], false);
    }
    // The summary: the medians over the pairs of each pair's ratios; at t = 0 the adaptive
    // model is the prior.
    let ratio = |p: &Value, t: f64, of: &str, axis: &str| {
        curve_median(p, "adaptive", t, axis) / curve_median(p, of, t, axis)
    };
    let summary = a["summary"].as_array().unwrap();
    assert_eq!(summary.len(), 3);
    for row in summary {
        assert_eq!(row["model"], "slip-blr");
        assert_eq!(row["pairs"], 2);
        let t = row["t_s"].as_f64().unwrap();
        for (field, axis) in [
            ("translational", "translational_median_m"),
            ("rotational", "rotational_median_rad"),
        ] {
            let want = 0.5 * (ratio(&pairs[0], t, "own", axis) + ratio(&pairs[1], t, "own", axis));
            let got = row["adaptive_over_own"][field].as_f64().unwrap();
            assert!((got - want).abs() < 1e-12, "{t} {field}: {got} {want}");
        }
        if t == 0.0 {
            assert_eq!(row["adaptive_over_frozen"]["translational"], 1.0);
            assert!(row["adaptive_over_scratch"].is_null());
        }
    }
    // The leaderboard quotes the ratio to the own fit after 60 s.
    let board = v["leaderboard"].as_array().unwrap();
    let blr = board.iter().find(|r| r["model"] == "slip-blr").unwrap();
    assert_eq!(
        blr["adaptive_over_own_60s"],
        summary[2]["adaptive_over_own"]
    );
    let acc = board.iter().find(|r| r["model"] == "acc-blr").unwrap();
    assert!(acc.get("adaptive_over_own_60s").is_none());
    // Without --adapt, no trace of the track.
    let plain = ok(&[
        "bench",
        "--suite",
        s(&suite),
        "--models",
        "slip-blr",
        "--no-transfer",
        "--json",
    ]);
    assert!(!plain.contains("adapt"), "{plain}");
    // --adapt-times without --adapt is refused, naming what it needs.
    let alone = common::drive(&["bench", "--adapt-times", "0,30"]);
    assert!(!alone.status.success());
    assert!(String::from_utf8_lossy(&alone.stderr).contains("--adapt"));
}

/// Issue 61's second option in the benchmark: each pair's terrain library is the prior's run
/// and the robot's other runs but the target, and its curve is that of `drive adapt
/// --library` on the same runs.
#[test]
fn the_adaptation_track_blends_each_pairs_library_as_drive_adapt_does() {
    let dir = tempfile::tempdir().unwrap();
    let suite = dir.path().join("suite.toml");
    let runs = [
        "warthog_grass_2024-08-08",
        "warthog_asphalt_slow_2024-08-08",
        "warthog_asphalt_a",
    ];
    let text: String = runs
        .iter()
        .map(|r| format!("[[dataset]]\nbundled = \"{r}\"\n"))
        .collect();
    std::fs::write(&suite, text).unwrap();
    let args = [
        "bench",
        "--suite",
        s(&suite),
        "--models",
        "slip-blr",
        "--no-transfer",
        "--adapt",
        "--adapt-times",
        "0,30,60",
        "--json",
    ];
    let v: Value = serde_json::from_str(&ok(&[&args[..], &["--adapt-library"]].concat())).unwrap();
    let a = &v["adaptation"];
    let pairs = a["pairs"].as_array().unwrap();
    assert_eq!(pairs.len(), 6, "{a}");
    let library_curve = |curve: &Value| -> Vec<Value> {
        curve
            .as_array()
            .unwrap()
            .iter()
            .filter(|c| c["model"] == "library")
            .cloned()
            .collect()
    };
    for p in pairs {
        let (prior, target) = (p["prior"].as_str().unwrap(), p["target"].as_str().unwrap());
        let third = runs.iter().find(|r| **r != prior && **r != target).unwrap();
        assert_eq!(p["library"], serde_json::json!([prior, third]));
        let alone = adapt_alone(prior, target, &["--library", &format!("bundled:{third}")]);
        let (ours, theirs) = (library_curve(&p["curve"]), library_curve(&alone["curve"]));
        assert_eq!(ours.len(), 3);
        assert_eq!(ours, theirs, "{prior} -> {target}");
    }
    // The summary's library medians are the medians over the pairs of each pair's ratios.
    let at = |p: &Value, m: &str, t: f64| curve_median(p, m, t, "translational_median_m");
    for row in a["summary"].as_array().unwrap() {
        let t = row["t_s"].as_f64().unwrap();
        let mut r: Vec<f64> = pairs
            .iter()
            .map(|p| at(p, "library", t) / at(p, "own", t))
            .collect();
        r.sort_by(f64::total_cmp);
        let median = 0.5 * (r[2] + r[3]);
        let got = row["library"]["over_own"]["translational"]
            .as_f64()
            .unwrap();
        assert!((got - median).abs() < 1e-12, "{t}: {got} {median}");
        assert_eq!(row["library"]["pairs"], 6);
    }
    // Without it, no library; without --adapt, the flag is refused.
    let plain = ok(&args);
    assert!(!plain.contains("library"), "{plain}");
    let alone = common::drive(&["bench", "--adapt-library"]);
    assert!(!alone.status.success());
    assert!(String::from_utf8_lossy(&alone.stderr).contains("--adapt"));
}

/// Issue 63 (a twelfth outside sweep): a copy of a run with noise on its commands and its
/// localization only (its encoders and IMU as recorded) was scored as a transfer: runs of
/// windows one window off, where two intervals' commands were close, were taken for the
/// copy's and their IMU for a difference no noise explained. It is the same run.
#[test]
fn a_copy_with_noise_on_its_commands_and_localization_is_the_same_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run = drive::bundled::load("warthog_asphalt_a").unwrap();
    let mut noise = gaussian(17);
    let largest = run
        .windows
        .iter()
        .flat_map(|w| w.command.iter().map(|u| u.x.abs().max(u.y.abs())))
        .fold(0.0f64, f64::max);
    let mut copy = run.clone();
    for w in &mut copy.windows {
        for u in &mut w.command {
            u.x += noise(0.01 * largest);
            u.y += noise(0.01 * largest);
        }
        for p in &mut w.pose {
            p.x += noise(0.01);
            p.y += noise(0.01);
            p.z += noise(0.005);
        }
    }
    drive::data::write_dataset(&copy, &d.join("copy.csv")).unwrap();
    let skipped = transfer_skipped(
        d,
        "[[dataset]]\nbundled = \"warthog_asphalt_a\"\nname = \"run\"\n\
         [[dataset]]\npath = \"copy.csv\"\n\
         [[dataset]]\nbundled = \"warthog_asphalt_2024-09-20a\"\nname = \"other\"\n",
    );
    for pair in ["run -> copy", "copy -> run"] {
        assert!(skipped.contains(pair), "{pair}: {skipped}");
    }
    // The other run is not the same run as either.
    assert!(
        !skipped.contains("-> other") && !skipped.contains("\"other ->"),
        "{skipped}"
    );
}

/// Issue 63 (a second sweep of that session): a noisy copy whose IMU was also scaled (or
/// biased, late, negated) was scored as a transfer: the commands' sequence held, but the IMU
/// differed by more than noise. Its localization saw the run's motion, window for window:
/// the same run. The same commands driven on two simulated grounds are two runs (a half of
/// shared straight windows called them one before).
#[test]
fn a_noisy_copy_with_its_imu_scaled_is_the_same_run_and_two_grounds_are_two() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run = drive::bundled::load("warthog_asphalt_a").unwrap();
    let mut noise = gaussian(5);
    let mut copy = run.clone();
    for w in &mut copy.windows {
        for (u, m) in w.command.iter_mut().zip(w.measured.iter_mut()) {
            u.x += noise(0.15);
            u.y += noise(0.15);
            m.x += noise(0.15);
            m.y += noise(0.15);
        }
        for p in &mut w.pose {
            p.x += noise(0.01);
            p.y += noise(0.01);
            p.z += noise(0.005);
        }
        for r in &mut w.imu_yaw_rate {
            *r = 1.05 * *r + noise(0.01);
        }
    }
    drive::data::write_dataset(&copy, &d.join("copy.csv")).unwrap();
    let registries = drive::Registries::builtin();
    for ground in ["gravel", "snow"] {
        let sim = drive::studies::simulate_protocol(&registries, "husky", ground, "uniform", 45, 1)
            .unwrap()
            .dataset;
        drive::data::write_dataset(&sim, &d.join(format!("{ground}.csv"))).unwrap();
    }
    let skipped = transfer_skipped(
        d,
        "[[dataset]]\nbundled = \"warthog_asphalt_a\"\nname = \"run\"\n\
         [[dataset]]\npath = \"copy.csv\"\n\
         [[dataset]]\npath = \"gravel.csv\"\n\
         [[dataset]]\npath = \"snow.csv\"\n",
    );
    for pair in ["run -> copy", "copy -> run"] {
        assert!(skipped.contains(pair), "{pair}: {skipped}");
    }
    assert!(
        !skipped.contains("gravel -> snow") && !skipped.contains("snow -> gravel"),
        "{skipped}"
    );
}

/// Issue 63 (a second sweep of that session): a noisy copy whose intervals were reordered,
/// whose commands alone were rescaled (by 1.05), or whose world was mirrored (sides
/// swapped, y, yaw and the IMU negated) was scored as a transfer: its commands did not pair
/// window after window with the run's. Each is the run's drive.
#[test]
fn a_noisy_copy_reordered_rescaled_or_mirrored_is_the_same_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run = drive::bundled::load("warthog_asphalt_a").unwrap();
    let mut noise = gaussian(23);
    let mut noisy = run.clone();
    for w in &mut noisy.windows {
        for u in &mut w.command {
            u.x += noise(0.15);
            u.y += noise(0.15);
        }
        for p in &mut w.pose {
            p.x += noise(0.01);
            p.y += noise(0.01);
            p.z += noise(0.005);
        }
    }
    // The intervals (three windows each) in another order.
    let mut reordered = noisy.clone();
    let intervals = reordered.windows.len() / 3;
    reordered.windows = (0..intervals)
        .flat_map(|k| {
            let k = (37 * k) % intervals;
            noisy.windows[3 * k..3 * k + 3].to_vec()
        })
        .enumerate()
        .map(|(index, mut w)| {
            (w.index, w.interval) = (index, index / 3);
            w
        })
        .collect();
    let mut rescaled = noisy.clone();
    for u in rescaled
        .windows
        .iter_mut()
        .flat_map(|w| w.command.iter_mut())
    {
        *u *= 1.05;
    }
    let mut mirrored = noisy.clone();
    for w in &mut mirrored.windows {
        for u in w.command.iter_mut().chain(w.measured.iter_mut()) {
            u.swap_rows(0, 1);
        }
        for p in &mut w.pose {
            p.y = -p.y;
            p.z = -p.z;
        }
        for r in &mut w.imu_yaw_rate {
            *r = -*r;
        }
    }
    let mut text = String::from("[[dataset]]\nbundled = \"warthog_asphalt_a\"\nname = \"run\"\n");
    for (name, copy) in [
        ("reordered", &reordered),
        ("rescaled", &rescaled),
        ("mirrored", &mirrored),
    ] {
        drive::data::write_dataset(copy, &d.join(format!("{name}.csv"))).unwrap();
        text.push_str(&format!("[[dataset]]\npath = \"{name}.csv\"\n"));
    }
    let skipped = transfer_skipped(d, &text);
    for copy in ["reordered", "rescaled", "mirrored"] {
        for pair in [format!("run -> {copy}"), format!("{copy} -> run")] {
            assert!(skipped.contains(&pair), "{pair}: {skipped}");
        }
    }
}

/// Issue 63 (a third sweep of that session): a dataset made of half of one run and half of
/// another (or of both whole, one after the other) made the two runs "one run through the
/// others", and their genuine pair was lost. Two runs are one through a third only where
/// the windows each shares with it overlap.
#[test]
fn two_runs_joined_in_a_third_dataset_stay_two_runs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = drive::bundled::load("warthog_asphalt_2024-09-20a").unwrap();
    let b = drive::bundled::load("warthog_asphalt_2024-09-20b").unwrap();
    let join = |parts: Vec<drive::traits::Window>| {
        let mut joined = a.clone();
        joined.windows = parts
            .into_iter()
            .enumerate()
            .map(|(index, mut w)| {
                (w.index, w.interval) = (index, index / 3);
                w
            })
            .collect();
        joined
    };
    let (ha, hb) = (3 * (a.windows.len() / 6), 3 * (b.windows.len() / 6));
    let halves = join([&a.windows[..ha], &b.windows[hb..]].concat());
    let both = join([&a.windows[..], &b.windows[..]].concat());
    drive::data::write_dataset(&halves, &d.join("halves.csv")).unwrap();
    drive::data::write_dataset(&both, &d.join("both.csv")).unwrap();
    for joined in ["halves", "both"] {
        let skipped = transfer_skipped(
            d,
            &format!(
                "[[dataset]]\nbundled = \"warthog_asphalt_2024-09-20a\"\nname = \"a\"\n\
                 [[dataset]]\nbundled = \"warthog_asphalt_2024-09-20b\"\nname = \"b\"\n\
                 [[dataset]]\npath = \"{joined}.csv\"\n"
            ),
        );
        assert!(skipped.contains(&format!("a -> {joined}")), "{skipped}");
        assert!(skipped.contains(&format!("b -> {joined}")), "{skipped}");
        assert!(
            !skipped.contains("a -> b:") && !skipped.contains("b -> a:"),
            "{skipped}"
        );
    }
    // Two copies of one run altered differently (its positions scaled by 1.5 in one, its
    // commands and encoders by 1.1 in the other): neither is the other's by its content,
    // both are the run's, and the windows they share with it are the same: one run.
    let mut positions = a.clone();
    for p in positions.windows.iter_mut().flat_map(|w| w.pose.iter_mut()) {
        (p.x, p.y) = (1.5 * p.x, 1.5 * p.y);
    }
    let mut inputs = a.clone();
    for w in &mut inputs.windows {
        for u in w.command.iter_mut().chain(w.measured.iter_mut()) {
            *u *= 1.1;
        }
    }
    drive::data::write_dataset(&positions, &d.join("positions.csv")).unwrap();
    drive::data::write_dataset(&inputs, &d.join("inputs.csv")).unwrap();
    let skipped = transfer_skipped(
        d,
        "[[dataset]]\nbundled = \"warthog_asphalt_2024-09-20a\"\nname = \"a\"\n\
         [[dataset]]\npath = \"positions.csv\"\n\
         [[dataset]]\npath = \"inputs.csv\"\n",
    );
    assert!(
        skipped.contains("positions -> inputs: one run through the others"),
        "{skipped}"
    );
}

/// Issue 63 (a fourth sweep of that session): a run cut again into windows ten samples
/// later (the same samples, other windows) shared no window's print and was scored as a
/// transfer from itself. Its samples are the run's to the bit: the same run.
#[test]
fn a_run_cut_again_into_later_windows_is_the_same_run() {
    let dir = tempfile::tempdir().unwrap();
    let run = drive::bundled::load("warthog_asphalt_2024-09-20a").unwrap();
    let mut recut = run.clone();
    let windows = &run.windows;
    recut.windows = windows
        .windows(2)
        .map(|pair| {
            let (a, b) = (&pair[0], &pair[1]);
            let mut w = a.clone();
            let join = |x: &[drive::traits::Input], y: &[drive::traits::Input]| {
                [&x[10..], &y[..10]].concat()
            };
            w.command = join(&a.command, &b.command);
            w.measured = join(&a.measured, &b.measured);
            // The next window's poses in this one's frame (it starts where this one
            // ends), then all in the frame of the new window's first sample.
            let compose = |base: drive::traits::Pose, p: drive::traits::Pose| {
                let (sin, cos) = base.z.sin_cos();
                drive::traits::Pose::new(
                    base.x + cos * p.x - sin * p.y,
                    base.y + sin * p.x + cos * p.y,
                    base.z + p.z,
                )
            };
            let end = *a.pose.last().unwrap();
            let joined: Vec<_> = a.pose[10..]
                .iter()
                .copied()
                .chain(b.pose[..10].iter().map(|p| compose(end, *p)))
                .collect();
            let start = joined[0];
            let (sin, cos) = start.z.sin_cos();
            w.pose = joined
                .iter()
                .map(|p| {
                    let (dx, dy) = (p.x - start.x, p.y - start.y);
                    drive::traits::Pose::new(
                        cos * dx + sin * dy,
                        -sin * dx + cos * dy,
                        p.z - start.z,
                    )
                })
                .collect();
            w.imu_yaw_rate = [&a.imu_yaw_rate[10..], &b.imu_yaw_rate[..10]].concat();
            w
        })
        .collect();
    drive::data::write_dataset(&recut, &dir.path().join("recut.csv")).unwrap();
    let skipped = transfer_skipped(
        dir.path(),
        "[[dataset]]\nbundled = \"warthog_asphalt_2024-09-20a\"\nname = \"run\"\n\
         [[dataset]]\npath = \"recut.csv\"\n\
         [[dataset]]\nbundled = \"warthog_asphalt_2024-09-20b\"\nname = \"other\"\n",
    );
    for pair in ["run -> recut", "recut -> run"] {
        assert!(skipped.contains(pair), "{pair}: {skipped}");
    }
    assert!(
        !skipped.contains("-> other:") && !skipped.contains("\"other ->"),
        "{skipped}"
    );
}

/// Issue 63 (a twelfth outside sweep): a target's terrain library holds no run that is the
/// target's own (here a part of it: the library's model would be scored on windows it was
/// fitted on, and beat the target's own fit); and the pair the two would make is named in
/// the adaptation's `skipped`, with --no-transfer too.
#[test]
fn a_library_leaves_out_the_runs_that_are_the_targets_own() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut part = drive::bundled::load("warthog_asphalt_a").unwrap();
    let last = part.windows.iter().map(|w| w.interval).max().unwrap();
    part.windows.retain(|w| w.interval + 40 > last);
    drive::data::write_dataset(&part, &d.join("part.csv")).unwrap();
    let suite = d.join("suite.toml");
    std::fs::write(
        &suite,
        "[[dataset]]\nbundled = \"warthog_grass_2024-08-08\"\n\
         [[dataset]]\nbundled = \"warthog_asphalt_a\"\n\
         [[dataset]]\npath = \"part.csv\"\n",
    )
    .unwrap();
    let v: Value = serde_json::from_str(&ok(&[
        "bench",
        "--suite",
        s(&suite),
        "--models",
        "slip-blr",
        "--no-transfer",
        "--adapt",
        "--adapt-library",
        "--adapt-times",
        "0",
        "--json",
    ]))
    .unwrap();
    let a = &v["adaptation"];
    let pairs = a["pairs"].as_array().unwrap();
    // grass -> asphalt_a, grass -> part, and back: the part and its run are not a pair.
    assert_eq!(pairs.len(), 4, "{a}");
    for p in pairs {
        let (prior, target) = (p["prior"].as_str().unwrap(), p["target"].as_str().unwrap());
        let library: Vec<&str> = p["library"]
            .as_array()
            .map(|l| l.iter().map(|x| x.as_str().unwrap()).collect())
            .unwrap_or_default();
        // Every prior's only other run is the target or the target's own: no library
        // (it held the part, or the whole run, before).
        assert!(library.is_empty(), "{prior} -> {target}: {library:?}");
    }
    let skipped: Vec<&str> = a["skipped"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_str().unwrap())
        .collect();
    for pair in ["warthog_asphalt_a -> part", "part -> warthog_asphalt_a"] {
        assert!(
            skipped
                .iter()
                .any(|x| x.starts_with(pair) && x.contains("the same windows")),
            "{pair}: {skipped:?}"
        );
    }
}

/// Issue 63: a robot file that took a registered robot's name (a Warthog's geometry named
/// "husky") is not that robot: its data gets no body size from the registered Husky, and the
/// check says so, rather than the Husky's body silently scaling the total unpredictability.
#[test]
fn a_robot_file_named_like_a_registered_robot_is_not_given_its_body() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let warthog = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/warthog_1080.toml"),
    )
    .unwrap();
    let renamed: String = warthog
        .lines()
        .map(|l| {
            if l.starts_with("name =") {
                "name = \"husky\"".to_string()
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    assert_ne!(renamed, warthog);
    std::fs::write(d.join("fake.toml"), renamed).unwrap();
    let data = d.join("fake.csv");
    ok(&[
        "simulate",
        "--robot",
        s(&d.join("fake.toml")),
        "--terrain",
        "gravel",
        "--duration",
        "120",
        "--seed",
        "4",
        "--out",
        s(&data),
    ]);
    let text = ok(&["check", "--data", s(&data)]);
    assert!(text.contains("no body size"), "{text}");
    assert!(!text.contains("body of the robot husky"), "{text}");
    // With the robot named, its own body.
    let text = ok(&[
        "check",
        "--data",
        s(&data),
        "--robot",
        s(&d.join("fake.toml")),
    ]);
    assert!(text.contains("(body of the robot file"), "{text}");
}
