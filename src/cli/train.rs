//! `drive train`: one model fitted and saved as JSON.

use super::common::{load, outputs_for, DataArgs, PredictionArgs};
use crate::models::model_file::{model_file_to_json, FitSettings};
use crate::traits::WindowSet;
use crate::Registries;
use anyhow::{Context, Result};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    data: DataArgs,
    #[command(flatten)]
    useless: super::common::UselessArg,
    /// Model to fit: a model name (slip-blr, slip-blr+rate-limited, ...; see drive list).
    #[arg(long)]
    model: String,
    /// Output model file.
    #[arg(long)]
    out: PathBuf,
    /// Train on the first fraction of the intervals only (default: all of the data).
    #[arg(long, allow_negative_numbers = true)]
    split: Option<f64>,
    #[command(flatten)]
    prediction: PredictionArgs,
}

pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    // An input replaced is said first; then a name of another kind of file.
    let mut outputs = outputs_for(&args.data.inputs(), &[("--out", &args.out)])?;
    super::common::named_output(
        "--out",
        &args.out,
        "a model file (JSON)",
        &[".toml", ".yaml", ".yml", ".md", ".html", ".svg", ".png"],
    )?;
    let spec = args
        .prediction
        .apply(vec![registries.model(&args.model)?])?
        .remove(0);
    let dataset = load(registries, &args.data)?;
    super::common::refuse_useless(
        &dataset,
        &super::common::data_name(&args.data),
        args.useless.allow_useless,
        true,
    )?;
    let train = match args.split {
        Some(f) => crate::eval::split_by_interval(&dataset, f)?.0,
        None => WindowSet::new(&dataset.robot, &dataset.windows),
    };
    let model = spec
        .fit(&train)
        .with_context(|| format!("fitting {}", args.model))?;
    // A calibration asked for but not made (fewer training intervals than its folds, or a
    // fold's refit failed) leaves the model's own covariance: said, not silent.
    let calibrated = serde_json::to_value(model.as_ref())
        .ok()
        .is_some_and(|v| v.get("type").and_then(|t| t.as_str()) == Some("calibrated"));
    let has_covariance = model
        .predict_with_covariance_into(
            &crate::traits::StartState::at_rest(crate::traits::Pose::zeros()),
            &[crate::traits::Input::zeros(); 2],
            &mut Vec::new(),
            &mut Vec::new(),
        )
        .is_ok();
    if spec.uncertainty != crate::models::calibration::Uncertainty::Paper
        && has_covariance
        && !calibrated
    {
        say!(
            "note: {}'s uncertainty is not calibrated (the calibration holds out blocks of training intervals, and the training windows span {} interval(s), or a fold's refit failed); its covariance is the model's own",
            args.model,
            train
                .windows
                .iter()
                .map(|w| w.interval)
                .collect::<std::collections::BTreeSet<_>>()
                .len()
        );
    }
    // The settings it was fitted with, kept in the file (a loaded model predicts and scores
    // from the start it was fitted for).
    let settings = FitSettings {
        split: args.split,
        training_windows: train.len(),
        commanded: crate::models::model_file::CommandRange::of(&train),
        ..FitSettings::of(&spec)
    };
    let text = model_file_to_json(model.as_ref(), &dataset.robot, Some(&settings))
        .with_context(|| format!("saving {}", args.model))?;
    // What train writes, predict, track and adapt read back: a fit the loader would refuse
    // (degenerate noise from useless data let through, ...) is not written.
    if let Err(e) =
        crate::models::model_file::read_model_file(&args.out.display().to_string(), &text)
    {
        anyhow::bail!(
            "the fitted {} is not a model the loader accepts, so it is not written: {e}",
            args.model
        );
    }
    outputs.write(&args.out, text)?;
    super::common::publish(outputs)?;
    say!(
        "fitted {} ({}) on {} windows of {}; saved to {}",
        args.model,
        spec.canonical(),
        train.len(),
        dataset.robot.name,
        args.out.display()
    );
    Ok(())
}
