//! drive-sim's integration tests, one binary (one link): one module per subject.

mod car;
mod physics;
mod raw_log;
mod runner;
mod targeted;

use drive_samplers::{build_sampler, builtin_samplers, RobotSpec, SamplerContext};
use drive_traits::{InputSampler, InputSpace};

/// The uniform sampler of `spec` seeded with `seed`, as `simulate` takes it (a factory of the
/// input space the characterization finds).
fn uniform(spec: RobotSpec, seed: u64) -> impl FnMut(InputSpace) -> Box<dyn InputSampler> {
    let samplers = builtin_samplers();
    move |space| {
        // The built-in uniform sampler over a characterized (non-empty) input space.
        build_sampler(
            &samplers,
            "uniform",
            &SamplerContext::new(&spec, seed).over(space),
        )
        .unwrap()
    }
}
