//! `drive compare-protocols`: the paper's Table I, on the simulator or on recorded data.

use anyhow::{bail, Context, Result};
use drive::eval::{
    compare_protocols, compare_regions, ProtocolComparison, ProtocolStudy, RegionComparison,
    RegionStudy,
};
use drive::samplers::{RobotSpec, SAMPLER_NAMES};
use drive::sim::Terrain;
use drive::traits::Dataset;

/// The simulated study's options, as given on the command line.
pub struct SimulatedArgs<'a> {
    pub robots: &'a [String],
    pub terrains: &'a [String],
    pub samplers: &'a [String],
    pub durations: &'a [f64],
    pub seeds: usize,
    pub first_seed: u64,
    pub test_duration: Option<f64>,
    pub model: &'a str,
    pub json: bool,
}

fn names(list: &[String]) -> Vec<&str> {
    list.iter()
        .map(|s| s.trim())
        .filter(|s| !s.is_empty())
        .collect()
}

/// Table I on the simulator.
pub fn simulated(args: &SimulatedArgs<'_>) -> Result<()> {
    let robots = names(args.robots)
        .into_iter()
        .map(RobotSpec::load)
        .collect::<Result<Vec<_>, _>>()?;
    let terrains = names(args.terrains)
        .into_iter()
        .map(|t| {
            Terrain::preset(t).with_context(|| {
                format!(
                    "unknown terrain '{t}' (the terrains are: {})",
                    Terrain::NAMES.join(", ")
                )
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let samplers = names(args.samplers);
    if let Some(s) = samplers.iter().find(|s| !SAMPLER_NAMES.contains(s)) {
        bail!(
            "unknown sampler '{s}' (the samplers are: {})",
            SAMPLER_NAMES.join(", ")
        );
    }
    if args.seeds == 0 {
        bail!("--seeds must be at least 1");
    }
    if let Some(d) = args
        .durations
        .iter()
        .find(|d| !(d.is_finite() && **d > 0.0))
    {
        bail!("--duration must be positive seconds of driving, got {d}");
    }
    let longest = args.durations.iter().copied().fold(0.0, f64::max);
    let study = ProtocolStudy {
        robots,
        terrains,
        samplers: samplers.iter().map(|s| s.to_string()).collect(),
        driving_s: args.durations.to_vec(),
        seeds: (0..args.seeds as u64)
            .map(|i| args.first_seed + i)
            .collect(),
        test_driving_s: args.test_duration.unwrap_or(longest.max(300.0)),
        model: args.model.to_string(),
    };
    let table = compare_protocols(&study)?;
    if args.json {
        println!("{}", serde_json::to_string(&table)?);
    } else {
        print!("{}", simulated_table(&table));
    }
    Ok(())
}

fn simulated_table(t: &ProtocolComparison) -> String {
    use std::fmt::Write as _;
    let seeds = t.rows.first().map_or(0, |r| r.seeds);
    let mut out = format!(
        "Protocols compared on the simulator (paper Table I): {} trained on each run, all tested on one {:.0} s {} run per seed ({seeds} seed{}); errors are medians of eq. 8 over the test windows{}\n",
        t.model,
        t.test_driving_s,
        t.reference,
        if seeds == 1 { "" } else { "s" },
        if seeds == 1 { "" } else { ", then over the seeds" },
    );
    let _ = writeln!(
        out,
        "{:<8} {:<7} {:>7} {:<18} {:>12} {:>12} {:>30}",
        "robot",
        "terrain",
        "driving",
        "sampler",
        "transl. [m]",
        "rot. [rad]",
        format!("{} better by", t.reference)
    );
    for r in &t.rows {
        let better = if r.sampler == t.reference {
            "-".to_string()
        } else {
            let wins = if r.seeds > 1 {
                format!(
                    " ({}/{}, {}/{})",
                    r.reference_wins_translational, r.seeds, r.reference_wins_rotational, r.seeds
                )
            } else {
                String::new()
            };
            format!(
                "{:+.1}% / {:+.1}%{wins}",
                r.reference_improvement_translational_percent,
                r.reference_improvement_rotational_percent
            )
        };
        let _ = writeln!(
            out,
            "{:<8} {:<7} {:>6.0}s {:<18} {:>12.4} {:>12.4} {:>30}",
            r.robot,
            r.terrain,
            r.driving_s,
            r.sampler,
            r.translational_median_m,
            r.rotational_median_rad,
            better
        );
    }
    // The paper's two headline figures, averaged over every robot, terrain and duration.
    let mean = |sampler: &str, f: fn(&drive::eval::ProtocolRow) -> f64| {
        let v: Vec<f64> = t
            .rows
            .iter()
            .filter(|r| r.sampler == sampler)
            .map(f)
            .collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    if let Some(a) = mean("angular", |r| r.reference_improvement_translational_percent) {
        let _ = writeln!(
            out,
            "mean improvement of {} over angular in translation: {a:+.1}% (paper: 31.8%)",
            t.reference
        );
    }
    if let Some(l) = mean("linear", |r| r.reference_improvement_rotational_percent) {
        let _ = writeln!(
            out,
            "mean improvement of {} over linear in rotation: {l:+.1}% (paper: 43.6%)",
            t.reference
        );
    }
    out
}

/// Table I on recorded data.
pub fn recorded(data: &Dataset, study: &RegionStudy, json: bool) -> Result<()> {
    crate::emit(json, &compare_regions(data, study)?, recorded_table)
}

fn recorded_table(t: &RegionComparison) -> String {
    use std::fmt::Write as _;
    let mut out = format!(
        "Protocols compared on recorded data (paper Table I): {} from {}, {} training intervals, {} evaluation windows\n\
         input space of the training commands [{:.2}, {:.2}] x [{:.2}, {:.2}] rad/s (top speed {:.3} m/s, turning in place {:.3} rad/s)\n",
        t.model,
        t.dataset,
        t.train_intervals,
        t.eval_windows,
        t.input_space[0][0],
        t.input_space[0][1],
        t.input_space[1][0],
        t.input_space[1][1],
        t.top_speed_m_s,
        t.turn_rate_rad_s,
    );
    let _ = writeln!(
        out,
        "{:<8} {:>9} {:>22} {:>26} {:>20}",
        "region",
        "intervals",
        "region [m / rad]",
        format!("uniform x{} [m / rad]", t.draws),
        "uniform better by"
    );
    for r in &t.regions {
        let _ = writeln!(
            out,
            "{:<8} {:>9} {:>22} {:>26} {:>20}",
            r.region,
            r.intervals,
            format!(
                "{:.4} / {:.4}",
                r.region_translational.median, r.region_rotational.median
            ),
            format!(
                "{:.4} / {:.4}",
                r.uniform_translational_median_m, r.uniform_rotational_median_rad
            ),
            format!(
                "{:+.1}% / {:+.1}%",
                r.improvement_translational_percent, r.improvement_rotational_percent
            ),
        );
    }
    for r in &t.regions {
        let _ = writeln!(out, "{} region: {}", r.region, r.definition);
    }
    let _ = writeln!(
        out,
        "uniform: as many intervals drawn at random from all training intervals, {} draws (median of their medians)",
        t.draws
    );
    out
}
