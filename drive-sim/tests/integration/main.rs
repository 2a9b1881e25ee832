//! drive-sim's integration tests, one binary (one link): one module per subject.

mod car;
mod physics;
mod raw_log;
mod runner;
mod targeted;

use drive_samplers::{build_sampler, builtin_samplers, RobotSpec, RunnerConfig, SamplerContext};
use drive_sim::{SimulationConfig, Terrain};
use drive_traits::{InputSampler, InputSpace};

/// The protocol run of `robot` on the preset `terrain` for `intervals` intervals, without
/// events.
fn config(
    robot: RobotSpec,
    terrain: &str,
    seed: u64,
    intervals: usize,
    name: &str,
) -> SimulationConfig {
    SimulationConfig {
        robot,
        terrain: Terrain::preset(terrain).unwrap(),
        seed,
        runner: RunnerConfig {
            max_intervals: Some(intervals),
            ..RunnerConfig::default()
        },
        events: vec![],
        name: name.into(),
    }
}

/// The uniform sampler of `spec` seeded with `seed`, as `simulate` takes it (a factory of the
/// input space the characterization finds).
fn uniform(spec: RobotSpec, seed: u64) -> impl FnMut(InputSpace) -> Box<dyn InputSampler> {
    sampler("uniform", spec, seed)
}

/// The built-in sampler `name` of `spec` seeded with `seed`, as `simulate` takes it.
fn sampler(
    name: &'static str,
    spec: RobotSpec,
    seed: u64,
) -> impl FnMut(InputSpace) -> Box<dyn InputSampler> {
    let samplers = builtin_samplers(std::sync::Arc::new(
        drive_models::slip::SlipBlrLeverage::default(),
    ));
    move |space| {
        // A built-in sampler over a characterized (non-empty) input space.
        build_sampler(
            &samplers,
            name,
            &SamplerContext::new(&spec, seed).over(space),
        )
        .unwrap()
    }
}
