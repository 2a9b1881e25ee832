//! Running a matrix plan: the simulated runs, then every (setting, model) cell through the
//! experiment engine, then the summaries.

use super::stats::summarize;
use super::{Matrix, MatrixCell, MatrixError, MatrixResult, Scenario};
use crate::{
    intervals_in, run_cells, simulate_runs, ExperimentError, ProtocolStudy, Registries, Setting,
    SimRun,
};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Runs every combination of `matrix` in parallel (rayon) with the parts of `registries`,
/// calling `progress(done, total)` after each simulated run, each fitted model and each
/// summary row.
pub fn run_matrix(
    matrix: &Matrix,
    registries: &Registries,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<MatrixResult, MatrixError> {
    let done = AtomicUsize::new(0);
    // Simulated runs first: per robot, terrain and seed, the test run then the training runs
    // (sampler x duration).
    let mut runs: Vec<SimRun> = Vec::new();
    // (index of the training run, index of its test run, sampler, duration)
    let mut trains: Vec<(usize, usize, String, f64)> = Vec::new();
    if let Some(sim) = &matrix.simulated {
        for robot in &sim.robots {
            for terrain in &sim.terrains {
                for &seed in &sim.seeds {
                    let test = runs.len();
                    let fail = |e: ExperimentError| MatrixError::Simulation {
                        what: format!("{} on {}", robot.name, terrain.name),
                        reason: Box::new(e),
                    };
                    runs.push(SimRun::intervals(
                        robot,
                        terrain,
                        &sim.test_sampler,
                        intervals_in(sim.test_duration).map_err(fail)?,
                        ProtocolStudy::test_seed(seed),
                    ));
                    for sampler in &sim.samplers {
                        for &d in &sim.durations {
                            trains.push((runs.len(), test, sampler.clone(), d));
                            runs.push(SimRun::intervals(
                                robot,
                                terrain,
                                sampler,
                                intervals_in(d).map_err(fail)?,
                                seed,
                            ));
                        }
                    }
                }
            }
        }
    }
    let settings_per_data: usize = matrix.datasets.len() * matrix.splits.len();
    let sim_scenarios = matrix
        .simulated
        .as_ref()
        .map_or(0, |s| trains.len() / s.seeds.len().max(1));
    // Simulated runs, fits, then one summary row per scenario and model.
    let total = runs.len()
        + (settings_per_data + trains.len()) * matrix.models.len()
        + (settings_per_data + sim_scenarios) * matrix.models.len();
    let tick = || progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
    let simulated =
        simulate_runs(registries, &runs, &tick).map_err(|e| MatrixError::Simulation {
            what: "a simulated run".into(),
            reason: Box::new(e),
        })?;

    let mut settings = Vec::new();
    let mut scenarios = Vec::new();
    for (label, data) in &matrix.datasets {
        for &split in &matrix.splits {
            let (train, eval) =
                drive_eval::split_by_interval(data, split).map_err(|e| MatrixError::Dataset {
                    name: label.clone(),
                    reason: e.to_string(),
                })?;
            settings.push(Setting { train, eval });
            scenarios.push((
                Scenario {
                    dataset: label.clone(),
                    robot: data.robot.robot.clone(),
                    terrain: None,
                    sampler: None,
                    duration_s: None,
                    split: Some(split),
                },
                None,
            ));
        }
    }
    for (train, test, sampler, duration) in &trains {
        let (run, data, test_data) = (
            &runs[*train],
            &simulated[*train].dataset,
            &simulated[*test].dataset,
        );
        if data.windows.is_empty() || test_data.windows.is_empty() {
            return Err(MatrixError::Simulation {
                what: format!(
                    "{} on {} with {sampler}, seed {}",
                    run.robot.name, run.terrain.name, run.seed
                ),
                reason: Box::new(ExperimentError::NotEnoughData(
                    "the run recorded no interval".into(),
                )),
            });
        }
        settings.push(Setting {
            train: data.all(),
            eval: test_data.all(),
        });
        scenarios.push((
            Scenario {
                dataset: "sim".into(),
                robot: run.robot.name.clone(),
                terrain: Some(run.terrain.name.clone()),
                sampler: Some(sampler.clone()),
                duration_s: Some(*duration),
                split: None,
            },
            Some(run.seed),
        ));
    }

    let cells: Vec<MatrixCell> = run_cells(&settings, &matrix.models, false, &tick)
        .into_iter()
        .map(|cell| {
            let (scenario, seed) = &scenarios[cell.setting];
            let setting = &settings[cell.setting];
            let mut out = MatrixCell {
                scenario: scenario.clone(),
                seed: *seed,
                model: matrix.models[cell.model].clone(),
                train_windows: setting.train.len(),
                eval_windows: setting.eval.len(),
                fit_seconds: cell.fit_seconds,
                translational: None,
                rotational: None,
                failure: None,
                errors: Vec::new(),
                intervals: Vec::new(),
            };
            match cell.outcome {
                Ok(scored) => {
                    out.translational = scored.report.translational(None);
                    out.rotational = scored.report.rotational(None);
                    out.errors = scored.report.windows.iter().map(|w| w.error).collect();
                    out.intervals = scored.report.windows.iter().map(|w| w.interval).collect();
                }
                Err(e) => out.failure = Some(e.to_string()),
            }
            out
        })
        .collect();
    let summary = summarize(matrix, &cells, &tick);
    Ok(MatrixResult {
        baseline: matrix.baseline.clone(),
        bootstrap: matrix.bootstrap,
        cells,
        summary,
        simulators: matrix
            .simulated
            .iter()
            .flat_map(|plan| &plan.robots)
            .map(|r| crate::RobotSimulator {
                robot: r.name.clone(),
                simulator: drive_sim::simulator_used(&registries.simulators, r),
            })
            .collect(),
        notes: Vec::new(),
    })
}
