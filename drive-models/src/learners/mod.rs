//! Motion-model learners (unfitted configurations) and the fitted models they return.

mod acc_blr;
mod naive;
mod powertrain_aware;
mod slip_blr;

pub use acc_blr::{AccBlr, AccBlrModel};
pub use naive::{Naive, NaiveModel};
pub use powertrain_aware::{PowertrainAware, PowertrainAwareModel};
pub use slip_blr::{slip_inputs, SlipBlr, SlipBlrModel, SlipInputs};
