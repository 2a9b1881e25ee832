//! Slip models (implementations of [`drive_traits::SlipModel`]) and their learners: a new
//! slip model is a new file here (or in a plug-in crate) and one registration.
//!
//! | registry name | learner | fitted | model |
//! |---|---|---|---|
//! | `no-slip` | [`NoSlip`] | [`NoSlipModel`] | `g = 0`: the vehicle does what it is commanded |
//! | `slip-blr` | [`SlipBlr`] | [`SlipBlrModel`] | the paper's slip-based BLR (eq. 5-7) |
//! | `slip-ipem` | [`SlipIpem`] | [`SlipIpemModel`] | slip nonlinear in the commanded body velocity with a body lag and an IMU yaw disturbance, fitted on multi-step rollout errors ([`ipem`]) |

pub mod ipem;
mod leverage;
mod none;
mod slip_blr;

pub use ipem::{slip_features, SlipIpem, SlipIpemModel};
pub use leverage::SlipBlrLeverage;
pub use none::{NoSlip, NoSlipModel};
pub use slip_blr::{
    car_slip_inputs, omni_slip_inputs, slip_inputs, CarSlipInputs, SlipBasis, SlipBlr,
    SlipBlrModel, SlipBlrOnline, SlipInputs,
};
