//! `drive export`: a fitted model in the layout other software loads (norlab_controllers'
//! `.npy` + YAML).

use crate::models::model_file::read_model_file;
use anyhow::{bail, Context, Result};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Model file written by `drive train`.
    #[arg(long)]
    model: PathBuf,
    /// The layout: `norlab`, norlab_controllers' SlipBLRPwrtrnDiffDriveMPC (slip-BLR on a
    /// FOPDT powertrain of a differential drive): slip_blr/*.npy, powertrain/*.npy and
    /// norlab_controller.yaml.
    #[arg(long, value_parser = ["norlab"])]
    format: String,
    /// Output directory (created; its files replaced).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(args: &Args, _registries: &crate::Registries) -> Result<()> {
    let yaml = args.out.join("norlab_controller.yaml");
    let mut outputs = super::common::outputs_for(
        &[("--model", args.model.clone())],
        &[
            ("--out", &args.out),
            ("norlab_controller.yaml in --out", &yaml),
        ],
    )?;
    let name = args.model.display().to_string();
    let text = crate::traits::files::read_text(
        &args.model,
        crate::models::model_file::MAX_MODEL_FILE_BYTES,
    )
    .with_context(|| format!("reading {name}"))?;
    let file = read_model_file(&name, &text)?;
    let export = match args.format.as_str() {
        "norlab" => crate::models::export::norlab(
            file.model.as_ref(),
            &file.robot,
            file.fitted_with.as_ref(),
        )
        .with_context(|| format!("{name}: cannot be exported as --format norlab"))?,
        other => bail!("unknown format {other}"),
    };
    for (path, bytes) in &export.files {
        outputs.write(&args.out.join(path), bytes)?;
    }
    super::common::publish(outputs)?;
    for note in &export.notes {
        say!("note: {note}");
    }
    say!(
        "{} exported as {}: {} files in {} (norlab_controller.yaml names them)",
        file.model.name(),
        args.format,
        export.files.len(),
        args.out.display()
    );
    Ok(())
}
