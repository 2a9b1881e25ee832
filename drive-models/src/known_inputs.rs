//! What a saved model knows of its inputs, and the notes a prediction beyond it earns: a
//! command beyond the commands the model was trained on, a start no data showed, a
//! prediction faster than any robot moves (`drive predict` prints them, Python's
//! `Model.predict` warns with them).

use crate::model_file::{CommandRange, FitSettings};
use drive_traits::limits::Short;
use drive_traits::{Input, MotionModel, Pose, RobotDescription};

/// The inputs a model knows: the commands it was trained on, else its powertrain's fitted
/// limits; what they are called, and whether its powertrain saturates beyond them.
///
/// ```
/// use drive_models::known_inputs::KnownInputs;
/// use drive_models::model_file::CommandRange;
/// use drive_traits::Input;
/// let robot = drive_traits::RobotDescription {
///     name: "r".into(),
///     robot: "husky".into(),
///     rate_hz: 20.0,
///     window_len: 40,
///     vehicle: std::sync::Arc::new(drive_models::DifferentialDrive::new(0.165, 0.55)),
///     position_frame: Default::default(),
///     terrain: String::new(),
///     registered_robot: String::new(),
/// };
/// let known = KnownInputs {
///     range: CommandRange { min: vec![-5.0, -5.0], max: vec![5.0, 5.0] },
///     what: "the commands it was trained on",
///     saturates: true,
/// };
/// assert!(known.command_note(&robot, [Input::new(1.0, 2.0, 0.0)]).is_none());
/// let note = known.command_note(&robot, [Input::new(1.0, 100.0, 0.0)]).unwrap();
/// assert!(note.starts_with("command 0 holds 100 rad/s on axis 'cmd_right', beyond the commands it was trained on ([-5, 5])"), "{note}");
/// ```
pub struct KnownInputs {
    /// The range of each input axis.
    pub range: CommandRange,
    /// What the range is (`the commands it was trained on`, `its powertrain's fitted limits`).
    pub what: &'static str,
    /// Whether the model's powertrain saturates a command beyond its limits.
    pub saturates: bool,
}

impl KnownInputs {
    /// What `model` (saved with `fitted_with`, for `robot`) knows: the commands of its
    /// training windows (`fitted_with.commanded`), or, in a file that does not keep them,
    /// its powertrain's fitted limits (its parameters `axis i min`, `axis i max`); `None`
    /// with neither.
    pub fn of(
        model: &dyn MotionModel,
        fitted_with: Option<&FitSettings>,
        robot: &RobotDescription,
    ) -> Option<KnownInputs> {
        let axes = robot.vehicle.axes();
        let limits = model.powertrain().and_then(|p| {
            let params = p.parameters();
            let find = |key: String| params.iter().find(|(k, _)| *k == key).map(|(_, v)| *v);
            let min: Option<Vec<f64>> = (0..axes.len())
                .map(|i| find(format!("axis {i} min")))
                .collect();
            let max: Option<Vec<f64>> = (0..axes.len())
                .map(|i| find(format!("axis {i} max")))
                .collect();
            Some(CommandRange {
                min: min?,
                max: max?,
            })
        });
        // The training commands first: a DRIVE run commands beyond what its wheels reach,
        // and the fit learned that saturation.
        let saturates = limits.is_some();
        let (range, what) = match (fitted_with.and_then(|f| f.commanded.clone()), limits) {
            (Some(c), _) => (c, "the commands it was trained on"),
            (None, Some(l)) => (l, "its powertrain's fitted limits"),
            (None, None) => return None,
        };
        Some(KnownInputs {
            range,
            what,
            saturates,
        })
    }

    /// A note when one of `commands` lies beyond the known inputs (the first such), saying
    /// whether the powertrain saturates it or the model extrapolates.
    pub fn command_note(
        &self,
        robot: &RobotDescription,
        commands: impl IntoIterator<Item = Input>,
    ) -> Option<String> {
        let axes = robot.vehicle.axes();
        let consequence = if self.saturates {
            "its powertrain saturates it at its fitted limits"
        } else {
            "the model extrapolates beyond its data"
        };
        let (k, i, v) = commands.into_iter().enumerate().find_map(|(k, u)| {
            let values: Vec<f64> = (0..axes.len()).map(|i| u[i]).collect();
            self.range.beyond(&values).map(|(i, v)| (k, i, v))
        })?;
        Some(format!(
            "command {k} holds {} {} on axis '{}', beyond {} ([{}, {}]): {consequence}; in the robot's units?",
            Short(v),
            axes[i].unit,
            axes[i].command_column,
            self.what,
            Short(self.range.min[i]),
            Short(self.range.max[i])
        ))
    }

    /// Notes when the start's measured inputs (`measured`, given as `wheels_flag`) lie
    /// beyond the known inputs, or its body velocity (`velocity`, given as
    /// `velocity_flag`) beyond twice the fastest those inputs drive the vehicle: a start no
    /// data showed, from which the model's state runs wherever its dynamics take it (a
    /// wheel at 1e6 rad/s: 1e7 m in two seconds).
    pub fn start_notes(
        &self,
        robot: &RobotDescription,
        measured: Input,
        velocity: Option<[f64; 2]>,
        wheels_flag: &str,
        velocity_flag: &str,
    ) -> Vec<String> {
        let mut notes = Vec::new();
        let axes = robot.vehicle.axes();
        let values: Vec<f64> = (0..axes.len()).map(|i| measured[i]).collect();
        if let Some((i, v)) = self.range.beyond(&values) {
            notes.push(format!(
                "{wheels_flag} holds {} {} on axis '{}', beyond {} ([{}, {}]): a start no data showed; in the robot's units?",
                Short(v),
                axes[i].unit,
                axes[i].measured_column,
                self.what,
                Short(self.range.min[i]),
                Short(self.range.max[i])
            ));
        }
        if let Some([vx, vy]) = velocity {
            let (fastest, _) = self.fastest(robot);
            let speed = vx.hypot(vy);
            if fastest.is_finite() && fastest > 0.0 && speed > 2.0 * fastest {
                notes.push(format!(
                    "{velocity_flag} is {} m/s, over twice the fastest {} drive the vehicle ({} m/s): a start no data showed; in m/s?",
                    Short(speed),
                    self.what,
                    Short(fastest)
                ));
            }
        }
        notes
    }

    /// A note when a start's yaw rate (`yaw_rate`, given as `flag`) is over twice the
    /// fastest the known inputs turn the vehicle: a start no data showed (a yaw rate of 50
    /// rad/s, or one in deg/s, was taken without a word).
    ///
    /// ```
    /// use drive_models::known_inputs::KnownInputs;
    /// use drive_models::model_file::CommandRange;
    /// let robot = drive_traits::RobotDescription {
    ///     name: "r".into(),
    ///     robot: "husky".into(),
    ///     rate_hz: 20.0,
    ///     window_len: 40,
    ///     vehicle: std::sync::Arc::new(drive_models::DifferentialDrive::new(0.165, 0.55)),
    ///     position_frame: Default::default(),
    ///     terrain: String::new(),
    ///     registered_robot: String::new(),
    /// };
    /// let known = KnownInputs {
    ///     range: CommandRange { min: vec![-5.0, -5.0], max: vec![5.0, 5.0] },
    ///     what: "the commands it was trained on",
    ///     saturates: true,
    /// };
    /// // Its fastest turn: 5 rad/s on opposite wheels of 0.165 m, 0.55 m apart, 3 rad/s.
    /// assert!(known.yaw_rate_note(&robot, 5.9, "--start-yaw-rate").is_none());
    /// assert!(known.yaw_rate_note(&robot, -6.1, "--start-yaw-rate").is_some());
    /// ```
    pub fn yaw_rate_note(
        &self,
        robot: &RobotDescription,
        yaw_rate: f64,
        flag: &str,
    ) -> Option<String> {
        let (_, fastest) = self.fastest(robot);
        (fastest.is_finite() && fastest > 0.0 && yaw_rate.abs() > 2.0 * fastest).then(|| {
            format!(
                "{flag} is {} rad/s, over twice the fastest {} turn the vehicle ({} rad/s): a start no data showed; in rad/s?",
                Short(yaw_rate),
                self.what,
                Short(fastest)
            )
        })
    }

    /// The fastest the known inputs drive the body (m/s) and turn it (rad/s): over the
    /// corners of their box.
    fn fastest(&self, robot: &RobotDescription) -> (f64, f64) {
        let n = robot.vehicle.axes().len();
        (0..1usize << n)
            .map(|corner| {
                let u = Input::from_fn(|i, _| {
                    if i >= n {
                        0.0
                    } else if corner >> i & 1 == 1 {
                        self.range.max[i]
                    } else {
                        self.range.min[i]
                    }
                });
                let b = robot.vehicle.body_velocity(&u);
                (b.x.hypot(b.y), b.z.abs())
            })
            .fold((0.0, 0.0), |(v, w), (a, b)| {
                (f64::max(v, a), f64::max(w, b))
            })
    }

    /// A note when the predicted `poses` (steps `dt` apart) move faster than ten times the
    /// fastest the known inputs drive the vehicle (a model file whose weights were edited
    /// to 1e8 went 25,000 km in two seconds without a word): no robot moves so, whatever
    /// its ground.
    pub fn speed_note(&self, robot: &RobotDescription, dt: f64, poses: &[Pose]) -> Option<String> {
        let (fastest, turning) = self.fastest(robot);
        if !(fastest.is_finite() && turning.is_finite() && dt > 0.0) {
            return None;
        }
        let (k, value, unit, most, how) = poses.windows(2).enumerate().find_map(|(k, p)| {
            let speed = (p[1].x - p[0].x).hypot(p[1].y - p[0].y) / dt;
            // The predicted yaw runs on unwrapped (a turn of 1e6 rad is no small one).
            let rate = (p[1].z - p[0].z).abs() / dt;
            if fastest > 0.0 && speed > 10.0 * fastest {
                Some((k + 1, speed, "m/s", fastest, "drive"))
            } else if turning > 0.0 && rate > 10.0 * turning {
                Some((k + 1, rate, "rad/s", turning, "turn"))
            } else {
                None
            }
        })?;
        Some(format!(
            "the model predicts {} {unit} at step {k}, over ten times the fastest the inputs it knows {how} the vehicle ({} {unit}): no robot moves so; a model file edited, or fitted on data in other units?",
            Short(value),
            Short(most)
        ))
    }
}
