//! The ROS 2 messages a bag's topics carry, decoded from CDR into the values the logger
//! keeps, with the reader's bounds on what is plausible.

use super::MAX_BAG_NAME_BYTES;
use serde::Deserialize;

// The ROS 2 messages read, as CDR lays them out (fields after the last one used are not
// read).
#[derive(Deserialize)]
struct Stamp {
    _sec: i32,
    _nanosec: u32,
}
#[derive(Deserialize)]
struct Header {
    _stamp: Stamp,
    _frame_id: String,
}
#[derive(Deserialize)]
struct Vector3 {
    x: f64,
    y: f64,
    z: f64,
}
#[derive(Deserialize)]
struct Quaternion {
    x: f64,
    y: f64,
    z: f64,
    w: f64,
}
#[derive(Deserialize)]
struct PoseMsg {
    position: Vector3,
    orientation: Quaternion,
}
#[derive(Deserialize)]
struct Odometry {
    _header: Header,
    _child_frame_id: String,
    pose: PoseMsg,
}
#[derive(Deserialize)]
struct PoseStamped {
    _header: Header,
    pose: PoseMsg,
}
#[derive(Deserialize)]
struct Imu {
    _header: Header,
    _orientation: Quaternion,
    _orientation_covariance: [f64; 9],
    angular_velocity: Vector3,
    _angular_velocity_covariance: [f64; 9],
    linear_acceleration: Vector3,
}
#[derive(Deserialize)]
struct Twist {
    linear: Vector3,
    angular: Vector3,
}
#[derive(Deserialize)]
struct TwistStamped {
    _header: Header,
    twist: Twist,
}
#[derive(Deserialize)]
struct JointState {
    _header: Header,
    name: Vec<String>,
    _position: Vec<f64>,
    velocity: Vec<f64>,
}
#[derive(Deserialize)]
struct Data<T> {
    data: T,
}

/// A decoded message's values.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Value {
    Step(i32),
    Bool(bool),
    Text(String),
    Pose([f64; 3], [f64; 4]),
    Number(f64),
    Imu([f64; 3], [f64; 3]),
    Twist([f64; 2]),
}

/// Decodes one CDR message (with its 4-byte encapsulation header) of type `ty`.
pub(super) fn decode(ty: &str, bytes: &[u8], joint: Option<&str>) -> Result<Value, String> {
    use byteorder::{BigEndian, LittleEndian};
    if bytes.len() < 4 {
        return Err("shorter than the CDR header".into());
    }
    let little = match bytes[..2] {
        [0, 1] | [0, 3] => true,
        [0, 0] | [0, 2] => false,
        _ => return Err(format!("unknown CDR encapsulation {:?}", &bytes[..2])),
    };
    fn read<'de, T: Deserialize<'de>>(body: &'de [u8], little: bool) -> Result<T, String> {
        let r = if little {
            cdr_encoding::from_bytes::<T, LittleEndian>(body)
        } else {
            cdr_encoding::from_bytes::<T, BigEndian>(body)
        };
        r.map(|(v, _)| v).map_err(|e| e.to_string())
    }
    let body = &bytes[4..];
    let pose = |p: PoseMsg| {
        let (x, q) = (p.position, p.orientation);
        Value::Pose([x.x, x.y, x.z], [q.x, q.y, q.z, q.w])
    };
    Ok(match ty {
        "std_msgs/msg/Int32" => Value::Step(read::<Data<i32>>(body, little)?.data),
        "std_msgs/msg/Bool" => Value::Bool(read::<Data<bool>>(body, little)?.data),
        // A calib_state is a word: a long text is no DRIVE message (and is not held).
        "std_msgs/msg/String" if body.len() > MAX_BAG_NAME_BYTES + 8 => {
            return Err(format!(
                "a text of {} bytes, more than the {MAX_BAG_NAME_BYTES} read",
                body.len()
            ))
        }
        "std_msgs/msg/String" => {
            let text = read::<Data<String>>(body, little)?.data;
            if text.len() > MAX_BAG_NAME_BYTES {
                return Err(format!(
                    "a text of {} bytes, more than the {MAX_BAG_NAME_BYTES} read",
                    text.len()
                ));
            }
            Value::Text(text)
        }
        "std_msgs/msg/Float64" => Value::Number(read::<Data<f64>>(body, little)?.data),
        "nav_msgs/msg/Odometry" => pose(read::<Odometry>(body, little)?.pose),
        // A PoseWithCovarianceStamped starts like a PoseStamped (the covariance follows).
        "geometry_msgs/msg/PoseStamped" | "geometry_msgs/msg/PoseWithCovarianceStamped" => {
            pose(read::<PoseStamped>(body, little)?.pose)
        }
        "sensor_msgs/msg/Imu" => {
            let m = read::<Imu>(body, little)?;
            let (w, a) = (m.angular_velocity, m.linear_acceleration);
            Value::Imu([w.x, w.y, w.z], [a.x, a.y, a.z])
        }
        "geometry_msgs/msg/Twist" => {
            let t = read::<Twist>(body, little)?;
            Value::Twist([t.linear.x, t.angular.z])
        }
        "geometry_msgs/msg/TwistStamped" => {
            let t = read::<TwistStamped>(body, little)?.twist;
            Value::Twist([t.linear.x, t.angular.z])
        }
        "sensor_msgs/msg/JointState" => {
            let m = read::<JointState>(body, little)?;
            let i = joint_index(&m.name, joint)?;
            match m.velocity.get(i) {
                Some(v) => Value::Number(*v),
                None => {
                    return Err(format!(
                        "joint {:?} has no velocity ({} velocities for {} names)",
                        m.name[i],
                        m.velocity.len(),
                        m.name.len()
                    ))
                }
            }
        }
        other => return Err(format!("{other} is not read")),
    })
}

/// `value` when every number in it is finite and within the measurement bound the CSV
/// readers keep (+-1e9; a quaternion's components within +-2).
pub(super) fn plausible(value: Value) -> Result<Value, String> {
    use drive_traits::limits::{Short, MAX_ABS_MEASUREMENT};
    let check = |what: &str, v: &[f64], bound: f64| -> Result<(), String> {
        match v.iter().find(|x| !(x.is_finite() && x.abs() <= bound)) {
            Some(x) => Err(format!(
                "{what} {} is not a finite number within +-{}",
                Short(*x),
                Short(bound)
            )),
            None => Ok(()),
        }
    };
    match &value {
        Value::Pose(p, q) => {
            check("a position", p, MAX_ABS_MEASUREMENT)?;
            check("a quaternion component", q, 2.0)?;
        }
        Value::Number(v) => check("the value", &[*v], MAX_ABS_MEASUREMENT)?,
        Value::Imu(w, a) => {
            check("an angular velocity", w, MAX_ABS_MEASUREMENT)?;
            check("an acceleration", a, MAX_ABS_MEASUREMENT)?;
        }
        Value::Twist(t) => check("a command", t, MAX_ABS_MEASUREMENT)?,
        Value::Step(_) | Value::Bool(_) | Value::Text(_) => {}
    }
    Ok(value)
}

/// The index of the named joint in a JointState message.
fn joint_index(names: &[String], joint: Option<&str>) -> Result<usize, String> {
    let Some(joint) = joint else {
        return Err("a JointState topic needs its joint: KEY=/topic:joint".into());
    };
    names.iter().position(|n| n == joint).ok_or_else(|| {
        format!(
            "no joint {joint:?} in the message (joints: {})",
            names.join(", ")
        )
    })
}
