//! The DRIVE protocol's inputs (Sec. III-A): robot descriptions, input-space samplers and
//! the command schedule. All samplers are seeded and deterministic: a seed gives the same
//! sequence on every platform (the generator is xoshiro256++, a fixed algorithm).

#![warn(missing_docs)]

mod others;
mod registry;
mod replay;
mod robot;
mod runner;
mod schedule;
mod targeted;
mod uniform;

pub use others::{AngularSampler, GridSampler, LinearSampler};
pub use registry::{build_sampler, builtin_samplers, MakeSampler, SamplerContext};
pub use replay::ReplaySampler;
pub use robot::{autorally, builtin_robots, ridgeback, BodySize, RobotError, RobotSpec};
pub use runner::{
    PauseReason, ProtocolRunner, RunnerConfig, RunnerInput, RunnerOutput, RunnerState, SampleTag,
    StopReason,
};
pub use schedule::{
    limit_acceleration, next_command, schedule, schedule_csv, window_len, ScheduledCommand,
    SentCommand, WINDOWS_PER_INTERVAL, WINDOW_S,
};
pub use targeted::{Target, TargetedSampler};
pub use uniform::{BodyLimits, SamplerError, UniformSampler};
