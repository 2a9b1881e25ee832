//! The protocol runner in the loop with the simulator, recording DRIVE windows.

use crate::{plant_for, MakePlant, ProtocolSampler, Terrain};
use drive_data::{CalibState, RawRow};
use drive_models::DifferentialDrive;
use drive_samplers::{
    window_len, PauseReason, ProtocolRunner, RobotSpec, RunnerConfig, RunnerInput, RunnerState,
    SampleTag, StopReason, WINDOWS_PER_INTERVAL,
};
use drive_traits::{
    relative_pose, vehicle_as, Characterization, CommandModel, Dataset, Input, InputSampler,
    InputSpace, Phase, Pose, Registry, RobotDescription, Window,
};
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use std::sync::Arc;
use thiserror::Error;

/// Scripted events, to test the runner's safety behaviour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// The dead-man switch is released from `from` to `to` (s).
    DeadmanReleased {
        /// start (s)
        from: f64,
        /// end (s)
        to: f64,
    },
    /// The localization publishes nothing from `from` to `to` (s).
    LocalizationLost {
        /// start (s)
        from: f64,
        /// end (s)
        to: f64,
    },
}

/// A simulation run.
pub struct SimulationConfig {
    /// The robot.
    pub robot: RobotSpec,
    /// The ground.
    pub terrain: Terrain,
    /// Seed of the simulator's noise.
    pub seed: u64,
    /// The runner's configuration (its `max_duration_s` bounds the run).
    pub runner: RunnerConfig,
    /// Scripted events.
    pub events: Vec<Event>,
    /// Dataset name.
    pub name: String,
}

/// Why a simulation could not run.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SimError {
    /// Nothing bounds the run.
    #[error("the run needs a duration or a number of intervals")]
    Unbounded,
    /// The plant's state stopped being finite numbers (a geometry or rate far outside
    /// what its physics can integrate).
    #[error("simulating {robot}: the simulation diverged at t = {t:.2} s (its measurements are no longer finite numbers); check the robot's geometry, mass and rates")]
    Diverged {
        /// The robot.
        robot: String,
        /// When (s).
        t: f64,
    },
    /// The run would record more samples than `RunnerConfig::max_samples`.
    #[error("simulating {robot}: {limit}")]
    TooLong {
        /// The robot.
        robot: String,
        /// The limit and what to do.
        limit: drive_traits::limits::TooLarge,
    },
    /// The robot's vehicle cannot be simulated by the plant registered for it.
    #[error("simulating {robot}: {reason}")]
    Plant {
        /// The robot.
        robot: String,
        /// Why.
        reason: String,
    },
}

/// What a simulation produced.
#[derive(Debug)]
pub struct Simulation {
    /// The recorded windows (complete intervals only).
    pub dataset: Dataset,
    /// How the runner ended.
    pub stop: RunnerState,
    /// What the characterization found.
    pub characterization: Option<Characterization>,
    /// States the runner went through, with the time they started (s).
    pub states: Vec<(f64, RunnerState)>,
    /// The commands sent, one per tick.
    pub commands: Vec<Input>,
    /// What the DRIVE logger would have recorded, one row per tick (see
    /// [`drive_data::write_raw_log`]): `ros_time` with +-2 ms of jitter, `joy_switch` True
    /// while the dead-man switch is released, `calib_state` `calib` while an interval is
    /// driven (and during a dead-man pause), `idle` otherwise, the body command, the ICP
    /// pose held between its 10 Hz updates (and frozen while localization is lost).
    pub raw: Vec<RawRow>,
}

/// The logger's clock at the start of a simulated run (ns): 2024-07-10, as a real log.
const RAW_EPOCH_NS: i64 = 1_720_641_663_000_000_000;

struct Recorded {
    tag: SampleTag,
    command: Input,
    input: Input,
    pose: Pose,
    imu: f64,
}

/// Runs the protocol with the simulator in the loop: the plant registered in `plants` for
/// the robot's vehicle type (the [`KinematicPlant`](crate::KinematicPlant) for a vehicle
/// without one). `sampler` builds the input sampler over the characterized input space;
/// `converged(k)` is asked after every interval.
pub fn simulate(
    config: SimulationConfig,
    plants: &Registry<dyn MakePlant>,
    sampler: impl FnMut(InputSpace) -> Box<dyn InputSampler> + 'static,
    converged: Option<Box<dyn FnMut(usize) -> bool>>,
) -> Result<Simulation, SimError> {
    let max_s = match (config.runner.max_duration_s, config.runner.max_intervals) {
        (Some(d), _) => d,
        // Characterization (up to six probes) plus the intervals, with room for pauses.
        (None, Some(n)) => 6.0 * config.runner.characterization_s + 6.0 * n as f64 * 2.0 + 60.0,
        (None, None) => return Err(SimError::Unbounded),
    };
    let mut robot = config.robot.clone();
    // A twin samples what its real run sampled, in the protocol's geometry, without
    // characterizing; its commands step or ramp as the real run's did.
    let mut sampler: Box<dyn FnMut(InputSpace) -> Box<dyn InputSampler>> = Box::new(sampler);
    if let Some(why) = config
        .terrain
        .fitted_for
        .as_ref()
        .and_then(|f| f.refuses(robot.vehicle.as_ref()))
    {
        return Err(SimError::Plant {
            robot: robot.name.clone(),
            reason: format!("terrain '{}' cannot drive it: {why}", config.terrain.name),
        });
    }
    if let Some(p) = config.terrain.protocol {
        let nominal: DifferentialDrive = vehicle_as(robot.vehicle.as_ref()).ok_or_else(|| {
            SimError::Plant {
                robot: robot.name.clone(),
                reason: format!(
                    "terrain '{}' carries a twin's protocol, which is a differential drive's; this robot's vehicle is '{}'",
                    config.terrain.name,
                    robot.vehicle.typetag_name()
                ),
            }
        })?;
        if let Some(why) = p.refuses(nominal.wheel_radius, nominal.baseline) {
            return Err(SimError::Plant {
                robot: robot.name.clone(),
                reason: format!("terrain '{}' cannot drive it: {why}", config.terrain.name),
            });
        }
        robot.input_limits = p.space();
        robot.input_rate_limits = None;
        robot.max_linear_acceleration = p.max_linear_acceleration.unwrap_or(f64::INFINITY);
        robot.max_angular_acceleration = p.max_angular_acceleration.unwrap_or(f64::INFINITY);
        let gain = p.difference_gain(nominal.baseline);
        let geometry: Arc<dyn CommandModel> =
            Arc::new(DifferentialDrive::new(nominal.wheel_radius, p.baseline));
        let mut inner = sampler;
        let body_limits = p.body_limits;
        sampler = Box::new(move |space| {
            let s = ProtocolSampler::new(inner(space), gain, Arc::clone(&geometry));
            Box::new(match body_limits {
                Some(limits) => s.within(limits, nominal.clone()),
                None => s,
            })
        });
    }
    let samples = max_s * robot.rate_hz;
    drive_traits::limits::at_most(
        "the run's samples (duration x rate_hz)",
        samples,
        config.runner.max_samples as f64,
        "shorten the run (drive simulate raises the limit with --max-samples)",
    )
    .map_err(|limit| SimError::TooLong {
        robot: robot.name.clone(),
        limit,
    })?;
    let mut sim = plant_for(plants, &robot, &config.terrain, config.seed).map_err(|reason| {
        SimError::Plant {
            robot: robot.name.clone(),
            reason: reason.to_string(),
        }
    })?;
    let mut runner = ProtocolRunner::new(robot.clone(), config.runner.clone(), sampler);
    if let Some(c) = converged {
        runner = runner.with_convergence_check(c);
    }
    runner.start();
    let len = window_len(&robot);
    let description = RobotDescription {
        name: config.name.clone(),
        robot: format!("simulated {} on {}", robot.name, config.terrain.name),
        rate_hz: robot.rate_hz,
        window_len: len,
        vehicle: Arc::clone(&robot.vehicle),
        // Poses are re-based on the first sample of each window (position and yaw).
        position_frame: drive_traits::PositionFrame::FirstSample,
        terrain: config.terrain.name.clone(),
        registered_robot: String::new(),
    }
    .with_registered_robot(&robot.name);
    let active = |t: f64, kind: fn(&Event) -> Option<(f64, f64)>| {
        config
            .events
            .iter()
            .filter_map(kind)
            .any(|(a, b)| t >= a && t < b)
    };
    let mut windows: Vec<Window> = Vec::new();
    let mut buffer: Vec<Recorded> = Vec::new();
    let mut states = vec![(0.0, runner.state().clone())];
    let mut commands = Vec::new();
    let mut raw = Vec::new();
    let mut jitter = Xoshiro256PlusPlus::seed_from_u64(config.seed ^ 0x10C0_CAFE);
    let (mut icp_index, mut published, mut step, mut driven) = (0u64, None::<Pose>, 0usize, false);
    let ticks = (max_s * robot.rate_hz).ceil() as usize + 1;
    for _ in 0..ticks {
        let m = sim.measure();
        let finite = m.input.iter().chain(m.pose.iter()).all(|v| v.is_finite())
            && m.imu_yaw_rate.is_finite();
        if !finite {
            return Err(SimError::Diverged {
                robot: robot.name.clone(),
                t: m.t,
            });
        }
        let deadman = !active(m.t, |e| match e {
            Event::DeadmanReleased { from, to } => Some((*from, *to)),
            _ => None,
        });
        let lost = active(m.t, |e| match e {
            Event::LocalizationLost { from, to } => Some((*from, *to)),
            _ => None,
        });
        let input = RunnerInput {
            t: m.t,
            encoder: Some(m.input),
            pose: (m.fresh_pose && !lost).then_some(m.pose),
            deadman,
        };
        let out = runner.tick(&input);
        // `states` starts with the initial state, so it is never empty.
        let last = &states.last().expect("the initial state is recorded").1;
        if std::mem::discriminant(runner.state()) != std::mem::discriminant(last) {
            states.push((m.t, runner.state().clone()));
        }
        match out.sample {
            Some(tag) => {
                if tag.window == 0 && tag.k == 0 {
                    // A new or resumed interval: what an interrupted one recorded is dropped.
                    buffer.clear();
                }
                buffer.push(Recorded {
                    tag,
                    command: out.command,
                    input: m.input,
                    pose: m.pose,
                    imu: m.imu_yaw_rate,
                });
                if buffer.len() == WINDOWS_PER_INTERVAL * len {
                    let first = windows.len();
                    for chunk in buffer.chunks(len) {
                        windows.push(window_from(chunk, windows.len()));
                    }
                    buffer.clear();
                    runner.observe(&description, &windows[first..]);
                }
            }
            None => buffer.clear(),
        }
        // The logger's row of this tick.
        if m.fresh_pose && !lost {
            icp_index += 1;
            published = Some(m.pose);
        }
        // A dead-man pause while driving suspends the interval under way: the logger
        // keeps its calib_step with joy_switch True.
        let deadman_pause = match runner.state() {
            RunnerState::Paused {
                reason: PauseReason::DeadmanReleased,
                interval,
            } if driven => {
                step = *interval;
                true
            }
            _ => false,
        };
        if let Some(tag) = out.sample {
            step = tag.interval;
            driven = true;
        }
        let p = published.unwrap_or(m.pose);
        let body = robot.vehicle.body_velocity(&out.command);
        raw.push(RawRow {
            line: raw.len() + 2,
            time_ns: RAW_EPOCH_NS
                + (m.t * 1e9).round() as i64
                + jitter.random_range(-2_000_000..=2_000_000),
            joy_switch: !deadman,
            icp_index,
            calib_state: if out.sample.is_some() || deadman_pause {
                CalibState::Calib
            } else {
                CalibState::Idle
            },
            calib_step: step as u64,
            measured: m.input,
            body_command: [body.x, body.z],
            position: [p.x, p.y, 0.0],
            quaternion: [0.0, 0.0, (0.5 * p.z).sin(), (0.5 * p.z).cos()],
            imu_rate: [0.0, 0.0, m.imu_yaw_rate],
            extra: Vec::new(),
        });
        commands.push(out.command);
        if matches!(runner.state(), RunnerState::Done(_)) {
            break;
        }
        sim.advance(out.command);
    }
    let stop = match runner.state() {
        RunnerState::Done(_) => runner.state().clone(),
        _ => RunnerState::Done(StopReason::Duration),
    };
    let mut dataset = Dataset {
        robot: description,
        windows,
    };
    dataset.link_start_velocities();
    Ok(Simulation {
        dataset,
        stop,
        characterization: runner.characterization(),
        states,
        commands,
        raw,
    })
}

/// A window from its samples: poses re-based to the window's first (measured) pose, in the
/// body frame at the window start.
fn window_from(samples: &[Recorded], index: usize) -> Window {
    let p0 = samples[0].pose;
    let tag = samples[0].tag;
    Window::new(
        index,
        tag.interval,
        if tag.window == 0 {
            Phase::Transient
        } else {
            Phase::Steady
        },
        samples.iter().map(|r| r.command).collect(),
        samples.iter().map(|r| r.input).collect(),
        samples
            .iter()
            .map(|r| relative_pose(&p0, &r.pose))
            .collect(),
        samples.iter().map(|r| r.imu).collect(),
    )
}
