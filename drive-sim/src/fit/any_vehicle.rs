//! The twin of a vehicle the skid-steer fit does not cover: any vehicle type whose simulator
//! (a registered plant, or the kinematic stand-in) reads the terrain's ground. The ground's
//! grip, turning resistance, rolling resistance and slip modulus are fitted so that the
//! simulator, given the real run's own commands, moves in each steady window as the robot
//! did (its mean forward, sideways and yaw velocities from the localization). The
//! simulator's own powertrain, controller and sensors are kept: they are the plant's, and a
//! plant of another vehicle type has no parameters this project knows how to fit.

use super::{at_least, minimize, SimFitError};
use crate::parameters::{MAX_ROLLING, SLIP_MODULUS_RANGE, TRACTION_RANGE};
use crate::{simulate, simulator_used, MakePlant, SimulationConfig, Terrain};
use argmin::core::{CostFunction, Error};
use drive_samplers::{ReplaySampler, RobotSpec, RunnerConfig};
use drive_traits::{vehicle_tag, Dataset, Input, InputSampler, Phase, Registry, Window};
use serde::Serialize;
use std::collections::HashMap;

/// The ground parameters fitted, with their ranges.
const FITTED: [(&str, (f64, f64)); 4] = [
    ("traction", TRACTION_RANGE),
    ("lateral", TRACTION_RANGE),
    ("rolling", (1e-4, MAX_ROLLING)),
    ("slip_modulus", SLIP_MODULUS_RANGE),
];

/// At most this many of the data's intervals are replayed in each of the fit's runs.
const MAX_INTERVALS: usize = 120;

/// Nelder-Mead's iterations per round (two rounds).
const ITERATIONS: u64 = 50;

/// `f` of each of `items`, on threads of their own.
fn in_parallel<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let f = &f;
    std::thread::scope(|scope| {
        let handles: Vec<_> = items.iter().map(|t| scope.spawn(move || f(t))).collect();
        handles
            .into_iter()
            // A panic in a simulation is a bug: passed on as it is.
            .map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
            .collect()
    })
}

/// The fit's cost of a ground, with what it was computed from.
#[derive(Debug, Clone, Copy)]
struct Cost {
    value: f64,
    rms: [f64; 3],
    compared: usize,
}

/// What the ground fit of a vehicle of any type found ([`fit_any_vehicle`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AnyVehicleFitReport {
    /// The simulator the twin runs on, as every simulating command names it.
    pub simulator: String,
    /// Whether that simulator is the kinematic stand-in (no simulator is registered for
    /// the vehicle type): a lag and a terrain loss, not a physics model.
    pub stand_in: bool,
    /// The data's steady windows with a localization track.
    pub steady_windows: usize,
    /// The data's intervals (with a steady window) whose command the fit's run held and
    /// whose motion it compared.
    pub intervals_compared: usize,
    /// The preset the fit started from: the one whose motion came closest.
    pub start: String,
    /// The fit's cost at the start: the mean over the compared intervals of the squared
    /// differences of their motion, twin minus real, the velocities over the data's RMS
    /// speed and the yaw rate over its RMS yaw rate.
    pub cost_start: f64,
    /// The same after the fit (never above `cost_start`).
    pub cost: f64,
    /// The RMS difference of the steady windows' mean motion, twin minus real, per
    /// interval: forward (m/s), sideways (m/s) and yaw (rad/s), at the start.
    pub motion_rms_start: [f64; 3],
    /// The same after the fit.
    pub motion_rms: [f64; 3],
    /// The fitted parameters at a bound of their range.
    pub at_bounds: Vec<String>,
    /// The fitted parameters the simulator barely responds to (half again or two thirds of
    /// the value moves the fit's cost by less than 1%): not pinned down by the data; and the
    /// three friction coefficients moved together, when that is so (a simulator that reads
    /// their ratios only).
    pub insensitive: Vec<String>,
    /// What the twin keeps from the simulator instead of fitting it.
    pub not_fitted: Vec<&'static str>,
}

/// A twin of a vehicle of any type, and its fit's report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AnyVehicleFit {
    /// The twin: its ground only (no powertrain, controller, sensors, variability or
    /// protocol tables: the simulator's own are kept).
    pub terrain: Terrain,
    /// The fit's report.
    pub report: AnyVehicleFitReport,
}

/// Fits the ground of a twin of `robot`, named `name`, on `data`, for a vehicle of any type:
/// the simulator registered for the vehicle type in `plants` (or the kinematic stand-in)
/// is given the data's own commands, interval by interval; its ground (traction, lateral,
/// rolling, slip modulus) is fitted with Nelder-Mead so that each steady window's mean
/// motion matches the real one's, starting from the closest preset.
///
/// Refuses data of another vehicle type than the robot's, too few steady windows, and data
/// whose localization does not move (the data checks' fatal findings).
///
/// ```
/// use drive_samplers::{builtin_robots, RobotSpec};
/// let plants = drive_sim::builtin_plants();
/// let robot = RobotSpec::load(&builtin_robots(), "husky").unwrap();
/// // The car's data is not the Husky's vehicle: refused, naming both.
/// let car = RobotSpec::load(&builtin_robots(), "autorally").unwrap();
/// let config = drive_sim::SimulationConfig {
///     robot: car,
///     terrain: drive_sim::Terrain::preset("tile").unwrap(),
///     seed: 1,
///     runner: drive_samplers::RunnerConfig { max_intervals: Some(4), ..Default::default() },
///     events: Vec::new(),
///     name: "autorally".into(),
/// };
/// let sampler = |s| -> Box<dyn drive_traits::InputSampler> {
///     Box::new(drive_samplers::UniformSampler::new(s, 1).unwrap())
/// };
/// let data = drive_sim::simulate(config, &plants, sampler, None).unwrap().dataset;
/// let e = drive_sim::fit_any_vehicle(&plants, &data, &robot, "twin").unwrap_err();
/// assert!(e.to_string().contains("ackermann"), "{e}");
/// ```
pub fn fit_any_vehicle(
    plants: &Registry<dyn MakePlant>,
    data: &Dataset,
    robot: &RobotSpec,
    name: &str,
) -> Result<AnyVehicleFit, SimFitError> {
    let steady_windows = check_any_vehicle_run(data, robot)?;
    let real = interval_motions(data);
    let commands: Vec<Input> = real.iter().map(|m| m.command).collect();
    let intervals = commands.len().min(MAX_INTERVALS);
    let scale = motion_scale(&real);
    let mut problem = GroundProblem {
        plants,
        robot,
        commands: &commands,
        real: &real,
        scale,
        intervals,
        // Replaced by the closest preset below (each preset is costed whole).
        base: Terrain::preset("gravel").expect("a preset name"),
    };
    // The start: the preset whose motion comes closest (each costed on a thread of its own).
    let presets: Vec<Terrain> = Terrain::NAMES
        .iter()
        // Every name of NAMES is a preset.
        .map(|p| Terrain::preset(p).expect("a preset name"))
        .collect();
    let costs = in_parallel(&presets, |t| problem.cost_of(t));
    let mut best: Option<(Cost, &Terrain)> = None;
    for (cost, t) in costs.into_iter().zip(&presets) {
        let cost = cost?;
        if best.as_ref().is_none_or(|(c, _)| cost.value < c.value) {
            best = Some((cost, t));
        }
    }
    // Four presets were costed.
    let (at_start, start) = best.expect("a preset");
    let x0: Vec<f64> = FITTED
        .iter()
        .map(|(name, _)| parameter(start, name).ln())
        .collect();
    problem.base = start.clone();
    let x = minimize(problem.clone(), x0, &[0.4; 4], ITERATIONS, "ground")?;
    let mut terrain = problem.terrain(&x);
    terrain.name = name.to_string();
    // The vehicle it is a twin of: another robot is refused it.
    terrain.fitted_for = Some(crate::FittedVehicle::of(robot.vehicle.as_ref()));
    let fitted = problem.cost_of(&terrain)?;
    // How much the cost moves with each parameter half again or two thirds of its value.
    // Last, the three friction coefficients together: a simulator that reads their ratios
    // only (the kinematic stand-in, the mecanum base) pins down those alone.
    let together = [0, 1, 2];
    let moves: Vec<Terrain> = (0..=FITTED.len())
        .flat_map(|i| {
            [1.5_f64, 1.0 / 1.5].map(|factor| {
                let mut y = x.clone();
                if i < FITTED.len() {
                    y[i] += factor.ln();
                } else {
                    together.iter().for_each(|&j| y[j] += factor.ln());
                }
                problem.terrain(&y)
            })
        })
        .collect();
    let moved = in_parallel(&moves, |t| problem.cost_of(t));
    let mut at_bounds = Vec::new();
    let mut insensitive = Vec::new();
    for (i, (param, (lo, hi))) in FITTED.iter().enumerate() {
        let v = parameter(&terrain, param);
        if v <= lo * 1.01 || v >= hi * 0.99 {
            at_bounds.push(format!("{param} = {v:.3}"));
        }
        let mut most = 0.0_f64;
        for cost in &moved[2 * i..2 * i + 2] {
            let cost = cost.as_ref().map_err(Clone::clone)?;
            most = most.max((cost.value - fitted.value).abs());
        }
        if most < 0.01 * fitted.value.max(1e-12) {
            insensitive.push((*param).to_string());
        }
    }
    let n = FITTED.len();
    let mut most = 0.0_f64;
    for cost in &moved[2 * n..2 * n + 2] {
        let cost = cost.as_ref().map_err(Clone::clone)?;
        most = most.max((cost.value - fitted.value).abs());
    }
    if most < 0.01 * fitted.value.max(1e-12) {
        insensitive.push(
            "traction, lateral and rolling together (their ratios alone are pinned down)".into(),
        );
    }
    let used = simulator_used(plants, robot);
    Ok(AnyVehicleFit {
        terrain,
        report: AnyVehicleFitReport {
            simulator: used.name.clone(),
            stand_in: used.stand_in,
            steady_windows,
            intervals_compared: fitted.compared,
            start: start.name.clone(),
            cost_start: at_start.value,
            cost: fitted.value,
            motion_rms_start: at_start.rms,
            motion_rms: fitted.rms,
            at_bounds,
            insensitive,
            not_fitted: vec![
                "powertrain and controller (the simulator's own)",
                "sensors (the simulator's defaults)",
                "variability (none)",
            ],
        },
    })
}

/// The checks [`fit_any_vehicle`] makes of its data before fitting (the vehicle type is
/// the robot's, at least 12 steady windows with a localization track, none of the data
/// checks' fatal findings), also what a twin of any vehicle is checked against (`drive
/// sim-fit --twin`); the number of steady windows.
pub fn check_any_vehicle_run(data: &Dataset, robot: &RobotSpec) -> Result<usize, SimFitError> {
    let (ours, theirs) = (
        vehicle_tag(robot.vehicle.as_ref()).unwrap_or_default(),
        vehicle_tag(data.robot.vehicle.as_ref()).unwrap_or_default(),
    );
    if ours != theirs {
        return Err(SimFitError::Unfit(format!(
            "the data's vehicle is '{theirs}' and the robot {}'s is '{ours}': give the robot the data was recorded with",
            robot.name
        )));
    }
    // The same type, another geometry: the twin would drive the robot's, not the data's.
    if let Some(why) =
        crate::FittedVehicle::of(data.robot.vehicle.as_ref()).refuses(robot.vehicle.as_ref())
    {
        return Err(SimFitError::Unfit(format!(
            "the robot {} is not the data's vehicle: {}; give the robot the data was recorded with",
            robot.name,
            why.replace("it is a twin of", "the data is of")
        )));
    }
    let steady_windows = data
        .windows
        .iter()
        .filter(|w| w.phase == Phase::Steady && window_motion(w, data.robot.dt()).is_some())
        .count();
    at_least(&[("steady windows", "ground", steady_windows, 12)])?;
    if let Some(f) = drive_data::quality::check(data, None)
        .into_iter()
        .find(|f| f.severity == drive_data::quality::Severity::Fatal)
    {
        return Err(SimFitError::Unfit(format!("{} ({})", f.message, f.check)));
    }
    Ok(steady_windows)
}

/// The value of a fitted ground parameter of `t`.
fn parameter(t: &Terrain, name: &str) -> f64 {
    match name {
        "traction" => t.traction,
        "lateral" => t.lateral,
        "rolling" => t.rolling,
        _ => t.slip_modulus,
    }
}

/// One interval of the data: its held command and its steady windows' mean motion.
#[derive(Debug, Clone, Copy)]
struct IntervalMotion {
    command: Input,
    motion: Option<[f64; 3]>,
}

/// The mean body-frame motion of a window from its localization track: forward and
/// sideways velocity (m/s, each step's displacement in the frame of the pose it starts
/// from) and yaw rate (rad/s, the unwrapped net turn over the window's duration). `None`
/// for a window of fewer than two poses.
fn window_motion(w: &Window, dt: f64) -> Option<[f64; 3]> {
    let n = w.pose.len();
    if n < 2 || dt.is_nan() || dt <= 0.0 {
        return None;
    }
    let (mut forward, mut sideways) = (0.0, 0.0);
    for p in w.pose.windows(2) {
        let (dx, dy) = (p[1].x - p[0].x, p[1].y - p[0].y);
        let (s, c) = p[0].z.sin_cos();
        forward += c * dx + s * dy;
        sideways += -s * dx + c * dy;
    }
    let t = (n - 1) as f64 * dt;
    let m = [
        forward / t,
        sideways / t,
        drive_traits::net_turn(&w.pose) / t,
    ];
    m.iter().all(|v| v.is_finite()).then_some(m)
}

/// The data's intervals in order, each with the command it held (its last window's last
/// command, as [`ReplaySampler::interval_commands`] takes it) and the mean motion of its
/// steady windows.
fn interval_motions(data: &Dataset) -> Vec<IntervalMotion> {
    let dt = data.robot.dt();
    let mut out: Vec<(usize, Input, [f64; 3], usize)> = Vec::new();
    for w in &data.windows {
        let Some(u) = w.command.last() else { continue };
        if out.last().is_none_or(|(i, ..)| *i != w.interval) {
            out.push((w.interval, *u, [0.0; 3], 0));
        }
        // Pushed above when absent.
        let last = out.last_mut().expect("an interval");
        last.1 = *u;
        if w.phase == Phase::Steady {
            if let Some(m) = window_motion(w, dt) {
                for (s, v) in last.2.iter_mut().zip(m) {
                    *s += v;
                }
                last.3 += 1;
            }
        }
    }
    out.into_iter()
        .map(|(_, command, sum, n)| IntervalMotion {
            command,
            motion: (n > 0).then(|| sum.map(|s| s / n as f64)),
        })
        .collect()
}

/// The scale of each motion axis in the cost: the data's RMS speed (forward and sideways
/// alike: a metre per second is one whichever way) and RMS yaw rate, each at least 0.05.
fn motion_scale(real: &[IntervalMotion]) -> [f64; 3] {
    let motions: Vec<[f64; 3]> = real.iter().filter_map(|m| m.motion).collect();
    let n = motions.len().max(1) as f64;
    let speed = (motions
        .iter()
        .map(|m| m[0] * m[0] + m[1] * m[1])
        .sum::<f64>()
        / n)
        .sqrt();
    let yaw = (motions.iter().map(|m| m[2] * m[2]).sum::<f64>() / n).sqrt();
    let (speed, yaw) = (speed.max(0.05), yaw.max(0.05));
    [speed, speed, yaw]
}

/// The Nelder-Mead problem: the ground's log-parameters to the scaled squared difference of
/// the steady windows' motion, twin minus real, over the intervals both hold.
#[derive(Clone)]
struct GroundProblem<'a> {
    plants: &'a Registry<dyn MakePlant>,
    robot: &'a RobotSpec,
    commands: &'a [Input],
    real: &'a [IntervalMotion],
    scale: [f64; 3],
    intervals: usize,
    base: Terrain,
}

impl GroundProblem<'_> {
    /// The base ground with the parameters `x` (natural logarithms), each within its range.
    fn terrain(&self, x: &[f64]) -> Terrain {
        let mut t = self.base.clone();
        for ((name, (lo, hi)), v) in FITTED.iter().zip(x) {
            let v = v.exp().clamp(*lo, *hi);
            match *name {
                "traction" => t.traction = v,
                "lateral" => t.lateral = v,
                "rolling" => t.rolling = v,
                _ => t.slip_modulus = v,
            }
        }
        t
    }

    /// The twin's motion per held command on `terrain`: one run of the data's commands.
    fn twin_motions(&self, terrain: &Terrain) -> Result<HashMap<[u64; 3], [f64; 3]>, SimFitError> {
        let config = SimulationConfig {
            robot: self.robot.clone(),
            terrain: terrain.clone(),
            seed: 1,
            runner: RunnerConfig {
                max_intervals: Some(self.intervals),
                ..RunnerConfig::default()
            },
            events: Vec::new(),
            name: "twin".into(),
        };
        let replay = ReplaySampler::new(self.commands.to_vec());
        let factory = move |_| -> Box<dyn InputSampler> {
            match &replay {
                Some(r) => Box::new(r.clone()),
                None => Box::new(super::variability::Still),
            }
        };
        let run =
            simulate(config, self.plants, factory, None).map_err(|e| SimFitError::Optimizer {
                stage: "ground",
                reason: e.to_string(),
            })?;
        let mut sums: HashMap<[u64; 3], ([f64; 3], usize)> = HashMap::new();
        for m in interval_motions(&run.dataset) {
            let Some(motion) = m.motion else { continue };
            let e = sums.entry(key(&m.command)).or_insert(([0.0; 3], 0));
            for (s, v) in e.0.iter_mut().zip(motion) {
                *s += v;
            }
            e.1 += 1;
        }
        Ok(sums
            .into_iter()
            .map(|(k, (s, n))| (k, s.map(|v| v / n as f64)))
            .collect())
    }

    /// The differences, twin minus real, of the intervals both hold.
    fn differences(&self, terrain: &Terrain) -> Result<Vec<[f64; 3]>, SimFitError> {
        let twin = self.twin_motions(terrain)?;
        Ok(self
            .real
            .iter()
            .filter_map(|r| {
                let real = r.motion?;
                let twin = twin.get(&key(&r.command))?;
                Some([0, 1, 2].map(|a| twin[a] - real[a]))
            })
            .collect())
    }

    /// The fit's cost of `terrain` (the scaled mean squared difference), its RMS
    /// differences per axis and the number of intervals compared; refuses a run that held
    /// too few of the data's commands to compare.
    fn cost_of(&self, terrain: &Terrain) -> Result<Cost, SimFitError> {
        let d = self.differences(terrain)?;
        at_least(&[(
            "intervals the twin and the data both hold",
            "ground",
            d.len(),
            6,
        )])?;
        let n = d.len() as f64;
        let value = d
            .iter()
            .map(|e| (0..3).map(|a| (e[a] / self.scale[a]).powi(2)).sum::<f64>())
            .sum::<f64>()
            / n;
        let rms = [0, 1, 2].map(|a| (d.iter().map(|e| e[a] * e[a]).sum::<f64>() / n).sqrt());
        Ok(Cost {
            value,
            rms,
            compared: d.len(),
        })
    }
}

impl CostFunction for GroundProblem<'_> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, x: &Self::Param) -> Result<f64, Error> {
        // Beyond a range, the clamped ground plus the distance outside (back towards it).
        let outside: f64 = FITTED
            .iter()
            .zip(x)
            .map(|((_, (lo, hi)), v)| (lo.ln() - v).max(0.0) + (v - hi.ln()).max(0.0))
            .sum();
        let cost = self
            .cost_of(&self.terrain(x))
            .map_err(|e| Error::msg(e.to_string()))?;
        Ok(cost.value + outside)
    }
}

/// A command as a key: its exact bits (the replayed commands are the data's, copied).
fn key(u: &Input) -> [u64; 3] {
    [u.x.to_bits(), u.y.to_bits(), u.z.to_bits()]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::builtin_plants;
    use drive_samplers::{builtin_robots, UniformSampler};

    /// A run of `robot` on `terrain`: `intervals` uniform draws, seeded.
    fn run(robot: &str, terrain: &Terrain, intervals: usize) -> (RobotSpec, Dataset) {
        let robot = RobotSpec::load(&builtin_robots(), robot).unwrap();
        let config = SimulationConfig {
            robot: robot.clone(),
            terrain: terrain.clone(),
            seed: 11,
            runner: RunnerConfig {
                max_intervals: Some(intervals),
                ..RunnerConfig::default()
            },
            events: Vec::new(),
            name: "truth".into(),
        };
        let sampler = |s| -> Box<dyn InputSampler> { Box::new(UniformSampler::new(s, 3).unwrap()) };
        let data = simulate(config, &builtin_plants(), sampler, None)
            .unwrap()
            .dataset;
        (robot, data)
    }

    #[test]
    fn a_mecanum_base_s_ground_is_recovered_from_its_motion() {
        // Not a preset: the fit starts from the closest one and must move.
        let truth = Terrain {
            name: "truth".into(),
            traction: 0.4,
            lateral: 0.15,
            rolling: 0.06,
            ..Terrain::preset("gravel").unwrap()
        };
        let (robot, data) = run("ridgeback", &truth, 40);
        let fit = fit_any_vehicle(&builtin_plants(), &data, &robot, "fitted").unwrap();
        let (t, r) = (&fit.terrain, &fit.report);
        assert_eq!(
            (r.simulator.as_str(), r.stand_in),
            ("omnidirectional", false)
        );
        assert_eq!(t.name, "fitted");
        // The mecanum plant sees the ground through two shares (docs of OmniPlant): the
        // forward loss rolling / traction (0.15) and the turn loss lateral / (lateral +
        // traction) (0.273); the slip modulus is not one of them.
        let forward = t.rolling / t.traction;
        let turn = t.lateral / (t.lateral + t.traction);
        assert!((forward - 0.15).abs() < 0.02, "{forward} {t:?}");
        assert!((turn - 0.15 / 0.55).abs() < 0.03, "{turn} {t:?}");
        assert!(r.insensitive.contains(&"slip_modulus".to_string()), "{r:?}");
        // It reads the friction coefficients' ratios only: the three together are not
        // pinned down, and the fit says so.
        assert!(
            r.insensitive
                .iter()
                .any(|i| i.starts_with("traction, lateral and rolling together")),
            "{r:?}"
        );
        assert!(r.cost <= r.cost_start && r.cost_start > 0.0, "{r:?}");
        assert!(r.intervals_compared >= 30, "{r:?}");
    }

    #[test]
    fn data_the_fit_cannot_use_is_refused_with_the_reason() {
        let (robot, data) = run("ridgeback", &Terrain::preset("tile").unwrap(), 2);
        let e = fit_any_vehicle(&builtin_plants(), &data, &robot, "t").unwrap_err();
        assert!(e.to_string().contains("too few steady windows"), "{e}");
        let husky = RobotSpec::load(&builtin_robots(), "husky").unwrap();
        let e = fit_any_vehicle(&builtin_plants(), &data, &husky, "t").unwrap_err();
        assert!(
            e.to_string().contains("'omnidirectional'") && e.to_string().contains("'differential'"),
            "{e}"
        );
    }
}
