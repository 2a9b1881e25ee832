//! `drive adapt`: a prior fitted on other ground adapting to a target run, against the
//! prior alone, a fit from scratch and the target's own fit (issue 61).

use super::common::{data_name, emit, load, outputs_for, DataArgs};
use crate::Registries;
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The target run (window CSV or bundled:NAME): its training half streamed into the
    /// adaptive model in time order, its evaluation half scored on.
    #[command(flatten)]
    data: DataArgs,
    #[command(flatten)]
    useless: super::common::UselessArg,
    /// The prior: a model file (`drive train --out`, ending in .json) adapted as it is, or
    /// a dataset (a window CSV or bundled:NAME) each model of --models is fitted on (all
    /// its windows).
    #[arg(long)]
    prior: String,
    /// The models adapted, comma-separated (see drive list); with a model-file prior, the
    /// model fitted from scratch and on the target's own training half beside it (default:
    /// the file's model).
    #[arg(long, value_delimiter = ',')]
    models: Option<Vec<String>>,
    /// Fraction of the target's intervals in its training half; the rest is scored on.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.5)]
    split: f64,
    /// Seconds of the training half after which the models are scored, comma-separated
    /// (those beyond the half are left out).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0,15,30,60,120,240",
        allow_hyphen_values = true
    )]
    times: Vec<f64>,
    /// A terrain library: datasets of the same robot on other grounds (window CSVs or
    /// bundled:NAME), comma-separated. Each model of --models is fitted on each of them
    /// (with its calibrated uncertainty) and, with the prior, blended by how likely each
    /// made the target's windows as they are driven (`library` in the curves, with each
    /// model's `weights`).
    #[arg(long, value_delimiter = ',')]
    library: Vec<String>,
    /// Print one JSON object on stdout: `curve` (one entry per learner, model and time:
    /// `learner`, `model` (adaptive, frozen, scratch, own, or library with --library and
    /// its `weights`), `t_s`,
    /// `translational_median_m`, `rotational_median_rad`, for adaptive `ground_changed`,
    /// and `note` where no model could be fitted), `extrapolation` (the prior's and the
    /// target's commanded body velocities per axis, `prior_range` and `target_range`, their
    /// largest forward speed and yaw rate, `prior_max` and `target_max`, and the target's
    /// training windows beyond the prior's, `windows_beyond` and `share_beyond`), `notes`,
    /// `prior`, `target`, `split`, `train_s`, `train_windows`, `evaluation_windows`.
    #[arg(long)]
    json: bool,
    /// Also write DIR/adapt.json, DIR/curve.csv and the curves' figure DIR/curves.png and
    /// .svg.
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    if !(args.split > 0.0 && args.split < 1.0) {
        anyhow::bail!("--split must be within (0, 1), got {}", args.split);
    }
    crate::traits::limits::at_most("--times", args.times.len() as f64, 100.0, "")?;
    if let Some(t) = args.times.iter().find(|t| !(t.is_finite() && **t >= 0.0)) {
        anyhow::bail!("--times are seconds from 0 on, got {t}");
    }
    let target = load(registries, &args.data)?;
    let target_name = data_name(&args.data);
    let mut useless: Vec<String> =
        super::common::refuse_useless(&target, &target_name, args.useless.allow_useless, true)?
            .into_iter()
            .map(|f| format!("{target_name}, the target: {f}"))
            .collect();
    let prior_path = PathBuf::from(&args.prior);
    let is_model_file = args.prior.to_ascii_lowercase().ends_with(".json");
    let prior_data;
    let prior_file;
    // The dataset a model file was fitted on: its name and windows.
    let mut fitted_on: Option<(String, Option<usize>)> = None;
    let (prior, names): (crate::studies::AdaptPrior<'_>, Vec<String>) = if is_model_file {
        let text = crate::traits::files::read_text(
            &prior_path,
            crate::models::model_file::MAX_MODEL_FILE_BYTES,
        )
        .with_context(|| format!("reading {}", args.prior))?;
        prior_file = crate::models::model_file::read_model_file(&args.prior, &text)?;
        let file = &prior_file;
        fitted_on = Some((
            file.robot.name.clone(),
            file.fitted_with.as_ref().map(|f| f.training_windows),
        ));
        let given = args
            .models
            .as_deref()
            .map(|m| super::common::model_names(registries, m))
            .transpose()?;
        let names = match &given {
            Some(m) if m.len() != 1 => anyhow::bail!(
                "--prior {} is one model: --models names the one fitted from scratch and on the target beside it, not {}",
                args.prior,
                m.len()
            ),
            Some(m) => m.clone(),
            None => vec![file.model.name()],
        };
        (
            crate::studies::AdaptPrior::Model(file.model.as_ref()),
            names,
        )
    } else {
        let prior_args = DataArgs {
            data: Some(prior_path.clone()),
            sidecar: None,
            frame: args.data.frame.clone(),
        };
        prior_data =
            load(registries, &prior_args).with_context(|| format!("--prior {}", args.prior))?;
        useless.extend(
            super::common::refuse_useless(
                &prior_data,
                &args.prior,
                args.useless.allow_useless,
                true,
            )?
            .into_iter()
            .map(|f| format!("{}, the prior: {f}", args.prior)),
        );
        let given = args
            .models
            .as_deref()
            .map(|m| super::common::model_names(registries, m))
            .transpose()?;
        let names = given.unwrap_or_else(|| {
            crate::studies::ADAPT_MODELS
                .split(',')
                .map(String::from)
                .collect()
        });
        (crate::studies::AdaptPrior::Data(&prior_data), names)
    };
    let names: Vec<&str> = super::common::names(&names);
    let specs = registries.models().resolve_list(&names)?;
    crate::traits::limits::at_most("--library", args.library.len() as f64, 50.0, " datasets")?;
    let mut library = Vec::new();
    for entry in &args.library {
        if entry.trim().is_empty() {
            anyhow::bail!("--library has an empty entry: give datasets separated by commas");
        }
        let entry_args = DataArgs {
            data: Some(PathBuf::from(entry)),
            sidecar: None,
            frame: args.data.frame.clone(),
        };
        let data = load(registries, &entry_args).with_context(|| format!("--library {entry}"))?;
        useless.extend(
            super::common::refuse_useless(&data, entry, args.useless.allow_useless, true)?
                .into_iter()
                .map(|f| format!("{entry}, in the library: {f}")),
        );
        library.push(std::sync::Arc::new(data));
    }
    let files = ["adapt.json", "curve.csv", "curves.png", "curves.svg"];
    let outputs = match &args.out {
        Some(dir) => {
            let planned: Vec<(String, PathBuf)> = files
                .iter()
                .map(|f| (format!("{f} in --out"), dir.join(f)))
                .collect();
            let mut all: Vec<(&str, &std::path::Path)> = vec![("--out", dir.as_path())];
            all.extend(planned.iter().map(|(r, p)| (r.as_str(), p.as_path())));
            let mut inputs = vec![("--prior", prior_path.clone())];
            inputs.extend(args.library.iter().map(|l| ("--library", PathBuf::from(l))));
            if let Some(d) = &args.data.data {
                inputs.push(("--data", d.clone()));
                inputs.push((
                    "the sidecar of --data",
                    args.data
                        .sidecar
                        .clone()
                        .unwrap_or_else(|| crate::data::sidecar_to_read(d)),
                ));
            }
            Some(outputs_for(&inputs, &all)?)
        }
        None => None,
    };
    let study = crate::studies::AdaptStudy {
        split: args.split,
        times_s: args.times.clone(),
        library,
        ..Default::default()
    };
    let mut result = crate::studies::adapt(registries, &prior, &target, &specs, &study)?;
    super::common::note_few_evaluation(None, result.evaluation_windows);
    // A model file fitted on a dataset of the target's name: the target itself, most likely,
    // and `frozen` then scored on windows it was fitted on (a dataset prior is refused so).
    if let Some((name, windows)) = fitted_on.filter(|(name, _)| *name == target.robot.name) {
        super::common::note(format!(
            "note: the prior was fitted on a dataset named as the target is ({name}{}; the target has {} windows): if it is the target itself, `frozen` is scored on windows it was fitted on, and its figures are no transfer",
            windows.map_or(String::new(), |n| format!(", {n} windows")),
            target.windows.len()
        ));
    }
    // What the data checks called useless, run anyway with --allow-useless, stays with the
    // numbers it made.
    result.notes.extend(
        useless
            .into_iter()
            .map(|f| format!("the data checks call it useless (run with --allow-useless): {f}")),
    );
    let staged = match (outputs, &args.out) {
        (Some(mut outputs), Some(dir)) => {
            outputs.own(dir);
            crate::report::adapt::stage(&result, &mut outputs, dir)?;
            Some(outputs)
        }
        _ => None,
    };
    // The standard output first: a command that cannot write it fails with nothing new
    // published.
    emit(args.json, &result, text)?;
    if let Some(outputs) = staged {
        super::common::publish(outputs)?;
    }
    if let Some(dir) = &args.out {
        say!("adapt: {} files written to {}", files.len(), dir.display());
    }
    Ok(())
}

/// The text table: per learner, each time's four models (translational / rotational
/// median), then the extrapolation note.
fn text(r: &crate::studies::Adaptation) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "adaptation of {} to {} (training half {:.0} s, split {}; eq. 8 medians over its {} evaluation windows, m / rad)",
        r.prior, r.target, r.train_s, r.split, r.evaluation_windows
    );
    let cell = |p: Option<&crate::studies::AdaptPoint>| match p {
        Some(p) => match (p.translational_median_m, p.rotational_median_rad) {
            (Some(t), Some(w)) => format!("{t:.4} / {w:.4}"),
            _ => "-".to_string(),
        },
        None => "-".to_string(),
    };
    let mut learners: Vec<&str> = Vec::new();
    for p in &r.curve {
        if !learners.contains(&p.learner.as_str()) {
            learners.push(&p.learner);
        }
    }
    for learner in learners {
        let library = r.curve.iter().any(|p| p.model == "library");
        let _ = writeln!(
            s,
            "\n{learner}\n  {:>6}  {:<17}  {:<17}  {:<17}  {:<17}  {}ground changed",
            "t [s]",
            "adaptive",
            "frozen",
            "scratch",
            "own",
            if library {
                format!("{:<17}  ", "library")
            } else {
                String::new()
            }
        );
        let mut times: Vec<f64> = r
            .curve
            .iter()
            .filter(|p| p.learner == learner)
            .map(|p| p.t_s)
            .collect();
        times.dedup();
        for t in times {
            let shown = seconds(t);
            let at = |model: &str| {
                r.curve
                    .iter()
                    .find(|p| p.learner == learner && p.model == model && p.t_s == t)
            };
            let changed = at("adaptive")
                .and_then(|p| p.ground_changed)
                .map_or("-", |c| if c { "yes" } else { "no" });
            let _ = writeln!(
                s,
                "  {shown:>6}  {:<17}  {:<17}  {:<17}  {:<17}  {}{changed}",
                cell(at("adaptive")),
                cell(at("frozen")),
                cell(at("scratch")),
                cell(at("own")),
                if library {
                    format!("{:<17}  ", cell(at("library")))
                } else {
                    String::new()
                }
            );
        }
    }
    if !r.library.is_empty() {
        let _ = writeln!(
            s,
            "\nlibrary: {} (the models blended by their likelihood of the windows driven)",
            r.library.join(", ")
        );
    }
    for note in &r.notes {
        let _ = writeln!(s, "\nnote: {note}");
    }
    match &r.extrapolation {
        Some(e) if e.windows_beyond > 0 => {
            let _ = writeln!(
                s,
                "\nnote: {} of the target's {} training windows ({:.0}%) command a body velocity beyond the prior's (more than {} times its largest in some axis and direction, or a direction it never drove; forward speed, lateral speed and yaw rate [min, max]: prior {}, target {}): there the prior extrapolates, and adaptation corrects more than the ground",
                e.windows_beyond,
                r.train_windows,
                100.0 * e.share_beyond,
                crate::studies::EXTRAPOLATION_MARGIN,
                ranges(&e.prior_range),
                ranges(&e.target_range)
            );
        }
        Some(_) => {
            let _ = writeln!(
                s,
                "\nthe target's commands stay within the prior's (no extrapolation)"
            );
        }
        None => {
            let _ = writeln!(
                s,
                "\nnote: the prior is a model file: whether the target's commands leave its training data is not known"
            );
        }
    }
    s
}

/// Seconds as given: whole ones without decimals, others with as many as they need (never
/// "-0").
fn seconds(t: f64) -> String {
    let t = t + 0.0;
    if t.fract() == 0.0 {
        format!("{t:.0}")
    } else {
        format!("{t}")
    }
}

/// Per-axis `[min, max]` ranges, two decimals.
fn ranges(r: &[[f64; 2]; 3]) -> String {
    r.iter()
        .map(|[a, b]| format!("[{a:.2}, {b:.2}]"))
        .collect::<Vec<_>>()
        .join(" ")
}
