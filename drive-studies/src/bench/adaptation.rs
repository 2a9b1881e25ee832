//! The benchmark's adaptation track (`drive bench --adapt`, issue 61): for every ordered
//! pair of the suite's runs of one robot (the transfer's pairs), each model fitted on all of
//! the first run adapts to the second as [`crate::adapt`] does; per pair its curves, and per
//! model and time the median over the pairs of the adaptive model's errors over the other
//! three's.

use super::results::Ratio;
use super::{terrain_known, BenchInput};
use crate::adapt::{adapt_with, library_member, AdaptPoint, AdaptPrior, AdaptStudy, NamedModels};
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
    /// The four curves (`adaptive`, `frozen`, `scratch`, `own`) at each time, and
    /// `library` with the terrain library.
    pub curve: Vec<AdaptPoint>,
    /// With the terrain library (`--adapt-library`): its models, the prior's run first,
    /// then the robot's other runs (the weights of the `library` points are in this order).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub library: Vec<String>,
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
    /// With the terrain library (`--adapt-library`): the median over the pairs of the
    /// library's blend over own, frozen and scratch, and its largest over frozen on pairs
    /// of one terrain, as the adaptive model's above (pairs with a library only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub library: Option<LibrarySummary>,
}

/// The terrain library's blend against the other curves, over the pairs that have one.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LibrarySummary {
    /// Pairs with a library (the robot has a third run) whose training half reaches `t_s`.
    pub pairs: usize,
    /// Median over the pairs of library / own.
    pub over_own: Option<Ratio>,
    /// Median over the pairs of library / frozen.
    pub over_frozen: Option<Ratio>,
    /// Median over the pairs of library / scratch; `None` at t = 0.
    pub over_scratch: Option<Ratio>,
    /// The largest library / frozen over the pairs of one terrain (both axes).
    pub worst_over_frozen_same_terrain: Option<f64>,
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
    /// powertrain and a slip model, a target too short for any time, two datasets that are
    /// not a pair: of other rates, or one run twice, as the transfer's `transfer_skipped`
    /// says).
    pub skipped: Vec<String>,
}

/// Runs the adaptation track on `pairs` (indices into `inputs`), with a terrain library for
/// each pair when `library` (the prior's run and the robot's other runs but the target and
/// the runs that are the target's, [`super::transfer_pairs`]); the pairs left out of `pairs`
/// are named in `skipped` with why (`pairs_skipped`).
pub(super) fn adaptation(
    inputs: &[BenchInput],
    specs: &[ModelSpec],
    study: &AdaptStudy,
    pairs: &[(usize, usize)],
    pairs_skipped: &[String],
    library: bool,
    progress: &(dyn Fn() + Sync),
) -> BenchAdaptation {
    let jobs: Vec<(usize, usize, usize)> = pairs
        .iter()
        .flat_map(|&(a, b)| (0..specs.len()).map(move |m| (a, b, m)))
        .collect();
    // Each run's library member, fitted once for all its pairs (a run that cannot be
    // fitted is left out of the libraries it would join).
    let mut runs: Vec<(usize, usize)> = if library {
        jobs.iter().map(|&(a, _, m)| (a, m)).collect()
    } else {
        Vec::new()
    };
    runs.sort_unstable();
    runs.dedup();
    let members: std::collections::HashMap<
        (usize, usize),
        std::sync::Arc<dyn drive_traits::MotionModel>,
    > = runs
        .par_iter()
        .filter_map(|&(i, m)| {
            library_member(&inputs[i].data, &specs[m])
                .ok()
                .map(|f| ((i, m), f))
        })
        .collect();
    // The library of a pair: the prior's run, then the robot's others but the target and
    // the runs that are the target's (a copy of it, a part of it or a run it is part of:
    // the pair they would make with it is not a pair), whose models would be scored on
    // windows they were fitted on; none where the robot has no third run.
    let library_of = |a: usize, b: usize, m: usize| -> Option<NamedModels> {
        let others: Vec<usize> = pairs
            .iter()
            .filter(|&&(x, c)| x == a && c != b && pairs.contains(&(c, b)))
            .map(|&(_, c)| c)
            .filter(|c| members.contains_key(&(*c, m)))
            .collect();
        if others.is_empty() {
            return None;
        }
        std::iter::once(a)
            .chain(others)
            .map(|i| {
                members
                    .get(&(i, m))
                    .map(|f| (inputs[i].name.clone(), std::sync::Arc::clone(f)))
            })
            .collect()
    };
    let outcomes: Vec<Result<AdaptPair, String>> = jobs
        .par_iter()
        .map(|&(a, b, m)| {
            let (ia, ib) = (&inputs[a], &inputs[b]);
            let spec = &specs[m];
            let library = library_of(a, b, m);
            let done = adapt_with(
                None,
                &AdaptPrior::Data(&ia.data),
                &ib.data,
                std::slice::from_ref(spec),
                study,
                library.as_ref(),
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
                    library: library
                        .map(|l| l.into_iter().map(|(n, _)| n).collect())
                        .unwrap_or_default(),
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
    let mut skipped: Vec<String> = pairs_skipped.to_vec();
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

/// `model`'s medians over `other`'s, per axis.
fn ratio(pair: &AdaptPair, model: &str, other: &str, t: f64) -> Option<[f64; 2]> {
    let (a, o) = (point(pair, model, t)?, point(pair, other, t)?);
    let r = |x: Option<f64>, y: Option<f64>| Some(x? / y?).filter(|v| v.is_finite());
    Some([
        r(a.translational_median_m, o.translational_median_m)?,
        r(a.rotational_median_rad, o.rotational_median_rad)?,
    ])
}

fn summarize(model: &str, t: f64, pairs: &[AdaptPair]) -> AdaptSummary {
    let of = |curve: &str| -> Vec<&AdaptPair> {
        pairs
            .iter()
            .filter(|p| p.model == model && point(p, curve, t).is_some())
            .collect()
    };
    let median_ratio = |of: &[&AdaptPair], curve: &str, other: &str| {
        let rs: Vec<[f64; 2]> = of
            .iter()
            .filter_map(|p| ratio(p, curve, other, t))
            .collect();
        let axis = |i: usize| {
            let v: Vec<f64> = rs.iter().map(|r| r[i]).collect();
            super::finite_median(&v)
        };
        Some(Ratio {
            translational: axis(0)?,
            rotational: axis(1)?,
        })
    };
    let worst = |of: &[&AdaptPair], curve: &str| {
        of.iter()
            .filter(|p| p.same_terrain == Some(true))
            .filter_map(|p| ratio(p, curve, "frozen", t))
            .map(|r| r[0].max(r[1]))
            .reduce(f64::max)
    };
    let adapted = of("adaptive");
    let library = of("library");
    AdaptSummary {
        model: model.to_string(),
        t_s: t,
        pairs: adapted.len(),
        adaptive_over_own: median_ratio(&adapted, "adaptive", "own"),
        adaptive_over_frozen: median_ratio(&adapted, "adaptive", "frozen"),
        adaptive_over_scratch: median_ratio(&adapted, "adaptive", "scratch"),
        worst_over_frozen_same_terrain: worst(&adapted, "adaptive"),
        ground_changed_pairs: adapted
            .iter()
            .filter(|p| point(p, "adaptive", t).and_then(|a| a.ground_changed) == Some(true))
            .count(),
        library: (!library.is_empty()).then(|| LibrarySummary {
            pairs: library.len(),
            over_own: median_ratio(&library, "library", "own"),
            over_frozen: median_ratio(&library, "library", "frozen"),
            over_scratch: median_ratio(&library, "library", "scratch"),
            worst_over_frozen_same_terrain: worst(&library, "library"),
        }),
    }
}
