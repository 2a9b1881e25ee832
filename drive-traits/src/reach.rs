//! What a vehicle can do inside an input space: its fastest forward and backward speeds,
//! its hardest left and right turns and its sideways reach, each with an input that gets
//! there. Asked of the vehicle ([`CommandModel::reach`](crate::CommandModel::reach)),
//! never guessed from one corner of the box: a four-wheel-steered rover's corner
//! (speed, front, rear all high) is a pure crab, and a car's (reverse, full lock) is not
//! where it turns hardest.

use crate::{input_serde, BodyVelocity, CommandModel, Input, InputSpace, MAX_INPUTS};
use serde::Serialize;

/// One extreme of a body velocity component over an input space, and an input inside the
/// space that reaches it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Extreme {
    /// The component's value there (m/s or rad/s).
    pub value: f64,
    /// An input that commands it.
    #[serde(with = "input_serde")]
    pub input: Input,
}

/// What a vehicle commands at the extremes of an input space (the commanded body velocity
/// `f(u)` of eq. 2, not what the ground lets it do).
///
/// ```
/// use drive_traits::vehicles::DifferentialDrive;
/// use drive_traits::{CommandModel, Input, InputSpace};
/// let husky = DifferentialDrive::new(0.165, 0.55);
/// let j = InputSpace::new(Input::new(-6.0, -6.0, 0.0), Input::new(6.0, 6.0, 0.0)).unwrap();
/// let reach = husky.reach(&j);
/// // Both wheels forward: 0.99 m/s; left wheel back, right wheel forward: turning in place.
/// assert!((reach.top_speed() - 0.99).abs() < 1e-12);
/// assert!((reach.top_yaw_rate() - 2.0 * 0.99 / 0.55).abs() < 1e-12);
/// assert_eq!(reach.left.input, Input::new(-6.0, 6.0, 0.0));
/// assert_eq!(reach.lateral(), 0.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Reach {
    /// The largest forward speed (m/s).
    pub forward: Extreme,
    /// The smallest forward speed (m/s; negative when the vehicle reverses).
    pub backward: Extreme,
    /// The largest yaw rate (rad/s, counter-clockwise: the hardest left turn).
    pub left: Extreme,
    /// The smallest yaw rate (rad/s: the hardest right turn, negative).
    pub right: Extreme,
    /// The largest lateral velocity (m/s, to the left).
    pub leftward: Extreme,
    /// The smallest lateral velocity (m/s, to the right, negative).
    pub rightward: Extreme,
}

impl Reach {
    /// The top forward speed (m/s, at least 0).
    pub fn top_speed(&self) -> f64 {
        self.forward.value.max(0.0)
    }

    /// The top yaw rate either way (rad/s, at least 0): the larger of the hardest left and
    /// right turns.
    pub fn top_yaw_rate(&self) -> f64 {
        self.left.value.max(-self.right.value).max(0.0)
    }

    /// The top lateral speed either way (m/s, at least 0; 0 for a vehicle that cannot
    /// command a sideways velocity).
    pub fn lateral(&self) -> f64 {
        self.leftward.value.max(-self.rightward.value).max(0.0)
    }
}

/// Grid points per axis of [`search_reach`]'s first pass (two axes, three axes).
const GRID_2: usize = 17;
const GRID_3: usize = 9;
/// Pattern-search steps of [`search_reach`]'s refinement, at most.
const REFINE_STEPS: usize = 200;

/// [`Reach`] found by searching the whole input space: every corner of the box, a regular
/// grid over it (17 points per axis for two inputs, 9 for three), then a pattern search
/// from the best point of each extreme, inside the box. Exact for a vehicle whose body
/// velocity is monotone along each axis (its extremes are at corners) and for a smooth
/// one whose extremes lie inside the box; the default of
/// [`CommandModel::reach`](crate::CommandModel::reach). Inputs where the vehicle's body
/// velocity is not finite are skipped; when none is finite, every extreme is 0 at the
/// box's centre.
///
/// ```
/// use drive_traits::vehicles::Ackermann;
/// use drive_traits::{search_reach, Input, InputSpace};
/// // A car of 2.5 m wheelbase: -2..5 m/s, +-0.5 rad of steering.
/// let car = Ackermann::new(2.5, 0.5);
/// let j = InputSpace::new(Input::new(-2.0, -0.5, 0.0), Input::new(5.0, 0.5, 0.0)).unwrap();
/// let reach = search_reach(&car, &j);
/// // The hardest turn is at top speed and full lock, not reversing (one corner's answer).
/// assert!((reach.top_yaw_rate() - 5.0 * 0.5_f64.tan() / 2.5).abs() < 1e-12);
/// assert_eq!(reach.backward.value, -2.0);
/// ```
pub fn search_reach<V: CommandModel + ?Sized>(vehicle: &V, space: &InputSpace) -> Reach {
    let dim = space.dim().min(MAX_INPUTS);
    let n = if dim <= 2 { GRID_2 } else { GRID_3 };
    // Each axis's grid values, its two ends exact (the corners first).
    let axis_values = |i: usize| -> Vec<f64> {
        let (lo, hi) = (space.min[i], space.max[i]);
        if i >= dim || lo == hi {
            return vec![lo];
        }
        let mut v = vec![lo, hi];
        v.extend((1..n - 1).map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64));
        v
    };
    let values: Vec<Vec<f64>> = (0..MAX_INPUTS).map(axis_values).collect();
    // Component (0 forward, 1 lateral, 2 yaw) and sign of each extreme, in the order of
    // `Reach`'s fields.
    const GOALS: [(usize, f64); 6] = [
        (0, 1.0),
        (0, -1.0),
        (2, 1.0),
        (2, -1.0),
        (1, 1.0),
        (1, -1.0),
    ];
    let mut best: [Option<(f64, Input)>; 6] = [None; 6];
    let consider = |u: Input, best: &mut [Option<(f64, Input)>; 6]| {
        let v: BodyVelocity = vehicle.body_velocity(&u);
        if !v.iter().all(|c| c.is_finite()) {
            return;
        }
        for (g, &(c, sign)) in GOALS.iter().enumerate() {
            let score = sign * v[c];
            if best[g].is_none_or(|(s, _)| score > s) {
                best[g] = Some((score, u));
            }
        }
    };
    // The corners first (ties keep the first found), then the rest of the grid.
    let mut index = [0usize; MAX_INPUTS];
    for pass in 0..2 {
        let limit = |i: usize| {
            if pass == 0 {
                values[i].len().min(2)
            } else {
                values[i].len()
            }
        };
        loop {
            let u = Input::from_fn(|i, _| values[i][index[i]]);
            let corner = (0..MAX_INPUTS).all(|i| index[i] < 2);
            if pass == 0 || !corner {
                consider(u, &mut best);
            }
            // The next grid point (an odometer over the axes).
            let mut axis = 0;
            while axis < MAX_INPUTS {
                index[axis] += 1;
                if index[axis] < limit(axis) {
                    break;
                }
                index[axis] = 0;
                axis += 1;
            }
            if axis == MAX_INPUTS {
                break;
            }
        }
    }
    // Refine each extreme by a pattern search from its best grid point, inside the box.
    let scale = space.scale();
    let extreme = |g: usize| -> Extreme {
        let (c, sign) = GOALS[g];
        let Some((mut score, mut u)) = best[g] else {
            return Extreme {
                value: 0.0,
                input: space.center(),
            };
        };
        let mut step = scale / (n - 1) as f64;
        for _ in 0..REFINE_STEPS {
            let mut moved = false;
            for i in 0..dim {
                for dir in [1.0, -1.0] {
                    let mut t = u;
                    t[i] = (t[i] + dir * step[i]).clamp(space.min[i], space.max[i]);
                    if t == u {
                        continue;
                    }
                    let v = vehicle.body_velocity(&t);
                    let s = sign * v[c];
                    if v.iter().all(|x| x.is_finite()) && s > score {
                        (score, u, moved) = (s, t, true);
                    }
                }
            }
            if !moved {
                step *= 0.5;
                if (0..dim).all(|i| step[i] <= 1e-12 * scale[i].max(f64::MIN_POSITIVE)) {
                    break;
                }
            }
        }
        Extreme {
            value: sign * score,
            input: u,
        }
    };
    Reach {
        forward: extreme(0),
        backward: extreme(1),
        left: extreme(2),
        right: extreme(3),
        leftward: extreme(4),
        rightward: extreme(5),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::InputAxis;

    /// A four-wheel-steered rover (speed, front steer, rear steer), wheelbase 1 m: its box's
    /// corner of all maxima is a pure crab (no yaw).
    #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
    struct Rover;

    #[typetag::serde(name = "rover-reach-test")]
    impl CommandModel for Rover {
        fn body_velocity(&self, u: &Input) -> BodyVelocity {
            let (tf, tr) = (u.y.tan(), u.z.tan());
            // Velocity of the midpoint, heading of the body.
            let beta = (0.5 * (tf + tr)).atan();
            BodyVelocity::new(
                u.x * beta.cos(),
                u.x * beta.sin(),
                u.x * beta.cos() * (tf - tr),
            )
        }
        fn input_for(&self, _: &BodyVelocity) -> Option<Input> {
            None
        }
        fn axes(&self) -> Vec<InputAxis> {
            Vec::new()
        }
        fn clone_box(&self) -> Box<dyn CommandModel> {
            Box::new(Rover)
        }
    }

    /// A vehicle whose yaw rate peaks inside its box: `w = v sin(2 s)` for s in [-1, 1].
    #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
    struct Inner;

    #[typetag::serde(name = "inner-reach-test")]
    impl CommandModel for Inner {
        fn body_velocity(&self, u: &Input) -> BodyVelocity {
            BodyVelocity::new(u.x, 0.0, u.x * (2.0 * u.y).sin())
        }
        fn input_for(&self, _: &BodyVelocity) -> Option<Input> {
            None
        }
        fn axes(&self) -> Vec<InputAxis> {
            Vec::new()
        }
        fn clone_box(&self) -> Box<dyn CommandModel> {
            Box::new(Inner)
        }
    }

    #[test]
    fn a_rover_turns_hardest_with_its_axles_steered_apart_not_at_its_crab_corner() {
        let j = InputSpace::new(Input::new(-1.0, -0.5, -0.5), Input::new(2.0, 0.5, 0.5)).unwrap();
        // The corner of all maxima crabs: no yaw at all.
        assert!(Rover.body_velocity(&j.max).z.abs() < 1e-12);
        let reach = search_reach(&Rover, &j);
        let turn = 2.0 * 2.0 * 0.5_f64.tan();
        assert!((reach.top_yaw_rate() - turn).abs() < 1e-9, "{reach:?}");
        assert_eq!(reach.left.input, Input::new(2.0, 0.5, -0.5));
        assert!((reach.top_speed() - 2.0).abs() < 1e-12);
        assert!((reach.lateral() - 2.0 * 0.5_f64.tan().atan().sin()).abs() < 1e-9);
        assert_eq!(reach.backward.value, -1.0);
    }

    #[test]
    fn an_extreme_inside_the_box_is_found_by_the_refinement() {
        let j = InputSpace::new(Input::new(0.0, -1.0, 0.0), Input::new(1.0, 1.0, 0.0)).unwrap();
        let reach = search_reach(&Inner, &j);
        // sin(2 s) peaks at s = pi / 4, between grid points.
        assert!((reach.left.value - 1.0).abs() < 1e-9, "{reach:?}");
        assert!((reach.left.input.y - std::f64::consts::FRAC_PI_4).abs() < 1e-4);
        assert!((reach.right.value + 1.0).abs() < 1e-9);
    }

    #[test]
    fn a_vehicle_that_never_gives_a_finite_velocity_reaches_nothing() {
        #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
        struct Broken;
        #[typetag::serde(name = "broken-reach-test")]
        impl CommandModel for Broken {
            fn body_velocity(&self, _: &Input) -> BodyVelocity {
                BodyVelocity::repeat(f64::NAN)
            }
            fn input_for(&self, _: &BodyVelocity) -> Option<Input> {
                None
            }
            fn axes(&self) -> Vec<InputAxis> {
                Vec::new()
            }
            fn clone_box(&self) -> Box<dyn CommandModel> {
                Box::new(Broken)
            }
        }
        let j = InputSpace::new(Input::new(-1.0, -1.0, 0.0), Input::new(1.0, 1.0, 0.0)).unwrap();
        let reach = search_reach(&Broken, &j);
        assert_eq!((reach.top_speed(), reach.top_yaw_rate()), (0.0, 0.0));
        assert_eq!(reach.forward.input, Input::zeros());
    }
}
