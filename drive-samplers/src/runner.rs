//! The protocol runner: the state machine a robot driver (a ROS 2 node, say) wraps. At each
//! command tick it takes the measurements and returns the command to send.
//!
//! States: idle, characterizing (step 1: the vehicle's probes, by default high
//! longitudinal commands both ways, and for a differential drive a turn in place, to find
//! the true input space and, with localization, the effective geometry), driving interval
//! k (step 2), paused (watchdog or dead-man switch), done (intervals, duration, geofence,
//! convergence, or a characterization that found no usable input space).

use crate::{next_command, window_len, RobotSpec, SentCommand, WINDOWS_PER_INTERVAL};
use drive_traits::{
    wrap_angle, Characterization, Input, InputSampler, InputSpace, Phase, Pose, Probe, ProbeMotion,
    ProbeResult, RobotDescription, Window,
};

/// What the robot measured at this tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunnerInput {
    /// Time (s).
    pub t: f64,
    /// New encoder wheel velocities, if any arrived since the last tick.
    pub encoder: Option<Input>,
    /// New localization pose, if any arrived since the last tick.
    pub pose: Option<Pose>,
    /// The dead-man switch is pressed.
    pub deadman: bool,
}

/// Why the runner is paused.
#[derive(Debug, Clone, PartialEq)]
pub enum PauseReason {
    /// The dead-man switch was released.
    DeadmanReleased,
    /// No encoder data for longer than the watchdog timeout.
    EncodersStale,
    /// No localization for longer than the watchdog timeout.
    LocalizationStale,
}

/// Why the protocol ended.
#[derive(Debug, Clone, PartialEq)]
pub enum StopReason {
    /// The asked number of intervals was driven.
    Intervals,
    /// The asked duration was reached.
    Duration,
    /// The robot left the safety perimeter.
    Geofence {
        /// distance from the start (m)
        distance: f64,
    },
    /// The model converged.
    Converged,
    /// The characterization found no usable input space (never a made-up one).
    CharacterizationFailed(String),
}

/// The runner's state.
#[derive(Debug, Clone, PartialEq)]
pub enum RunnerState {
    /// Not started.
    Idle,
    /// Step 1: the vehicle's characterization probes.
    Characterizing {
        /// probe number
        probe: usize,
        /// ticks into it
        tick: usize,
    },
    /// Step 2: interval `interval`, `tick` ticks into it.
    Driving {
        /// interval index
        interval: usize,
        /// ticks into the interval
        tick: usize,
    },
    /// Stopped, zero command; resumes the interval from its transient window.
    Paused {
        /// why
        reason: PauseReason,
        /// interval to resume
        interval: usize,
    },
    /// Finished.
    Done(StopReason),
}

/// Where a driving tick falls: the sample of the window being recorded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleTag {
    /// Interval index.
    pub interval: usize,
    /// Window in the interval (0 transient, 1 and 2 steady).
    pub window: usize,
    /// Sample in the window.
    pub k: usize,
    /// Phase of the window.
    pub phase: Phase,
}

/// What the runner results in at a tick.
#[derive(Debug, Clone, PartialEq)]
pub struct RunnerOutput {
    /// Command to send (the vehicle's inputs: wheel velocities for a skid-steer).
    pub command: Input,
    /// The sample being recorded, while driving.
    pub sample: Option<SampleTag>,
}

/// Configuration of the runner.
#[derive(Debug, Clone, PartialEq)]
pub struct RunnerConfig {
    /// Watchdog: pause when encoders or localization are older than this (s).
    pub stale_timeout_s: f64,
    /// Safety perimeter: stop beyond this distance from the start (m).
    pub geofence_radius_m: Option<f64>,
    /// Stop after this many intervals.
    pub max_intervals: Option<usize>,
    /// Stop after this much time (s).
    pub max_duration_s: Option<f64>,
    /// Duration of each characterization sub-step (s); the last second is averaged. The
    /// default, 8 s, lets a powertrain with a 1.5 s time constant settle.
    pub characterization_s: f64,
    /// Whether localization is expected (watchdog, geofence, geometry identification).
    pub localization: bool,
    /// Most samples a run may record (see `drive_traits::limits::MAX_RUN_SAMPLES`): a run
    /// bounded beyond it is refused before it starts.
    pub max_samples: usize,
}

impl Default for RunnerConfig {
    fn default() -> Self {
        RunnerConfig {
            stale_timeout_s: 0.5,
            geofence_radius_m: None,
            max_intervals: None,
            max_duration_s: None,
            characterization_s: 8.0,
            localization: true,
            max_samples: drive_traits::limits::MAX_RUN_SAMPLES,
        }
    }
}

type SamplerFactory = Box<dyn FnMut(InputSpace) -> Box<dyn InputSampler>>;
type ConvergenceCheck = Box<dyn FnMut(usize) -> bool>;

#[derive(Debug, Default, Clone, Copy)]
struct Averager {
    n: usize,
    inputs: Input,
    /// First and last localization updates in the averaging span, with their times.
    start_pose: Option<(f64, Pose)>,
    end_pose: Option<(f64, Pose)>,
    /// Yaw turned between the first and last updates, summed update by update so that a
    /// fast turn (more than half a turn in the span) is not wrapped away.
    yaw_turned: f64,
}

/// The DRIVE protocol runner.
pub struct ProtocolRunner {
    robot: RobotSpec,
    config: RunnerConfig,
    factory: SamplerFactory,
    sampler: Option<Box<dyn InputSampler>>,
    converged: Option<ConvergenceCheck>,
    state: RunnerState,
    characterization: Option<Characterization>,
    user_space: Option<InputSpace>,
    /// The probe under way and what it has averaged so far.
    probe: Option<(Probe, Averager)>,
    /// What the finished probes measured.
    probed: Vec<ProbeResult>,
    target: Input,
    sent: SentCommand,
    last_encoder: f64,
    last_pose: f64,
    start_pose: Option<Pose>,
    pose: Option<Pose>,
    start_time: Option<f64>,
    completed: usize,
    target_interval: Option<usize>,
}

impl std::fmt::Debug for ProtocolRunner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ProtocolRunner")
            .field("state", &self.state)
            .field("completed", &self.completed)
            .finish()
    }
}

impl ProtocolRunner {
    /// A runner for `robot` (its vehicle maps inputs to body velocities and plans the
    /// characterization); `sampler` builds the input sampler once the input space is known.
    pub fn new(
        robot: RobotSpec,
        config: RunnerConfig,
        sampler: impl FnMut(InputSpace) -> Box<dyn InputSampler> + 'static,
    ) -> Self {
        let user_space = robot.input_limits;
        ProtocolRunner {
            robot,
            config,
            factory: Box::new(sampler),
            sampler: None,
            converged: None,
            state: RunnerState::Idle,
            characterization: None,
            user_space,
            probe: None,
            probed: Vec::new(),
            target: Input::zeros(),
            sent: SentCommand::default(),
            last_encoder: f64::NEG_INFINITY,
            last_pose: f64::NEG_INFINITY,
            start_pose: None,
            pose: None,
            start_time: None,
            completed: 0,
            target_interval: None,
        }
    }

    /// Stops with [`StopReason::Converged`] when `check(completed intervals)` says so,
    /// asked at the end of every interval.
    pub fn with_convergence_check(mut self, check: impl FnMut(usize) -> bool + 'static) -> Self {
        self.converged = Some(Box::new(check));
        self
    }

    /// The current state.
    pub fn state(&self) -> &RunnerState {
        &self.state
    }

    /// What the characterization found (or the user-given input space).
    pub fn characterization(&self) -> Option<Characterization> {
        self.characterization.clone()
    }

    /// Intervals completed.
    pub fn completed_intervals(&self) -> usize {
        self.completed
    }

    /// Hands the windows recorded during the interval that just ended to the sampler (see
    /// [`InputSampler::observe`]): a driver calls this before the next tick, so that a
    /// targeted sampler draws the next input from what has been measured so far.
    pub fn observe(&mut self, robot: &RobotDescription, interval: &[Window]) {
        if let Some(s) = self.sampler.as_mut() {
            s.observe(robot, interval);
        }
    }

    /// Starts: characterizes the input space unless the robot description gives it.
    pub fn start(&mut self) {
        if self.state != RunnerState::Idle {
            return;
        }
        self.state = match self.user_space {
            Some(space) => {
                self.characterization = Some(Characterization {
                    space,
                    geometry: Vec::new(),
                });
                self.sampler = Some((self.factory)(space));
                RunnerState::Driving {
                    interval: 0,
                    tick: 0,
                }
            }
            None => self.next_probe(0),
        };
    }

    fn ticks(&self, seconds: f64) -> usize {
        (seconds * self.robot.rate_hz).round().max(1.0) as usize
    }

    /// One command tick.
    pub fn tick(&mut self, m: &RunnerInput) -> RunnerOutput {
        let zero = RunnerOutput {
            command: Input::zeros(),
            sample: None,
        };
        if m.encoder.is_some() {
            self.last_encoder = m.t;
        }
        if let Some(p) = m.pose {
            self.last_pose = m.t;
            self.pose = Some(p);
            self.start_pose.get_or_insert(p);
        }
        let start_time = *self.start_time.get_or_insert(m.t);
        if matches!(self.state, RunnerState::Idle | RunnerState::Done(_)) {
            return zero;
        }
        // Ends that do not depend on the state.
        if let (Some(r), Some(p), Some(s)) =
            (self.config.geofence_radius_m, self.pose, self.start_pose)
        {
            let distance = (p.xy() - s.xy()).norm();
            if distance > r {
                self.state = RunnerState::Done(StopReason::Geofence { distance });
                return zero;
            }
        }
        if self
            .config
            .max_duration_s
            .is_some_and(|d| m.t - start_time >= d)
        {
            self.state = RunnerState::Done(StopReason::Duration);
            return zero;
        }
        // Watchdog and dead-man switch.
        let pause = if !m.deadman {
            Some(PauseReason::DeadmanReleased)
        } else if m.t - self.last_encoder > self.config.stale_timeout_s {
            Some(PauseReason::EncodersStale)
        } else if self.config.localization && m.t - self.last_pose > self.config.stale_timeout_s {
            Some(PauseReason::LocalizationStale)
        } else {
            None
        };
        let interval = match &self.state {
            RunnerState::Driving { interval, .. } | RunnerState::Paused { interval, .. } => {
                *interval
            }
            _ => 0,
        };
        if let Some(reason) = pause {
            // Characterization restarts from scratch; driving resumes its interval.
            if matches!(self.state, RunnerState::Characterizing { .. }) {
                self.probe = None;
                self.probed.clear();
            }
            self.state = RunnerState::Paused { reason, interval };
            self.sent = SentCommand::default();
            return zero;
        }
        if let RunnerState::Paused { interval, .. } = self.state {
            self.state = if self.sampler.is_some() {
                RunnerState::Driving { interval, tick: 0 }
            } else {
                self.next_probe(0)
            };
        }
        match self.state.clone() {
            RunnerState::Characterizing { probe, tick } => self.characterize(probe, tick, m),
            RunnerState::Driving { interval, tick } => self.drive(interval, tick),
            _ => zero,
        }
    }

    /// The state of the first usable probe from number `index` on (the vehicle's probes
    /// that need localization are skipped without it), or the end of the characterization.
    fn next_probe(&mut self, index: usize) -> RunnerState {
        let mut i = index;
        loop {
            match self
                .robot
                .vehicle
                .probe(i, self.robot.max_speed, &self.probed)
            {
                Some(p) if p.needs_localization && !self.config.localization => i += 1,
                Some(p) => {
                    self.probe = Some((p, Averager::default()));
                    return RunnerState::Characterizing { probe: i, tick: 0 };
                }
                None => return self.finish_characterization(),
            }
        }
    }

    /// Holds probe `index` for the characterization time, averaging its last second.
    fn characterize(&mut self, index: usize, tick: usize, m: &RunnerInput) -> RunnerOutput {
        let n = self.ticks(self.config.characterization_s);
        let averaged = self.ticks(1.0).min(n);
        let Some((probe, a)) = self.probe.as_mut() else {
            // A probe is always set when the state is Characterizing.
            self.state = self.finish_characterization();
            return RunnerOutput {
                command: Input::zeros(),
                sample: None,
            };
        };
        let command = probe.command;
        if tick >= n - averaged {
            if let Some(e) = m.encoder {
                a.inputs += e;
                a.n += 1;
            }
            if let Some(p) = m.pose {
                if let Some((_, last)) = a.end_pose {
                    a.yaw_turned += wrap_angle(p.z - last.z);
                }
                a.start_pose.get_or_insert((m.t, p));
                a.end_pose = Some((m.t, p));
            }
        }
        let next = tick + 1;
        self.state = if next < n {
            RunnerState::Characterizing {
                probe: index,
                tick: next,
            }
        } else {
            // The probe just ended: what it measured.
            if let Some((probe, a)) = self.probe.take() {
                let motion = match (a.start_pose, a.end_pose) {
                    (Some((t0, s)), Some((t1, e))) if t1 > t0 => Some(ProbeMotion {
                        duration_s: t1 - t0,
                        distance_m: (e.xy() - s.xy()).norm(),
                        yaw_turned: a.yaw_turned,
                    }),
                    _ => None,
                };
                self.probed.push(ProbeResult {
                    probe,
                    measured: a.inputs / a.n.max(1) as f64,
                    motion,
                });
            }
            self.next_probe(index + 1)
        };
        RunnerOutput {
            command,
            sample: None,
        }
    }

    /// The vehicle's characterization from what the probes measured: then driving, or the
    /// end with the reason when no usable input space was found.
    fn finish_characterization(&mut self) -> RunnerState {
        match self.robot.vehicle.characterize(&self.probed) {
            Ok(c) => {
                self.sampler = Some((self.factory)(c.space));
                self.characterization = Some(c);
                RunnerState::Driving {
                    interval: 0,
                    tick: 0,
                }
            }
            Err(reason) => {
                RunnerState::Done(StopReason::CharacterizationFailed(reason.to_string()))
            }
        }
    }

    fn drive(&mut self, interval: usize, tick: usize) -> RunnerOutput {
        if self.config.max_intervals.is_some_and(|n| interval >= n) {
            self.state = RunnerState::Done(StopReason::Intervals);
            return RunnerOutput {
                command: Input::zeros(),
                sample: None,
            };
        }
        let len = window_len(&self.robot);
        // A new interval draws its input; a resumed one keeps it.
        if self.target_interval != Some(interval) {
            if let Some(s) = self.sampler.as_mut() {
                self.target = s.next_input();
                self.target_interval = Some(interval);
            }
        }
        let command = next_command(&self.robot, &mut self.sent, &self.target);
        let window = tick / len;
        let sample = SampleTag {
            interval,
            window,
            k: tick % len,
            phase: if window == 0 {
                Phase::Transient
            } else {
                Phase::Steady
            },
        };
        let next = tick + 1;
        self.state = if next < WINDOWS_PER_INTERVAL * len {
            RunnerState::Driving {
                interval,
                tick: next,
            }
        } else {
            self.completed = interval + 1;
            if self.converged.as_mut().is_some_and(|c| c(interval + 1)) {
                RunnerState::Done(StopReason::Converged)
            } else {
                RunnerState::Driving {
                    interval: interval + 1,
                    tick: 0,
                }
            }
        };
        RunnerOutput {
            command,
            sample: Some(sample),
        }
    }
}
