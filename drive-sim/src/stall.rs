//! A turn the ground holds at its start: stiction in a skid-steer's turning resistance.
//!
//! On a real Warthog run at low speed (warthog_asphalt_slow_2024-08-08), half of the
//! commands that start or reverse a turn leave the wheels turning together (the encoders
//! give a tenth of the commanded difference for the whole 6 s command), while no command
//! that continues a turn the wheels already make does: the ground's static resistance to a
//! turn exceeds what the wheel loops push against it, and once the robot turns the sliding
//! resistance does not. The smooth friction curve of [`contact_force`](crate::contact_force)
//! has no static part, so a twin of that run followed every turn, and its wheels followed
//! the commands fifty times more regularly than the robot's.
//!
//! [`TurnStall`] gives a twin that behaviour: each new command that does not continue the
//! wheels' turn stalls with a probability, and a stalled command's wheels keep a share of
//! its turn until the next command. `drive sim-fit` counts both on the real run's steady
//! windows (`fit::stall`).

use drive_traits::Input;
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use serde::{Deserialize, Serialize};

/// The wheels continue a turn when they already turn its way at least this share of the
/// new command's turn (half differences of the wheel speeds).
pub const CONTINUING_TURN: f64 = 0.2;

/// How a ground holds a turn at its start (a fitted twin's `[turn_stall]`): a command that
/// starts or reverses a turn (the wheels not turning its way by at least
/// [`CONTINUING_TURN`] of it) stalls with `probability`, and its wheels are then commanded
/// `share` of its turn, their mean speed unchanged, until the next command. A command
/// change (a step, or a ramp: a command changing every tick) is decided when the command is
/// held again (for a step, the tick after it), with one draw, judged as the fit judges the
/// real run: the new command against the wheels as they were when the change began. A
/// command that changes every tick (a closed-loop controller's, `drive track`) is never
/// held, so never stalls: the stall acts on protocol runs, stepped or ramped.
///
/// ```
/// let t = drive_sim::Terrain::from_toml("slow.toml",
///     "name = 'slow'\ntraction = 0.2\nslip_modulus = 0.6\nlateral = 0.05\nrolling = 0.01\n\
///      [turn_stall]\nprobability = 0.5\nshare = 0.1\n").unwrap();
/// assert_eq!(t.turn_stall.unwrap().probability, 0.5);
/// // A probability beyond one is refused, naming the field.
/// let e = drive_sim::Terrain::from_toml("bad.toml",
///     "name = 'x'\ntraction = 0.2\nslip_modulus = 0.6\nlateral = 0.05\nrolling = 0.01\n\
///      [turn_stall]\nprobability = 1.5\nshare = 0.1\n").unwrap_err();
/// assert!(e.to_string().contains("turn_stall.probability"), "{e}");
/// // The wheels turning the new command's way continue its turn; at rest they start one.
/// use drive_traits::Input;
/// assert!(drive_sim::TurnStall::continues(Input::new(0.0, 1.0, 0.0), Input::new(0.3, 0.7, 0.0)));
/// assert!(!drive_sim::TurnStall::continues(Input::new(0.0, 1.0, 0.0), Input::zeros()));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TurnStall {
    /// Probability that a command starting or reversing a turn stalls, in [0, 1].
    pub probability: f64,
    /// The share of its turn a stalled command's wheels are commanded, in [0, 1].
    pub share: f64,
}

impl TurnStall {
    /// True when wheels turning at `wheels` (rad/s) continue the turn of `command`: their
    /// half difference has the command's sign and at least [`CONTINUING_TURN`] of its size.
    pub fn continues(command: Input, wheels: Input) -> bool {
        let (turn, turning) = (half_difference(command), half_difference(wheels));
        turn * turning > 0.0 && turning.abs() >= CONTINUING_TURN * turn.abs()
    }
}

/// The half difference of a pair of wheel speeds (right minus left, over two).
pub(crate) fn half_difference(u: Input) -> f64 {
    (u.y - u.x) / 2.0
}

/// A simulator's stall: the previous tick's command, whether it was held, the wheels when
/// the current change began, whether that change is decided, and the factor on the
/// command's turn. Its draws are its own stream, so a terrain without a stall simulates
/// exactly as before it existed.
#[derive(Debug, Clone)]
pub(crate) struct StallState {
    stall: TurnStall,
    last: Option<Input>,
    held: bool,
    wheels_before: Input,
    decided: bool,
    factor: f64,
    rng: Xoshiro256PlusPlus,
}

impl StallState {
    pub(crate) fn new(stall: TurnStall, seed: u64) -> Self {
        StallState {
            stall,
            last: None,
            held: true,
            wheels_before: Input::zeros(),
            decided: true,
            factor: 1.0,
            rng: Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x57A1_1ED7_0125),
        }
    }

    /// The command the wheel loops are given for `command`, with the wheels at `wheels`: a
    /// change is followed while it changes; when the command is held again, one draw under
    /// the probability stalls it unless the wheels as they were when it began continue its
    /// turn, and a stalled command keeps `share` of its turn until the next change.
    pub(crate) fn command(&mut self, command: Input, wheels: Input) -> Input {
        if self.last == Some(command) {
            self.held = true;
            if !self.decided {
                self.decided = true;
                let draw: f64 = self.rng.random();
                if draw < self.stall.probability
                    && !TurnStall::continues(command, self.wheels_before)
                {
                    self.factor = self.stall.share;
                }
            }
        } else {
            if self.held {
                // A new change (a step, or a ramp's first tick): followed until held.
                self.held = false;
                self.wheels_before = wheels;
                self.decided = false;
                self.factor = 1.0;
            }
            self.last = Some(command);
        }
        if self.factor == 1.0 {
            return command;
        }
        let mean = (command.x + command.y) / 2.0;
        let kept = half_difference(command) * self.factor;
        Input::new(mean - kept, mean + kept, command.z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stalled_start_keeps_its_share_of_the_turn_and_a_continued_turn_never_stalls() {
        let always = TurnStall {
            probability: 1.0,
            share: 0.1,
        };
        let mut s = StallState::new(always, 1);
        // From rest: a turn starts, followed at its step, stalled once held; the mean speed
        // is kept.
        let u = Input::new(0.0, 2.0, 0.0);
        assert_eq!(s.command(u, Input::zeros()), u);
        let out = s.command(u, Input::zeros());
        assert!(
            (out.x - 0.9).abs() < 1e-12 && (out.y - 1.1).abs() < 1e-12,
            "{out}"
        );
        // Held on: stalled, whatever the wheels do meanwhile.
        assert_eq!(s.command(u, Input::new(0.0, 2.0, 0.0)), out);
        // A new command whose turn the wheels make when it begins: followed.
        let v = Input::new(-1.0, 2.0, 0.0);
        assert_eq!(s.command(v, Input::new(0.5, 1.5, 0.0)), v);
        assert_eq!(s.command(v, Input::new(0.5, 1.5, 0.0)), v);
        // Reversed: stalls once held.
        let r = Input::new(2.0, 0.0, 0.0);
        assert_eq!(s.command(r, Input::new(0.5, 1.5, 0.0)), r);
        let out = s.command(r, Input::new(0.5, 1.5, 0.0));
        assert!(
            (out.x - 1.1).abs() < 1e-12 && (out.y - 0.9).abs() < 1e-12,
            "{out}"
        );
        // Never stalling: the command itself.
        let mut never = StallState::new(
            TurnStall {
                probability: 0.0,
                share: 0.1,
            },
            1,
        );
        assert_eq!(never.command(u, Input::zeros()), u);
        assert_eq!(never.command(u, Input::zeros()), u);
    }

    #[test]
    fn the_share_of_stalled_starts_is_the_probability() {
        let mut s = StallState::new(
            TurnStall {
                probability: 0.3,
                share: 0.0,
            },
            7,
        );
        let mut stalled = 0;
        for i in 0..4000 {
            // Alternating turns from rest, each held for two ticks: each a change, each a
            // start, decided on its second tick.
            let turn = if i % 2 == 0 { 1.0 } else { -1.0 };
            let u = Input::new(-turn, turn, 0.0);
            assert_eq!(s.command(u, Input::zeros()), u);
            let out = s.command(u, Input::zeros());
            stalled += usize::from(out.x == 0.0 && out.y == 0.0);
        }
        let share = stalled as f64 / 4000.0;
        assert!((share - 0.3).abs() < 0.03, "{share}");
    }

    #[test]
    fn a_ramp_is_one_change_judged_by_the_wheels_when_it_began() {
        let always = TurnStall {
            probability: 1.0,
            share: 0.0,
        };
        let at = |turn: f64| Input::new(-turn, turn, 0.0);
        // A ramp from a small turn to a large one: followed while it ramps; held, it
        // stalls, as the wheels when it began (0.3) made less than a fifth of its 2.0.
        let mut s = StallState::new(always, 3);
        s.command(at(0.3), at(0.3));
        s.command(at(0.3), at(0.3));
        for turn in [0.8, 1.4, 2.0] {
            assert_eq!(s.command(at(turn), at(turn - 0.5)), at(turn));
        }
        assert_eq!(s.command(at(2.0), at(1.8)), Input::zeros());
        // A ramp down the same way: the wheels when it began continue it, followed.
        let mut s = StallState::new(always, 3);
        s.command(at(2.0), at(2.0));
        s.command(at(2.0), at(2.0));
        for turn in [1.5, 1.0, 0.5] {
            assert_eq!(s.command(at(turn), at(turn + 0.5)), at(turn));
        }
        assert_eq!(s.command(at(0.5), at(0.6)), at(0.5));
        assert_eq!(s.command(at(0.5), at(0.5)), at(0.5));
    }
}
