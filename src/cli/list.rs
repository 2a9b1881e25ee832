//! `drive list`: the registered parts and the bundled datasets.

use super::common::emit;
use crate::studies::{Catalog, Listed};
use crate::Registries;
use anyhow::Result;
use serde::Serialize;
use std::fmt::Write as _;

#[derive(clap::Args)]
pub struct Args {
    /// Print one JSON object (lists vehicles, powertrains, learners, samplers, terrains,
    /// robots, simulators, controllers, models, datasets) instead of the text.
    #[arg(long)]
    json: bool,
}

/// A bundled dataset as listed.
#[derive(Serialize)]
struct ListedDataset {
    /// `bundled:NAME`.
    name: String,
    robot: &'static str,
    terrain: &'static str,
    windows: usize,
    description: &'static str,
}

/// The registered parts and the bundled datasets.
#[derive(Serialize)]
struct Listing {
    #[serde(flatten)]
    catalog: Catalog,
    datasets: Vec<ListedDataset>,
}

pub fn run(args: &Args, registries: &Registries) -> Result<()> {
    let datasets = crate::bundled::BUNDLED
        .iter()
        .map(|b| ListedDataset {
            name: format!("{}{}", crate::bundled::PREFIX, b.name),
            robot: b.robot,
            terrain: b.terrain,
            windows: b.windows,
            description: b.description,
        })
        .collect();
    let listing = Listing {
        catalog: registries.catalog(),
        datasets,
    };
    emit(args.json, &listing, text)
}

fn text(l: &Listing) -> String {
    let c = &l.catalog;
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
            if let Some(axes) = &i.axes {
                extra.push(format!("{} inputs: {}", axes.len(), axes.join(", ")));
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
    section(&mut s, "controllers (drive track)", &c.controllers);
    let _ = writeln!(s, "models ({}): {}", c.models.len(), c.models.join(", "));
    let _ = writeln!(
        s,
        "\ndatasets (bundled; --data bundled:NAME, or path = \"bundled:NAME\" in a suite):"
    );
    let width = l.datasets.iter().map(|d| d.name.len()).max().unwrap_or(0) + 2;
    for d in &l.datasets {
        let _ = writeln!(
            s,
            "  {:<width$}{} windows, robot {}, terrain {}: {}",
            d.name,
            d.windows,
            d.robot,
            if d.terrain.is_empty() {
                "not recorded"
            } else {
                d.terrain
            },
            d.description
        );
    }
    s
}
