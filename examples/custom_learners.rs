//! Configure learners beyond the registry's defaults and compare them on the bundled data.
//!
//! Run with `cargo run --release --features examples --example custom_learners`.

use drive::eval::{evaluate_model, split_by_interval};
use drive::models::baselines::AccBlr;
use drive::models::powertrain::{Commanded, Fopdt, RateLimited};
use drive::models::slip::{NoSlip, SlipBlr};
use drive::models::Composed;
use drive::traits::{Baseline, BodyVelocityEstimator, Learner, MotionModel};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let data = drive::bundled::husky()?;
    let (train, eval) = split_by_interval(&data, 0.5)?;
    let span = |span_s| SlipBlr {
        velocity: BodyVelocityEstimator { span_s },
        ..SlipBlr::default()
    };

    // The naive model, the paper's slip-BLR, the same on the commanded wheel velocities (no
    // powertrain) or on a rate-limited powertrain, a weak prior (phi = 1 halves the
    // posterior mean, eq. 6), other velocity spans, and the acceleration baseline.
    let candidates: Vec<(&str, Box<dyn MotionModel>)> = vec![
        (
            "naive",
            Box::new(Composed::new(Commanded, NoSlip).fit(&train)?),
        ),
        (
            "slip-blr (paper)",
            Box::new(Composed::new(Fopdt::default(), SlipBlr::default()).fit(&train)?),
        ),
        (
            "slip-blr, no powertrain",
            Box::new(Composed::new(Commanded, SlipBlr::default()).fit(&train)?),
        ),
        (
            "slip-blr, rate-limited powertrain",
            Box::new(Composed::new(RateLimited::default(), SlipBlr::default()).fit(&train)?),
        ),
        (
            "slip-blr, phi = 1",
            Box::new(
                Composed::new(Fopdt::default(), SlipBlr::default().with_phi(1.0)).fit(&train)?,
            ),
        ),
        (
            "slip-blr, 0.1 s velocity span",
            Box::new(Composed::new(Fopdt::default(), span(0.1)).fit(&train)?),
        ),
        (
            "slip-blr, 0.4 s velocity span",
            Box::new(Composed::new(Fopdt::default(), span(0.4)).fit(&train)?),
        ),
        (
            "acc-blr",
            AccBlr::default().fit_with(&train, Some(&Commanded))?,
        ),
    ];

    println!(
        "{:<36} {:>18} {:>18}",
        "model", "translational [m]", "rotational [rad]"
    );
    for (label, model) in &candidates {
        let report = evaluate_model(model.as_ref(), &eval);
        // The evaluation half is not empty, so both summaries exist.
        let (t, r) = (
            report.translational(None).unwrap(),
            report.rotational(None).unwrap(),
        );
        println!("{label:<36} {:>18.4} {:>18.4}", t.median, r.median);
    }
    Ok(())
}
