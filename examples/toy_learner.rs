//! A researcher's own learner and sampler in the evaluation matrix, from outside the
//! workspace's crates: implement the traits, register each under a name (one line each),
//! and every combination of the sweep includes them.
//!
//! Run with `cargo run --release --example toy_learner`.
//!
//! The toy learner, `scaled-drive`, is eq. 4 on the commands with one least-squares gain per
//! body dimension (forward speed and yaw rate) from the measured body velocities: a crude
//! slip model with no powertrain. The toy sampler, `forward-only`, draws uniformly over the
//! part of the input space where both wheels turn forward.

use drive::eval::{run_matrix, SweepFile};
use drive::models::rollout::integrate;
use drive::models::velocity::BodyVelocityEstimator;
use drive::models::{DifferentialDrive, LearnerRegistry};
use drive::samplers::{SamplerContext, SamplerRegistry, UniformSampler};
use drive::traits::{
    BodyVelocity, FitError, Input, Learner, MotionModel, Pose, StartState, WindowSet,
};
use serde::{Deserialize, Serialize};

/// The unfitted configuration (no hyperparameters).
#[derive(Debug, Clone, Copy, Default)]
struct ScaledDrive;

/// The fitted model: eq. 4 scaled by `gain_x` (forward) and `gain_yaw` (yaw rate).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct ScaledDriveModel {
    vehicle: DifferentialDrive,
    gain_x: f64,
    gain_yaw: f64,
    dt: f64,
}

impl Learner for ScaledDrive {
    type Fitted = ScaledDriveModel;

    fn fit(&self, train: &WindowSet<'_>) -> Result<ScaledDriveModel, FitError> {
        if train.is_empty() {
            return Err(FitError::EmptyTrainingSet);
        }
        let vehicle = DifferentialDrive::from_robot(train.robot);
        let dt = train.robot.dt();
        // Least squares through the origin: gain = sum(f v) / sum(f f) per dimension.
        let (mut fv, mut ff) = ([0.0; 2], [0.0; 2]);
        let mut measured = Vec::new();
        for w in &train.windows {
            BodyVelocityEstimator::default().estimate(w, dt, &mut measured);
            for (u, v) in w.command.iter().zip(&measured) {
                let Some(v) = v else { continue };
                let f = vehicle.eq4(u);
                for (j, d) in [0usize, 2].into_iter().enumerate() {
                    fv[j] += f[d] * v[d];
                    ff[j] += f[d] * f[d];
                }
            }
        }
        let gain = |j: usize| if ff[j] > 0.0 { fv[j] / ff[j] } else { 1.0 };
        Ok(ScaledDriveModel {
            vehicle,
            gain_x: gain(0),
            gain_yaw: gain(1),
            dt,
        })
    }
}

#[typetag::serde(name = "scaled-drive")]
impl MotionModel for ScaledDriveModel {
    fn name(&self) -> &'static str {
        "scaled-drive"
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>) {
        let v: Vec<BodyVelocity> = commands
            .iter()
            .map(|u| {
                let f = self.vehicle.eq4(u);
                BodyVelocity::new(self.gain_x * f.x, 0.0, self.gain_yaw * f.z)
            })
            .collect();
        integrate(&start.pose, &v, self.dt, poses);
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // The one place each new piece is registered.
    let mut learners = LearnerRegistry::builtin();
    learners.register("scaled-drive", ScaledDrive)?;
    let mut samplers = SamplerRegistry::builtin();
    samplers.register("forward-only", |ctx: &SamplerContext<'_>| {
        let mut space = ctx.space;
        space.min.x = space.min.x.max(0.0);
        space.min.y = space.min.y.max(0.0);
        Ok(Box::new(UniformSampler::new(space, ctx.seed)?))
    })?;

    let sweep = SweepFile::parse(
        "toy sweep",
        r#"
        learners = ["naive", "slip-blr", "scaled-drive"]
        powertrains = ["fopdt"]
        baseline = "naive"
        [[datasets]]
        bundled = "husky"
        [simulated]
        robots = ["husky"]
        terrains = ["gravel", "ice"]
        samplers = ["uniform", "forward-only"]
        durations = [120]
        seeds = [1, 2]
        "#,
    )?;
    let plan = sweep.plan(
        &learners,
        &samplers,
        &|source| match source.bundled.as_deref() {
            Some("husky") => drive::bundled::husky().map_err(|e| e.to_string()),
            _ => Err("this example knows the bundled Husky data only".into()),
        },
    )?;
    let result = run_matrix(&plan, &learners, &samplers, &|_, _| {})?;
    print!("{}", result.to_markdown());
    Ok(())
}
