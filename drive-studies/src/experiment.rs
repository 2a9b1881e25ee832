//! The one experiment engine: a plan of cells, each a model fitted on a setting's training
//! windows and scored with eq. 8 on its evaluation windows, run in parallel; and simulated
//! runs, also in parallel. Every analysis builds its settings and hands them here: the
//! model comparison (one setting, many models), the evaluation matrix (datasets x splits
//! and simulated runs x models), the protocol study (simulated training runs and a test
//! run), the region study (subsets of intervals) and the convergence curve (prefixes).

use crate::{ExperimentError, Registries};
use drive_eval::{evaluate_model_from, ModelReport};
use drive_models::ModelSpec;
use drive_samplers::{build_sampler, RobotSpec, RunnerConfig, SamplerContext, SamplerError};
use drive_sim::{simulate, Simulation, SimulationConfig, Terrain};
use drive_traits::{Dataset, FitError, Input, InputSampler, MotionModel, WindowSet};
use rayon::prelude::*;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// One evaluation setting: the windows a model is fitted on and the windows it is scored on.
#[derive(Debug, Clone)]
pub struct Setting<'a> {
    /// Training windows.
    pub train: WindowSet<'a>,
    /// Evaluation windows.
    pub eval: WindowSet<'a>,
}

/// A fitted and scored model.
#[derive(Debug)]
pub struct Scored {
    /// Eq. 8 on every evaluation window.
    pub report: ModelReport,
    /// The fitted model, when the plan keeps them.
    pub model: Option<Box<dyn MotionModel>>,
}

/// What one cell (a setting and a model) produced.
#[derive(Debug)]
pub struct Cell {
    /// Index of the setting.
    pub setting: usize,
    /// Index of the model.
    pub model: usize,
    /// Time to fit (s).
    pub fit_seconds: f64,
    /// The scores, or why the fit failed.
    pub outcome: Result<Scored, FitError>,
}

/// Fits every model on every setting's training windows and scores it on the setting's
/// evaluation windows, in parallel (rayon); `progress` is called after each cell. The cells
/// come back in plan order: setting by setting, model by model. With `keep_models`, each
/// cell keeps its fitted model.
///
/// ```
/// use drive_eval::split_by_interval;
/// use drive_studies::{run_cells, Registries, Setting};
/// let data = drive_studies::simulate_protocol(&Registries::builtin(), "husky", "gravel", "uniform", 6, 1).unwrap().dataset;
/// let (train, eval) = split_by_interval(&data, 0.5).unwrap();
/// let registries = Registries::builtin();
/// let models = registries.models().resolve_list(&["naive", "slip-blr"]).unwrap();
/// let cells = run_cells(&[Setting { train, eval }], &models, false, &|| {});
/// assert_eq!(cells.len(), 2);
/// assert!(cells.iter().all(|c| c.outcome.is_ok()));
/// ```
pub fn run_cells(
    settings: &[Setting<'_>],
    models: &[ModelSpec],
    keep_models: bool,
    progress: &(dyn Fn() + Sync),
) -> Vec<Cell> {
    let plan: Vec<(usize, usize)> = (0..settings.len())
        .flat_map(|s| (0..models.len()).map(move |m| (s, m)))
        .collect();
    plan.par_iter()
        .map(|&(s, m)| {
            let cell = run_cell(&settings[s], &models[m], keep_models, s, m);
            progress();
            cell
        })
        .collect()
}

fn run_cell(setting: &Setting<'_>, spec: &ModelSpec, keep_model: bool, s: usize, m: usize) -> Cell {
    let start = Instant::now();
    let fitted = spec.fit(&setting.train);
    let fit_seconds = start.elapsed().as_secs_f64();
    Cell {
        setting: s,
        model: m,
        fit_seconds,
        outcome: fitted.map(|model| Scored {
            report: evaluate_model_from(model.as_ref(), &setting.eval, spec.start),
            model: keep_model.then_some(model),
        }),
    }
}

/// One simulated protocol run: a robot on a terrain, driven by a registered sampler.
#[derive(Debug, Clone)]
pub struct SimRun {
    /// The robot.
    pub robot: RobotSpec,
    /// The ground.
    pub terrain: Terrain,
    /// A registered sampler's name.
    pub sampler: String,
    /// When the run ends (intervals or duration) and the runner's safety settings.
    pub runner: RunnerConfig,
    /// Seed of the simulator's noise and of the sampler.
    pub seed: u64,
}

impl SimRun {
    /// A run of `intervals` DRIVE intervals after the characterization.
    pub fn intervals(
        robot: &RobotSpec,
        terrain: &Terrain,
        sampler: &str,
        intervals: usize,
        seed: u64,
    ) -> Self {
        SimRun {
            robot: robot.clone(),
            terrain: terrain.clone(),
            sampler: sampler.to_string(),
            runner: RunnerConfig {
                max_intervals: Some(intervals),
                ..RunnerConfig::default()
            },
            seed,
        }
    }

    /// The dataset name of the run.
    pub fn label(&self) -> String {
        format!(
            "sim-{}-{}-{}-s{}",
            self.robot.name, self.terrain.name, self.sampler, self.seed
        )
    }
}

/// Runs the DRIVE protocol on the simulator: characterization, then intervals with the
/// registered sampler over the characterized input space; the plant is the one registered
/// for the robot's vehicle.
pub fn simulate_run(registries: &Registries, run: &SimRun) -> Result<Simulation, ExperimentError> {
    let sampler_error = |reason| ExperimentError::Sampler {
        name: run.sampler.clone(),
        reason,
    };
    // Fail early on a name or limits that cannot work over the nominal input space.
    build_sampler(
        &registries.samplers,
        &run.sampler,
        &SamplerContext::new(&run.robot, run.seed),
    )
    .map_err(sampler_error)?;
    // The sampler is built over the characterized space, inside the runner; an error there
    // is kept and returned after the run (the runner then holds still).
    let failure: Arc<Mutex<Option<SamplerError>>> = Arc::default();
    let (samplers, spec, slot) = (
        registries.samplers.clone(),
        run.robot.clone(),
        failure.clone(),
    );
    let (name, seed) = (run.sampler.clone(), run.seed);
    let factory = move |space| match build_sampler(
        &samplers,
        &name,
        &SamplerContext::new(&spec, seed).over(space),
    ) {
        Ok(s) => s,
        Err(e) => {
            *slot.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
            Box::new(HoldStill) as Box<dyn InputSampler>
        }
    };
    let config = SimulationConfig {
        name: run.label(),
        robot: run.robot.clone(),
        terrain: run.terrain.clone(),
        seed: run.seed,
        runner: run.runner.clone(),
        events: Vec::new(),
    };
    let result = simulate(config, &registries.simulators, factory, None)?;
    let failed = failure.lock().unwrap_or_else(|p| p.into_inner()).take();
    if let Some(e) = failed {
        return Err(sampler_error(e));
    }
    usable(&run.label(), &result.dataset)?;
    Ok(result)
}

/// A simulated run nothing can be learned from (a robot that cannot move: a wheel limit or
/// a friction of 1e-300 in a twin file) is refused, rather than scored as all-zero errors by
/// every command that simulates: the data checks' first fatal finding on it.
pub(crate) fn usable(run: &str, dataset: &Dataset) -> Result<(), ExperimentError> {
    match drive_data::quality::check(dataset, None)
        .into_iter()
        .find(|f| f.severity == drive_data::quality::Severity::Fatal)
    {
        Some(f) => Err(ExperimentError::Unusable {
            run: run.to_string(),
            finding: format!("{} ({})", f.message, f.check),
        }),
        None => Ok(()),
    }
}

/// Runs every simulation in parallel (rayon), in order; `progress` is called after each.
pub fn simulate_runs(
    registries: &Registries,
    runs: &[SimRun],
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<Simulation>, ExperimentError> {
    runs.par_iter()
        .map(|run| {
            let sim = simulate_run(registries, run);
            progress();
            sim
        })
        .collect()
}

/// Stands in for a sampler that could not be built.
struct HoldStill;

impl InputSampler for HoldStill {
    fn next_input(&mut self) -> Input {
        Input::zeros()
    }
}
