//! `drive report`: report.md and the paper's figures for one dataset.

use super::common::{load, DataArgs, ModelsArg};
use crate::traits::vehicle_tag;
use crate::Registries;
use anyhow::{bail, Result};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    data: DataArgs,
    #[command(flatten)]
    useless: super::common::UselessArg,
    /// Output folder (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// The robot's manufacturer limits for the input-space figure: a registered robot
    /// (husky, hd2, warthog, ...) or a TOML file. Default: the husky preset for the bundled
    /// data, none otherwise.
    #[arg(long)]
    robot: Option<String>,
    /// Fraction of the DRIVE intervals (in recording order) used for training.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.5)]
    split: f64,
    #[command(flatten)]
    models: ModelsArg,
    /// Model whose convergence (Fig. 7) and protocol regions (Fig. 5) are analysed.
    #[arg(long, default_value = "slip-blr")]
    model: String,
    #[command(flatten)]
    prediction: super::common::PredictionArgs,
}

pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    let models = super::common::model_names(registries, &args.models.models)?;
    let mut inputs = args.data.inputs();
    if let Some(r) = &args.robot {
        inputs.extend(super::common::robot_input(r));
    }
    let md = args.out.join("report.md");
    let mut outputs = super::common::outputs_for(
        &inputs,
        &[("--out", &args.out), ("report.md in --out", &md)],
    )?;
    // Before any data is read (compare_specs refuses it too).
    crate::studies::check_names(&registries.models().resolve_list(&models)?)?;
    registries.model(&args.model)?;
    let dataset = load(registries, &args.data)?;
    super::common::refuse_useless(
        &dataset,
        &super::common::data_name(&args.data),
        args.useless.allow_useless,
        false,
    )?;
    let robot = args
        .robot
        .as_deref()
        .or(args.data.data.is_none().then_some("husky"));
    let naive_input_space = match robot {
        Some(r) => {
            let spec = registries.robot(r)?;
            let (theirs, ours) = (
                vehicle_tag(spec.vehicle.as_ref()),
                vehicle_tag(dataset.robot.vehicle.as_ref()),
            );
            if theirs != ours {
                bail!(
                    "the robot {}'s vehicle is {} and the data's is {}: its limits are in other input axes",
                    spec.name,
                    theirs.unwrap_or_default(),
                    ours.unwrap_or_default()
                );
            }
            // Another robot of the same kind: its limits and body are used, said as `drive
            // check --robot` says it (the unpredictability depends on the body).
            if let Some(f) = crate::data::quality::vehicle_mismatch(
                dataset.robot.vehicle.as_ref(),
                spec.vehicle.as_ref(),
                &spec.name,
            ) {
                say!("note: {}", f.message);
            }
            Some((
                format!("naive input space ({} manufacturer limits)", spec.name),
                spec.nominal_input_space,
            ))
        }
        None => None,
    };
    let options = crate::report::ReportOptions {
        split: args.split,
        naive_input_space,
        models,
        model: args.model.clone(),
        start: args.prediction.start()?,
        uncertainty: args.prediction.uncertainty()?,
        body: {
            let robot =
                super::common::robot_of(registries, &args.data, args.robot.as_deref(), &dataset)?;
            robot.body.map(|b| (robot.source, b))
        },
        ..Default::default()
    };
    // The studies fit and evaluate; the report only draws and writes.
    let analysis = crate::studies::report::ReportAnalysis::build_with_progress(
        registries,
        &dataset,
        &options,
        &super::common::progress(),
    )?;
    super::common::note_few_evaluation(
        Some(analysis.comparison.eval_intervals),
        analysis.comparison.eval_windows,
    );
    let report = crate::report::Report::new(analysis);
    outputs.own(&args.out);
    let files = report.stage(&mut outputs, &args.out)?;
    super::common::publish(outputs)?;
    if let Err(reason) = &report.protocols {
        say!("note: no protocol figure: {reason}");
    }
    say!(
        "report on {}: {} files written to {} (open report.md)",
        dataset.robot.name,
        files.len(),
        args.out.display()
    );
    Ok(())
}
