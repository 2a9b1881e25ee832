//! `drive compare-protocols`: the paper's Table I, on the simulator or on recorded data.

use super::common::{emit, load, names, DataArgs};
use crate::studies::{
    compare_protocols, compare_regions, ProtocolComparison, ProtocolStudy, RegionComparison,
    RegionStudy, MIXED,
};
use crate::traits::limits;
use crate::traits::Dataset;
use crate::Registries;
use anyhow::{bail, Result};

#[derive(clap::Args)]
pub struct Args {
    /// Robots (registered names or TOML files), comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "husky,hd2,warthog")]
    robot: Vec<String>,
    /// Terrains, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "tile,gravel,snow,ice")]
    terrain: Vec<String>,
    /// Twins of real runs instead of robots x terrains, comma-separated, each as
    /// ROBOT=TWIN.toml (the robot the twin was fitted for, a registered name or a robot
    /// file, and its terrain file from `drive sim-fit`): Table I on each, and which
    /// protocol wins where, across them.
    #[arg(long, value_delimiter = ',', conflicts_with_all = ["robot", "terrain", "real", "data"])]
    twins: Vec<String>,
    /// Driving time of each training run (s, characterization excluded), comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "300",
        allow_hyphen_values = true
    )]
    duration: Vec<f64>,
    /// Samplers compared (each gathers a training run), comma-separated; the first is the
    /// reference.
    #[arg(long, value_delimiter = ',', default_value = "uniform,linear,angular")]
    samplers: Vec<String>,
    /// Samplers the held-out test runs are driven by, comma-separated: every trained model
    /// is tested on each, and on their union ("mixed").
    #[arg(long, value_delimiter = ',', default_value = "uniform,linear,angular")]
    test_samplers: Vec<String>,
    /// Number of repetitions (seeds seed, seed+1, ...).
    #[arg(long, allow_negative_numbers = true, default_value_t = 1)]
    seeds: usize,
    /// First seed.
    #[arg(long, allow_negative_numbers = true, default_value_t = 1)]
    seed: u64,
    /// Driving time of each held-out test run (s); default: the longest --duration, at
    /// least 300 s.
    #[arg(long, allow_negative_numbers = true)]
    test_duration: Option<f64>,
    /// Model trained on each run (a model name; see drive list).
    #[arg(long, default_value = "slip-blr")]
    model: String,
    /// Compare on recorded data (--data, or the bundled Husky data) instead.
    #[arg(long)]
    real: bool,
    #[command(flatten)]
    data: DataArgs,
    #[command(flatten)]
    useless: super::common::UselessArg,
    /// With --real: fraction of the intervals the regions are taken from.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.5)]
    split: f64,
    /// With --real: random uniform draws per region.
    #[arg(long, allow_negative_numbers = true, default_value_t = 25)]
    draws: usize,
    /// Print one JSON object on stdout instead of the table.
    #[arg(long)]
    json: bool,
}

pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    // An unknown model is said before any data is read.
    registries.model(&args.model)?;
    if args.real || args.data.data.is_some() {
        limits::at_most("--draws", args.draws as f64, limits::MAX_DRAWS as f64, "")?;
        let study = RegionStudy {
            split: args.split,
            model: args.model.clone(),
            draws: args.draws,
            seed: args.seed,
            ..Default::default()
        };
        let data = load(registries, &args.data)?;
        super::common::refuse_useless(
            &data,
            &super::common::data_name(&args.data),
            args.useless.allow_useless,
            true,
        )?;
        recorded(registries, &data, &study, args.json)
    } else {
        simulated(args, registries)
    }
}

/// Table I on the simulator.
fn simulated(args: &Args, registries: &Registries) -> Result<()> {
    if !args.twins.is_empty() {
        return twins(args, registries);
    }
    let robots = names(&args.robot)
        .into_iter()
        .map(|r| registries.robot(r))
        .collect::<Result<Vec<_>, _>>()?;
    let terrains = names(&args.terrain)
        .into_iter()
        .map(|t| registries.terrain(t))
        .collect::<Result<Vec<_>, _>>()?;
    // Results are grouped by name: two robots or terrains under one name would be pooled.
    for (flag, mut given) in [
        (
            "--robot",
            robots.iter().map(|r| r.name.clone()).collect::<Vec<_>>(),
        ),
        (
            "--terrain",
            terrains.iter().map(|t| t.name.clone()).collect(),
        ),
    ] {
        given.sort();
        if let Some(w) = given.windows(2).find(|w| w[0] == w[1]) {
            bail!(
                "{flag} names '{}' twice (a file's name is the one inside it): results are grouped by name, give each its own (drive sim-fit --name)",
                w[0]
            );
        }
    }
    let table = compare_protocols(registries, &study(args, registries, robots, terrains)?)?;
    if args.json {
        outln!("{}", serde_json::to_string(&table)?);
    } else {
        out!("{}", simulated_table(&table));
    }
    Ok(())
}

/// The study of the command line's samplers, durations, seeds and model over `robots` x
/// `terrains`.
fn study(
    args: &Args,
    registries: &Registries,
    robots: Vec<crate::samplers::RobotSpec>,
    terrains: Vec<crate::sim::Terrain>,
) -> Result<ProtocolStudy> {
    let samplers = names(&args.samplers);
    let test_samplers = names(&args.test_samplers);
    for s in samplers.iter().chain(&test_samplers) {
        registries.samplers.get(s)?;
    }
    if samplers.is_empty() || test_samplers.is_empty() {
        bail!("--samplers and --test-samplers each need at least one sampler");
    }
    if args.seeds == 0 {
        bail!("--seeds must be at least 1");
    }
    limits::at_most("--seeds", args.seeds as f64, limits::MAX_SEEDS as f64, "")?;
    if let Some(d) = args.duration.iter().find(|d| !(d.is_finite() && **d > 0.0)) {
        bail!(
            "--duration must be positive seconds of driving, got {}",
            limits::Short(*d)
        );
    }
    let longest = args.duration.iter().copied().fold(0.0, f64::max);
    Ok(ProtocolStudy {
        robots,
        terrains,
        samplers: samplers.iter().map(|s| s.to_string()).collect(),
        driving_s: args.duration.to_vec(),
        seeds: (0..args.seeds as u64)
            .map(|i| args.seed.wrapping_add(i))
            .collect(),
        test_samplers: test_samplers.iter().map(|s| s.to_string()).collect(),
        mixed_test: true,
        test_driving_s: args.test_duration.unwrap_or(longest.max(300.0)),
        model: args.model.to_string(),
    })
}

/// Table I on each twin of `--twins` (each with its own robot), then which training
/// sampler wins on each test set across them.
fn twins(args: &Args, registries: &Registries) -> Result<()> {
    let mut pairs = Vec::new();
    for pair in &args.twins {
        let Some((robot, twin)) = pair.split_once('=') else {
            bail!("--twins takes ROBOT=TWIN.toml pairs; '{pair}' has no '='");
        };
        let twin = registries.terrain(twin)?;
        if let (None, Some(f)) = (&twin.protocol, &twin.fitted_for) {
            bail!(
                "--twins: terrain '{}' is the twin of a vehicle of type '{}', of which drive sim-fit fits the ground only (no protocol of its real run to replay): --twins compares protocols on skid-steer twins",
                twin.name,
                f.vehicle
            );
        }
        if twin.protocol.is_none() {
            bail!(
                "--twins: terrain '{}' is not a twin of a real run (it has no protocol); give a file written by drive sim-fit",
                twin.name
            );
        }
        pairs.push((registries.robot(robot)?, twin));
    }
    let mut names: Vec<&str> = pairs.iter().map(|(_, t)| t.name.as_str()).collect();
    names.sort_unstable();
    if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
        bail!(
            "--twins names '{}' twice (a file's name is the one inside it): give each its own (drive sim-fit --name)",
            w[0]
        );
    }
    let mut table: Option<ProtocolComparison> = None;
    for (robot, twin) in pairs {
        let one = compare_protocols(
            registries,
            &study(args, registries, vec![robot], vec![twin])?,
        )?;
        match &mut table {
            None => table = Some(one),
            Some(t) => {
                t.rows.extend(one.rows);
                t.cells.extend(one.cells);
            }
        }
    }
    // At least one pair: clap gave --twins a value.
    let table = table.ok_or_else(|| anyhow::anyhow!("--twins is empty"))?;
    if args.json {
        // The table and, as the text shows them, its winners.
        let mut json = serde_json::to_value(&table)?;
        json["winners"] = serde_json::to_value(table.winners())?;
        outln!("{}", serde_json::to_string(&json)?);
    } else {
        out!("{}", simulated_table(&table));
        out!("{}", winners(&table));
    }
    Ok(())
}

/// Per robot, terrain (twin) and driving time: which training sampler has the lowest
/// median error on each test set, and how often each wins across them
/// ([`ProtocolComparison::winners`]).
fn winners(t: &ProtocolComparison) -> String {
    use std::fmt::Write as _;
    let w = t.winners();
    let mut out = String::from(
        "\nwhich protocol trains the best model, per twin (lowest median error on each test set; translation / rotation):\n",
    );
    for b in &w.blocks {
        let _ = write!(out, "  {} on {}, {:.0} s:", b.robot, b.terrain, b.driving_s);
        for best in &b.best {
            let _ = write!(
                out,
                " on {} {} / {};",
                best.test_sampler, best.translational, best.rotational
            );
        }
        out.push('\n');
    }
    let _ = writeln!(
        out,
        "wins over the {} twins (translation, rotation):",
        w.blocks.len()
    );
    for test in &t.test_sets {
        let line: Vec<String> = w
            .wins
            .iter()
            .filter(|c| &c.test_sampler == test)
            .map(|c| format!("{} {}/{}", c.train_sampler, c.translational, c.rotational))
            .collect();
        let _ = writeln!(out, "  tested on {test}: {}", line.join(", "));
    }
    out
}

fn simulated_table(t: &ProtocolComparison) -> String {
    use std::fmt::Write as _;
    let seeds = t.rows.first().map_or(0, |r| r.seeds);
    let tests = t
        .test_sets
        .iter()
        .filter(|s| *s != MIXED)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    let mut out = format!(
        "Protocols compared on the simulator (paper Table I, as a cross-evaluation): {} trained on each training run and tested on held-out {:.0} s runs driven by {tests}{} ({seeds} seed{}); errors are medians of eq. 8 over the test windows{}, translation [m] / rotation [rad]\n",
        t.model,
        t.test_driving_s,
        if t.test_sets.iter().any(|s| s == MIXED) { ", and on all of them together (mixed)" } else { "" },
        if seeds == 1 { "" } else { "s" },
        if seeds == 1 { "" } else { " of every seed" },
    );
    for r in &t.simulators {
        let _ = writeln!(out, "simulator of {}: {}", r.robot, r.simulator);
    }
    // One block per robot, terrain and driving time: training samplers down, test sets
    // across.
    let mut blocks: Vec<(&str, &str, f64)> = Vec::new();
    for r in &t.rows {
        let key = (r.robot.as_str(), r.terrain.as_str(), r.driving_s);
        if !blocks.contains(&key) {
            blocks.push(key);
        }
    }
    let trains: Vec<&str> = {
        let mut v: Vec<&str> = Vec::new();
        for r in &t.rows {
            if !v.contains(&r.train_sampler.as_str()) {
                v.push(&r.train_sampler);
            }
        }
        v
    };
    let find = |b: (&str, &str, f64), train: &str, test: &str| {
        t.rows.iter().find(|r| {
            (r.robot.as_str(), r.terrain.as_str(), r.driving_s) == b
                && r.train_sampler == train
                && r.test_sampler == test
        })
    };
    for &b in &blocks {
        let _ = writeln!(
            out,
            "\n{} on {}, {:.0} s of driving per training run",
            b.0, b.1, b.2
        );
        let _ = write!(out, "{:<18}", "trained on \\ test");
        for test in &t.test_sets {
            let _ = write!(out, " {:>19}", test);
        }
        out.push('\n');
        for train in &trains {
            let _ = write!(out, "{train:<18}");
            for test in &t.test_sets {
                let cell = find(b, train, test).map_or("-".to_string(), |r| {
                    format!(
                        "{:.4} / {:.4}",
                        r.translational_median_m, r.rotational_median_rad
                    )
                });
                let _ = write!(out, " {cell:>19}");
            }
            out.push('\n');
        }
        for train in trains.iter().filter(|s| **s != t.reference) {
            let _ = write!(
                out,
                "{:<18}",
                format!("{} better than {train}", t.reference)
            );
            out.push('\n');
            for test in &t.test_sets {
                if let Some(r) = find(b, train, test) {
                    let (x, y) = (
                        &r.reference_improvement_translational,
                        &r.reference_improvement_rotational,
                    );
                    let wins = if r.seeds > 1 {
                        format!(
                            ", wins {}/{} and {}/{} seeds",
                            r.reference_wins_translational,
                            r.seeds,
                            r.reference_wins_rotational,
                            r.seeds
                        )
                    } else {
                        String::new()
                    };
                    let _ = writeln!(
                        out,
                        "  tested on {test:<10} {:+.1}% [{:+.1}, {:+.1}] / {:+.1}% [{:+.1}, {:+.1}]{wins}",
                        x.percent, x.ci[0], x.ci[1], y.percent, y.ci[0], y.ci[1]
                    );
                }
            }
        }
    }
    // How the reference ranks among the training samplers, per test set.
    if trains.len() > 1 {
        let _ = writeln!(
            out,
            "\n{} ranked among the {} training samplers, over the {} robot/terrain/duration blocks (best, worst):",
            t.reference,
            trains.len(),
            blocks.len()
        );
        for test in &t.test_sets {
            let rank = |metric: fn(&crate::studies::ProtocolRow) -> f64| {
                let (mut best, mut worst) = (0, 0);
                for &b in &blocks {
                    let values: Vec<f64> = trains
                        .iter()
                        .filter_map(|s| find(b, s, test).map(metric))
                        .collect();
                    let Some(mine) = find(b, &t.reference, test).map(metric) else {
                        continue;
                    };
                    if values.iter().all(|v| mine <= *v) {
                        best += 1;
                    }
                    if values.iter().all(|v| mine >= *v) {
                        worst += 1;
                    }
                }
                (best, worst)
            };
            let (tb, tw) = rank(|r| r.translational_median_m);
            let (rb, rw) = rank(|r| r.rotational_median_rad);
            let _ = writeln!(
                out,
                "  tested on {test:<10} translation best {tb}, worst {tw}; rotation best {rb}, worst {rw}"
            );
        }
    }
    // The paper's two headline figures, averaged over every block, on each test set.
    let mean = |train: &str, test: &str, f: fn(&crate::studies::ProtocolRow) -> f64| {
        let v: Vec<f64> = t
            .rows
            .iter()
            .filter(|r| r.train_sampler == train && r.test_sampler == test)
            .map(f)
            .collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    for test in &t.test_sets {
        let a = mean("angular", test, |r| {
            r.reference_improvement_translational.percent
        });
        let l = mean("linear", test, |r| {
            r.reference_improvement_rotational.percent
        });
        if let (Some(a), Some(l)) = (a, l) {
            let _ = writeln!(
                out,
                "tested on {test}: mean improvement of {} over angular in translation {a:+.1}% (paper: 31.8%), over linear in rotation {l:+.1}% (paper: 43.6%)",
                t.reference
            );
        }
    }
    out
}

/// Table I on recorded data.
fn recorded(
    registries: &Registries,
    data: &Dataset,
    study: &RegionStudy,
    json: bool,
) -> Result<()> {
    let comparison = compare_regions(registries, data, study)?;
    super::common::note_few_evaluation(None, comparison.eval_windows);
    emit(json, &comparison, recorded_table)
}

fn recorded_table(t: &RegionComparison) -> String {
    use std::fmt::Write as _;
    let mut out = format!(
        "Protocols compared on recorded data (paper Table I): {} from {}, {} training intervals, {} evaluation windows\n\
         input space of the training commands {} (top speed {:.3} m/s, top yaw rate {:.3} rad/s)\n",
        t.model,
        t.dataset,
        t.train_intervals,
        t.eval_windows,
        t.input_space
            .iter()
            .map(|[lo, hi]| format!("[{lo:.2}, {hi:.2}]"))
            .collect::<Vec<_>>()
            .join(" x "),
        t.top_speed_m_s,
        t.turn_rate_rad_s,
    );
    let _ = writeln!(
        out,
        "{:<8} {:>9} {:>22} {:>26} {:>20}",
        "region",
        "intervals",
        "region [m / rad]",
        format!("uniform x{} [m / rad]", t.draws),
        "uniform better by"
    );
    for r in &t.regions {
        let _ = writeln!(
            out,
            "{:<8} {:>9} {:>22} {:>26} {:>20}",
            r.region,
            r.intervals,
            format!(
                "{:.4} / {:.4}",
                r.region_translational.median, r.region_rotational.median
            ),
            format!(
                "{:.4} / {:.4}",
                r.uniform_translational_median_m, r.uniform_rotational_median_rad
            ),
            format!(
                "{:+.1}% / {:+.1}%",
                r.improvement_translational_percent, r.improvement_rotational_percent
            ),
        );
    }
    for r in &t.regions {
        let _ = writeln!(out, "{} region: {}", r.region, r.definition);
    }
    let _ = writeln!(
        out,
        "uniform: as many intervals drawn at random from all training intervals, {} draws (median of their medians)",
        t.draws
    );
    out
}
