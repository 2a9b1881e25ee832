//! Vehicles: how an input vector maps to a commanded body velocity (paper eq. 2, eq. 4 for
//! a skid-steer), what the input axes are, and how the protocol's characterization step
//! finds the true input space J of the vehicle.

use crate::{BodyVelocity, Input, PartTag, RegistryItem};
use crate::{CharacterizationError, InvalidPart};
use serde::{Deserialize, Serialize};

/// The input space J of a vehicle: a box of inputs `min <= u <= max`, with limits per axis
/// (Sec. III-A; the axes may have different units, as speed and steering angle).
///
/// The box has the vehicle's number of axes ([`dim`](Self::dim)): the axes beyond them are
/// the interval `[0, 0]` (a two-input vehicle's third axis), which inputs of the vehicle
/// always satisfy and samplers never draw. Written to files as `{"min": [..], "max": [..]}`
/// with only the vehicle's axes.
///
/// ```
/// use drive_traits::{Input, InputSpace};
/// let j = InputSpace::new(Input::new(-6.8, -6.8, 0.0), Input::new(6.8, 6.8, 0.0)).unwrap();
/// assert!(j.contains(&Input::new(1.0, -2.0, 0.0)));
/// assert!(!j.contains(&Input::new(7.0, 0.0, 0.0)));
/// assert_eq!(j.dim(), 2);
/// let omni = InputSpace::new(Input::new(-1.0, -0.5, -2.0), Input::new(1.0, 0.5, 2.0)).unwrap();
/// assert_eq!(omni.dim(), 3);
/// assert_eq!(serde_json::to_string(&j).unwrap(), r#"{"min":[-6.8,-6.8],"max":[6.8,6.8]}"#);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputSpace {
    /// Lower corner.
    #[serde(with = "crate::input_serde")]
    pub min: Input,
    /// Upper corner.
    #[serde(with = "crate::input_serde")]
    pub max: Input,
}

impl InputSpace {
    /// A box; `None` if a bound is not finite or `min > max` on some axis.
    pub fn new(min: Input, max: Input) -> Option<Self> {
        let ok = min.iter().chain(max.iter()).all(|v| v.is_finite())
            && min.iter().zip(max.iter()).all(|(a, b)| a <= b);
        ok.then_some(InputSpace { min, max })
    }

    /// The number of axes of the box: [`MAX_INPUTS`](crate::MAX_INPUTS) unless its last
    /// axes are the interval `[0, 0]` (at least two).
    pub fn dim(&self) -> usize {
        let mut dim = crate::MAX_INPUTS;
        while dim > 2 && self.min[dim - 1] == 0.0 && self.max[dim - 1] == 0.0 {
            dim -= 1;
        }
        dim
    }

    /// The size of each axis, `max - min`, and 1 for the axes beyond [`dim`](Self::dim): what
    /// a difference of inputs is divided by to compare axes of different units (the axes
    /// the vehicle does not have stay at zero instead of 0 / 0).
    ///
    /// ```
    /// use drive_traits::{Input, InputSpace};
    /// let j = InputSpace::new(Input::new(-2.0, -1.0, 0.0), Input::new(2.0, 1.0, 0.0)).unwrap();
    /// assert_eq!(j.scale(), Input::new(4.0, 2.0, 1.0));
    /// ```
    pub fn scale(&self) -> Input {
        let dim = self.dim();
        Input::from_fn(|i, _| {
            if i < dim {
                self.max[i] - self.min[i]
            } else {
                1.0
            }
        })
    }

    /// True if `u` lies inside the box (bounds included).
    pub fn contains(&self, u: &Input) -> bool {
        (0..crate::MAX_INPUTS).all(|i| u[i] >= self.min[i] && u[i] <= self.max[i])
    }

    /// `u` clamped into the box, per axis.
    pub fn clamp(&self, u: &Input) -> Input {
        Input::from_fn(|i, _| u[i].clamp(self.min[i], self.max[i]))
    }

    /// The centre of the box.
    pub fn center(&self) -> Input {
        (self.min + self.max) * 0.5
    }
}

/// One input axis of a vehicle: its name and unit, and the window CSV columns of its
/// commanded and measured values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct InputAxis {
    /// Name (`left`, `speed`, ...).
    pub name: &'static str,
    /// Unit (`rad/s`, `m/s`, `rad`).
    pub unit: &'static str,
    /// Column of the commanded value in the window CSV (`cmd_left`).
    pub command_column: &'static str,
    /// Column of the measured value (`enc_left`).
    pub measured_column: &'static str,
}

/// How a vehicle turns: what a slip model may assume about where its slip comes from.
///
/// `#[non_exhaustive]`: a kind of steering added later (holonomic wheels, frame steering)
/// is not a breaking change; code outside this crate that matches on it keeps an arm for
/// the kinds it does not know.
///
/// ```
/// use drive_traits::Steering;
/// assert_eq!(Steering::default(), Steering::Skid);
/// assert_eq!(Steering::Wheels.as_str(), "steered wheels");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "kebab-case")]
#[non_exhaustive]
pub enum Steering {
    /// By driving its sides at different speeds (skid-steer, differential drive, a body
    /// velocity command): every turn skids or scrubs (paper Sec. III-B.2).
    #[default]
    Skid,
    /// By steered wheels rolling along the turn (car-like, Ackermann): the tyres slip
    /// sideways with the lateral acceleration, the driven wheels lengthwise.
    Wheels,
    /// Without turning to move: an omnidirectional base (mecanum or omni wheels) drives
    /// sideways and turns at once, its rollers slipping most across.
    Holonomic,
}

impl Steering {
    /// A short description, for reports.
    pub fn as_str(self) -> &'static str {
        match self {
            Steering::Skid => "skid",
            Steering::Wheels => "steered wheels",
            Steering::Holonomic => "holonomic",
        }
    }
}

/// One sub-step of the characterization (DRIVE step 1): a command held while the runner
/// averages what the vehicle reaches in its last second.
#[derive(Debug, Clone, PartialEq)]
pub struct Probe {
    /// Name, for reports (`forward`, `turn`, ...).
    pub name: &'static str,
    /// The input held.
    pub command: Input,
    /// Whether the probe is only useful with localization (geometry identification).
    pub needs_localization: bool,
}

/// How the vehicle moved during a probe's averaging span, from the localization.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbeMotion {
    /// Time between the first and last localization updates of the span (s).
    pub duration_s: f64,
    /// Straight-line distance between them (m).
    pub distance_m: f64,
    /// Yaw turned between them, summed update by update (rad; more than half a turn is
    /// not wrapped away).
    pub yaw_turned: f64,
}

/// What a probe measured.
#[derive(Debug, Clone, PartialEq)]
pub struct ProbeResult {
    /// The probe.
    pub probe: Probe,
    /// Mean measured input over the averaging span.
    pub measured: Input,
    /// The motion seen by the localization, when there was one.
    pub motion: Option<ProbeMotion>,
}

/// What the characterization found: the true input space J and, with localization, the
/// vehicle's effective geometry (`wheel_radius`, `baseline`, ... by name).
#[derive(Debug, Clone, PartialEq)]
pub struct Characterization {
    /// The true input space J.
    pub space: InputSpace,
    /// Effective geometry parameters identified, by name.
    pub geometry: Vec<(String, f64)>,
}

impl Characterization {
    /// The identified value of the geometry parameter `name`, if any.
    pub fn geometry(&self, name: &str) -> Option<f64> {
        self.geometry
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| *v)
    }
}

/// A vehicle: the map from an input vector to the commanded body velocity `f(u)` of paper
/// eq. 2 (for a skid-steer robot, the ideal differential drive of eq. 4), its inverse, its
/// input axes and how its input space is characterized.
///
/// A dataset's sidecar names its vehicle and carries its geometry (`"vehicle": {"type":
/// "differential", ...}`); every learner, metric and sampler takes the vehicle from there.
/// Saved as a trait object with typetag (`"type": "<tag>"`): an implementation needs
/// `#[typetag::serde(name = "...")]`, and is registered in the vehicle registry.
///
/// ```
/// use drive_traits::{BodyVelocity, CommandModel, Input, InputAxis};
/// use serde::{Deserialize, Serialize};
///
/// /// A robot commanded directly in body velocity (v, omega), as a `cmd_vel` interface is.
/// #[derive(Debug, Clone, Serialize, Deserialize)]
/// struct Unicycle;
///
/// #[typetag::serde(name = "unicycle-doc")]
/// impl CommandModel for Unicycle {
///     fn body_velocity(&self, u: &Input) -> BodyVelocity { BodyVelocity::new(u.x, 0.0, u.y) }
///     fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
///         (v.y == 0.0).then(|| Input::new(v.x, v.z, 0.0))
///     }
///     fn axes(&self) -> Vec<InputAxis> {
///         vec![InputAxis { name: "v", unit: "m/s", command_column: "cmd_v", measured_column: "meas_v" },
///          InputAxis { name: "omega", unit: "rad/s", command_column: "cmd_omega", measured_column: "meas_omega" }]
///     }
///     fn clone_box(&self) -> Box<dyn CommandModel> { Box::new(self.clone()) }
/// }
///
/// let v = Unicycle.body_velocity(&Input::new(1.0, 0.5, 0.0));
/// assert_eq!(v, BodyVelocity::new(1.0, 0.0, 0.5));
/// // The default characterization drives forward and backward at twice the top speed.
/// assert_eq!(Unicycle.probe(0, 1.0, &[]).unwrap().command, Input::new(2.0, 0.0, 0.0));
/// ```
#[typetag::serde(tag = "type")]
pub trait CommandModel: std::fmt::Debug + Send + Sync {
    /// Commanded body velocity `f(u)` for input `u`.
    fn body_velocity(&self, u: &Input) -> BodyVelocity;

    /// `f(u)` for every input of `inputs`, into `out` (cleared first): one call per rollout.
    fn body_velocities_into(&self, inputs: &[Input], out: &mut Vec<BodyVelocity>) {
        out.clear();
        out.extend(inputs.iter().map(|u| self.body_velocity(u)));
    }

    /// The input that commands body velocity `v`, where one exists (a skid-steer cannot
    /// command a lateral velocity: `v.y` must be zero).
    fn input_for(&self, v: &BodyVelocity) -> Option<Input>;

    /// [`CommandModel::input_for`] of every body velocity of `v`, into `out` (cleared
    /// first): one call per batch (a controller's sampled body velocities). The default
    /// loops with the implementation's own `input_for`, which the compiler inlines.
    fn inputs_for_into(&self, v: &[BodyVelocity], out: &mut Vec<Option<Input>>) {
        out.clear();
        out.extend(v.iter().map(|v| self.input_for(v)));
    }

    /// The input that commands the forward speed `linear` (m/s) and the yaw rate `angular`
    /// (rad/s): what a Twist (linear.x, angular.z) asks of the robot, what the protocol's
    /// samplers and acceleration limits, the logger's commands on import and the
    /// controllers work in. `None` where no input gives them.
    ///
    /// The default is [`input_for`](Self::input_for) of `(linear, 0, angular)` where that
    /// exists; otherwise (a vehicle whose lateral velocity follows from the other two, such
    /// as a body whose reference point is off its turning axis) the input whose commanded
    /// forward speed and yaw rate are these, whatever lateral velocity the vehicle then
    /// has, found by Newton's method from the zero input.
    ///
    /// ```
    /// use drive_traits::{BodyVelocity, CommandModel, Input, InputAxis};
    /// // A unicycle whose reference point is 0.3 m ahead of its axle: v_y = 0.3 w.
    /// #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
    /// struct Offset;
    /// #[typetag::serde(name = "offset-doc")]
    /// impl CommandModel for Offset {
    ///     fn body_velocity(&self, u: &Input) -> BodyVelocity { BodyVelocity::new(u.x, 0.3 * u.y, u.y) }
    ///     fn input_for(&self, v: &BodyVelocity) -> Option<Input> {
    ///         (v.y == 0.3 * v.z).then(|| Input::new(v.x, v.z, 0.0))
    ///     }
    ///     fn axes(&self) -> Vec<InputAxis> { unimplemented!() }
    ///     fn clone_box(&self) -> Box<dyn CommandModel> { Box::new(Offset) }
    /// }
    /// assert_eq!(Offset.input_for(&BodyVelocity::new(1.0, 0.0, 0.5)), None);
    /// let u = Offset.input_for_twist(1.0, 0.5).unwrap();
    /// assert!((u - Input::new(1.0, 0.5, 0.0)).norm() < 1e-9);
    /// ```
    fn input_for_twist(&self, linear: f64, angular: f64) -> Option<Input> {
        if let Some(u) = self.input_for(&BodyVelocity::new(linear, 0.0, angular)) {
            return Some(u);
        }
        twist_by_newton(self, linear, angular)
    }

    /// The input axes, in the order of the input vector (two or three: at most
    /// [`MAX_INPUTS`](crate::MAX_INPUTS)).
    fn axes(&self) -> Vec<InputAxis>;

    /// The number of input axes (the length of [`axes`](Self::axes)).
    fn input_dim(&self) -> usize {
        self.axes().len()
    }

    /// What the vehicle commands at the extremes of the input space `space`: its top
    /// forward and backward speeds, hardest left and right turns and sideways reach, each
    /// with an input that gets there. Every part that needs a vehicle's top speed or top
    /// yaw rate (the human-like samplers, the protocol regions, the report's figures) asks
    /// it here. The default searches the whole box ([`search_reach`](crate::search_reach));
    /// a vehicle that knows its extremes in closed form may say so.
    fn reach(&self, space: &InputSpace) -> crate::Reach {
        crate::search_reach(self, space)
    }

    /// The manufacturer's (naive) input space for a top speed (m/s), when the geometry
    /// gives one.
    fn nominal_input_space(&self, top_speed: f64) -> Option<InputSpace> {
        let _ = top_speed;
        None
    }

    /// The characterization's probe number `index` for a vehicle of nominal top speed
    /// `top_speed` (m/s), given what the earlier probes measured (`done`); `None` when the
    /// characterization is complete. By default: the body command of twice the top speed,
    /// forward then backward (the paper's step 1).
    fn probe(&self, index: usize, top_speed: f64, done: &[ProbeResult]) -> Option<Probe> {
        let _ = done;
        let (name, sign) = match index {
            0 => ("forward", 1.0),
            1 => ("backward", -1.0),
            _ => return None,
        };
        let command = self.input_for_twist(sign * 2.0 * top_speed, 0.0)?;
        Some(Probe {
            name,
            command,
            needs_localization: false,
        })
    }

    /// The input space (and geometry) from what the probes measured. By default the box
    /// spanned by the probes' mean measured inputs, refused when an axis did not move.
    fn characterize(
        &self,
        results: &[ProbeResult],
    ) -> Result<Characterization, CharacterizationError> {
        Ok(Characterization {
            space: spanned_space(self, results)?,
            geometry: Vec::new(),
        })
    }

    /// Checks the geometry read from a file (finite, positive lengths); `Err` says what is
    /// wrong.
    fn check(&self) -> Result<(), InvalidPart> {
        Ok(())
    }

    /// Checks input limits given for this vehicle (a steering range within +-90 degrees,
    /// ...); `Err` says what is wrong. Any finite box by default.
    fn check_input_space(&self, space: &InputSpace) -> Result<(), InvalidPart> {
        let _ = space;
        Ok(())
    }

    /// The geometry parameters by name, for reports.
    fn geometry(&self) -> Vec<(&'static str, f64)> {
        Vec::new()
    }

    /// How the vehicle turns ([`Steering::Skid`] unless it steers its wheels): the slip
    /// learners choose their slip inputs from it.
    fn steering(&self) -> Steering {
        Steering::Skid
    }

    /// The vehicle's own slip-BLR basis (eq. 5), when none of the built-in ones (chosen
    /// from [`steering`](Self::steering)) describes how it slips: slip-BLR fits it instead
    /// (see [`SlipFeatures`](crate::SlipFeatures)). `None` by default.
    fn slip_features(&self) -> Option<Box<dyn crate::SlipFeatures>> {
        None
    }

    /// The columns of the measured inputs in the DRIVE logger's raw CSV; by default the
    /// window CSV's (the axes' `measured_column`).
    fn logger_measured_columns(&self) -> Vec<&'static str> {
        self.axes().iter().map(|a| a.measured_column).collect()
    }

    /// Boxed clone.
    fn clone_box(&self) -> Box<dyn CommandModel>;
}

/// The box spanned by the probes' mean measured inputs; an error naming the axis when the
/// probes never commanded it, or when what it reached spans less than 5% of what was
/// commanded on it (a stuck axis, or measurement noise on one that was never driven):
/// never a degenerate or made-up range.
///
/// ```
/// use drive_traits::{spanned_space, Input, Probe, ProbeResult};
/// # use drive_traits::{BodyVelocity, CommandModel, InputAxis};
/// # #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)] struct V;
/// # #[typetag::serde(name = "spanned-doc")] impl CommandModel for V {
/// #   fn body_velocity(&self, u: &Input) -> BodyVelocity { BodyVelocity::new(u.x, 0.0, u.y) }
/// #   fn input_for(&self, v: &BodyVelocity) -> Option<Input> { Some(Input::new(v.x, v.z, 0.0)) }
/// #   fn axes(&self) -> Vec<InputAxis> { vec![InputAxis { name: "v", unit: "m/s", command_column: "a", measured_column: "b" },
/// #       InputAxis { name: "w", unit: "rad/s", command_column: "c", measured_column: "d" }] }
/// #   fn clone_box(&self) -> Box<dyn CommandModel> { Box::new(V) } }
/// let probe = |c: Input, m: Input| ProbeResult { probe: Probe { name: "p", command: c, needs_localization: false }, measured: m, motion: None };
/// // Commanded +-4 on both axes, reached +-2 and +-1.
/// let moved = [probe(Input::new(4.0, 4.0, 0.0), Input::new(2.0, 1.0, 0.0)), probe(Input::new(-4.0, -4.0, 0.0), Input::new(-2.0, -1.0, 0.0))];
/// let j = spanned_space(&V, &moved).unwrap();
/// assert_eq!((j.min, j.max), (Input::new(-2.0, -1.0, 0.0), Input::new(2.0, 1.0, 0.0)));
/// // The second axis never commanded: its noise is no range.
/// let straight = [probe(Input::new(4.0, 0.0, 0.0), Input::new(2.0, 0.01, 0.0)), probe(Input::new(-4.0, 0.0, 0.0), Input::new(-2.0, -0.01, 0.0))];
/// assert!(spanned_space(&V, &straight).unwrap_err().contains("'w'"));
/// ```
pub fn spanned_space<V: CommandModel + ?Sized>(
    vehicle: &V,
    results: &[ProbeResult],
) -> Result<InputSpace, CharacterizationError> {
    let mut min = Input::repeat(f64::INFINITY);
    let mut max = Input::repeat(f64::NEG_INFINITY);
    let mut cmd_min = Input::repeat(f64::INFINITY);
    let mut cmd_max = Input::repeat(f64::NEG_INFINITY);
    for r in results {
        min = min.inf(&r.measured);
        max = max.sup(&r.measured);
        cmd_min = cmd_min.inf(&r.probe.command);
        cmd_max = cmd_max.sup(&r.probe.command);
    }
    for (i, axis) in vehicle.axes().iter().enumerate().take(crate::MAX_INPUTS) {
        let commanded = cmd_max[i] - cmd_min[i];
        if !(commanded.is_finite() && commanded > 0.0) {
            return Err(CharacterizationError::from(format!(
                "the characterization's probes never command the axis '{}': its range cannot be found; give the input limits",
                axis.name
            )));
        }
        let reached = max[i] - min[i];
        if !(reached.is_finite() && reached >= 0.05 * commanded) {
            return Err(CharacterizationError::from(format!(
                "the axis '{}' did not move during the characterization (it reached {:.4} to {:.4} {} for commands of {:.4} to {:.4}); check that its measurement is recorded and the vehicle is free to move",
                axis.name, min[i], max[i], axis.unit, cmd_min[i], cmd_max[i]
            )));
        }
    }
    InputSpace::new(min, max).ok_or_else(|| "the measured input space is not finite".into())
}

impl Clone for Box<dyn CommandModel> {
    fn clone(&self) -> Self {
        self.clone_box()
    }
}

impl RegistryItem for dyn CommandModel {
    /// Two or three input axes ([`MAX_INPUTS`](crate::MAX_INPUTS)), as many as
    /// [`CommandModel::input_dim`] says.
    fn check_part(&self) -> Result<(), InvalidPart> {
        let (axes, dim) = (self.axes().len(), self.input_dim());
        if axes != dim {
            return Err(InvalidPart::from(format!(
                "its axes() lists {axes} input axes and its input_dim() says {dim}"
            )));
        }
        if !(2..=crate::MAX_INPUTS).contains(&dim) {
            return Err(InvalidPart::from(format!(
                "it has {dim} input axes; a vehicle has 2 or 3 (at most MAX_INPUTS = {})",
                crate::MAX_INPUTS
            )));
        }
        Ok(())
    }

    fn part_tag(&self) -> Option<PartTag> {
        let tag = vehicle_tag(self)?;
        // The type's name as its derived Debug output starts with it.
        let debug = format!("{self:?}");
        let type_name = debug
            .split(|c: char| !(c.is_alphanumeric() || c == '_'))
            .next()
            .unwrap_or_default()
            .to_string();
        Some(PartTag::named::<Box<dyn CommandModel>>(
            "CommandModel",
            tag,
            type_name,
        ))
    }
}

/// The type tag of a vehicle (`differential`, `ackermann`, ...), from its saved form.
///
/// ```
/// # use drive_traits::{BodyVelocity, CommandModel, Input, InputAxis};
/// # #[derive(Debug, Clone, serde::Serialize, serde::Deserialize)] struct V;
/// # #[typetag::serde(name = "tag-doc")] impl CommandModel for V {
/// #   fn body_velocity(&self, u: &Input) -> BodyVelocity { BodyVelocity::new(u.x, 0.0, u.y) }
/// #   fn input_for(&self, v: &BodyVelocity) -> Option<Input> { Some(Input::new(v.x, v.z, 0.0)) }
/// #   fn axes(&self) -> Vec<InputAxis> { vec![InputAxis { name: "v", unit: "m/s", command_column: "a", measured_column: "b" },
/// #       InputAxis { name: "w", unit: "rad/s", command_column: "c", measured_column: "d" }] }
/// #   fn clone_box(&self) -> Box<dyn CommandModel> { Box::new(V) } }
/// assert_eq!(drive_traits::vehicle_tag(&V).as_deref(), Some("tag-doc"));
/// ```
pub fn vehicle_tag(v: &dyn CommandModel) -> Option<String> {
    serde_json::to_value(v)
        .ok()?
        .get("type")?
        .as_str()
        .map(String::from)
}

/// The vehicle `v` as its concrete type `T`, when it is one (read back from its saved form):
/// what a simulator of one kind of vehicle uses to get at the geometry.
pub fn vehicle_as<T: serde::de::DeserializeOwned + crate::Tagged>(
    v: &dyn CommandModel,
) -> Option<T> {
    let mut value = serde_json::to_value(v).ok()?;
    let fields = value.as_object_mut()?;
    if fields.remove("type")?.as_str()? != T::TAG {
        return None;
    }
    serde_json::from_value(value).ok()
}

/// The input whose commanded forward speed and yaw rate are `(linear, angular)`: Newton's
/// method on those two components of `f(u)` over the first two input axes (the others
/// held at zero), with a central-difference Jacobian, from the zero input (exact in one step for the linear kinematics of every built-in vehicle).
fn twist_by_newton<V: CommandModel + ?Sized>(
    vehicle: &V,
    linear: f64,
    angular: f64,
) -> Option<Input> {
    if !(linear.is_finite() && angular.is_finite()) {
        return None;
    }
    let target = nalgebra::Vector2::new(linear, angular);
    let twist = |u: &Input| {
        let v = vehicle.body_velocity(u);
        nalgebra::Vector2::new(v.x, v.z)
    };
    let scale = 1.0 + target.amax();
    let mut u = Input::zeros();
    for _ in 0..50 {
        let residual = twist(&u) - target;
        if !residual.iter().all(|r| r.is_finite()) {
            return None;
        }
        if residual.amax() <= 1e-12 * scale {
            return Some(u);
        }
        let h = 1e-6 * (1.0 + u.amax());
        let mut jacobian = nalgebra::Matrix2::zeros();
        for j in 0..2 {
            let mut step = Input::zeros();
            step[j] = h;
            jacobian.set_column(j, &((twist(&(u + step)) - twist(&(u - step))) / (2.0 * h)));
        }
        let step = jacobian.lu().solve(&residual)?;
        u.x -= step.x;
        u.y -= step.y;
    }
    let residual = twist(&u) - target;
    (residual.amax() <= 1e-9 * scale).then_some(u)
}
