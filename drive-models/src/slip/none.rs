use drive_traits::{
    BodyVelocity, FitError, OnlineSlip, RobotDescription, SlipData, SlipLearner, SlipModel,
    SlipStepper, StatelessSlip, Tagged,
};
use serde::{Deserialize, Serialize};

/// No slip: the vehicle moves at the commanded body velocity (`g = 0` in eq. 2). On the
/// commanded powertrain this is the naive model (the manufacturer's), on the FOPDT the
/// paper's powertrain-aware model.
///
/// ```
/// use drive_models::slip::NoSlipModel;
/// use drive_traits::{BodyVelocity, SlipModel};
/// let f = BodyVelocity::new(1.0, 0.0, 0.3);
/// assert_eq!(NoSlipModel.slip(&f), BodyVelocity::zeros());
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct NoSlipModel;

impl Tagged for NoSlipModel {
    const TAG: &'static str = "no-slip";
}

#[typetag::serde(name = "no-slip")]
impl SlipModel for NoSlipModel {
    fn slip(&self, _f: &BodyVelocity) -> BodyVelocity {
        BodyVelocity::zeros()
    }

    fn body_velocities_into(&self, f: &[BodyVelocity], out: &mut Vec<BodyVelocity>) {
        out.clear();
        out.extend_from_slice(f);
    }

    fn stepper(&self) -> Option<Box<dyn SlipStepper + '_>> {
        Some(Box::new(StatelessSlip(self)))
    }

    fn clone_box(&self) -> Box<dyn SlipModel> {
        Box::new(*self)
    }
}

/// The learner of [`NoSlipModel`]: nothing to learn.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct NoSlip;

impl SlipLearner for NoSlip {
    type Fitted = NoSlipModel;
    fn fit(&self, _data: &SlipData<'_>) -> Result<NoSlipModel, FitError> {
        Ok(NoSlipModel)
    }

    fn online(&self, _robot: &RobotDescription) -> Option<Box<dyn OnlineSlip>> {
        Some(Box::new(NoSlip))
    }
}

/// Nothing to learn online either.
impl OnlineSlip for NoSlip {
    fn add(&mut self, _data: &SlipData<'_>) {}

    fn fitted(&self) -> Result<Box<dyn SlipModel>, FitError> {
        Ok(Box::new(NoSlipModel))
    }

    fn clone_box(&self) -> Box<dyn OnlineSlip> {
        Box::new(NoSlip)
    }
}
