//! `drive check`: the data-quality checks of `drive import` on a window CSV.

use super::common::{load, DataArgs};
use crate::data::quality::{check, to_text, Check, CHECKS};
use crate::import::stopping;
use crate::Registries;
use anyhow::{bail, Result};

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    data: DataArgs,
    /// The robot description (a registered robot or a TOML file), for the outside-limits
    /// check.
    #[arg(long)]
    robot: Option<String>,
    /// Checks whose fatal finding does not make the exit code 1, comma-separated.
    #[arg(long, value_delimiter = ',')]
    allow: Vec<String>,
    /// Print the findings as one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

/// `Err` for a name that is not a check's.
pub fn known_checks(names: &[String]) -> Result<()> {
    for n in names {
        if Check::from_key(n).is_none() {
            let keys: Vec<&str> = CHECKS.iter().map(|(k, _)| *k).collect();
            bail!(
                "--allow: no check {n:?} (the checks are: {})",
                keys.join(", ")
            );
        }
    }
    Ok(())
}

pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    known_checks(&args.allow)?;
    super::common::stdout_not_an_input(&args.data.inputs())?;
    let data = load(registries, &args.data)?;
    let robot = match &args.robot {
        Some(r) => Some(registries.robot(r)?),
        None => None,
    };
    let mut findings = check(&data, robot.as_ref().map(|r| r.input_space()).as_ref());
    if let Some(r) = &robot {
        findings.extend(crate::data::quality::vehicle_mismatch(
            data.robot.vehicle.as_ref(),
            r.vehicle.as_ref(),
            &r.name,
        ));
    }
    let of = super::common::robot_of(registries, &args.data, args.robot.as_deref(), &data)?;
    let u = crate::eval::unpredictability(
        &data,
        of.body,
        &crate::eval::UnpredictabilityConfig::default(),
    );
    let unpredictability = serde_json::json!({
        "translational": u.translational,
        "rotational": u.rotational,
        "total": u.total,
        "pooled": u.pooled,
        "body": of.body,
        "body_source": of.source,
    });
    if args.json {
        outln!(
            "{}",
            serde_json::json!({"dataset": data.robot.name, "windows": data.windows.len(), "checks": findings, "unpredictability": unpredictability})
        );
    } else {
        let median = |s: Option<crate::eval::UnpredictabilitySummary>| {
            s.map_or("-".to_string(), |s| format!("{:.3}", s.median))
        };
        out!(
            "{}: {} windows, {}\n{}the terrain's unpredictability (median over the {} windows; 0 moves as commanded, 1 does not move): translational {}, rotational {}, total {}{}\n",
            data.robot.name,
            data.windows.len(),
            if findings.is_empty() {
                "every check passed".to_string()
            } else {
                format!("{} finding(s)", findings.len())
            },
            to_text(&findings),
            u.pooled,
            median(u.translational),
            median(u.rotational),
            median(u.total),
            if of.body.is_some() {
                format!(" (body of the {})", of.source)
            } else {
                " (no body size for the total: --robot with body_length and body_width)".into()
            }
        );
    }
    if let Some(f) = stopping(&findings, &args.allow) {
        bail!(
            "check {}: {} (--allow {} to accept it)",
            f.check,
            f.message,
            f.check
        );
    }
    Ok(())
}
