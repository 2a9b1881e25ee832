//! The DRIVE protocol's inputs (Sec. III-A): robot descriptions, input-space samplers and
//! the command schedule. All samplers are seeded and deterministic: a seed gives the same
//! sequence on every platform (the generator is xoshiro256++, a fixed algorithm).

#![warn(missing_docs)]

mod others;
mod robot;
mod runner;
mod schedule;
mod targeted;
mod uniform;

pub use others::{AngularSampler, GridSampler, LinearSampler};
pub use robot::{RobotError, RobotSpec};
pub use runner::{
    Characterization, Characterize, PauseReason, ProtocolRunner, RunnerConfig, RunnerInput,
    RunnerOutput, RunnerState, SampleTag, StopReason,
};
pub use schedule::{
    limit_acceleration, schedule, schedule_csv, window_len, ScheduledCommand, WINDOWS_PER_INTERVAL,
    WINDOW_S,
};
pub use targeted::{Target, TargetedSampler};
pub use uniform::{BodyLimits, SamplerError, UniformSampler};

use drive_traits::{CommandModel, InputSampler};

/// The names of the samplers, for the command line.
pub const SAMPLER_NAMES: [&str; 6] = [
    "uniform",
    "grid",
    "linear",
    "angular",
    "targeted",
    "targeted-coverage",
];

/// Builds the sampler registered under `name` for a robot over its input space; `vehicle`
/// maps inputs to body velocities (and back). The one place a new sampler is registered.
pub fn sampler_named(
    name: &str,
    robot: &RobotSpec,
    vehicle: impl Fn() -> Box<dyn CommandModel>,
    seed: u64,
) -> Result<Box<dyn InputSampler>, SamplerError> {
    sampler_over(name, robot.input_space(), robot, vehicle, seed)
}

/// Like [`sampler_named`] over a given input space (for instance the one found by the
/// characterization step).
pub fn sampler_over(
    name: &str,
    space: drive_traits::InputSpace,
    robot: &RobotSpec,
    vehicle: impl Fn() -> Box<dyn CommandModel>,
    seed: u64,
) -> Result<Box<dyn InputSampler>, SamplerError> {
    let uniform = |vehicle: Box<dyn CommandModel>| -> Result<Box<dyn InputSampler>, SamplerError> {
        let s = UniformSampler::new(space, seed)?;
        Ok(
            match (robot.controller_max_linear, robot.controller_max_angular) {
                (None, None) => Box::new(s),
                (lin, ang) => Box::new(s.with_body_limits(BodyLimits {
                    vehicle,
                    max_linear: lin.unwrap_or(f64::INFINITY),
                    max_angular: ang.unwrap_or(f64::INFINITY),
                })?),
            },
        )
    };
    Ok(match name {
        "uniform" => uniform(vehicle())?,
        "grid" => Box::new(GridSampler::new(space, 10, seed)?),
        "linear" => Box::new(LinearSampler::new(space, vehicle(), seed)),
        "angular" => Box::new(AngularSampler::new(space, vehicle(), seed)),
        "targeted" => Box::new(TargetedSampler::new(
            space,
            uniform(vehicle())?,
            Target::SlipVariance,
        )),
        "targeted-coverage" => Box::new(TargetedSampler::new(
            space,
            uniform(vehicle())?,
            Target::Coverage,
        )),
        other => return Err(SamplerError::Unknown(other.to_string())),
    })
}
