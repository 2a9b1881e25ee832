//! The `drive` command line as a library: a researcher's crate registers its own parts in a
//! [`Registries`] and gets the whole command line with them.
//!
//! ```no_run
//! use std::sync::Arc;
//! fn main() -> std::process::ExitCode {
//!     let mut registries = drive::Registries::builtin();
//!     // registries.slip_learners.register("my-slip", "...", Arc::new(MySlipLearner)).unwrap();
//!     drive::cli::main(registries)
//! }
//! ```
//!
//! One module per command; `common` holds what they share (the data arguments, number
//! parsing, JSON or text output).

/// `print!` to standard output that ends the command quietly when the reader has gone
/// (`drive eval | head -1`); an error otherwise.
macro_rules! out {
    ($($t:tt)*) => {
        $crate::cli::common::write_out(format_args!($($t)*))?
    };
}

/// `eprintln!` that never panics: a standard error that cannot be written (closed,
/// `/dev/full`, a file over `ulimit -f`) is ignored, the exit code still says what happened.
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        // What reaches the terminal quotes paths and data: never a raw control character.
        let _ = writeln!(
            std::io::stderr(),
            "{}",
            $crate::cli::common::printable(&format!($($t)*))
        );
    }};
}

/// `println!` with the behaviour of [`out!`].
macro_rules! outln {
    ($($t:tt)*) => {
        $crate::cli::common::write_out(format_args!("{}\n", format_args!($($t)*)))?
    };
}

mod adapt;
mod bench;
mod check;
mod common;
mod compare_protocols;
mod converge;
mod eval;
mod export;
mod import;
mod list;
mod matrix;
mod predict;
mod protocol;
mod report;
mod score;
mod sim_fit;
mod simulate;
mod track;
mod train;

use crate::Registries;
use clap::{Parser, Subcommand};
use std::ffi::OsString;
use std::process::ExitCode;

pub use matrix::run_with as run_matrix;

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

#[derive(Subcommand)]
enum Command {
    /// Fit every model on the training intervals and score it on the rest (paper eq. 8).
    Eval(eval::Args),
    /// Fit one model and save it as JSON.
    Train(train::Args),
    /// Prediction error against training driving time, and the convergence time (paper
    /// Fig. 7): train on the first 1, 2, 3, ... intervals, evaluate on the evaluation part.
    Converge(converge::Args),
    /// The DRIVE command schedule: sampled inputs held for 6 s intervals (one transient and
    /// two steady 2 s windows) within the robot's acceleration limits.
    Protocol(protocol::Args),
    /// Run the protocol (characterization, then DRIVE intervals) on a simulated UGV and
    /// write the recorded windows as a window CSV and its sidecar.
    Simulate(simulate::Args),
    /// Fit a twin of a real robot for the simulator on a DRIVE dataset: its controller,
    /// powertrain, terrain and sensor noise, written as a terrain TOML file that `drive
    /// simulate --terrain FILE` runs.
    SimFit(sim_fit::Args),
    /// Compare data-gathering protocols (paper Table I). On the simulator: equal driving
    /// time with each sampler, a model trained on each, all tested on one held-out run per
    /// seed. With --real: on recorded data, models trained on the intervals in a
    /// linear-focused and an angular-focused region against as many drawn from all of J.
    CompareProtocols(compare_protocols::Args),
    /// Import a raw DRIVE logger CSV: cut each 6 s interval into one transient and two
    /// steady windows, drop the unusable ones with their reason, and write the window CSV
    /// and sidecar that `drive eval` reads.
    Import(import::Args),
    /// Run the data-quality checks of `drive import` on a window CSV: the robot did not
    /// move while commanded (not-moving), a constant IMU (imu-constant), encoders at zero
    /// under commands (encoders-zero), commands beyond the robot's limits (outside-limits,
    /// with --robot). Exit code 1 when a check finds the data useless.
    Check(check::Args),
    /// Score every combination of a sweep file (datasets or simulated runs x models x
    /// splits) and write DIR/matrix.csv (one row per combination and metric),
    /// DIR/matrix.json and DIR/summary.md (median, IQR, improvement over the baseline with a
    /// bootstrap interval). See examples/sweep.toml.
    Matrix(matrix::Args),
    /// Write DIR/report.md (model comparison, convergence time, fitted parameters,
    /// uncertainty calibration) and the paper's figures as PNG and SVG for one dataset.
    Report(report::Args),
    /// Benchmark models across datasets (every bundled dataset, or a suite file of window
    /// CSVs, raw logs and bags): each dataset's comparison as drive eval, the transfer
    /// between runs of the same robot, the terrain's unpredictability (energy-based) and a
    /// leaderboard; tables on stdout, --json, or --out DIR with CSV, Markdown and an HTML
    /// page.
    Bench(bench::Args),
    /// Adapt a model fitted on other ground (a model file, or a dataset to fit one on) to a
    /// target run: its training half streamed in time order into the adaptive model, which
    /// is scored on its evaluation half after 0, 15, 30, 60, 120 and 240 s, beside the prior
    /// alone (frozen), a fit from scratch on the same seconds and the target's own fit.
    Adapt(adapt::Args),
    /// Follow paths in closed loop: each model inside a model-predictive controller (MPPI)
    /// driving the simulated robot (a preset terrain or a twin of a real run) along a line,
    /// circle, figure-eight, zigzag or a path file; cross-track and heading errors,
    /// completion and controller time per model, training data, path, speed and seed.
    Track(track::Args),
    /// Predict poses from a saved model and a command sequence.
    Predict(predict::Args),
    /// Score a saved model on every window of a dataset it was not fitted on (another run,
    /// terrain or calibration of the same robot): eq. 8 medians and quartiles, per phase,
    /// and its 95% regions' coverage.
    Score(score::Args),
    /// Write a fitted model in the layout other software loads: norlab_controllers' slip-BLR
    /// MPC (`--format norlab`: .npy arrays and a YAML of its parameters).
    Export(export::Args),
    /// List the registered parts: vehicles, powertrains, learners, samplers, terrains,
    /// robots.
    List(list::Args),
}

/// Runs the command line of this process with `registries`: parses the arguments, checks
/// the registered parts, runs the command. An error is one line on stderr and exit code 1;
/// an argument error exit code 2.
pub fn main(registries: Registries) -> ExitCode {
    ignore_file_size_signal();
    run(std::env::args_os(), &registries)
}

/// A write beyond the file-size limit (`ulimit -f`) raises SIGXFSZ, which kills the process
/// by default (exit 153, no message, staged temporaries left behind). Ignored, the write
/// fails with EFBIG instead: reported as an error, the temporaries removed.
fn ignore_file_size_signal() {
    #[cfg(unix)]
    // SAFETY: setting a standard signal's disposition to SIG_IGN, before any thread starts;
    // no handler runs.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
}

/// Runs the command line on `args` (the program name first) with `registries`.
pub fn run<I, T>(args: I, registries: &Registries) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    ExitCode::from(run_status(args, registries))
}

/// What a host that runs the command line in its own process (the Python package's `drive`
/// console command and `drive.report`) learns of a command's progress, and where it may
/// stop it.
///
/// ```
/// use std::sync::atomic::{AtomicUsize, Ordering};
/// use std::sync::Arc;
/// struct Count(AtomicUsize);
/// impl drive::cli::RunObserver for Count {
///     fn unit_done(&self, _total: usize) {
///         self.0.fetch_add(1, Ordering::Relaxed);
///     }
/// }
/// let count = Arc::new(Count(AtomicUsize::new(0)));
/// let registries = drive::Registries::builtin();
/// assert_eq!(drive::cli::run_status_observed(["drive", "list"], &registries, count.clone()), 0);
/// assert_eq!(count.0.load(Ordering::Relaxed), 0); // `list` has no units of work
/// ```
pub trait RunObserver: Send + Sync {
    /// One more of the running command's `total` units of work is done (`drive report`:
    /// each model's fit and score, the convergence, the protocol regions, the figures'
    /// analyses). A host may stop the command here by unwinding.
    fn unit_done(&self, total: usize);

    /// Called as the command is about to publish its outputs: a host whose user
    /// interrupted the command stops it here (by unwinding), and nothing is written.
    fn before_publish(&self) {}
}

/// [`run_status`] with `observer` told of the command's progress on this thread.
pub fn run_status_observed<I, T>(
    args: I,
    registries: &Registries,
    observer: std::sync::Arc<dyn RunObserver>,
) -> u8
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let _observing = common::Observing::new(observer);
    run_status(args, registries)
}

/// Where a model name is unknown and names a file (or ends in `.json`): what a saved model
/// is given to, since `--models` and `--model` of the fitting commands name models to fit.
fn model_file_hint(e: &anyhow::Error) -> String {
    let unknown = e.chain().find_map(|c| match c.downcast_ref() {
        Some(crate::traits::RegistryError::Unknown { kind, name, .. }) if *kind == "model" => {
            Some(name.clone())
        }
        _ => None,
    });
    let Some(name) = unknown else {
        return String::new();
    };
    let shown = common::printable(&name);
    if std::path::Path::new(&name).is_file() {
        format!(
            "; '{shown}' is a file: a saved model (drive train --out) is scored with `drive score --model {shown} --data DATA`, adapted with `drive adapt --prior {shown}` and driven with `drive track --models {shown}`"
        )
    } else if name.to_ascii_lowercase().ends_with(".json") {
        format!("; no file '{shown}' either (a saved model is given to drive score, adapt --prior or track --models)")
    } else {
        String::new()
    }
}

/// [`run`] with the exit status as a number: 0 on success, 1 on an error (reported on
/// standard error), 2 on a command-line usage error. What a host that runs the command line
/// in its own process (the Python package's `drive` console command) returns.
///
/// ```
/// let registries = drive::Registries::builtin();
/// assert_eq!(drive::cli::run_status(["drive", "list"], &registries), 0);
/// assert_eq!(drive::cli::run_status(["drive", "no-such-command"], &registries), 2);
/// ```
pub fn run_status<I, T>(args: I, registries: &Registries) -> u8
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let args: Vec<OsString> = args.into_iter().map(Into::into).collect();
    let cli = match common::parse::<Cli, _, _>(args.iter().cloned()) {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    common::take_notes();
    let result = registries
        .check_tags()
        .map_err(anyhow::Error::from)
        .and_then(|()| common::streams_not_named_inputs(&args))
        .and_then(|()| match cli.command {
            Command::Eval(a) => eval::run(&a, registries),
            Command::Train(a) => train::run(&a, registries),
            Command::Converge(a) => converge::run(&a, registries),
            Command::Protocol(a) => protocol::run(&a, registries),
            Command::Simulate(a) => simulate::run(&a, registries),
            Command::SimFit(a) => sim_fit::run(&a, registries),
            Command::CompareProtocols(a) => compare_protocols::run(&a, registries),
            Command::Import(a) => import::run(&a, registries),
            Command::Check(a) => check::run(&a, registries),
            Command::Matrix(a) => matrix::run(&a, registries),
            Command::Report(a) => report::run(&a, registries),
            Command::Bench(a) => bench::run(&a, registries),
            Command::Adapt(a) => adapt::run(&a, registries),
            Command::Track(a) => track::run(&a, registries),
            Command::Predict(a) => predict::run(&a, registries),
            Command::Score(a) => score::run(&a, registries),
            Command::Export(a) => export::run(&a, registries),
            Command::List(a) => list::run(&a, registries),
        });
    let notes = common::take_notes();
    match result {
        Ok(()) => {
            for line in notes {
                say!("{line}");
            }
            0
        }
        // The reader of our output has gone: nothing more to say.
        Err(e) if e.downcast_ref::<common::ClosedPipe>().is_some() => 0,
        Err(e) => {
            match e.downcast_ref::<common::StreamOntoInput>() {
                // The standard error appends to an input: the refusal goes to the standard
                // output when that is no input, else nowhere (the exit status says it),
                // never onto the input's end.
                Some(s) if s.stderr_appends_to_input => {
                    if !s.stdout_is_input {
                        use std::io::Write as _;
                        let _ = writeln!(
                            std::io::stdout(),
                            "error: {}",
                            common::printable(&format!("{e:#}"))
                        );
                    }
                }
                _ => say!("error: {e:#}{}", model_file_hint(&e)),
            }
            1
        }
    }
}
