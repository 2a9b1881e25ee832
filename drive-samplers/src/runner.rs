//! The protocol runner: the state machine a robot driver (a ROS 2 node, say) wraps. At each
//! command tick it takes the measurements and returns the command to send.
//!
//! States: idle, characterizing (step 1: high longitudinal commands both ways, then a turn
//! in place, to find the wheel velocity limits and, with localization, the effective wheel
//! radius and baseline), driving interval k (step 2), paused (watchdog or dead-man switch),
//! done (intervals, duration, geofence or convergence).

use crate::{limit_acceleration, window_len, RobotSpec, WINDOWS_PER_INTERVAL};
use drive_traits::{
    BodyVelocity, CommandModel, Input, InputSampler, InputSpace, Phase, Pose, RobotDescription,
    Window,
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
}

/// The characterization step's sub-steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Characterize {
    /// Full forward.
    Forward,
    /// Full backward.
    Backward,
    /// Turn in place (for the baseline).
    Turn,
}

/// The runner's state.
#[derive(Debug, Clone, PartialEq)]
pub enum RunnerState {
    /// Not started.
    Idle,
    /// Step 1.
    Characterizing {
        /// sub-step
        step: Characterize,
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
    /// Command to send (wheel velocities, rad/s).
    pub command: Input,
    /// The sample being recorded, while driving.
    pub sample: Option<SampleTag>,
}

/// What the characterization found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Characterization {
    /// The true input space J.
    pub space: InputSpace,
    /// Effective wheel radius (m), when localization was available.
    pub wheel_radius: Option<f64>,
    /// Effective baseline (m), when localization was available.
    pub baseline: Option<f64>,
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
    /// Whether localization is expected (watchdog, geofence, radius and baseline
    /// identification).
    pub localization: bool,
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
        }
    }
}

type SamplerFactory = Box<dyn FnMut(InputSpace) -> Box<dyn InputSampler>>;
type ConvergenceCheck = Box<dyn FnMut(usize) -> bool>;

#[derive(Debug, Default, Clone, Copy)]
struct Averager {
    n: usize,
    wheels: Input,
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
    vehicle: Box<dyn CommandModel>,
    config: RunnerConfig,
    factory: SamplerFactory,
    sampler: Option<Box<dyn InputSampler>>,
    converged: Option<ConvergenceCheck>,
    state: RunnerState,
    characterization: Option<Characterization>,
    user_space: Option<InputSpace>,
    averages: [Averager; 3],
    target: Input,
    sent: BodyVelocity,
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
    /// A runner for `robot` (`vehicle` maps inputs to body velocities); `sampler` builds
    /// the input sampler once the input space is known.
    pub fn new(
        robot: RobotSpec,
        vehicle: Box<dyn CommandModel>,
        config: RunnerConfig,
        sampler: impl FnMut(InputSpace) -> Box<dyn InputSampler> + 'static,
    ) -> Self {
        let user_space = robot.wheel_limits.map(|_| robot.input_space());
        ProtocolRunner {
            robot,
            vehicle,
            config,
            factory: Box::new(sampler),
            sampler: None,
            converged: None,
            state: RunnerState::Idle,
            characterization: None,
            user_space,
            averages: [Averager::default(); 3],
            target: Input::zeros(),
            sent: BodyVelocity::zeros(),
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
        self.characterization
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
                    wheel_radius: None,
                    baseline: None,
                });
                self.sampler = Some((self.factory)(space));
                RunnerState::Driving {
                    interval: 0,
                    tick: 0,
                }
            }
            None => RunnerState::Characterizing {
                step: Characterize::Forward,
                tick: 0,
            },
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
                self.averages = [Averager::default(); 3];
            }
            self.state = RunnerState::Paused { reason, interval };
            self.sent = BodyVelocity::zeros();
            return zero;
        }
        if let RunnerState::Paused { interval, .. } = self.state {
            self.state = if self.sampler.is_some() {
                RunnerState::Driving { interval, tick: 0 }
            } else {
                RunnerState::Characterizing {
                    step: Characterize::Forward,
                    tick: 0,
                }
            };
        }
        match self.state.clone() {
            RunnerState::Characterizing { step, tick } => self.characterize(step, tick, m),
            RunnerState::Driving { interval, tick } => self.drive(interval, tick),
            _ => zero,
        }
    }

    fn characterize(&mut self, step: Characterize, tick: usize, m: &RunnerInput) -> RunnerOutput {
        let n = self.ticks(self.config.characterization_s);
        let averaged = self.ticks(1.0).min(n);
        let v = 2.0 * self.robot.max_speed;
        let body = match step {
            Characterize::Forward => BodyVelocity::new(v, 0.0, 0.0),
            Characterize::Backward => BodyVelocity::new(-v, 0.0, 0.0),
            // Turning in place at half of what the forward step reached.
            Characterize::Turn => {
                let reached = self.averages[0].wheels / self.averages[0].n.max(1) as f64;
                let w = 0.5 * reached.x.abs().min(reached.y.abs());
                return self.characterize_with(step, tick, n, averaged, Input::new(-w, w), m);
            }
        };
        let command = self.vehicle.input_for(&body).unwrap_or(Input::zeros());
        self.characterize_with(step, tick, n, averaged, command, m)
    }

    fn characterize_with(
        &mut self,
        step: Characterize,
        tick: usize,
        n: usize,
        averaged: usize,
        command: Input,
        m: &RunnerInput,
    ) -> RunnerOutput {
        let slot = step as usize;
        if tick >= n - averaged {
            let a = &mut self.averages[slot];
            if let Some(e) = m.encoder {
                a.wheels += e;
                a.n += 1;
            }
            if let Some(p) = m.pose {
                if let Some((_, last)) = a.end_pose {
                    a.yaw_turned += drive_traits::wrap_angle(p.z - last.z);
                }
                a.start_pose.get_or_insert((m.t, p));
                a.end_pose = Some((m.t, p));
            }
        }
        let next = tick + 1;
        self.state = if next < n {
            RunnerState::Characterizing { step, tick: next }
        } else {
            match step {
                Characterize::Forward => RunnerState::Characterizing {
                    step: Characterize::Backward,
                    tick: 0,
                },
                Characterize::Backward if self.config.localization => RunnerState::Characterizing {
                    step: Characterize::Turn,
                    tick: 0,
                },
                _ => {
                    self.finish_characterization();
                    RunnerState::Driving {
                        interval: 0,
                        tick: 0,
                    }
                }
            }
        };
        RunnerOutput {
            command,
            sample: None,
        }
    }

    fn finish_characterization(&mut self) {
        let mean = |a: &Averager| a.wheels / a.n.max(1) as f64;
        let (fwd, back) = (mean(&self.averages[0]), mean(&self.averages[1]));
        let space = InputSpace::new(back.inf(&fwd), fwd.sup(&back))
            .or_else(|| InputSpace::new(Input::repeat(-1.0), Input::repeat(1.0)))
            .unwrap_or(self.robot.input_space());
        // Effective radius: distance over wheel angle between two localization updates;
        // effective baseline: r (w_r - w_l) over the yaw rate turning in place.
        let (mut wheel_radius, mut baseline) = (None, None);
        if let (Some((t0, s)), Some((t1, e))) =
            (self.averages[0].start_pose, self.averages[0].end_pose)
        {
            let angle = 0.5 * (fwd.x + fwd.y) * (t1 - t0);
            if angle.abs() > 1e-6 {
                wheel_radius = Some((e.xy() - s.xy()).norm() / angle.abs());
            }
        }
        let turn = &self.averages[2];
        if let (Some(r), Some((t0, _)), Some((t1, _))) =
            (wheel_radius, turn.start_pose, turn.end_pose)
        {
            let w = mean(turn);
            let yaw_rate = turn.yaw_turned / (t1 - t0);
            if yaw_rate.abs() > 1e-6 && t1 > t0 {
                baseline = Some(r * (w.y - w.x) / yaw_rate);
            }
        }
        self.characterization = Some(Characterization {
            space,
            wheel_radius,
            baseline,
        });
        self.sampler = Some((self.factory)(space));
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
        let target_body = self.vehicle.body_velocity(&self.target);
        self.sent = limit_acceleration(&self.sent, &target_body, &self.robot);
        let command = self.vehicle.input_for(&self.sent).unwrap_or(self.target);
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
