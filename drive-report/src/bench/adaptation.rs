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

/// The summary tables' columns: the adaptive model's, and the library's (without `changed`).
const COLUMNS: [&str; 8] = [
    "model",
    "t [s]",
    "pairs",
    "/ frozen",
    "/ scratch",
    "/ own",
    "worst / frozen",
    "changed",
];

/// The summary's rows as cells ([`COLUMNS`]): the adaptive model's, and the library's
/// where a row has one (its last column left out).
fn rows(a: &BenchAdaptation) -> (Vec<Vec<String>>, Vec<Vec<String>>) {
    let mut adaptive = Vec::new();
    let mut library = Vec::new();
    for r in &a.summary {
        adaptive.push(vec![
            r.model.clone(),
            r.t_s.to_string(),
            r.pairs.to_string(),
            ratio(r.adaptive_over_frozen),
            ratio(r.adaptive_over_scratch),
            ratio(r.adaptive_over_own),
            worst(r.worst_over_frozen_same_terrain),
            r.ground_changed_pairs.to_string(),
        ]);
        if let Some(l) = &r.library {
            library.push(vec![
                r.model.clone(),
                r.t_s.to_string(),
                l.pairs.to_string(),
                ratio(l.over_frozen),
                ratio(l.over_scratch),
                ratio(l.over_own),
                worst(l.worst_over_frozen_same_terrain),
            ]);
        }
    }
    (adaptive, library)
}

/// A row of the terminal's table: the model `mw` wide, the rest in fixed columns.
fn text_row<S: AsRef<str>>(cells: &[S], mw: usize) -> String {
    let mut s = String::from("  ");
    for (i, c) in cells.iter().enumerate() {
        let c = c.as_ref();
        let _ = match i {
            0 => write!(s, "{c:<mw$}"),
            1 => write!(s, "{c:>7}"),
            2 => write!(s, "  {c:>5}  "),
            3..=5 => write!(s, "{c:<17}"),
            6 => write!(s, "{c:>14}"),
            _ => write!(s, "  {c:>7}"),
        };
    }
    s
}

/// A row of a Markdown table, the model (the first cell) escaped by `md`.
fn md_row<S: AsRef<str>>(cells: &[S], md: fn(&str) -> String) -> String {
    let cells: Vec<String> = cells
        .iter()
        .enumerate()
        .map(|(i, c)| {
            if i == 0 {
                md(c.as_ref())
            } else {
                c.as_ref().to_string()
            }
        })
        .collect();
    format!("| {} |", cells.join(" | "))
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
    let (adaptive, library) = rows(a);
    let _ = writeln!(s, "{}", text_row(&COLUMNS, mw));
    for r in &adaptive {
        let _ = writeln!(s, "{}", text_row(r, mw));
    }
    if !library.is_empty() {
        let _ = writeln!(s, "\n{LIBRARY}");
        let _ = writeln!(s, "{}", text_row(&COLUMNS[..7], mw));
        for r in &library {
            let _ = writeln!(s, "{}", text_row(r, mw));
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
    let (adaptive, library) = rows(a);
    let header = |n: usize| format!("| {} |\n|{}", COLUMNS[..n].join(" | "), "---|".repeat(n));
    let _ = writeln!(s, "{}", header(8));
    for r in &adaptive {
        let _ = writeln!(s, "{}", md_row(r, md));
    }
    if !library.is_empty() {
        let _ = writeln!(s, "\n{LIBRARY}\n\n{}", header(7));
        for r in &library {
            let _ = writeln!(s, "{}", md_row(r, md));
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
