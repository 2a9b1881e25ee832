//! Planar poses, body velocities and the state propagation of paper eq. 1.

use nalgebra::{Matrix3, Vector3};

/// Planar pose `[x, y, yaw]` in metres and radians.
pub type Pose = Vector3<f64>;

/// Body velocity `[v_x, v_y, omega]` in the robot frame, in m/s and rad/s.
pub type BodyVelocity = Vector3<f64>;

/// A vehicle input vector, of up to [`MAX_INPUTS`] axes: `[omega_left, omega_right, 0]` wheel
/// angular velocities (rad/s) for a skid-steer robot, `[speed, steering angle, 0]` for an
/// Ackermann vehicle, `[v_x, v_y, omega]` for an omnidirectional base.
///
/// The vehicle says how many axes it has ([`CommandModel::input_dim`](crate::CommandModel::input_dim),
/// the length of its [`axes`](crate::CommandModel::axes)); the axes beyond them are zero.
/// Files write only a vehicle's own axes (see [`input_serde`]).
pub type Input = Vector3<f64>;

/// The most input axes a vehicle may have (an omnidirectional base's three).
pub const MAX_INPUTS: usize = 3;

/// The serialized form of an [`Input`]: its first two axes, and the third only when it is
/// not zero, so that a two-input vehicle's files read `[left, right]` as they always have;
/// reads two or three numbers (a missing third axis is zero).
///
/// ```
/// use drive_traits::{input_serde, Input};
/// #[derive(serde::Serialize, serde::Deserialize)]
/// struct S { #[serde(with = "input_serde")] u: Input }
/// assert_eq!(serde_json::to_string(&S { u: Input::new(1.0, 2.0, 0.0) }).unwrap(), r#"{"u":[1.0,2.0]}"#);
/// assert_eq!(serde_json::to_string(&S { u: Input::new(1.0, 2.0, 3.0) }).unwrap(), r#"{"u":[1.0,2.0,3.0]}"#);
/// assert_eq!(serde_json::from_str::<S>(r#"{"u":[1.0,2.0]}"#).unwrap().u, Input::new(1.0, 2.0, 0.0));
/// assert!(serde_json::from_str::<S>(r#"{"u":[1.0]}"#).is_err());
/// ```
pub mod input_serde {
    use super::Input;
    use serde::de::Error as _;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// Writes the axes as a sequence (two, or three when the third is not zero).
    pub fn serialize<S: Serializer>(u: &Input, s: S) -> Result<S::Ok, S::Error> {
        if u.z == 0.0 {
            [u.x, u.y].serialize(s)
        } else {
            [u.x, u.y, u.z].serialize(s)
        }
    }

    /// Reads two or three numbers.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Input, D::Error> {
        let v = Vec::<f64>::deserialize(d)?;
        match v.as_slice() {
            [a, b] => Ok(Input::new(*a, *b, 0.0)),
            [a, b, c] => Ok(Input::new(*a, *b, *c)),
            _ => Err(D::Error::invalid_length(v.len(), &"2 or 3 input axes")),
        }
    }
}

/// 3x3 covariance of a pose `[x, y, yaw]`.
pub type PoseCovariance = Matrix3<f64>;

/// One explicit Euler step of paper eq. 1: `q[k+1] = q[k] + T(yaw[k]) v[k] dt`.
///
/// ```
/// use drive_traits::{euler_step, BodyVelocity, Pose};
/// let q = euler_step(&Pose::new(0.0, 0.0, std::f64::consts::FRAC_PI_2), &BodyVelocity::new(1.0, 0.0, 0.5), 0.1);
/// assert!((q.x - 0.0).abs() < 1e-12 && (q.y - 0.1).abs() < 1e-12 && (q.z - (std::f64::consts::FRAC_PI_2 + 0.05)).abs() < 1e-12);
/// ```
#[inline]
pub fn euler_step(q: &Pose, v: &BodyVelocity, dt: f64) -> Pose {
    let (s, c) = q.z.sin_cos();
    Pose::new(
        q.x + (c * v.x - s * v.y) * dt,
        q.y + (s * v.x + c * v.y) * dt,
        q.z + v.z * dt,
    )
}

/// The net turn of `poses`' yaw (rad), unwrapped: each step's change taken to the nearest
/// turn (a fast spin passes +-pi between samples), summed.
///
/// ```
/// use drive_traits::{net_turn, Pose};
/// let spin: Vec<Pose> = (0..5).map(|k| Pose::new(0.0, 0.0, drive_traits::wrap_angle(k as f64))).collect();
/// assert!((net_turn(&spin) - 4.0).abs() < 1e-12);
/// ```
pub fn net_turn(poses: &[Pose]) -> f64 {
    poses
        .windows(2)
        .map(|p| {
            let d = p[1].z - p[0].z;
            d.sin().atan2(d.cos())
        })
        .sum::<f64>()
}

/// Wraps an angle to `[-pi, pi]`.
///
/// ```
/// use drive_traits::wrap_angle;
/// assert!((wrap_angle(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
/// assert!((wrap_angle(-0.5) + 0.5).abs() < 1e-15);
/// ```
pub fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::PI;
    if (-PI..=PI).contains(&a) {
        return a;
    }
    let r = (a + PI).rem_euclid(2.0 * PI) - PI;
    // rem_euclid maps +pi to -pi; keep the sign of the input at the boundary.
    if r == -PI && a > 0.0 {
        PI
    } else {
        r
    }
}

/// `pose` seen from `origin`: its position in the body frame at `origin`, and its yaw
/// relative to `origin`'s, wrapped to [-pi, pi]. How DRIVE windows re-base their poses to
/// the window's start.
///
/// ```
/// use drive_traits::{relative_pose, Pose};
/// let origin = Pose::new(1.0, 1.0, std::f64::consts::FRAC_PI_2);
/// let p = relative_pose(&origin, &Pose::new(1.0, 3.0, std::f64::consts::PI));
/// assert!((p - Pose::new(2.0, 0.0, std::f64::consts::FRAC_PI_2)).norm() < 1e-12);
/// ```
pub fn relative_pose(origin: &Pose, pose: &Pose) -> Pose {
    let (s, c) = origin.z.sin_cos();
    let (dx, dy) = (pose.x - origin.x, pose.y - origin.y);
    Pose::new(
        c * dx + s * dy,
        -s * dx + c * dy,
        wrap_angle(pose.z - origin.z),
    )
}

/// Unwraps a sequence of angles in place so that consecutive values never jump by more
/// than pi (the sequence then stays continuous across the ±pi boundary).
///
/// ```
/// use drive_traits::unwrap_angles;
/// let mut a = [3.0, -3.0, -2.9];
/// unwrap_angles(&mut a);
/// assert!((a[1] - (2.0 * std::f64::consts::PI - 3.0)).abs() < 1e-12);
/// ```
pub fn unwrap_angles(angles: &mut [f64]) {
    use std::f64::consts::PI;
    let mut offset = 0.0;
    for i in 1..angles.len() {
        let prev = angles[i - 1];
        let mut cur = angles[i] + offset;
        let d = cur - prev;
        if d > PI {
            let turns = ((d + PI) / (2.0 * PI)).floor();
            offset -= turns * 2.0 * PI;
            cur -= turns * 2.0 * PI;
        } else if d < -PI {
            let turns = ((-d + PI) / (2.0 * PI)).floor();
            offset += turns * 2.0 * PI;
            cur += turns * 2.0 * PI;
        }
        angles[i] = cur;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn wrap_stays_in_range() {
        for i in -100..100 {
            let a = i as f64 * 0.37;
            let w = wrap_angle(a);
            assert!((-PI..=PI).contains(&w));
            assert!(
                ((a - w) / (2.0 * PI)).fract().abs() < 1e-9
                    || ((a - w) / (2.0 * PI)).fract().abs() > 1.0 - 1e-9
            );
        }
    }

    #[test]
    fn unwrap_removes_jumps() {
        let truth: Vec<f64> = (0..50).map(|k| 0.3 * k as f64).collect();
        let mut wrapped: Vec<f64> = truth.iter().map(|a| wrap_angle(*a)).collect();
        unwrap_angles(&mut wrapped);
        for (a, b) in truth.iter().zip(&wrapped) {
            assert!((a - b).abs() < 1e-9);
        }
    }

    #[test]
    fn euler_step_straight_line() {
        let q = euler_step(
            &Pose::new(1.0, 2.0, 0.0),
            &BodyVelocity::new(2.0, 0.0, 0.0),
            0.05,
        );
        assert_eq!(q, Pose::new(1.1, 2.0, 0.0));
    }
}
