//! A vehicle's own slip inputs for slip-BLR (eq. 5): which functions of the commanded
//! body velocity each slip dimension is linear in, when none of the built-in bases (the
//! paper's skid-steer, the car's, the omnidirectional base's) describes how it slips.

use crate::BodyVelocity;

/// The most slip inputs one regression of a [`SlipFeatures`] basis may have.
pub const MAX_SLIP_INPUTS: usize = 4;

/// The slip inputs of one commanded body velocity, per regression (longitudinal, lateral,
/// angular); only the first [`SlipFeatures::dimensions`] of each row are read.
pub type SlipInputRows = [[f64; MAX_SLIP_INPUTS]; 3];

/// A slip-BLR basis of one's own (eq. 5): the slip inputs of the longitudinal, lateral and
/// angular regressions as functions of the commanded body velocity `f = (v_x, v_y, w)`.
///
/// A vehicle provides one through
/// [`CommandModel::slip_features`](crate::CommandModel::slip_features); slip-BLR then fits
/// it instead of the basis its [`Steering`](crate::Steering) would choose, and its model
/// files save it (a typetag trait object, `#[typetag::serde(name = "...")]`).
///
/// ```
/// use drive_traits::{BodyVelocity, SlipFeatures, SlipInputRows};
/// use serde::{Deserialize, Serialize};
///
/// /// A rover's slip: forward, a share of its crab, and its turn scrubbing.
/// #[derive(Debug, Clone, Serialize, Deserialize)]
/// struct RoverSlip;
///
/// #[typetag::serde(name = "rover-slip-doc")]
/// impl SlipFeatures for RoverSlip {
///     fn dimensions(&self) -> [usize; 3] { [1, 2, 2] }
///     fn names(&self) -> [Vec<String>; 3] {
///         [vec!["f_x".into()], vec!["f_y".into(), "f_x f_w".into()], vec!["f_w".into(), "f_y".into()]]
///     }
///     fn inputs(&self, f: &BodyVelocity) -> SlipInputRows {
///         [[f.x, 0.0, 0.0, 0.0], [f.y, f.x * f.z, 0.0, 0.0], [f.z, f.y, 0.0, 0.0]]
///     }
///     fn clone_box(&self) -> Box<dyn SlipFeatures> { Box::new(RoverSlip) }
/// }
///
/// let rows = RoverSlip.inputs(&BodyVelocity::new(1.0, 0.5, 2.0));
/// assert_eq!(rows[1][..2], [0.5, 2.0]);
/// assert!(drive_traits::check_slip_features(&RoverSlip).is_ok());
/// ```
#[typetag::serde(tag = "type")]
pub trait SlipFeatures: std::fmt::Debug + Send + Sync {
    /// The number of slip inputs of the longitudinal, lateral and angular regressions
    /// (each 1 to [`MAX_SLIP_INPUTS`]).
    fn dimensions(&self) -> [usize; 3];

    /// The slip inputs' names per regression, for reports (`f_x f_w`, ...).
    fn names(&self) -> [Vec<String>; 3];

    /// The slip inputs of the commanded body velocity `f`, per regression (the first
    /// [`dimensions`](Self::dimensions) of each row).
    fn inputs(&self, f: &BodyVelocity) -> SlipInputRows;

    /// Boxed clone.
    fn clone_box(&self) -> Box<dyn SlipFeatures>;
}

/// `Err` naming what is wrong when a basis's dimensions are outside 1 to
/// [`MAX_SLIP_INPUTS`] or its names do not match them.
pub fn check_slip_features(basis: &dyn SlipFeatures) -> Result<(), crate::InvalidPart> {
    let dims = basis.dimensions();
    let names = basis.names();
    for ((k, names), what) in dims
        .iter()
        .zip(&names)
        .zip(["longitudinal", "lateral", "angular"])
    {
        if !(1..=MAX_SLIP_INPUTS).contains(k) {
            return Err(crate::InvalidPart(format!(
                "the slip basis {basis:?} gives the {what} slip {k} inputs: 1 to {MAX_SLIP_INPUTS} are supported"
            )));
        }
        if names.len() != *k {
            return Err(crate::InvalidPart(format!(
                "the slip basis {basis:?} names {} {what} slip inputs where it has {k}",
                names.len()
            )));
        }
    }
    Ok(())
}
