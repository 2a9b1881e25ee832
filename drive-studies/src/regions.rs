//! The paper's Table I on recorded data: models trained on the intervals whose commands
//! fall in a linear-focused or an angular-focused region of the input space, against
//! models trained on as many intervals drawn from all of J, all evaluated on the same
//! evaluation part.

use crate::protocols::median_or_nan;
use crate::{run_cells, ExperimentError, Registries, Setting};
use drive_eval::{improvement_percent, split_by_interval, Mrmse, Summary};
use drive_traits::{Dataset, Input, InputSpace, Window, WindowSet};
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use serde::Serialize;

/// How the regions are cut and the uniform baseline drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct RegionStudy {
    /// Fraction of the intervals (recording order) the regions are taken from; the rest
    /// evaluates.
    pub split: f64,
    /// Model trained (a model name).
    pub model: String,
    /// Random subsets of the training intervals drawn for the uniform baseline.
    pub draws: usize,
    /// Seed of those draws.
    pub seed: u64,
    /// Linear-focused region: yaw rate within this fraction of the turning-in-place rate
    /// (the `linear` sampler's small turns).
    pub linear_yaw_fraction: f64,
    /// Angular-focused region: forward speed within this band of the top speed, as
    /// fractions (around the `angular` sampler's half speed).
    pub angular_speed_band: [f64; 2],
}

impl Default for RegionStudy {
    fn default() -> Self {
        RegionStudy {
            split: 0.5,
            model: "slip-blr".into(),
            draws: 25,
            seed: 0,
            linear_yaw_fraction: 0.15,
            angular_speed_band: [0.25, 0.75],
        }
    }
}

/// One region against the uniform baseline of the same size.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RegionResult {
    /// `linear` or `angular`.
    pub region: String,
    /// The region in words, with its numbers.
    pub definition: String,
    /// Training intervals in the region (and in each uniform draw).
    pub intervals: usize,
    /// Errors of the model trained on the region (m).
    pub region_translational: Summary,
    /// Errors of the model trained on the region (rad).
    pub region_rotational: Summary,
    /// Median over the draws of the uniform models' median translational error (m).
    pub uniform_translational_median_m: f64,
    /// Median over the draws of the uniform models' median rotational error (rad).
    pub uniform_rotational_median_rad: f64,
    /// Smallest and largest of the draws' median translational errors (m).
    pub uniform_translational_range_m: [f64; 2],
    /// Smallest and largest of the draws' median rotational errors (rad).
    pub uniform_rotational_range_rad: [f64; 2],
    /// Improvement of uniform over the region in translation (%).
    pub improvement_translational_percent: f64,
    /// Improvement of uniform over the region in rotation (%).
    pub improvement_rotational_percent: f64,
    /// Every evaluation window's errors of the model trained on the region.
    #[serde(skip)]
    pub region_errors: Vec<Mrmse>,
    /// Every evaluation window's errors of the models trained on the uniform draws, pooled.
    #[serde(skip)]
    pub uniform_errors: Vec<Mrmse>,
}

/// What [`compare_regions`] found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RegionComparison {
    /// Dataset name.
    pub dataset: String,
    /// Model trained.
    pub model: String,
    /// Training intervals available.
    pub train_intervals: usize,
    /// Evaluation windows.
    pub eval_windows: usize,
    /// Uniform draws per region.
    pub draws: usize,
    /// The input space spanned by the training commands, per input axis of the vehicle:
    /// `[[min, max], ...]` (the vehicle's units: rad/s for wheel velocities).
    pub input_space: Vec<[f64; 2]>,
    /// Top forward speed in that space (m/s).
    pub top_speed_m_s: f64,
    /// Turning-in-place yaw rate in that space (rad/s).
    pub turn_rate_rad_s: f64,
    /// The linear-focused and angular-focused regions.
    pub regions: Vec<RegionResult>,
}

/// Whether a held input falls in a region.
type Region<'a> = Box<dyn Fn(&Input) -> bool + 'a>;

/// The input an interval held: the last command of its last window (after the
/// acceleration limit, what the robot was asked to keep).
fn held_input(windows: &[&Window]) -> Option<Input> {
    windows.last()?.command.last().copied()
}

/// Runs the region study on a recorded dataset.
///
/// ```
/// use drive_studies::{compare_regions, simulate_protocol, RegionStudy, Registries};
/// let r = Registries::builtin();
/// let data = simulate_protocol(&r, "husky", "gravel", "uniform", 40, 2).unwrap().dataset;
/// let study = RegionStudy { draws: 3, ..RegionStudy::default() };
/// let table = compare_regions(&r, &data, &study).unwrap();
/// assert_eq!(table.regions.len(), 2);
/// assert_eq!(table.regions[0].region, "linear");
/// ```
pub fn compare_regions(
    registries: &Registries,
    data: &Dataset,
    study: &RegionStudy,
) -> Result<RegionComparison, ExperimentError> {
    let model = registries.model(&study.model)?;
    drive_traits::limits::at_most(
        "draws",
        study.draws as f64,
        drive_traits::limits::MAX_DRAWS as f64,
        "",
    )?;
    if study.draws == 0 {
        return Err(ExperimentError::Empty("uniform draws"));
    }
    let (train, eval) = split_by_interval(data, study.split)
        .map_err(|e| ExperimentError::NotEnoughData(e.to_string()))?;
    // Training intervals in recording order, with the input each held.
    let mut intervals: Vec<(Vec<&Window>, Input)> = Vec::new();
    for w in &train.windows {
        match intervals.last_mut() {
            Some((ws, _)) if ws[0].interval == w.interval => ws.push(w),
            _ => intervals.push((vec![w], Input::zeros())),
        }
    }
    for (ws, held) in &mut intervals {
        // Every group holds at least the window that opened it.
        *held = held_input(ws).unwrap_or_default();
    }
    let (min, max) = intervals.iter().fold(
        (
            Input::repeat(f64::INFINITY),
            Input::repeat(f64::NEG_INFINITY),
        ),
        |(lo, hi), (_, u)| (lo.inf(u), hi.sup(u)),
    );
    let vehicle = data.robot.vehicle.as_ref();
    // The fastest forward command and the hardest turn inside the box the training
    // commands span, as the vehicle reaches them (a differential drive's turn in place, a
    // car's full lock at top speed, a rover's axles steered apart).
    let reach = InputSpace::new(min, max).map(|space| vehicle.reach(&space));
    let (top_speed, turn_rate) = reach.map_or((0.0, 0.0), |r| (r.top_speed(), r.top_yaw_rate()));
    if !(top_speed > 0.0 && turn_rate > 0.0) {
        return Err(ExperimentError::NotEnoughData(format!(
            "the training commands span no forward speed or no turn (top speed {top_speed:.3} m/s, turn rate {turn_rate:.3} rad/s)"
        )));
    }
    let [lo, hi] = study.angular_speed_band;
    let regions: [(&str, String, Region<'_>); 2] = [
        (
            "linear",
            format!(
                "|yaw rate| <= {:.3} rad/s ({} of the largest in the input space)",
                study.linear_yaw_fraction * turn_rate,
                study.linear_yaw_fraction
            ),
            Box::new(|u: &Input| {
                vehicle.body_velocity(u).z.abs() <= study.linear_yaw_fraction * turn_rate
            }),
        ),
        (
            "angular",
            format!(
                "forward speed in [{:.3}, {:.3}] m/s ({lo} to {hi} of the top speed)",
                lo * top_speed,
                hi * top_speed
            ),
            Box::new(|u: &Input| {
                let v = vehicle.body_velocity(u).x / top_speed;
                v >= lo && v <= hi
            }),
        ),
    ];
    // Every training subset first (the draws in a fixed order), then every fit at once.
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(study.seed);
    let mut subsets: Vec<Vec<&Window>> = Vec::new();
    let mut plan = Vec::new();
    for (name, definition, inside) in &regions {
        let chosen: Vec<usize> = (0..intervals.len())
            .filter(|&i| inside(&intervals[i].1))
            .collect();
        if chosen.len() < 2 {
            return Err(ExperimentError::NotEnoughData(format!(
                "only {} training interval(s) fall in the {name}-focused region ({definition}); at least 2 are needed",
                chosen.len()
            )));
        }
        let windows_of = |picked: &[usize]| -> Vec<&Window> {
            picked
                .iter()
                .flat_map(|&i| intervals[i].0.iter().copied())
                .collect()
        };
        let first = subsets.len();
        subsets.push(windows_of(&chosen));
        let mut order: Vec<usize> = (0..intervals.len()).collect();
        for _ in 0..study.draws {
            // A partial Fisher-Yates shuffle: the first n are a uniform draw without
            // replacement.
            for i in 0..chosen.len() {
                let j = rng.random_range(i..order.len());
                order.swap(i, j);
            }
            let mut picked = order[..chosen.len()].to_vec();
            picked.sort_unstable();
            subsets.push(windows_of(&picked));
        }
        plan.push((name, definition, chosen.len(), first));
    }
    let settings: Vec<Setting<'_>> = subsets
        .into_iter()
        .map(|windows| Setting {
            train: WindowSet {
                robot: &data.robot,
                windows,
            },
            eval: eval.clone(),
        })
        .collect();
    let cells = run_cells(&settings, std::slice::from_ref(&model), false, &|| {});
    let mut scores = Vec::with_capacity(cells.len());
    for (i, cell) in cells.into_iter().enumerate() {
        let what = if plan.iter().any(|p| p.3 == i) {
            "a region"
        } else {
            "a uniform draw"
        };
        let scored = cell.outcome.map_err(|reason| ExperimentError::Fit {
            model: model.name.clone(),
            data: what.to_string(),
            reason,
        })?;
        let empty = || ExperimentError::NotEnoughData(format!("no evaluation window for {what}"));
        let r = &scored.report;
        scores.push((
            r.translational(None).ok_or_else(empty)?,
            r.rotational(None).ok_or_else(empty)?,
            r.windows.iter().map(|w| w.error).collect::<Vec<Mrmse>>(),
        ));
    }
    let mut results = Vec::new();
    for (name, definition, count, first) in plan {
        let (rt, rr, region_errors) = scores[first].clone();
        let draws = &scores[first + 1..first + 1 + study.draws];
        let uniform_t: Vec<f64> = draws.iter().map(|d| d.0.median).collect();
        let uniform_r: Vec<f64> = draws.iter().map(|d| d.1.median).collect();
        let uniform_errors: Vec<Mrmse> = draws.iter().flat_map(|d| d.2.iter().copied()).collect();
        let range = |v: &[f64]| {
            [
                v.iter().copied().fold(f64::INFINITY, f64::min),
                v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            ]
        };
        let (ut, ur) = (
            median_or_nan(uniform_t.iter().copied()),
            median_or_nan(uniform_r.iter().copied()),
        );
        results.push(RegionResult {
            region: name.to_string(),
            definition: definition.clone(),
            intervals: count,
            region_translational: rt,
            region_rotational: rr,
            uniform_translational_median_m: ut,
            uniform_rotational_median_rad: ur,
            uniform_translational_range_m: range(&uniform_t),
            uniform_rotational_range_rad: range(&uniform_r),
            improvement_translational_percent: improvement_percent(ut, rt.median),
            improvement_rotational_percent: improvement_percent(ur, rr.median),
            region_errors,
            uniform_errors,
        });
    }
    Ok(RegionComparison {
        dataset: data.robot.name.clone(),
        model: model.name.clone(),
        train_intervals: intervals.len(),
        eval_windows: eval.len(),
        draws: study.draws,
        input_space: (0..data
            .robot
            .vehicle
            .input_dim()
            .clamp(1, drive_traits::MAX_INPUTS))
            .map(|i| [min[i], max[i]])
            .collect(),
        top_speed_m_s: top_speed,
        turn_rate_rad_s: turn_rate,
        regions: results,
    })
}
