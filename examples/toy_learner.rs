//! A researcher's own whole-model learner and sampler in the evaluation matrix, through the
//! library: implement the traits, register each under a name (one line each), and every
//! combination of the sweep includes them. (`examples/plugin/` does the same for a slip
//! learner, a powertrain, a sampler and a vehicle, and runs the whole command line.)
//!
//! Run with `cargo run --release --features examples --example toy_learner`.
//!
//! The toy learner, `scaled-drive`, is the vehicle's command model on the commands with one
//! least-squares gain per body dimension (forward speed and yaw rate) from the measured
//! body velocities: a crude slip model with no powertrain, written as a baseline. The toy
//! sampler, `forward-only`, draws uniformly over the part of the input space where both
//! inputs are positive.

use drive::models::rollout::integrate;
use drive::samplers::{SamplerContext, UniformSampler};
use drive::studies::{run_matrix, SweepFile};
use drive::traits::{
    BodyVelocity, BodyVelocityEstimator, CommandModel, FitError, Input, InputSampler, Learner,
    MotionModel, Pose, StartState, Tagged, WindowSet,
};
use drive::Registries;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// The unfitted configuration (no hyperparameters).
#[derive(Debug, Clone, Copy, Default)]
struct ScaledDrive;

/// The fitted model: the command model scaled by `gain_x` (forward) and `gain_yaw` (yaw rate).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct ScaledDriveModel {
    vehicle: Arc<dyn CommandModel>,
    gain_x: f64,
    gain_yaw: f64,
    dt: f64,
}

impl Tagged for ScaledDriveModel {
    const TAG: &'static str = "scaled-drive";
}

impl Learner for ScaledDrive {
    type Fitted = ScaledDriveModel;

    fn fit(&self, train: &WindowSet<'_>) -> Result<ScaledDriveModel, FitError> {
        if train.is_empty() {
            return Err(FitError::EmptyTrainingSet);
        }
        let vehicle = Arc::clone(&train.robot.vehicle);
        let dt = train.robot.dt();
        // Least squares through the origin: gain = sum(f v) / sum(f f) per dimension.
        let (mut fv, mut ff) = ([0.0; 2], [0.0; 2]);
        let mut measured = Vec::new();
        for w in &train.windows {
            BodyVelocityEstimator::default().estimate(w, dt, &mut measured);
            for (u, v) in w.command.iter().zip(&measured) {
                let Some(v) = v else { continue };
                let f = vehicle.body_velocity(u);
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
    fn name(&self) -> String {
        "scaled-drive".into()
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn predict_into(&self, start: &StartState, commands: &[Input], poses: &mut Vec<Pose>) {
        let v: Vec<BodyVelocity> = commands
            .iter()
            .map(|u| {
                let f = self.vehicle.body_velocity(u);
                BodyVelocity::new(self.gain_x * f.x, 0.0, self.gain_yaw * f.z)
            })
            .collect();
        integrate(&start.pose, &v, self.dt, poses);
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // The one place each new piece is registered.
    let mut registries = Registries::builtin();
    registries.baselines.register(
        "scaled-drive",
        "the command model with a least-squares gain per body dimension",
        Arc::new(ScaledDrive),
    )?;
    registries.samplers.register(
        "forward-only",
        "uniform where both inputs are positive",
        Arc::new(|ctx: &SamplerContext<'_>| {
            let mut space = ctx.space;
            space.min.x = space.min.x.max(0.0);
            space.min.y = space.min.y.max(0.0);
            Ok(Box::new(UniformSampler::new(space, ctx.seed)?) as Box<dyn InputSampler>)
        }),
    )?;

    let sweep = SweepFile::parse(
        "toy sweep",
        r#"
        learners = ["naive", "slip-blr", "scaled-drive"]
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
    let plan = sweep.plan(&registries, &|source| match source.bundled.as_deref() {
        Some("husky") => drive::bundled::husky().map_err(Into::into),
        _ => Err("this example knows the bundled Husky data only".into()),
    })?;
    let result = run_matrix(&plan, &registries, &|_, _| {})?;
    print!("{}", result.to_markdown());
    Ok(())
}
