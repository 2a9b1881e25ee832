//! Every registry of parts, in one place: what the experiments, the command line and a
//! researcher's own program take.

use drive_control::{builtin_controllers, MakeController};
use drive_models::registry::{
    builtin_aliases, builtin_baselines, builtin_powertrains, builtin_slip_learners,
    builtin_vehicles,
};
use drive_models::{ModelAlias, ModelSpec, Models};
use drive_samplers::{builtin_robots, builtin_samplers, MakeSampler, RobotError, RobotSpec};
use drive_sim::{builtin_plants, builtin_terrains, MakePlant, Terrain, TerrainError};
use drive_traits::{Baseline, CommandModel, FitPowertrain, FitSlip, Registry, RegistryError};
use serde::Serialize;

/// The registries of every kind of part, one [`Registry`] each.
///
/// A researcher's part is one `register` call away from every experiment and from the
/// whole `drive` command line:
///
/// ```
/// use drive_studies::Registries;
/// use drive_models::powertrain::Fopdt;
/// use std::sync::Arc;
/// let mut r = Registries::builtin();
/// // The FOPDT with a shorter search range, as a powertrain of its own.
/// r.powertrains
///     .register("fopdt-short", "FOPDT, time constants up to 2 s", Arc::new(Fopdt { max_time_constant: 2.0, ..Fopdt::default() }))
///     .unwrap();
/// assert_eq!(r.models().resolve("slip-blr+fopdt-short").unwrap().canonical(), "slip-blr+fopdt-short");
/// assert!(r.models().all().len() >= 12);
/// ```
#[derive(Clone)]
pub struct Registries {
    /// Vehicles (by the type name their sidecars and robot files give).
    pub vehicles: Registry<dyn CommandModel>,
    /// Powertrain learners.
    pub powertrains: Registry<dyn FitPowertrain>,
    /// Slip learners.
    pub slip_learners: Registry<dyn FitSlip>,
    /// Whole-model baselines.
    pub baselines: Registry<dyn Baseline>,
    /// Model names that stand for others (the paper's `naive`, `powertrain`).
    pub aliases: Registry<ModelAlias>,
    /// Input samplers of the protocol.
    pub samplers: Registry<dyn MakeSampler>,
    /// Terrains of the simulator.
    pub terrains: Registry<Terrain>,
    /// Robot presets.
    pub robots: Registry<RobotSpec>,
    /// Simulated plants by vehicle type (a vehicle without one gets the kinematic plant).
    pub simulators: Registry<dyn MakePlant>,
    /// Controllers of the closed loop (`drive track`).
    pub controllers: Registry<dyn MakeController>,
}

impl std::fmt::Debug for Registries {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Registries")
            .field("vehicles", &self.vehicles.names())
            .field("powertrains", &self.powertrains.names())
            .field("slip_learners", &self.slip_learners.names())
            .field("baselines", &self.baselines.names())
            .field("samplers", &self.samplers.names())
            .field("terrains", &self.terrains.names())
            .field("robots", &self.robots.names())
            .field("controllers", &self.controllers.names())
            .finish()
    }
}

impl Default for Registries {
    fn default() -> Self {
        Self::builtin()
    }
}

impl Registries {
    /// The project's parts.
    pub fn builtin() -> Self {
        Registries {
            vehicles: builtin_vehicles(),
            powertrains: builtin_powertrains(),
            slip_learners: builtin_slip_learners(),
            baselines: builtin_baselines(),
            aliases: builtin_aliases(),
            samplers: builtin_samplers(std::sync::Arc::new(
                drive_models::slip::SlipBlrLeverage::default(),
            )),
            terrains: builtin_terrains(),
            robots: builtin_robots(),
            simulators: builtin_plants(),
            controllers: builtin_controllers(),
        }
    }

    /// The model-part registries, to resolve model names.
    pub fn models(&self) -> Models<'_> {
        Models {
            powertrains: &self.powertrains,
            slip_learners: &self.slip_learners,
            baselines: &self.baselines,
            aliases: &self.aliases,
        }
    }

    /// Resolves a model name (see [`Models::resolve`]).
    pub fn model(&self, name: &str) -> Result<ModelSpec, RegistryError> {
        self.models().resolve(name)
    }

    /// A registered robot, or a robot TOML file.
    pub fn robot(&self, name_or_path: &str) -> Result<RobotSpec, RobotError> {
        RobotSpec::load(&self.robots, name_or_path)
    }

    /// A registered terrain, or a terrain TOML file (a twin written by `drive sim-fit`).
    pub fn terrain(&self, name_or_path: &str) -> Result<Terrain, TerrainError> {
        Terrain::load(&self.terrains, name_or_path)
    }

    /// Asks typetag about the saved tag of every registered part: an error for a tag that
    /// another linked type also uses (neither could be loaded from a file) or that no type
    /// is saved under, for a vehicle, powertrain or slip learner registered under another
    /// name than its (fitted model's) tag, and for a simulator registered for a vehicle that
    /// is not. The command line checks this before
    /// it runs.
    ///
    /// ```
    /// use drive_studies::Registries;
    /// use std::sync::Arc;
    /// let mut r = Registries::builtin();
    /// assert!(r.check_tags().is_ok());
    /// // The differential drive once more, under a name that is not its tag.
    /// let husky = r.robot("husky").unwrap();
    /// r.vehicles.register("skid", "the same vehicle", Arc::from(husky.vehicle.clone_box())).unwrap();
    /// let e = r.check_tags().unwrap_err().to_string();
    /// assert!(e.contains("registered as 'skid'") && e.contains("'differential'"), "{e}");
    /// // A simulator for a vehicle that is not registered.
    /// let mut r = Registries::builtin();
    /// let plant = r.simulators.find("differential").unwrap().part().clone();
    /// r.simulators.register("tank", "a simulator of nothing registered", plant).unwrap();
    /// let e = r.check_tags().unwrap_err().to_string();
    /// assert!(e.contains("simulator is registered for the vehicle 'tank'"), "{e}");
    /// ```
    pub fn check_tags(&self) -> Result<(), RegistryError> {
        // One identity per vehicle: the name it is registered and looked up under is the
        // tag its files are saved with, and a simulator is for a registered vehicle.
        for e in self.vehicles.entries() {
            if let Some(tag) = drive_traits::vehicle_tag(e.part().as_ref()) {
                if tag != e.name() {
                    return Err(RegistryError::NameIsNotTag {
                        kind: "vehicle",
                        name: e.name().to_string(),
                        tag,
                    });
                }
            }
        }
        // A learner's name is its fitted model's tag, so that a model is called the same
        // (`slip+powertrain`) by the command line, by `Composed::new` and in its files.
        let learners = self
            .powertrains
            .entries()
            .iter()
            .map(|e| ("powertrain", e.name(), e.tag()))
            .chain(
                self.slip_learners
                    .entries()
                    .iter()
                    .map(|e| ("slip learner", e.name(), e.tag())),
            );
        for (kind, name, tag) in learners {
            if let Some(tag) = tag.filter(|t| t.tag != name) {
                return Err(RegistryError::NameIsNotTag {
                    kind,
                    name: name.to_string(),
                    tag: tag.tag.clone(),
                });
            }
        }
        for e in self.simulators.entries() {
            if self.vehicles.find(e.name()).is_none() {
                return Err(RegistryError::Orphan {
                    kind: "simulator",
                    of: "vehicle",
                    name: e.name().to_string(),
                    known: self
                        .vehicles
                        .entries()
                        .iter()
                        .map(|v| v.name())
                        .collect::<Vec<_>>()
                        .join(", "),
                });
            }
        }
        self.vehicles.check_tags()?;
        self.powertrains.check_tags()?;
        self.slip_learners.check_tags()?;
        self.baselines.check_tags()
    }

    /// `Err` when `vehicle` (read from a data sidecar or a model file) is not a registered
    /// vehicle: a part is looked up under its tag, never used unregistered (its simulator,
    /// its listing and its name would be another part's or none).
    ///
    /// ```
    /// use drive_studies::Registries;
    /// let r = Registries::builtin();
    /// let husky = r.robot("husky").unwrap();
    /// assert!(r.check_vehicle(husky.vehicle.as_ref()).is_ok());
    /// let mut without = Registries::builtin();
    /// without.vehicles = drive_traits::Registry::new("vehicle");
    /// without.simulators = drive_traits::Registry::new("simulator");
    /// let e = without.check_vehicle(husky.vehicle.as_ref()).unwrap_err().to_string();
    /// assert!(e.contains("unknown vehicle 'differential'"), "{e}");
    /// ```
    pub fn check_vehicle(&self, vehicle: &dyn CommandModel) -> Result<(), RegistryError> {
        match drive_traits::vehicle_tag(vehicle) {
            Some(tag) => self.vehicles.get(&tag).map(|_| ()),
            None => Ok(()),
        }
    }

    /// Every registered part, for listing (`drive list`).
    pub fn catalog(&self) -> Catalog {
        let plain = |names: Vec<(&str, &str)>| -> Vec<Listed> {
            names
                .into_iter()
                .map(|(n, d)| Listed {
                    name: n.to_string(),
                    description: d.to_string(),
                    ..Listed::default()
                })
                .collect()
        };
        fn pairs<T: ?Sized>(r: &Registry<T>) -> Vec<(&str, &str)> {
            r.entries()
                .iter()
                .map(|e| (e.name(), e.description()))
                .collect()
        }
        let mut learners = Vec::new();
        for e in self.aliases.entries() {
            learners.push(Listed {
                name: e.name().to_string(),
                description: e.description().to_string(),
                kind: Some("alias".into()),
                means: Some(e.part().target.clone()),
                ..Listed::default()
            });
        }
        for e in self.slip_learners.entries() {
            learners.push(Listed {
                name: e.name().to_string(),
                description: e.description().to_string(),
                kind: Some("slip".into()),
                default_powertrain: Some(drive_models::registry::DEFAULT_POWERTRAIN.into()),
                ..Listed::default()
            });
        }
        for e in self.baselines.entries() {
            learners.push(Listed {
                name: e.name().to_string(),
                description: e.description().to_string(),
                kind: Some("baseline".into()),
                default_powertrain: e.part().default_powertrain().map(String::from),
                ..Listed::default()
            });
        }
        let axes_of = |v: &dyn CommandModel| {
            v.axes()
                .iter()
                .map(|a| format!("{} [{}]", a.name, a.unit))
                .collect::<Vec<_>>()
        };
        let robots = self
            .robots
            .entries()
            .iter()
            .map(|e| Listed {
                name: e.name().to_string(),
                description: e.description().to_string(),
                vehicle: drive_traits::vehicle_tag(e.part().vehicle.as_ref()),
                inputs: Some(e.part().vehicle.input_dim()),
                ..Listed::default()
            })
            .collect();
        let vehicles = self
            .vehicles
            .entries()
            .iter()
            .map(|e| Listed {
                name: e.name().to_string(),
                description: e.description().to_string(),
                inputs: Some(e.part().input_dim()),
                axes: Some(axes_of(e.part().as_ref())),
                ..Listed::default()
            })
            .collect();
        Catalog {
            vehicles,
            powertrains: plain(pairs(&self.powertrains)),
            learners,
            samplers: plain(pairs(&self.samplers)),
            terrains: plain(pairs(&self.terrains)),
            robots,
            simulators: plain(pairs(&self.simulators)),
            controllers: plain(pairs(&self.controllers)),
            models: self
                .models()
                .all()
                .iter()
                .map(ModelSpec::canonical)
                .collect(),
        }
    }
}

/// One listed part.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Listed {
    /// Registered name.
    pub name: String,
    /// One-line description.
    pub description: String,
    /// For a learner: `slip`, `baseline` or `alias`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kind: Option<String>,
    /// For a learner: the powertrain used when none is named.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub default_powertrain: Option<String>,
    /// For an alias: the model it stands for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub means: Option<String>,
    /// For a robot: its vehicle type.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vehicle: Option<String>,
    /// For a vehicle or a robot: its number of input axes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inputs: Option<usize>,
    /// For a vehicle: its input axes, `name [unit]`, in order.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub axes: Option<Vec<String>>,
}

/// Every registered part, by kind (what `drive list --json` prints).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Catalog {
    /// Vehicles.
    pub vehicles: Vec<Listed>,
    /// Powertrains.
    pub powertrains: Vec<Listed>,
    /// Learners: slip learners, baselines and the paper's model names.
    pub learners: Vec<Listed>,
    /// Samplers.
    pub samplers: Vec<Listed>,
    /// Terrains.
    pub terrains: Vec<Listed>,
    /// Robot presets, with their vehicle type.
    pub robots: Vec<Listed>,
    /// Simulated plants, by vehicle type.
    pub simulators: Vec<Listed>,
    /// Controllers of the closed loop.
    pub controllers: Vec<Listed>,
    /// Every model combination (`learner+powertrain`).
    pub models: Vec<String>,
}
