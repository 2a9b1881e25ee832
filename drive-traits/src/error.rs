use thiserror::Error;

/// Why a learner or a powertrain could not be fitted on the data it was given.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum FitError {
    /// The training set holds no window at all.
    #[error("the training set is empty")]
    EmptyTrainingSet,
    /// The powertrain fit needs transient windows (Sec. III-A) and there are none.
    #[error("no transient window in the training set: the powertrain (eq. 3) is fitted on transient windows")]
    NoTransientWindow,
    /// Fewer usable samples than parameters to learn.
    #[error("{what}: {samples} usable samples for {parameters} parameters")]
    TooFewSamples {
        /// what was being fitted
        what: String,
        /// usable samples
        samples: usize,
        /// parameters to learn
        parameters: usize,
    },
    /// A regression input carries no information (zero variance) or repeats another one.
    #[error(
        "{what}: the inputs are degenerate ({detail}); the training data does not excite them"
    )]
    DegenerateInputs {
        /// what was being fitted
        what: String,
        /// which input, and how
        detail: String,
    },
    /// A hyperparameter of the configuration is out of its valid range.
    #[error("invalid hyperparameter {name} = {value}: {expected}")]
    InvalidHyperparameter {
        /// name of the hyperparameter
        name: &'static str,
        /// value given
        value: f64,
        /// what is expected
        expected: &'static str,
    },
    /// A part the fit uses is invalid (a vehicle's own slip basis of unsupported
    /// dimensions, ...).
    #[error("{0}")]
    InvalidPart(String),
    /// The numerical optimizer failed.
    #[error("{what}: the optimizer failed: {reason}")]
    Optimizer {
        /// what was being fitted
        what: String,
        /// the optimizer's message
        reason: String,
    },
    /// The fit produced a non-finite parameter (never returned as a model).
    #[error("{what}: the fit produced a non-finite value")]
    NonFinite {
        /// what was being fitted
        what: String,
    },
}

/// Why a motion model could not produce the asked prediction.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MotionError {
    /// The model gives no uncertainty (a model without a probabilistic slip model is
    /// deterministic).
    #[error("the {model} model does not predict an uncertainty")]
    NoUncertainty {
        /// model name
        model: String,
    },
    /// The buffers of a batch prediction do not have matching lengths.
    #[error("batch shape: {sequences} start states and a horizon of {horizon} need {expected} commands and {expected} poses, got {commands} commands and {poses} poses")]
    BatchShape {
        /// number of start states (sequences)
        sequences: usize,
        /// steps per sequence
        horizon: usize,
        /// sequences x horizon
        expected: usize,
        /// commands given
        commands: usize,
        /// pose slots given
        poses: usize,
    },
    /// A stepped state's buffer does not hold the stepper's number of values
    /// ([`crate::step::Stepper::state_len`] per state).
    #[error(
        "state shape: the stepper's states hold {expected} numbers, the buffer given holds {found}"
    )]
    StateShape {
        /// numbers expected
        expected: usize,
        /// numbers given
        found: usize,
    },
    /// A command history given to a model stepped by replay, which predicts from the start
    /// alone ([`crate::step::ReplayStepper`]).
    #[error("the {model} model is stepped by replaying its prediction, which takes no command history: give history=[] (or implement its stepper)")]
    NoHistory {
        /// model name
        model: String,
    },
    /// A state stepped by replay holds every command so far, up to a number of steps.
    #[error("the {model} model is stepped by replay, whose states hold at most {max_steps} steps (raise max_steps, or start a new state)")]
    ReplayFull {
        /// model name
        model: String,
        /// the states' capacity
        max_steps: usize,
    },
    /// A prediction that is not a finite number: a start state or commands beyond what the
    /// model can integrate (never returned as poses).
    #[error("the prediction is not a finite number from step {step} (t = {} s): the start state or the commands are beyond what {model} can integrate", crate::limits::Short(*t))]
    NotFinite {
        /// model name
        model: String,
        /// the first step whose prediction is not finite
        step: usize,
        /// its time from the start (s)
        t: f64,
    },
}

impl MotionError {
    /// The error for `poses` predicted by `model` (with their covariances, when given) if
    /// some value is not a finite number; `None` when all are.
    ///
    /// ```
    /// use drive_traits::{MotionError, Pose};
    /// let poses = [Pose::zeros(), Pose::new(f64::NAN, 0.0, 0.0)];
    /// let e = MotionError::not_finite("naive", 0.05, &poses, &[]).unwrap();
    /// assert!(e.to_string().starts_with("the prediction is not a finite number from step 1 (t = 0.05 s)"));
    /// assert!(MotionError::not_finite("naive", 0.05, &poses[..1], &[]).is_none());
    /// ```
    pub fn not_finite(
        model: &str,
        dt: f64,
        poses: &[crate::Pose],
        covariances: &[crate::PoseCovariance],
    ) -> Option<MotionError> {
        let finite = |k: usize| {
            poses[k].iter().all(|v| v.is_finite())
                && covariances
                    .get(k)
                    .is_none_or(|c| c.iter().all(|v| v.is_finite()))
        };
        (0..poses.len())
            .find(|&k| !finite(k))
            .map(|step| MotionError::NotFinite {
                model: model.to_string(),
                step,
                t: step as f64 * dt,
            })
    }

    /// Checks the buffers of a batch prediction.
    pub fn check_batch(
        sequences: usize,
        horizon: usize,
        commands: usize,
        poses: usize,
    ) -> Result<(), MotionError> {
        let expected = sequences * horizon;
        if commands == expected && poses == expected {
            Ok(())
        } else {
            Err(MotionError::BatchShape {
                sequences,
                horizon,
                expected,
                commands,
                poses,
            })
        }
    }
}

/// A part (a vehicle, a powertrain, a slip model, a fitted model, a model's settings) whose
/// values cannot work, with what is wrong in words: what the parts' `check` methods return.
///
/// ```
/// use drive_traits::InvalidPart;
/// let e = InvalidPart::from("vehicle wheel_radius = -1 is not a positive length");
/// assert_eq!(e.to_string(), "vehicle wheel_radius = -1 is not a positive length");
/// ```
#[derive(Debug, Error, Clone, PartialEq, Eq)]
#[error("{0}")]
pub struct InvalidPart(pub String);

/// The characterization probes' results give the vehicle no input space (paper Sec. III-A):
/// what [`CommandModel::characterize`](crate::CommandModel::characterize) returns.
///
/// ```
/// use drive_traits::CharacterizationError;
/// let e = CharacterizationError::from(String::from("no probe moved the wheels"));
/// assert_eq!(e.to_string(), "no probe moved the wheels");
/// ```
#[derive(Debug, Error, Clone, PartialEq, Eq)]
#[error("{0}")]
pub struct CharacterizationError(pub String);

/// A name that is none of the ones known (a start, a frame, an uncertainty, a check's
/// commands), with the known ones in its message.
///
/// ```
/// use drive_traits::{StartInfo, UnknownName};
/// let e: UnknownName = StartInfo::parse("gps").unwrap_err();
/// assert!(e.to_string().contains("gps"));
/// ```
#[derive(Debug, Error, Clone, PartialEq, Eq)]
#[error("{0}")]
pub struct UnknownName(pub String);

macro_rules! from_message {
    ($($t:ident),*) => {$(
        impl From<String> for $t {
            fn from(message: String) -> Self {
                $t(message)
            }
        }
        impl From<&str> for $t {
            fn from(message: &str) -> Self {
                $t(message.to_string())
            }
        }
        /// The message.
        impl std::ops::Deref for $t {
            type Target = str;
            fn deref(&self) -> &str {
                &self.0
            }
        }
    )*};
}
from_message!(InvalidPart, CharacterizationError, UnknownName);
