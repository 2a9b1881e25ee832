//! The other samplers: a grid over J, and the two human-like protocols the paper compares
//! DRIVE against (Sec. IV-B).

use crate::{BodyLimits, SamplerError};
use drive_traits::{BodyVelocity, CommandModel, Input, InputSampler, InputSpace};
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use std::sync::Arc;

/// A regular `n x n` grid over J, visited in a seeded random order, reshuffled at every
/// pass.
///
/// ```
/// use drive_samplers::GridSampler;
/// use drive_traits::{Input, InputSampler, InputSpace};
/// let j = InputSpace::new(Input::new(-1.0, -1.0), Input::new(1.0, 1.0)).unwrap();
/// let mut g = GridSampler::new(j, 3, 1).unwrap();
/// let mut seen: Vec<Input> = (0..9).map(|_| g.next_input()).collect();
/// seen.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
/// assert_eq!(seen[0], Input::new(-1.0, -1.0));
/// assert_eq!(seen[4], Input::new(0.0, 0.0));
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
        let points = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .map(|(i, j)| Input::new(at(i, 0), at(j, 1)))
            .collect();
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
}

impl BodyToInput {
    fn input(&self, v: BodyVelocity) -> Input {
        let v = match &self.limits {
            Some(l) => {
                let x = v.x.clamp(-l.max_linear, l.max_linear);
                BodyVelocity::new(x, v.y, l.turn_within(x, v.z))
            }
            None => v,
        };
        // A differential drive inverts any (v_x, 0, w); a vehicle that cannot command `v`
        // gets the centre of J (never reached by the samplers below).
        let u = self
            .vehicle
            .input_for(&v)
            .unwrap_or((self.space.min + self.space.max) * 0.5);
        self.space.clamp(&u)
    }

    /// Top forward speed (all inputs at their maximum, within the controller's linear
    /// limit) and top yaw rate (first input at its minimum, second at its maximum: turning
    /// in place for a skid-steer) inside J.
    fn reach(&self) -> (f64, f64) {
        let fwd = self
            .vehicle
            .body_velocity(&self.space.max)
            .x
            .abs()
            .min(self.limits.as_ref().map_or(f64::INFINITY, |l| l.max_linear));
        let turn = self
            .vehicle
            .body_velocity(&Input::new(self.space.min.x, self.space.max.y))
            .z
            .abs();
        (fwd, turn)
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
            map: BodyToInput {
                vehicle,
                space,
                limits: None,
            },
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
        }
    }

    /// The same sampler within the controller's body limits (speed clamped, yaw rate
    /// limited at that speed), when there are some.
    pub fn with_body_limits(mut self, limits: Option<BodyLimits>) -> Self {
        self.map.limits = limits;
        self
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
            map: BodyToInput {
                vehicle,
                space,
                limits: None,
            },
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
        }
    }

    /// The same sampler within the controller's body limits (speed clamped, yaw rate
    /// limited at that speed), when there are some.
    pub fn with_body_limits(mut self, limits: Option<BodyLimits>) -> Self {
        self.map.limits = limits;
        self
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
