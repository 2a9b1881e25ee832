//! `drive report` draws any part through its own traits (issue 32): a powertrain written
//! outside the crates shows its own parameters (`Powertrain::parameters`) and its own
//! response in the powertrain figure; the vehicle's geometry comes from
//! `CommandModel::geometry`.

use drive::report::{Report, ReportOptions};
use drive::serde::{Deserialize, Serialize};
use drive::studies::report::ReportAnalysis;
use drive::studies::Registries;
use drive::traits::{FitError, Input, Powertrain, PowertrainLearner, Tagged, WindowSet};
use drive::typetag;
use std::sync::Arc;

/// Each step, the wheels move `share` of the way to the command.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(crate = "drive::serde")]
struct HalfWay {
    share: f64,
}

impl Tagged for HalfWay {
    const TAG: &'static str = "half-way";
}

#[typetag::serde(name = "half-way")]
impl Powertrain for HalfWay {
    fn predict_into(&self, initial: &Input, commands: &[Input], predicted: &mut Vec<Input>) {
        predicted.clear();
        let mut u = *initial;
        for c in commands {
            predicted.push(u);
            u += self.share * (c - u);
        }
    }
    fn parameters(&self) -> Vec<(String, f64)> {
        vec![("share per step".into(), self.share)]
    }
    fn clone_box(&self) -> Box<dyn Powertrain> {
        Box::new(self.clone())
    }
}

/// Least squares of `u[k+1] - u[k] = share (c[k] - u[k])` on the measured inputs.
struct HalfWayLearner;

impl PowertrainLearner for HalfWayLearner {
    type Fitted = HalfWay;
    fn fit(&self, train: &WindowSet<'_>) -> Result<HalfWay, FitError> {
        let (mut num, mut den) = (0.0, 0.0);
        for w in &train.windows {
            for k in 1..w.len() {
                let gap = w.command[k - 1] - w.measured[k - 1];
                num += (w.measured[k] - w.measured[k - 1]).dot(&gap);
                den += gap.dot(&gap);
            }
        }
        if den == 0.0 {
            return Err(FitError::EmptyTrainingSet);
        }
        Ok(HalfWay {
            share: (num / den).clamp(0.0, 1.0),
        })
    }
}

#[test]
fn the_report_shows_a_plug_in_powertrains_own_parameters_and_response() {
    let mut registries = Registries::builtin();
    registries
        .powertrains
        .register(
            "half-way",
            "moves a share of the way each step",
            Arc::new(HalfWayLearner),
        )
        .unwrap();
    let data = drive::studies::simulate_protocol(&registries, "husky", "gravel", "uniform", 14, 5)
        .unwrap()
        .dataset;
    let options = ReportOptions {
        models: vec!["naive".into(), "slip-blr+half-way".into()],
        model: "slip-blr+half-way".into(),
        draws: 2,
        ..ReportOptions::default()
    };
    let report = Report::new(ReportAnalysis::build(&registries, &data, &options).unwrap());

    // The parameters as the plug-in lists them, next to slip-BLR's own.
    let fitted = report
        .fitted
        .iter()
        .find(|f| f.model == "slip-blr+half-way")
        .expect("the plug-in model's parameters");
    let share = fitted
        .parameters
        .iter()
        .find(|(name, _)| name == "powertrain: share per step")
        .map(|(_, v)| *v)
        .expect("the plug-in powertrain's parameter");
    assert!(share > 0.0 && share < 1.0, "{share}");
    assert!(fitted
        .parameters
        .iter()
        .any(|(name, _)| name == "longitudinal slip: w[f_x]"));
    let md = report.markdown();
    assert!(md.contains("| powertrain: share per step |"), "{md}");
    assert!(md.contains("| wheel_radius | 0.1650 |"), "{md}");

    // The powertrain figure draws the plug-in's response: its label, and each window's
    // trace is the fitted powertrain's prediction from the measured input.
    let trace = &report.powertrain;
    assert!(
        trace.powertrain.starts_with("half-way"),
        "{}",
        trace.powertrain
    );
    let model = report
        .comparison
        .models
        .iter()
        .find(|m| m.name == "slip-blr+half-way")
        .and_then(|m| m.fitted.as_deref())
        .unwrap();
    let powertrain = model.powertrain().expect("a composed model's powertrain");
    assert_eq!(
        powertrain.parameters(),
        vec![("share per step".into(), share)]
    );
    let (_, eval) = drive::eval::split_by_interval(&data, options.split).unwrap();
    let first = eval
        .windows
        .iter()
        .find(|w| w.phase == drive::traits::Phase::Transient)
        .unwrap();
    let expected = powertrain.predict(&first.measured[0], &first.command);
    assert_eq!(&trace.modeled[..first.len()], &expected[..]);
}
