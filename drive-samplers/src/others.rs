//! The other samplers: a grid over J, and the two human-like protocols the paper compares
//! DRIVE against (Sec. IV-B).

use crate::{BodyLimits, SamplerError};
use drive_traits::{BodyVelocity, CommandModel, Input, InputSampler, InputSpace, Reach};
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use std::sync::Arc;

/// A regular grid of `n` points per axis over J (`n x n`, or `n x n x n` for a vehicle of
/// three inputs), visited in a seeded random order, reshuffled at every pass.
///
/// ```
/// use drive_samplers::GridSampler;
/// use drive_traits::{Input, InputSampler, InputSpace};
/// let j = InputSpace::new(Input::new(-1.0, -1.0, 0.0), Input::new(1.0, 1.0, 0.0)).unwrap();
/// let mut g = GridSampler::new(j, 3, 1).unwrap();
/// let mut seen: Vec<Input> = (0..9).map(|_| g.next_input()).collect();
/// seen.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
/// assert_eq!(seen[0], Input::new(-1.0, -1.0, 0.0));
/// assert_eq!(seen[4], Input::new(0.0, 0.0, 0.0));
/// ```
#[derive(Debug, Clone)]
pub struct GridSampler {
    points: Vec<Input>,
    next: usize,
    rng: Xoshiro256PlusPlus,
}

impl GridSampler {
    /// A grid of `n` points per axis (n >= 2) over `space`.
    pub fn new(space: InputSpace, n: usize, seed: u64) -> Result<Self, SamplerError> {
        if n < 2 {
            return Err(SamplerError::InvalidParameter {
                name: "grid points per axis",
                value: n as f64,
                expected: "at least 2",
            });
        }
        let at = |i: usize, axis: usize| {
            space.min[axis] + (space.max[axis] - space.min[axis]) * i as f64 / (n - 1) as f64
        };
        let points = if space.dim() == 2 {
            (0..n)
                .flat_map(|i| (0..n).map(move |j| (i, j)))
                .map(|(i, j)| Input::new(at(i, 0), at(j, 1), 0.0))
                .collect()
        } else {
            (0..n)
                .flat_map(|i| (0..n).flat_map(move |j| (0..n).map(move |k| (i, j, k))))
                .map(|(i, j, k)| Input::new(at(i, 0), at(j, 1), at(k, 2)))
                .collect()
        };
        let mut g = GridSampler {
            points,
            next: 0,
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
        };
        g.shuffle();
        Ok(g)
    }

    fn shuffle(&mut self) {
        for i in (1..self.points.len()).rev() {
            let j = self.rng.random_range(0..=i);
            self.points.swap(i, j);
        }
    }
}

impl InputSampler for GridSampler {
    fn next_input(&mut self) -> Input {
        if self.next == self.points.len() {
            self.shuffle();
            self.next = 0;
        }
        self.next += 1;
        self.points[self.next - 1]
    }
}

/// Body commands, within the controller's limits, converted to inputs and clamped into J.
#[derive(Debug)]
struct BodyToInput {
    vehicle: Arc<dyn CommandModel>,
    space: InputSpace,
    limits: Option<BodyLimits>,
    /// What the vehicle reaches inside J, asked once.
    reach: Reach,
}

impl BodyToInput {
    fn new(space: InputSpace, vehicle: Arc<dyn CommandModel>) -> Self {
        BodyToInput {
            reach: vehicle.reach(&space),
            vehicle,
            space,
            limits: None,
        }
    }

    fn input(&self, v: BodyVelocity) -> Input {
        let v = match &self.limits {
            Some(l) => {
                let x = v.x.clamp(-l.max_linear, l.max_linear);
                BodyVelocity::new(x, v.y, l.turn_within(x, v.z))
            }
            None => v,
        };
        // The input of the forward speed and yaw rate (a Twist): exact for a differential
        // drive, solved for a vehicle whose lateral velocity follows from them. A vehicle
        // with no input for them is refused when the sampler is made (`BodyToInput::new`),
        // so this fallback (the centre of J) is never reached.
        let u = self
            .vehicle
            .input_for_twist(v.x, v.z)
            .unwrap_or((self.space.min + self.space.max) * 0.5);
        self.space.clamp(&u)
    }

    /// `Err` when the vehicle has no input for the body velocities the sampler draws:
    /// `draws`, each a (forward speed, yaw rate) as fractions of [`BodyToInput::reach`],
    /// the corners of what the sampler draws. Instead of a schedule of inputs that never
    /// move the robot.
    fn check(&self, sampler: &'static str, draws: &[(f64, f64)]) -> Result<(), SamplerError> {
        let (v, w) = self.reach();
        let vehicle = || {
            drive_traits::vehicle_tag(self.vehicle.as_ref())
                .unwrap_or_else(|| format!("{:?}", self.vehicle))
        };
        // A sampler whose draws turn needs a yaw rate to draw from, and every sampler a
        // forward speed: never a schedule that silently drives straight or stands still.
        let turns = draws.iter().any(|&(_, fw)| fw != 0.0);
        for (needed, reached, what) in [(true, v, "forward speed"), (turns, w, "yaw rate")] {
            if needed && (reached.is_nan() || reached <= 1e-9) {
                return Err(SamplerError::NoReach {
                    sampler,
                    vehicle: vehicle(),
                    what,
                    reach: Box::new(self.reach),
                });
            }
        }
        for &(fv, fw) in draws {
            let (linear, angular) = (fv * v, fw * w);
            if self.vehicle.input_for_twist(linear, angular).is_none() {
                return Err(SamplerError::NoInputForTwist {
                    sampler,
                    vehicle: vehicle(),
                    linear,
                    angular,
                });
            }
        }
        Ok(())
    }

    /// Top forward speed (within the controller's linear limit) and top yaw rate either
    /// way inside J, as the vehicle reaches them ([`CommandModel::reach`]).
    fn reach(&self) -> (f64, f64) {
        let fwd = self
            .reach
            .top_speed()
            .min(self.limits.as_ref().map_or(f64::INFINITY, |l| l.max_linear));
        (fwd, self.reach.top_yaw_rate())
    }
}

/// A human-like, linear-focused protocol (after the manual driving guidelines of Williams
/// et al.): mostly forward driving at 30-100% of the top speed, reversing one time in ten,
/// with small turns (yaw rate within 15% of the turning-in-place rate). This is this
/// project's operationalization; the paper describes the protocol only in words.
#[derive(Debug)]
pub struct LinearSampler {
    map: BodyToInput,
    rng: Xoshiro256PlusPlus,
}

impl LinearSampler {
    /// Over J = `space` for `vehicle`, seeded.
    pub fn new(space: InputSpace, vehicle: Arc<dyn CommandModel>, seed: u64) -> Self {
        LinearSampler {
            map: BodyToInput::new(space, vehicle),
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
        }
    }

    /// The same sampler within the controller's body limits (speed clamped, yaw rate
    /// limited at that speed), when there are some.
    pub fn with_body_limits(mut self, limits: Option<BodyLimits>) -> Self {
        self.map.limits = limits;
        self
    }

    /// `Err` when the vehicle has no input for the body velocities this sampler draws (the
    /// registry's sampler is checked so when it is made).
    pub fn check(&self) -> Result<(), SamplerError> {
        // The corners of what `next_input` draws.
        let draws = [1.0, 0.3, -0.1, -0.5]
            .into_iter()
            .flat_map(|v| [(v, 0.0), (v, 0.15), (v, -0.15)]);
        self.map.check("linear", &draws.collect::<Vec<_>>())
    }
}

impl InputSampler for LinearSampler {
    fn next_input(&mut self) -> Input {
        let (v_max, w_max) = self.map.reach();
        let forward = self.rng.random::<f64>() < 0.9;
        let speed = if forward {
            self.rng.random_range(0.3..=1.0) * v_max
        } else {
            -self.rng.random_range(0.1..=0.5) * v_max
        };
        let w = self.rng.random_range(-0.15..=0.15) * w_max;
        self.map.input(BodyVelocity::new(speed, 0.0, w))
    }
}

/// An angular-focused protocol (after Wang et al.): a steady forward speed (half the top
/// speed) with a varying commanded curvature, the yaw rate drawn uniformly over what J
/// allows at that speed.
#[derive(Debug)]
pub struct AngularSampler {
    map: BodyToInput,
    rng: Xoshiro256PlusPlus,
}

impl AngularSampler {
    /// Over J = `space` for `vehicle`, seeded.
    pub fn new(space: InputSpace, vehicle: Arc<dyn CommandModel>, seed: u64) -> Self {
        AngularSampler {
            map: BodyToInput::new(space, vehicle),
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
        }
    }

    /// The same sampler within the controller's body limits (speed clamped, yaw rate
    /// limited at that speed), when there are some.
    pub fn with_body_limits(mut self, limits: Option<BodyLimits>) -> Self {
        self.map.limits = limits;
        self
    }

    /// `Err` when the vehicle has no input for the body velocities this sampler draws (the
    /// registry's sampler is checked so when it is made).
    pub fn check(&self) -> Result<(), SamplerError> {
        // The corners of what `next_input` draws.
        self.map
            .check("angular", &[(0.5, 0.0), (0.5, 0.5), (0.5, -0.5)])
    }
}

impl InputSampler for AngularSampler {
    fn next_input(&mut self) -> Input {
        let (v_max, w_max) = self.map.reach();
        let speed = 0.5 * v_max;
        // At half speed, half of the wheel headroom is left for turning.
        let w = self.rng.random_range(-0.5..=0.5) * w_max;
        self.map.input(BodyVelocity::new(speed, 0.0, w))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{builtin_robots, schedule, RobotSpec};
    use drive_traits::InputAxis;

    /// A unicycle whose reference point is 0.4 m ahead of its axle: its lateral velocity is
    /// 0.4 times its yaw rate, so `input_for((v, 0, w))` has no input for any turn.
    #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
    struct Offset;

    #[typetag::serde(name = "offset-unicycle-test")]
    impl CommandModel for Offset {
        fn body_velocity(&self, u: &Input) -> BodyVelocity {
            BodyVelocity::new(u.x, 0.4 * u.y, u.y)
        }
        fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
            (v.y == 0.4 * v.z).then(|| Input::new(v.x, v.z, 0.0))
        }
        fn axes(&self) -> Vec<InputAxis> {
            vec![
                InputAxis {
                    name: "v",
                    unit: "m/s",
                    command_column: "cmd_v",
                    measured_column: "meas_v",
                },
                InputAxis {
                    name: "w",
                    unit: "rad/s",
                    command_column: "cmd_w",
                    measured_column: "meas_w",
                },
            ]
        }
        fn clone_box(&self) -> Box<dyn CommandModel> {
            Box::new(Offset)
        }
    }

    /// A vehicle that turns as fast as it drives (its yaw rate is its speed; the second
    /// input does nothing): no input drives it straight.
    #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
    struct Coupled;

    #[typetag::serde(name = "coupled-test")]
    impl CommandModel for Coupled {
        fn body_velocity(&self, u: &Input) -> BodyVelocity {
            BodyVelocity::new(u.x, 0.0, u.x)
        }
        fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
            (v.y == 0.0 && v.z == v.x).then(|| Input::new(v.x, 0.0, 0.0))
        }
        fn axes(&self) -> Vec<InputAxis> {
            Offset.axes()
        }
        fn clone_box(&self) -> Box<dyn CommandModel> {
            Box::new(Coupled)
        }
    }

    fn robot(vehicle: Arc<dyn CommandModel>) -> RobotSpec {
        let mut robot = builtin_robots()
            .get("husky")
            .expect("the husky preset is registered")
            .part()
            .as_ref()
            .clone();
        robot.vehicle = vehicle;
        robot
    }

    #[test]
    fn a_vehicle_whose_lateral_velocity_follows_its_yaw_rate_gets_moving_schedules() {
        let space =
            InputSpace::new(Input::new(-1.0, -1.5, 0.0), Input::new(1.0, 1.5, 0.0)).unwrap();
        let robot = robot(Arc::new(Offset));
        for make in [
            |s, v, seed| Box::new(LinearSampler::new(s, v, seed)) as Box<dyn InputSampler>,
            |s, v, seed| Box::new(AngularSampler::new(s, v, seed)) as Box<dyn InputSampler>,
        ] {
            let mut sampler = make(space, Arc::clone(&robot.vehicle), 3);
            let targets: Vec<Input> = (0..50).map(|_| sampler.next_input()).collect();
            // Every target moves the robot (no all-zero schedule), turns within J, and its
            // forward speed and yaw rate are the ones drawn.
            assert!(targets.iter().all(|u| u.x.abs() > 0.05), "{targets:?}");
            assert!(targets.iter().any(|u| u.y.abs() > 0.01));
            let mut sampler = make(space, Arc::clone(&robot.vehicle), 3);
            let rows = schedule(&robot, sampler.as_mut(), 3);
            // The acceleration ramps are kept: the first command is a small step from rest,
            // not the target.
            assert!(rows[0].command.norm() < 0.5 * rows[0].target.norm());
            assert!(rows.iter().any(|r| r.command.norm() > 0.1));
        }
    }

    #[test]
    fn a_vehicle_with_no_input_for_the_drawn_body_velocities_is_refused_by_name() {
        let space =
            InputSpace::new(Input::new(-1.0, -1.0, 0.0), Input::new(1.0, 1.0, 0.0)).unwrap();
        let sampler = LinearSampler::new(space, Arc::new(Coupled), 0);
        let e = sampler.check().unwrap_err().to_string();
        assert!(
            e.contains("coupled-test") && e.contains("linear sampler"),
            "{e}"
        );
        assert!(e.contains("(1 m/s forward, 0 rad/s yaw rate)"), "{e}");
        assert!(AngularSampler::new(space, Arc::new(Offset), 0)
            .check()
            .is_ok());
    }
}
