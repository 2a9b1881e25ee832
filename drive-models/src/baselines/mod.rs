//! Baselines: whole motion-model learners that are not built from a slip model
//! (implementations of [`drive_traits::Baseline`]).
//!
//! | registry name | learner | fitted | model |
//! |---|---|---|---|
//! | `acc-blr` | [`AccBlr`] | [`AccBlrModel`] | acceleration BLR (McKinnon and Schoellig 2019) |

mod acc_blr;

pub use acc_blr::{AccBlr, AccBlrModel};
