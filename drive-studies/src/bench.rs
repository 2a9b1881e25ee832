//! The benchmark: many datasets (robots, terrains) x many models, on the one experiment
//! engine.
//!
//! - **Within each dataset**: the paper's split, exactly as `drive eval` runs it
//!   ([`compare_specs`]), with every model's improvement over slip-BLR and its paired
//!   bootstrap interval.
//! - **Transfer**: for every ordered pair of datasets of the same robot, each model fitted
//!   on all of the first and scored on the evaluation half of the second, against the same
//!   model fitted on the second's own training half.
//! - **Leaderboard**: per model, the mean rank over datasets, the datasets where it beats
//!   slip-BLR with an interval excluding 0, and the geometric mean of its median's ratio to
//!   slip-BLR's.
//! - **The terrain's unpredictability** ([`unpredictability`]) per dataset, and how each
//!   model's error grows with it.

use crate::{compare_specs, CompareError, PairedImprovement};
use drive_eval::{
    average_ranks, evaluate_errors, spearman, split_by_interval, unpredictability, BootstrapConfig,
    Mrmse, Unpredictability, UnpredictabilityConfig, WindowUnpredictability,
};
use drive_models::calibration::Uncertainty;
use drive_models::ModelSpec;
use drive_samplers::BodySize;
use drive_traits::{Dataset, FitError, MotionModel};
use rayon::prelude::*;
use std::collections::{BTreeMap, HashMap};
use thiserror::Error;

mod adaptation;
mod results;
mod sequence;
pub use adaptation::{
    AdaptPair, AdaptSummary, BenchAdaptation, LibrarySummary, LEADERBOARD_ADAPT_T_S,
};
pub use results::{
    Bench, BenchDataset, BenchModel, BenchUnpredictability, ErrorGrowth, LeaderboardRow, Ratio,
    SkippedDataset, TransferCell, TransferGroup, TransferSummary, UnpairedRobot,
    UnpredictabilityBin,
};

/// One dataset of a benchmark, loaded, with its labels.
#[derive(Debug, Clone)]
pub struct BenchInput {
    /// Its name in the results (unique within the benchmark).
    pub name: String,
    /// Where it was read from (a path, `bundled:NAME`).
    pub source: String,
    /// The robot's identity: datasets of the same robot are compared in transfer. A
    /// registered robot's name when one was given or recognised, else the sidecar's robot.
    pub robot: String,
    /// The ground, free text (empty or `unknown...` when not known).
    pub terrain: String,
    /// The body's footprint, for the total unpredictability.
    pub body: Option<BodySize>,
    /// Where the body's footprint comes from (empty without one).
    pub body_source: String,
    /// The windows.
    pub data: Dataset,
    /// What loading it noted (a data check's warning, a recognised robot): one line each.
    pub notes: Vec<String>,
}

/// How the benchmark runs.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchConfig {
    /// Training fraction of each dataset's intervals (the paper's 0.5).
    pub split: f64,
    /// Whether to run the transfer between datasets of the same robot.
    pub transfer: bool,
    /// The unpredictability's settings.
    pub unpredictability: UnpredictabilityConfig,
    /// The evaluation intervals a dataset needs for its bootstrap intervals to count as
    /// evidence in the leaderboard (wins and losses): with a handful of intervals, every
    /// resample draws the same few and the interval collapses to a point.
    pub min_evidence_intervals: usize,
    /// Rank a dataset the data checks call useless (a fatal finding of
    /// [`drive_data::quality::check`], as `drive check` exits 1 on) instead of skipping it.
    pub allow_useless: bool,
    /// Run the adaptation track (`drive bench --adapt`) with these settings: every model
    /// fitted on one run adapting to another of the same robot, as `drive adapt`.
    pub adapt: Option<crate::AdaptStudy>,
    /// With the adaptation track: also a terrain library for each pair (`drive bench
    /// --adapt-library`): the prior and the model fitted on each other run of the robot,
    /// blended by their likelihood of the windows driven, as `drive adapt --library` (each
    /// run fitted once for all its pairs).
    pub adapt_library: bool,
}

impl Default for BenchConfig {
    fn default() -> Self {
        BenchConfig {
            split: 0.5,
            transfer: true,
            unpredictability: UnpredictabilityConfig::default(),
            min_evidence_intervals: 10,
            allow_useless: false,
            adapt: None,
            adapt_library: false,
        }
    }
}

/// Why a benchmark could not run.
#[derive(Debug, Error)]
pub enum BenchError {
    /// No dataset, or no model.
    #[error("{0}")]
    Empty(&'static str),
    /// Two datasets share a name.
    #[error("two datasets are named '{0}' (give one a name = \"...\")")]
    DuplicateName(String),
    /// A model is named twice.
    #[error("the model '{0}' is named twice")]
    DuplicateModel(String),
    /// The comparison failed on one dataset.
    #[error("dataset '{name}': {reason}")]
    Dataset {
        /// The dataset.
        name: String,
        /// Why.
        reason: CompareError,
    },
    /// Every dataset was skipped (each with why).
    #[error("no dataset could be benchmarked: {0}")]
    AllSkipped(String),
    /// A transfer fit failed.
    #[error("transfer: fitting {model} on all of '{dataset}': {reason}")]
    TransferFit {
        /// Model.
        model: String,
        /// The training dataset.
        dataset: String,
        /// Why.
        reason: FitError,
    },
}

/// The work units of a benchmark (for a progress bar): one per dataset's comparison, one
/// per transfer fit, one per transfer score.
pub fn bench_units(inputs: &[BenchInput], models: usize, config: &BenchConfig) -> usize {
    if !config.transfer && config.adapt.is_none() {
        return inputs.len();
    }
    let pairs = transfer_pairs(inputs).0;
    let adapted = if config.adapt.is_some() {
        pairs.len() * models
    } else {
        0
    };
    if !config.transfer {
        return inputs.len() + adapted;
    }
    let mut trained: Vec<usize> = pairs.iter().map(|p| p.0).collect();
    trained.sort_unstable();
    trained.dedup();
    inputs.len() + (trained.len() + pairs.len()) * models + adapted
}

/// The ordered pairs (train, test) of datasets of the same robot that can be compared, and
/// the pairs skipped with why (other rates or vehicle types, or the same windows).
fn transfer_pairs(inputs: &[BenchInput]) -> (Vec<(usize, usize)>, Vec<String>) {
    let prints: Vec<WindowPrints> = inputs.iter().map(|i| window_prints(&i.data)).collect();
    // Which datasets share windows, and how many.
    let n = inputs.len();
    let mut shared = vec![None; n * n];
    for a in 0..n {
        for b in a + 1..n {
            if inputs[a].robot != inputs[b].robot {
                continue;
            }
            let found = shared_windows(&prints[a], &prints[b]);
            shared[a * n + b] = Some(found);
            shared[b * n + a] = Some(found);
        }
    }
    // How many windows `a` and `c` share (the share found of the one with fewer, times
    // its windows), where they are one run; 0 otherwise.
    let size = |i: usize| inputs[i].data.windows.len();
    let common = |a: usize, c: usize| -> usize {
        match shared[a * n + c] {
            Some(found) if same_run(found) => {
                let fewer = size(a).min(size(c));
                (found.0 * fewer).div_ceil(found.1.max(1)).min(fewer)
            }
            _ => 0,
        }
    };
    // Two datasets one run through a third (two copies of one run altered differently:
    // each the run's, not the other's): each shares windows with it, and the windows they
    // share with it overlap in at least as many as a direct same run needs (a tenth of the
    // one with fewer). A dataset made of half of one run and half of another (or of both
    // whole, one after the other) shares each run's windows in its own half: the two runs
    // stay two.
    let through = |a: usize, b: usize| -> bool {
        (0..n).filter(|&c| c != a && c != b).any(|c| {
            let (ac, bc) = (common(a, c), common(b, c));
            let overlap = (ac + bc).saturating_sub(size(c));
            ac > 0 && bc > 0 && overlap * SAME_RUN_SHARE_DENOMINATOR >= size(a).min(size(b)).max(1)
        })
    };
    let mut pairs = Vec::new();
    let mut skipped = Vec::new();
    for (a, ia) in inputs.iter().enumerate() {
        for (b, ib) in inputs.iter().enumerate() {
            if a == b || ia.robot != ib.robot {
                continue;
            }
            let (ra, rb) = (&ia.data.robot, &ib.data.robot);
            let why = if ra.rate_hz != rb.rate_hz || ra.window_len != rb.window_len {
                Some(format!(
                    "{} Hz x {} samples against {} Hz x {}",
                    ra.rate_hz, ra.window_len, rb.rate_hz, rb.window_len
                ))
            } else if crate::vehicle_type(&ia.data) != crate::vehicle_type(&ib.data) {
                Some(format!(
                    "vehicle types {} and {}",
                    crate::vehicle_type(&ia.data),
                    crate::vehicle_type(&ib.data)
                ))
            } else {
                // One run listed twice, in two formats, or with a part of itself: its own
                // windows, by content.
                let (shared, smaller) = shared[a * n + b].unwrap_or((0, 0));
                if same_run((shared, smaller)) {
                    Some(format!(
                        "the same windows ({shared} of the {smaller} of the one with fewer are also in the other: one run listed twice, in two formats, or with a part of itself?): each model would be scored on windows it was fitted on"
                    ))
                } else if through(a, b) {
                    Some(
                        "one run through the others of the suite (each shares its windows with a dataset that shares them with the other: two copies of one run altered differently?): each model would be scored on windows it was fitted on".to_string(),
                    )
                } else {
                    None
                }
            };
            match why {
                None => pairs.push((a, b)),
                Some(why) => skipped.push(format!("{} -> {}: {why}", ia.name, ib.name)),
            }
        }
    }
    (pairs, skipped)
}

/// Every robot of the benchmark left without a transfer pair, with why: one dataset only,
/// or every pair of its datasets skipped (`transfer_skipped` says why each).
fn unpaired_robots(inputs: &[BenchInput], pairs: &[(usize, usize)]) -> Vec<UnpairedRobot> {
    let mut robots: Vec<&str> = Vec::new();
    for i in inputs {
        if !robots.contains(&i.robot.as_str()) {
            robots.push(&i.robot);
        }
    }
    robots
        .into_iter()
        .filter(|r| !pairs.iter().any(|&(a, _)| inputs[a].robot == *r))
        .map(|robot| {
            let datasets: Vec<String> = inputs
                .iter()
                .filter(|i| i.robot == robot)
                .map(|i| i.name.clone())
                .collect();
            let reason = if datasets.len() == 1 {
                "only one dataset of this robot: no other run to transfer to".to_string()
            } else {
                "every pair of its datasets is skipped (see transfer_skipped)".to_string()
            };
            UnpairedRobot {
                robot: robot.to_string(),
                datasets,
                reason,
            }
        })
        .collect()
}

/// Two datasets are the same run when at least one in this many of the windows of the one
/// with fewer are also in the other (a tenth: two real runs share none).
pub(crate) const SAME_RUN_SHARE_DENOMINATOR: usize = 10;

/// The quantization steps of a window's print: its mean command and mean measured input
/// per axis (rad/s or m/s), its net motion in its start frame (m, m, rad).
const PRINT_STEPS: [f64; 3] = [0.02, 0.05, 0.02];

/// Prints of each window's content, by which one run is recognised in another whatever its
/// file's format, precision or order: per window its mean command and mean measured input
/// per axis and its net motion in its own start frame (forward, sideways, turn), quantized
/// ([`PRINT_STEPS`]) on two grids half a step apart, so that a copy rounded to a few
/// significant digits (or a raw log against its imported window CSV, equal to 1e-15) still
/// matches on at least one of them; windows where the robot neither was commanded nor moved
/// by a step carry no identity and have none. Each grid's prints sorted.
///
/// A second print holds the localization's track alone: the pose a quarter, half, three
/// quarters and all of the way through the window, in its start frame; two windows share
/// it when every one of those values agrees within [`TRACK_TOLERANCE`] (5 mm and 0.5% of
/// the distance, 5 mrad). Two runs do not share a track so closely unless one is a copy of
/// the other, whatever was done to its commands and encoders or to its precision (a copy
/// with its encoders recalibrated by a few percent, its positions written to the
/// millimetre: the same drive).
pub(crate) struct WindowPrints {
    grids: [Vec<u64>; 2],
    /// For each window with a print, its prints on both grids.
    windows: Vec<[u64; 2]>,
    /// For each window whose localization moved, its track.
    tracks: Vec<Track>,
    /// The tracks by their net motion's cell ([`TRACK_CELL`]).
    track_cells: HashMap<[i64; 3], Vec<usize>>,
    /// For each window driven, what the robot was sent and sensed of itself ([`Inputs`]).
    inputs: Vec<Inputs>,
    /// The inputs by their mean command's cell ([`INPUTS_CELL`]).
    input_cells: HashMap<[i64; 2], Vec<usize>>,
    /// The windows in recorded order: the sequence of commands one drive keeps through
    /// noise ([`sequence::one_drive`]).
    sequence: sequence::Sequence,
    /// Every sample's inputs and IMU (their bits, hashed; sorted, once each), where its
    /// wheels turn: a run cut into other windows (every window a few samples later) keeps
    /// them, which no other run holds ([`SAME_SAMPLES_SHARE`]).
    samples: Vec<u64>,
}

/// The share of the samples (of the run with fewer) whose commands, measured inputs and
/// IMU are the other run's to the bit, from which two runs are one: a copy cut into other
/// windows holds all of them; two drives share none (the same commands simulated on two
/// grounds: a few straight stretches' worth).
const SAME_SAMPLES_SHARE: f64 = 0.5;

/// [`WindowPrints::samples`] of `data`.
fn sample_prints(data: &Dataset) -> Vec<u64> {
    use std::hash::{Hash, Hasher};
    let mut out: Vec<u64> = data
        .windows
        .iter()
        .flat_map(|w| {
            w.command
                .iter()
                .zip(&w.measured)
                .zip(w.imu_yaw_rate.iter().chain(std::iter::repeat(&0.0)))
        })
        .filter(|((_, m), _)| m.iter().any(|v| *v != 0.0))
        .map(|((c, m), r)| {
            let mut h = std::collections::hash_map::DefaultHasher::new();
            for v in c.iter().chain(m.iter()).chain(std::iter::once(r)) {
                v.to_bits().hash(&mut h);
            }
            h.finish()
        })
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// A window's mean command and mean measured input per axis and its mean IMU yaw rate: what
/// the robot was sent and what it sensed of itself, whatever its localization saw. A copy
/// whose localization alone was altered (noise added, positions scaled) keeps them.
type Inputs = [f64; 7];

/// How far two windows' [`Inputs`] may be apart and be one drive's: their means over a
/// window (40 samples at 20 Hz) of a run and of its copy with noise of 0.03 per sample differ
/// by 0.007 (one sigma); 0.02 rad/s or m/s on each.
const INPUTS_TOLERANCE: f64 = 0.02;

/// The cell of a window's mean command (its first two axes) for finding the inputs near it.
const INPUTS_CELL: f64 = 0.05;

/// The share of windows whose [`Inputs`] agree from which two runs are one (four in five):
/// two runs driven with the same commands (a simulator's same seed on two grounds) share
/// those of their straight windows, where the ground changes neither the wheels nor the yaw
/// rate (a simulated Husky on gravel and on snow, seed 1: 81 of 138, which a half called
/// one run); a copy shares all of its own.
const SAME_INPUTS_SHARE: f64 = 0.8;

/// A window's localization track: the pose (forward, sideways, turn) at a quarter, half,
/// three quarters and all of the way through it, in its start frame.
type Track = [f64; 12];

/// How far two tracks' values may be apart and still be one drive's: 5 mm plus 0.5% of
/// the distance, and 5 mrad (a copy written to the millimetre, its yaw to the milliradian).
const TRACK_TOLERANCE: [f64; 3] = [0.005, 0.005, 0.005];

/// The cell of a track's net motion for finding the tracks near it (m, m, rad).
const TRACK_CELL: f64 = 0.05;

/// [`WindowPrints`] of `data`.
pub(crate) fn window_prints(data: &Dataset) -> WindowPrints {
    use std::hash::{Hash, Hasher};
    let mut windows = Vec::new();
    let mut tracks = Vec::new();
    let mut track_cells: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    let mut inputs = Vec::new();
    let mut input_cells: HashMap<[i64; 2], Vec<usize>> = HashMap::new();
    // Every window's means in order, for the sequence (computed once, for both prints).
    let mut means = Vec::new();
    for w in data.windows.iter().filter(|w| w.len() >= 2) {
        let mean = window_means(w);
        means.push(mean);
        if let Some(i) = mean.filter(driven) {
            input_cells
                .entry(inputs_cell(&i))
                .or_default()
                .push(inputs.len());
            inputs.push(i);
        }
        if let Some(track) = track_of(w) {
            track_cells
                .entry(track_cell(&track))
                .or_default()
                .push(tracks.len());
            tracks.push(track);
        }
        let n = w.len() as f64;
        let mean = |inputs: &[drive_traits::Input], i: usize| -> f64 {
            inputs.iter().map(|u| u[i]).sum::<f64>() / n
        };
        let (first, last) = (w.pose[0], w.pose[w.len() - 1]);
        let (dx, dy) = (last.x - first.x, last.y - first.y);
        let (sin, cos) = first.z.sin_cos();
        let turn = drive_traits::net_turn(&w.pose);
        let mut values: Vec<(f64, f64)> = Vec::with_capacity(9);
        for i in 0..3 {
            values.push((mean(&w.command, i), PRINT_STEPS[0]));
            values.push((mean(&w.measured, i), PRINT_STEPS[0]));
        }
        values.push((cos * dx + sin * dy, PRINT_STEPS[1]));
        values.push((-sin * dx + cos * dy, PRINT_STEPS[1]));
        values.push((turn, PRINT_STEPS[2]));
        if values.iter().all(|(v, step)| v.abs() < *step)
            || values.iter().any(|(v, _)| !v.is_finite())
        {
            continue;
        }
        let print = |offset: f64| {
            let mut h = std::collections::hash_map::DefaultHasher::new();
            for (v, step) in &values {
                ((v / step + offset).floor() as i64).hash(&mut h);
            }
            h.finish()
        };
        windows.push([print(0.0), print(0.5)]);
    }
    let mut grids = [
        windows.iter().map(|p| p[0]).collect::<Vec<_>>(),
        windows.iter().map(|p| p[1]).collect::<Vec<_>>(),
    ];
    grids.iter_mut().for_each(|g| g.sort_unstable());
    WindowPrints {
        grids,
        windows,
        tracks,
        track_cells,
        inputs,
        input_cells,
        sequence: sequence::Sequence::of(data, means),
        samples: sample_prints(data),
    }
}

/// Whether a window's [`Inputs`] say it was commanded or moved its wheels by
/// [`INPUTS_TOLERANCE`] (a window standing still carries no identity).
fn driven(values: &Inputs) -> bool {
    values[..6].iter().any(|v| v.abs() >= INPUTS_TOLERANCE)
}

/// A window's [`Inputs`]; `None` where one is not finite.
fn window_means(w: &drive_traits::Window) -> Option<Inputs> {
    let n = w.len() as f64;
    let mut values = [0.0; 7];
    for axis in 0..3 {
        values[axis] = w.command.iter().map(|u| u[axis]).sum::<f64>() / n;
        values[3 + axis] = w.measured.iter().map(|u| u[axis]).sum::<f64>() / n;
    }
    values[6] = w.imu_yaw_rate.iter().sum::<f64>() / w.imu_yaw_rate.len().max(1) as f64;
    values.iter().all(|v| v.is_finite()).then_some(values)
}

/// The cell of a window's mean command ([`INPUTS_CELL`]).
fn inputs_cell(i: &Inputs) -> [i64; 2] {
    [i[0], i[1]].map(|v| (v / INPUTS_CELL).floor() as i64)
}

/// Whether `prints` holds a window whose [`Inputs`] agree with `i` within
/// [`INPUTS_TOLERANCE`] on every value.
fn holds_inputs(prints: &WindowPrints, i: &Inputs) -> bool {
    let [a, b] = inputs_cell(i);
    (-1..=1).any(|da| {
        (-1..=1).any(|db| {
            prints
                .input_cells
                .get(&[a + da, b + db])
                .is_some_and(|near| {
                    near.iter().any(|&n| {
                        prints.inputs[n]
                            .iter()
                            .zip(i)
                            .all(|(x, y)| (x - y).abs() <= INPUTS_TOLERANCE)
                    })
                })
        })
    })
}

/// The cell of a track's net motion ([`TRACK_CELL`]).
fn track_cell(t: &Track) -> [i64; 3] {
    [t[9], t[10], t[11]].map(|v| (v / TRACK_CELL).floor() as i64)
}

/// Whether two tracks are one drive's ([`TRACK_TOLERANCE`]).
fn same_track(a: &Track, b: &Track) -> bool {
    a.iter().zip(b).enumerate().all(|(i, (x, y))| {
        let axis = i % 3;
        let scale = if axis == 2 {
            0.0
        } else {
            0.005 * x.abs().max(y.abs())
        };
        (x - y).abs() <= TRACK_TOLERANCE[axis] + scale
    })
}

/// Whether `prints` holds a track one drive's with `t` or with its mirror image (sideways
/// and turn negated: a copy whose world was mirrored, y, yaw and the sides swapped).
fn holds_track(prints: &WindowPrints, t: &Track) -> bool {
    let mut mirrored = *t;
    for (i, v) in mirrored.iter_mut().enumerate() {
        if i % 3 != 0 {
            *v = -*v;
        }
    }
    holds_track_as_is(prints, t) || holds_track_as_is(prints, &mirrored)
}

/// Whether `prints` holds a track one drive's with `t`: among the tracks of its net
/// motion's cell and the cells around it.
fn holds_track_as_is(prints: &WindowPrints, t: &Track) -> bool {
    let [a, b, c] = track_cell(t);
    (-1..=1).any(|i| {
        (-1..=1).any(|j| {
            (-1..=1).any(|k| {
                prints
                    .track_cells
                    .get(&[a + i, b + j, c + k])
                    .is_some_and(|near| near.iter().any(|&n| same_track(&prints.tracks[n], t)))
            })
        })
    })
}

/// A window's localization track ([`Track`]); `None` when the localization did not move
/// by a centimetre or a hundredth of a radian (a frozen or still track, or one within the
/// tolerance of one, has no identity).
fn track_of(w: &drive_traits::Window) -> Option<Track> {
    let n = w.pose.len();
    let first = w.pose[0];
    let (sin, cos) = first.z.sin_cos();
    let mut values = [0.0; 12];
    for (slot, k) in [n / 4, n / 2, 3 * n / 4, n - 1].into_iter().enumerate() {
        let p = w.pose[k];
        let (dx, dy) = (p.x - first.x, p.y - first.y);
        values[3 * slot] = cos * dx + sin * dy;
        values[3 * slot + 1] = -sin * dx + cos * dy;
        values[3 * slot + 2] = drive_traits::net_turn(&w.pose[..=k]);
    }
    if values.iter().any(|v| !v.is_finite()) || values.iter().all(|v| v.abs() < 0.01) {
        return None;
    }
    Some(values)
}

impl WindowPrints {
    /// How many windows have a print.
    pub(crate) fn len(&self) -> usize {
        self.windows.len()
    }
}

/// How many windows of the one of `a` and `b` with fewer prints are also in the other (on
/// either grid), and of how many: by their content, or by their localization's track when
/// that shares a larger part (a copy with its inputs altered).
pub(crate) fn shared_windows(a: &WindowPrints, b: &WindowPrints) -> (usize, usize) {
    let (few, many) = if a.len() <= b.len() { (a, b) } else { (b, a) };
    let by_content = few
        .windows
        .iter()
        .filter(|p| (0..2).any(|g| many.grids[g].binary_search(&p[g]).is_ok()))
        .count();
    let (few_tracks, many_tracks) = if a.tracks.len() <= b.tracks.len() {
        (a, b)
    } else {
        (b, a)
    };
    let by_track = few_tracks
        .tracks
        .iter()
        .filter(|t| holds_track(many_tracks, t))
        .count();
    let content = (by_content, few.len());
    let track = (by_track, few_tracks.tracks.len());
    // The larger share (cross-multiplied: either count may be 0).
    let larger = if track.0 * content.1.max(1) > content.0 * track.1.max(1) {
        track
    } else {
        content
    };
    // What the robot was sent and sensed, in most windows: one drive, whatever was done to
    // its localization ([`SAME_INPUTS_SHARE`]).
    let (few_inputs, many_inputs) = if a.inputs.len() <= b.inputs.len() {
        (a, b)
    } else {
        (b, a)
    };
    let by_inputs = few_inputs
        .inputs
        .iter()
        .filter(|i| holds_inputs(many_inputs, i))
        .count();
    let inputs = (by_inputs, few_inputs.inputs.len());
    let larger = if by_inputs > 0
        && by_inputs as f64 >= SAME_INPUTS_SHARE * inputs.1 as f64
        && inputs.0 * larger.1.max(1) > larger.0 * inputs.1.max(1)
    {
        inputs
    } else {
        larger
    };
    // One drive's commands window after window, its IMU off by noise alone: a copy with
    // noise on every column ([`sequence::one_drive`]).
    let larger = match sequence::one_drive(&a.sequence, &b.sequence, SAME_INPUTS_SHARE) {
        Some(found) if found.0 * larger.1.max(1) > larger.0 * found.1.max(1) => found,
        _ => larger,
    };
    // The same samples to the bit, however the windows were cut ([`SAME_SAMPLES_SHARE`]):
    // as a share of the windows of the one with fewer.
    let (few_samples, many_samples) = if a.samples.len() <= b.samples.len() {
        (&a.samples, &b.samples)
    } else {
        (&b.samples, &a.samples)
    };
    let shared_samples = few_samples
        .iter()
        .filter(|h| many_samples.binary_search(h).is_ok())
        .count();
    let share = shared_samples as f64 / few_samples.len().max(1) as f64;
    let windows = if a.samples.len() <= b.samples.len() {
        a.len()
    } else {
        b.len()
    };
    let by_samples = ((share * windows as f64).round() as usize, windows);
    if share >= SAME_SAMPLES_SHARE
        && by_samples.0 * larger.1.max(1) > larger.0 * by_samples.1.max(1)
    {
        by_samples
    } else {
        larger
    }
}

/// Whether two runs' prints say they are one run: at least one in
/// [`SAME_RUN_SHARE_DENOMINATOR`] of the windows shared ([`shared_windows`]).
pub(crate) fn same_run(shared: (usize, usize)) -> bool {
    shared.0 > 0 && shared.0 * SAME_RUN_SHARE_DENOMINATOR >= shared.1
}

/// Whether a terrain label is known (not empty, not `unknown...`).
pub fn terrain_known(terrain: &str) -> bool {
    let t = terrain.trim().to_ascii_lowercase();
    !(t.is_empty() || t.starts_with("unknown"))
}

/// The median of the finite values ([`drive_traits::median`]), `None` when there are none.
pub(crate) fn finite_median(values: &[f64]) -> Option<f64> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    (!v.is_empty()).then(|| drive_traits::median(&mut v))
}

impl ErrorGrowth {
    /// How the errors of `report` grow with the unpredictability `u` of the same dataset's
    /// windows.
    pub fn of(report: &drive_eval::ModelReport, u: &Unpredictability) -> ErrorGrowth {
        error_growth(&report.windows, &u.by_window(), u.total.is_some())
    }
}

/// How a model's window errors grow with the windows' unpredictability.
fn error_growth(
    windows: &[drive_eval::WindowErrors],
    unpredictable: &HashMap<usize, WindowUnpredictability>,
    with_total: bool,
) -> ErrorGrowth {
    let pairs = |pick: fn(&WindowUnpredictability) -> Option<f64>,
                 error: fn(&Mrmse) -> f64|
     -> (Vec<f64>, Vec<f64>) {
        windows
            .iter()
            .filter_map(|w| {
                let u = pick(unpredictable.get(&w.window)?)?;
                let e = error(&w.error);
                e.is_finite().then_some((e, u))
            })
            .unzip()
    };
    let (et, ut) = pairs(|u| u.translational, |e| e.translational);
    let (er, ur) = pairs(|u| u.rotational, |e| e.rotational);
    let binned_by = if with_total { "total" } else { "translational" };
    let key: fn(&WindowUnpredictability) -> Option<f64> = if with_total {
        |u| u.total
    } else {
        |u| u.translational
    };
    let mut sorted: Vec<(f64, &drive_eval::WindowErrors)> = windows
        .iter()
        .filter_map(|w| Some((key(unpredictable.get(&w.window)?)?, w)))
        .collect();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
    let n = sorted.len();
    let mut thirds = Vec::new();
    if n >= 3 {
        for t in 0..3 {
            let part = &sorted[t * n / 3..(t + 1) * n / 3];
            let (Some(first), Some(last)) = (part.first(), part.last()) else {
                continue;
            };
            let trans: Vec<f64> = part.iter().map(|(_, w)| w.error.translational).collect();
            let rot: Vec<f64> = part.iter().map(|(_, w)| w.error.rotational).collect();
            thirds.push(UnpredictabilityBin {
                unpredictability: [first.0, last.0],
                windows: part.len(),
                translational_median_m: finite_median(&trans).unwrap_or(f64::NAN),
                rotational_median_rad: finite_median(&rot).unwrap_or(f64::NAN),
            });
        }
    }
    ErrorGrowth {
        spearman_translational: spearman(&et, &ut),
        spearman_rotational: spearman(&er, &ur),
        binned_by,
        thirds,
    }
}

fn ratio_of(improvement: &drive_eval::Improvement) -> f64 {
    1.0 - improvement.percent / 100.0
}

/// One dataset: the comparison (as `drive eval`) and the unpredictability.
fn within(
    input: &BenchInput,
    specs: &[ModelSpec],
    config: &BenchConfig,
) -> Result<BenchDataset, BenchError> {
    let comparison =
        compare_specs(&input.data, config.split, specs).map_err(|reason| BenchError::Dataset {
            name: input.name.clone(),
            reason,
        })?;
    let u: Unpredictability = unpredictability(&input.data, input.body, &config.unpredictability);
    let by_window = u.by_window();
    let trans: Vec<f64> = comparison
        .models
        .iter()
        .map(|m| m.translational_median_m)
        .collect();
    let rot: Vec<f64> = comparison
        .models
        .iter()
        .map(|m| m.rotational_median_rad)
        .collect();
    let (rank_t, rank_r) = (average_ranks(&trans), average_ranks(&rot));
    // At 2 s itself: windows shorter than that have none (their last horizon is not 2 s).
    let at_2s = |c: &Option<BTreeMap<String, f64>>| c.as_ref().and_then(|c| c.get("2.0").copied());
    let models = comparison
        .models
        .iter()
        .enumerate()
        .map(|(i, m)| BenchModel {
            name: m.name.clone(),
            model: m.model.clone(),
            translational_median_m: m.translational_median_m,
            rotational_median_rad: m.rotational_median_rad,
            translational_iqr_m: m.translational_iqr_m,
            rotational_iqr_rad: m.rotational_iqr_rad,
            rank_translational: rank_t[i],
            rank_rotational: rank_r[i],
            improvement_over_naive: m.improvement_over_naive,
            improvement_over_slip_blr: m.improvement_over_slip_blr,
            ratio_to_slip_blr: m.improvement_over_slip_blr.map(|b| Ratio {
                translational: ratio_of(&b.translational),
                rotational: ratio_of(&b.rotational),
            }),
            position_coverage95_2s: at_2s(&m.coverage95),
            yaw_coverage95_2s: at_2s(&m.yaw_coverage95),
            coverage95_by_phase: m.coverage95_by_phase.clone(),
            area_ratio_to_constant: m.area_ratio_to_constant,
            error_rank_correlation: m.error_rank_correlation.clone(),
            fit_seconds: m.fit_seconds,
            error_growth: error_growth(&m.report.windows, &by_window, u.total.is_some()),
        })
        .collect();
    let data = &input.data;
    Ok(BenchDataset {
        name: input.name.clone(),
        source: input.source.clone(),
        robot: input.robot.clone(),
        robot_description: data.robot.robot.clone(),
        terrain: input.terrain.clone(),
        vehicle: comparison.vehicle.clone(),
        windows: data.windows.len(),
        window_s: comparison.window_s,
        intervals: data.interval_count(),
        train_windows: comparison.train_windows,
        eval_windows: comparison.eval_windows,
        eval_intervals: comparison.eval_intervals,
        evidence: comparison.eval_intervals >= config.min_evidence_intervals,
        position_frame: comparison.position_frame,
        models,
        unpredictability: BenchUnpredictability {
            translational: u.translational,
            rotational: u.rotational,
            total: u.total,
            pooled: u.pooled,
            body: input.body,
            body_source: input.body_source.clone(),
        },
        comparison,
        window_unpredictability: u.windows,
        notes: input.notes.clone(),
    })
}

/// Runs the benchmark: every model of `specs` on every dataset of `inputs` (in parallel),
/// the transfer between datasets of the same robot, the leaderboard. `progress` is called
/// after each unit of work ([`bench_units`] of them).
///
/// ```
/// use drive_studies::{run_bench, BenchConfig, BenchInput, Registries};
/// let registries = Registries::builtin();
/// let sim = |terrain: &str, seed| {
///     let data = drive_studies::simulate_protocol(&registries, "husky", terrain, "uniform", 8, seed).unwrap().dataset;
///     BenchInput { name: format!("{terrain}-{seed}"), source: "simulated".into(), robot: "husky".into(),
///         terrain: terrain.into(), body: None, body_source: String::new(), data, notes: Vec::new() }
/// };
/// let inputs = vec![sim("tile", 1), sim("snow", 2), sim("snow", 3)];
/// let specs = registries.models().resolve_list(&["naive", "slip-blr"]).unwrap();
/// let bench = run_bench(&inputs, &specs, &BenchConfig::default(), &|| {}).unwrap();
/// assert_eq!(bench.datasets.len(), 3);
/// assert_eq!(bench.transfer.len(), 3 * 2 * 2); // 6 ordered pairs, 2 models
/// assert_eq!(bench.leaderboard[0].model, "slip-blr");
/// ```
pub fn run_bench(
    inputs: &[BenchInput],
    specs: &[ModelSpec],
    config: &BenchConfig,
    progress: &(dyn Fn() + Sync),
) -> Result<Bench, BenchError> {
    if inputs.is_empty() {
        return Err(BenchError::Empty("the suite holds no dataset"));
    }
    if specs.is_empty() {
        return Err(BenchError::Empty("no model to benchmark"));
    }
    for (i, a) in inputs.iter().enumerate() {
        if inputs[..i].iter().any(|b| b.name == a.name) {
            return Err(BenchError::DuplicateName(a.name.clone()));
        }
    }
    for (i, a) in specs.iter().enumerate() {
        if specs[..i]
            .iter()
            .any(|b| b.name == a.name || b.canonical() == a.canonical() && b.start == a.start)
        {
            return Err(BenchError::DuplicateModel(a.name.clone()));
        }
    }
    // A dataset the data checks call useless, or on which the models cannot be compared,
    // is skipped with why; the others go on.
    let outcomes: Vec<Result<BenchDataset, String>> = inputs
        .par_iter()
        .map(|input| {
            let d = checked(input, config).and_then(|findings| {
                let mut d = within(input, specs, config).map_err(|e| match e {
                    BenchError::Dataset { reason, .. } => reason.to_string(),
                    e => e.to_string(),
                })?;
                // What the data checks found, beside what loading it noted (once each).
                for note in findings {
                    if !d.notes.contains(&note) {
                        d.notes.push(note);
                    }
                }
                Ok(d)
            });
            progress();
            d
        })
        .collect();
    let mut datasets = Vec::new();
    let mut skipped = Vec::new();
    for (input, outcome) in inputs.iter().zip(outcomes) {
        match outcome {
            Ok(d) => datasets.push(d),
            Err(reason) => skipped.push(SkippedDataset {
                dataset: input.name.clone(),
                reason,
            }),
        }
    }
    if datasets.is_empty() {
        return Err(BenchError::AllSkipped(SkippedDataset::listed(&skipped)));
    }
    // The transfer runs between the datasets kept (copied only when one was skipped).
    let kept: Vec<BenchInput>;
    let inputs = if skipped.is_empty() {
        inputs
    } else {
        kept = inputs
            .iter()
            .filter(|i| !skipped.iter().any(|s| s.dataset == i.name))
            .cloned()
            .collect();
        // The units planned for the skipped datasets (their transfer and adaptation) are
        // done: there is nothing left of them to do, and a progress bar reaches its total.
        let planned = bench_units(inputs, specs.len(), config);
        let left = bench_units(&kept, specs.len(), config) - kept.len();
        for _ in 0..planned.saturating_sub(inputs.len() + left) {
            progress();
        }
        &kept[..]
    };
    let (pairs, transfer_skipped) = if config.transfer || config.adapt.is_some() {
        transfer_pairs(inputs)
    } else {
        (Vec::new(), Vec::new())
    };
    let adaptation = config.adapt.as_ref().map(|study| {
        adaptation::adaptation(
            inputs,
            specs,
            study,
            &pairs,
            &transfer_skipped,
            config.adapt_library,
            progress,
        )
    });
    let (pairs, transfer_skipped) = if config.transfer {
        (pairs, transfer_skipped)
    } else {
        (Vec::new(), Vec::new())
    };
    let transfer_unpaired = if config.transfer {
        unpaired_robots(inputs, &pairs)
    } else {
        Vec::new()
    };
    let transfer = transfer_cells(inputs, specs, config, &pairs, &datasets, progress)?;
    let transfer_summary = specs
        .iter()
        .map(|spec| summarize_transfer(&spec.name, &transfer))
        .collect();
    let leaderboard = leaderboard(specs, &datasets, adaptation.as_ref());
    Ok(Bench {
        split: config.split,
        model_names: specs.iter().map(|s| s.name.clone()).collect(),
        min_evidence_intervals: config.min_evidence_intervals,
        bootstrap: datasets
            .first()
            .map_or_else(BootstrapConfig::default, |d| d.comparison.bootstrap),
        datasets,
        transfer,
        transfer_summary,
        leaderboard,
        transfer_skipped,
        transfer_unpaired,
        skipped,
        adaptation,
    })
}

/// What the data checks find in `input`: `Err` with why it is skipped when one of their
/// findings is fatal (unless [`BenchConfig::allow_useless`]), else every finding as a note
/// of the dataset (`check NAME: message`, a fatal one ranked under `--allow-useless` said
/// so): a number from data the checks doubt is never ranked without a word.
fn checked(input: &BenchInput, config: &BenchConfig) -> Result<Vec<String>, String> {
    let findings = drive_data::quality::check(&input.data, None);
    let fatal =
        |f: &drive_data::quality::Finding| f.severity == drive_data::quality::Severity::Fatal;
    if let (false, Some(f)) = (config.allow_useless, findings.iter().find(|f| fatal(f))) {
        return Err(format!(
            "the data checks call it useless: {} ({}; drive check says more, --allow-useless ranks it anyway)",
            f.message, f.check
        ));
    }
    Ok(findings
        .iter()
        .map(|f| {
            if fatal(f) {
                format!(
                    "check {}: {} (drive check calls this fatal: the data is useless; ranked because of --allow-useless)",
                    f.check, f.message
                )
            } else {
                format!("check {}: {}", f.check, f.message)
            }
        })
        .collect())
}

/// Fits every model on all of each training dataset of `pairs`, scores it on each test
/// dataset's evaluation windows.
fn transfer_cells(
    inputs: &[BenchInput],
    specs: &[ModelSpec],
    config: &BenchConfig,
    pairs: &[(usize, usize)],
    datasets: &[BenchDataset],
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<TransferCell>, BenchError> {
    let mut trained: Vec<usize> = pairs.iter().map(|p| p.0).collect();
    trained.sort_unstable();
    trained.dedup();
    // Point predictions only: no calibration of the covariance.
    let plain: Vec<ModelSpec> = specs
        .iter()
        .map(|s| s.clone().with_uncertainty(Uncertainty::Paper, s.start))
        .collect();
    let jobs: Vec<(usize, usize)> = trained
        .iter()
        .flat_map(|&a| (0..plain.len()).map(move |m| (a, m)))
        .collect();
    let fitted: Vec<((usize, usize), Box<dyn MotionModel>)> = jobs
        .par_iter()
        .map(|&(a, m)| {
            let model =
                plain[m]
                    .fit(&inputs[a].data.all())
                    .map_err(|reason| BenchError::TransferFit {
                        model: specs[m].name.clone(),
                        dataset: inputs[a].name.clone(),
                        reason,
                    });
            progress();
            model.map(|model| ((a, m), model))
        })
        .collect::<Result<_, _>>()?;
    let fitted: HashMap<(usize, usize), Box<dyn MotionModel>> = fitted.into_iter().collect();
    let cells: Vec<(usize, usize, usize)> = pairs
        .iter()
        .flat_map(|&(a, b)| (0..specs.len()).map(move |m| (a, b, m)))
        .collect();
    cells
        .par_iter()
        .map(|&(a, b, m)| {
            let (ia, ib) = (&inputs[a], &inputs[b]);
            // The split was checked when the test dataset was compared.
            let (_, eval) =
                split_by_interval(&ib.data, config.split).map_err(|e| BenchError::Dataset {
                    name: ib.name.clone(),
                    reason: e.into(),
                })?;
            // Every (training dataset, model) of a pair was fitted above.
            let model = &fitted[&(a, m)];
            let report = evaluate_errors(model.as_ref(), &eval, plain[m].start);
            let own = &datasets[b].models[m];
            let t = report.translational(None).map_or(f64::NAN, |s| s.median);
            let r = report.rotational(None).map_or(f64::NAN, |s| s.median);
            let loss = |x: f64, own: f64| -drive_eval::improvement_percent(x, own);
            progress();
            Ok(TransferCell {
                model: specs[m].name.clone(),
                train: ia.name.clone(),
                test: ib.name.clone(),
                robot: ia.robot.clone(),
                same_geometry: serde_json::to_value(ia.data.robot.vehicle.as_ref()).ok()
                    == serde_json::to_value(ib.data.robot.vehicle.as_ref()).ok(),
                same_terrain: (terrain_known(&ia.terrain) && terrain_known(&ib.terrain))
                    .then(|| ia.terrain.trim().eq_ignore_ascii_case(ib.terrain.trim())),
                translational_median_m: t,
                rotational_median_rad: r,
                own_translational_median_m: own.translational_median_m,
                own_rotational_median_rad: own.rotational_median_rad,
                loss_translational_percent: loss(t, own.translational_median_m),
                loss_rotational_percent: loss(r, own.rotational_median_rad),
            })
        })
        .collect()
}

fn summarize_transfer(model: &str, cells: &[TransferCell]) -> TransferSummary {
    let group = |same: bool| {
        let of: Vec<&TransferCell> = cells
            .iter()
            .filter(|c| c.model == model && c.same_terrain == Some(same))
            .collect();
        let t: Vec<f64> = of.iter().map(|c| c.loss_translational_percent).collect();
        let r: Vec<f64> = of.iter().map(|c| c.loss_rotational_percent).collect();
        TransferGroup {
            pairs: of.len(),
            median_loss_translational_percent: finite_median(&t),
            median_loss_rotational_percent: finite_median(&r),
        }
    };
    TransferSummary {
        model: model.to_string(),
        same_terrain: group(true),
        other_terrain: group(false),
        unknown_terrain_pairs: cells
            .iter()
            .filter(|c| c.model == model && c.same_terrain.is_none())
            .count(),
        other_geometry_pairs: cells
            .iter()
            .filter(|c| c.model == model && !c.same_geometry)
            .count(),
    }
}

fn leaderboard(
    specs: &[ModelSpec],
    datasets: &[BenchDataset],
    adaptation: Option<&BenchAdaptation>,
) -> Vec<LeaderboardRow> {
    let mut rows: Vec<LeaderboardRow> = specs
        .iter()
        .enumerate()
        .map(|(m, spec)| {
            let of: Vec<&BenchModel> = datasets.iter().map(|d| &d.models[m]).collect();
            let n = of.len().max(1) as f64;
            let mean = |f: &dyn Fn(&BenchModel) -> f64| of.iter().map(|b| f(b)).sum::<f64>() / n;
            let above = |i: &drive_eval::Improvement| i.ci[0] > 0.0;
            let below = |i: &drive_eval::Improvement| i.ci[1] < 0.0;
            let count = |f: &dyn Fn(&PairedImprovement) -> bool| {
                datasets
                    .iter()
                    .filter(|d| d.evidence)
                    .map(|d| &d.models[m])
                    .filter(|b| b.improvement_over_slip_blr.as_ref().is_some_and(f))
                    .count()
            };
            let geometric = |pick: fn(&Ratio) -> f64| {
                let logs: Vec<f64> = of
                    .iter()
                    .filter_map(|b| b.ratio_to_slip_blr.as_ref().map(pick))
                    .map(f64::ln)
                    .collect();
                if logs.is_empty() {
                    f64::NAN
                } else {
                    (logs.iter().sum::<f64>() / logs.len() as f64).exp()
                }
            };
            let mean_of =
                |v: Vec<f64>| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
            LeaderboardRow {
                model: spec.name.clone(),
                datasets: of.len(),
                mean_rank: mean(&|b| 0.5 * (b.rank_translational + b.rank_rotational)),
                mean_rank_translational: mean(&|b| b.rank_translational),
                mean_rank_rotational: mean(&|b| b.rank_rotational),
                wins_over_slip_blr: count(&|i| above(&i.translational) && above(&i.rotational)),
                wins_translational: count(&|i| above(&i.translational)),
                wins_rotational: count(&|i| above(&i.rotational)),
                losses_to_slip_blr: count(&|i| below(&i.translational) || below(&i.rotational)),
                ratio_to_slip_blr: Ratio {
                    translational: geometric(|r| r.translational),
                    rotational: geometric(|r| r.rotational),
                },
                error_growth_spearman: [
                    mean_of(
                        of.iter()
                            .filter_map(|b| b.error_growth.spearman_translational)
                            .collect(),
                    ),
                    mean_of(
                        of.iter()
                            .filter_map(|b| b.error_growth.spearman_rotational)
                            .collect(),
                    ),
                ],
                adaptive_over_own_60s: adaptation.and_then(|a| {
                    a.summary
                        .iter()
                        .find(|s| s.model == spec.name && s.t_s == LEADERBOARD_ADAPT_T_S)
                        .and_then(|s| s.adaptive_over_own)
                }),
            }
        })
        .collect();
    rows.sort_by(|a, b| a.mean_rank.total_cmp(&b.mean_rank));
    rows
}
