//! An omnidirectional (mecanum or omni-wheel) base commanded in body velocity: three inputs.

use crate::InvalidPart;
use crate::{BodyVelocity, CommandModel, Input, InputAxis, InputSpace, Probe, ProbeResult, Tagged};
use serde::{Deserialize, Serialize};

/// An omnidirectional base (mecanum wheels, as a Clearpath Ridgeback; omni wheels) commanded
/// in body velocity, as its `cmd_vel` interface is: three inputs, the forward speed `v_x`
/// (m/s), the lateral speed `v_y` (m/s, to the left) and the yaw rate `w` (rad/s); the
/// commanded body velocity is the input itself, `f(u) = u` (eq. 2), and every body
/// velocity has an input.
///
/// The geometry is the wheels' half wheelbase `l_x` and half track `l_y` (m): a mecanum
/// wheel's speed is `(v_x -+ v_y -+ (l_x + l_y) w) / r`, so a yaw rate costs `l_x + l_y`
/// times as much wheel speed as a translation, which sets the nominal input space
/// (`|v_x|, |v_y| <= top speed`, `|w| <= top speed / (l_x + l_y)`).
///
/// ```
/// use drive_traits::vehicles::Omnidirectional;
/// use drive_traits::{BodyVelocity, CommandModel, Input};
/// let base = Omnidirectional::new(0.319, 0.2775);
/// let u = Input::new(0.5, -0.2, 0.3);
/// assert_eq!(base.body_velocity(&u), BodyVelocity::new(0.5, -0.2, 0.3));
/// assert_eq!(base.input_for(&BodyVelocity::new(0.5, -0.2, 0.3)), Some(u));
/// assert_eq!(base.input_dim(), 3);
/// let j = base.nominal_input_space(1.1).unwrap();
/// assert_eq!(j.dim(), 3);
/// assert!((j.max.z - 1.1 / (0.319 + 0.2775)).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Omnidirectional {
    /// Half the distance between the front and rear axles, `l_x` (m).
    pub half_wheelbase: f64,
    /// Half the distance between the left and right wheels, `l_y` (m).
    pub half_track: f64,
}

impl Tagged for Omnidirectional {
    const TAG: &'static str = "omnidirectional";
}

impl Omnidirectional {
    /// A base with wheels at `(+-l_x, +-l_y)` from its centre.
    pub fn new(half_wheelbase: f64, half_track: f64) -> Self {
        Omnidirectional {
            half_wheelbase,
            half_track,
        }
    }

    /// The lever arm `l_x + l_y` (m) that converts a yaw rate into wheel speed.
    fn lever(&self) -> f64 {
        self.half_wheelbase + self.half_track
    }
}

/// The axes of an omnidirectional base: its body velocity command.
const AXES: [InputAxis; 3] = [
    InputAxis {
        name: "v_x",
        unit: "m/s",
        command_column: "cmd_vx",
        measured_column: "meas_vx",
    },
    InputAxis {
        name: "v_y",
        unit: "m/s",
        command_column: "cmd_vy",
        measured_column: "meas_vy",
    },
    InputAxis {
        name: "w",
        unit: "rad/s",
        command_column: "cmd_w",
        measured_column: "meas_w",
    },
];

#[typetag::serde(name = "omnidirectional")]
impl CommandModel for Omnidirectional {
    #[inline]
    fn body_velocity(&self, u: &Input) -> BodyVelocity {
        *u
    }

    #[inline]
    fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
        v.iter().all(|c| c.is_finite()).then_some(*v)
    }

    fn axes(&self) -> Vec<InputAxis> {
        AXES.to_vec()
    }

    fn input_dim(&self) -> usize {
        3
    }

    /// `|v_x|, |v_y| <= top_speed`, `|w| <= top_speed / (l_x + l_y)`.
    fn nominal_input_space(&self, top_speed: f64) -> Option<InputSpace> {
        let w = top_speed / self.lever();
        InputSpace::new(
            Input::new(-top_speed, -top_speed, -w),
            Input::new(top_speed, top_speed, w),
        )
    }

    /// Forward, backward, left, right at twice the top speed, then turning left and right
    /// at twice the nominal yaw rate: each axis driven both ways beyond its limits, as the
    /// paper's step 1 drives a skid-steer's wheels.
    fn probe(&self, index: usize, top_speed: f64, done: &[ProbeResult]) -> Option<Probe> {
        let _ = done;
        let (v, w) = (2.0 * top_speed, 2.0 * top_speed / self.lever());
        let (name, command) = match index {
            0 => ("forward", Input::new(v, 0.0, 0.0)),
            1 => ("backward", Input::new(-v, 0.0, 0.0)),
            2 => ("left", Input::new(0.0, v, 0.0)),
            3 => ("right", Input::new(0.0, -v, 0.0)),
            4 => ("turn left", Input::new(0.0, 0.0, w)),
            5 => ("turn right", Input::new(0.0, 0.0, -w)),
            _ => return None,
        };
        Some(Probe {
            name,
            command,
            needs_localization: false,
        })
    }

    fn check(&self) -> Result<(), InvalidPart> {
        super::positive_lengths(&self.geometry())
    }

    fn geometry(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("half_wheelbase", self.half_wheelbase),
            ("half_track", self.half_track),
        ]
    }

    fn steering(&self) -> crate::Steering {
        crate::Steering::Holonomic
    }

    fn clone_box(&self) -> Box<dyn CommandModel> {
        Box::new(self.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_probes_drive_every_axis_both_ways_and_span_the_measured_box() {
        let base = Omnidirectional::new(0.3, 0.25);
        let probes: Vec<Probe> = (0..).map_while(|i| base.probe(i, 1.0, &[])).collect();
        assert_eq!(probes.len(), 6);
        for axis in 0..3 {
            assert!(probes.iter().any(|p| p.command[axis] > 0.0));
            assert!(probes.iter().any(|p| p.command[axis] < 0.0));
        }
        // The base reaches half of each command.
        let results: Vec<ProbeResult> = probes
            .into_iter()
            .map(|probe| ProbeResult {
                measured: probe.command * 0.5,
                probe,
                motion: None,
            })
            .collect();
        let j = base.characterize(&results).unwrap().space;
        assert_eq!(j.max, Input::new(1.0, 1.0, 1.0 / 0.55));
        assert_eq!(j.min, -j.max);
    }

    #[test]
    fn the_geometry_is_checked() {
        assert!(Omnidirectional::new(0.3, 0.25).check().is_ok());
        assert!(Omnidirectional::new(0.0, 0.25)
            .check()
            .unwrap_err()
            .contains("half_wheelbase"));
        assert!(Omnidirectional::new(0.3, f64::NAN).check().is_err());
    }
}
