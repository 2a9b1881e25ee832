//! Which slip inputs suit a car: slip-BLR on the car basis (the default for an Ackermann
//! vehicle) against the paper's skid-steer basis forced on the same data, on the simulated
//! AutoRally over three terrains and five seeds (44 DRIVE intervals each, half to train).
//!
//! `cargo run --release --features examples --example car_slip_basis`; docs/car.md quotes it.

use drive::eval::{evaluate_model, split_by_interval};
use drive::models::powertrain::Fopdt;
use drive::models::slip::{SlipBasis, SlipBlr};
use drive::models::Composed;
use drive::studies::simulate_protocol;
use drive::traits::Learner;
use drive::Registries;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let registries = Registries::builtin();
    println!("terrain  seed  car basis [m / rad]   skid-steer basis [m / rad]");
    let mut wins = [0usize; 2];
    let mut runs = 0;
    for terrain in ["tile", "gravel", "snow"] {
        for seed in 1..=5 {
            let data =
                simulate_protocol(&registries, "autorally", terrain, "uniform", 44, seed)?.dataset;
            let (train, eval) = split_by_interval(&data, 0.5)?;
            let mut row = Vec::new();
            for basis in [SlipBasis::Car, SlipBasis::SkidSteer] {
                let learner = SlipBlr {
                    basis: Some(basis),
                    ..SlipBlr::default()
                };
                let model = Composed::new(Fopdt::default(), learner).fit(&train)?;
                let report = evaluate_model(&model, &eval);
                let median = |s: Option<drive::eval::Summary>| s.map_or(f64::NAN, |s| s.median);
                row.push([
                    median(report.translational(None)),
                    median(report.rotational(None)),
                ]);
            }
            for d in 0..2 {
                wins[d] += usize::from(row[0][d] < row[1][d]);
            }
            runs += 1;
            println!(
                "{terrain:<8} {seed:>4}  {:.4} / {:.4}       {:.4} / {:.4}",
                row[0][0], row[0][1], row[1][0], row[1][1]
            );
        }
    }
    println!(
        "the car basis is better in {} of {runs} runs in translation, {} of {runs} in rotation",
        wins[0], wins[1]
    );
    Ok(())
}
