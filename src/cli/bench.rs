//! `drive bench`: a suite of datasets x models, the transfer between runs of one robot, the
//! terrain's unpredictability and a leaderboard.

use super::common::{emit, outputs_for, PredictionArgs, Progress};
use crate::data::suite::{read_suite, SuiteSource};
use crate::studies::{bench_units, run_bench, BenchConfig, BenchInput};
use crate::Registries;
use anyhow::{bail, Result};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The models of the benchmark by default: the paper's four and slip-ipem.
pub const DEFAULT_MODELS: &str = crate::studies::BENCH_MODELS;

#[derive(clap::Args)]
pub struct Args {
    /// The suite (TOML, one [[dataset]] table per dataset: path, raw or bag; robot, terrain,
    /// name; see docs/benchmark.md); every bundled dataset when absent.
    #[arg(long)]
    suite: Option<PathBuf>,
    /// Models, comma-separated (as drive eval --models).
    #[arg(long, value_delimiter = ',', default_value = DEFAULT_MODELS)]
    models: Vec<String>,
    /// Fraction of each dataset's intervals (in recording order) used for training.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.5)]
    split: f64,
    #[command(flatten)]
    prediction: PredictionArgs,
    /// Skip the transfer between datasets of the same robot.
    #[arg(long)]
    no_transfer: bool,
    /// Rank a dataset the data checks call useless (what `drive check` exits 1 on: a frozen
    /// localization, a dead encoder, ...) instead of skipping it.
    #[arg(long)]
    allow_useless: bool,
    /// Also run the adaptation track: for every ordered pair of runs of one robot, each
    /// model fitted on all of the first adapts to the second as `drive adapt` (its training
    /// half streamed in time order, its evaluation half scored after each of
    /// --adapt-times); the JSON's `adaptation` and the leaderboard's
    /// `adaptive_over_own_60s`. Models that are not composed of a powertrain and a slip
    /// model are listed as skipped.
    #[arg(long)]
    adapt: bool,
    /// With --adapt: also a terrain library for each pair, as `drive adapt --library`: the
    /// prior and the model fitted on each of the robot's other runs (but the target),
    /// blended by their likelihood of the windows driven (`library` in each pair's curves,
    /// `library` in the summary; a robot with a third run only).
    #[arg(long, requires = "adapt")]
    adapt_library: bool,
    /// The adaptation track's times, s of each target's training half, comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0,15,30,60,120,240",
        allow_hyphen_values = true,
        requires = "adapt"
    )]
    adapt_times: Vec<f64>,
    /// Print one JSON object on stdout instead of the tables.
    #[arg(long)]
    json: bool,
    /// Also write DIR/bench.md, DIR/bench.html (self-contained, figures embedded),
    /// DIR/datasets.csv, DIR/transfer.csv, DIR/leaderboard.csv, DIR/windows.csv and
    /// DIR/bench.json.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// The files of `--out`.
const FILES: [&str; 7] = [
    "bench.md",
    "bench.html",
    "datasets.csv",
    "transfer.csv",
    "leaderboard.csv",
    "windows.csv",
    "bench.json",
];

/// The file of `--out` the adaptation track adds (`--adapt`).
const ADAPT_FILE: &str = "adapt.csv";

pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    let entries = match &args.suite {
        Some(path) => Some(read_suite(path)?),
        None => None,
    };
    // Inputs: the suite and every file it reads.
    let mut inputs: Vec<(&'static str, PathBuf)> = Vec::new();
    if let Some(path) = &args.suite {
        inputs.push(("--suite", path.clone()));
    }
    for e in entries.iter().flatten() {
        match &e.source {
            SuiteSource::Windows { csv, sidecar } => {
                if crate::data::bundled::name_in(csv).is_none() {
                    inputs.push(("a dataset of --suite", csv.clone()));
                    inputs.push((
                        "a sidecar of --suite",
                        sidecar
                            .clone()
                            .unwrap_or_else(|| crate::data::sidecar_to_read(csv)),
                    ));
                }
            }
            SuiteSource::Raw(p) => inputs.push(("a raw log of --suite", p.clone())),
            SuiteSource::Bag { path, .. } => {
                inputs.extend(super::common::bag_inputs("a bag of --suite", path))
            }
        }
        if let Some(r) = &e.robot {
            inputs.extend(super::common::robot_input(r));
        }
    }
    let files: Vec<PathBuf> = args
        .out
        .iter()
        .flat_map(|dir| {
            FILES
                .iter()
                .chain(args.adapt.then_some(&ADAPT_FILE))
                .map(move |f| dir.join(f))
        })
        .collect();
    let mut planned: Vec<(&str, &Path)> = Vec::new();
    if let Some(dir) = &args.out {
        planned.push(("--out", dir.as_path()));
        planned.extend(files.iter().map(|f| ("a file of --out", f.as_path())));
    }
    let mut outputs = outputs_for(&inputs, &planned)?;
    let specs = args
        .prediction
        .apply(super::eval::specs(registries, &args.models, None)?)?;
    if !(args.split > 0.0 && args.split < 1.0) {
        bail!("--split {} must lie strictly between 0 and 1", args.split);
    }
    // A dataset that cannot be read or imported is skipped and named, the others go on.
    let (datasets, unloaded): (Vec<BenchInput>, Vec<crate::studies::SkippedDataset>) =
        match &entries {
            Some(e) => crate::suite::load_skipping(registries, e)?,
            None => (crate::suite::bundled(registries)?, Vec::new()),
        };
    crate::traits::limits::at_most("--adapt-times", args.adapt_times.len() as f64, 100.0, "")?;
    if let Some(t) = args
        .adapt_times
        .iter()
        .find(|t| !(t.is_finite() && **t >= 0.0))
    {
        bail!("--adapt-times are seconds from 0 on, got {t}");
    }
    let config = BenchConfig {
        split: args.split,
        transfer: !args.no_transfer,
        allow_useless: args.allow_useless,
        adapt: args.adapt.then(|| crate::studies::AdaptStudy {
            split: args.split,
            times_s: args.adapt_times.clone(),
            ..Default::default()
        }),
        adapt_library: args.adapt_library,
        ..BenchConfig::default()
    };
    let progress = Progress::new("bench");
    let total = bench_units(&datasets, specs.len(), &config);
    let done = AtomicUsize::new(0);
    let mut bench = run_bench(&datasets, &specs, &config, &|| {
        progress.update(done.fetch_add(1, Ordering::Relaxed) + 1, total)
    })
    .map_err(|e| match (&e, unloaded.is_empty()) {
        (crate::studies::BenchError::AllSkipped(_), false) => anyhow::anyhow!(
            "{e}; and unread: {}",
            crate::studies::SkippedDataset::listed(&unloaded)
        ),
        _ => e.into(),
    })?;
    bench.skipped.extend(unloaded);
    progress.bar.finish_and_clear();
    if let Some(dir) = &args.out {
        let written = crate::report::bench::files(&bench)?;
        outputs.own(dir);
        for (name, content) in written {
            outputs.write(&dir.join(name), content)?;
        }
    }
    // The standard output first: a command that cannot write it fails with nothing new
    // published.
    let transfer = config.transfer;
    emit(args.json, &bench, |b| {
        crate::report::bench::text(b, transfer)
    })?;
    if let Some(dir) = &args.out {
        super::common::publish(outputs)?;
        say!(
            "{} datasets x {} models in {:.1} s; written to {}/ ({})",
            bench.datasets.len(),
            bench.model_names.len(),
            progress.start.elapsed().as_secs_f64(),
            dir.display(),
            FILES
                .iter()
                .chain(bench.adaptation.is_some().then_some(&ADAPT_FILE))
                .copied()
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(())
}
