//! The benchmark page's figures (SVG, drawn with plotters): medians, ratios to slip-BLR,
//! the transfer heat maps, the terrains' unpredictability and the error against it.

use crate::figures::{self, BoxGroup, DrawResult, COLOURS};
use crate::ReportError;
use drive_studies::{Bench, TransferCell};
use drive_traits::Phase;
use plotters::coord::Shift;
use plotters::prelude::*;

const FONT: &str = "sans-serif";

/// One kind of a window's unpredictability.
type PickKind = fn(&drive_eval::WindowUnpredictability) -> Option<f64>;

/// The figures of the page: name, caption, size.
pub(super) fn figure_list(b: &Bench) -> Vec<(&'static str, String, (u32, u32))> {
    let w = (240 + 110 * b.datasets.len() as u32).clamp(900, 2400);
    let h = 600;
    let mut f = vec![
        (
            "medians",
            "Median MRMSE per dataset and model, with the quartiles (log scale)".to_string(),
            (w, h),
        ),
        (
            "ratio_to_slip_blr",
            "Each model's median over slip-BLR's, with the 95% paired bootstrap interval (log scale; below 1: better than slip-BLR)".to_string(),
            (w, h),
        ),
    ];
    let groups = transfer_groups(b);
    if !groups.is_empty() {
        let cells: usize = groups
            .iter()
            .map(|(_, names)| names.len())
            .max()
            .unwrap_or(1);
        let side = (100 + 50 * cells as u32).clamp(320, 900);
        f.push((
            "transfer",
            "Transfer: loss of each model fitted on all of one run (row) and scored on another run of the robot (column), against the model fitted on that run itself [%]; the diagonal names the run by its number in the datasets table".to_string(),
            (
                2 * side,
                (60 + b.model_names.len() as u32 * side * groups.len() as u32).min(12000),
            ),
        ));
    }
    f.push((
        "unpredictability",
        "The terrain's unpredictability per window, per dataset (steady windows; 0: moves as commanded, 1: does not move)".to_string(),
        (w.max(1200), h),
    ));
    f.push((
        "error_vs_unpredictability",
        "Each model's median error against the dataset's unpredictability".to_string(),
        (1100, 520),
    ));
    f
}

/// Most datasets of one robot drawn in a transfer heat map (a larger group's map would be a
/// wall of unreadable cells; `transfer.csv` has every pair).
const MAX_HEAT_MAP: usize = 40;

/// The robots with transfer pairs (of at most [`MAX_HEAT_MAP`] datasets), and their datasets
/// in the suite's order.
fn transfer_groups(b: &Bench) -> Vec<(String, Vec<String>)> {
    let paired: std::collections::HashSet<&str> = b
        .transfer
        .iter()
        .flat_map(|c| [c.train.as_str(), c.test.as_str()])
        .collect();
    let mut groups: Vec<(String, Vec<String>)> = Vec::new();
    for d in &b.datasets {
        if !paired.contains(d.name.as_str()) {
            continue;
        }
        match groups.iter_mut().find(|g| g.0 == d.robot) {
            Some(g) => g.1.push(d.name.clone()),
            None => groups.push((d.robot.clone(), vec![d.name.clone()])),
        }
    }
    groups.retain(|g| g.1.len() <= MAX_HEAT_MAP);
    groups
}

/// Draws one figure of the page as SVG text.
pub fn figure_svg(b: &Bench, name: &str) -> Result<String, ReportError> {
    crate::register_font();
    let size = figure_list(b)
        .into_iter()
        .find(|f| f.0 == name)
        .map_or((1000, 560), |f| f.2);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        draw(b, name, &root).map_err(|e| ReportError::Draw(format!("{name}: {e}")))?;
    }
    Ok(svg)
}

fn draw<DB: DrawingBackend>(b: &Bench, name: &str, root: &DrawingArea<DB, Shift>) -> DrawResult
where
    DB::ErrorType: 'static,
{
    match name {
        "medians" => points_per_dataset(root, b, false),
        "ratio_to_slip_blr" => points_per_dataset(root, b, true),
        "transfer" => transfer(root, b),
        "unpredictability" => {
            root.fill(&WHITE)?;
            let body = figures::header(root, "Unpredictability per dataset (steady windows)", &[])?;
            let panels = body.split_evenly((1, 3));
            let kinds: [(&str, PickKind); 3] = [
                ("translational", |w| w.translational),
                ("rotational", |w| w.rotational),
                ("total", |w| w.total),
            ];
            for (panel, (kind, pick)) in panels.iter().zip(kinds) {
                let groups: Vec<BoxGroup> = b
                    .datasets
                    .iter()
                    .enumerate()
                    .map(|(i, d)| {
                        (
                            number(&(i as f64)),
                            d.window_unpredictability
                                .iter()
                                .filter(|w| w.phase == Phase::Steady)
                                .filter_map(pick)
                                .collect(),
                        )
                    })
                    .collect();
                figures::box_panel(panel, &groups, &format!("{kind} unpredictability"))?;
            }
            root.present()?;
            Ok(())
        }
        "error_vs_unpredictability" => error_vs_unpredictability(root, b),
        other => Err(format!("no figure named {other}").into()),
    }
}

/// A tick label of a log axis: only at 1, 2 and 5 times a power of ten (the others crowd).
fn log_tick(v: &f64) -> String {
    if !(v.is_finite() && *v > 0.0) {
        return String::new();
    }
    let power = 10f64.powf(v.log10().floor());
    let m = v / power;
    if [1.0, 2.0, 5.0, 10.0]
        .iter()
        .any(|n| (m - n).abs() < 1e-6 * n)
    {
        let digits = (-v.log10().floor()).max(0.0) as usize;
        format!("{v:.digits$}")
    } else {
        String::new()
    }
}

/// The tick label of dataset `x` (0-based position): its number in the datasets table
/// (names of any length side by side would overlap).
fn number(x: &f64) -> String {
    let i = x.round();
    if (x - i).abs() < 1e-6 && i >= 0.0 {
        format!("{}", i as usize + 1)
    } else {
        String::new()
    }
}

/// The datasets by number, for the captions.
pub(super) fn numbered(b: &Bench) -> String {
    let names: Vec<String> = b
        .datasets
        .iter()
        .enumerate()
        .map(|(i, d)| format!("{} {}", i + 1, d.name))
        .collect();
    format!("datasets: {}", names.join(", "))
}

/// Per dataset (x), per model (offset points): the median with its quartiles, or the ratio
/// to slip-BLR with its interval; two panels (translational, rotational), log scale.
fn points_per_dataset<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    b: &Bench,
    ratio: bool,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let keys: Vec<(String, figures::Key)> = b
        .model_names
        .iter()
        .enumerate()
        .map(|(i, m)| (m.clone(), figures::Key::Dot(COLOURS[i % COLOURS.len()])))
        .collect();
    let title = if ratio {
        "Median MRMSE over slip-BLR's, 95% paired bootstrap intervals"
    } else {
        "Median MRMSE with quartiles"
    };
    let body = figures::header(root, title, &keys)?;
    let panels = body.split_evenly((2, 1));
    let n = b.datasets.len();
    let models = b.model_names.len().max(1);
    for (p, translational) in panels.iter().zip([true, false]) {
        // (dataset, model, low, mid, high)
        let mut points: Vec<(usize, usize, f64, f64, f64)> = Vec::new();
        for (i, d) in b.datasets.iter().enumerate() {
            for (j, m) in d.models.iter().enumerate() {
                let v = if ratio {
                    let Some(imp) = m.improvement_over_slip_blr else {
                        continue;
                    };
                    let imp = if translational {
                        imp.translational
                    } else {
                        imp.rotational
                    };
                    let r = |pct: f64| 1.0 - pct / 100.0;
                    (r(imp.ci[1]), r(imp.percent), r(imp.ci[0]))
                } else if translational {
                    (
                        m.translational_iqr_m[0],
                        m.translational_median_m,
                        m.translational_iqr_m[1],
                    )
                } else {
                    (
                        m.rotational_iqr_rad[0],
                        m.rotational_median_rad,
                        m.rotational_iqr_rad[1],
                    )
                };
                points.push((i, j, v.0, v.1, v.2));
            }
        }
        let positive: Vec<f64> = points
            .iter()
            .flat_map(|p| [p.2, p.3, p.4])
            .filter(|v| v.is_finite() && *v > 0.0)
            .collect();
        let lo = positive.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = positive.iter().copied().fold(0.0f64, f64::max);
        let (lo, hi) = if lo.is_finite() && hi > 0.0 {
            (lo / 1.3, hi * 1.3)
        } else {
            (0.01, 10.0)
        };
        let desc = match (ratio, translational) {
            (true, true) => "translational, ratio to slip-BLR",
            (true, false) => "rotational, ratio to slip-BLR",
            (false, true) => "translational MRMSE [m]",
            (false, false) => "rotational MRMSE [rad]",
        };
        let mut chart = ChartBuilder::on(p)
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(70)
            .build_cartesian_2d(-0.5..n as f64 - 0.5, (lo..hi).log_scale())?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n.max(1))
            .x_label_formatter(&number)
            .y_label_formatter(&log_tick)
            .y_desc(desc)
            .axis_desc_style((FONT, 15))
            .label_style((FONT, 13))
            .draw()?;
        if ratio {
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(-0.5, 1.0), (n as f64 - 0.5, 1.0)],
                BLACK.stroke_width(1),
            )))?;
        }
        let width = 0.7;
        for (i, j, low, mid, high) in points {
            let c = COLOURS[j % COLOURS.len()];
            let x = i as f64 - width / 2.0 + width * (j as f64 + 0.5) / models as f64;
            let clip = |v: f64| v.clamp(lo, hi);
            if low.is_finite() && high.is_finite() {
                chart.draw_series(std::iter::once(PathElement::new(
                    vec![(x, clip(low)), (x, clip(high))],
                    c.stroke_width(2),
                )))?;
            }
            if mid.is_finite() && mid > 0.0 {
                chart.draw_series(std::iter::once(Circle::new((x, clip(mid)), 4, c.filled())))?;
            }
        }
    }
    root.present()?;
    Ok(())
}

/// A colour for a loss in percent: white at 0, red for a loss, blue for a gain, saturated at
/// +-100%.
fn loss_colour(loss: f64) -> RGBColor {
    if !loss.is_finite() {
        return RGBColor(200, 200, 200);
    }
    let t = (loss.abs() / 100.0).min(1.0);
    let fade = |c: u8| (255.0 - t * (255.0 - c as f64)) as u8;
    if loss >= 0.0 {
        RGBColor(fade(214), fade(39), fade(40))
    } else {
        RGBColor(fade(31), fade(119), fade(180))
    }
}

/// Heat maps of the transfer losses: per robot and model, train (rows) x test (columns),
/// translational and rotational side by side.
fn transfer<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, b: &Bench) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let body = figures::header(
        root,
        "Transfer loss [%]: fitted on the row's run, scored on the column's (the diagonal names the run)",
        &[],
    )?;
    let groups = transfer_groups(b);
    // Each cell by (model, train, test).
    let cells: std::collections::HashMap<(&str, &str, &str), &TransferCell> = b
        .transfer
        .iter()
        .map(|c| ((c.model.as_str(), c.train.as_str(), c.test.as_str()), c))
        .collect();
    let rows = b.model_names.len() * groups.len();
    if rows == 0 {
        root.present()?;
        return Ok(());
    }
    let panels = body.split_evenly((rows, 2));
    let mut k = 0;
    for (robot, names) in &groups {
        for model in &b.model_names {
            for translational in [true, false] {
                let panel = &panels[k];
                k += 1;
                let n = names.len();
                let title = format!(
                    "{model} on {robot}, {}",
                    if translational {
                        "translational"
                    } else {
                        "rotational"
                    }
                );
                let mut chart = ChartBuilder::on(panel)
                    .margin(8)
                    .caption(title, (FONT, 15))
                    .x_label_area_size(22)
                    .y_label_area_size(22)
                    .build_cartesian_2d(0.0..n as f64, 0.0..n as f64)?;
                chart
                    .configure_mesh()
                    .disable_mesh()
                    .x_labels(0)
                    .y_labels(0)
                    .x_desc("scored on (test) ->")
                    .y_desc("fitted on (train)")
                    .axis_desc_style((FONT, 12))
                    .draw()?;
                for (r, train) in names.iter().enumerate() {
                    for (c, test) in names.iter().enumerate() {
                        let loss = if r == c {
                            Some(0.0)
                        } else {
                            cells
                                .get(&(model.as_str(), train.as_str(), test.as_str()))
                                .map(|x| {
                                    if translational {
                                        x.loss_translational_percent
                                    } else {
                                        x.loss_rotational_percent
                                    }
                                })
                        };
                        // Row 0 at the top.
                        let y0 = (n - 1 - r) as f64;
                        let colour = loss.map_or(RGBColor(230, 230, 230), loss_colour);
                        chart.draw_series(std::iter::once(Rectangle::new(
                            [(c as f64, y0), (c as f64 + 1.0, y0 + 1.0)],
                            colour.filled(),
                        )))?;
                        chart.draw_series(std::iter::once(Rectangle::new(
                            [(c as f64, y0), (c as f64 + 1.0, y0 + 1.0)],
                            WHITE.stroke_width(1),
                        )))?;
                        // The diagonal names the run (its number in the datasets table).
                        let label = if r == c {
                            b.datasets
                                .iter()
                                .position(|d| &d.name == train)
                                .map(|i| format!("#{}", i + 1))
                        } else {
                            loss.filter(|l| l.is_finite()).map(|l| format!("{l:+.0}"))
                        };
                        if let Some(label) = label {
                            chart.draw_series(std::iter::once(Text::new(
                                label,
                                (c as f64 + 0.3, y0 + 0.6),
                                (FONT, 12).into_font(),
                            )))?;
                        }
                    }
                }
            }
        }
    }
    root.present()?;
    Ok(())
}

/// Each model's median error (y) against the dataset's median unpredictability (x): total
/// when known, else translational; translational and rotational panels.
fn error_vs_unpredictability<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    b: &Bench,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let keys: Vec<(String, figures::Key)> = b
        .model_names
        .iter()
        .enumerate()
        .map(|(i, m)| (m.clone(), figures::Key::Dot(COLOURS[i % COLOURS.len()])))
        .collect();
    let body = figures::header(
        root,
        "Median error against the dataset's unpredictability",
        &keys,
    )?;
    let panels = body.split_evenly((1, 2));
    for (p, translational) in panels.iter().zip([true, false]) {
        let mut points = Vec::new();
        for d in &b.datasets {
            let u = &d.unpredictability;
            let x = if translational {
                u.total.or(u.translational)
            } else {
                u.total.or(u.rotational)
            };
            let Some(x) = x.map(|s| s.median) else {
                continue;
            };
            for (j, m) in d.models.iter().enumerate() {
                let y = if translational {
                    m.translational_median_m
                } else {
                    m.rotational_median_rad
                };
                if y.is_finite() && y > 0.0 {
                    points.push((x, y, j));
                }
            }
        }
        let lo = points.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
        let hi = points.iter().map(|p| p.1).fold(0.0f64, f64::max);
        let (lo, hi) = if lo.is_finite() && hi > 0.0 {
            (lo / 1.3, hi * 1.3)
        } else {
            (0.01, 10.0)
        };
        let mut chart = ChartBuilder::on(p)
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..1.0, (lo..hi).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("unpredictability (total, or per kind without a body size)")
            .y_desc(if translational {
                "translational MRMSE [m]"
            } else {
                "rotational MRMSE [rad]"
            })
            .y_label_formatter(&log_tick)
            .axis_desc_style((FONT, 14))
            .label_style((FONT, 13))
            .draw()?;
        for (x, y, j) in points {
            let c = COLOURS[j % COLOURS.len()];
            chart.draw_series(std::iter::once(Circle::new((x, y), 5, c.filled())))?;
        }
    }
    root.present()?;
    Ok(())
}
