//! The DRIVE protocol's inputs (Sec. III-A): robot descriptions, input-space samplers and
//! the command schedule. All samplers are seeded and deterministic: a seed gives the same
//! sequence on every platform (the generator is xoshiro256++, a fixed algorithm).

#![warn(missing_docs)]

mod others;
mod registry;
mod robot;
mod runner;
mod schedule;
mod targeted;
mod uniform;

pub use others::{AngularSampler, GridSampler, LinearSampler};
pub use registry::{SamplerContext, SamplerRegistry};
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

/// The names of the built-in samplers, in registration order (see [`SamplerRegistry`]).
pub const SAMPLER_NAMES: [&str; 6] = [
    "uniform",
    "grid",
    "linear",
    "angular",
    "targeted",
    "targeted-coverage",
];

/// Builds the built-in sampler registered under `name` for a robot over its input space;
/// `vehicle` maps inputs to body velocities (and back).
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
    SamplerRegistry::builtin().build(
        name,
        &SamplerContext {
            space,
            robot,
            vehicle: &vehicle,
            seed,
        },
    )
}
