//! `drive list`: the registered parts.

use super::common::emit;
use crate::eval::{Catalog, Listed};
use crate::Registries;
use anyhow::Result;
use std::fmt::Write as _;

#[derive(clap::Args)]
pub struct Args {
    /// Print one JSON object (lists vehicles, powertrains, learners, samplers, terrains,
    /// robots, simulators, models) instead of the text.
    #[arg(long)]
    json: bool,
}

pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    emit(args.json, &registries.catalog(), text)
}

fn text(c: &Catalog) -> String {
    let mut s = String::new();
    let section = |s: &mut String, title: &str, items: &[Listed]| {
        let _ = writeln!(s, "{title}:");
        let width = items.iter().map(|i| i.name.len()).max().unwrap_or(0) + 2;
        for i in items {
            let mut extra = Vec::new();
            if let Some(k) = &i.kind {
                extra.push(k.clone());
            }
            if let Some(m) = &i.means {
                extra.push(format!("= {m}"));
            }
            if let Some(p) = &i.default_powertrain {
                extra.push(format!("default powertrain {p}"));
            }
            if let Some(v) = &i.vehicle {
                extra.push(format!("vehicle {v}"));
            }
            let extra = if extra.is_empty() {
                String::new()
            } else {
                format!(" [{}]", extra.join(", "))
            };
            let _ = writeln!(s, "  {:<width$}{}{extra}", i.name, i.description);
        }
        let _ = writeln!(s);
    };
    section(&mut s, "vehicles", &c.vehicles);
    section(&mut s, "powertrains", &c.powertrains);
    section(
        &mut s,
        "learners (a model is LEARNER+POWERTRAIN, or a learner alone on its default powertrain)",
        &c.learners,
    );
    section(&mut s, "samplers", &c.samplers);
    section(&mut s, "terrains", &c.terrains);
    section(&mut s, "robots", &c.robots);
    section(
        &mut s,
        "simulators (by vehicle; others get the kinematic plant)",
        &c.simulators,
    );
    let _ = writeln!(s, "models ({}): {}", c.models.len(), c.models.join(", "));
    s
}
