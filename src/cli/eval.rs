//! `drive eval`: every model fitted on the training intervals and scored on the rest.

use super::common::{emit, load, names, outputs_for, DataArgs, ModelsArg, PredictionArgs};
use crate::models::ModelSpec;
use crate::studies::{compare_specs, Comparison, ErrorSummary, ModelResult, PhaseSummary};
use crate::Registries;
use anyhow::{bail, Result};
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    data: DataArgs,
    #[command(flatten)]
    useless: super::common::UselessArg,
    /// Fraction of the DRIVE intervals (in recording order) used for training.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.5)]
    split: f64,
    #[command(flatten)]
    models: ModelsArg,
    /// Powertrain of the models named without one (naive excepted: it is the commands):
    /// a registered powertrain (commanded, fopdt, rate-limited, ...). Default: each model's
    /// own (fopdt for powertrain and slip-blr, commanded for acc-blr, as in the paper).
    #[arg(long)]
    powertrain: Option<String>,
    #[command(flatten)]
    prediction: PredictionArgs,
    /// Print one JSON object on stdout instead of the table.
    #[arg(long)]
    json: bool,
    /// Write every evaluation window's errors per model to this CSV.
    #[arg(long)]
    per_window: Option<PathBuf>,
}

/// The models named, with `--powertrain` applied to those named without one.
pub fn specs(
    registries: &Registries,
    models: &[String],
    powertrain: Option<&str>,
) -> Result<Vec<ModelSpec>> {
    let names = names(models);
    if names.is_empty() {
        bail!(
            "--models is empty (the models are: {})",
            registries.catalog().models.join(", ")
        );
    }
    // A saved model is not refitted: it is scored where it is (its own command). A model
    // name that is also a file's is the model.
    if let Some(file) = names.iter().find(|n| {
        std::path::Path::new(n).is_file() && registries.models().resolve_list(&[**n]).is_err()
    }) {
        bail!(
            "--models {file}: a model file is fitted already, and --models names models to fit on the training intervals (see drive list); score a saved model on a dataset with `drive score --model {file} --data DATA`"
        );
    }
    if let Some(p) = powertrain {
        registries.powertrains.get(p)?;
    }
    let mut out = Vec::new();
    for name in names {
        let specs = registries.models().resolve_list(&[name])?;
        for spec in specs {
            let spec = match (powertrain, &spec.powertrain) {
                (Some(p), Some(_))
                    if !name.contains(['+', '/']) && name != "naive" && name != "all" =>
                {
                    registries
                        .models()
                        .resolve(&format!("{}+{p}", spec.learner))?
                        .named(name)
                }
                _ => spec,
            };
            out.push(spec);
        }
    }
    // Before any data is read (compare_specs refuses it too).
    crate::studies::check_names(&out)?;
    Ok(out)
}

pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    let planned: Vec<(&str, &std::path::Path)> = args
        .per_window
        .iter()
        .map(|p| ("--per-window", p.as_path()))
        .collect();
    // A CSV under its own kind of name, never over a dataset.
    if let Some(path) = args
        .per_window
        .as_deref()
        .filter(|p| !super::common::is_standard_output(p))
    {
        super::common::csv_output("--per-window", path, "a per-window table (CSV)", false)?;
    }
    if let Some(path) = args
        .per_window
        .as_deref()
        .filter(|p| args.json && super::common::is_standard_output(p))
    {
        bail!(
            "--per-window {} is the standard output, where --json prints its document: the CSV and the JSON would be mixed; give --per-window a file, or leave out --json",
            path.display()
        );
    }
    let mut outputs = outputs_for(&args.data.inputs(), &planned)?;
    let specs = args.prediction.apply(specs(
        registries,
        &args.models.models,
        args.powertrain.as_deref(),
    )?)?;
    let dataset = load(registries, &args.data)?;
    super::common::refuse_useless(
        &dataset,
        &super::common::data_name(&args.data),
        args.useless.allow_useless,
        true,
    )?;
    let cmp = compare_specs(&dataset, args.split, &specs)?;
    // Figures from a handful of intervals are printed, and said to be so.
    let evidence = crate::studies::BenchConfig::default().min_evidence_intervals;
    if cmp.eval_intervals < evidence {
        say!(
            "note: {} evaluation interval(s): the medians and their bootstrap intervals rest on too few to be evidence (drive bench counts a dataset from {evidence})",
            cmp.eval_intervals
        );
    }
    if cmp.train_intervals < 2
        && args.prediction.uncertainty()? != crate::models::calibration::Uncertainty::Paper
    {
        say!(
            "note: {} training interval(s): no uncertainty is calibrated (the calibration holds out blocks of training intervals); each model's covariance is its own",
            cmp.train_intervals
        );
    }
    // Regions far wider than one circle holding as many of the positions: said (the grass
    // run's 45 training windows gave 4x and 17x: the calibration's fold models, fitted on
    // half of them, missed by far more than the final model).
    for m in cmp.models.iter().filter(|m| {
        m.uncertainty
            .is_some_and(|u| u != crate::models::calibration::Uncertainty::Paper)
    }) {
        if let Some(r) = m.area_ratio_to_constant.filter(|r| *r > 2.0) {
            say!(
                "note: {}'s 95% regions at 2 s are {:.1}x the area of one circle holding as many of the measured positions: over-cautious on this data (the calibration scores models fitted on part of the {} training interval(s); more training data sharpens them)",
                m.name,
                r,
                cmp.train_intervals
            );
        }
    }
    if let Some(path) = &args.per_window {
        if let Some((m, w)) = cmp.models.iter().find_map(|m| {
            m.report
                .windows
                .iter()
                .find(|w| !(w.error.translational.is_finite() && w.error.rotational.is_finite()))
                .map(|w| (m, w))
        }) {
            bail!(
                "{}: the error of {} on window {} is not a finite number; nothing written",
                path.display(),
                m.name,
                w.window
            );
        }
        outputs.write(path, per_window_csv(&cmp))?;
        super::common::publish(outputs)?;
    }
    emit(args.json, &cmp, table)
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

/// The comparison as text: one section per window phase, a row per model.
pub fn table(cmp: &Comparison) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "DRIVE model comparison on {} ({}{})",
        cmp.dataset,
        if cmp.robot.is_empty() {
            "robot not named"
        } else {
            &cmp.robot
        },
        if cmp.terrain.is_empty() {
            String::new()
        } else {
            format!("; terrain: {}", cmp.terrain)
        }
    );
    let _ = writeln!(
        s,
        "train: first {} intervals ({} windows); evaluate: last {} intervals ({} windows); split {}",
        cmp.train_intervals, cmp.train_windows, cmp.eval_intervals, cmp.eval_windows, cmp.split
    );
    let full: Vec<String> = cmp
        .models
        .iter()
        .filter(|m| m.name != m.model)
        .map(|m| format!("{} = {}", m.name, m.model))
        .collect();
    if !full.is_empty() {
        let _ = writeln!(s, "models: {}", full.join(", "));
    }
    let _ = writeln!(
        s,
        "MRMSE over the {} s windows (paper eq. 8): median [IQR], improvement over naive\n",
        crate::traits::limits::Short(cmp.window_s)
    );
    let width = name_width(cmp.models.iter());
    let section =
        |s: &mut String, title: &str, pick: &dyn Fn(&ModelResult) -> Option<PhaseSummary>| {
            let count = cmp
                .models
                .iter()
                .find_map(|m| pick(m).map(|p| p.windows))
                .unwrap_or(0);
            let _ = writeln!(s, "{title} ({count} windows)");
            let (translational, rotational) = ("translational MRMSE [m]", "rotational MRMSE [rad]");
            let _ = writeln!(s, "  {:<width$}{translational:<37}{rotational}", "");
            let header = "median  IQR               vs naive";
            let _ = writeln!(s, "  {:<width$}{header:<37}{header}", "model");
            for m in &cmp.models {
                let Some(p) = pick(m) else {
                    let _ = writeln!(s, "  {:<width$}no window", m.name);
                    continue;
                };
                let cell = |e: ErrorSummary| {
                    let [q1, q3] = e.iqr;
                    format!(
                        "{:<6.4}  [{q1:.4}, {q3:.4}]  {:>+7.1}%",
                        e.median, e.improvement_over_naive_percent
                    )
                };
                let _ = writeln!(
                    s,
                    "  {:<width$}{:<37}{}",
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
    improvement_section(&mut s, cmp);
    uncertainty_section(&mut s, cmp);
    s
}

/// The width of the model-name column: the longest name and a space, at least 11.
fn name_width<'a>(models: impl Iterator<Item = &'a ModelResult>) -> usize {
    models.map(|m| m.name.len() + 1).max().unwrap_or(0).max(11)
}

/// Every model's improvement over naive and over slip-BLR with its paired bootstrap
/// interval.
fn improvement_section(s: &mut String, cmp: &Comparison) {
    let _ = writeln!(
        s,
        "improvement of the medians with {:.0}% intervals (paired bootstrap, {} resamples of the evaluation intervals)",
        100.0 * cmp.bootstrap.level,
        cmp.bootstrap.resamples
    );
    let width = name_width(cmp.models.iter());
    let _ = writeln!(
        s,
        "  {:<width$}{:<28}{:<28}{:<28}rotational",
        "", "vs naive: translational", "rotational", "vs slip-BLR: translational"
    );
    let cell = |i: &crate::eval::Improvement| {
        format!(
            "{:<28}",
            format!("{:+.1}% [{:+.1}, {:+.1}]", i.percent, i.ci[0], i.ci[1])
        )
    };
    for m in &cmp.models {
        let naive = &m.improvement_over_naive;
        let over_naive = format!("{}{}", cell(&naive.translational), cell(&naive.rotational));
        let over_blr = m
            .improvement_over_slip_blr
            .as_ref()
            .map_or("slip-BLR could not be fitted".to_string(), |b| {
                format!("{}{}", cell(&b.translational), cell(&b.rotational))
            });
        let _ = writeln!(
            s,
            "  {:<width$}{over_naive:<56}{}",
            m.name,
            over_blr.trim_end()
        );
    }
    let _ = writeln!(s);
}

/// The calibration of the models with a pose covariance: coverage of the 95% regions at
/// 0.5, 1 and 2 s (position, yaw) and the mean negative log-likelihood.
fn uncertainty_section(s: &mut String, cmp: &Comparison) {
    let with: Vec<&ModelResult> = cmp
        .models
        .iter()
        .filter(|m| m.coverage95.is_some())
        .collect();
    let Some(first) = with.first() else {
        return;
    };
    let _ = writeln!(
        s,
        "predicted uncertainty ({}; predictions start from {}): share of the measured poses inside the 95% regions",
        first.uncertainty.map_or("", |u| u.as_str()),
        first.start.as_str()
    );
    let width = name_width(with.iter().copied());
    // The horizons the windows reach (a 1 s window has no 2 s one).
    let horizons: Vec<String> = first
        .coverage95
        .as_ref()
        .map(|c| {
            c.keys()
                .map(|k| k.parse::<f64>().map_or(k.clone(), |h| format!("{h}")))
                .collect()
        })
        .unwrap_or_default();
    let last = first
        .coverage95
        .as_ref()
        .and_then(|c| c.keys().last().cloned())
        .unwrap_or_else(|| "2.0".into());
    let at_horizons = format!("at {} s", horizons.join("/"));
    let _ = writeln!(
        s,
        "  {:<width$}{:<24}{:<24}NLL [nats/step]",
        "",
        format!("position {at_horizons}"),
        format!("yaw {at_horizons}")
    );
    for m in with {
        let at = |c: &Option<std::collections::BTreeMap<String, f64>>| {
            c.as_ref().map_or(String::new(), |c| {
                c.values()
                    .map(|f| format!("{:.1}%", 100.0 * f))
                    .collect::<Vec<_>>()
                    .join(" ")
            })
        };
        let _ = writeln!(
            s,
            "  {:<width$}{:<24}{:<24}{}",
            m.name,
            at(&m.coverage95),
            at(&m.yaw_coverage95),
            m.nll.filter(|v| v.is_finite()).map_or(
                "not finite (degenerate covariances)".into(),
                |v| {
                    if v.abs() < 1e4 {
                        format!("{v:.2}")
                    } else {
                        format!("{v:.2e}")
                    }
                }
            )
        );
    }
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "which predictions the regions say are hard, at {} s: position coverage per phase and per third of the commanded speed; mean region area over the constant circle of the same coverage; rank correlation of the predicted spread with the error",
        last.parse::<f64>().map_or(last.clone(), |h| format!("{h}"))
    );
    let _ = writeln!(
        s,
        "  {:<width$}{:<18}{:<24}{:<13}rank corr. position / yaw",
        "", "transient/steady", "speed low/mid/high", "area ratio"
    );
    for m in cmp.models.iter().filter(|m| m.coverage95.is_some()) {
        let at = |groups: &Option<crate::eval::GroupCoverage>, keys: &[&str]| {
            keys.iter()
                .map(|k| {
                    groups
                        .as_ref()
                        .and_then(|g| g.get(*k))
                        .and_then(|h| h.get(&last))
                        .map_or("-".to_string(), |f| format!("{:.0}%", 100.0 * f))
                })
                .collect::<Vec<_>>()
                .join("/")
        };
        let rank = |k: &str| {
            m.error_rank_correlation
                .as_ref()
                .and_then(|r| r.get(k))
                .map_or("-".to_string(), |v| format!("{v:+.2}"))
        };
        let _ = writeln!(
            s,
            "  {:<width$}{:<18}{:<24}{:<13}{} / {}",
            m.name,
            at(&m.coverage95_by_phase, &["transient", "steady"]),
            at(&m.coverage95_by_speed, &["low", "mid", "high"]),
            m.area_ratio_to_constant
                .filter(|v| v.is_finite())
                .map_or("-".to_string(), |v| format!("{v:.2}")),
            rank("position"),
            rank("yaw")
        );
    }
    let _ = writeln!(s);
}
