//! The paper's slip-BLR as the targeted sampler's guide: where, fitted on the windows driven
//! so far, it is least sure of the slip.

use super::SlipBlr;
use crate::powertrain::Fopdt;
use drive_traits::{
    BodyVelocity, PowertrainLearner, SlipData, SlipLearner, SlipLeverage, WindowSet,
};

/// [`SlipLeverage`] of the paper's slip-BLR on the FOPDT powertrain, both with their default
/// settings: refitted on the windows given, its [`SlipBlrModel::leverage`](super::SlipBlrModel::leverage)
/// at each body velocity (the slip inputs of a command held steadily are those of its
/// commanded body velocity).
///
/// ```
/// use drive_models::slip::SlipBlrLeverage;
/// use drive_traits::{BodyVelocity, SlipLeverage, WindowSet};
/// let husky = drive_models::DifferentialDrive::new(0.165, 0.55);
/// let robot = drive_traits::RobotDescription::new("r", "", 20.0, 40, husky);
/// // No windows: nothing to fit, no leverage.
/// let none = WindowSet { robot: &robot, windows: vec![] };
/// assert!(SlipBlrLeverage::default().leverage(&none, &[BodyVelocity::zeros()]).is_none());
/// ```
#[derive(Debug, Clone, Default)]
pub struct SlipBlrLeverage {
    /// The powertrain fitted first.
    pub powertrain: Fopdt,
    /// The slip learner fitted on the powertrain's predictions.
    pub learner: SlipBlr,
}

impl SlipLeverage for SlipBlrLeverage {
    fn leverage(&self, windows: &WindowSet<'_>, at: &[BodyVelocity]) -> Option<Vec<f64>> {
        let powertrain = self.powertrain.fit(windows).ok()?;
        let model = self
            .learner
            .fit(&SlipData::new(windows, &powertrain))
            .ok()?;
        Some(at.iter().map(|f| model.leverage(f)).collect())
    }
}
