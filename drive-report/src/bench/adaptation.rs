//! The benchmark's adaptation track (`drive bench --adapt`): its summary as text and
//! Markdown, its curves as CSV.

use super::field;
use drive_studies::{BenchAdaptation, Ratio};
use std::fmt::Write as _;

const INTRO: &str = "adaptation: each model fitted on all of one run adapts to another run of the same robot (its training half streamed in time order, as drive adapt); median over the pairs of the adaptive model's eq. 8 median over the prior alone (frozen), the fit from scratch on the same seconds (scratch) and the fit on the whole training half (own), translational / rotational; worst / frozen: the largest over the pairs of one terrain";

const LIBRARY: &str = "library: the prior and the model fitted on each other run of the robot (but the target), blended by their likelihood of the windows driven (as drive adapt --library); the same medians over the pairs with a library";

/// A ratio's two axes, `-` without one.
pub(super) fn ratio(r: Option<Ratio>) -> String {
    r.map_or("-".into(), |r| {
        format!("{:.3} / {:.3}", r.translational, r.rotational)
    })
}

fn worst(v: Option<f64>) -> String {
    v.map_or("-".into(), |v| format!("{v:.3}"))
}

/// The adaptation's summary as the terminal shows it, after the transfer.
pub(super) fn text(a: &BenchAdaptation) -> String {
    let mut s = format!("\n{INTRO}\n");
    let mw = a
        .summary
        .iter()
        .map(|r| r.model.len())
        .max()
        .unwrap_or(0)
        .max(5)
        + 2;
    let _ = writeln!(
        s,
        "  {:<mw$}{:>7}  {:>5}  {:<17}{:<17}{:<17}{:>14}  {:>7}",
        "model", "t [s]", "pairs", "/ frozen", "/ scratch", "/ own", "worst / frozen", "changed"
    );
    for r in &a.summary {
        let _ = writeln!(
            s,
            "  {:<mw$}{:>7}  {:>5}  {:<17}{:<17}{:<17}{:>14}  {:>7}",
            r.model,
            r.t_s,
            r.pairs,
            ratio(r.adaptive_over_frozen),
            ratio(r.adaptive_over_scratch),
            ratio(r.adaptive_over_own),
            worst(r.worst_over_frozen_same_terrain),
            r.ground_changed_pairs
        );
    }
    if a.summary.iter().any(|r| r.library.is_some()) {
        let _ = writeln!(s, "\n{LIBRARY}");
        let _ = writeln!(
            s,
            "  {:<mw$}{:>7}  {:>5}  {:<17}{:<17}{:<17}{:>14}",
            "model", "t [s]", "pairs", "/ frozen", "/ scratch", "/ own", "worst / frozen"
        );
        for r in &a.summary {
            if let Some(l) = &r.library {
                let _ = writeln!(
                    s,
                    "  {:<mw$}{:>7}  {:>5}  {:<17}{:<17}{:<17}{:>14}",
                    r.model,
                    r.t_s,
                    l.pairs,
                    ratio(l.over_frozen),
                    ratio(l.over_scratch),
                    ratio(l.over_own),
                    worst(l.worst_over_frozen_same_terrain)
                );
            }
        }
    }
    if a.pairs.is_empty() {
        let _ = writeln!(s, "  no pair of runs of one robot adapted");
    }
    for why in &a.skipped {
        let _ = writeln!(s, "adaptation skipped: {why}");
    }
    s
}

/// The adaptation's section of `bench.md`.
pub(super) fn markdown(a: &BenchAdaptation, md: fn(&str) -> String) -> String {
    let mut s = String::from("\n## Adaptation to another run's ground\n\n");
    let _ = writeln!(
        s,
        "Each model fitted on all of one run adapts to another run of the same robot, as `drive adapt` (its training half streamed in time order, scored on its evaluation half after t seconds of it); per model and t, the median over the pairs of the adaptive model's eq. 8 median over the prior alone (frozen), the model fitted from scratch on the same t seconds (scratch) and the one fitted on the whole training half (own), translational / rotational. Worst / frozen: the largest over the pairs of one terrain (both axes). Changed: the pairs where the detector found the ground changed. Every pair's curves are in `adapt.csv`.\n"
    );
    let _ = writeln!(
        s,
        "| model | t [s] | pairs | / frozen | / scratch | / own | worst / frozen | changed |\n|---|---|---|---|---|---|---|---|"
    );
    for r in &a.summary {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            md(&r.model),
            r.t_s,
            r.pairs,
            ratio(r.adaptive_over_frozen),
            ratio(r.adaptive_over_scratch),
            ratio(r.adaptive_over_own),
            worst(r.worst_over_frozen_same_terrain),
            r.ground_changed_pairs
        );
    }
    if a.summary.iter().any(|r| r.library.is_some()) {
        let _ = writeln!(
            s,
            "\n{LIBRARY}\n\n| model | t [s] | pairs | / frozen | / scratch | / own | worst / frozen |\n|---|---|---|---|---|---|---|"
        );
        for r in &a.summary {
            if let Some(l) = &r.library {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {} | {} |",
                    md(&r.model),
                    r.t_s,
                    l.pairs,
                    ratio(l.over_frozen),
                    ratio(l.over_scratch),
                    ratio(l.over_own),
                    worst(l.worst_over_frozen_same_terrain)
                );
            }
        }
    }
    for why in &a.skipped {
        let _ = writeln!(s, "\nAdaptation skipped: {}", md(why));
    }
    s
}

/// One row per pair, model, curve and time: `adapt.csv`.
pub fn adapt_csv(a: &BenchAdaptation) -> String {
    let mut s = String::from(
        "model,prior,target,robot,same_terrain,train_s,share_beyond_prior,curve,t_s,translational_median_m,rotational_median_rad,ground_changed\n",
    );
    let num = |v: Option<f64>| {
        v.filter(|x| x.is_finite())
            .map_or(String::new(), |x| x.to_string())
    };
    for p in &a.pairs {
        for c in &p.curve {
            let row = [
                field(&p.model),
                field(&p.prior),
                field(&p.target),
                field(&p.robot),
                p.same_terrain.map_or(String::new(), |b| b.to_string()),
                num(Some(p.train_s)),
                num(p.share_beyond_prior),
                c.model.to_string(),
                num(Some(c.t_s)),
                num(c.translational_median_m),
                num(c.rotational_median_rad),
                c.ground_changed.map_or(String::new(), |b| b.to_string()),
            ];
            let _ = writeln!(s, "{}", row.join(","));
        }
    }
    s
}
