//! The one place where model names map to learners. [`LearnerRegistry::builtin`] holds the
//! project's learners; a researcher's own learner is one [`LearnerRegistry::register`] call
//! away from every comparison that takes a registry (`drive_eval::compare_with`, the
//! evaluation matrix).

use crate::learners::{AccBlr, Naive, PowertrainAware, SlipBlr};
use crate::powertrain::{Fopdt, Ideal};
use drive_traits::{FitError, Learner, MotionModel, WindowSet};
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use thiserror::Error;

/// The names of the built-in models, in the order the comparison reports them.
pub const MODEL_NAMES: [&str; 4] = ["naive", "powertrain", "slip-blr", "acc-blr"];

/// Where a learner's wheel velocities come from: the commands themselves (the ideal
/// powertrain, what the manufacturer assumes) or the fitted FOPDT of eq. 3.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PowertrainChoice {
    /// Commanded wheel velocities, reached at once ([`Ideal`]).
    Commanded,
    /// First-order plus dead time per side, fitted on the transient windows ([`Fopdt`], eq. 3).
    Fopdt,
}

impl PowertrainChoice {
    /// Every choice, in report order.
    pub const ALL: [PowertrainChoice; 2] = [PowertrainChoice::Commanded, PowertrainChoice::Fopdt];

    /// The name used on the command line and in sweep files.
    ///
    /// ```
    /// use drive_models::PowertrainChoice;
    /// assert_eq!(PowertrainChoice::parse("fopdt"), Some(PowertrainChoice::Fopdt));
    /// assert_eq!(PowertrainChoice::Commanded.name(), "commanded");
    /// ```
    pub fn name(self) -> &'static str {
        match self {
            PowertrainChoice::Commanded => "commanded",
            PowertrainChoice::Fopdt => "fopdt",
        }
    }

    /// The choice named `name`; `None` for an unknown name.
    pub fn parse(name: &str) -> Option<PowertrainChoice> {
        Self::ALL.into_iter().find(|c| c.name() == name)
    }
}

/// Why a registration was refused.
#[derive(Debug, Error, PartialEq)]
pub enum RegistryError {
    /// The name is already registered.
    #[error("a learner named '{0}' is already registered")]
    Duplicate(String),
    /// The name is empty or holds characters that break the CSV and command-line lists.
    #[error("'{0}' is not a usable learner name (non-empty; letters, digits, '-' and '_')")]
    BadName(String),
}

type FitFn = dyn Fn(&WindowSet<'_>, PowertrainChoice) -> Result<Box<dyn MotionModel>, FitError>
    + Send
    + Sync;

/// One registered learner.
#[derive(Clone)]
pub struct LearnerEntry {
    name: String,
    default_powertrain: Option<PowertrainChoice>,
    fit: Arc<FitFn>,
}

impl LearnerEntry {
    /// The registered name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// The powertrain used when none is asked for; `None` for a learner without a
    /// powertrain (the naive model, a user's learner registered with
    /// [`LearnerRegistry::register`]).
    pub fn default_powertrain(&self) -> Option<PowertrainChoice> {
        self.default_powertrain
    }
    /// Whether the learner is built on a powertrain (and so gives a different model per
    /// [`PowertrainChoice`]).
    pub fn uses_powertrain(&self) -> bool {
        self.default_powertrain.is_some()
    }
    /// Fits the learner with `powertrain` (ignored by a learner without one; its default
    /// when `None`).
    pub fn fit(
        &self,
        train: &WindowSet<'_>,
        powertrain: Option<PowertrainChoice>,
    ) -> Result<Box<dyn MotionModel>, FitError> {
        let choice = powertrain
            .or(self.default_powertrain)
            .unwrap_or(PowertrainChoice::Commanded);
        (self.fit)(train, choice)
    }
}

impl std::fmt::Debug for LearnerEntry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LearnerEntry")
            .field("name", &self.name)
            .field("default_powertrain", &self.default_powertrain)
            .finish_non_exhaustive()
    }
}

fn boxed<L: Learner>(learner: &L, train: &WindowSet<'_>) -> Result<Box<dyn MotionModel>, FitError> {
    learner
        .fit(train)
        .map(|m| Box::new(m) as Box<dyn MotionModel>)
}

/// Learners by name, in registration order.
///
/// ```
/// use drive_models::{LearnerRegistry, PowertrainChoice};
/// use drive_models::learners::Naive;
/// let mut registry = LearnerRegistry::builtin();
/// // A researcher's learner joins every comparison with one line (here the naive model again).
/// registry.register("my-naive", Naive).unwrap();
/// assert_eq!(registry.names(), ["naive", "powertrain", "slip-blr", "acc-blr", "my-naive"]);
/// assert!(registry.register("naive", Naive).is_err()); // names are unique
/// assert_eq!(registry.get("slip-blr").unwrap().default_powertrain(), Some(PowertrainChoice::Fopdt));
/// ```
#[derive(Clone, Debug, Default)]
pub struct LearnerRegistry {
    entries: Vec<LearnerEntry>,
}

impl LearnerRegistry {
    /// A registry with no learner.
    pub fn empty() -> Self {
        Self::default()
    }

    /// The project's learners: `naive` (eq. 4 on the commands), `powertrain` (eq. 3 + 4),
    /// `slip-blr` (eq. 3-7) and `acc-blr` (the acceleration baseline). The last three
    /// run on either powertrain; `powertrain` and `slip-blr` default to the FOPDT as in the
    /// paper, `acc-blr` to the commands as in McKinnon and Schoellig.
    pub fn builtin() -> Self {
        use PowertrainChoice::{Commanded, Fopdt as OnFopdt};
        let mut r = Self::empty();
        let fresh = "the built-in names are distinct and well formed";
        r.register("naive", Naive).expect(fresh);
        r.register_on_powertrain(
            "powertrain",
            OnFopdt,
            PowertrainAware { powertrain: Ideal },
            PowertrainAware::<Fopdt>::default(),
        )
        .expect(fresh);
        r.register_on_powertrain(
            "slip-blr",
            OnFopdt,
            SlipBlr::<Fopdt>::default().with_powertrain(Ideal),
            SlipBlr::<Fopdt>::default(),
        )
        .expect(fresh);
        r.register_on_powertrain(
            "acc-blr",
            Commanded,
            AccBlr::<Ideal>::default(),
            AccBlr::<Ideal>::default().with_powertrain(Fopdt::default()),
        )
        .expect(fresh);
        r
    }

    fn push(
        &mut self,
        name: &str,
        default_powertrain: Option<PowertrainChoice>,
        fit: Arc<FitFn>,
    ) -> Result<&mut Self, RegistryError> {
        let usable = !name.is_empty()
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
        if !usable {
            return Err(RegistryError::BadName(name.to_string()));
        }
        if self.get(name).is_some() {
            return Err(RegistryError::Duplicate(name.to_string()));
        }
        self.entries.push(LearnerEntry {
            name: name.to_string(),
            default_powertrain,
            fit,
        });
        Ok(self)
    }

    /// Registers a learner that has no powertrain option (it fits the same way whatever
    /// [`PowertrainChoice`] a comparison asks for).
    pub fn register<L>(&mut self, name: &str, learner: L) -> Result<&mut Self, RegistryError>
    where
        L: Learner + Send + Sync + 'static,
    {
        self.push(name, None, Arc::new(move |train, _| boxed(&learner, train)))
    }

    /// Registers a learner built on a powertrain, as its configuration on the commanded
    /// wheel velocities and on the fitted FOPDT; `default` is used when a comparison asks for
    /// no powertrain in particular.
    pub fn register_on_powertrain<A, B>(
        &mut self,
        name: &str,
        default: PowertrainChoice,
        on_commands: A,
        on_fopdt: B,
    ) -> Result<&mut Self, RegistryError>
    where
        A: Learner + Send + Sync + 'static,
        B: Learner + Send + Sync + 'static,
    {
        self.push(
            name,
            Some(default),
            Arc::new(move |train, choice| match choice {
                PowertrainChoice::Commanded => boxed(&on_commands, train),
                PowertrainChoice::Fopdt => boxed(&on_fopdt, train),
            }),
        )
    }

    /// The entry registered under `name`.
    pub fn get(&self, name: &str) -> Option<&LearnerEntry> {
        self.entries.iter().find(|e| e.name == name)
    }

    /// The registered names, in registration order.
    pub fn names(&self) -> Vec<&str> {
        self.entries.iter().map(|e| e.name.as_str()).collect()
    }

    /// Every entry, in registration order.
    pub fn entries(&self) -> &[LearnerEntry] {
        &self.entries
    }

    /// Fits the learner registered under `name` (see [`LearnerEntry::fit`]); `None` for an
    /// unknown name.
    pub fn fit(
        &self,
        name: &str,
        train: &WindowSet<'_>,
        powertrain: Option<PowertrainChoice>,
    ) -> Option<Result<Box<dyn MotionModel>, FitError>> {
        Some(self.get(name)?.fit(train, powertrain))
    }
}

/// Fits the built-in model registered under `name` with its default configuration; `None`
/// for an unknown name.
///
/// ```no_run
/// # fn demo(train: &drive_traits::WindowSet<'_>) {
/// let model = drive_models::fit_named("slip-blr", train).expect("a registered name").unwrap();
/// assert_eq!(model.name(), "slip-blr");
/// # }
/// ```
pub fn fit_named(
    name: &str,
    train: &WindowSet<'_>,
) -> Option<Result<Box<dyn MotionModel>, FitError>> {
    LearnerRegistry::builtin().fit(name, train, None)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learners::Naive;

    #[test]
    fn names_are_unique_and_well_formed() {
        let mut r = LearnerRegistry::builtin();
        assert_eq!(r.names(), MODEL_NAMES);
        assert_eq!(
            r.register("slip-blr", Naive).unwrap_err(),
            RegistryError::Duplicate("slip-blr".into())
        );
        for bad in ["", "a,b", "with space", "a/b"] {
            assert_eq!(
                r.register(bad, Naive).unwrap_err(),
                RegistryError::BadName(bad.into())
            );
        }
        assert!(r.register("my_model-2", Naive).is_ok());
        assert!(r.get("my_model-2").is_some_and(|e| !e.uses_powertrain()));
    }

    #[test]
    fn default_powertrains_follow_the_paper() {
        let r = LearnerRegistry::builtin();
        let default = |n| r.get(n).unwrap().default_powertrain();
        assert_eq!(default("naive"), None);
        assert_eq!(default("powertrain"), Some(PowertrainChoice::Fopdt));
        assert_eq!(default("slip-blr"), Some(PowertrainChoice::Fopdt));
        assert_eq!(default("acc-blr"), Some(PowertrainChoice::Commanded));
    }
}
