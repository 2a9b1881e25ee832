//! `drive matrix`: every combination of a sweep file, with a progress bar on a terminal.

use crate::studies::{run_matrix, DatasetSource, MatrixResult, SweepFile};
use crate::Registries;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

#[derive(clap::Args)]
pub struct Args {
    /// The sweep file (TOML).
    #[arg(long)]
    config: PathBuf,
    /// Output folder (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Print the JSON document on stdout instead of the Markdown summary.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    useless: super::common::UselessArg,
}

pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    run_checked(
        &args.config,
        &args.out,
        args.json,
        args.useless.allow_useless,
        registries,
    )
    .map(|_| ())
}

/// Resolves a sweep's dataset: a bundled name, or a file relative to the sweep file.
fn load_source(base: &Path, source: &DatasetSource) -> Result<crate::traits::Dataset, String> {
    if let Some(name) = &source.bundled {
        return crate::bundled::load(name).map_err(|e| e.to_string());
    }
    // The plan checks that exactly one of file and bundled is given.
    let file = source.file.as_ref().ok_or("no file given")?;
    if crate::data::bundled::name_in(file).is_some() {
        // `file = "bundled:NAME"` is no path relative to the sweep file.
        return crate::data::read_dataset(file, source.sidecar.as_deref())
            .map_err(|e| e.to_string());
    }
    let sidecar = source.sidecar.as_ref().map(|s| base.join(s));
    crate::data::read_dataset(&base.join(file), sidecar.as_deref()).map_err(|e| e.to_string())
}

/// Runs `drive matrix` on the sweep file `config` with the parts of `registries`, writing
/// its files into `out`; prints the summary (or the JSON document with `json`).
pub fn run_with(
    config: &Path,
    out: &Path,
    json: bool,
    registries: &Registries,
) -> Result<MatrixResult> {
    run_checked(config, out, json, false, registries)
}

/// [`run_with`], a dataset the data checks call useless refused (naming it and the
/// finding) unless `allow_useless` (`--allow-useless`).
fn run_checked(
    config: &Path,
    out: &Path,
    json: bool,
    allow_useless: bool,
    registries: &Registries,
) -> Result<MatrixResult> {
    let name = config.display().to_string();
    // A sweep file is a page of TOML: a regular file of at most 1 MB.
    let text = crate::traits::files::read_text(config, 1 << 20)
        .with_context(|| format!("reading {name}"))?;
    let mut sweep = SweepFile::parse(&name, &text)?;
    let base = config.parent().unwrap_or(Path::new("."));
    // Robot and terrain files are read relative to the sweep file, as its datasets are
    // (registered names stay names).
    if let Some(sim) = &mut sweep.simulated {
        let relative = |name: &mut String, registered: bool| {
            let path = Path::new(name.as_str());
            if !registered && path.is_relative() && base.join(path).is_file() {
                *name = base.join(path).display().to_string();
            }
        };
        for r in &mut sim.robots {
            let registered = registries.robots.find(r).is_some();
            relative(r, registered);
        }
        for t in &mut sim.terrains {
            let registered = registries.terrains.find(t).is_some();
            relative(t, registered);
        }
    }
    let mut inputs = vec![("--config", config.to_path_buf())];
    // The robot and terrain files the simulated part reads (named as on the command line).
    if let Some(sim) = &sweep.simulated {
        for r in &sim.robots {
            inputs.extend(
                super::common::robot_input(r)
                    .into_iter()
                    .map(|(_, p)| ("a robot of --config", p)),
            );
        }
        for t in &sim.terrains {
            inputs.extend(super::common::terrain_input("a terrain of --config", t));
        }
    }
    let read = Mutex::new(inputs);
    let useless: Mutex<Vec<String>> = Mutex::new(Vec::new());
    let plan = sweep.plan(registries, &|s| {
        if let Some(file) = &s.file {
            let csv = base.join(file);
            let sidecar = s.sidecar.as_ref().map_or_else(
                || crate::data::sidecar_to_read(&csv),
                |side| base.join(side),
            );
            let mut read = read.lock().unwrap_or_else(|p| p.into_inner());
            read.extend([
                ("a dataset of --config", csv),
                ("a sidecar of --config", sidecar),
            ]);
        }
        let data = load_source(base, s)?;
        registries
            .check_vehicle(data.robot.vehicle.as_ref())
            .map_err(|e| format!("the data's vehicle: {e}"))?;
        // The rule of every command that fits and scores: useless data is refused.
        let fatal = crate::data::quality::check(&data, None)
            .into_iter()
            .find(|f| f.severity == crate::data::quality::Severity::Fatal);
        match (allow_useless, fatal) {
            (false, Some(f)) => {
                return Err(format!(
                    "the data checks call it useless: {} ({}; drive check says more; --allow-useless fits and scores on it anyway)",
                    f.message, f.check
                )
                .into());
            }
            // Allowed, and said: its figures are scored on data the checks call useless.
            (true, Some(f)) => {
                super::common::say_finding(&data, &f);
                useless
                    .lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .push(format!(
                        "{}: scored although the data checks call it useless ({}: {}); its figures are not evidence of a model's accuracy",
                        s.label(),
                        f.check,
                        f.message
                    ));
            }
            _ => {}
        }
        Ok(data)
    })?;
    let files = ["matrix.csv", "matrix.json", "summary.md"].map(|f| out.join(f));
    let mut outputs = super::common::outputs_for(
        &read.into_inner().unwrap_or_else(|p| p.into_inner()),
        &[
            ("--out", out),
            ("matrix.csv in --out", &files[0]),
            ("matrix.json in --out", &files[1]),
            ("summary.md in --out", &files[2]),
        ],
    )?;
    let progress = super::common::Progress::new("matrix");
    let mut result = run_matrix(&plan, registries, &|d, t| progress.update(d, t))?;
    result.notes = useless.into_inner().unwrap_or_else(|p| p.into_inner());
    result.notes.extend(few_evaluation(&result));
    for n in &result.notes {
        super::common::note(format!("note: {n}"));
    }
    progress.bar.finish_and_clear();
    let markdown = result.to_markdown();
    outputs.own(out);
    outputs.write(&files[0], result.to_csv())?;
    outputs.write(&files[1], serde_json::to_string_pretty(&result)?)?;
    outputs.write(&files[2], &markdown)?;
    super::common::publish(outputs)?;
    if json {
        outln!("{}", serde_json::to_string(&result)?);
    } else {
        out!("{markdown}");
    }
    let failed = result.cells.iter().filter(|c| c.failure.is_some()).count();
    say!(
        "{} combinations in {:.1} s{}; written to {}/matrix.csv, matrix.json, summary.md",
        result.cells.len(),
        progress.start.elapsed().as_secs_f64(),
        if failed > 0 {
            format!(" ({failed} fits failed, listed in summary.md)")
        } else {
            String::new()
        },
        out.display()
    );
    Ok(result)
}

/// The scenarios whose evaluation intervals (pooled over the seeds, counted on the first
/// model scored there) are too few to be evidence, as `drive eval` and `drive bench` count
/// them.
fn few_evaluation(result: &MatrixResult) -> Vec<String> {
    let evidence = crate::studies::BenchConfig::default().min_evidence_intervals;
    let mut labels: Vec<String> = Vec::new();
    for c in &result.cells {
        let label = c.scenario.label();
        if !labels.contains(&label) {
            labels.push(label);
        }
    }
    labels
        .into_iter()
        .filter_map(|label| {
            let cells: Vec<_> = result
                .cells
                .iter()
                .filter(|c| c.scenario.label() == label && c.failure.is_none())
                .collect();
            let model = &cells.first()?.model;
            let (mut intervals, mut windows) = (0usize, 0usize);
            for c in cells.iter().filter(|c| &c.model == model) {
                let mut seen = c.intervals.clone();
                seen.sort_unstable();
                seen.dedup();
                intervals += seen.len();
                windows += c.eval_windows;
            }
            (intervals < evidence).then(|| {
                format!(
                    "{label}: {windows} evaluation window(s) in {intervals} interval(s): its medians rest on too few to be evidence (drive bench counts a dataset from {evidence} evaluation intervals)"
                )
            })
        })
        .collect()
}
