use drive_traits::robot::BodyLimits;
use drive_traits::{Input, InputSampler, InputSpace, RegistryError};
use rand::rngs::Xoshiro256PlusPlus;
use rand::SeedableRng;
use rand_distr::{Distribution, Uniform};
use thiserror::Error;

/// Why a sampler cannot be built.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SamplerError {
    /// The input space has no extent on some axis.
    #[error("the input space is empty on axis {axis}: [{min}, {max}]")]
    EmptySpace {
        /// 0 or 1 (left or right for a skid-steer)
        axis: usize,
        /// lower bound
        min: f64,
        /// upper bound
        max: f64,
    },
    /// The controller's speed limits exclude (almost) all of the input space.
    #[error("the controller limits (linear {linear} m/s, angular {angular} rad/s, lateral acceleration {lateral} m/s^2) leave less than 0.1% of the input space to sample")]
    LimitsExcludeSpace {
        /// linear limit
        linear: f64,
        /// angular limit
        angular: f64,
        /// lateral acceleration limit
        lateral: f64,
    },
    /// A parameter is out of range.
    #[error("invalid sampler parameter {name} = {value}: {expected}")]
    InvalidParameter {
        /// name
        name: &'static str,
        /// value
        value: f64,
        /// what is expected
        expected: &'static str,
    },
    /// The vehicle has no input for a body velocity the sampler draws (a forward speed and
    /// a yaw rate, see `CommandModel::input_for_twist`).
    #[error("the vehicle {vehicle} has no input for the body velocity ({linear} m/s forward, {angular} rad/s yaw rate) the {sampler} sampler draws: sample its input space instead (uniform, grid)")]
    NoInputForTwist {
        /// The sampler.
        sampler: &'static str,
        /// The vehicle's tag.
        vehicle: String,
        /// Forward speed (m/s).
        linear: f64,
        /// Yaw rate (rad/s).
        angular: f64,
    },
    /// The vehicle reaches no forward speed or no yaw rate inside the input space, and the
    /// sampler draws from it (the angular sampler's turns from the top yaw rate).
    #[error("the {sampler} sampler draws a {what} the vehicle {vehicle} does not reach in its input space (its reach: forward {:.3} m/s, yaw rate {:.3} rad/s left, {:.3} right): sample its input space instead (uniform, grid)", reach.forward.value, reach.left.value, reach.right.value)]
    NoReach {
        /// The sampler.
        sampler: &'static str,
        /// The vehicle's tag.
        vehicle: String,
        /// What is missing (`forward speed`, `yaw rate`).
        what: &'static str,
        /// What the vehicle reaches.
        reach: Box<drive_traits::Reach>,
    },
    /// No sampler of that name.
    #[error(transparent)]
    Registry(#[from] RegistryError),
}

/// The DRIVE calibration distribution `u ~ U2(omega_min, omega_max)`: independent uniform
/// draws over the input-space box J, optionally restricted by the controller's limits.
///
/// ```
/// use drive_samplers::UniformSampler;
/// use drive_traits::{Input, InputSampler, InputSpace};
/// let j = InputSpace::new(Input::new(-6.8, -6.8, 0.0), Input::new(6.8, 6.8, 0.0)).unwrap();
/// let mut a = UniformSampler::new(j, 42).unwrap();
/// let mut b = UniformSampler::new(j, 42).unwrap();
/// let u = a.next_input();
/// assert!(j.contains(&u));
/// assert_eq!(u, b.next_input()); // same seed, same sequence
/// ```
#[derive(Debug)]
pub struct UniformSampler {
    rng: Xoshiro256PlusPlus,
    /// One distribution per axis of the space ([`InputSpace::dim`]).
    axes: Vec<Uniform<f64>>,
    limits: Option<BodyLimits>,
}

impl UniformSampler {
    /// A sampler over `space` seeded with `seed`.
    pub fn new(space: InputSpace, seed: u64) -> Result<Self, SamplerError> {
        let axis = |i: usize| {
            Uniform::new_inclusive(space.min[i], space.max[i])
                .ok()
                .filter(|_| space.max[i] > space.min[i])
                .ok_or(SamplerError::EmptySpace {
                    axis: i,
                    min: space.min[i],
                    max: space.max[i],
                })
        };
        Ok(UniformSampler {
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
            axes: (0..space.dim()).map(axis).collect::<Result<_, _>>()?,
            limits: None,
        })
    }

    /// The same sampler, redrawing samples beyond the controller's body speed limits.
    /// Refused when the limits leave less than 0.1% of J (checked on 10,000 draws of a
    /// separate generator, so the sequence itself does not change).
    pub fn with_body_limits(mut self, limits: BodyLimits) -> Result<Self, SamplerError> {
        let mut probe = Xoshiro256PlusPlus::seed_from_u64(0x5eed);
        let inside = (0..10_000)
            .filter(|_| limits.allows(&draw(&self.axes, &mut probe)))
            .count();
        if inside < 10 {
            return Err(SamplerError::LimitsExcludeSpace {
                linear: limits.max_linear,
                angular: limits.max_angular,
                lateral: limits.max_lateral_acceleration,
            });
        }
        self.limits = Some(limits);
        Ok(self)
    }

    fn draw(&mut self) -> Input {
        draw(&self.axes, &mut self.rng)
    }
}

/// One input drawn axis by axis, in order (the axes beyond them zero).
fn draw(axes: &[Uniform<f64>], rng: &mut Xoshiro256PlusPlus) -> Input {
    let mut u = Input::zeros();
    for (i, axis) in axes.iter().enumerate() {
        u[i] = axis.sample(rng);
    }
    u
}

impl InputSampler for UniformSampler {
    fn next_input(&mut self) -> Input {
        loop {
            let u = self.draw();
            // At least 0.1% of draws are accepted (checked at construction).
            if self.limits.as_ref().is_none_or(|l| l.allows(&u)) {
                return u;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_every_axis_of_a_three_input_space_and_none_beyond_two() {
        let j = InputSpace::new(Input::new(-1.0, -0.5, -2.0), Input::new(1.0, 0.5, 2.0)).unwrap();
        let mut s = UniformSampler::new(j, 3).unwrap();
        let draws: Vec<Input> = (0..2000).map(|_| s.next_input()).collect();
        for axis in 0..3 {
            let mean = draws.iter().map(|u| u[axis]).sum::<f64>() / 2000.0;
            let top = draws.iter().map(|u| u[axis]).fold(f64::MIN, f64::max);
            assert!(mean.abs() < 0.1 * j.max[axis], "axis {axis}: mean {mean}");
            assert!(top > 0.9 * j.max[axis], "axis {axis}: top {top}");
        }
        assert!(draws.iter().all(|u| j.contains(u)));
        // A two-input space: the third axis stays zero.
        let flat = InputSpace::new(Input::new(-1.0, -1.0, 0.0), Input::new(1.0, 1.0, 0.0)).unwrap();
        let mut s = UniformSampler::new(flat, 3).unwrap();
        assert!((0..100).all(|_| s.next_input().z == 0.0));
    }

    #[test]
    fn covers_the_box_uniformly() {
        // Pearson chi-square over a 5 x 5 grid: 24 degrees of freedom, the 0.999 quantile is 51.2.
        let j = InputSpace::new(Input::new(-2.0, 1.0, 0.0), Input::new(4.0, 3.0, 0.0)).unwrap();
        let mut s = UniformSampler::new(j, 7).unwrap();
        let n = 10_000;
        let mut counts = [0usize; 25];
        for _ in 0..n {
            let u = s.next_input();
            assert!(j.contains(&u));
            let bx = (((u.x - j.min.x) / (j.max.x - j.min.x)) * 5.0)
                .floor()
                .min(4.0) as usize;
            let by = (((u.y - j.min.y) / (j.max.y - j.min.y)) * 5.0)
                .floor()
                .min(4.0) as usize;
            counts[bx * 5 + by] += 1;
        }
        let expected = n as f64 / 25.0;
        let chi2: f64 = counts
            .iter()
            .map(|c| (*c as f64 - expected).powi(2) / expected)
            .sum();
        assert!(chi2 < 51.2, "chi2 = {chi2}");
    }

    #[test]
    fn empty_space_is_refused() {
        let j = InputSpace::new(Input::new(1.0, 0.0, 0.0), Input::new(1.0, 2.0, 0.0)).unwrap();
        assert!(matches!(
            UniformSampler::new(j, 0),
            Err(SamplerError::EmptySpace { axis: 0, .. })
        ));
    }
}
