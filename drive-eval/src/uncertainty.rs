//! How well a model's predicted pose covariance matches its errors on the evaluation
//! windows: coverage of the 95% regions at fixed horizons, the mean negative
//! log-likelihood, and a reliability diagram (nominal against observed coverage).

use drive_models::calibration::{chi2_1, chi2_2, pose_errors, position_score};
use drive_traits::{MotionModel, StartInfo, WindowSet};
use serde::Serialize;
use std::collections::BTreeMap;

/// The horizons (s) of the coverage figures; one a step beyond a window's last step is taken
/// at its last step (2 s windows of 40 samples at 20 Hz end at 1.95 s), one further beyond
/// is left out (1 s windows have no `"2.0"`: it would be their 0.95 s).
pub const COVERAGE_HORIZONS_S: [f64; 3] = [0.5, 1.0, 2.0];

/// The nominal coverages of the reliability diagram.
pub const RELIABILITY_LEVELS: [f64; 8] = [0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.98, 0.99];

/// One point of a reliability diagram.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ReliabilityPoint {
    /// Nominal coverage of the region.
    pub nominal: f64,
    /// Observed fraction of the measured positions inside the position ellipse of that
    /// coverage (every step of every window).
    pub position: f64,
    /// The same for the yaw interval.
    pub yaw: f64,
}

/// The calibration of a model's predicted uncertainty on evaluation windows.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UncertaintyReport {
    /// Fraction of the measured positions inside the predicted 95% ellipse at 0.5, 1 and
    /// 2 s (keys `"0.5"`, `"1.0"`, `"2.0"`).
    pub coverage95: BTreeMap<String, f64>,
    /// Fraction of the measured yaws inside the predicted 95% interval, same horizons.
    pub yaw_coverage95: BTreeMap<String, f64>,
    /// Mean negative log-likelihood (nats) of the measured position under the predicted
    /// 2-D Gaussian, per step (every step k >= 1 of every window with a positive-definite
    /// position covariance).
    pub nll: f64,
    /// Fraction inside the 95% ellipse over every step of every window.
    pub coverage95_overall: f64,
    /// Fraction inside the 95% ellipse at each step k = 1 .. n-1.
    pub coverage95_per_step: Vec<f64>,
    /// Nominal against observed coverage, 50% to 99%.
    pub reliability: Vec<ReliabilityPoint>,
    /// [`UncertaintyReport::reliability`] over the transient and over the steady windows
    /// (keys `"transient"`, `"steady"`; a phase without a window is absent).
    pub reliability_by_phase: BTreeMap<String, Vec<ReliabilityPoint>>,
    /// Steps whose position covariance was not positive definite (counted as outside, left
    /// out of the NLL).
    pub degenerate: usize,
    /// [`UncertaintyReport::coverage95`] of the transient and of the steady windows (keys
    /// `"transient"`, `"steady"`; a phase without a window is absent).
    pub coverage95_by_phase: GroupCoverage,
    /// The same for the yaw.
    pub yaw_coverage95_by_phase: GroupCoverage,
    /// [`UncertaintyReport::coverage95`] in the thirds of the evaluation windows by their
    /// commanded speed (the mean body speed of their commands through the vehicle; keys
    /// `"low"`, `"mid"`, `"high"`).
    pub coverage95_by_speed: GroupCoverage,
    /// The same for the yaw.
    pub yaw_coverage95_by_speed: GroupCoverage,
    /// Sharpness at 2 s: the mean area of the predicted 95% position ellipses over the area
    /// of the smallest circle, the same for every window, that holds as many of the measured
    /// positions (below 1: the ellipses say more than a constant radius would).
    pub area_ratio_to_constant: f64,
    /// The same for the yaw: the mean width of the 95% intervals over the smallest constant
    /// width of the same coverage.
    pub yaw_width_ratio_to_constant: f64,
    /// Spearman's correlation at 2 s between a window's predicted spread (the radius of the
    /// circle of its ellipse's area; the yaw's standard deviation) and its actual error
    /// (keys `"position"`, `"yaw"`): how well the uncertainty says which prediction is hard.
    pub error_rank_correlation: BTreeMap<String, f64>,
}

/// Coverages per group (a phase, a third of the speed) and horizon (`"0.5"`, `"1.0"`,
/// `"2.0"`).
pub type GroupCoverage = BTreeMap<String, BTreeMap<String, f64>>;

/// One evaluation window's phase, commanded speed and figures at each horizon.
struct WindowRecord {
    phase: drive_traits::Phase,
    speed: f64,
    at: Vec<AtStep>,
}

/// One window's uncertainty and error at one horizon step.
#[derive(Debug, Clone, Copy)]
struct AtStep {
    /// Inside the 95% ellipse.
    position: bool,
    /// Inside the 95% yaw interval.
    yaw: bool,
    /// Area of the 95% ellipse (m^2); infinite for a degenerate covariance.
    area: f64,
    /// Position error norm (m).
    error: f64,
    /// Width of the 95% yaw interval (rad).
    yaw_width: f64,
    /// Absolute yaw error (rad).
    yaw_error: f64,
}

/// The horizons of [`COVERAGE_HORIZONS_S`] that windows of `n` samples `dt` apart reach
/// (within a step beyond their last), each with its step (at most the last).
fn reached_horizons(n: usize, dt: f64) -> Vec<(f64, usize)> {
    COVERAGE_HORIZONS_S
        .iter()
        .map(|&h| (h, (h / dt).round()))
        .filter(|&(_, k)| k <= n as f64)
        .map(|(h, k)| (h, (k as usize).clamp(1, n - 1)))
        .collect()
}

/// The share inside at each horizon of `records` (window x horizon).
fn horizon_shares(
    horizons: &[(f64, usize)],
    records: &[&[AtStep]],
    pick: fn(&AtStep) -> bool,
) -> BTreeMap<String, f64> {
    horizons
        .iter()
        .enumerate()
        .map(|(i, (h, _))| {
            let inside = records.iter().filter(|r| pick(&r[i])).count();
            (
                format!("{h:.1}"),
                inside as f64 / records.len().max(1) as f64,
            )
        })
        .collect()
}

/// The smallest constant bound holding a `share` of the `errors` (its order statistic of
/// rank `ceil(share n)`); NaN without an error.
fn constant_bound(errors: &[f64], share: f64) -> f64 {
    let mut e: Vec<f64> = errors.iter().copied().filter(|x| x.is_finite()).collect();
    if e.is_empty() {
        return f64::NAN;
    }
    e.sort_by(f64::total_cmp);
    let rank = ((share * e.len() as f64).ceil() as usize).clamp(1, e.len());
    e[rank - 1]
}

fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len().max(1) as f64
}

/// Scores the pose covariance of `model` on the windows of `eval` (predictions from what
/// `start` allows); `None` for a model without a covariance or windows without two samples.
///
/// ```
/// use drive_eval::{score_uncertainty, split_by_interval};
/// use drive_models::{powertrain::Fopdt, slip::SlipBlr, Composed};
/// use drive_traits::{Learner, StartInfo};
/// let data = drive_data::bundled::load("husky_drive").unwrap();
/// let (train, eval) = split_by_interval(&data, 0.5).unwrap();
/// // The paper's slip-BLR, its covariance the paper's (eq. 7).
/// let model = Composed::new(Fopdt::default(), SlipBlr::default()).fit(&train).unwrap();
/// let u = score_uncertainty(&model, &eval, StartInfo::default()).unwrap();
/// assert_eq!(u.coverage95.keys().collect::<Vec<_>>(), ["0.5", "1.0", "2.0"]);
/// assert!(u.coverage95.values().all(|f| (0.0..=1.0).contains(f)));
/// assert_eq!(u.reliability.len(), 8);
/// ```
pub fn score_uncertainty(
    model: &dyn MotionModel,
    eval: &WindowSet<'_>,
    start: StartInfo,
) -> Option<UncertaintyReport> {
    let vehicle = eval.robot.vehicle.as_ref();
    let n = eval.windows.iter().map(|w| w.len()).max()?;
    if n < 2 {
        return None;
    }
    let dt = eval.robot.dt();
    let levels = RELIABILITY_LEVELS.map(|p| (chi2_2(p), chi2_1(p)));
    let (chi2_pos, chi2_yaw) = (chi2_2(0.95), chi2_1(0.95));
    let mut inside = vec![0usize; n];
    let mut yaw_inside = vec![0usize; n];
    let mut counted = vec![0usize; n];
    let mut reliability = [(0usize, 0usize); RELIABILITY_LEVELS.len()];
    // The same per phase (transient, steady), with the steps counted.
    let mut phase_reliability = [[(0usize, 0usize); RELIABILITY_LEVELS.len()]; 2];
    let mut phase_steps = [0usize; 2];
    let (mut nll, mut nll_count, mut degenerate) = (0.0, 0usize, 0usize);
    let (mut poses, mut covs) = (Vec::new(), Vec::new());
    // Per window: its phase, its commanded speed, and its figures at each horizon.
    let mut records: Vec<WindowRecord> = Vec::new();
    let horizons = reached_horizons(n, dt);
    let steps: Vec<usize> = horizons.iter().map(|&(_, k)| k).collect();
    for w in eval.windows.iter().filter(|w| w.len() >= 2) {
        model
            .predict_with_covariance_into(
                &w.start_state_with(vehicle, start),
                &w.command,
                &mut poses,
                &mut covs,
            )
            .ok()?;
        let errors = pose_errors(&poses, &w.pose);
        let speed = w
            .command
            .iter()
            .map(|u| {
                let f = vehicle.body_velocity(u);
                f.x.hypot(f.y)
            })
            .sum::<f64>()
            / w.command.len().max(1) as f64;
        let at: Vec<AtStep> = steps
            .iter()
            .map(|&k| {
                let k = k.min(errors.len() - 1);
                let (e, c) = (&errors[k], &covs[k]);
                let det = c[(0, 0)] * c[(1, 1)] - c[(0, 1)] * c[(1, 0)];
                let yaw_var = c[(2, 2)];
                AtStep {
                    position: position_score(e, c) <= chi2_pos,
                    yaw: yaw_var > 0.0 && e.z * e.z / yaw_var <= chi2_yaw,
                    area: if det > 0.0 {
                        std::f64::consts::PI * chi2_pos * det.sqrt()
                    } else {
                        f64::INFINITY
                    },
                    error: e.x.hypot(e.y),
                    yaw_width: 2.0 * (chi2_yaw * yaw_var.max(0.0)).sqrt(),
                    yaw_error: e.z.abs(),
                }
            })
            .collect();
        records.push(WindowRecord {
            phase: w.phase,
            speed,
            at,
        });
        for (k, e) in errors.iter().enumerate().skip(1) {
            let c = &covs[k];
            counted[k] += 1;
            let m2 = position_score(e, c);
            let yaw_var = c[(2, 2)];
            let y2 = if yaw_var > 0.0 {
                e.z * e.z / yaw_var
            } else {
                f64::INFINITY
            };
            if m2 <= chi2_pos {
                inside[k] += 1;
            }
            if y2 <= chi2_yaw {
                yaw_inside[k] += 1;
            }
            let phase = usize::from(w.phase == drive_traits::Phase::Steady);
            phase_steps[phase] += 1;
            for ((slot, by_phase), (lp, ly)) in reliability
                .iter_mut()
                .zip(&mut phase_reliability[phase])
                .zip(&levels)
            {
                slot.0 += usize::from(m2 <= *lp);
                slot.1 += usize::from(y2 <= *ly);
                by_phase.0 += usize::from(m2 <= *lp);
                by_phase.1 += usize::from(y2 <= *ly);
            }
            let det = c[(0, 0)] * c[(1, 1)] - c[(0, 1)] * c[(1, 0)];
            // A singular covariance has no density: counted apart, not as -inf or NaN.
            let step_nll = 0.5 * (m2 + det.ln()) + (2.0 * std::f64::consts::PI).ln();
            if m2.is_finite() && det > 0.0 && step_nll.is_finite() {
                nll += step_nll;
                nll_count += 1;
            } else {
                degenerate += 1;
            }
        }
    }
    let total: usize = counted.iter().sum();
    if total == 0 {
        return None;
    }
    let fraction = |hits: &[usize], k: usize| hits[k] as f64 / counted[k].max(1) as f64;
    // By phase and by thirds of the commanded speed.
    let by = |keep: &dyn Fn(&WindowRecord) -> bool| -> Vec<&[AtStep]> {
        records
            .iter()
            .filter(|r| keep(r))
            .map(|r| r.at.as_slice())
            .collect()
    };
    let (mut coverage95_by_phase, mut yaw_coverage95_by_phase) = (BTreeMap::new(), BTreeMap::new());
    for phase in [drive_traits::Phase::Transient, drive_traits::Phase::Steady] {
        let of = by(&|r| r.phase == phase);
        if !of.is_empty() {
            coverage95_by_phase.insert(
                phase.as_str().to_string(),
                horizon_shares(&horizons, &of, |a| a.position),
            );
            yaw_coverage95_by_phase.insert(
                phase.as_str().to_string(),
                horizon_shares(&horizons, &of, |a| a.yaw),
            );
        }
    }
    let mut speeds: Vec<f64> = records.iter().map(|r| r.speed).collect();
    speeds.sort_by(f64::total_cmp);
    let cut = |p: f64| crate::quantile(&speeds, p).unwrap_or(0.0);
    let (low, high) = (cut(1.0 / 3.0), cut(2.0 / 3.0));
    let (mut coverage95_by_speed, mut yaw_coverage95_by_speed) = (BTreeMap::new(), BTreeMap::new());
    for (name, keep) in [
        ("low", &(|s: f64| s <= low) as &dyn Fn(f64) -> bool),
        ("mid", &|s: f64| s > low && s <= high),
        ("high", &|s: f64| s > high),
    ] {
        let of = by(&|r| keep(r.speed));
        if !of.is_empty() {
            coverage95_by_speed.insert(
                name.to_string(),
                horizon_shares(&horizons, &of, |a| a.position),
            );
            yaw_coverage95_by_speed
                .insert(name.to_string(), horizon_shares(&horizons, &of, |a| a.yaw));
        }
    }
    // Sharpness and ranking at the last horizon (2 s).
    let last: Vec<AtStep> = records
        .iter()
        .filter_map(|r| r.at.last().copied())
        .collect();
    let share = |pick: fn(&AtStep) -> bool| {
        last.iter().filter(|a| pick(a)).count() as f64 / last.len().max(1) as f64
    };
    let column = |pick: fn(&AtStep) -> f64| -> Vec<f64> { last.iter().map(pick).collect() };
    let (area, error) = (column(|a| a.area), column(|a| a.error));
    let (yaw_width, yaw_error) = (column(|a| a.yaw_width), column(|a| a.yaw_error));
    let circle = constant_bound(&error, share(|a| a.position));
    let area_ratio_to_constant = mean(&area) / (std::f64::consts::PI * circle * circle);
    // A yaw interval is twice its half-width, the constant one twice its bound.
    let yaw_width_ratio_to_constant =
        mean(&yaw_width) / (2.0 * constant_bound(&yaw_error, share(|a| a.yaw)));
    let radius: Vec<f64> = area
        .iter()
        .map(|a| (a / std::f64::consts::PI).sqrt())
        .collect();
    let mut error_rank_correlation = BTreeMap::new();
    if let Some(r) = crate::spearman(&radius, &error) {
        error_rank_correlation.insert("position".to_string(), r);
    }
    if let Some(r) = crate::spearman(&yaw_width, &yaw_error) {
        error_rank_correlation.insert("yaw".to_string(), r);
    }
    let at_horizons = |hits: &[usize]| {
        horizons
            .iter()
            .map(|&(h, k)| (format!("{h:.1}"), fraction(hits, k)))
            .collect::<BTreeMap<_, _>>()
    };
    let points = |counts: &[(usize, usize)], total: usize| -> Vec<ReliabilityPoint> {
        RELIABILITY_LEVELS
            .iter()
            .zip(counts)
            .map(|(&nominal, (p, y))| ReliabilityPoint {
                nominal,
                position: *p as f64 / total as f64,
                yaw: *y as f64 / total as f64,
            })
            .collect()
    };
    let reliability_by_phase = [drive_traits::Phase::Transient, drive_traits::Phase::Steady]
        .iter()
        .zip(phase_reliability.iter().zip(phase_steps))
        .filter(|(_, (_, steps))| *steps > 0)
        .map(|(phase, (counts, steps))| (phase.as_str().to_string(), points(counts, steps)))
        .collect();
    Some(UncertaintyReport {
        coverage95: at_horizons(&inside),
        yaw_coverage95: at_horizons(&yaw_inside),
        nll: if nll_count > 0 {
            nll / nll_count as f64
        } else {
            f64::NAN
        },
        coverage95_overall: inside.iter().sum::<usize>() as f64 / total as f64,
        coverage95_per_step: (1..n).map(|k| fraction(&inside, k)).collect(),
        reliability: points(&reliability, total),
        reliability_by_phase,
        degenerate,
        coverage95_by_phase,
        yaw_coverage95_by_phase,
        coverage95_by_speed,
        yaw_coverage95_by_speed,
        area_ratio_to_constant,
        yaw_width_ratio_to_constant,
        error_rank_correlation,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_models::DifferentialDrive;
    use drive_traits::{
        Input, MotionError, Phase, Pose, PoseCovariance, RobotDescription, StartState, Tagged,
        Window,
    };
    use serde::Deserialize;

    /// Predicts the start pose, with a covariance of `var` on every axis after the start.
    #[derive(Debug, Serialize, Deserialize)]
    struct Still {
        var: f64,
    }
    #[typetag::serde(name = "still-uncertainty-test")]
    impl MotionModel for Still {
        fn name(&self) -> String {
            "still".into()
        }
        fn dt(&self) -> f64 {
            0.05
        }
        fn predict_into(&self, s: &StartState, c: &[Input], p: &mut Vec<Pose>) {
            p.clear();
            p.resize(c.len(), s.pose);
        }
        fn predict_with_covariance_into(
            &self,
            s: &StartState,
            c: &[Input],
            p: &mut Vec<Pose>,
            cov: &mut Vec<PoseCovariance>,
        ) -> Result<(), MotionError> {
            self.predict_into(s, c, p);
            cov.clear();
            cov.extend((0..c.len()).map(|k| {
                if k == 0 {
                    PoseCovariance::zeros()
                } else {
                    PoseCovariance::identity() * self.var
                }
            }));
            Ok(())
        }
    }
    impl Tagged for Still {
        const TAG: &'static str = "still-uncertainty-test";
    }

    #[test]
    fn coverage_counts_errors_inside_the_ellipse_hand_computed() {
        // 40 samples at 20 Hz; window i's measured position is at distance d_i (m) from the
        // prediction at every step, yaw error 0. Under a unit covariance the 95% ellipse
        // has radius sqrt(5.99) = 2.448.
        let robot = RobotDescription::new("t", "", 20.0, 40, DifferentialDrive::new(0.1, 0.5));
        let distances = [0.5, 1.0, 2.0, 3.0];
        let windows: Vec<Window> = distances
            .iter()
            .enumerate()
            .map(|(i, d)| {
                Window::new(
                    i,
                    i,
                    Phase::Steady,
                    vec![Input::zeros(); 40],
                    vec![Input::zeros(); 40],
                    jumped(*d),
                    vec![0.0; 40],
                )
            })
            .collect();
        let set = WindowSet::new(&robot, &windows);
        let u = score_uncertainty(&Still { var: 1.0 }, &set, StartInfo::default()).unwrap();
        assert_eq!(u.coverage95["0.5"], 0.75);
        assert_eq!(u.coverage95["2.0"], 0.75);
        assert_eq!(u.yaw_coverage95["1.0"], 1.0);
        assert_eq!(u.coverage95_per_step.len(), 39);
        // NLL: mean of 0.5 d^2 + ln(2 pi) over the windows (ln det = 0).
        let expected = distances.iter().map(|d| 0.5 * d * d).sum::<f64>() / 4.0
            + (2.0 * std::f64::consts::PI).ln();
        assert!((u.nll - expected).abs() < 1e-12);
        // 50% ellipse: radius sqrt(-2 ln 0.5) = 1.177: only 0.5 and 1.0 are inside.
        assert_eq!(u.reliability[0].nominal, 0.5);
        assert_eq!(u.reliability[0].position, 0.5);
        // A zero covariance: every step degenerate, nothing inside.
        let z = score_uncertainty(&Still { var: 0.0 }, &set, StartInfo::default()).unwrap();
        assert_eq!((z.coverage95["1.0"], z.degenerate), (0.0, 4 * 39));
        assert!(z.nll.is_nan());
    }

    /// Windows `i` whose measured position is `d_i` (m) from the start at every step, of
    /// phase transient for the first two, their measured start input `(d_i, 0)` and
    /// commands of body speed `d_i` (wheel velocities 10 d_i on 0.1 m wheels).
    /// 40 poses: the start, then `d` m straight ahead for the rest of the window.
    fn jumped(d: f64) -> Vec<Pose> {
        (0..40)
            .map(|k| {
                if k == 0 {
                    Pose::zeros()
                } else {
                    Pose::new(d, 0.0, 0.0)
                }
            })
            .collect()
    }

    fn spread_windows() -> Vec<Window> {
        [0.5, 1.0, 2.0, 3.0]
            .iter()
            .enumerate()
            .map(|(i, d)| {
                Window::new(
                    i,
                    i,
                    if i < 2 {
                        Phase::Transient
                    } else {
                        Phase::Steady
                    },
                    vec![Input::new(10.0 * d, 10.0 * d, 0.0); 40],
                    vec![Input::new(*d, 0.0, 0.0); 40],
                    jumped(*d),
                    vec![0.0; 40],
                )
            })
            .collect()
    }

    /// Predicts the start pose with a variance of the squared measured start input's first
    /// axis: a spread that knows each window's error.
    #[derive(Debug, Serialize, Deserialize)]
    struct Knowing;
    #[typetag::serde(name = "knowing-uncertainty-test")]
    impl MotionModel for Knowing {
        fn name(&self) -> String {
            "knowing".into()
        }
        fn dt(&self) -> f64 {
            0.05
        }
        fn predict_into(&self, s: &StartState, c: &[Input], p: &mut Vec<Pose>) {
            p.clear();
            p.resize(c.len(), s.pose);
        }
        fn predict_with_covariance_into(
            &self,
            s: &StartState,
            c: &[Input],
            p: &mut Vec<Pose>,
            cov: &mut Vec<PoseCovariance>,
        ) -> Result<(), MotionError> {
            self.predict_into(s, c, p);
            cov.clear();
            let var = s.input.x * s.input.x;
            cov.extend((0..c.len()).map(|k| {
                if k == 0 {
                    PoseCovariance::zeros()
                } else {
                    PoseCovariance::identity() * var
                }
            }));
            Ok(())
        }
    }
    impl Tagged for Knowing {
        const TAG: &'static str = "knowing-uncertainty-test";
    }

    #[test]
    fn coverage_by_phase_and_speed_sharpness_and_ranking_hand_computed() {
        let robot = RobotDescription::new("t", "", 20.0, 40, DifferentialDrive::new(0.1, 0.5));
        let windows = spread_windows();
        let set = WindowSet::new(&robot, &windows);
        // One unit variance for all: errors 0.5, 1, 2 inside the 2.448 m circle, 3 out.
        let u = score_uncertainty(&Still { var: 1.0 }, &set, StartInfo::default()).unwrap();
        assert_eq!(u.coverage95_by_phase["transient"]["2.0"], 1.0);
        assert_eq!(u.coverage95_by_phase["steady"]["2.0"], 0.5);
        // The reliability per phase: the 50% circle (radius sqrt(1.386) = 1.18 m) holds the
        // transient errors 0.5 and 1 at every step, neither steady one (2, 3); the yaw
        // errors are 0.
        let half = |phase: &str| u.reliability_by_phase[phase][0];
        assert_eq!(
            (half("transient").nominal, half("transient").position),
            (0.5, 1.0)
        );
        assert_eq!((half("steady").position, half("steady").yaw), (0.0, 1.0));
        assert_eq!(u.reliability[0].position, 0.5);
        // Speeds 0.5, 1, 2, 3 m/s: thirds at 1 and 2 (linear interpolation).
        assert_eq!(u.coverage95_by_speed["low"]["1.0"], 1.0);
        assert_eq!(u.coverage95_by_speed["mid"]["1.0"], 1.0);
        assert_eq!(u.coverage95_by_speed["high"]["1.0"], 0.0);
        assert_eq!(u.yaw_coverage95_by_speed["high"]["0.5"], 1.0);
        // Coverage 3/4: the smallest constant circle holding three errors has radius 2;
        // every ellipse has area pi 5.99 against pi 4.
        let chi2 = chi2_2(0.95);
        assert!((u.area_ratio_to_constant - chi2 / 4.0).abs() < 1e-12);
        // A constant spread ranks nothing.
        assert!(!u.error_rank_correlation.contains_key("position"));
        // A spread that grows with the error: ranked perfectly, every error inside; the
        // constant circle must reach 3 m, the ellipses average pi 5.99 (0.25+1+4+9)/4.
        let k = score_uncertainty(&Knowing, &set, StartInfo::default()).unwrap();
        assert_eq!(k.error_rank_correlation["position"], 1.0);
        assert_eq!(k.coverage95["2.0"], 1.0);
        let expected = chi2 * (0.25 + 1.0 + 4.0 + 9.0) / 4.0 / 9.0;
        assert!((k.area_ratio_to_constant - expected).abs() < 1e-12);
    }
}
