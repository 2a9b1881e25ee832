//! Simulated UGVs to run the DRIVE protocol without a robot: a skid-steer rigid body for
//! the `differential` vehicle, a dynamic bicycle for the `ackermann` car ([`car`]), and a
//! kinematic stand-in for any other vehicle ([`Plant`]s registered by vehicle type).
//!
//! The ground truth is deliberately not the slip-BLR model family: a planar rigid body with
//! mass and yaw inertia touching the ground at discrete contact points, each with a
//! combined-slip friction force on a friction ellipse ([`contact_force`]: the Janosi-Hanamoto
//! shear curve of the slip, traction along the wheel, lateral friction across it), so that
//! turning scrubs the wheels sideways; rolling resistance; torque-limited motors in a
//! velocity loop with rising and falling time constants and a dead time, behind an optional
//! low-level controller with body-velocity gains, caps and acceleration limits
//! ([`ControllerParams`]); a ground whose grip can vary in time ([`Variability`]) and that
//! can hold a turn at its start ([`TurnStall`]); sensors
//! as on the real robots (encoder noise, ICP poses at 10 Hz with noise, latency, jitter and
//! a mount on the body, an IMU with noise and bias). Terrain presets `tile`, `gravel`,
//! `snow`, `ice` (see [`Terrain`]), or a twin of a real robot fitted on its data
//! ([`sim_fit`], with the protocol its run followed: [`TwinProtocol`]).
//!
//! [`simulate`] runs the protocol runner in the loop with the simulator and records the
//! same windows as the real data, so every loader, model and metric works on it unchanged.

#![warn(missing_docs)]

pub mod car;
mod fit;
mod omni;
mod parameters;
mod plant;
mod run;
mod sensors;
mod sim;
mod stall;
mod terrain;
mod twin;
mod vehicle;

pub use car::{step_car, Actuator, CarParams, CarSimulator, CarState};
pub use fit::{
    check_any_vehicle_run, check_real_run, command_scatter, fit_any_vehicle, scatter, sim_fit,
    sim_fit_with_contact_spread, speeds_kept, AnyVehicleFit, AnyVehicleFitReport, Scatter,
    ScatterFit, SimFit, SimFitError, SimFitReport, TurnStallFit,
};
pub use omni::OmniPlant;
pub use parameters::{
    fitted_parameters, fitted_parameters_within, FittedParameter, CONTACT_SPREAD_CHOICES,
};
pub use plant::{
    builtin_plants, plant_for, reads_ground_only, simulator_of, simulator_used, KinematicPlant,
    MakePlant, Plant, PlantError, SimulatorUsed,
};
pub use run::{simulate, Event, SimError, Simulation, SimulationConfig};
pub use sensors::{Instruments, Sensors, ICP_GAP_BINS, ICP_GAP_STEP_S};
pub use sim::{Measured, Simulator};
pub use stall::{TurnStall, CONTINUING_TURN};
pub use terrain::{
    builtin_terrains, FittedVehicle, Terrain, TerrainError, Variability, MAX_CONTACT_SPREAD,
    MIN_CONTACT_SPREAD,
};
pub use twin::{replay_commands, scale_difference, ProtocolSampler, TwinProtocol};
pub use vehicle::{
    contact_force, step_body, ControllerParams, PowertrainParams, VehicleParams, VehicleState,
};
