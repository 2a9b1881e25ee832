//! `drive protocol`: the DRIVE command schedule of a robot with a sampler.

use crate::samplers::{build_sampler, schedule, schedule_csv, SamplerContext};
use crate::studies::INTERVAL_S;
use crate::traits::limits;
use crate::Registries;
use anyhow::{bail, Result};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// A registered robot (husky, hd2, warthog, ...; see drive list) or a robot TOML file.
    #[arg(long)]
    robot: String,
    /// Input sampler: uniform (DRIVE), grid, linear, angular, ... (see drive list).
    #[arg(long, default_value = "uniform")]
    sampler: String,
    /// Number of 6 s intervals.
    #[arg(long, allow_negative_numbers = true)]
    intervals: usize,
    /// Seed of the sampler.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0)]
    seed: u64,
    /// Output CSV: t,interval,phase and the vehicle's command columns.
    #[arg(long)]
    out: PathBuf,
    /// Most commands in the schedule (a guard against a mistyped --intervals).
    #[arg(long, allow_negative_numbers = true, default_value_t = limits::MAX_RUN_SAMPLES)]
    max_samples: usize,
}

pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    if args.intervals == 0 {
        bail!("--intervals must be at least 1");
    }
    let mut outputs = super::common::outputs_for(
        &super::common::robot_input(&args.robot),
        &[("--out", &args.out)],
    )?;
    // A name that says another kind of file (or a compressed one: the CSV is written as
    // text) is refused before any work.
    super::common::csv_output("--out", &args.out, "a schedule (CSV, uncompressed)", false)?;
    super::common::check_max_samples(args.max_samples)?;
    let spec = registries.robot(&args.robot)?;
    let samples = args.intervals as f64 * INTERVAL_S * spec.rate_hz;
    limits::at_most(
        "--intervals",
        args.intervals as f64,
        (args.max_samples as f64 / (INTERVAL_S * spec.rate_hz)).floor(),
        &format!(
            "{} commands at {} Hz are more than --max-samples {}",
            limits::Short(samples),
            spec.rate_hz,
            args.max_samples
        ),
    )?;
    let mut s = build_sampler(
        &registries.samplers,
        &args.sampler,
        &SamplerContext::new(&spec, args.seed),
    )?;
    if s.learns_from_windows() {
        say!(
            "note: the {} sampler chooses each input from the windows driven so far; a schedule planned offline has none, so it holds its warm-up draws throughout (drive simulate, or the protocol runner on the robot, gives it the windows)",
            args.sampler
        );
    }
    let rows = schedule(&spec, s.as_mut(), args.intervals);
    outputs.write(&args.out, schedule_csv(&spec, &rows))?;
    super::common::publish(outputs)?;
    say!(
        "{} commands ({} intervals, {:.0} s at {} Hz) for {} with the {} sampler; saved to {}",
        rows.len(),
        args.intervals,
        rows.len() as f64 / spec.rate_hz,
        spec.rate_hz,
        spec.name,
        args.sampler,
        args.out.display()
    );
    Ok(())
}
