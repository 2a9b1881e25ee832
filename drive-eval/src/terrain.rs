//! The terrain's unpredictability: how far the body motion the robot was commanded is from
//! the motion it made, as kinetic energy, after the energy-based metric of the DRIVE
//! follow-up (Baril et al., T-FR 2025; code in norlab-ulaval/doughnut_calib,
//! `metric_energy.py`, its `SlopeMetric`).
//!
//! For each sample `k` of a window, the commanded body velocity `c = f(u_k)` (the commands
//! through the vehicle's kinematics, eq. 4 for a skid-steer) is compared with the body
//! velocity `m` the localization measured one command step later. Their kinetic energies,
//! translational `E_t = m_r (v_x^2 + v_y^2) / 2` and rotational `E_r = I w^2 / 2`, are mapped
//! to `[0, 1]` by
//!
//! ```text
//! u = (4 / pi) |atan2(E_measured, E_commanded) - pi / 4|
//! ```
//!
//! 0 when the robot moves with the energy it was commanded, 1 when it does not move (or
//! moves with no command). The total compares `E_t + E_r` of the command with the measured
//! `E_t (1 + cos a) / 2 + E_r [w_c w_m > 0]`: the measured translation weighted by the
//! agreement of its direction with the command's (`a` the angle between them) and the
//! rotation counted only when it turns the commanded way.
//!
//! The robot's mass cancels in every ratio; the total needs the body's moment of inertia per
//! unit mass, `(l^2 + w^2) / 12` for a uniform box of the body's footprint (as the original;
//! [`BodySize`]).
//!
//! Where the original code leaves a choice, this module makes it (documented on
//! [`UnpredictabilityConfig`]): the measured velocity is the localization's mean over 1 s,
//! each step turned into the body frame (the original reads an interpolated velocity
//! column); commands are
//! clipped to the input space the encoders reached (the original clips them to the robot's
//! software limits), so that a motor's saturation is not counted as the terrain's; samples
//! where neither the command nor the motion carries 5% of the dataset's top commanded speed
//! are left out (a standing robot commanded to stand is neither predictable nor not); the
//! dataset's figure is the median over the samples of its steady windows (the original's
//! `steady_state_only`).

use crate::stats::quantile;
use drive_samplers::BodySize;
use drive_traits::{
    BodyVelocity, BodyVelocityEstimator, Dataset, Input, InputSpace, Phase, PositionFrame, Window,
};
use serde::Serialize;
use std::f64::consts::{FRAC_PI_4, PI};

/// How the unpredictability is computed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnpredictabilityConfig {
    /// Span over which the localization's steps give the measured body velocity (s). 1 s: differentiated over 0.2 s (two updates of a 10 Hz ICP), centimetre
    /// localization noise alone reads 0.1-0.4 in translation on runs that follow their
    /// commands, which a steady window's constant velocity does not need.
    pub velocity_span_s: f64,
    /// Command steps between a command and the motion it is compared with (the original's
    /// one-step alignment: the command at `k`, the motion at `k + 1`).
    pub lag_steps: usize,
    /// A sample counts when the commanded or the measured motion reaches this fraction of
    /// the dataset's top commanded speed (translational and angular separately).
    pub floor_fraction: f64,
    /// Per axis, the commands are clipped to the range between these quantiles of the
    /// measured inputs (widened to include 0): the input space the robot reached.
    pub reached_quantiles: [f64; 2],
    /// The windows the dataset's figure pools: the steady ones (as the original) or all.
    pub steady_only: bool,
}

impl Default for UnpredictabilityConfig {
    fn default() -> Self {
        UnpredictabilityConfig {
            velocity_span_s: 1.0,
            lag_steps: 1,
            floor_fraction: 0.05,
            reached_quantiles: [0.005, 0.995],
            steady_only: true,
        }
    }
}

/// The unpredictability of one kind (translational, rotational or total) over a set of
/// samples.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct UnpredictabilitySummary {
    /// Median over the samples.
    pub median: f64,
    /// First and third quartiles.
    pub iqr: [f64; 2],
    /// Mean over the samples.
    pub mean: f64,
    /// Samples counted.
    pub samples: usize,
}

impl UnpredictabilitySummary {
    fn of(mut values: Vec<f64>) -> Option<Self> {
        if values.is_empty() {
            return None;
        }
        values.sort_by(f64::total_cmp);
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        Some(UnpredictabilitySummary {
            median: quantile(&values, 0.5)?,
            iqr: [quantile(&values, 0.25)?, quantile(&values, 0.75)?],
            mean,
            samples: values.len(),
        })
    }
}

/// One window's unpredictability: the median over its counted samples of each kind
/// (`None` where no sample counts).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WindowUnpredictability {
    /// Window index.
    pub window: usize,
    /// Its DRIVE interval.
    pub interval: usize,
    /// Transient or steady.
    pub phase: Phase,
    /// Translational.
    pub translational: Option<f64>,
    /// Rotational.
    pub rotational: Option<f64>,
    /// Total (with the body's inertia).
    pub total: Option<f64>,
}

/// A dataset's unpredictability: its summaries over the pooled samples and every window's.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Unpredictability {
    /// Translational kinetic energy.
    pub translational: Option<UnpredictabilitySummary>,
    /// Rotational kinetic energy.
    pub rotational: Option<UnpredictabilitySummary>,
    /// Total kinetic energy, direction- and sign-weighted; `None` without the body's size.
    pub total: Option<UnpredictabilitySummary>,
    /// The windows pooled: `steady` or `all`.
    pub pooled: &'static str,
    /// The body's moment of inertia per unit mass used by the total (m^2).
    pub inertia_per_mass_m2: Option<f64>,
    /// The input space the commands were clipped to (the one the encoders reached).
    pub reached: Option<InputSpace>,
    /// Every window's figures, in the dataset's order.
    pub windows: Vec<WindowUnpredictability>,
}

impl Unpredictability {
    /// The window figures by window index (for matching with per-window errors).
    pub fn by_window(&self) -> std::collections::HashMap<usize, WindowUnpredictability> {
        self.windows.iter().map(|w| (w.window, *w)).collect()
    }
}

/// `(4 / pi) |atan2(measured, commanded) - pi / 4|`: 0 for equal energies, 1 when one of
/// them is zero.
///
/// ```
/// use drive_eval::energy_unpredictability as u;
/// assert_eq!(u(2.0, 2.0), 0.0);
/// assert_eq!(u(0.0, 2.0), 1.0);
/// assert!((u(2.0, 0.0) - 1.0).abs() < 1e-15);
/// assert!(u(1.0, 2.0) > 0.0 && u(1.0, 2.0) < 1.0);
/// ```
pub fn energy_unpredictability(measured: f64, commanded: f64) -> f64 {
    (4.0 / PI * (measured.atan2(commanded) - FRAC_PI_4).abs()).clamp(0.0, 1.0)
}

/// The input space the measured inputs reached: per axis the range between the configured
/// quantiles, widened to include 0. An axis that reached less than 5% of what it was
/// commanded (a stuck motor, or one never driven) is not clipped: `None` for the whole box
/// when neither axis gives a range, else the commanded range stands in for such an axis.
fn reached_space(data: &Dataset, q: [f64; 2]) -> Option<InputSpace> {
    let axis = |i: usize, of: fn(&Window) -> &Vec<Input>| -> Vec<f64> {
        let mut v: Vec<f64> = data
            .windows
            .iter()
            .flat_map(|w| of(w).iter().map(move |u| u[i]))
            .filter(|x| x.is_finite())
            .collect();
        v.sort_by(f64::total_cmp);
        v
    };
    let range = |sorted: &[f64]| -> Option<[f64; 2]> {
        Some([
            quantile(sorted, q[0])?.min(0.0),
            quantile(sorted, q[1])?.max(0.0),
        ])
    };
    let mut lo = Input::zeros();
    let mut hi = Input::zeros();
    // Each of the vehicle's axes.
    for i in 0..data.robot.vehicle.input_dim().min(drive_traits::MAX_INPUTS) {
        let measured = range(&axis(i, |w| &w.measured))?;
        let commanded = axis(i, |w| &w.command);
        let span = |r: [f64; 2]| r[1] - r[0];
        let commanded = [
            commanded.first().copied()?.min(0.0),
            commanded.last().copied()?.max(0.0),
        ];
        let r = if span(measured) >= 0.05 * span(commanded) {
            measured
        } else {
            commanded
        };
        lo[i] = r[0];
        hi[i] = r[1];
    }
    // A box with no width on an axis (nothing commanded on it) still clips to it.
    Some(InputSpace { min: lo, max: hi })
}

/// The body velocity at each sample from the localization, over `span_s` centred on it: the
/// mean of the steps' displacements, each turned into the body frame at the middle of its
/// step and lengthened by the arc it drove (`(a / 2) / sin(a / 2)` for a heading change
/// `a`), so that a constant body velocity is measured exactly however far the robot turns
/// over the span; the yaw rate from the heading change over the span. `None` near the
/// window's ends.
fn arc_velocities(window: &Window, dt: f64, span_s: f64) -> Vec<Option<BodyVelocity>> {
    let n = window.len();
    let h = BodyVelocityEstimator { span_s }.half_width(dt);
    let mut out = vec![None; n];
    if n <= 2 * h {
        return out;
    }
    let mut yaw: Vec<f64> = window.pose.iter().map(|p| p.z).collect();
    drive_traits::unwrap_angles(&mut yaw);
    // Each step's displacement in the body frame, per unit of time.
    let steps: Vec<[f64; 2]> = (0..n - 1)
        .map(|j| {
            let (a, b) = (&window.pose[j], &window.pose[j + 1]);
            let half = 0.5 * (yaw[j + 1] - yaw[j]);
            let arc = if half.abs() < 1e-6 {
                1.0
            } else {
                half / half.sin()
            };
            let (s, c) = (yaw[j] + half).sin_cos();
            let (dx, dy) = (b.x - a.x, b.y - a.y);
            [(c * dx + s * dy) * arc / dt, (-s * dx + c * dy) * arc / dt]
        })
        .collect();
    let t = 2.0 * h as f64 * dt;
    for k in h..n - h {
        let (mut vx, mut vy) = (0.0, 0.0);
        for step in &steps[k - h..k + h] {
            vx += step[0];
            vy += step[1];
        }
        let m = 2.0 * h as f64;
        out[k] = Some(BodyVelocity::new(
            vx / m,
            vy / m,
            (yaw[k + h] - yaw[k - h]) / t,
        ));
    }
    out
}

/// One sample's commanded and measured body velocities.
struct Sample {
    commanded: BodyVelocity,
    measured: BodyVelocity,
}

/// The (commanded, measured) pairs of a window, with the commands clipped to `reached`.
fn samples(
    window: &Window,
    data: &Dataset,
    reached: Option<&InputSpace>,
    config: &UnpredictabilityConfig,
    out: &mut Vec<Sample>,
) {
    out.clear();
    let corrected;
    let window = if data.robot.position_frame == PositionFrame::PaperMean5 {
        let mut w = window.clone();
        w.to_first_sample_frame();
        corrected = w;
        &corrected
    } else {
        window
    };
    let measured = arc_velocities(window, data.robot.dt(), config.velocity_span_s);
    let vehicle = data.robot.vehicle.as_ref();
    for (k, u) in window.command.iter().enumerate() {
        let Some(Some(m)) = measured.get(k + config.lag_steps) else {
            continue;
        };
        let u = reached.map_or(*u, |j| j.clamp(u));
        let c = vehicle.body_velocity(&u);
        if c.iter().chain(m.iter()).all(|v| v.is_finite()) {
            out.push(Sample {
                commanded: c,
                measured: *m,
            });
        }
    }
}

/// The per-sample values of one window: translational, rotational, total.
struct SampleValues {
    translational: Vec<f64>,
    rotational: Vec<f64>,
    total: Vec<f64>,
}

/// The terrain's unpredictability of `data` (see the module's documentation); `body` gives
/// the total (without it, `total` is `None`).
///
/// ```
/// use drive_eval::{unpredictability, UnpredictabilityConfig};
/// let data = drive_data::bundled::load("husky_drive").unwrap();
/// let body = drive_samplers::BodySize { length_m: 0.8382, width_m: 0.6604 };
/// let u = unpredictability(&data, Some(body), &UnpredictabilityConfig::default());
/// let total = u.total.unwrap();
/// assert!((0.0..=1.0).contains(&total.median));
/// assert_eq!(u.windows.len(), data.windows.len());
/// ```
pub fn unpredictability(
    data: &Dataset,
    body: Option<BodySize>,
    config: &UnpredictabilityConfig,
) -> Unpredictability {
    let inertia = body.map(|b| b.inertia_per_mass());
    let reached = reached_space(data, config.reached_quantiles);
    // The top commanded speeds give the floors.
    let mut pairs = Vec::new();
    let mut per_window: Vec<Vec<Sample>> = Vec::with_capacity(data.windows.len());
    let (mut top_v, mut top_w) = (0.0f64, 0.0f64);
    for w in &data.windows {
        samples(w, data, reached.as_ref(), config, &mut pairs);
        for s in &pairs {
            top_v = top_v.max(s.commanded.x.hypot(s.commanded.y));
            top_w = top_w.max(s.commanded.z.abs());
        }
        per_window.push(std::mem::take(&mut pairs));
    }
    let floor_t = 0.5 * (config.floor_fraction * top_v).powi(2);
    let floor_r = 0.5 * (config.floor_fraction * top_w).powi(2);
    let values = |samples: &[Sample]| -> SampleValues {
        let mut v = SampleValues {
            translational: Vec::new(),
            rotational: Vec::new(),
            total: Vec::new(),
        };
        for s in samples {
            let (c, m) = (&s.commanded, &s.measured);
            // Per unit mass (translational) and per unit of inertia (rotational).
            let et = [0.5 * (c.x * c.x + c.y * c.y), 0.5 * (m.x * m.x + m.y * m.y)];
            let er = [0.5 * c.z * c.z, 0.5 * m.z * m.z];
            if et[0].max(et[1]) > floor_t {
                v.translational.push(energy_unpredictability(et[1], et[0]));
            }
            if er[0].max(er[1]) > floor_r {
                v.rotational.push(energy_unpredictability(er[1], er[0]));
            }
            if let Some(i) = inertia {
                let commanded = et[0] + i * er[0];
                let raw = et[1] + i * er[1];
                if commanded.max(raw) > floor_t + i * floor_r {
                    let (nc, nm) = (c.x.hypot(c.y), m.x.hypot(m.y));
                    let cos = if nc > 0.0 && nm > 0.0 {
                        ((c.x * m.x + c.y * m.y) / (nc * nm)).clamp(-1.0, 1.0)
                    } else {
                        1.0
                    };
                    let same_turn = if c.z * m.z > 0.0 { 1.0 } else { 0.0 };
                    let measured = et[1] * (1.0 + cos) / 2.0 + i * er[1] * same_turn;
                    v.total.push(energy_unpredictability(measured, commanded));
                }
            }
        }
        v
    };
    let median =
        |mut v: Vec<f64>| -> Option<f64> { (!v.is_empty()).then(|| drive_traits::median(&mut v)) };
    let (mut pooled_t, mut pooled_r, mut pooled_total) = (Vec::new(), Vec::new(), Vec::new());
    let mut windows = Vec::with_capacity(data.windows.len());
    for (w, s) in data.windows.iter().zip(&per_window) {
        let v = values(s);
        if !config.steady_only || w.phase == Phase::Steady {
            pooled_t.extend_from_slice(&v.translational);
            pooled_r.extend_from_slice(&v.rotational);
            pooled_total.extend_from_slice(&v.total);
        }
        windows.push(WindowUnpredictability {
            window: w.index,
            interval: w.interval,
            phase: w.phase,
            translational: median(v.translational),
            rotational: median(v.rotational),
            total: median(v.total),
        });
    }
    Unpredictability {
        translational: UnpredictabilitySummary::of(pooled_t),
        rotational: UnpredictabilitySummary::of(pooled_r),
        total: UnpredictabilitySummary::of(pooled_total),
        pooled: if config.steady_only { "steady" } else { "all" },
        inertia_per_mass_m2: inertia,
        reached,
        windows,
    }
}
