//! Configure learners beyond the registry's defaults and compare them on the bundled data.
//!
//! Run with `cargo run --release --example custom_learners`.

use drive::eval::{evaluate_model, split_by_interval};
use drive::models::learners::{AccBlr, Naive, SlipBlr};
use drive::models::powertrain::{Fopdt, Ideal};
use drive::models::velocity::BodyVelocityEstimator;
use drive::traits::{Learner, MotionModel};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let data = drive::bundled::husky()?;
    let (train, eval) = split_by_interval(&data, 0.5)?;

    // The paper's slip-BLR, the same on the commanded wheel velocities (no powertrain),
    // a weak prior (phi = 1 halves the posterior mean, eq. 6), and a wider velocity span.
    let candidates: Vec<(&str, Box<dyn MotionModel>)> = vec![
        ("naive", Box::new(Naive.fit(&train)?)),
        (
            "slip-blr (paper)",
            Box::new(SlipBlr::<Fopdt>::default().fit(&train)?),
        ),
        (
            "slip-blr, no powertrain",
            Box::new(SlipBlr::<Ideal>::default().fit(&train)?),
        ),
        (
            "slip-blr, phi = 1",
            Box::new(SlipBlr::<Fopdt>::default().with_phi(1.0).fit(&train)?),
        ),
        (
            "slip-blr, 0.1 s velocity span",
            Box::new(
                SlipBlr {
                    velocity: BodyVelocityEstimator { span_s: 0.1 },
                    ..SlipBlr::<Fopdt>::default()
                }
                .fit(&train)?,
            ),
        ),
        (
            "slip-blr, 0.4 s velocity span",
            Box::new(
                SlipBlr {
                    velocity: BodyVelocityEstimator { span_s: 0.4 },
                    ..SlipBlr::<Fopdt>::default()
                }
                .fit(&train)?,
            ),
        ),
        ("acc-blr", Box::new(AccBlr::<Ideal>::default().fit(&train)?)),
    ];

    println!(
        "{:<32} {:>18} {:>18}",
        "model", "translational [m]", "rotational [rad]"
    );
    for (label, model) in &candidates {
        let report = evaluate_model(model.as_ref(), &eval);
        // The evaluation half is not empty, so both summaries exist.
        let (t, r) = (
            report.translational(None).unwrap(),
            report.rotational(None).unwrap(),
        );
        println!("{label:<32} {:>18.4} {:>18.4}", t.median, r.median);
    }
    Ok(())
}
