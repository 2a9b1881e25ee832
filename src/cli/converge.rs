//! `drive converge`: the paper's Fig. 7 analysis and convergence time.

use super::common::{load, parse_pair, DataArgs};
use crate::Registries;
use anyhow::{bail, Result};

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    data: DataArgs,
    #[command(flatten)]
    useless: super::common::UselessArg,
    /// Fraction of the intervals whose prefixes are trained on; the rest evaluates.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.5)]
    split: f64,
    /// Model whose convergence is analysed (a model name; see drive list).
    #[arg(long, default_value = "slip-blr")]
    model: String,
    /// Gradient thresholds m/s,rad/s of the convergence rule.
    #[arg(long, value_parser = parse_pair, default_value = "0.01,0.01", allow_hyphen_values = true)]
    thresholds: [f64; 2],
    /// Random orders of the training intervals whose curves are summarized (median and
    /// range) beside the recording order; 0 for none. Default: 30 for a model that fits
    /// online (slip-blr, powertrain), 0 for one fitted from scratch at every amount.
    #[arg(long)]
    orders: Option<usize>,
    /// Seed of the random orders.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// At most this many training amounts per curve (every amount when there are fewer
    /// intervals; otherwise every amount up to half of it, the rest evenly spaced). The
    /// convergence rule reads the gradients between the points kept: fewer points, coarser
    /// gradients, another convergence time.
    #[arg(long, default_value_t = 100)]
    max_points: usize,
    /// What the predictions start from (see drive eval --help).
    #[arg(long, default_value = "encoders+imu", value_parser = crate::traits::StartInfo::NAMES)]
    start: String,
    /// Print one JSON object on stdout instead of the table.
    #[arg(long)]
    json: bool,
}

pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    let start = crate::traits::StartInfo::parse(&args.start).map_err(anyhow::Error::msg)?;
    let spec = registries.model(&args.model)?;
    let spec = spec.clone().with_uncertainty(spec.uncertainty, start);
    if let Some(orders) = args.orders {
        crate::traits::limits::at_most("--orders", orders as f64, 1000.0, "")?;
    }
    if args.max_points < 2 {
        bail!("--max-points must be at least 2, got {}", args.max_points);
    }
    let thresholds = args.thresholds;
    if thresholds.iter().any(|t| *t <= 0.0) {
        bail!(
            "--thresholds must be positive, got {},{}",
            crate::traits::limits::Short(thresholds[0]),
            crate::traits::limits::Short(thresholds[1])
        );
    }
    let dataset = load(registries, &args.data)?;
    super::common::refuse_useless(
        &dataset,
        &super::common::data_name(&args.data),
        args.useless.allow_useless,
        true,
    )?;
    let config = crate::studies::ConvergenceConfig {
        split: args.split,
        thresholds,
        max_points: args.max_points,
        orders: args
            .orders
            .unwrap_or(if spec.growing(&dataset.robot).is_some() {
                crate::studies::ConvergenceConfig::default().orders
            } else {
                0
            }),
        seed: args.seed,
    };
    let c = crate::studies::convergence_with(&dataset, &config, &spec)?;
    if c.curve.is_empty() {
        let why = c
            .skipped
            .first()
            .map_or("no training interval".into(), |s| {
                format!("with {} intervals: {}", s.intervals, s.reason)
            });
        bail!(
            "{} could not be fitted on any amount of the training data ({why})",
            spec.name
        );
    }
    super::common::note_few_evaluation(None, c.eval_windows);
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
    let orders = c.random_orders.as_ref();
    outln!(
        "fitting: {} ({}){}",
        c.fitting,
        if c.fitting == "online" {
            "slip posterior updated interval by interval, powertrain refitted each time the data grew by half"
        } else {
            "every amount fitted from scratch"
        },
        orders.map_or(String::new(), |o| format!(
            "; random orders: {} (seed {}), median [min, max] of their medians",
            o.orders, o.seed
        ))
    );
    outln!(
        "{:>10} {:>10} {:>18} {:>18}{}",
        "time [s]",
        "intervals",
        "transl. med. [m]",
        "rot. med. [rad]",
        if orders.is_some() {
            "   random orders: transl. [m]      rot. [rad]"
        } else {
            ""
        }
    );
    for p in &c.curve {
        let spread = orders
            .and_then(|o| o.curve.iter().find(|s| s.intervals == p.intervals))
            .map_or(String::new(), |s| {
                let f = |v: [f64; 3]| format!("{:.4} [{:.4}, {:.4}]", v[1], v[0], v[2]);
                format!("   {}  {}", f(s.translational_m), f(s.rotational_rad))
            });
        outln!(
            "{:>10.1} {:>10} {:>18.4} {:>18.4}{spread}",
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
        None if c.curve.len() < 2 => outln!(
            "convergence time: none (a curve of {} point has no gradient to meet the rule with: too few training intervals)",
            c.curve.len()
        ),
        None => outln!("convergence time: none (the curve never meets the rule)"),
    }
    if let Some(o) = orders {
        match (o.convergence_time_s, o.median_convergence_time_s) {
            (Some([lo, _, hi]), Some(med)) => outln!(
                "over {} random orders: median {med:.1} s, range {lo:.1} to {hi:.1} s{}",
                o.orders,
                if o.never_converged > 0 {
                    format!(" ({} never converge)", o.never_converged)
                } else {
                    String::new()
                }
            ),
            (Some([lo, _, hi]), None) => outln!(
                "over {} random orders: median never ({} never converge; the others from {lo:.1} to {hi:.1} s)",
                o.orders,
                o.never_converged
            ),
            (None, _) => outln!("over {} random orders: none converges", o.orders),
        }
    }
    Ok(())
}
