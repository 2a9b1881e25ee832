//! What the commands share: the data arguments, the argument parser, number parsing and
//! output as JSON or text.

use crate::data::output::Outputs;
use crate::data::{read_dataset, DataError};
use crate::traits::Dataset;
use anyhow::Result;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::ffi::OsString;
use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// A dataset to work on.
#[derive(clap::Args)]
pub struct DataArgs {
    /// Window CSV (format: docs/data-format.md), or a bundled dataset as
    /// bundled:NAME (see drive list); the bundled Husky dataset when absent.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Sidecar JSON of the window CSV; by default beside it, `run.csv` -> `run.meta.json`
    /// (or the older `run.json`).
    #[arg(long, requires = "data")]
    pub sidecar: Option<PathBuf>,
    /// Positions as the data has them (as-published), or, when the sidecar declares the
    /// paper parser's frame (position_frame "paper-mean5"), rotated into each window's
    /// first-sample frame like its yaw (corrected).
    #[arg(long, default_value = "as-published", value_parser = ["as-published", "corrected"])]
    pub frame: String,
}

/// Whether a command fits and scores on data the data checks call useless.
#[derive(clap::Args)]
pub struct UselessArg {
    /// Fit and score on data the data checks call useless (what `drive check` exits 1 on: a
    /// frozen localization, a dead encoder, encoders in another unit, ...) instead of
    /// refusing it.
    #[arg(long)]
    pub allow_useless: bool,
}

/// Refuses `data` (named `name`) when the data checks call it useless (their first fatal
/// finding, named), unless `allow`; says the findings on stderr once ([`note_quality`]'s
/// lines): every one when allowed, the warnings also when `with_warnings`. Returns the fatal
/// findings let through (`check: message`), for an output that records them.
pub fn refuse_useless(
    data: &Dataset,
    name: &str,
    allow: bool,
    with_warnings: bool,
) -> Result<Vec<String>> {
    let findings = crate::data::quality::check(data, None);
    let fatal =
        |f: &&crate::data::quality::Finding| f.severity == crate::data::quality::Severity::Fatal;
    if let (false, Some(f)) = (allow, findings.iter().find(fatal)) {
        anyhow::bail!(
            "{name}: the data checks call it useless: {} ({}; drive check says more; --allow-useless fits and scores on it anyway)",
            f.message,
            f.check
        );
    }
    for f in findings
        .iter()
        .filter(|f| allow || with_warnings && !fatal(f))
    {
        say_finding(data, f);
    }
    Ok(findings
        .iter()
        .filter(fatal)
        .map(|f| format!("{}: {}", f.check, f.message))
        .collect())
}

/// The name of the data `args` loads, for messages.
pub fn data_name(args: &DataArgs) -> String {
    args.data
        .as_ref()
        .map_or(crate::bundled::HUSKY_CSV_NAME.to_string(), |p| {
            p.display().to_string()
        })
}

/// The models a command compares.
#[derive(clap::Args)]
pub struct ModelsArg {
    /// Models, comma-separated: the paper's names (naive, powertrain, slip-blr, acc-blr),
    /// LEARNER+POWERTRAIN (slip-blr+rate-limited), or all (every registered combination);
    /// see drive list.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = crate::studies::PAPER_MODELS
    )]
    pub models: Vec<String>,
}

/// How the models' predictions start and how their uncertainty is made.
#[derive(clap::Args)]
pub struct PredictionArgs {
    /// What every model's predictions start from: the encoders only (the body velocity is
    /// eq. 4 on the measured wheels), the encoders and the IMU's yaw rate, or these and the
    /// localization's velocity over the half second before the window (when the preceding
    /// window runs on into it). Models whose state is a velocity (acc-blr, slip-ipem) read
    /// them; the paper's others start from the encoders whatever this says.
    #[arg(long, default_value = "encoders+imu", value_parser = crate::traits::StartInfo::NAMES)]
    pub start: String,
    /// Pose covariance: calibrated (the model's own, scaled per horizon step and by a
    /// learned difficulty of each prediction, by cross-conformal calibration on two halves
    /// of the training intervals), horizon (the same without the difficulty: one size per
    /// step) or paper (eq. 7 propagated, as published).
    #[arg(long, default_value = "calibrated", value_parser = crate::models::calibration::Uncertainty::NAMES)]
    pub uncertainty: String,
}

impl PredictionArgs {
    /// The start information asked for.
    pub fn start(&self) -> Result<crate::traits::StartInfo> {
        crate::traits::StartInfo::parse(&self.start).map_err(anyhow::Error::msg)
    }

    /// The uncertainty method asked for.
    pub fn uncertainty(&self) -> Result<crate::models::calibration::Uncertainty> {
        crate::models::calibration::Uncertainty::parse(&self.uncertainty)
            .map_err(anyhow::Error::msg)
    }

    /// `specs` with the start information and the uncertainty method asked for.
    pub fn apply(
        &self,
        specs: Vec<crate::models::ModelSpec>,
    ) -> Result<Vec<crate::models::ModelSpec>> {
        let (start, uncertainty) = (self.start()?, self.uncertainty()?);
        Ok(specs
            .into_iter()
            .map(|s| s.with_uncertainty(uncertainty, start))
            .collect())
    }
}

impl DataArgs {
    /// The files these arguments read (the CSV and its sidecar), for [`outputs_for`].
    pub fn inputs(&self) -> Vec<(&'static str, PathBuf)> {
        match &self.data {
            None => Vec::new(),
            // A bundled dataset is no file.
            Some(csv) if crate::data::bundled::name_in(csv).is_some() => Vec::new(),
            Some(csv) => vec![
                ("--data", csv.clone()),
                (
                    if self.sidecar.is_some() {
                        "--sidecar"
                    } else {
                        "sidecar of --data"
                    },
                    self.sidecar
                        .clone()
                        .unwrap_or_else(|| crate::data::sidecar_to_read(csv)),
                ),
            ],
        }
    }
}

/// The files a bag reads, as inputs named `what`: the recording, its .mcap files and, for a
/// bag directory, its metadata.yaml (an output inside it must not replace them).
pub fn bag_inputs(what: &'static str, bag: &Path) -> Vec<(&'static str, PathBuf)> {
    let mut inputs = vec![(what, bag.to_path_buf())];
    if let Ok(files) = crate::data::bag_files(bag) {
        inputs.extend(files.into_iter().map(|f| (what, f)));
    }
    if bag.is_dir() {
        inputs.push((what, bag.join("metadata.yaml")));
    }
    inputs
}

/// The robot file a `--robot` argument reads, if it names one (see `RobotSpec::load`).
pub fn robot_input(name_or_path: &str) -> Vec<(&'static str, PathBuf)> {
    crate::samplers::RobotSpec::file_of(name_or_path)
        .map(|p| ("--robot", p.to_path_buf()))
        .into_iter()
        .collect()
}

/// The terrain file a `--terrain` argument (or a sweep's terrain) reads, if it names one: a
/// `.toml` name or an existing file (see `Terrain::load`), as the input `what`.
pub fn terrain_input(what: &'static str, name_or_path: &str) -> Vec<(&'static str, PathBuf)> {
    let path = Path::new(name_or_path);
    (name_or_path.ends_with(".toml") || path.is_file())
        .then(|| (what, path.to_path_buf()))
        .into_iter()
        .collect()
}

/// The robot of the dataset `args` names, for its body (the terrain's unpredictability):
/// `explicit` (`--robot`) when given, the robot a bundled dataset was recorded with, else
/// the registered robot recognised in the sidecar's robot text.
pub fn robot_of(
    registries: &crate::Registries,
    args: &DataArgs,
    explicit: Option<&str>,
    data: &Dataset,
) -> Result<crate::suite::RobotOf> {
    let bundled = match &args.data {
        None => Some("husky".to_string()),
        Some(p) => crate::data::bundled::name_in(p)
            .and_then(crate::bundled::find)
            .map(|b| b.robot.to_string()),
    };
    let explicit = explicit.map(str::to_string).or(bundled);
    Ok(crate::suite::robot_of(
        registries,
        data,
        explicit.as_deref(),
    )?)
}

/// `Err` when `--max-samples` is beyond the ceiling it may be raised to.
pub fn check_max_samples(max_samples: usize) -> Result<()> {
    crate::traits::limits::at_most(
        "--max-samples",
        max_samples as f64,
        crate::traits::limits::MAX_RUN_SAMPLES_CEILING as f64,
        "",
    )?;
    Ok(())
}

/// The standard streams the shell redirected to a regular file (`> file`, `2> file`): the
/// stream's name and the file's metadata.
#[cfg(unix)]
fn streams_in_files() -> Vec<(&'static str, std::fs::Metadata)> {
    [
        ("standard output", "/dev/stdout"),
        ("standard error", "/dev/stderr"),
    ]
    .into_iter()
    .filter_map(|(stream, device)| Some((stream, std::fs::metadata(device).ok()?)))
    .filter(|(_, m)| m.is_file())
    .collect()
}

/// Whether `path` is where the standard output goes, whatever it is (a file, a pipe, a
/// terminal; `/dev/stdout`, `/proc/self/fd/1` or the file's own name): by device and inode.
pub fn is_standard_output(path: &Path) -> bool {
    #[cfg(unix)]
    {
        std::fs::metadata("/dev/stdout").is_ok_and(|out| is_stream_file(&out, path))
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        false
    }
}

/// Whether `path` is the file `stream` writes to (by device and inode, so that a link or
/// another path to the same file counts).
#[cfg(unix)]
fn is_stream_file(stream: &std::fs::Metadata, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt as _;
    std::fs::metadata(path).is_ok_and(|m| m.dev() == stream.dev() && m.ino() == stream.ino())
}

/// `Err` when the standard output or error is one of `inputs` (`drive eval --data run.csv
/// --json > run.meta.json`): the shell emptied that file before the command started, and
/// its reader would only say it is empty. The standard error too (`2> run.meta.json`): the
/// message then lands in that file, which at least says what happened to it.
pub fn stdout_not_an_input(inputs: &[(&'static str, PathBuf)]) -> Result<()> {
    streams_not_inputs(inputs)
}

/// Flags whose value is a file the command writes: its own check names a redirection onto
/// them (see [`outputs_for`]).
const OUTPUT_FLAGS: &[&str] = &["--out", "--raw-out", "--per-window"];

/// `Err` when the standard output or error is a file named on the command line `args`
/// (the command's name first, then its arguments) as an input, or the sidecar of a window
/// CSV named there: checked before any command parses a file, so that `drive adapt --prior
/// m.json > m.json` says the shell emptied the model file rather than that its JSON ends
/// early, and `drive converge --data d.csv >> d.meta.json` is refused before the sidecar is
/// appended to. Each command checks the files its inputs name in turn (a suite's datasets).
pub fn streams_not_named_inputs(args: &[OsString]) -> Result<()> {
    let mut named: Vec<(String, PathBuf)> = Vec::new();
    let mut flag: Option<String> = None;
    // A sidecar named by its own flag is that flag's file, not the one beside the CSV.
    let sidecar_named = args.iter().any(|a| {
        let a = a.to_string_lossy();
        a.starts_with("--") && a.contains("sidecar")
    });
    // The program and the command's name.
    for arg in args.iter().skip(2) {
        let text = arg.to_string_lossy();
        let (role, value) = match text.split_once('=') {
            Some((f, v)) if f.starts_with("--") => (Some(f.to_string()), OsString::from(v)),
            _ if text.starts_with("--") => {
                flag = Some(text.into_owned());
                continue;
            }
            _ => (flag.take(), arg.clone()),
        };
        if role.as_deref().is_some_and(|f| OUTPUT_FLAGS.contains(&f)) {
            continue;
        }
        let path = PathBuf::from(value);
        // `/dev/stdout` named as a file is the stream itself, never emptied by it.
        if path.starts_with("/dev") || path.starts_with("/proc") || !path.is_file() {
            continue;
        }
        let role = role.unwrap_or_else(|| "argument".to_string());
        if !sidecar_named
            && path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("csv"))
        {
            named.push((
                format!("sidecar of {role}"),
                crate::data::sidecar_to_read(&path),
            ));
        }
        named.push((role, path));
    }
    streams_not_inputs(&named)
}

/// A standard stream redirected onto an input: the message, and where it may be said
/// without writing into that input (`2>> run.meta.json`: the refusal must not land on the
/// end of the file it protects).
#[derive(Debug)]
pub struct StreamOntoInput {
    /// What to say.
    pub message: String,
    /// The standard error appends to an input: say nothing there.
    pub stderr_appends_to_input: bool,
    /// The standard output is an input (emptied or appended to): say nothing there either.
    pub stdout_is_input: bool,
}

impl std::fmt::Display for StreamOntoInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for StreamOntoInput {}

/// `Err` ([`StreamOntoInput`]) when the standard output or error is one of `inputs` (role,
/// path).
fn streams_not_inputs<R: std::fmt::Display>(inputs: &[(R, PathBuf)]) -> Result<()> {
    #[cfg(unix)]
    {
        let streams = streams_in_files();
        let onto = |name: &str| {
            streams
                .iter()
                .filter(|(stream, _)| *stream == name)
                .find_map(|(_, out)| {
                    inputs
                        .iter()
                        .find(|(_, p)| is_stream_file(out, p))
                        .map(|input| (out.len(), input))
                })
        };
        let (stdout, stderr) = (onto("standard output"), onto("standard error"));
        for (stream, hit) in [("standard output", stdout), ("standard error", stderr)] {
            if let Some((len, (role, path))) = hit {
                // `>` empties the file before drive starts; `>>` would write onto its end.
                let what = if len == 0 {
                    "the shell emptied it before drive started (its content is gone: restore it, or re-create it with the command that wrote it)"
                } else {
                    "the output would be written onto its end"
                };
                return Err(StreamOntoInput {
                    message: format!(
                        "the {stream} is {}, the input {role}: {what}; redirect the output to another file",
                        path.display()
                    ),
                    stderr_appends_to_input: stderr.is_some_and(|(len, _)| len > 0),
                    stdout_is_input: stdout.is_some(),
                }
                .into());
            }
        }
    }
    #[cfg(not(unix))]
    let _ = inputs;
    Ok(())
}

/// A window CSV (or raw log) to be written at `path` for `flag`: refused where its name says
/// it is another kind of file (`run.json`, `run.meta.json`, a robot or terrain `.toml`, an
/// array: [`crate::data::output_names::NOT_CSV_NAMES`]): the CSV would be written under that
/// name without a word, and a `--out pair.meta.json` would replace the sidecar of the
/// dataset `pair.csv`; where its sidecar's path is a device or a pipe (a link to
/// `/dev/null`, a FIFO that would hang the write); and, for a CSV that is not a dataset
/// (`dataset` false: a raw log, a per-window table, a schedule), over an existing dataset's
/// CSV (its sidecar would be left describing something else).
pub fn csv_output_name(flag: &str, path: &std::path::Path) -> Result<()> {
    csv_output(flag, path, "a window CSV (uncompressed)", true)
}

/// [`csv_output_name`] for a CSV of `kind`, a dataset or not.
pub fn csv_output(flag: &str, path: &std::path::Path, kind: &str, dataset: bool) -> Result<()> {
    if dataset {
        let sidecar = crate::data::sidecar_path(path);
        if crate::data::output::is_special(&sidecar) {
            anyhow::bail!(
                "{flag} {}: its sidecar {} is a device, a pipe or a standard stream: the dataset could not be read back (a dataset is a CSV with its sidecar JSON beside it)",
                path.display(),
                sidecar.display()
            );
        }
    }
    crate::data::output_names::refused_name(
        path,
        kind,
        crate::data::output_names::NOT_CSV_NAMES,
        dataset,
    )
    .map_err(|e| match e {
        crate::data::output_names::NameError::OtherKind { path, kind, ending } => anyhow::anyhow!(
            "{flag} {path}: {kind} is written there, and the name says {ending}: name it .csv{}",
            if dataset {
                " (its sidecar is written beside it as .meta.json)"
            } else {
                ""
            }
        ),
        e => anyhow::anyhow!("{flag} {e}"),
    })
}

/// A file of `kind` (`a model file (JSON)`, `a twin (TOML)`) to be written at `path` for
/// `flag`: refused where its name says it is a dataset, a dataset's sidecar, a recording or
/// an array ([`DATA_NAMES`]) or another of the kinds `others` names, or where it is a
/// dataset's sidecar by the name of earlier releases (`run.json` beside `run.csv`), or an
/// existing dataset's CSV: `train --out run.csv` replaced the dataset `run.csv` (its sidecar
/// left beside a model file), and `--out run.meta.json` the sidecar of `run.csv`, without a
/// word, as [`csv_output_name`] refuses the other way round.
pub fn named_output(flag: &str, path: &std::path::Path, kind: &str, others: &[&str]) -> Result<()> {
    named_other_than(flag, path, kind, &[DATA_NAMES, others].concat())
}

/// The names of datasets, their sidecars and recordings, and of the array and table files
/// a researcher keeps data in (`train --out model.npy` wrote JSON under the name of a numpy
/// array; [`named_output`]).
pub const DATA_NAMES: &[&str] = crate::data::output_names::DATA_NAMES;

/// `Err` where the name of `path` (written for `flag`, a file of `kind`, not a dataset) ends
/// in one of `refused` (case aside), or is a dataset's sidecar or CSV
/// ([`crate::data::output_names::refused_name`]).
pub fn named_other_than(
    flag: &str,
    path: &std::path::Path,
    kind: &str,
    refused: &[&str],
) -> Result<()> {
    crate::data::output_names::refused_name(path, kind, refused, false)
        .map_err(|e| anyhow::anyhow!("{flag} {e}"))
}

/// Staged outputs of a command that reads `inputs`, checked up front against `planned`
/// (flag, path): an output never replaces an input or another output, and the files
/// appear together when the command succeeds (see `drive_data::output`).
pub fn outputs_for(
    inputs: &[(&'static str, PathBuf)],
    planned: &[(&str, &Path)],
) -> Result<Outputs> {
    stdout_not_an_input(inputs)?;
    stdout_not_an_output(planned)?;
    let inputs: Vec<(&str, &Path)> = inputs.iter().map(|(r, p)| (*r, p.as_path())).collect();
    let outputs = Outputs::new(&inputs);
    outputs.check(planned)?;
    // A directory of outputs (one whose files are planned too) under a file's name
    // (`bench --out results.csv` made a directory of that name).
    for (flag, dir) in planned {
        if planned.iter().any(|(_, f)| f.parent() == Some(*dir)) {
            let name = dir
                .file_name()
                .map(|n| n.to_string_lossy().to_ascii_lowercase())
                .unwrap_or_default();
            let endings = [DATA_NAMES, crate::data::output_names::NOT_CSV_NAMES].concat();
            if let Some(ending) = endings.iter().find(|e| name.ends_with(*e)) {
                anyhow::bail!(
                    "{flag} {}: a directory of outputs is written there, and the name says {ending}: name it for what it is (a folder)",
                    dir.display()
                );
            }
        }
    }
    Ok(outputs)
}

/// `Err` when the standard output is a file the command is about to replace (`drive import
/// ... --out run.csv --json > run.csv`): the output would be renamed over it and the
/// printed report lost without a word.
fn stdout_not_an_output(planned: &[(&str, &Path)]) -> Result<()> {
    #[cfg(unix)]
    for (_, out) in streams_in_files()
        .into_iter()
        .filter(|(stream, _)| *stream == "standard output")
    {
        // `--per-window /dev/stdout` is written into, never renamed over: no loss.
        let replaced = planned.iter().find(|(_, p)| {
            !(p.starts_with("/dev") || p.starts_with("/proc")) && is_stream_file(&out, p)
        });
        if let Some((role, path)) = replaced {
            anyhow::bail!(
                "the standard output is {}, the output {role}: what is printed would be replaced by that file; redirect the output to another file",
                path.display()
            );
        }
    }
    #[cfg(not(unix))]
    let _ = planned;
    Ok(())
}

/// Loads the dataset the arguments name (the bundled Husky data by default), with its
/// positions in the frame `--frame` asks for; a dataset in the paper parser's frame is
/// noted (one line on stderr, see [`note`]). `Err` also for data of a vehicle that is not
/// registered in `registries` (no part is used unregistered).
pub fn load(registries: &crate::Registries, args: &DataArgs) -> Result<Dataset> {
    let data = load_unchecked(args)?;
    registries
        .check_vehicle(data.robot.vehicle.as_ref())
        .map_err(|e| anyhow::anyhow!("{}: the data's vehicle: {e}", data_name(args)))?;
    Ok(data)
}

/// Says on stderr what the data checks (`drive check`) find in `data`: a command fits and
/// scores on such data, and its figures carry what a warning says (an IMU that never
/// changes, encoders outside their limits, ...); a fatal finding (a frozen localization, a
/// dead encoder) is said too with `with_fatal`, as what to look at first when the command
/// then fails on a consequence of it (a command that refuses such data itself leaves it).
pub fn note_quality(data: &Dataset, with_fatal: bool) {
    for f in crate::data::quality::check(data, None)
        .into_iter()
        .filter(|f| with_fatal || f.severity == crate::data::quality::Severity::Warning)
    {
        say_finding(data, &f);
    }
}

/// One finding of the data checks on stderr, as a note.
pub fn say_finding(data: &Dataset, f: &crate::data::quality::Finding) {
    let fatal = if f.severity == crate::data::quality::Severity::Fatal {
        ", which drive check calls fatal"
    } else {
        ""
    };
    say!(
        "note: {}: {} ({}{fatal}; drive check says more)",
        data.robot.name,
        f.message,
        f.check
    );
}

/// [`load`] without the registry check.
fn load_unchecked(args: &DataArgs) -> Result<Dataset, DataError> {
    let mut data = match &args.data {
        Some(csv) => {
            let data = read_dataset(csv, args.sidecar.as_deref())?;
            note_legacy_sidecar(csv, args.sidecar.as_deref());
            data
        }
        None => crate::bundled::husky()?,
    };
    if data.robot.position_frame == crate::traits::PositionFrame::PaperMean5 {
        let name = match &args.data {
            Some(csv) => csv.display().to_string(),
            None => crate::bundled::HUSKY_CSV_NAME.to_string(),
        };
        if args.frame == "corrected" {
            data.to_first_sample_frame();
            note(format!("note: {name}: positions rotated from the paper parser's frame (mean orientation of each window's first 5 samples) into the first sample's, like yaw (--frame corrected)"));
        } else {
            note(format!("note: {name}: positions are in the paper parser's frame (mean orientation of each window's first 5 samples; yaw is relative to the first sample), as published; --frame corrected rotates them"));
        }
    }
    Ok(data)
}

/// Notes that the sidecar of `csv` was read from the earlier releases' name (`run.json`, see
/// `drive_data::legacy_sidecar_path`) when none was given.
pub fn note_legacy_sidecar(csv: &Path, given: Option<&Path>) {
    if given.is_none()
        && crate::data::bundled::name_in(csv).is_none()
        && crate::data::sidecar_to_read(csv) == crate::data::legacy_sidecar_path(csv)
    {
        note(format!(
            "note: read the sidecar of {} from {}, its name in earlier releases; it is now written as {} (rename it so that a command's JSON output redirected to {} cannot replace it)",
            csv.display(),
            crate::data::legacy_sidecar_path(csv).display(),
            crate::data::sidecar_path(csv).display(),
            crate::data::legacy_sidecar_path(csv).display(),
        ));
    }
}

thread_local! {
    /// The host's observer of the command running on this thread ([`super::run_status_observed`]).
    static OBSERVER: std::cell::RefCell<Option<std::sync::Arc<dyn super::RunObserver>>> =
        const { std::cell::RefCell::new(None) };
}

/// The observer of the command running on this thread, for as long as it lives.
pub struct Observing;

impl Observing {
    /// Makes `observer` the observer of this thread's commands until dropped.
    pub fn new(observer: std::sync::Arc<dyn super::RunObserver>) -> Self {
        OBSERVER.with(|o| *o.borrow_mut() = Some(observer));
        Observing
    }
}

impl Drop for Observing {
    fn drop(&mut self) {
        OBSERVER.with(|o| *o.borrow_mut() = None);
    }
}

/// The running command's progress callback: `progress(total)` as each of its units of work
/// ends (nothing without a host's observer). Taken on the command's thread; called from any.
pub fn progress() -> impl Fn(usize) + Sync {
    let observer = OBSERVER.with(|o| o.borrow().clone());
    move |total| {
        if let Some(o) = &observer {
            o.unit_done(total);
        }
    }
}

/// Publishes the command's staged outputs, after the host's observer (if any) has had its
/// say: an interrupted host stops the command there, and nothing is written.
pub fn publish(outputs: Outputs) -> Result<Vec<PathBuf>> {
    if let Some(o) = OBSERVER.with(|o| o.borrow().clone()) {
        o.before_publish();
    }
    Ok(outputs.publish()?)
}

/// Notes of the running command, printed on stderr when it succeeds (a failed command's
/// stderr is its one-line error).
static NOTES: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());

/// Adds a note (one line) for the end of the running command.
pub fn note(line: String) {
    NOTES
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .push(line);
}

/// A note when a study's figures rest on fewer evaluation intervals than `drive bench`
/// counts a dataset from (as `drive eval` says it): `intervals`, or else the windows
/// (three a DRIVE interval).
pub fn note_few_evaluation(intervals: Option<usize>, windows: usize) {
    let evidence = crate::studies::BenchConfig::default().min_evidence_intervals;
    let few = match intervals {
        Some(n) => n < evidence,
        None => windows < 3 * evidence,
    };
    if few {
        note(format!(
            "note: {} evaluation window(s){}: the medians rest on too few to be evidence (drive bench counts a dataset from {evidence} evaluation intervals)",
            windows,
            intervals.map_or(String::new(), |n| format!(" in {n} interval(s)"))
        ));
    }
}

/// Takes the notes of the running command.
pub fn take_notes() -> Vec<String> {
    std::mem::take(
        &mut *NOTES
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner),
    )
}

/// Whether `c` may not reach a terminal raw: a control character other than a line break
/// or a tab, or an invisible formatting character (zero-width, bidirectional override).
fn hidden(c: char) -> bool {
    (c.is_control() && c != '\n' && c != '\t')
        || matches!(c, '\u{200b}'..='\u{200f}' | '\u{2028}'..='\u{202e}' | '\u{2060}'..='\u{2069}' | '\u{feff}')
}

/// `text` as it may reach a terminal: control characters other than line breaks and tabs
/// (an escape sequence in a data file's cell, a path or a flag's value would recolour or
/// rewrite the user's terminal) and the invisible Unicode formatting characters (zero-width
/// characters, bidirectional overrides, which reorder what is shown) written as `\u{..}`
/// escapes. Error messages and notes quote what the user gave.
pub fn printable(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(hidden) {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if hidden(c) {
            out.push_str(&format!("\\u{{{:x}}}", c as u32));
        } else {
            out.push(c);
        }
    }
    std::borrow::Cow::Owned(out)
}

/// Parses the command line; an argument error is reported on one line (clap's own message
/// without the usage block), help and version are printed as usual.
pub fn parse<C, I, T>(args: I) -> Result<C, u8>
where
    C: clap::Parser,
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    use clap::error::ErrorKind;
    C::try_parse_from(args).map_err(|e| {
        if matches!(
            e.kind(),
            ErrorKind::DisplayHelp
                | ErrorKind::DisplayVersion
                | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
        ) {
            // Help that could not be written (`--help > /dev/full`) is a failure.
            if e.print().is_err() {
                return 1;
            }
            return if e.exit_code() == 0 { 0 } else { 2 };
        }
        let text = e.render().to_string();
        let message: Vec<&str> = text
            .lines()
            .map(str::trim)
            .take_while(|l| !l.starts_with("Usage:") && !l.starts_with("For more information"))
            .filter(|l| !l.is_empty())
            .collect();
        say!("{} (see drive --help)", printable(&message.join(" ")));
        2
    })
}

/// A command-line value that is not the numbers its flag takes.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct BadNumbers(pub String);

/// `N` comma-separated finite numbers.
pub fn parse_numbers<const N: usize>(s: &str) -> Result<[f64; N], BadNumbers> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != N {
        return Err(BadNumbers(format!(
            "expected {N} comma-separated numbers, got '{s}'"
        )));
    }
    let mut out = [0.0; N];
    for (o, p) in out.iter_mut().zip(parts) {
        *o = p
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| BadNumbers(format!("'{p}' is not a finite number")))?;
    }
    Ok(out)
}

/// One finite number.
pub fn parse_number(s: &str) -> Result<f64, BadNumbers> {
    s.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| BadNumbers(format!("'{s}' is not a finite number")))
}

/// Two comma-separated numbers.
pub fn parse_pair(s: &str) -> Result<[f64; 2], BadNumbers> {
    parse_numbers::<2>(s)
}

/// One number per input axis, as given on the command line (the vehicle checks how many).
#[derive(Debug, Clone, PartialEq)]
pub struct AxisValues(pub Vec<f64>);

impl AxisValues {
    /// The input, when there is one number per axis of a vehicle of `dim` axes.
    pub fn input(&self, flag: &str, dim: usize) -> anyhow::Result<crate::traits::Input> {
        if self.0.len() != dim {
            anyhow::bail!(
                "{flag} gives {} numbers; the vehicle has {dim} input axes",
                self.0.len()
            );
        }
        let mut u = crate::traits::Input::zeros();
        for (i, v) in self.0.iter().enumerate() {
            u[i] = *v;
        }
        Ok(u)
    }
}

/// Two or three comma-separated numbers: one per input axis.
pub fn parse_axes(s: &str) -> Result<AxisValues, BadNumbers> {
    let parts: Vec<&str> = s.split(',').collect();
    if !(2..=crate::traits::MAX_INPUTS).contains(&parts.len()) {
        return Err(BadNumbers(format!(
            "expected one number per input axis (2 or 3, comma-separated), got '{s}'"
        )));
    }
    parts
        .iter()
        .map(|p| parse_number(p))
        .collect::<Result<_, _>>()
        .map(AxisValues)
}

/// Three comma-separated numbers.
pub fn parse_triplet(s: &str) -> Result<[f64; 3], BadNumbers> {
    parse_numbers::<3>(s)
}

/// The names of a comma-separated list, trimmed, empty ones dropped.
pub fn names(list: &[String]) -> Vec<&str> {
    list.iter()
        .map(|s| s.trim())
        .filter(|s| !s.is_empty())
        .collect()
}

/// The model names `--models` gives (see [`names`]: trimmed, empty entries dropped), `Err`
/// when none is left (`--models ''` or `--models ,`): a command never runs on no model and
/// writes an empty comparison.
pub fn model_names(registries: &crate::Registries, list: &[String]) -> Result<Vec<String>> {
    let given: Vec<String> = names(list).into_iter().map(String::from).collect();
    if given.is_empty() {
        anyhow::bail!(
            "--models is empty (the models are: {})",
            registries.catalog().models.join(", ")
        );
    }
    Ok(given)
}

/// Standard output was closed by its reader (a pipe into `head`).
#[derive(Debug)]
pub struct ClosedPipe;

impl std::fmt::Display for ClosedPipe {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("standard output closed")
    }
}

impl std::error::Error for ClosedPipe {}

/// Writes to standard output; a closed pipe is [`ClosedPipe`] (the command then ends
/// quietly), another failure an error that says so.
pub fn write_out(args: std::fmt::Arguments<'_>) -> Result<()> {
    use std::io::Write as _;
    // A control or invisible formatting character from the data (a cell, a name) never
    // reaches the terminal raw: written as JSON's own escape (`\u202e`), so that a JSON
    // text keeps its meaning (serde_json writes no raw control character, and the others
    // decode back to themselves).
    let text = args.to_string();
    let text = if text.chars().any(hidden) {
        std::borrow::Cow::Owned(
            text.chars()
                .map(|c| {
                    if hidden(c) {
                        format!("\\u{:04x}", c as u32)
                    } else {
                        c.to_string()
                    }
                })
                .collect(),
        )
    } else {
        std::borrow::Cow::Borrowed(text.as_str())
    };
    let mut stdout = std::io::stdout().lock();
    match stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
    {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Err(ClosedPipe.into()),
        Err(e) => Err(anyhow::anyhow!("cannot write to standard output: {e}")),
    }
}

/// Prints `value` as one JSON object on stdout when `json`, else its text `table`.
pub fn emit<T: serde::Serialize>(
    json: bool,
    value: &T,
    table: impl FnOnce(&T) -> String,
) -> Result<()> {
    if json {
        outln!("{}", serde_json::to_string(value)?);
    } else {
        out!("{}", table(value));
    }
    Ok(())
}

/// A progress bar drawn on stderr once the run has lasted a second, when stderr is a
/// terminal; nothing otherwise.
pub struct Progress {
    /// The bar.
    pub bar: ProgressBar,
    /// When the run started.
    pub start: Instant,
    shown: Mutex<bool>,
    terminal: bool,
}

impl Progress {
    /// A hidden bar named `label`, shown once the run lasts a second on a terminal.
    pub fn new(label: &str) -> Self {
        let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::hidden());
        bar.set_style(
            ProgressStyle::with_template(
                &format!(
                    "{{spinner}} {label} [{{elapsed_precise}}] {{wide_bar}} {{pos}}/{{len}} (eta {{eta}})"
                ),
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        Progress {
            bar,
            start: Instant::now(),
            shown: Mutex::new(false),
            terminal: std::io::stderr().is_terminal(),
        }
    }

    /// Moves the bar to `done` of `total`.
    pub fn update(&self, done: usize, total: usize) {
        self.bar.set_length(total as u64);
        self.bar.set_position(done as u64);
        if self.terminal && self.start.elapsed() > Duration::from_secs(1) {
            let mut shown = self.shown.lock().unwrap_or_else(|p| p.into_inner());
            if !*shown {
                *shown = true;
                self.bar.set_draw_target(ProgressDrawTarget::stderr());
                self.bar.enable_steady_tick(Duration::from_millis(200));
            }
        }
    }
}
