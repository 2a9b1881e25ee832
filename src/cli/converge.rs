//! `drive converge`: the paper's Fig. 7 analysis and convergence time.

use super::common::{load, parse_pair, DataArgs};
use crate::Registries;
use anyhow::{bail, Result};

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    data: DataArgs,
    /// Fraction of the intervals whose prefixes are trained on; the rest evaluates.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.5)]
    split: f64,
    /// Model whose convergence is analysed (a model name; see drive list).
    #[arg(long, default_value = "slip-blr")]
    model: String,
    /// Gradient thresholds m/s,rad/s of the convergence rule.
    #[arg(long, value_parser = parse_pair, default_value = "0.01,0.01", allow_hyphen_values = true)]
    thresholds: [f64; 2],
    /// Print one JSON object on stdout instead of the table.
    #[arg(long)]
    json: bool,
}

pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    let spec = registries.model(&args.model)?;
    let thresholds = args.thresholds;
    if thresholds.iter().any(|t| *t <= 0.0) {
        bail!(
            "--thresholds must be positive, got {},{}",
            crate::traits::limits::Short(thresholds[0]),
            crate::traits::limits::Short(thresholds[1])
        );
    }
    let dataset = load(&args.data)?;
    let c = crate::eval::convergence(&dataset, args.split, thresholds, &spec)?;
    if args.json {
        outln!("{}", serde_json::to_string(&c)?);
        return Ok(());
    }
    outln!(
        "Convergence of {} ({}) on {} (paper Fig. 7): training on the first intervals, {} evaluation windows",
        args.model,
        c.model,
        dataset.robot.name,
        c.eval_windows
    );
    outln!(
        "{:>10} {:>10} {:>18} {:>18}",
        "time [s]",
        "intervals",
        "transl. med. [m]",
        "rot. med. [rad]"
    );
    for p in &c.curve {
        outln!(
            "{:>10.1} {:>10} {:>18.4} {:>18.4}",
            p.training_time_s,
            p.intervals,
            p.translational_median_m,
            p.rotational_median_rad
        );
    }
    if !c.skipped.is_empty() {
        let first = &c.skipped[0];
        outln!(
            "not fitted with {} of the amounts of data (e.g. {} intervals: {})",
            c.skipped.len(),
            first.intervals,
            first.reason
        );
    }
    match c.convergence_time_s {
        Some(t) => outln!(
            "convergence time: {t:.1} s (every later gradient under {} m/s and {} rad/s)",
            thresholds[0],
            thresholds[1]
        ),
        None => outln!("convergence time: none (the curve never meets the rule)"),
    }
    Ok(())
}
