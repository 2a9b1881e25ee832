use crate::limits::Short;
use crate::{
    spanned_space, BodyVelocity, Characterization, CommandModel, Input, InputAxis, InputSpace,
    Probe, ProbeResult, Steering, Tagged,
};
use crate::{CharacterizationError, InvalidPart};
use serde::{Deserialize, Serialize};

/// The kinematic bicycle of a car-like (Ackermann-steered) robot: inputs are the speed `v`
/// of the rear axle centre (m/s) and the steering angle `delta` of the virtual front wheel
/// (rad); `f = [v, 0, v tan(delta) / L]` with `L` the wheelbase. The body frame is at the
/// rear axle centre (where a rolling car has no lateral velocity; `base_link` of the
/// Autoware convention).
///
/// The paper's future work ("extend DRIVE to other vehicle types"): the same protocol, the
/// same powertrain and slip learners, on a vehicle that cannot turn in place.
///
/// ```
/// use drive_traits::vehicles::Ackermann;
/// use drive_traits::{BodyVelocity, CommandModel, Input};
/// let car = Ackermann::new(0.57, 0.3665);
/// let f = car.body_velocity(&Input::new(2.0, 0.2, 0.0));
/// assert!((f.z - 2.0 * 0.2f64.tan() / 0.57).abs() < 1e-12);
/// assert_eq!((f.x, f.y), (2.0, 0.0));
/// // The inverse: the steering angle of a curvature.
/// let u = car.input_for(&f).unwrap();
/// assert!((u - Input::new(2.0, 0.2, 0.0)).norm() < 1e-12);
/// // A car cannot turn in place, nor slide sideways on command.
/// assert!(car.input_for(&BodyVelocity::new(0.0, 0.0, 1.0)).is_none());
/// assert!(car.input_for(&BodyVelocity::new(1.0, 0.1, 0.0)).is_none());
/// assert_eq!(car.axes()[1].command_column, "cmd_steering");
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ackermann {
    /// Wheelbase L (m): rear axle to front axle.
    pub wheelbase: f64,
    /// The manufacturer's steering limit (rad), both directions: gives the nominal input
    /// space.
    pub max_steering: f64,
}

impl Tagged for Ackermann {
    const TAG: &'static str = "ackermann";
}

impl Ackermann {
    /// A car of wheelbase `wheelbase` (m) steering up to `max_steering` (rad) each way.
    pub fn new(wheelbase: f64, max_steering: f64) -> Self {
        Ackermann {
            wheelbase,
            max_steering,
        }
    }
}

/// The axes of a car: speed and steering angle.
const AXES: [InputAxis; 2] = [
    InputAxis {
        name: "speed",
        unit: "m/s",
        command_column: "cmd_speed",
        measured_column: "meas_speed",
    },
    InputAxis {
        name: "steering",
        unit: "rad",
        command_column: "cmd_steering",
        measured_column: "meas_steering",
    },
];

/// The speed of the steering probes, as a fraction of the top speed: slow enough for a
/// full-lock circle on any ground (1 m/s on a 5 m/s car: 0.7 m/s^2 on a 1.5 m radius).
const STEERING_PROBE_SPEED: f64 = 0.2;

#[typetag::serde(name = "ackermann")]
impl CommandModel for Ackermann {
    #[inline]
    fn body_velocity(&self, u: &Input) -> BodyVelocity {
        BodyVelocity::new(u.x, 0.0, u.x * u.y.tan() / self.wheelbase)
    }

    /// `delta = atan(L w / v)`; at rest, only the body velocity zero (steering straight);
    /// never a lateral velocity.
    #[inline]
    fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
        if v.y != 0.0 {
            return None;
        }
        if v.x == 0.0 {
            return (v.z == 0.0).then(Input::zeros);
        }
        Some(Input::new(v.x, (self.wheelbase * v.z / v.x).atan(), 0.0))
    }

    fn axes(&self) -> Vec<InputAxis> {
        AXES.to_vec()
    }

    /// `+-top_speed` by `+-max_steering`.
    fn nominal_input_space(&self, top_speed: f64) -> Option<InputSpace> {
        InputSpace::new(
            Input::new(-top_speed, -self.max_steering, 0.0),
            Input::new(top_speed, self.max_steering, 0.0),
        )
    }

    /// Forward and backward straight at twice the top speed (the speed range), then left
    /// and right at a fifth of the top speed with twice the steering limit (the steering
    /// range, and, with localization, the effective wheelbase).
    fn probe(&self, index: usize, top_speed: f64, done: &[ProbeResult]) -> Option<Probe> {
        let _ = done;
        let (name, command) = match index {
            0 => ("forward", Input::new(2.0 * top_speed, 0.0, 0.0)),
            1 => ("backward", Input::new(-2.0 * top_speed, 0.0, 0.0)),
            2 => (
                "left",
                Input::new(
                    STEERING_PROBE_SPEED * top_speed,
                    2.0 * self.max_steering,
                    0.0,
                ),
            ),
            3 => (
                "right",
                Input::new(
                    STEERING_PROBE_SPEED * top_speed,
                    -2.0 * self.max_steering,
                    0.0,
                ),
            ),
            _ => return None,
        };
        Some(Probe {
            name,
            command,
            needs_localization: false,
        })
    }

    /// The box the probes reached (speed from the straight probes, steering from the
    /// turning ones); with localization, the effective wheelbase `v tan(delta) / w` of each
    /// turning probe, averaged.
    fn characterize(
        &self,
        results: &[ProbeResult],
    ) -> Result<Characterization, CharacterizationError> {
        let space = spanned_space(self, results)?;
        let wheelbases: Vec<f64> = results
            .iter()
            .filter(|r| matches!(r.probe.name, "left" | "right"))
            .filter_map(|r| {
                let m = r.motion?;
                let yaw_rate = m.yaw_turned / m.duration_s;
                let l = r.measured.x * r.measured.y.tan() / yaw_rate;
                (m.duration_s > 0.0 && yaw_rate.abs() > 1e-6 && l.is_finite() && l > 0.0)
                    .then_some(l)
            })
            .collect();
        let mut geometry = Vec::new();
        if !wheelbases.is_empty() {
            geometry.push((
                "wheelbase".to_string(),
                wheelbases.iter().sum::<f64>() / wheelbases.len() as f64,
            ));
        }
        Ok(Characterization { space, geometry })
    }

    fn check(&self) -> Result<(), InvalidPart> {
        super::positive_lengths(&[("wheelbase", self.wheelbase)])?;
        if !(self.max_steering > 0.0 && self.max_steering < std::f64::consts::FRAC_PI_2) {
            return Err(InvalidPart::from(format!(
                "vehicle max_steering = {} is not an angle in (0, pi/2) rad",
                Short(self.max_steering)
            )));
        }
        Ok(())
    }

    /// A steering range strictly within +-90 degrees (where `tan` is finite).
    fn check_input_space(&self, space: &InputSpace) -> Result<(), InvalidPart> {
        let half_turn = std::f64::consts::FRAC_PI_2;
        if space.min.y <= -half_turn || space.max.y >= half_turn {
            return Err(InvalidPart::from(format!(
                "the steering range [{}, {}] rad reaches +-pi/2, where a car's curvature is infinite",
                Short(space.min.y),
                Short(space.max.y)
            )));
        }
        Ok(())
    }

    fn geometry(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("wheelbase", self.wheelbase),
            ("max_steering", self.max_steering),
        ]
    }

    fn steering(&self) -> Steering {
        Steering::Wheels
    }

    fn clone_box(&self) -> Box<dyn CommandModel> {
        Box::new(self.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ProbeMotion;

    fn result(name: &'static str, command: Input, measured: Input, yaw: f64) -> ProbeResult {
        ProbeResult {
            probe: Probe {
                name,
                command,
                needs_localization: false,
            },
            measured,
            motion: Some(ProbeMotion {
                duration_s: 1.0,
                distance_m: measured.x.abs(),
                yaw_turned: yaw,
            }),
        }
    }

    #[test]
    fn characterization_finds_both_ranges_and_the_wheelbase() {
        let car = Ackermann::new(0.5, 0.4);
        let probes: Vec<Probe> = (0..)
            .map_while(|i| car.probe(i, 5.0, &[]))
            .collect::<Vec<_>>();
        assert_eq!(probes.len(), 4);
        // A car of true wheelbase 0.6 m reaching 4 m/s and +-0.3 rad.
        let yaw = |v: f64, d: f64| v * f64::tan(d) / 0.6;
        let results = [
            result("forward", probes[0].command, Input::new(4.0, 0.0, 0.0), 0.0),
            result(
                "backward",
                probes[1].command,
                Input::new(-4.0, 0.0, 0.0),
                0.0,
            ),
            result(
                "left",
                probes[2].command,
                Input::new(1.0, 0.3, 0.0),
                yaw(1.0, 0.3),
            ),
            result(
                "right",
                probes[3].command,
                Input::new(1.0, -0.3, 0.0),
                yaw(1.0, -0.3),
            ),
        ];
        let c = car.characterize(&results).unwrap();
        assert_eq!(c.space.min, Input::new(-4.0, -0.3, 0.0));
        assert_eq!(c.space.max, Input::new(4.0, 0.3, 0.0));
        assert!((c.geometry("wheelbase").unwrap() - 0.6).abs() < 1e-12);
    }

    #[test]
    fn a_steering_that_does_not_move_is_refused() {
        let car = Ackermann::new(0.5, 0.4);
        let p = |i| car.probe(i, 5.0, &[]).unwrap().command;
        let results = [
            result("forward", p(0), Input::new(4.0, 0.0, 0.0), 0.0),
            result("backward", p(1), Input::new(-4.0, 0.0, 0.0), 0.0),
            result("left", p(2), Input::new(1.0, 0.001, 0.0), 0.0),
            result("right", p(3), Input::new(1.0, -0.001, 0.0), 0.0),
        ];
        let e = car.characterize(&results).unwrap_err();
        assert!(e.contains("'steering' did not move"), "{e}");
    }

    #[test]
    fn geometry_is_checked() {
        assert!(Ackermann::new(0.5, 0.4).check().is_ok());
        assert!(Ackermann::new(-0.5, 0.4).check().is_err());
        assert!(Ackermann::new(0.5, 1.6).check().is_err());
        assert!(Ackermann::new(0.5, f64::NAN).check().is_err());
    }
}
