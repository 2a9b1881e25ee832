//! The DRIVE motion models (Sec. III-B of Baril et al.), as parts composed into one model:
//!
//! | part | here | paper |
//! |---|---|---|
//! | vehicle | [`vehicles`] (drive-traits', re-exported): [`DifferentialDrive`] (eq. 4), [`vehicles::Ackermann`] (a car), [`vehicles::Omnidirectional`] (three inputs) | eq. 4 |
//! | powertrain | [`powertrain`]: commanded, FOPDT, rate-limited, the dead time's delay line | eq. 3 |
//! | slip model | [`slip`]: none, slip-BLR, slip-ipem ([`slip::ipem`]: nonlinear, fitted with argmin on multi-step errors) | eq. 5-7 |
//! | the composed model | [`Composed`] -> [`ComposedModel`], stepped one command at a time (`stepping.rs`) | eq. 1-2 |
//! | baselines | [`baselines`]: acc-BLR | Fig. 6 |
//! | uncertainty | [`calibration`] (calibrated regions, cross-conformal), [`difficulty`] (the learned difficulty) | eq. 7 |
//! | batches | [`batch`]: rollouts and stepped states on all cores | |
//! | adaptation | [`adapt`]: a fitted model's slip corrected online from the ground driven | eq. 5 |
//! | files | [`model_file`]: model files with the settings a model was fitted with, [`known_inputs`] (what a saved model knows of its inputs, and the notes a prediction beyond it earns), [`export`] (norlab_controllers' layout) | |
//!
//! Learners are unfitted configurations implementing the learner traits of
//! [`drive_traits`]; their `fit` returns a separate fitted type. [`registry`] names every part
//! and resolves model names such as `slip-blr+fopdt`.

#![warn(missing_docs)]

use drive_traits::InvalidPart;

pub mod adapt;
pub mod baselines;
pub mod batch;
mod blend;
pub mod blr;
pub mod calibration;
mod composed;
pub mod difficulty;
pub mod export;
pub mod known_inputs;
pub mod model_file;
pub mod powertrain;
pub mod registry;
pub mod rollout;
pub mod slip;
mod stepping;
/// The built-in vehicles, drive-traits' ([`drive_traits::vehicles`]): at the foundation, so
/// that data and robots name them without the models.
pub use drive_traits::vehicles;

pub use blend::BlendedModel;
pub use composed::{Composed, ComposedModel, GrowingFit};

/// Checks a fitted part's sample period read from a file: `Err` when the `part` (the
/// powertrain, the slip model) was fitted at another command period `step` than the
/// model's `dt` (its time constants or lags would be read in the wrong unit of steps).
pub(crate) fn check_same_step(part: &str, step: Option<f64>, dt: f64) -> Result<(), InvalidPart> {
    match step {
        Some(step) if (step - dt).abs() > 1e-9 * dt.abs().max(step.abs()) => {
            Err(InvalidPart::from(format!(
                "the {part}'s step {} s is not the model's {} s",
                drive_traits::limits::Short(step),
                drive_traits::limits::Short(dt)
            )))
        }
        _ => Ok(()),
    }
}

pub use registry::{LearnerKind, ModelAlias, ModelSpec, Models};
pub use vehicles::DifferentialDrive;
