//! The `drive` command line: train and evaluate DRIVE motion models on real data.

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use drive::data::{read_dataset, DataError};
use drive::eval::{compare_with, Comparison};
use drive::models::model_file::{model_from_json, model_to_json};
use drive::models::{DifferentialDrive, LearnerRegistry, PowertrainChoice, MODEL_NAMES};
use drive::traits::{Dataset, Input, Pose, StartState, WindowSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

mod compare_protocols;
mod import_log;
mod matrix;

#[derive(Parser)]
#[command(
    name = "drive",
    version,
    about = "DRIVE: identify how a UGV really moves on its terrain (Baril et al.)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Args)]
struct DataArgs {
    /// Window CSV (see data/README.md); the bundled Husky dataset when absent.
    #[arg(long)]
    data: Option<PathBuf>,
    /// Sidecar JSON of the window CSV; by default the CSV's path with a .json extension.
    #[arg(long, requires = "data")]
    sidecar: Option<PathBuf>,
}

#[derive(Subcommand)]
enum Command {
    /// Fit every model on the training intervals and score it on the rest (paper eq. 8).
    Eval {
        #[command(flatten)]
        data: DataArgs,
        /// Fraction of the DRIVE intervals (in recording order) used for training.
        #[arg(long, default_value_t = 0.5)]
        split: f64,
        /// Models to compare, comma-separated.
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "naive,powertrain,slip-blr,acc-blr"
        )]
        models: Vec<String>,
        /// Powertrain of the models built on one: commanded (wheel velocities = commands) or
        /// fopdt (eq. 3). Default: each model's own (fopdt for powertrain and slip-blr,
        /// commanded for acc-blr, as in the paper).
        #[arg(long, value_parser = parse_powertrain)]
        powertrain: Option<PowertrainChoice>,
        /// Print one JSON object on stdout instead of the table.
        #[arg(long)]
        json: bool,
        /// Write every evaluation window's errors per model to this CSV.
        #[arg(long)]
        per_window: Option<PathBuf>,
    },
    /// Fit one model and save it as JSON.
    Train {
        #[command(flatten)]
        data: DataArgs,
        /// Model to fit.
        #[arg(long)]
        model: String,
        /// Output model file.
        #[arg(long)]
        out: PathBuf,
        /// Train on the first fraction of the intervals only (default: all of the data).
        #[arg(long)]
        split: Option<f64>,
    },
    /// Prediction error against training driving time, and the convergence time (paper
    /// Fig. 7): train on the first 1, 2, 3, ... intervals, evaluate on the evaluation part.
    Converge {
        #[command(flatten)]
        data: DataArgs,
        /// Fraction of the intervals whose prefixes are trained on; the rest evaluates.
        #[arg(long, default_value_t = 0.5)]
        split: f64,
        /// Model whose convergence is analysed.
        #[arg(long, default_value = "slip-blr")]
        model: String,
        /// Gradient thresholds m/s,rad/s of the convergence rule.
        #[arg(long, value_parser = parse_pair, default_value = "0.01,0.01", allow_hyphen_values = true)]
        thresholds: [f64; 2],
        /// Print one JSON object on stdout instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// The DRIVE command schedule: sampled inputs held for 6 s intervals (one transient and
    /// two steady 2 s windows) within the robot's acceleration limits.
    Protocol {
        /// A preset (husky, hd2, warthog) or a robot TOML file.
        #[arg(long)]
        robot: String,
        /// Input sampler: uniform (DRIVE), grid, linear, angular.
        #[arg(long, default_value = "uniform")]
        sampler: String,
        /// Number of 6 s intervals.
        #[arg(long)]
        intervals: usize,
        /// Seed of the sampler.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Output CSV: t,interval,phase,cmd_left,cmd_right.
        #[arg(long)]
        out: PathBuf,
    },
    /// Run the protocol (characterization, then DRIVE intervals) on a simulated UGV and
    /// write the recorded windows as a window CSV and its sidecar.
    Simulate {
        /// A preset (husky, hd2, warthog) or a robot TOML file.
        #[arg(long)]
        robot: String,
        /// Terrain: tile, gravel, snow, ice.
        #[arg(long)]
        terrain: String,
        /// Input sampler: uniform (DRIVE), grid, linear, angular.
        #[arg(long, default_value = "uniform")]
        sampler: String,
        /// Duration of the run (s), characterization included.
        #[arg(long)]
        duration: f64,
        /// Seed of the sampler and of the simulator's noise.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Output window CSV (its sidecar JSON is written beside it).
        #[arg(long)]
        out: PathBuf,
        /// Also write what the DRIVE logger would have recorded (the raw CSV `drive
        /// import` reads).
        #[arg(long)]
        raw_out: Option<PathBuf>,
    },
    /// Compare data-gathering protocols (paper Table I). On the simulator: equal driving
    /// time with each sampler, slip-BLR trained on each, all tested on one held-out uniform
    /// run. With --real: on recorded data, models trained on the intervals in a
    /// linear-focused and an angular-focused region against as many drawn from all of J.
    CompareProtocols {
        /// Robot presets (husky, hd2, warthog) or TOML files, comma-separated.
        #[arg(long, value_delimiter = ',', default_value = "husky,hd2,warthog")]
        robot: Vec<String>,
        /// Terrains, comma-separated.
        #[arg(long, value_delimiter = ',', default_value = "tile,gravel,snow,ice")]
        terrain: Vec<String>,
        /// Driving time of each training run (s, characterization excluded), comma-separated.
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "300",
            allow_hyphen_values = true
        )]
        duration: Vec<f64>,
        /// Samplers compared, comma-separated; the first is the reference.
        #[arg(long, value_delimiter = ',', default_value = "uniform,linear,angular")]
        samplers: Vec<String>,
        /// Number of repetitions (seeds seed, seed+1, ...).
        #[arg(long, default_value_t = 1)]
        seeds: usize,
        /// First seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Driving time of the held-out test run (s); default: the longest --duration, at
        /// least 300 s.
        #[arg(long)]
        test_duration: Option<f64>,
        /// Model trained on each run.
        #[arg(long, default_value = "slip-blr")]
        model: String,
        /// Compare on recorded data (--data, or the bundled Husky data) instead.
        #[arg(long)]
        real: bool,
        #[command(flatten)]
        data: DataArgs,
        /// With --real: fraction of the intervals the regions are taken from.
        #[arg(long, default_value_t = 0.5)]
        split: f64,
        /// With --real: random uniform draws per region.
        #[arg(long, default_value_t = 25)]
        draws: usize,
        /// Print one JSON object on stdout instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// Import a raw DRIVE logger CSV: cut each 6 s interval into one transient and two
    /// steady windows, drop the unusable ones with their reason, and write the window CSV
    /// and sidecar that `drive eval` reads.
    Import {
        /// The logger's raw CSV.
        #[arg(long)]
        raw: PathBuf,
        /// The robot's geometry and command rate: a preset (husky, hd2, warthog) or a TOML file.
        #[arg(long)]
        robot: String,
        /// Output window CSV (its sidecar JSON is written beside it).
        #[arg(long)]
        out: PathBuf,
        /// A time between two rows longer than this (s) cuts an interval (never less than two
        /// command periods).
        #[arg(long, default_value_t = 0.25)]
        max_gap: f64,
        /// The longest time without a localization update inside an interval (s).
        #[arg(long, default_value_t = 0.5)]
        localization_timeout: f64,
        /// Print the keep/drop report as one JSON object on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Score every combination of a sweep file (datasets or simulated runs x learners x
    /// powertrains x splits) and write DIR/matrix.csv (one row per combination and metric),
    /// DIR/matrix.json and DIR/summary.md (median, IQR, improvement over the baseline with a
    /// bootstrap interval). See examples/sweep.toml.
    Matrix {
        /// The sweep file (TOML).
        #[arg(long)]
        config: PathBuf,
        /// Output folder (created if missing).
        #[arg(long)]
        out: PathBuf,
        /// Print the JSON document on stdout instead of the Markdown summary.
        #[arg(long)]
        json: bool,
    },
    /// Write DIR/report.md (model comparison, convergence time, fitted parameters,
    /// uncertainty calibration) and the paper's figures as PNG and SVG for one dataset.
    Report {
        #[command(flatten)]
        data: DataArgs,
        /// Output folder (created if missing).
        #[arg(long)]
        out: PathBuf,
        /// The robot's manufacturer limits for the input-space figure: a preset (husky, hd2,
        /// warthog) or a TOML file. Default: the husky preset for the bundled data, none
        /// otherwise.
        #[arg(long)]
        robot: Option<String>,
        /// Fraction of the DRIVE intervals (in recording order) used for training.
        #[arg(long, default_value_t = 0.5)]
        split: f64,
    },
    /// Predict poses from a saved model and a command sequence.
    Predict {
        /// Model file written by `drive train`.
        #[arg(long)]
        model: PathBuf,
        /// CSV with columns t,cmd_left,cmd_right (wheel angular velocities, command rate).
        #[arg(long)]
        commands: PathBuf,
        /// Start pose x,y,yaw (m, m, rad) (default: origin).
        #[arg(long, value_parser = parse_triplet, allow_hyphen_values = true)]
        start: Option<[f64; 3]>,
        /// Measured wheel velocities at the start, left,right (rad/s) (default: at rest).
        #[arg(long, value_parser = parse_pair, allow_hyphen_values = true)]
        start_wheels: Option<[f64; 2]>,
    },
}

fn parse_numbers<const N: usize>(s: &str) -> Result<[f64; N], String> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != N {
        return Err(format!("expected {N} comma-separated numbers, got '{s}'"));
    }
    let mut out = [0.0; N];
    for (o, p) in out.iter_mut().zip(parts) {
        *o = p
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("'{p}' is not a finite number"))?;
    }
    Ok(out)
}
fn parse_powertrain(s: &str) -> Result<PowertrainChoice, String> {
    PowertrainChoice::parse(s)
        .ok_or_else(|| format!("unknown powertrain '{s}' (the powertrains are: commanded, fopdt)"))
}
fn parse_triplet(s: &str) -> Result<[f64; 3], String> {
    parse_numbers::<3>(s)
}
fn parse_pair(s: &str) -> Result<[f64; 2], String> {
    parse_numbers::<2>(s)
}

fn load(args: &DataArgs) -> Result<Dataset, DataError> {
    match &args.data {
        Some(csv) => read_dataset(csv, args.sidecar.as_deref()),
        None => drive::bundled::husky(),
    }
}

/// Parses the command line; an argument error is reported on one line (clap's own message
/// without the usage block), help and version are printed as usual.
fn parse_cli() -> Result<Cli, ExitCode> {
    use clap::error::ErrorKind;
    Cli::try_parse().map_err(|e| {
        if matches!(
            e.kind(),
            ErrorKind::DisplayHelp
                | ErrorKind::DisplayVersion
                | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
        ) {
            let _ = e.print();
            return if e.exit_code() == 0 {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(2)
            };
        }
        let text = e.render().to_string();
        let message: Vec<&str> = text
            .lines()
            .map(str::trim)
            .take_while(|l| !l.starts_with("Usage:") && !l.starts_with("For more information"))
            .filter(|l| !l.is_empty())
            .collect();
        eprintln!("{} (see drive --help)", message.join(" "));
        ExitCode::from(2)
    })
}

fn main() -> ExitCode {
    let cli = match parse_cli() {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    let result = match cli.command {
        Command::Eval {
            data,
            split,
            models,
            powertrain,
            json,
            per_window,
        } => run_eval(
            &data,
            split,
            &models,
            powertrain,
            json,
            per_window.as_deref(),
        ),
        Command::Train {
            data,
            model,
            out,
            split,
        } => run_train(&data, &model, &out, split),
        Command::Protocol {
            robot,
            sampler,
            intervals,
            seed,
            out,
        } => run_protocol(&robot, &sampler, intervals, seed, &out),
        Command::Simulate {
            robot,
            terrain,
            sampler,
            duration,
            seed,
            out,
            raw_out,
        } => run_simulate(
            &robot,
            &terrain,
            &sampler,
            duration,
            seed,
            &out,
            raw_out.as_deref(),
        ),
        Command::Converge {
            data,
            split,
            model,
            thresholds,
            json,
        } => run_converge(&data, split, &model, thresholds, json),
        Command::CompareProtocols {
            robot,
            terrain,
            duration,
            samplers,
            seeds,
            seed,
            test_duration,
            model,
            real,
            data,
            split,
            draws,
            json,
        } => {
            if real || data.data.is_some() {
                let study = drive::eval::RegionStudy {
                    split,
                    model,
                    draws,
                    seed,
                    ..Default::default()
                };
                load(&data)
                    .map_err(anyhow::Error::from)
                    .and_then(|d| compare_protocols::recorded(&d, &study, json))
            } else {
                compare_protocols::simulated(&compare_protocols::SimulatedArgs {
                    robots: &robot,
                    terrains: &terrain,
                    samplers: &samplers,
                    durations: &duration,
                    seeds,
                    first_seed: seed,
                    test_duration,
                    model: &model,
                    json,
                })
            }
        }
        Command::Import {
            raw,
            robot,
            out,
            max_gap,
            localization_timeout,
            json,
        } => import_log::run(
            &raw,
            &robot,
            &out,
            &drive::data::ImportConfig {
                max_gap_s: max_gap,
                localization_timeout_s: localization_timeout,
            },
            json,
        ),
        Command::Report {
            data,
            out,
            robot,
            split,
        } => run_report(&data, &out, robot.as_deref(), split),
        Command::Matrix { config, out, json } => matrix::run_with(
            &config,
            &out,
            json,
            &drive::models::LearnerRegistry::builtin(),
            &drive::samplers::SamplerRegistry::builtin(),
        )
        .map(|_| ()),
        Command::Predict {
            model,
            commands,
            start,
            start_wheels,
        } => run_predict(&model, &commands, start, start_wheels),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run_eval(
    data: &DataArgs,
    split: f64,
    models: &[String],
    powertrain: Option<PowertrainChoice>,
    json: bool,
    per_window: Option<&Path>,
) -> Result<()> {
    let dataset = load(data)?;
    let names: Vec<&str> = models
        .iter()
        .map(|s| s.trim())
        .filter(|s| !s.is_empty())
        .collect();
    if names.is_empty() {
        bail!(
            "--models is empty (the models are: {})",
            MODEL_NAMES.join(", ")
        );
    }
    let cmp = compare_with(
        &LearnerRegistry::builtin(),
        &dataset,
        split,
        &names,
        powertrain,
    )?;
    if let Some(path) = per_window {
        std::fs::write(path, per_window_csv(&cmp))
            .with_context(|| format!("writing {}", path.display()))?;
    }
    emit(json, &cmp, table)
}

/// Prints `value` as one JSON object on stdout when `json`, else its text `table`.
fn emit<T: serde::Serialize>(
    json: bool,
    value: &T,
    table: impl FnOnce(&T) -> String,
) -> Result<()> {
    if json {
        println!("{}", serde_json::to_string(value)?);
    } else {
        print!("{}", table(value));
    }
    Ok(())
}

fn per_window_csv(cmp: &Comparison) -> String {
    let mut out = String::from("model,window,interval,phase,translational_m,rotational_rad\n");
    for m in &cmp.models {
        for w in &m.report.windows {
            let _ = writeln!(
                out,
                "{},{},{},{},{},{}",
                m.name,
                w.window,
                w.interval,
                w.phase.as_str(),
                w.error.translational,
                w.error.rotational
            );
        }
    }
    out
}

fn table(cmp: &Comparison) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "DRIVE model comparison on {} ({})",
        cmp.dataset,
        if cmp.robot.is_empty() {
            "robot not named"
        } else {
            &cmp.robot
        }
    );
    let _ = writeln!(
        s,
        "train: first {} intervals ({} windows); evaluate: last {} intervals ({} windows); split {}",
        cmp.train_intervals, cmp.train_windows, cmp.eval_intervals, cmp.eval_windows, cmp.split
    );
    let powertrains: Vec<String> = cmp
        .models
        .iter()
        .filter_map(|m| m.powertrain.map(|p| format!("{} on {}", m.name, p.name())))
        .collect();
    if !powertrains.is_empty() {
        let _ = writeln!(s, "powertrains: {}", powertrains.join(", "));
    }
    let _ = writeln!(
        s,
        "MRMSE over the 2 s windows (paper eq. 8): median [IQR], improvement over naive\n"
    );
    let section =
        |s: &mut String,
         title: &str,
         pick: &dyn Fn(&drive::eval::ModelResult) -> Option<drive::eval::PhaseSummary>| {
            let count = cmp
                .models
                .iter()
                .find_map(|m| pick(m).map(|p| p.windows))
                .unwrap_or(0);
            let _ = writeln!(s, "{title} ({count} windows)");
            let (translational, rotational) = ("translational MRMSE [m]", "rotational MRMSE [rad]");
            let _ = writeln!(s, "  {:<11}{translational:<37}{rotational}", "");
            let header = "median  IQR               vs naive";
            let _ = writeln!(s, "  {:<11}{header:<37}{header}", "model");
            for m in &cmp.models {
                let Some(p) = pick(m) else {
                    let _ = writeln!(s, "  {:<11}no window", m.name);
                    continue;
                };
                let cell = |e: drive::eval::ErrorSummary| {
                    let [q1, q3] = e.iqr;
                    format!(
                        "{:<6.4}  [{q1:.4}, {q3:.4}]  {:>+7.1}%",
                        e.median, e.improvement_over_naive_percent
                    )
                };
                let _ = writeln!(
                    s,
                    "  {:<11}{:<37}{}",
                    m.name,
                    cell(p.translational_m),
                    cell(p.rotational_rad)
                );
            }
            let _ = writeln!(s);
        };
    section(&mut s, "all evaluation windows", &|m| Some(m.all));
    section(&mut s, "transient windows", &|m| m.transient);
    section(&mut s, "steady windows", &|m| m.steady);
    s
}

fn run_report(data: &DataArgs, out: &Path, robot: Option<&str>, split: f64) -> Result<()> {
    let dataset = load(data)?;
    let robot = robot.or(data.data.is_none().then_some("husky"));
    let naive_input_space = match robot {
        Some(r) => {
            let spec = drive::samplers::RobotSpec::load(r)?;
            Some((
                format!("naive input space ({} manufacturer limits)", spec.name),
                spec.input_space(),
            ))
        }
        None => None,
    };
    let options = drive::report::ReportOptions {
        split,
        naive_input_space,
        ..Default::default()
    };
    let report = drive::report::Report::build(&dataset, &options)?;
    let files = report.write(out)?;
    if let Err(reason) = &report.protocols {
        eprintln!("note: no protocol figure: {reason}");
    }
    eprintln!(
        "report on {}: {} files written to {} (open report.md)",
        dataset.robot.name,
        files.len(),
        out.display()
    );
    Ok(())
}

fn run_protocol(robot: &str, sampler: &str, intervals: usize, seed: u64, out: &Path) -> Result<()> {
    use drive::samplers::{sampler_named, schedule, schedule_csv, RobotSpec};
    if intervals == 0 {
        bail!("--intervals must be at least 1");
    }
    let spec = RobotSpec::load(robot)?;
    let vehicle = || {
        Box::new(DifferentialDrive::new(spec.wheel_radius, spec.baseline))
            as Box<dyn drive::traits::CommandModel>
    };
    let mut s = sampler_named(sampler, &spec, vehicle, seed)?;
    let rows = schedule(&spec, vehicle().as_ref(), s.as_mut(), intervals);
    std::fs::write(out, schedule_csv(&rows))
        .with_context(|| format!("writing {}", out.display()))?;
    eprintln!(
        "{} commands ({} intervals, {:.0} s at {} Hz) for {} with the {sampler} sampler; saved to {}",
        rows.len(),
        intervals,
        rows.len() as f64 / spec.rate_hz,
        spec.rate_hz,
        spec.name,
        out.display()
    );
    Ok(())
}

fn run_simulate(
    robot: &str,
    terrain: &str,
    sampler: &str,
    duration: f64,
    seed: u64,
    out: &Path,
    raw_out: Option<&Path>,
) -> Result<()> {
    use drive::samplers::{RobotSpec, RunnerConfig};
    use drive::sim::Terrain;
    if !(duration.is_finite() && duration > 0.0) {
        bail!("--duration must be a positive number of seconds, got {duration}");
    }
    let spec = RobotSpec::load(robot)?;
    let ground = Terrain::preset(terrain).with_context(|| {
        format!(
            "unknown terrain '{terrain}' (the terrains are: {})",
            Terrain::NAMES.join(", ")
        )
    })?;
    let runner = RunnerConfig {
        max_duration_s: Some(duration),
        ..RunnerConfig::default()
    };
    let run = drive::eval::simulate_with(&spec, ground, sampler, runner, seed)?;
    if run.dataset.windows.is_empty() {
        bail!("the run of {duration} s recorded no complete interval (characterization takes about 24 s, an interval 6 s)");
    }
    drive::data::write_dataset(&run.dataset, out)?;
    if let Some(path) = raw_out {
        let mut text = String::new();
        drive::data::write_raw_log(&run.raw, &[], &mut text);
        std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))?;
    }
    let c = run.characterization;
    eprintln!(
        "{} windows ({} intervals) of {} on {}; input space {}; saved to {}",
        run.dataset.windows.len(),
        run.dataset.windows.len() / 3,
        spec.name,
        ground.name,
        c.map_or("user-given".into(), |c| format!(
            "[{:.2}, {:.2}] x [{:.2}, {:.2}] rad/s, effective radius {}, baseline {}",
            c.space.min.x,
            c.space.max.x,
            c.space.min.y,
            c.space.max.y,
            c.wheel_radius.map_or("-".into(), |v| format!("{v:.3} m")),
            c.baseline.map_or("-".into(), |v| format!("{v:.3} m"))
        )),
        out.display()
    );
    Ok(())
}

fn run_converge(
    data: &DataArgs,
    split: f64,
    name: &str,
    thresholds: [f64; 2],
    json: bool,
) -> Result<()> {
    if !MODEL_NAMES.contains(&name) {
        bail!(
            "unknown model '{name}' (the models are: {})",
            MODEL_NAMES.join(", ")
        );
    }
    if thresholds.iter().any(|t| *t <= 0.0) {
        bail!(
            "--thresholds must be positive, got {},{}",
            thresholds[0],
            thresholds[1]
        );
    }
    let dataset = load(data)?;
    // The name was checked against the registry above.
    let fit =
        |set: &WindowSet<'_>| drive::models::fit_named(name, set).expect("a registered model");
    let c = drive::eval::convergence(&dataset, split, thresholds, fit)?;
    if json {
        println!("{}", serde_json::to_string(&c)?);
        return Ok(());
    }
    println!("Convergence of {name} on {} (paper Fig. 7): training on the first intervals, {} evaluation windows", dataset.robot.name, c.eval_windows);
    println!(
        "{:>10} {:>10} {:>18} {:>18}",
        "time [s]", "intervals", "transl. med. [m]", "rot. med. [rad]"
    );
    for p in &c.curve {
        println!(
            "{:>10.1} {:>10} {:>18.4} {:>18.4}",
            p.training_time_s, p.intervals, p.translational_median_m, p.rotational_median_rad
        );
    }
    if !c.skipped.is_empty() {
        let first = &c.skipped[0];
        println!(
            "not fitted with {} of the amounts of data (e.g. {} intervals: {})",
            c.skipped.len(),
            first.intervals,
            first.reason
        );
    }
    match c.convergence_time_s {
        Some(t) => println!(
            "convergence time: {t:.1} s (every later gradient under {} m/s and {} rad/s)",
            thresholds[0], thresholds[1]
        ),
        None => println!("convergence time: none (the curve never meets the rule)"),
    }
    Ok(())
}

fn run_train(data: &DataArgs, name: &str, out: &Path, split: Option<f64>) -> Result<()> {
    let dataset = load(data)?;
    let train = match split {
        Some(f) => drive::eval::split_by_interval(&dataset, f)?.0,
        None => WindowSet::new(&dataset.robot, &dataset.windows),
    };
    let model = drive::models::fit_named(name, &train)
        .with_context(|| {
            format!(
                "unknown model '{name}' (the models are: {})",
                MODEL_NAMES.join(", ")
            )
        })?
        .with_context(|| format!("fitting {name}"))?;
    std::fs::write(out, model_to_json(model.as_ref(), &dataset.robot))
        .with_context(|| format!("writing {}", out.display()))?;
    eprintln!(
        "fitted {name} on {} windows of {}; saved to {}",
        train.len(),
        dataset.robot.name,
        out.display()
    );
    Ok(())
}

/// Reads a `t,cmd_left,cmd_right` command file sampled at period `dt`.
fn read_commands(path: &Path, dt: f64) -> Result<Vec<Input>> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {name}"))?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        bail!("{name}: the file is empty")
    };
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    if cols != ["t", "cmd_left", "cmd_right"] {
        bail!("{name}, line 1: expected the header 't,cmd_left,cmd_right', found '{header}'");
    }
    let mut out = Vec::new();
    let mut t0 = None;
    for (i, line) in lines {
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != 3 {
            bail!(
                "{name}, line {}: {} fields where the header has 3",
                i + 1,
                fields.len()
            );
        }
        let mut v = [0.0; 3];
        for (j, f) in fields.iter().enumerate() {
            let x: f64 = f.trim().parse().map_err(|_| {
                anyhow::anyhow!(
                    "{name}, line {}, column '{}': '{}' is not a number",
                    i + 1,
                    cols[j],
                    f.trim()
                )
            })?;
            if !x.is_finite() {
                bail!(
                    "{name}, line {}, column '{}': '{}' is not a finite number",
                    i + 1,
                    cols[j],
                    f.trim()
                );
            }
            v[j] = x;
        }
        let t0 = *t0.get_or_insert(v[0]);
        let expected = t0 + out.len() as f64 * dt;
        if (v[0] - expected).abs() > 0.5 * dt {
            bail!("{name}, line {}, column 't': t = {} but the model's command period is {dt} s (expected t = {expected})", i + 1, v[0]);
        }
        out.push(Input::new(v[1], v[2]));
    }
    if out.is_empty() {
        bail!("{name}: no command rows");
    }
    Ok(out)
}

fn run_predict(
    model_path: &Path,
    commands: &Path,
    start: Option<[f64; 3]>,
    start_wheels: Option<[f64; 2]>,
) -> Result<()> {
    let name = model_path.display().to_string();
    let text = std::fs::read_to_string(model_path).with_context(|| format!("reading {name}"))?;
    let (model, robot) = model_from_json(&name, &text)?;
    let cmds = read_commands(commands, model.dt())?;
    let pose = start.map_or(Pose::zeros(), |[x, y, yaw]| Pose::new(x, y, yaw));
    let wheels = start_wheels.map_or(Input::zeros(), |[l, r]| Input::new(l, r));
    let start = StartState {
        pose,
        input: wheels,
        body_velocity: DifferentialDrive::from_robot(&robot).eq4(&wheels),
    };
    let (mut poses, mut covs) = (Vec::new(), Vec::new());
    let with_cov = model
        .predict_with_covariance_into(&start, &cmds, &mut poses, &mut covs)
        .is_ok();
    if !with_cov {
        model.predict_into(&start, &cmds, &mut poses);
    }
    let mut out = String::from("k,t,x,y,yaw");
    if with_cov {
        out.push_str(",cov_xx,cov_xy,cov_xyaw,cov_yy,cov_yyaw,cov_yawyaw");
    }
    out.push('\n');
    let rate_hz = 1.0 / model.dt();
    for (k, p) in poses.iter().enumerate() {
        let _ = write!(out, "{k},{},{},{},{}", k as f64 / rate_hz, p.x, p.y, p.z);
        if with_cov {
            let c = &covs[k];
            let _ = write!(
                out,
                ",{},{},{},{},{},{}",
                c[(0, 0)],
                c[(0, 1)],
                c[(0, 2)],
                c[(1, 1)],
                c[(1, 2)],
                c[(2, 2)]
            );
        }
        out.push('\n');
    }
    print!("{out}");
    Ok(())
}
