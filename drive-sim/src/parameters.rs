//! A twin's fitted parameters, each with the range its fit searched and whether it ended at
//! a bound of that range: what the data did not pin down (`drive sim-fit` reports them).

use crate::Terrain;
use serde::Serialize;

/// One fitted parameter of a twin.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FittedParameter {
    /// Its name as the twin's TOML file has it (`traction`, `powertrain.dead_time`, ...),
    /// or, for a summary of a table of the file, the table's name and what is summarised
    /// (`sensors.icp_gaps.mean_s`).
    pub name: String,
    /// The fitted value.
    pub value: f64,
    /// The lower bound of the range the fit searched (or, where its search is wider than
    /// what it can give, of the values it can give); `None` when there is none, or when it
    /// is the quantity's own zero (a noise, a dead time, a variability of zero means "none",
    /// not "the fit wanted less").
    pub min: Option<f64>,
    /// The upper bound of that range; `None` when there is none.
    pub max: Option<f64>,
    /// The value sits at one of the bounds (within 0.1%): the fit would have gone further,
    /// so the data does not pin it down, or the simulator cannot express what it shows.
    pub at_bound: bool,
}

impl FittedParameter {
    fn new(name: &str, value: f64, min: Option<f64>, max: Option<f64>) -> Self {
        let at_min = min.is_some_and(|lo| {
            if lo > 0.0 {
                value <= lo * 1.001
            } else {
                value <= lo + 1e-3 * lo.abs().max(1e-9)
            }
        });
        let at_max = max.is_some_and(|hi| {
            if hi > 0.0 {
                value >= hi * 0.999
            } else {
                value >= hi - 1e-3 * hi.abs().max(1e-9)
            }
        });
        FittedParameter {
            name: name.to_string(),
            value,
            min,
            max,
            at_bound: at_min || at_max,
        }
    }
}

/// The ground's ranges in the fit (its parameters are searched in log space, then clamped).
pub(crate) const TRACTION_RANGE: (f64, f64) = (1e-3, 5.0);
/// The range of the slip moduli.
pub(crate) const SLIP_MODULUS_RANGE: (f64, f64) = (1e-3, 10.0);
/// The largest rolling resistance.
pub(crate) const MAX_ROLLING: f64 = 0.9;
/// The contact spreads (shares of the baseline, [`Terrain::contact_spread`]) a twin's fit
/// tries when the vehicle's own (0.9 for wheels, 1.1 for tracks) gives a twin that fails its
/// check (`drive_studies::fit_twin`): shorter and longer levers of the turning resistance.
pub const CONTACT_SPREAD_CHOICES: [f64; 3] = [0.6, 0.75, 1.2];
/// The largest dead time (s).
pub(crate) const MAX_DEAD_TIME_S: f64 = 2.0;
/// The right side's gain range.
pub(crate) const RIGHT_GAIN_RANGE: (f64, f64) = (0.5, 2.0);
/// The largest log standard deviation of a grip process.
pub(crate) const MAX_VARIABILITY: f64 = 3.0;
/// The localization mount's range: offsets (m) and yaw (rad).
pub(crate) const MOUNT_RANGE: (f64, f64) = (10.0, 1.0);
/// The widest jitter of the localization's timestamps (s).
pub(crate) const MAX_ICP_JITTER_S: f64 = 1.0;
/// The slowest localization rate (Hz).
pub(crate) const MIN_ICP_RATE_HZ: f64 = 0.5;
/// The correlation time's search, in windows: from 1/50 of a window to 50 windows.
pub(crate) const CORRELATION_WINDOWS: f64 = 50.0;
/// The correlations of an interval's two steady windows the correlation time is inverted
/// from: a measured one beyond them is taken at them (its correlation time then at a bound
/// of its range, [`correlation_time_for`] of these).
pub(crate) const CORRELATION_RANGE: (f64, f64) = (0.05, 0.95);

/// The correlation of the means of two adjacent windows of length `t` of a stationary
/// first-order Gauss-Markov process of correlation time `tau`.
pub(crate) fn adjacent_window_correlation(t: f64, tau: f64) -> f64 {
    let x = t / tau;
    (1.0 - (-x).exp()).powi(2) / (2.0 * (x - 1.0 + (-x).exp()))
}

/// The correlation time whose adjacent windows of length `window` (s) correlate by `rho`
/// ([`adjacent_window_correlation`] inverted by bisection within [`CORRELATION_WINDOWS`]).
pub(crate) fn correlation_time_for(window: f64, rho: f64) -> f64 {
    let (mut lo, mut hi) = (window / CORRELATION_WINDOWS, window * CORRELATION_WINDOWS);
    for _ in 0..60 {
        let mid = (lo * hi).sqrt();
        // The correlation grows with the correlation time.
        if adjacent_window_correlation(window, mid) < rho {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (lo * hi).sqrt()
}

/// Every fitted parameter of the twin `t` (as `drive sim-fit` writes it) with its range;
/// `window_s` is the data's window length (s), which the correlation time's range follows.
///
/// ```
/// let twin = drive_sim::Terrain::from_toml("twin.toml",
///     &std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/husky_twin.toml")).unwrap()).unwrap();
/// let p = drive_sim::fitted_parameters(&twin, 2.0);
/// let traction = p.iter().find(|p| p.name == "traction").unwrap();
/// assert_eq!((traction.min, traction.max, traction.at_bound), (Some(1e-3), Some(5.0), false));
/// assert!(p.iter().any(|p| p.name == "powertrain.dead_time"));
/// ```
pub fn fitted_parameters(t: &Terrain, window_s: f64) -> Vec<FittedParameter> {
    fitted_parameters_within(t, window_s, None)
}

/// [`fitted_parameters`], the grip processes' variability searched only up to `limits`
/// (traction, lateral, rolling; [`crate::SimFitReport::variability_limits`]) where given:
/// a process at its limit is at a bound.
///
/// ```
/// let twin = drive_sim::Terrain::from_toml("twin.toml",
///     &std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/husky_twin.toml")).unwrap()).unwrap();
/// let rolling = twin.variability.unwrap().rolling;
/// let p = drive_sim::fitted_parameters_within(&twin, 2.0, Some([3.0, 3.0, rolling]));
/// let r = p.iter().find(|p| p.name == "variability.rolling").unwrap();
/// assert!(r.at_bound && r.max == Some(rolling));
/// ```
pub fn fitted_parameters_within(
    t: &Terrain,
    window_s: f64,
    limits: Option<[f64; 3]>,
) -> Vec<FittedParameter> {
    let mut out = Vec::new();
    let mut push = |name: &str, value: f64, min: Option<f64>, max: Option<f64>| {
        out.push(FittedParameter::new(name, value, min, max))
    };
    let (lo, hi) = TRACTION_RANGE;
    push("traction", t.traction, Some(lo), Some(hi));
    push("lateral", t.lateral, Some(lo), Some(hi));
    let (lo, hi) = SLIP_MODULUS_RANGE;
    push("slip_modulus", t.slip_modulus, Some(lo), Some(hi));
    if let Some(k) = t.lateral_slip_modulus {
        push("lateral_slip_modulus", k, Some(lo), Some(hi));
    }
    push("rolling", t.rolling, None, Some(MAX_ROLLING));
    if let Some(s) = t.contact_spread {
        // Chosen among CONTACT_SPREAD_CHOICES and the vehicle's own: at a bound at the
        // shortest or longest tried.
        let tried = CONTACT_SPREAD_CHOICES.iter().copied();
        let lo = tried.clone().fold(f64::INFINITY, f64::min);
        let hi = tried.fold(f64::NEG_INFINITY, f64::max);
        push("contact_spread", s, Some(lo), Some(hi));
    }
    if let Some(c) = &t.controller {
        push("controller.linear_gain", c.linear_gain, None, None);
        push("controller.angular_gain", c.angular_gain, None, None);
        for (name, v) in [
            ("controller.max_linear", c.max_linear),
            ("controller.max_angular", c.max_angular),
            (
                "controller.max_linear_acceleration",
                c.max_linear_acceleration,
            ),
            (
                "controller.max_angular_acceleration",
                c.max_angular_acceleration,
            ),
        ] {
            if let Some(v) = v {
                push(name, v, None, None);
            }
        }
    }
    if let Some(p) = &t.powertrain {
        push(
            "powertrain.time_constant.rising",
            p.time_constant[0],
            None,
            None,
        );
        push(
            "powertrain.time_constant.falling",
            p.time_constant[1],
            None,
            None,
        );
        push(
            "powertrain.dead_time",
            p.dead_time,
            None,
            Some(MAX_DEAD_TIME_S),
        );
        let (lo, hi) = RIGHT_GAIN_RANGE;
        push("powertrain.right_gain", p.right_gain, Some(lo), Some(hi));
        push("powertrain.wheel_limit", p.wheel_limit, None, None);
    }
    if let Some(s) = &t.sensors {
        push(
            "sensors.icp_rate_hz",
            s.icp_rate_hz,
            Some(MIN_ICP_RATE_HZ),
            None,
        );
        if let Some((mean, long)) = s.gap_summary() {
            push("sensors.icp_gaps.mean_s", mean, None, None);
            push("sensors.icp_gaps.share_from_half_s", long, None, None);
        }
        push("sensors.icp_noise.position", s.icp_noise[0], None, None);
        push("sensors.icp_noise.yaw", s.icp_noise[1], None, None);
        push(
            "sensors.icp_jitter",
            s.icp_jitter,
            None,
            Some(MAX_ICP_JITTER_S),
        );
        let (offset, yaw) = MOUNT_RANGE;
        push(
            "sensors.icp_mount.forward",
            s.icp_mount[0],
            Some(-offset),
            Some(offset),
        );
        push(
            "sensors.icp_mount.yaw",
            s.icp_mount[2],
            Some(-yaw),
            Some(yaw),
        );
        push("sensors.encoder_noise", s.encoder_noise, None, None);
        push("sensors.imu_noise", s.imu_noise, None, None);
        push("sensors.imu_bias", s.imu_bias, None, None);
    }
    if let Some(v) = &t.variability {
        for (j, (name, sd)) in [
            ("variability.traction", v.traction),
            ("variability.lateral", v.lateral),
            ("variability.rolling", v.rolling),
        ]
        .into_iter()
        .enumerate()
        {
            let limit = limits.map_or(MAX_VARIABILITY, |l| l[j].min(MAX_VARIABILITY));
            // A process searched no further than zero is none, not at a bound.
            push(name, sd, None, (limit > 0.0).then_some(limit));
        }
        // What the fit can give: the correlation time of the least and the most correlated
        // windows it inverts.
        let (least, most) = CORRELATION_RANGE;
        push(
            "variability.correlation_time",
            v.correlation_time,
            Some(correlation_time_for(window_s, least)),
            Some(correlation_time_for(window_s, most)),
        );
    }
    if let Some(s) = &t.turn_stall {
        // A share of counted commands: no range of a search.
        push("turn_stall.probability", s.probability, None, None);
        // Clamped at zero: stalled wheels that turned against their command.
        push("turn_stall.share", s.share, Some(0.0), None);
    }
    if let Some(p) = &t.protocol {
        push("protocol.baseline", p.baseline, None, None);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_are_flagged_within_a_thousandth() {
        let p = FittedParameter::new("x", 4.999, Some(1e-3), Some(5.0));
        assert!(p.at_bound);
        let p = FittedParameter::new("x", 4.9, Some(1e-3), Some(5.0));
        assert!(!p.at_bound);
        let p = FittedParameter::new("x", 1.0005e-3, Some(1e-3), Some(5.0));
        assert!(p.at_bound);
        let p = FittedParameter::new("mount", -10.0, Some(-10.0), Some(10.0));
        assert!(p.at_bound);
        let p = FittedParameter::new("mount", -9.0, Some(-10.0), Some(10.0));
        assert!(!p.at_bound);
        let p = FittedParameter::new("noise", 0.0, None, None);
        assert!(!p.at_bound);
    }

    #[test]
    fn a_twin_at_its_caps_says_so() {
        let mut t = Terrain::preset("gravel").unwrap();
        t.traction = 5.0;
        t.variability = Some(crate::Variability {
            traction: 0.0,
            lateral: 0.2,
            rolling: 3.0,
            correlation_time: 1.0,
        });
        let p = fitted_parameters(&t, 2.0);
        let bound: Vec<&str> = p
            .iter()
            .filter(|p| p.at_bound)
            .map(|p| p.name.as_str())
            .collect();
        assert_eq!(bound, ["traction", "variability.rolling"]);
    }

    #[test]
    fn a_contact_spread_is_listed_at_a_bound_at_the_shortest_or_longest_tried() {
        let spread = |s: Option<f64>| {
            let t = Terrain {
                contact_spread: s,
                ..Terrain::preset("gravel").unwrap()
            };
            fitted_parameters(&t, 2.0)
                .into_iter()
                .find(|p| p.name == "contact_spread")
                .map(|p| (p.min, p.max, p.at_bound))
        };
        assert_eq!(spread(None), None);
        assert_eq!(spread(Some(0.6)), Some((Some(0.6), Some(1.2), true)));
        assert_eq!(spread(Some(0.75)), Some((Some(0.6), Some(1.2), false)));
        assert_eq!(spread(Some(1.2)), Some((Some(0.6), Some(1.2), true)));
        // In a twin file: read back, and refused outside the simulator's range, named.
        let text =
            "name = 'g'\ntraction = 0.5\nslip_modulus = 0.1\nlateral = 0.4\nrolling = 0.02\n";
        let t = Terrain::from_toml("g.toml", &format!("{text}contact_spread = 0.75\n")).unwrap();
        assert_eq!(t.contact_spread, Some(0.75));
        assert_eq!(Terrain::from_toml("g.toml", &t.to_toml()).unwrap(), t);
        for bad in ["0.05", "3.5", "nan", "-1"] {
            let err = Terrain::from_toml("g.toml", &format!("{text}contact_spread = {bad}\n"))
                .unwrap_err()
                .to_string();
            assert!(
                err.contains("contact_spread") && err.contains("[0.1, 3]"),
                "{bad}: {err}"
            );
        }
    }

    #[test]
    fn a_correlation_time_the_fit_cannot_go_below_is_at_a_bound() {
        // Windows of 2 s correlating by the fit's least correlation (0.05): 0.18 s.
        let least = correlation_time_for(2.0, CORRELATION_RANGE.0);
        assert!((adjacent_window_correlation(2.0, least) - 0.05).abs() < 1e-9);
        assert!((least - 0.1818).abs() < 1e-3, "{least}");
        let mut t = Terrain::preset("gravel").unwrap();
        let at = |t: &Terrain| {
            fitted_parameters(t, 2.0)
                .into_iter()
                .find(|p| p.name == "variability.correlation_time")
                .unwrap()
                .at_bound
        };
        for (tau, bound) in [(least, true), (1.0, false), (1e3, true)] {
            t.variability = Some(crate::Variability {
                traction: 0.1,
                lateral: 0.0,
                rolling: 0.0,
                correlation_time: tau,
            });
            assert_eq!(at(&t), bound, "{tau}");
        }
    }
}
