//! How a real run's protocol commanded its robot, so that a fitted twin
//! (`drive sim-fit`) samples what the real run sampled.
//!
//! The DRIVE paper's own node draws wheel speeds uniformly in a box, but converts them to the
//! body velocity it sends with the geometry its characterization *estimated*, and the logger
//! converts that body velocity back to wheel speeds with the robot's nominal geometry. The
//! recorded commands then fill the box's image: a diamond in body velocity (the paper's
//! Fig. 2) whose aspect ratio is the estimated baseline's, not the nominal one's. On the
//! bundled Husky data the commands span 14.5 rad/s per wheel but only 0.95 m/s of forward
//! speed: a box in the nominal wheel speeds would command twice the forward speeds the real
//! run did. Its commands also step at the start of an interval instead of ramping.

use drive_models::DifferentialDrive;
use drive_traits::{Input, InputSampler, InputSpace, RobotDescription, Window};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// The protocol of a fitted twin's real run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TwinProtocol {
    /// The baseline (m) the protocol converted its sampled wheel speeds to body velocities
    /// with (the robot's own baseline when it used the nominal geometry).
    pub baseline: f64,
    /// The box the protocol drew wheel speeds from, in that geometry: `[[min, max], [min,
    /// max]]`, left then right (rad/s). The characterization is skipped.
    pub input_limits: [[f64; 2]; 2],
    /// Linear acceleration limit of the sent commands (m/s^2); absent: commands step to
    /// the sampled input at the start of an interval.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_linear_acceleration: Option<f64>,
    /// Angular acceleration limit of the sent commands (rad/s^2); absent: commands step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_angular_acceleration: Option<f64>,
    /// The rectangle of body velocities the protocol's draws span: `[[min, max] forward
    /// speed (m/s), [min, max] yaw rate (rad/s)]`, in the robot's geometry
    /// (`robot_wheel_radius`, `robot_baseline`). Draws of `input_limits` outside it are drawn
    /// again: a protocol that drew body velocities in a rectangle (or capped them) is
    /// followed, and on a box's draws the rectangle cuts only the box's corners. Absent: the
    /// box alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body_limits: Option<[[f64; 2]; 2]>,
    /// The wheel radius (m) of the robot the twin was fitted for (the data's).
    pub robot_wheel_radius: f64,
    /// The baseline (m) of the robot the twin was fitted for (the data's).
    pub robot_baseline: f64,
}

impl TwinProtocol {
    /// The sampled box.
    ///
    /// ```
    /// let p = drive_sim::TwinProtocol {
    ///     baseline: 0.22,
    ///     input_limits: [[-6.0, 6.0], [-5.0, 6.5]],
    ///     max_linear_acceleration: None,
    ///     max_angular_acceleration: None,
    ///     body_limits: None,
    ///     robot_wheel_radius: 0.165,
    ///     robot_baseline: 0.55,
    /// };
    /// assert_eq!(p.space().unwrap().min.y, -5.0);
    /// assert!(p.refuses(0.165, 0.55).is_none() && p.refuses(0.3, 1.17).is_some());
    /// // Recorded with a 0.55 m baseline, a wheel-speed difference looks 2.5 times larger.
    /// assert!((p.difference_gain(0.55) - 2.5).abs() < 1e-12);
    /// ```
    pub fn space(&self) -> Option<InputSpace> {
        let [l, r] = self.input_limits;
        InputSpace::new(Input::new(l[0], r[0], 0.0), Input::new(l[1], r[1], 0.0))
    }

    /// Why this twin cannot drive `robot` (a differential drive of `wheel_radius` and
    /// `baseline`): another geometry than the one it was fitted for (within 1%).
    pub fn refuses(&self, wheel_radius: f64, baseline: f64) -> Option<String> {
        let off = |a: f64, b: f64| (a - b).abs() > 0.01 * b.abs();
        (off(wheel_radius, self.robot_wheel_radius) || off(baseline, self.robot_baseline)).then(|| {
            format!(
                "it is a twin of a robot with wheel radius {} m and baseline {} m; this robot has {} m and {} m",
                drive_traits::limits::Short(self.robot_wheel_radius),
                drive_traits::limits::Short(self.robot_baseline),
                drive_traits::limits::Short(wheel_radius),
                drive_traits::limits::Short(baseline)
            )
        })
    }

    /// The factor the protocol's geometry puts on the wheel-speed difference, as recorded
    /// in the nominal geometry (`nominal_baseline / baseline`): the commanded yaw rate
    /// `r (u_r - u_l) / baseline` is recorded as a difference `yaw rate x nominal_baseline /
    /// r`, while the forward speed keeps the wheel-speed sum.
    pub fn difference_gain(&self, nominal_baseline: f64) -> f64 {
        nominal_baseline / self.baseline
    }
}

/// Scales the difference of the two wheel speeds by `gain`, keeping their sum.
///
/// ```
/// use drive_traits::Input;
/// let u = drive_sim::scale_difference(Input::new(1.0, 3.0, 0.0), 2.0);
/// assert_eq!(u, Input::new(0.0, 4.0, 0.0));
/// ```
pub fn scale_difference(u: Input, gain: f64) -> Input {
    let (sum, diff) = ((u.x + u.y) / 2.0, (u.y - u.x) / 2.0 * gain);
    Input::new(sum - diff, sum + diff, 0.0)
}

/// What to give a twin's sampler so that its runs hold the `recorded` commands, interval by
/// interval (a twin run driven as a real one was: `drive sim-fit`'s check and its variability
/// stage). Through the twin's protocol, on a differential-drive `robot`, the commands are
/// mapped back from the protocol's geometry (its difference gain undone), and its rectangle
/// of body velocities, which redraws inputs outside it, is removed from `terrain`; without a
/// protocol, or on another vehicle, they are held as recorded, every input axis.
///
/// ```
/// use drive_samplers::{builtin_robots, RobotSpec};
/// use drive_sim::{replay_commands, scale_difference, Terrain, TwinProtocol};
/// use drive_traits::Input;
/// let robot = RobotSpec::load(&builtin_robots(), "husky").unwrap(); // baseline 0.55 m
/// let mut terrain = Terrain::preset("gravel").unwrap();
/// let recorded = [Input::new(1.0, 3.0, 0.0)];
/// // Without a protocol: as recorded.
/// assert_eq!(replay_commands(&mut terrain.clone(), &robot, &recorded), recorded);
/// terrain.protocol = Some(TwinProtocol {
///     input_limits: [[-6.0, 6.0], [-6.0, 6.0]],
///     baseline: 0.275,
///     max_linear_acceleration: None,
///     max_angular_acceleration: None,
///     body_limits: Some([[-1.0, 1.0], [-2.0, 2.0]]),
///     robot_wheel_radius: 0.165,
///     robot_baseline: 0.55,
/// });
/// let given = replay_commands(&mut terrain, &robot, &recorded);
/// // The protocol doubles the difference (0.55 / 0.275): given half of it, it records it.
/// assert_eq!(given, [Input::new(1.5, 2.5, 0.0)]);
/// assert_eq!(scale_difference(given[0], 2.0), recorded[0]);
/// assert_eq!(terrain.protocol.unwrap().body_limits, None);
/// ```
pub fn replay_commands(
    terrain: &mut crate::Terrain,
    robot: &drive_samplers::RobotSpec,
    recorded: &[Input],
) -> Vec<Input> {
    let nominal = drive_traits::vehicle_as::<DifferentialDrive>(robot.vehicle.as_ref());
    match (terrain.protocol.as_mut(), nominal) {
        (Some(p), Some(nominal)) => {
            p.body_limits = None;
            let back = 1.0 / p.difference_gain(nominal.baseline);
            recorded
                .iter()
                .map(|&u| scale_difference(u, back))
                .collect()
        }
        _ => recorded.to_vec(),
    }
}

/// A sampler in the protocol's geometry, seen in the nominal one: its inputs are recorded
/// with their wheel-speed difference scaled by `gain`; what it observes is mapped back, with
/// a robot description of the protocol's geometry, so that a sampler that learns from the
/// windows (`targeted`) reasons in its own coordinates.
///
/// ```
/// use drive_sim::ProtocolSampler;
/// use drive_traits::{Input, InputSampler, InputSpace};
/// let space = InputSpace::new(Input::new(-1.0, -1.0, 0.0), Input::new(1.0, 1.0, 0.0)).unwrap();
/// let inner = drive_samplers::UniformSampler::new(space, 7).unwrap();
/// let geometry = std::sync::Arc::new(drive_models::DifferentialDrive::new(0.165, 0.22));
/// let mut s = ProtocolSampler::new(Box::new(inner), 2.5, geometry);
/// let u = s.next_input();
/// // The sum of the wheel speeds stays within the box's, the difference is stretched.
/// assert!((u.x + u.y).abs() <= 2.0 && (u.y - u.x).abs() <= 5.0);
/// ```
pub struct ProtocolSampler {
    inner: Box<dyn InputSampler>,
    gain: f64,
    /// The body-velocity rectangle its draws must fall in, and the geometry that tells.
    within: Option<([[f64; 2]; 2], DifferentialDrive)>,
    robot: Option<RobotDescription>,
    protocol_vehicle: Arc<dyn drive_traits::CommandModel>,
}

impl ProtocolSampler {
    /// `inner` draws in the protocol's geometry, `protocol_vehicle`; `gain` maps its inputs
    /// to the nominal geometry's ([`TwinProtocol::difference_gain`]).
    pub fn new(
        inner: Box<dyn InputSampler>,
        gain: f64,
        protocol_vehicle: Arc<dyn drive_traits::CommandModel>,
    ) -> Self {
        ProtocolSampler {
            inner,
            gain,
            within: None,
            robot: None,
            protocol_vehicle,
        }
    }

    /// Draws only inputs whose body velocity in `geometry` (the recorded commands') lies in
    /// `limits` (`[[min, max] forward speed, [min, max] yaw rate]`, [`TwinProtocol::body_limits`]):
    /// the others are drawn again (up to 10,000 times; then the last is moved into the
    /// rectangle).
    ///
    /// ```
    /// use drive_sim::ProtocolSampler;
    /// use drive_models::DifferentialDrive;
    /// use drive_traits::{Input, InputSampler, InputSpace};
    /// let space = InputSpace::new(Input::new(-10.0, -10.0, 0.0), Input::new(10.0, 10.0, 0.0)).unwrap();
    /// let inner = drive_samplers::UniformSampler::new(space, 7).unwrap();
    /// let g = DifferentialDrive::new(0.3, 1.08);
    /// let mut s = ProtocolSampler::new(Box::new(inner), 1.0, std::sync::Arc::new(g.clone()))
    ///     .within([[-1.0, 1.0], [-0.5, 0.5]], g.clone());
    /// for _ in 0..100 {
    ///     let u = s.next_input();
    ///     let (v, w) = (0.3 * (u.x + u.y) / 2.0, 0.3 * (u.y - u.x) / 1.08);
    ///     assert!(v.abs() <= 1.0 + 1e-9 && w.abs() <= 0.5 + 1e-9);
    /// }
    /// ```
    pub fn within(mut self, limits: [[f64; 2]; 2], geometry: DifferentialDrive) -> Self {
        self.within = Some((limits, geometry));
        self
    }
}

impl InputSampler for ProtocolSampler {
    fn next_input(&mut self) -> Input {
        let Some(([v_range, w_range], g)) = &self.within else {
            return scale_difference(self.inner.next_input(), self.gain);
        };
        let body = |u: Input| {
            [
                g.wheel_radius * (u.x + u.y) / 2.0,
                g.wheel_radius * (u.y - u.x) / g.baseline,
            ]
        };
        let inside = |[v, w]: [f64; 2]| {
            (v_range[0]..=v_range[1]).contains(&v) && (w_range[0]..=w_range[1]).contains(&w)
        };
        let mut u = scale_difference(self.inner.next_input(), self.gain);
        for _ in 0..10_000 {
            if inside(body(u)) {
                return u;
            }
            u = scale_difference(self.inner.next_input(), self.gain);
        }
        let [v, w] = body(u);
        let (v, w) = (
            v.clamp(v_range[0], v_range[1]),
            w.clamp(w_range[0], w_range[1]),
        );
        crate::ControllerParams::wheels([v, w], g.wheel_radius, g.baseline)
    }

    fn observe(&mut self, robot: &RobotDescription, interval: &[Window]) {
        let back = 1.0 / self.gain;
        let mapped: Vec<Window> = interval
            .iter()
            .map(|w| {
                let mut w = w.clone();
                for u in w.command.iter_mut().chain(w.measured.iter_mut()) {
                    *u = scale_difference(*u, back);
                }
                w
            })
            .collect();
        let described = self.robot.get_or_insert_with(|| RobotDescription {
            vehicle: Arc::clone(&self.protocol_vehicle),
            ..robot.clone()
        });
        self.inner.observe(described, &mapped);
    }
}
