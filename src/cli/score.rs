//! `drive score`: a saved model's eq. 8 errors on every window of a dataset (transfer).

use super::common::{data_name, emit, load, refuse_useless, DataArgs, UselessArg};
use crate::studies::Score;
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Model file written by `drive train`.
    #[arg(long)]
    model: PathBuf,
    #[command(flatten)]
    data: DataArgs,
    #[command(flatten)]
    useless: UselessArg,
    /// What the predictions start from (as `drive eval --start`); default: what the model
    /// was fitted for (its file's `fitted_with.start`), else encoders+imu.
    #[arg(long, value_parser = crate::traits::StartInfo::NAMES)]
    start: Option<String>,
    /// Score on a dataset of the same vehicle type with another geometry (another
    /// calibration of the robot's wheel radius or baseline): refused otherwise, since the
    /// model's inputs command the body velocities of the geometry it was fitted for; the
    /// difference is said.
    #[arg(long)]
    allow_other_geometry: bool,
    /// Print one JSON object on stdout instead of the table.
    #[arg(long)]
    json: bool,
}

pub fn run(args: &Args, registries: &crate::Registries) -> Result<()> {
    super::common::stdout_not_an_input(&[("--model", args.model.clone())])?;
    let name = args.model.display().to_string();
    let text = crate::traits::files::read_text(
        &args.model,
        crate::models::model_file::MAX_MODEL_FILE_BYTES,
    )
    .with_context(|| format!("reading {name}"))?;
    let file = crate::models::model_file::read_model_file(&name, &text)?;
    registries
        .check_vehicle(file.robot.vehicle.as_ref())
        .with_context(|| format!("{name}: the model's vehicle"))?;
    let start = match &args.start {
        Some(s) => crate::traits::StartInfo::parse(s).map_err(anyhow::Error::msg)?,
        None => file
            .fitted_with
            .as_ref()
            .map_or_else(crate::traits::StartInfo::default, |f| f.start),
    };
    let data = load(registries, &args.data)?;
    let data_label = data_name(&args.data);
    let useless = refuse_useless(&data, &data_label, args.useless.allow_useless, true)?;
    let mut score = crate::studies::score_model(
        file.model.as_ref(),
        &file.robot,
        &data,
        start,
        args.allow_other_geometry,
        "--allow-other-geometry",
    )
    .with_context(|| format!("scoring {name} on {data_label}"))?;
    // A model fitted on a dataset of this name may have been fitted on these very windows.
    if file.robot.name == data.robot.name {
        let fitted = file
            .fitted_with
            .as_ref()
            .map_or("its".to_string(), |f| format!("its {}", f.training_windows));
        score.notes.push(format!(
            "{name} was fitted on a dataset named as this one ('{}'): if it is this run, {fitted} training windows are scored too (drive eval scores held-out intervals)",
            data.robot.name.escape_debug()
        ));
    }
    score
        .notes
        .extend(useless.into_iter().map(|f| format!("{data_label}: {f}")));
    for n in &score.notes {
        super::common::note(format!("note: {n}"));
    }
    emit(args.json, &score, |s| table(s, &name))
}

/// The score as text: the medians and quartiles of each error kind, all windows and per
/// phase, and the 95% regions' coverage for a model with a covariance.
fn table(score: &Score, file: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{} ({}) on {}: {} windows, predictions from {}",
        super::common::printable(file),
        score.model.escape_debug(),
        score.dataset.escape_debug(),
        score.windows,
        score.start
    );
    let _ = writeln!(
        s,
        "{:<10} {:>7}  {:>30}  {:>30}",
        "windows", "count", "translational median [IQR] m", "rotational median [IQR] rad"
    );
    let rows = [
        ("all", score.translational_m.all, score.rotational_rad.all),
        (
            "transient",
            score.translational_m.transient,
            score.rotational_rad.transient,
        ),
        (
            "steady",
            score.translational_m.steady,
            score.rotational_rad.steady,
        ),
    ];
    for (label, t, r) in rows {
        let (Some(t), Some(r)) = (t, r) else {
            continue;
        };
        let q = |e: crate::studies::ErrorQuartiles| {
            format!("{:.4} [{:.4}, {:.4}]", e.median, e.iqr[0], e.iqr[1])
        };
        let _ = writeln!(
            s,
            "{label:<10} {:>7}  {:>30}  {:>30}",
            t.windows,
            q(t),
            q(r)
        );
    }
    if let Some(u) = &score.uncertainty {
        let at = |m: &std::collections::BTreeMap<String, f64>| {
            m.iter()
                .map(|(k, v)| format!("{k} {:.0}%", 100.0 * v))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let _ = writeln!(
            s,
            "95% regions: positions inside {}; yaw inside {}",
            at(&u.coverage95),
            at(&u.yaw_coverage95)
        );
    }
    s
}
