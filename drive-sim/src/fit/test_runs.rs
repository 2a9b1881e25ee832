//! Simulated runs the stages' tests recover their grounds from.

use super::*;

/// A Husky run on gravel of `intervals` DRIVE intervals, seeded, on `terrain` (the stages'
/// tests simulate the ground they recover).
pub(super) fn husky_run(terrain: Terrain, intervals: usize, seed: u64) -> Dataset {
    use drive_samplers::builtin_robots;
    let config = SimulationConfig {
        robot: RobotSpec::load(&builtin_robots(), "husky").unwrap(),
        terrain,
        seed,
        runner: RunnerConfig {
            max_intervals: Some(intervals),
            ..RunnerConfig::default()
        },
        events: Vec::new(),
        name: "test".into(),
    };
    let sampler = move |space| -> Box<dyn InputSampler> {
        // A characterized input space is not empty.
        Box::new(UniformSampler::new(space, seed).unwrap())
    };
    simulate(config, &builtin_plants(), sampler, None)
        .unwrap()
        .dataset
}
