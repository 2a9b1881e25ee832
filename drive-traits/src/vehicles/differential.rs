use crate::{
    spanned_space, BodyVelocity, Characterization, CommandModel, Input, InputAxis, InputSpace,
    Probe, ProbeResult, Tagged,
};
use crate::{CharacterizationError, InvalidPart};
use serde::{Deserialize, Serialize};

/// The share of the turn probe's commanded wheel difference its wheels must make for the
/// probe to give an effective baseline.
const MIN_TURN_MADE: f64 = 0.2;

/// The ideal differential drive of a skid-steer robot (paper eq. 4):
/// `f = r [ (w_l + w_r) / 2, 0, (w_r - w_l) / b ]`; inputs are the left and right wheel
/// (or track sprocket) angular velocities.
///
/// ```
/// use drive_traits::vehicles::DifferentialDrive;
/// use drive_traits::{CommandModel, Input};
/// let husky = DifferentialDrive::new(0.165, 0.55);
/// let f = husky.body_velocity(&Input::new(2.0, 4.0, 0.0));
/// assert!((f.x - 0.495).abs() < 1e-12);    // 0.165 * 3
/// assert!(f.y == 0.0);
/// assert!((f.z - 0.6).abs() < 1e-12);      // 0.165 * 2 / 0.55
/// let u = husky.input_for(&f).unwrap();
/// assert!((u - Input::new(2.0, 4.0, 0.0)).norm() < 1e-12);
/// assert_eq!(husky.axes()[0].command_column, "cmd_left");
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DifferentialDrive {
    /// Wheel or sprocket radius r (m).
    pub wheel_radius: f64,
    /// Vehicle width b (m).
    pub baseline: f64,
}

impl Tagged for DifferentialDrive {
    const TAG: &'static str = "differential";
}

impl DifferentialDrive {
    /// A differential drive with radius `r` and width `b`.
    pub fn new(wheel_radius: f64, baseline: f64) -> Self {
        DifferentialDrive {
            wheel_radius,
            baseline,
        }
    }

    /// Eq. 4 without the trait-object indirection.
    #[inline]
    pub fn eq4(&self, u: &Input) -> BodyVelocity {
        let r = self.wheel_radius;
        BodyVelocity::new(r * 0.5 * (u.x + u.y), 0.0, r * (u.y - u.x) / self.baseline)
    }
}

/// The axes of a differential drive, with the window CSV columns of the DRIVE datasets.
const AXES: [InputAxis; 2] = [
    InputAxis {
        name: "left",
        unit: "rad/s",
        command_column: "cmd_left",
        measured_column: "enc_left",
    },
    InputAxis {
        name: "right",
        unit: "rad/s",
        command_column: "cmd_right",
        measured_column: "enc_right",
    },
];

#[typetag::serde(name = "differential")]
impl CommandModel for DifferentialDrive {
    #[inline]
    fn body_velocity(&self, u: &Input) -> BodyVelocity {
        self.eq4(u)
    }

    #[inline]
    fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
        if v.y != 0.0 {
            return None;
        }
        let r = self.wheel_radius;
        let half = 0.5 * v.z * self.baseline;
        Some(Input::new((v.x - half) / r, (v.x + half) / r, 0.0))
    }

    fn axes(&self) -> Vec<InputAxis> {
        AXES.to_vec()
    }

    /// The manufacturer's input space: `+-top_speed / r` on both wheels.
    fn nominal_input_space(&self, top_speed: f64) -> Option<InputSpace> {
        let w = top_speed / self.wheel_radius;
        InputSpace::new(Input::new(-w, -w, 0.0), Input::new(w, w, 0.0))
    }

    /// Forward and backward at twice the top speed (the wheel limits), then, with
    /// localization, a turn in place at half of what the forward probe reached (the
    /// effective baseline).
    fn probe(&self, index: usize, top_speed: f64, done: &[ProbeResult]) -> Option<Probe> {
        let straight = |name, sign: f64| {
            Some(Probe {
                name,
                command: self.input_for(&BodyVelocity::new(sign * 2.0 * top_speed, 0.0, 0.0))?,
                needs_localization: false,
            })
        };
        match index {
            0 => straight("forward", 1.0),
            1 => straight("backward", -1.0),
            2 => {
                let reached = done.first()?.measured;
                let w = 0.5 * reached.x.abs().min(reached.y.abs());
                Some(Probe {
                    name: "turn",
                    command: Input::new(-w, w, 0.0),
                    needs_localization: true,
                })
            }
            _ => None,
        }
    }

    /// The wheel limits from the forward and backward probes; with localization, the
    /// effective wheel radius (distance over wheel angle going forward) and baseline
    /// (`r (w_r - w_l)` over the yaw rate turning in place; none when the wheels made less
    /// than a fifth of the probe's turn, or the robot turned the other way).
    fn characterize(
        &self,
        results: &[ProbeResult],
    ) -> Result<Characterization, CharacterizationError> {
        let straight: Vec<ProbeResult> = results
            .iter()
            .filter(|r| r.probe.name != "turn")
            .cloned()
            .collect();
        let space = spanned_space(self, &straight)?;
        let mut geometry = Vec::new();
        let forward = results.iter().find(|r| r.probe.name == "forward");
        let radius = forward.and_then(|f| {
            let m = f.motion?;
            let angle = 0.5 * (f.measured.x + f.measured.y) * m.duration_s;
            (angle.abs() > 1e-6).then(|| m.distance_m / angle.abs())
        });
        if let Some(r) = radius {
            geometry.push(("wheel_radius".to_string(), r));
        }
        let turn = results.iter().find(|r| r.probe.name == "turn");
        if let (Some(r), Some(t)) = (radius, turn) {
            if let Some(m) = t.motion {
                let yaw_rate = m.yaw_turned / m.duration_s;
                // Only a turn the wheels made tells the geometry: on a ground that holds a
                // turn at its start they may stay together, and the ratio of two rates
                // near zero is noise (of either sign).
                let (asked, made) = (
                    t.probe.command.y - t.probe.command.x,
                    t.measured.y - t.measured.x,
                );
                let turned = made * asked > 0.0 && made.abs() >= MIN_TURN_MADE * asked.abs();
                let baseline = r * made / yaw_rate;
                if m.duration_s > 0.0 && yaw_rate.abs() > 1e-6 && turned && baseline > 0.0 {
                    geometry.push(("baseline".to_string(), baseline));
                }
            }
        }
        Ok(Characterization { space, geometry })
    }

    fn check(&self) -> Result<(), InvalidPart> {
        super::positive_lengths(&self.geometry())
    }

    fn geometry(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("wheel_radius", self.wheel_radius),
            ("baseline", self.baseline),
        ]
    }

    /// The DRIVE logger's encoder columns.
    fn logger_measured_columns(&self) -> Vec<&'static str> {
        vec!["meas_left_vel", "meas_right_vel"]
    }

    fn clone_box(&self) -> Box<dyn CommandModel> {
        Box::new(self.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ProbeMotion;

    fn probes(turn_made: Input, yaw_turned: f64) -> Vec<ProbeResult> {
        let husky = DifferentialDrive::new(0.165, 0.55);
        let forward = ProbeResult {
            probe: husky.probe(0, 1.0, &[]).unwrap(),
            measured: Input::new(6.0, 6.0, 0.0),
            // 1.98 m in 2 s at 6 rad/s: a radius of 0.165 m.
            motion: Some(ProbeMotion {
                duration_s: 2.0,
                distance_m: 1.98,
                yaw_turned: 0.0,
            }),
        };
        let backward = ProbeResult {
            probe: husky.probe(1, 1.0, &[]).unwrap(),
            measured: Input::new(-6.0, -6.0, 0.0),
            motion: None,
        };
        let done = [forward.clone()];
        let turn = ProbeResult {
            probe: husky.probe(2, 1.0, &done).unwrap(),
            measured: turn_made,
            motion: Some(ProbeMotion {
                duration_s: 2.0,
                distance_m: 0.0,
                yaw_turned,
            }),
        };
        vec![forward, backward, turn]
    }

    fn baseline(results: &[ProbeResult]) -> Option<f64> {
        DifferentialDrive::new(0.165, 0.55)
            .characterize(results)
            .unwrap()
            .geometry
            .iter()
            .find(|(name, _)| name == "baseline")
            .map(|g| g.1)
    }

    #[test]
    fn the_turn_probe_gives_a_baseline_only_when_its_wheels_made_the_turn() {
        // The probe asks -3 / +3 rad/s; the wheels make it and the robot turns 0.99 rad/s:
        // b = 0.165 * 6 / 0.99 = 1.0 m.
        let b = baseline(&probes(Input::new(-3.0, 3.0, 0.0), 1.98)).unwrap();
        assert!((b - 1.0).abs() < 1e-12, "{b}");
        // A turn held at its start: the wheels make a twentieth of it, the yaw is noise of
        // either sign. No baseline, where the ratio gave 0.165 * 0.3 / -0.01 = -4.95 m.
        assert_eq!(baseline(&probes(Input::new(-0.15, 0.15, 0.0), -0.02)), None);
        assert_eq!(baseline(&probes(Input::new(-0.15, 0.15, 0.0), 0.02)), None);
        // The wheels turning the other way, or the robot: none either.
        assert_eq!(baseline(&probes(Input::new(3.0, -3.0, 0.0), 1.98)), None);
        assert_eq!(baseline(&probes(Input::new(-3.0, 3.0, 0.0), -1.98)), None);
        // Just over a fifth of the turn is enough.
        let b = baseline(&probes(Input::new(-0.62, 0.62, 0.0), 0.4)).unwrap();
        assert!((b - 0.165 * 1.24 / 0.2).abs() < 1e-12, "{b}");
    }
}
