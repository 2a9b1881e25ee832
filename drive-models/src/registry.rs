//! The one place where model names map to learners: add a learner here and every command
//! (`drive eval --models`, `drive train --model`) knows it.

use crate::learners::{AccBlr, Naive, PowertrainAware, SlipBlr};
use crate::powertrain::Fopdt;
use drive_traits::{FitError, Learner, MotionModel, WindowSet};

/// The names of the registered models, in the order the comparison reports them.
pub const MODEL_NAMES: [&str; 4] = ["naive", "powertrain", "slip-blr", "acc-blr"];

/// Fits the model registered under `name` with its default configuration; `None` for an
/// unknown name.
///
/// ```no_run
/// # fn demo(train: &drive_traits::WindowSet<'_>) {
/// let model = drive_models::fit_named("slip-blr", train).expect("a registered name").unwrap();
/// assert_eq!(model.name(), "slip-blr");
/// # }
/// ```
pub fn fit_named(
    name: &str,
    train: &WindowSet<'_>,
) -> Option<Result<Box<dyn MotionModel>, FitError>> {
    fn boxed<L: Learner>(l: L, train: &WindowSet<'_>) -> Result<Box<dyn MotionModel>, FitError> {
        l.fit(train).map(|m| Box::new(m) as Box<dyn MotionModel>)
    }
    Some(match name {
        "naive" => boxed(Naive, train),
        "powertrain" => boxed(PowertrainAware::<Fopdt>::default(), train),
        "slip-blr" => boxed(SlipBlr::<Fopdt>::default(), train),
        "acc-blr" => boxed(AccBlr::default(), train),
        _ => return None,
    })
}
