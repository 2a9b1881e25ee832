//! The outputs of a benchmark ([`drive_studies::Bench`]): the text the terminal shows, CSV
//! tables, a Markdown summary, the JSON document and one self-contained HTML page whose
//! figures (SVG) are embedded.
//!
//! | figure | shows |
//! |---|---|
//! | `medians` | every model's median MRMSE with its quartiles, per dataset |
//! | `ratio_to_slip_blr` | every model's median over slip-BLR's with the 95% paired bootstrap interval, per dataset |
//! | `transfer` | per model, the loss of a model fitted on another run of the robot, train x test |
//! | `unpredictability` | the windows' unpredictability per dataset, labelled with its terrain |
//! | `error_vs_unpredictability` | each model's median error against the dataset's unpredictability |

use crate::ReportError;
use drive_studies::Bench;
use std::fmt::Write as _;

mod adaptation;
mod plots;
mod text;
pub use adaptation::adapt_csv;
pub use plots::figure_svg;
use plots::{figure_list, numbered};
pub use text::text;

/// Every file of `drive bench --out` by name, with its content.
///
/// ```no_run
/// # fn demo(bench: &drive_studies::Bench) -> Result<(), drive_report::ReportError> {
/// let files = drive_report::bench::files(bench)?;
/// assert!(files.iter().any(|(name, _)| *name == "bench.html"));
/// # Ok(()) }
/// ```
pub fn files(bench: &Bench) -> Result<Vec<(&'static str, String)>, ReportError> {
    let mut files = vec![
        ("bench.md", markdown(bench)),
        ("bench.html", html(bench)?),
        ("datasets.csv", datasets_csv(bench)),
        ("transfer.csv", transfer_csv(bench)),
        ("leaderboard.csv", leaderboard_csv(bench)),
        ("windows.csv", windows_csv(bench)),
        (
            "bench.json",
            serde_json::to_string_pretty(bench).map_err(|e| ReportError::Draw(e.to_string()))?
                + "\n",
        ),
    ];
    if let Some(a) = &bench.adaptation {
        files.push(("adapt.csv", adapt_csv(a)));
    }
    Ok(files)
}

/// A CSV field: quoted when it holds a comma, a quote or a line break.
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn num(v: Option<f64>) -> String {
    v.filter(|x| x.is_finite())
        .map_or(String::new(), |x| x.to_string())
}

/// One row per dataset and model.
pub fn datasets_csv(b: &Bench) -> String {
    let mut s = String::from(
        "dataset,robot,terrain,model,full_model,eval_windows,translational_median_m,translational_q1_m,translational_q3_m,rotational_median_rad,rotational_q1_rad,rotational_q3_rad,rank_translational,rank_rotational,vs_slip_blr_translational_percent,vs_slip_blr_translational_ci_low,vs_slip_blr_translational_ci_high,vs_slip_blr_rotational_percent,vs_slip_blr_rotational_ci_low,vs_slip_blr_rotational_ci_high,ratio_to_slip_blr_translational,ratio_to_slip_blr_rotational,position_coverage95_2s,yaw_coverage95_2s,spearman_error_unpredictability_translational,spearman_error_unpredictability_rotational,unpredictability_translational,unpredictability_rotational,unpredictability_total\n",
    );
    for d in &b.datasets {
        let u = &d.unpredictability;
        for m in &d.models {
            let v = m.improvement_over_slip_blr;
            let row = [
                field(&d.name),
                field(&d.robot),
                field(&d.terrain),
                field(&m.name),
                field(&m.model),
                d.eval_windows.to_string(),
                num(Some(m.translational_median_m)),
                num(Some(m.translational_iqr_m[0])),
                num(Some(m.translational_iqr_m[1])),
                num(Some(m.rotational_median_rad)),
                num(Some(m.rotational_iqr_rad[0])),
                num(Some(m.rotational_iqr_rad[1])),
                num(Some(m.rank_translational)),
                num(Some(m.rank_rotational)),
                num(v.map(|i| i.translational.percent)),
                num(v.map(|i| i.translational.ci[0])),
                num(v.map(|i| i.translational.ci[1])),
                num(v.map(|i| i.rotational.percent)),
                num(v.map(|i| i.rotational.ci[0])),
                num(v.map(|i| i.rotational.ci[1])),
                num(m.ratio_to_slip_blr.map(|r| r.translational)),
                num(m.ratio_to_slip_blr.map(|r| r.rotational)),
                num(m.position_coverage95_2s),
                num(m.yaw_coverage95_2s),
                num(m.error_growth.spearman_translational),
                num(m.error_growth.spearman_rotational),
                num(u.translational.map(|x| x.median)),
                num(u.rotational.map(|x| x.median)),
                num(u.total.map(|x| x.median)),
            ];
            let _ = writeln!(s, "{}", row.join(","));
        }
    }
    s
}

/// One row per model and ordered pair of datasets.
pub fn transfer_csv(b: &Bench) -> String {
    let mut s = String::from(
        "model,robot,train,test,same_terrain,same_geometry,translational_median_m,rotational_median_rad,own_translational_median_m,own_rotational_median_rad,loss_translational_percent,loss_rotational_percent\n",
    );
    for c in &b.transfer {
        let row = [
            field(&c.model),
            field(&c.robot),
            field(&c.train),
            field(&c.test),
            c.same_terrain.map_or(String::new(), |x| x.to_string()),
            c.same_geometry.to_string(),
            num(Some(c.translational_median_m)),
            num(Some(c.rotational_median_rad)),
            num(Some(c.own_translational_median_m)),
            num(Some(c.own_rotational_median_rad)),
            num(Some(c.loss_translational_percent)),
            num(Some(c.loss_rotational_percent)),
        ];
        let _ = writeln!(s, "{}", row.join(","));
    }
    s
}

/// One row per model, best first.
pub fn leaderboard_csv(b: &Bench) -> String {
    let mut s = String::from(
        "model,datasets,mean_rank,mean_rank_translational,mean_rank_rotational,wins_over_slip_blr,wins_translational,wins_rotational,losses_to_slip_blr,ratio_to_slip_blr_translational,ratio_to_slip_blr_rotational,error_growth_spearman_translational,error_growth_spearman_rotational\n",
    );
    for r in &b.leaderboard {
        let row = [
            field(&r.model),
            r.datasets.to_string(),
            num(Some(r.mean_rank)),
            num(Some(r.mean_rank_translational)),
            num(Some(r.mean_rank_rotational)),
            r.wins_over_slip_blr.to_string(),
            r.wins_translational.to_string(),
            r.wins_rotational.to_string(),
            r.losses_to_slip_blr.to_string(),
            num(Some(r.ratio_to_slip_blr.translational)),
            num(Some(r.ratio_to_slip_blr.rotational)),
            num(r.error_growth_spearman[0]),
            num(r.error_growth_spearman[1]),
        ];
        let _ = writeln!(s, "{}", row.join(","));
    }
    s
}

/// One row per dataset, window and model: the window's unpredictability and, for an
/// evaluation window, the model's errors.
pub fn windows_csv(b: &Bench) -> String {
    let mut s = String::from(
        "dataset,window,interval,phase,part,unpredictability_translational,unpredictability_rotational,unpredictability_total,model,translational_m,rotational_rad\n",
    );
    for d in &b.datasets {
        let errors: Vec<std::collections::HashMap<usize, drive_eval::Mrmse>> = d
            .comparison
            .models
            .iter()
            .map(|m| {
                m.report
                    .windows
                    .iter()
                    .map(|w| (w.window, w.error))
                    .collect()
            })
            .collect();
        for w in &d.window_unpredictability {
            let head = [
                field(&d.name),
                w.window.to_string(),
                w.interval.to_string(),
                w.phase.as_str().to_string(),
            ];
            let u = [num(w.translational), num(w.rotational), num(w.total)];
            let evaluated = errors.first().is_some_and(|e| e.contains_key(&w.window));
            if !evaluated {
                let _ = writeln!(s, "{},train,{},,,", head.join(","), u.join(","));
                continue;
            }
            for (m, e) in d.models.iter().zip(&errors) {
                let (t, r) = e.get(&w.window).map_or((None, None), |e| {
                    (Some(e.translational), Some(e.rotational))
                });
                let _ = writeln!(
                    s,
                    "{},eval,{},{},{},{}",
                    head.join(","),
                    u.join(","),
                    field(&m.name),
                    num(t),
                    num(r)
                );
            }
        }
    }
    s
}

fn pct(i: &drive_eval::Improvement, evidence: bool) -> String {
    let sure = if evidence && (i.ci[0] > 0.0 || i.ci[1] < 0.0) {
        "**"
    } else {
        ""
    };
    format!(
        "{sure}{:+.1}%{sure} [{:+.1}, {:+.1}]",
        i.percent, i.ci[0], i.ci[1]
    )
}

fn or_dash(v: Option<f64>, digits: usize) -> String {
    v.filter(|x| x.is_finite())
        .map_or("-".into(), |v| format!("{v:.digits$}"))
}

fn terrain(t: &str) -> &str {
    if t.is_empty() {
        "not recorded"
    } else {
        t
    }
}

/// One section of tables per part of the benchmark, as Markdown (also the HTML page's
/// tables, converted).
pub fn markdown(b: &Bench) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# DRIVE benchmark\n");
    // The windows' length: the paper's 2 s, or each dataset's where they differ.
    let mut lengths: Vec<f64> = b.datasets.iter().map(|d| d.window_s).collect();
    lengths.sort_by(f64::total_cmp);
    lengths.dedup();
    let over = match lengths.as_slice() {
        [one] => format!("{} s", drive_traits::limits::Short(*one)),
        _ => "each dataset's windows (their lengths differ: see each dataset)".to_string(),
    };
    let _ = writeln!(
        s,
        "{} datasets x {} models ({}). Each dataset's first {} of the DRIVE intervals trains, the rest evaluates, as `drive eval`; errors are the paper's multi-step RMSE (eq. 8) over {over}. Intervals are 95% paired bootstrap intervals ({} resamples of the evaluation intervals); **bold** where they exclude 0 on a dataset of enough evaluation intervals to count (see the leaderboard).\n",
        b.datasets.len(),
        b.model_names.len(),
        b.model_names.join(", "),
        b.split,
        b.bootstrap.resamples
    );
    let _ = writeln!(s, "## Leaderboard\n");
    let _ = writeln!(
        s,
        "Mean rank over the datasets (translational and rotational ranks averaged, 1 best); wins: datasets where the model beats slip-BLR with the interval above 0 in both, in translation, in rotation; losses: datasets where slip-BLR beats it in either (only datasets of {} evaluation intervals or more count: with fewer, every resample draws the same few); ratio: geometric mean of the median's ratio to slip-BLR's; growth: mean over the datasets of the Spearman correlation of a window's error with its unpredictability.\n",
        b.min_evidence_intervals
    );
    // With the adaptation track: its adaptive model over its own fit after 60 s.
    let adapted = b.adaptation.is_some();
    let _ = writeln!(
        s,
        "| # | model | mean rank | wins (both / t / r) | losses | ratio t | ratio r | growth t | growth r |{}\n|---|---|---|---|---|---|---|---|---|{}",
        if adapted { " adapted / own, 60 s |" } else { "" },
        if adapted { "---|" } else { "" }
    );
    for (i, r) in b.leaderboard.iter().enumerate() {
        let adapt_cell = if adapted {
            format!(" {} |", adaptation::ratio(r.adaptive_over_own_60s))
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "| {} | {} | {:.2} | {} / {} / {} | {} | {:.3} | {:.3} | {} | {} |{adapt_cell}",
            i + 1,
            r.model,
            r.mean_rank,
            r.wins_over_slip_blr,
            r.wins_translational,
            r.wins_rotational,
            r.losses_to_slip_blr,
            r.ratio_to_slip_blr.translational,
            r.ratio_to_slip_blr.rotational,
            or_dash(r.error_growth_spearman[0], 2),
            or_dash(r.error_growth_spearman[1], 2)
        );
    }
    let _ = writeln!(s, "\n## Datasets\n");
    let _ = writeln!(
        s,
        "Unpredictability (T-FR 2025's energy metric; median over the {} windows' samples): 0 when the robot moves as commanded, 1 when it does not move.\n",
        b.datasets
            .first()
            .map_or("steady", |d| d.unpredictability.pooled)
    );
    let _ = writeln!(
        s,
        "| # | dataset | robot | terrain | windows | evaluated | unpredictability t | r | total | body |\n|---|---|---|---|---|---|---|---|---|---|"
    );
    for (i, d) in b.datasets.iter().enumerate() {
        let u = &d.unpredictability;
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            i + 1,
            md(&d.name),
            md(&d.robot),
            md(terrain(&d.terrain)),
            d.windows,
            d.eval_windows,
            or_dash(u.translational.map(|x| x.median), 3),
            or_dash(u.rotational.map(|x| x.median), 3),
            or_dash(u.total.map(|x| x.median), 3),
            md(&u.body_source)
        );
    }
    for d in &b.datasets {
        for note in &d.notes {
            let _ = writeln!(s, "\nNote on {}: {}", md(&d.name), md(note));
        }
    }
    let _ = writeln!(s, "\n## Per dataset\n");
    for d in &b.datasets {
        let windows = if lengths.len() > 1 || d.window_s != 2.0 {
            format!(", windows of {} s", drive_traits::limits::Short(d.window_s))
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "### {} ({}, {}{windows})\n",
            md(&d.name),
            md(&d.robot),
            md(terrain(&d.terrain))
        );
        let _ = writeln!(
            s,
            "| model | translational [m] median [IQR] | rotational [rad] median [IQR] | vs slip-BLR: translational | rotational | coverage 95% at 2 s (position, yaw) |\n|---|---|---|---|---|---|"
        );
        for m in &d.models {
            let v = m.improvement_over_slip_blr;
            let _ = writeln!(
                s,
                "| {} | {:.4} [{:.4}, {:.4}] | {:.4} [{:.4}, {:.4}] | {} | {} | {} |",
                md(&m.name),
                m.translational_median_m,
                m.translational_iqr_m[0],
                m.translational_iqr_m[1],
                m.rotational_median_rad,
                m.rotational_iqr_rad[0],
                m.rotational_iqr_rad[1],
                v.map_or("-".into(), |i| pct(&i.translational, d.evidence)),
                v.map_or("-".into(), |i| pct(&i.rotational, d.evidence)),
                match (m.position_coverage95_2s, m.yaw_coverage95_2s) {
                    (Some(p), Some(y)) => format!("{:.1}%, {:.1}%", 100.0 * p, 100.0 * y),
                    _ => "-".into(),
                }
            );
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(s, "## Transfer between runs of the same robot\n");
    if b.transfer.is_empty() {
        let _ = writeln!(s, "No two datasets of the same robot could be compared.\n");
    } else {
        let _ = writeln!(
            s,
            "Each model fitted on all of one run and scored on the evaluation windows of another run of the same robot; the loss is against the same model fitted on that run's own training half (median over the pairs).\n"
        );
        let _ = writeln!(
            s,
            "| model | same terrain: pairs | loss t | loss r | other terrain: pairs | loss t | loss r | terrain unknown |\n|---|---|---|---|---|---|---|---|"
        );
        for t in &b.transfer_summary {
            let g = |g: &drive_studies::TransferGroup| {
                format!(
                    "{} | {} | {}",
                    g.pairs,
                    g.median_loss_translational_percent
                        .map_or("-".into(), |v| format!("{v:+.1}%")),
                    g.median_loss_rotational_percent
                        .map_or("-".into(), |v| format!("{v:+.1}%"))
                )
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} |",
                md(&t.model),
                g(&t.same_terrain),
                g(&t.other_terrain),
                t.unknown_terrain_pairs
            );
        }
        let _ = writeln!(
            s,
            "\nEvery pair (translational / rotational median MRMSE of the transferred model; its loss):\n"
        );
        let _ = writeln!(
            s,
            "| model | train | test | same terrain | same geometry | transferred | own | loss |\n|---|---|---|---|---|---|---|---|"
        );
        for c in &b.transfer {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {:.4} / {:.4} | {:.4} / {:.4} | {:+.1}% / {:+.1}% |",
                md(&c.model),
                md(&c.train),
                md(&c.test),
                c.same_terrain
                    .map_or("unknown", |x| if x { "yes" } else { "no" }),
                if c.same_geometry { "yes" } else { "no" },
                c.translational_median_m,
                c.rotational_median_rad,
                c.own_translational_median_m,
                c.own_rotational_median_rad,
                c.loss_translational_percent,
                c.loss_rotational_percent
            );
        }
    }
    for skipped in &b.transfer_skipped {
        let _ = writeln!(s, "\nTransfer skipped: {}", md(skipped));
    }
    for r in &b.transfer_unpaired {
        let _ = writeln!(
            s,
            "\nNo transfer for robot {} ({}): {}",
            md(&r.robot),
            md(&r.datasets.join(", ")),
            md(&r.reason)
        );
    }
    for skipped in &b.skipped {
        let _ = writeln!(
            s,
            "\nDataset skipped: {}: {}",
            md(&skipped.dataset),
            md(&skipped.reason)
        );
    }
    if let Some(a) = &b.adaptation {
        s.push_str(&adaptation::markdown(a, md));
    }
    let _ = writeln!(s, "\n## Error against the unpredictability\n");
    let _ = writeln!(
        s,
        "Each dataset's evaluation windows in thirds of their unpredictability ({}), lowest first: median translational [m] / rotational [rad] MRMSE per third.\n",
        b.datasets
            .first()
            .and_then(|d| d.models.first())
            .map_or("total", |m| m.error_growth.binned_by)
    );
    let _ = writeln!(
        s,
        "| dataset | model | low third | middle third | high third | Spearman t | Spearman r |\n|---|---|---|---|---|---|---|"
    );
    for d in &b.datasets {
        for m in &d.models {
            let third = |i: usize| {
                m.error_growth.thirds.get(i).map_or("-".into(), |t| {
                    format!(
                        "{:.3} / {:.3} (u {:.2}-{:.2})",
                        t.translational_median_m,
                        t.rotational_median_rad,
                        t.unpredictability[0],
                        t.unpredictability[1]
                    )
                })
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} |",
                md(&d.name),
                md(&m.name),
                third(0),
                third(1),
                third(2),
                or_dash(m.error_growth.spearman_translational, 2),
                or_dash(m.error_growth.spearman_rotational, 2)
            );
        }
    }
    s
}

/// User text (names, terrains) for Markdown: no pipe, no line break, no HTML (`<`, `>`
/// and `&` as entities, which Markdown shows as the characters).
fn md(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('|', "/")
        .replace(['\n', '\r'], " ")
}

/// The characters [`md`] wrote as entities, back (before escaping for HTML once).
fn unmd(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&")
}

/// Text for HTML.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The Markdown tables as HTML (pipe tables, headings and paragraphs; nothing else is
/// written by [`markdown`]).
fn markdown_to_html(md: &str) -> String {
    let inline = |t: &str| -> String {
        // **bold** and `code`, after escaping (once: the Markdown's entities are undone first).
        let t = esc(&unmd(t));
        let mut out = String::new();
        let mut bold = false;
        let mut code = false;
        let mut rest = t.as_str();
        while !rest.is_empty() {
            if let Some(r) = rest.strip_prefix("**") {
                out.push_str(if bold { "</b>" } else { "<b>" });
                bold = !bold;
                rest = r;
            } else if let Some(r) = rest.strip_prefix('`') {
                out.push_str(if code { "</code>" } else { "<code>" });
                code = !code;
                rest = r;
            } else {
                let c = rest.chars().next().unwrap_or_default();
                out.push(c);
                rest = &rest[c.len_utf8()..];
            }
        }
        if bold {
            out.push_str("</b>");
        }
        if code {
            out.push_str("</code>");
        }
        out
    };
    let mut html = String::new();
    let lines: Vec<&str> = md.lines().collect();
    let mut i = 0;
    while i < lines.len() {
        let line = lines[i];
        if let Some(h) = line.strip_prefix("### ") {
            let _ = writeln!(html, "<h3>{}</h3>", inline(h));
        } else if let Some(h) = line.strip_prefix("## ") {
            let _ = writeln!(html, "<h2>{}</h2>", inline(h));
        } else if let Some(h) = line.strip_prefix("# ") {
            let _ = writeln!(html, "<h1>{}</h1>", inline(h));
        } else if line.starts_with('|') {
            let cells = |l: &str| -> Vec<String> {
                l.trim()
                    .trim_matches('|')
                    .split('|')
                    .map(|c| inline(c.trim()))
                    .collect()
            };
            html.push_str("<table>\n<tr>");
            for c in cells(line) {
                let _ = write!(html, "<th>{c}</th>");
            }
            html.push_str("</tr>\n");
            i += 1;
            // The separator row.
            if i < lines.len() && lines[i].starts_with("|-") {
                i += 1;
            }
            while i < lines.len() && lines[i].starts_with('|') {
                html.push_str("<tr>");
                for c in cells(lines[i]) {
                    let _ = write!(html, "<td>{c}</td>");
                }
                html.push_str("</tr>\n");
                i += 1;
            }
            html.push_str("</table>\n");
            continue;
        } else if !line.trim().is_empty() {
            let _ = writeln!(html, "<p>{}</p>", inline(line));
        }
        i += 1;
    }
    html
}

/// The self-contained HTML page: the Markdown summary's tables and every figure as inline
/// SVG. It loads nothing (a content security policy forbids any request).
pub fn html(b: &Bench) -> Result<String, ReportError> {
    let md = markdown(b);
    // The figures go after the leaderboard and the datasets.
    let body = markdown_to_html(&md);
    let (head, tail) = match body.find("<h2>Per dataset</h2>") {
        Some(i) => body.split_at(i),
        None => (body.as_str(), ""),
    };
    let mut figures_html = String::from("<h2>Figures</h2>\n");
    for (name, caption, _) in figure_list(b) {
        let svg = figure_svg(b, name)?;
        // The XML declaration of a standalone SVG file has no place inside HTML.
        let svg = match svg.find("<svg") {
            Some(i) => &svg[i..],
            None => svg.as_str(),
        };
        let _ = writeln!(
            figures_html,
            "<figure id=\"{name}\">\n{svg}\n<figcaption>{}</figcaption>\n</figure>",
            esc(
                &if matches!(name, "transfer" | "error_vs_unpredictability") {
                    caption
                } else {
                    format!("{caption}; {}", numbered(b))
                }
            )
        );
    }
    Ok(format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src 'unsafe-inline'; img-src data:\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>DRIVE benchmark</title>\n<style>\n\
         body {{ font-family: sans-serif; margin: 2em auto; max-width: 1500px; padding: 0 1em; color: #222; }}\n\
         table {{ border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.9em; }}\n\
         th, td {{ border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; }}\n\
         th {{ background: #f2f2f2; }}\n\
         figure {{ margin: 1em 0 2em; overflow-x: auto; }}\n\
         figure svg {{ max-width: 100%; height: auto; }}\n\
         figcaption {{ font-style: italic; margin-top: 0.3em; }}\n\
         </style>\n</head>\n<body>\n{head}{figures_html}{tail}</body>\n</html>\n"
    ))
}
