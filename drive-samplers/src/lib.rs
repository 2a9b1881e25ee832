//! The DRIVE protocol's inputs (Sec. III-A): input-space samplers and the command schedule
//! (the robots they run on are [`drive_traits::robot`]'s, re-exported here). All samplers
//! are seeded and deterministic: a seed gives the same sequence on every platform (the
//! generator is xoshiro256++, a fixed algorithm).

#![warn(missing_docs)]

mod others;
mod registry;
mod replay;
mod runner;
mod schedule;
mod targeted;
mod uniform;

/// The robots (at the foundation, [`drive_traits::robot`]), re-exported where the protocol
/// uses them.
pub use drive_traits::robot::{
    autorally, builtin_robots, ridgeback, BodyLimits, BodySize, RobotError, RobotSpec,
};
pub use others::{AngularSampler, GridSampler, LinearSampler};
pub use registry::{build_sampler, builtin_samplers, MakeSampler, SamplerContext};
pub use replay::ReplaySampler;
pub use runner::{
    PauseReason, ProtocolRunner, RunnerConfig, RunnerInput, RunnerOutput, RunnerState, SampleTag,
    StopReason,
};
pub use schedule::{
    limit_acceleration, next_command, schedule, schedule_csv, window_len, ScheduledCommand,
    SentCommand, WINDOWS_PER_INTERVAL, WINDOW_S,
};
pub use targeted::{Target, TargetedSampler};
pub use uniform::{SamplerError, UniformSampler};
