//! The benchmark as the terminal shows it (`drive bench` without `--json`).

use drive_studies::Bench;
use std::fmt::Write as _;

/// `+12.3` with a `!` when the interval excludes 0 and counts as evidence.
fn signed(i: &drive_eval::Improvement, evidence: bool) -> String {
    let sure = evidence && (i.ci[0] > 0.0 || i.ci[1] < 0.0);
    format!("{:+.1}{}", i.percent, if sure { "!" } else { "" })
}

fn terrain_text(t: &str) -> String {
    let t = if t.is_empty() { "not recorded" } else { t };
    if t.chars().count() > 22 {
        format!("{}...", t.chars().take(19).collect::<String>())
    } else {
        t.to_string()
    }
}

/// `-` for none (a non-finite value printed as it is, unlike the Markdown's).
fn or_dash(v: Option<f64>, digits: usize) -> String {
    v.map_or("-".into(), |v| format!("{v:.digits$}"))
}

/// The benchmark as text (what `drive bench` prints): datasets, medians, improvements over
/// slip-BLR, transfer, leaderboard. `transfer` says whether the transfer part was run (its
/// absence is then explained).
///
/// ```no_run
/// # fn demo(bench: &drive_studies::Bench) {
/// let text = drive_report::bench::text(bench, true);
/// assert!(text.starts_with("DRIVE benchmark: "));
/// # }
/// ```
pub fn text(b: &Bench, transfer: bool) -> String {
    let mut s = String::new();
    let nw = b
        .datasets
        .iter()
        .map(|d| d.name.chars().count())
        .max()
        .unwrap_or(0)
        .max(7)
        + 2;
    let mw = b
        .model_names
        .iter()
        .map(String::len)
        .max()
        .unwrap_or(0)
        .max(17)
        + 2;
    let header = format!(
        "  {:<nw$}{}",
        "dataset",
        b.model_names
            .iter()
            .map(|m| format!("{m:<mw$}"))
            .collect::<String>()
    );
    let _ = writeln!(
        s,
        "DRIVE benchmark: {} datasets x {} models; each dataset's first {} of the intervals trains, the rest evaluates (as drive eval)\n",
        b.datasets.len(),
        b.model_names.len(),
        b.split
    );
    let _ = writeln!(
        s,
        "datasets (unpredictability: median over the {} windows' samples, 0 = moves as commanded, 1 = does not move)",
        b.datasets
            .first()
            .map_or("steady", |d| d.unpredictability.pooled)
    );
    let _ = writeln!(
        s,
        "  {:<nw$}{:<10}{:<24}{:>8}  unpredictability transl. / rot. / total",
        "dataset", "robot", "terrain", "eval win"
    );
    for d in &b.datasets {
        let u = &d.unpredictability;
        let _ = writeln!(
            s,
            "  {:<nw$}{:<10}{:<24}{:>8}  {} / {} / {}",
            d.name,
            if d.robot.chars().count() > 9 {
                format!("{}.", d.robot.chars().take(8).collect::<String>())
            } else {
                d.robot.clone()
            },
            terrain_text(&d.terrain),
            d.eval_windows,
            or_dash(u.translational.map(|x| x.median), 3),
            or_dash(u.rotational.map(|x| x.median), 3),
            or_dash(u.total.map(|x| x.median), 3),
        );
    }
    for d in &b.datasets {
        for note in &d.notes {
            let _ = writeln!(s, "  note on {}: {note}", d.name);
        }
    }
    let _ = writeln!(
        s,
        "\nmedian MRMSE (paper eq. 8) on the evaluation windows: translational [m] / rotational [rad]; * best of the row"
    );
    let _ = writeln!(s, "{header}");
    for d in &b.datasets {
        let _ = write!(s, "  {:<nw$}", d.name);
        let best_t = d
            .models
            .iter()
            .map(|m| m.translational_median_m)
            .fold(f64::INFINITY, f64::min);
        let best_r = d
            .models
            .iter()
            .map(|m| m.rotational_median_rad)
            .fold(f64::INFINITY, f64::min);
        for m in &d.models {
            let star = |v: f64, best: f64| if v == best { "*" } else { "" };
            let cell = format!(
                "{:.3}{}/{:.3}{}",
                m.translational_median_m,
                star(m.translational_median_m, best_t),
                m.rotational_median_rad,
                star(m.rotational_median_rad, best_r)
            );
            let _ = write!(s, "{cell:<mw$}");
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(
        s,
        "\nimprovement of the medians over slip-BLR, translational / rotational [%]; ! where the 95% paired bootstrap interval excludes 0"
    );
    let _ = writeln!(s, "{header}");
    for d in &b.datasets {
        let _ = write!(s, "  {:<nw$}", d.name);
        for m in &d.models {
            let cell = m.improvement_over_slip_blr.map_or("-".into(), |i| {
                format!(
                    "{}/{}",
                    signed(&i.translational, d.evidence),
                    signed(&i.rotational, d.evidence)
                )
            });
            let _ = write!(s, "{cell:<mw$}");
        }
        let _ = writeln!(s);
    }
    if b.transfer.is_empty() {
        let _ = writeln!(
            s,
            "\ntransfer: {}",
            if !transfer {
                "not run (--no-transfer)"
            } else if b.transfer_skipped.is_empty() {
                "no two datasets of the same robot"
            } else {
                "no two datasets of the same robot that can be compared"
            }
        );
    } else {
        let _ = writeln!(
            s,
            "\ntransfer: each model fitted on all of one run, scored on another run of the same robot; median over the pairs of the loss against the model fitted on that run itself, translational / rotational [%]"
        );
        let group = |g: &drive_studies::TransferGroup| {
            if g.pairs == 0 {
                "-".to_string()
            } else {
                format!(
                    "{:+.1} / {:+.1} ({} pairs)",
                    g.median_loss_translational_percent.unwrap_or(f64::NAN),
                    g.median_loss_rotational_percent.unwrap_or(f64::NAN),
                    g.pairs
                )
            }
        };
        let _ = writeln!(
            s,
            "  {:<mw$}{:<30}{:<30}terrain unknown",
            "model", "same terrain", "other terrain"
        );
        for t in &b.transfer_summary {
            let _ = writeln!(
                s,
                "  {:<mw$}{:<30}{:<30}{} pairs",
                t.model,
                group(&t.same_terrain),
                group(&t.other_terrain),
                t.unknown_terrain_pairs
            );
        }
        if let Some(t) = b
            .transfer_summary
            .first()
            .filter(|t| t.other_geometry_pairs > 0)
        {
            let _ = writeln!(
                s,
                "  ({} of the pairs join runs of two vehicle geometries: the model keeps the geometry of the run it was fitted on)",
                t.other_geometry_pairs
            );
        }
    }
    if let Some(a) = &b.adaptation {
        s.push_str(&super::adaptation::text(a));
    }
    let _ = writeln!(
        s,
        "\nleaderboard over {} datasets: mean rank (1 best; translational and rotational ranks averaged), datasets where the model beats slip-BLR with the 95% interval above 0 (both / translation / rotation) or loses to it (datasets of {} evaluation intervals or more), geometric mean of the median's ratio to slip-BLR's, mean Spearman correlation of the window errors with the windows' unpredictability",
        b.datasets.len(),
        b.min_evidence_intervals
    );
    let adapted = b.adaptation.is_some();
    let _ = writeln!(
        s,
        "  {:<mw$}{:>9}  {:>14}  {:>6}  {:>8}  {:>8}  {:>13}{}",
        "model",
        "mean rank",
        "wins (b/t/r)",
        "losses",
        "ratio t",
        "ratio r",
        "growth t / r",
        if adapted { "  adapted / own, 60 s" } else { "" }
    );
    for r in &b.leaderboard {
        let growth = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:+.2}"));
        let adapt_cell = if adapted {
            format!("  {}", super::adaptation::ratio(r.adaptive_over_own_60s))
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "  {:<mw$}{:>9.2}  {:>14}  {:>6}  {:>8.3}  {:>8.3}  {:>13}{adapt_cell}",
            r.model,
            r.mean_rank,
            format!(
                "{}/{}/{}",
                r.wins_over_slip_blr, r.wins_translational, r.wins_rotational
            ),
            r.losses_to_slip_blr,
            r.ratio_to_slip_blr.translational,
            r.ratio_to_slip_blr.rotational,
            format!(
                "{} / {}",
                growth(r.error_growth_spearman[0]),
                growth(r.error_growth_spearman[1])
            )
        );
    }
    let no_body: Vec<&str> = b
        .datasets
        .iter()
        .filter(|d| d.unpredictability.body.is_none())
        .map(|d| d.name.as_str())
        .collect();
    if !no_body.is_empty() {
        let _ = writeln!(
            s,
            "\nno total unpredictability for {} (no body size: give robot = \"a preset or a robot file with body_length and body_width\")",
            no_body.join(", ")
        );
    }
    let few: Vec<String> = b
        .datasets
        .iter()
        .filter(|d| !d.evidence)
        .map(|d| format!("{} ({})", d.name, d.eval_intervals))
        .collect();
    if !few.is_empty() {
        let _ = writeln!(
            s,
            "too few evaluation intervals for their bootstrap intervals to count (no ! and no win or loss): {}",
            few.join(", ")
        );
    }
    for skipped in &b.transfer_skipped {
        let _ = writeln!(s, "transfer skipped: {skipped}");
    }
    for r in &b.transfer_unpaired {
        let _ = writeln!(
            s,
            "no transfer for robot {} ({}): {}",
            r.robot,
            r.datasets.join(", "),
            r.reason
        );
    }
    for skipped in &b.skipped {
        let _ = writeln!(
            s,
            "dataset skipped: {}: {}",
            skipped.dataset, skipped.reason
        );
    }
    // Cells are padded to their column: no trailing blanks.
    s.lines().map(str::trim_end).collect::<Vec<_>>().join("\n") + "\n"
}
