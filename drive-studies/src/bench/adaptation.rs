//! The benchmark's adaptation track (`drive bench --adapt`, issue 61): for every ordered
//! pair of the suite's runs of one robot (the transfer's pairs), each model fitted on all of
//! the first run adapts to the second as [`crate::adapt`] does; per pair its curves, and per
//! model and time the median over the pairs of the adaptive model's errors over the other
//! three's.

use super::results::Ratio;
use super::{terrain_known, BenchInput};
use crate::adapt::{adapt_with, AdaptPoint, AdaptPrior, AdaptStudy};
use crate::ExperimentError;
use drive_models::ModelSpec;
use rayon::prelude::*;
use serde::Serialize;

/// The time (s of the target's driving) the leaderboard quotes the adaptation at: the
/// issue's "after 60 s of the new run".
pub const LEADERBOARD_ADAPT_T_S: f64 = 60.0;

/// One model adapting from one run of a pair to the other.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AdaptPair {
    /// The model (as named in the benchmark).
    pub model: String,
    /// The run its prior was fitted on (all of it).
    pub prior: String,
    /// The run it adapts to (its training half streamed, its evaluation half scored).
    pub target: String,
    /// The robot of both.
    pub robot: String,
    /// Whether both runs' terrains are known and equal; `None` when either is unknown.
    pub same_terrain: Option<bool>,
    /// Seconds in the target's training half.
    pub train_s: f64,
    /// Share of the target's training windows commanded beyond the prior's commands
    /// (extrapolation, not terrain: see [`crate::Extrapolation`]).
    pub share_beyond_prior: Option<f64>,
    /// The four curves (`adaptive`, `frozen`, `scratch`, `own`) at each time.
    pub curve: Vec<AdaptPoint>,
}

/// Per model and time: the median over the pairs of the adaptive model's eq. 8 median over
/// each other model's (translational, rotational).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AdaptSummary {
    /// The model.
    pub model: String,
    /// Seconds of the target's training half streamed.
    pub t_s: f64,
    /// Pairs whose training half reaches `t_s`.
    pub pairs: usize,
    /// Median over the pairs of adaptive / own (the model fitted on the target's whole
    /// training half).
    pub adaptive_over_own: Option<Ratio>,
    /// Median over the pairs of adaptive / frozen (the prior alone).
    pub adaptive_over_frozen: Option<Ratio>,
    /// Median over the pairs of adaptive / scratch (fitted on the same seconds only);
    /// `None` at t = 0.
    pub adaptive_over_scratch: Option<Ratio>,
    /// The largest adaptive / frozen over the pairs of one terrain (both axes): what
    /// adapting costs where the ground did not change; `None` without such a pair.
    pub worst_over_frozen_same_terrain: Option<f64>,
    /// Pairs where the detector found the ground changed at this time.
    pub ground_changed_pairs: usize,
}

/// The adaptation track of a benchmark.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BenchAdaptation {
    /// The times scored (s of each target's training half, those beyond a half left out).
    pub times_s: Vec<f64>,
    /// Every model adapted on every pair.
    pub pairs: Vec<AdaptPair>,
    /// Per model and time, over the pairs.
    pub summary: Vec<AdaptSummary>,
    /// Models or pairs without an adaptation, with why (a model that is not composed of a
    /// powertrain and a slip model, a target too short for any time).
    pub skipped: Vec<String>,
}

/// Runs the adaptation track on `pairs` (indices into `inputs`).
pub(super) fn adaptation(
    inputs: &[BenchInput],
    specs: &[ModelSpec],
    study: &AdaptStudy,
    pairs: &[(usize, usize)],
    progress: &(dyn Fn() + Sync),
) -> BenchAdaptation {
    let jobs: Vec<(usize, usize, usize)> = pairs
        .iter()
        .flat_map(|&(a, b)| (0..specs.len()).map(move |m| (a, b, m)))
        .collect();
    let outcomes: Vec<Result<AdaptPair, String>> = jobs
        .par_iter()
        .map(|&(a, b, m)| {
            let (ia, ib) = (&inputs[a], &inputs[b]);
            let spec = &specs[m];
            let done = adapt_with(
                None,
                &AdaptPrior::Data(&ia.data),
                &ib.data,
                std::slice::from_ref(spec),
                study,
                &|| {},
            );
            progress();
            match done {
                Ok(d) => Ok(AdaptPair {
                    model: spec.name.clone(),
                    prior: ia.name.clone(),
                    target: ib.name.clone(),
                    robot: ia.robot.clone(),
                    same_terrain: (terrain_known(&ia.terrain) && terrain_known(&ib.terrain))
                        .then(|| ia.terrain.trim().eq_ignore_ascii_case(ib.terrain.trim())),
                    train_s: d.train_s,
                    share_beyond_prior: d.extrapolation.map(|e| e.share_beyond),
                    curve: d.curve,
                }),
                // A model the adaptation does not apply to is named once, not per pair.
                Err(ExperimentError::Incompatible(why))
                    if why.contains("only a model composed") =>
                {
                    Err(format!("{}: {why}", spec.name))
                }
                Err(e) => Err(format!("{} -> {}, {}: {e}", ia.name, ib.name, spec.name)),
            }
        })
        .collect();
    let mut done = Vec::new();
    let mut skipped: Vec<String> = Vec::new();
    for o in outcomes {
        match o {
            Ok(p) => done.push(p),
            Err(why) => {
                if !skipped.contains(&why) {
                    skipped.push(why);
                }
            }
        }
    }
    let mut times_s: Vec<f64> = done
        .iter()
        .flat_map(|p| p.curve.iter().map(|c| c.t_s))
        .collect();
    times_s.sort_by(f64::total_cmp);
    times_s.dedup();
    let summary = specs
        .iter()
        .flat_map(|spec| {
            let done = &done;
            times_s.iter().map(move |&t| summarize(&spec.name, t, done))
        })
        .filter(|s| s.pairs > 0)
        .collect();
    BenchAdaptation {
        times_s,
        pairs: done,
        summary,
        skipped,
    }
}

/// The eq. 8 medians of `model` (`adaptive`, `frozen`, ...) at `t` in `pair`.
fn point<'a>(pair: &'a AdaptPair, model: &str, t: f64) -> Option<&'a AdaptPoint> {
    pair.curve.iter().find(|p| p.model == model && p.t_s == t)
}

/// The adaptive model's medians over `other`'s, per axis.
fn ratio(pair: &AdaptPair, other: &str, t: f64) -> Option<[f64; 2]> {
    let (a, o) = (point(pair, "adaptive", t)?, point(pair, other, t)?);
    let r = |x: Option<f64>, y: Option<f64>| Some(x? / y?).filter(|v| v.is_finite());
    Some([
        r(a.translational_median_m, o.translational_median_m)?,
        r(a.rotational_median_rad, o.rotational_median_rad)?,
    ])
}

fn summarize(model: &str, t: f64, pairs: &[AdaptPair]) -> AdaptSummary {
    let of: Vec<&AdaptPair> = pairs
        .iter()
        .filter(|p| p.model == model && point(p, "adaptive", t).is_some())
        .collect();
    let median_ratio = |other: &str| {
        let rs: Vec<[f64; 2]> = of.iter().filter_map(|p| ratio(p, other, t)).collect();
        let axis = |i: usize| {
            let v: Vec<f64> = rs.iter().map(|r| r[i]).collect();
            super::finite_median(&v)
        };
        Some(Ratio {
            translational: axis(0)?,
            rotational: axis(1)?,
        })
    };
    AdaptSummary {
        model: model.to_string(),
        t_s: t,
        pairs: of.len(),
        adaptive_over_own: median_ratio("own"),
        adaptive_over_frozen: median_ratio("frozen"),
        adaptive_over_scratch: median_ratio("scratch"),
        worst_over_frozen_same_terrain: of
            .iter()
            .filter(|p| p.same_terrain == Some(true))
            .filter_map(|p| ratio(p, "frozen", t))
            .map(|r| r[0].max(r[1]))
            .reduce(f64::max),
        ground_changed_pairs: of
            .iter()
            .filter(|p| point(p, "adaptive", t).and_then(|a| a.ground_changed) == Some(true))
            .count(),
    }
}
