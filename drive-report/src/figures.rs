//! The figures, drawn with plotters on any backend (PNG and SVG share one drawing function).

use crate::analysis::{
    body_polygon, ellipse, Calibration, InputSpaceFigure, PowertrainTrace, Trajectory,
};
use drive_eval::Mrmse;
use drive_studies::Convergence;
use drive_traits::CommandModel;
use drive_traits::Phase;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::error::Error;

/// What a drawing function returns.
pub type DrawResult = Result<(), Box<dyn Error>>;

const FONT: &str = "sans-serif";
const TITLE: i32 = 22;
const LABEL: i32 = 16;

/// Colours: blue, orange, green, red, purple, grey (colour-blind friendly, Tableau).
pub const COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(127, 127, 127),
];

/// Decimals that tell about ten ticks apart over an axis of extent `range` (0 from 10 units
/// up, 2 for a few tenths of a radian).
fn tick_digits(range: f64) -> usize {
    if range.is_finite() && range > 0.0 {
        (-(range / 10.0).log10()).ceil().clamp(0.0, 6.0) as usize
    } else {
        0
    }
}

fn span(values: impl IntoIterator<Item = f64>, pad: f64) -> (f64, f64) {
    let (lo, hi) = values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(v), h.max(v))
        });
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let m = ((hi - lo) * pad).max(1e-6);
    (lo - m, hi + m)
}

/// A legend entry's symbol.
#[derive(Clone, Copy)]
pub enum Key {
    /// A line of this colour and width.
    Line(RGBColor, u32),
    /// A cross marker.
    Cross(RGBColor),
    /// A filled dot.
    Dot(RGBColor),
    /// A shaded area.
    Fill(RGBAColor),
}

/// Draws the title and a legend laid out in rows above the plots (so that no legend covers
/// data), and returns the area left for the plots.
pub fn header<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    keys: &[(String, Key)],
) -> Result<DrawingArea<DB, Shift>, Box<dyn Error>>
where
    DB::ErrorType: 'static,
{
    let (width, _) = root.dim_in_pixel();
    let text = TextStyle::from((FONT, LABEL).into_font()).color(&BLACK);
    let title_font = TextStyle::from((FONT, TITLE).into_font()).color(&BLACK);
    // Lay out the keys in rows: symbol (26 px), gap, text, spacing.
    let mut rows: Vec<Vec<(i32, usize)>> = vec![Vec::new()];
    let mut x = 20i32;
    for (i, (label, _)) in keys.iter().enumerate() {
        let (w, _) = root.estimate_text_size(label, &text)?;
        let item = 26 + 6 + w as i32 + 28;
        if x + item > width as i32 - 10 && x > 20 {
            rows.push(Vec::new());
            x = 20;
        }
        if let Some(r) = rows.last_mut() {
            r.push((x, i));
        }
        x += item;
    }
    let row_h = 24;
    let title_h = 38;
    let used = if keys.is_empty() {
        0
    } else {
        rows.len() as u32 * row_h
    };
    let (head, body) = root.split_vertically(title_h + used + 6);
    let (tw, _) = root.estimate_text_size(title, &title_font)?;
    head.draw_text(title, &title_font, ((width as i32 - tw as i32) / 2, 8))?;
    for (r, row) in rows.iter().enumerate() {
        let y = title_h as i32 + r as i32 * row_h as i32 + row_h as i32 / 2;
        // Centre the row.
        let row_w = row.last().map_or(0, |(x, i)| {
            let w = root
                .estimate_text_size(&keys[*i].0, &text)
                .map_or(0, |s| s.0);
            x + 26 + 6 + w as i32
        }) - 20;
        let shift = ((width as i32 - row_w) / 2 - 20).max(0);
        for &(x, i) in row {
            let x = x + shift;
            let (label, key) = &keys[i];
            match *key {
                Key::Line(c, w) => head.draw(&PathElement::new(
                    vec![(x, y), (x + 26, y)],
                    c.stroke_width(w),
                ))?,
                Key::Cross(c) => head.draw(&Cross::new((x + 13, y), 5, c.stroke_width(2)))?,
                Key::Dot(c) => head.draw(&Circle::new((x + 13, y), 4, c.filled()))?,
                Key::Fill(c) => {
                    head.draw(&Rectangle::new([(x, y - 7), (x + 26, y + 7)], c.filled()))?
                }
            }
            head.draw_text(label, &text, (x + 32, y - LABEL / 2 - 1))?;
        }
    }
    Ok(body)
}

/// Paper Fig. 1: the input spaces and the driving data in the (forward speed, yaw rate) plane.
pub fn input_space<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    fig: &InputSpaceFigure,
    vehicle: &dyn CommandModel,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let mut polygons = vec![
        (
            "commanded input space (commands' extremes)".to_string(),
            body_polygon(vehicle, &fig.commanded),
            COLOURS[0],
        ),
        (
            "true input space (inputs reached)".to_string(),
            body_polygon(vehicle, &fig.reached),
            COLOURS[2],
        ),
    ];
    if let Some((label, space)) = &fig.naive {
        polygons.insert(0, (label.clone(), body_polygon(vehicle, space), COLOURS[5]));
    }
    let mut keys: Vec<(String, Key)> = polygons
        .iter()
        .map(|(l, _, c)| (l.clone(), Key::Line(*c, 3)))
        .collect();
    keys.push((
        "commands sent (steady windows)".into(),
        Key::Cross(COLOURS[1]),
    ));
    keys.push((
        "measured body velocities (steady windows)".into(),
        Key::Dot(COLOURS[3]),
    ));
    let body = header(root, "Input space in body velocities (eq. 4)", &keys)?;
    let xs = polygons
        .iter()
        .flat_map(|p| p.1.iter().map(|v| v.x))
        .chain(fig.measured.iter().map(|v| v.x));
    let ys = polygons
        .iter()
        .flat_map(|p| p.1.iter().map(|v| v.z))
        .chain(fig.measured.iter().map(|v| v.z));
    let (x0, x1) = span(xs, 0.05);
    let (y0, y1) = span(ys, 0.05);
    let mut chart = ChartBuilder::on(&body)
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(65)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc("forward speed v_x [m/s]")
        .y_desc("yaw rate ω [rad/s]")
        .axis_desc_style((FONT, LABEL))
        .label_style((FONT, LABEL - 2))
        .x_label_formatter(&|v| format!("{v:.1}"))
        .y_label_formatter(&|v| format!("{v:.1}"))
        .draw()?;
    for (_, corners, colour) in &polygons {
        let mut path: Vec<(f64, f64)> = corners.iter().map(|v| (v.x, v.z)).collect();
        path.push(path[0]);
        chart.draw_series(std::iter::once(PathElement::new(
            path,
            colour.stroke_width(3),
        )))?;
    }
    let c = COLOURS[1];
    chart.draw_series(
        fig.commands
            .iter()
            .map(|v| Cross::new((v.x, v.z), 4, c.stroke_width(1))),
    )?;
    let c = COLOURS[3];
    chart.draw_series(
        fig.measured
            .iter()
            .map(|v| Circle::new((v.x, v.z), 2, c.filled())),
    )?;
    root.present()?;
    Ok(())
}

/// `a and b`, `a, b and c`: the axes' names.
fn names(axes: &[drive_traits::InputAxis]) -> String {
    let names: Vec<&str> = axes.iter().map(|a| a.name).collect();
    match names.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} and {last}", rest.join(", ")),
        _ => names.concat(),
    }
}

/// Paper Fig. 3: commanded, measured and modeled inputs (wheel velocities for a skid-steer),
/// one panel per input axis.
pub fn powertrain<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    trace: &PowertrainTrace,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let transient = COLOURS[1].mix(0.18);
    let steady = COLOURS[0].mix(0.08);
    let keys = [
        ("commanded".to_string(), Key::Line(BLACK, 2)),
        ("measured".to_string(), Key::Line(COLOURS[3], 2)),
        (
            format!(
                "{} model, restarted from the measured input at each window",
                trace.powertrain
            ),
            Key::Line(COLOURS[0], 2),
        ),
        ("transient window".to_string(), Key::Fill(transient)),
        ("steady window".to_string(), Key::Fill(steady)),
    ];
    let body = header(
        root,
        &format!(
            "Powertrain: {} over three DRIVE intervals (eq. 3)",
            names(&trace.axes)
        ),
        &keys,
    )?;
    let panels = body.split_evenly((trace.axes.len().max(1), 1));
    let t1 = trace.windows.last().map_or(1.0, |w| w.1);
    for (side, area) in panels.iter().enumerate() {
        let pick = |u: &drive_traits::Input| u[side];
        let values = trace
            .commanded
            .iter()
            .chain(&trace.measured)
            .chain(&trace.modeled)
            .map(pick);
        let (y0, y1) = span(values, 0.08);
        let mut chart = ChartBuilder::on(area)
            .margin(10)
            .x_label_area_size(45)
            .y_label_area_size(65)
            .build_cartesian_2d(0.0..t1, y0..y1)?;
        let axis = trace.axes[side];
        let digits = tick_digits(y1 - y0);
        chart
            .configure_mesh()
            .x_desc("time [s]")
            .y_desc(format!("{} [{}]", axis.name, axis.unit))
            .axis_desc_style((FONT, LABEL))
            .label_style((FONT, LABEL - 2))
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.digits$}"))
            .draw()?;
        chart.draw_series(trace.windows.iter().map(|&(a, b, phase)| {
            let fill = if phase == Phase::Transient {
                transient
            } else {
                steady
            };
            Rectangle::new([(a, y0), (b, y1)], fill.filled())
        }))?;
        for (values, colour) in [
            (&trace.commanded, BLACK),
            (&trace.measured, COLOURS[3]),
            (&trace.modeled, COLOURS[0]),
        ] {
            chart.draw_series(LineSeries::new(
                trace.t.iter().zip(values).map(|(t, u)| (*t, pick(u))),
                colour.stroke_width(2),
            ))?;
        }
    }
    root.present()?;
    Ok(())
}

/// One group of a box plot: its label and its values.
pub type BoxGroup = (String, Vec<f64>);

/// Tukey's box: quartiles, whiskers at the farthest values within 1.5 IQR, the rest outliers.
struct TukeyBox {
    q: [f64; 3],
    whiskers: [f64; 2],
    outliers: Vec<f64>,
}

fn tukey(values: &[f64]) -> Option<TukeyBox> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    let q = |p| drive_eval::quantile(&v, p);
    let (q1, q2, q3) = (q(0.25)?, q(0.5)?, q(0.75)?);
    let (lo, hi) = (q1 - 1.5 * (q3 - q1), q3 + 1.5 * (q3 - q1));
    let inside: Vec<f64> = v.iter().copied().filter(|x| *x >= lo && *x <= hi).collect();
    Some(TukeyBox {
        q: [q1, q2, q3],
        whiskers: [
            inside.first().copied().unwrap_or(q1),
            inside.last().copied().unwrap_or(q3),
        ],
        outliers: v.into_iter().filter(|x| *x < lo || *x > hi).collect(),
    })
}

/// One panel of box plots (see [`error_boxes`]), the y axis described by `y_desc`.
pub fn box_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    groups: &[BoxGroup],
    y_desc: &str,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let boxes: Vec<Option<TukeyBox>> = groups.iter().map(|(_, v)| tukey(v)).collect();
    let hi = boxes
        .iter()
        .flatten()
        .flat_map(|b| b.outliers.iter().copied().chain([b.whiskers[1]]))
        .fold(0.0f64, f64::max)
        .max(1e-6);
    let n = groups.len();
    let labels: Vec<String> = groups.iter().map(|g| g.0.clone()).collect();
    let mut chart = ChartBuilder::on(area)
        .margin(10)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d(-0.5..n as f64 - 0.5, 0.0..hi * 1.05)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(n)
        .x_label_formatter(&|x| {
            let i = x.round();
            if (x - i).abs() < 1e-6 && i >= 0.0 {
                labels.get(i as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        })
        .y_label_formatter(&|v| format!("{v:.2}"))
        .y_desc(y_desc)
        .axis_desc_style((FONT, LABEL))
        .label_style((FONT, LABEL - 2))
        .draw()?;
    for (i, b) in boxes.iter().enumerate() {
        let Some(b) = b else { continue };
        let c = COLOURS[i % COLOURS.len()];
        let x = i as f64;
        let (w, cap) = (0.3, 0.12);
        chart.draw_series(std::iter::once(Rectangle::new(
            [(x - w, b.q[0]), (x + w, b.q[2])],
            c.mix(0.25).filled(),
        )))?;
        chart.draw_series(std::iter::once(Rectangle::new(
            [(x - w, b.q[0]), (x + w, b.q[2])],
            c.stroke_width(2),
        )))?;
        chart.draw_series([
            PathElement::new(vec![(x - w, b.q[1]), (x + w, b.q[1])], c.stroke_width(3)),
            PathElement::new(vec![(x, b.q[2]), (x, b.whiskers[1])], c.stroke_width(2)),
            PathElement::new(vec![(x, b.q[0]), (x, b.whiskers[0])], c.stroke_width(2)),
            PathElement::new(
                vec![(x - cap, b.whiskers[1]), (x + cap, b.whiskers[1])],
                c.stroke_width(2),
            ),
            PathElement::new(
                vec![(x - cap, b.whiskers[0]), (x + cap, b.whiskers[0])],
                c.stroke_width(2),
            ),
        ])?;
        chart.draw_series(
            b.outliers
                .iter()
                .map(|y| Circle::new((x, *y), 2, c.mix(0.5).filled())),
        )?;
    }
    Ok(())
}

/// Paper Fig. 5/6: box plots of the translational and rotational MRMSE per group (model or
/// protocol): boxes from the first to the third quartile, the median as a thick line,
/// whiskers to the farthest windows within 1.5 IQR, outliers as dots.
pub fn error_boxes<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    groups: &[(String, Vec<Mrmse>)],
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let body = header(root, title, &[])?;
    let panels = body.split_evenly((1, 2));
    let pick = |f: fn(&Mrmse) -> f64| -> Vec<BoxGroup> {
        groups
            .iter()
            .map(|(l, e)| (l.clone(), e.iter().map(f).collect()))
            .collect()
    };
    box_panel(
        &panels[0],
        &pick(|e| e.translational),
        "translational MRMSE [m]",
    )?;
    box_panel(
        &panels[1],
        &pick(|e| e.rotational),
        "rotational MRMSE [rad]",
    )?;
    root.present()?;
    Ok(())
}

/// Paper Fig. 7: median errors against training time, log-log, the convergence time marked.
pub fn convergence<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    model: &str,
    c: &Convergence,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let mut keys = vec![
        (
            "median translational error".to_string(),
            Key::Line(COLOURS[0], 2),
        ),
        (
            "median rotational error".to_string(),
            Key::Line(COLOURS[2], 2),
        ),
    ];
    if let Some(tc) = c.convergence_time_s {
        keys.push((
            format!("convergence time {tc:.1} s"),
            Key::Line(COLOURS[3], 2),
        ));
    }
    let body = header(
        root,
        &format!("Convergence of {model}: error on the evaluation windows against training time"),
        &keys,
    )?;
    let panels = body.split_evenly((1, 2));
    let t = |p: &drive_studies::ConvergencePoint| p.training_time_s;
    let (tx0, tx1) = c
        .curve
        .iter()
        .map(t)
        .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    let (tx0, tx1) = if tx0.is_finite() && tx0 > 0.0 {
        (tx0 * 0.8, tx1 * 1.25)
    } else {
        (1.0, 10.0)
    };
    for (i, area) in panels.iter().enumerate() {
        let value = |p: &drive_studies::ConvergencePoint| {
            if i == 0 {
                p.translational_median_m
            } else {
                p.rotational_median_rad
            }
        };
        let pts: Vec<(f64, f64)> = c
            .curve
            .iter()
            .map(|p| (t(p), value(p)))
            .filter(|p| p.1 > 0.0)
            .collect();
        let (lo, hi) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
            (a.min(p.1), b.max(p.1))
        });
        let (lo, hi) = if lo.is_finite() {
            (lo * 0.8, hi * 1.25)
        } else {
            (0.01, 1.0)
        };
        let mut chart = ChartBuilder::on(area)
            .margin(10)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d((tx0..tx1).log_scale(), (lo..hi).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("training driving time [s] (log scale)")
            .y_desc(if i == 0 {
                "median translational MRMSE [m] (log scale)"
            } else {
                "median rotational MRMSE [rad] (log scale)"
            })
            .axis_desc_style((FONT, LABEL))
            .label_style((FONT, LABEL - 2))
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.2}"))
            .draw()?;
        let colour = COLOURS[if i == 0 { 0 } else { 2 }];
        chart.draw_series(LineSeries::new(pts.iter().copied(), colour.stroke_width(2)))?;
        if let Some(tc) = c.convergence_time_s {
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(tc, lo), (tc, hi)],
                COLOURS[3].stroke_width(2),
            )))?;
        }
    }
    root.present()?;
    Ok(())
}

/// Predicted against measured paths for a few evaluation windows, with the 95% position
/// ellipses of the models that give covariances.
pub fn trajectories<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    trajectories: &[Trajectory],
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let mut keys: Vec<(String, Key)> = Vec::new();
    if let Some(t) = trajectories.first() {
        for (i, (name, _, covs)) in t.predicted.iter().enumerate() {
            let c = COLOURS[i % COLOURS.len()];
            let label = if covs.is_some() {
                format!("{name} (with 95% ellipses)")
            } else {
                name.clone()
            };
            keys.push((label, Key::Line(c, 2)));
        }
    }
    keys.push(("measured (localization)".into(), Key::Line(BLACK, 3)));
    let body = header(
        root,
        "Predicted and measured paths over 2 s evaluation windows (ellipses every 0.5 s)",
        &keys,
    )?;
    let cols = 2;
    let rows = trajectories.len().div_ceil(cols).max(1);
    let panels = body.split_evenly((rows, cols));
    for (traj, area) in trajectories.iter().zip(panels.iter()) {
        let mut xs: Vec<f64> = traj.measured.iter().map(|p| p.x).collect();
        let mut ys: Vec<f64> = traj.measured.iter().map(|p| p.y).collect();
        for (_, poses, _) in &traj.predicted {
            xs.extend(poses.iter().map(|p| p.x));
            ys.extend(poses.iter().map(|p| p.y));
        }
        let (x0, x1) = span(xs, 0.08);
        let (y0, y1) = span(ys, 0.08);
        // Equal scales on both axes: widen the smaller span around its centre.
        let (pw, ph) = area.dim_in_pixel();
        let aspect = pw.saturating_sub(80) as f64 / ph.saturating_sub(80).max(1) as f64;
        let half = ((x1 - x0) / aspect).max(y1 - y0).max(0.2) / 2.0;
        let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
        let mut chart = ChartBuilder::on(area)
            .caption(format!("evaluation window {}", traj.window), (FONT, LABEL))
            .margin(8)
            .x_label_area_size(40)
            .y_label_area_size(55)
            .build_cartesian_2d(cx - half * aspect..cx + half * aspect, cy - half..cy + half)?;
        chart
            .configure_mesh()
            .x_desc("x [m] (robot frame at the window start)")
            .y_desc("y [m]")
            .axis_desc_style((FONT, LABEL - 2))
            .label_style((FONT, LABEL - 4))
            .x_label_formatter(&|v| format!("{v:.2}"))
            .y_label_formatter(&|v| format!("{v:.2}"))
            .draw()?;
        for (i, (_, poses, covs)) in traj.predicted.iter().enumerate() {
            let colour = COLOURS[i % COLOURS.len()];
            if let Some(covs) = covs {
                for k in (10..poses.len().min(covs.len())).step_by(10) {
                    let e = ellipse((poses[k].x, poses[k].y), &covs[k], 48);
                    chart
                        .draw_series(std::iter::once(Polygon::new(e.clone(), colour.mix(0.10))))?;
                    chart.draw_series(std::iter::once(PathElement::new(
                        e,
                        colour.mix(0.6).stroke_width(1),
                    )))?;
                }
            }
            chart.draw_series(LineSeries::new(
                poses.iter().map(|p| (p.x, p.y)),
                colour.stroke_width(2),
            ))?;
        }
        chart.draw_series(LineSeries::new(
            traj.measured.iter().map(|p| (p.x, p.y)),
            BLACK.stroke_width(3),
        ))?;
    }
    root.present()?;
    Ok(())
}

/// The reliability diagram: observed against nominal coverage (50% to 99%) of the predicted
/// position ellipses (solid, with dots) and yaw intervals (crosses), every horizon step of
/// every evaluation window, then of the transient and of the steady windows alone (three
/// panels); a calibrated model lies on the diagonal in each.
pub fn calibration<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    cals: &[Calibration],
    _dt: f64,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let mut keys = vec![(
        "observed = nominal: a calibrated model".to_string(),
        Key::Line(COLOURS[5], 2),
    )];
    for (i, c) in cals.iter().enumerate() {
        let colour = COLOURS[(i + 2) % COLOURS.len()];
        let at = |h: &str| c.coverage95.get(h).map_or(f64::NAN, |f| 100.0 * f);
        keys.push((
            format!(
                "{} position (95%: {:.1} / {:.1} / {:.1}% at 0.5 / 1 / 2 s; NLL {})",
                c.model,
                at("0.5"),
                at("1.0"),
                at("2.0"),
                crate::nll_text(c.mean_nll)
            ),
            Key::Dot(colour),
        ));
        keys.push((format!("{} yaw", c.model), Key::Cross(colour)));
    }
    let body = header(
        root,
        "Reliability of the predicted uncertainty: observed against nominal coverage",
        &keys,
    )?;
    let panels = body.split_evenly((1, 3));
    let phases: [(&str, Option<&str>); 3] = [
        ("every window", None),
        ("transient windows", Some("transient")),
        ("steady windows", Some("steady")),
    ];
    for (panel, (title, phase)) in panels.iter().zip(phases) {
        let mut chart = ChartBuilder::on(panel)
            .margin(15)
            .caption(title, (FONT, LABEL))
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(45.0..100.0, 0.0..100.0)?;
        chart
            .configure_mesh()
            .x_desc("nominal coverage of the predicted region [%]")
            .y_desc("measured poses inside it [% of steps]")
            .axis_desc_style((FONT, LABEL))
            .label_style((FONT, LABEL - 2))
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .draw()?;
        chart.draw_series(std::iter::once(PathElement::new(
            vec![(45.0, 45.0), (100.0, 100.0)],
            COLOURS[5].stroke_width(2),
        )))?;
        for (i, c) in cals.iter().enumerate() {
            let colour = COLOURS[(i + 2) % COLOURS.len()];
            let diagram = match phase {
                None => Some(&c.reliability),
                Some(p) => c.reliability_by_phase.get(p),
            };
            let Some(diagram) = diagram else {
                continue;
            };
            let points = |pick: fn(&drive_eval::ReliabilityPoint) -> f64| -> Vec<(f64, f64)> {
                diagram
                    .iter()
                    .filter(|p| pick(p).is_finite())
                    .map(|p| (100.0 * p.nominal, 100.0 * pick(p)))
                    .collect()
            };
            let position = points(|p| p.position);
            let yaw = points(|p| p.yaw);
            chart.draw_series(LineSeries::new(position.clone(), colour.stroke_width(2)))?;
            chart.draw_series(
                position
                    .iter()
                    .map(|&(x, y)| Circle::new((x, y), 4, colour.filled())),
            )?;
            chart.draw_series(LineSeries::new(yaw.clone(), colour.stroke_width(1)))?;
            chart.draw_series(
                yaw.iter()
                    .map(|&(x, y)| Cross::new((x, y), 5, colour.stroke_width(2))),
            )?;
        }
    }
    root.present()?;
    Ok(())
}
