//! How well a model's predicted pose covariance matches its errors on the evaluation
//! windows: coverage of the 95% regions at fixed horizons, the mean negative
//! log-likelihood, and a reliability diagram (nominal against observed coverage).

use drive_models::calibration::{chi2_1, chi2_2, pose_errors, position_score};
use drive_traits::{MotionModel, StartInfo, WindowSet};
use serde::Serialize;
use std::collections::BTreeMap;

/// The horizons (s) of the coverage figures; one beyond a window's last step is taken at
/// its last step (2 s windows of 40 samples at 20 Hz end at 1.95 s).
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
    /// Steps whose position covariance was not positive definite (counted as outside, left
    /// out of the NLL).
    pub degenerate: usize,
}

/// Scores the pose covariance of `model` on the windows of `eval` (predictions from what
/// `start` allows); `None` for a model without a covariance or windows without two samples.
///
/// ```
/// use drive_eval::{score_uncertainty, split_by_interval, Registries};
/// let data = drive_eval::simulate_protocol(&Registries::builtin(), "husky", "gravel", "uniform", 12, 1).unwrap().dataset;
/// let (train, eval) = split_by_interval(&data, 0.5).unwrap();
/// let spec = Registries::builtin().models().resolve("slip-blr").unwrap();
/// let model = spec.fit(&train).unwrap();
/// let u = score_uncertainty(model.as_ref(), &eval, spec.start).unwrap();
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
    let (mut nll, mut nll_count, mut degenerate) = (0.0, 0usize, 0usize);
    let (mut poses, mut covs) = (Vec::new(), Vec::new());
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
            for (slot, (lp, ly)) in reliability.iter_mut().zip(&levels) {
                slot.0 += usize::from(m2 <= *lp);
                slot.1 += usize::from(y2 <= *ly);
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
    let at_horizons = |hits: &[usize]| {
        COVERAGE_HORIZONS_S
            .iter()
            .map(|h| {
                let k = ((h / dt).round() as usize).clamp(1, n - 1);
                (format!("{h:.1}"), fraction(hits, k))
            })
            .collect::<BTreeMap<_, _>>()
    };
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
        reliability: RELIABILITY_LEVELS
            .iter()
            .zip(reliability)
            .map(|(&nominal, (p, y))| ReliabilityPoint {
                nominal,
                position: p as f64 / total as f64,
                yaw: y as f64 / total as f64,
            })
            .collect(),
        degenerate,
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
            .map(|(i, d)| Window {
                index: i,
                interval: i,
                phase: Phase::Steady,
                command: vec![Input::zeros(); 40],
                measured: vec![Input::zeros(); 40],
                pose: (0..40)
                    .map(|k| {
                        if k == 0 {
                            Pose::zeros()
                        } else {
                            Pose::new(*d, 0.0, 0.0)
                        }
                    })
                    .collect(),
                imu_yaw_rate: vec![0.0; 40],
                start_velocity: None,
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
}
