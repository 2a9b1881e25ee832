//! Stage 0: the turns the ground holds at their start ([`TurnStall`]), counted on the real
//! run's steady windows before the controller is fitted (whose gains then describe the
//! commands the wheels followed).

use super::*;
use crate::stall::half_difference;
use crate::TurnStall;
use std::collections::BTreeSet;

/// Fewest stalled starts for a fitted stall: fewer are read as the run's odd windows.
pub(super) const MIN_STALLED_STARTS: usize = 3;

/// Fewest continued turns for the share of a followed turn.
const MIN_CONTINUED_TURNS: usize = 5;

/// A turn command stalled when its wheels kept less than this share of a followed turn's.
pub(super) const STALLED_SHARE: f64 = 0.3;

/// What the stall stage counted on the real run, and the stall it fitted.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct TurnStallFit {
    /// Turn commands (a turn at least a quarter of the run's 90th percentile) after an
    /// interval whose wheels did not already turn their way: starts and reversals.
    pub starts: usize,
    /// Of those, the ones whose steady wheels kept less than 0.3 of a followed turn's share.
    pub stalled_starts: usize,
    /// Turn commands that continued the wheels' turn.
    pub continued: usize,
    /// Of those, the stalled ones.
    pub stalled_continued: usize,
    /// The median share of its turn a continued turn command's steady wheels give (the
    /// encoders' half difference over the command's); NaN with fewer than 5 continued turn
    /// commands (then none is counted as stalled).
    pub followed_share: f64,
    /// The fitted stall: none with fewer than 3 stalled starts or 5 continued turns.
    pub stall: Option<TurnStall>,
}

/// One interval's turn: the command's half difference and its steady wheels' (means over
/// its steady windows), and its last steady window's wheels.
struct IntervalTurn {
    interval: usize,
    command: f64,
    wheels: f64,
    windows: usize,
    last_wheels: f64,
}

/// Counts the real run's stalled turns: each interval's steady wheels against its command,
/// split by whether the previous interval's last steady wheels already turned its way
/// ([`TurnStall::continues`]); fits a [`TurnStall`] from the starts and reversals when at
/// least [`MIN_STALLED_STARTS`] of them stalled and at least [`MIN_CONTINUED_TURNS`] turn
/// commands continued a turn (the followed share a stall is measured against): its
/// probability their stalled share, its share their kept turn (median) over a followed
/// one's, in [0, 1]. Also the intervals whose turn command stalled (a start, or a continued
/// turn, which the simulator never stalls), when a stall is fitted (the controller and
/// powertrain stages leave them out), none otherwise. The previous interval is the one
/// numbered before: after a step the data dropped, a command is judged against wheels
/// that ran before that step.
pub(super) fn fit_turn_stall(data: &Dataset) -> (TurnStallFit, BTreeSet<usize>) {
    let mut turns: Vec<IntervalTurn> = Vec::new();
    for w in data.windows.iter().filter(|w| w.phase == Phase::Steady) {
        if w.command.is_empty() || w.measured.is_empty() {
            continue;
        }
        let command = mean(w.command.iter().map(|&u| half_difference(u)));
        let wheels = mean(w.measured.iter().map(|&u| half_difference(u)));
        match turns.last_mut() {
            // Another steady window of the interval: the running means, and its last.
            Some(t) if t.interval == w.interval => {
                t.windows += 1;
                let n = t.windows as f64;
                t.command += (command - t.command) / n;
                t.wheels += (wheels - t.wheels) / n;
                t.last_wheels = wheels;
            }
            _ => turns.push(IntervalTurn {
                interval: w.interval,
                command,
                wheels,
                windows: 1,
                last_wheels: wheels,
            }),
        }
    }
    // Each interval after its previous one, with the previous one's last steady wheels.
    let after: Vec<(&IntervalTurn, f64)> = turns
        .windows(2)
        .filter(|pair| pair[0].interval.checked_add(1) == Some(pair[1].interval))
        .map(|pair| (&pair[1], pair[0].last_wheels))
        .collect();
    let mut turns_commanded: Vec<f64> = after.iter().map(|(t, _)| t.command.abs()).collect();
    turns_commanded.sort_by(f64::total_cmp);
    let threshold = drive_traits::quantile(&turns_commanded, 0.9).unwrap_or(f64::NAN) / 4.0;
    // (continues, share, interval) of each turn command.
    let judged: Vec<(bool, f64, usize)> = after
        .iter()
        .filter(|(t, _)| t.command.abs() >= threshold && t.command != 0.0)
        .map(|&(t, before)| {
            let continues = TurnStall::continues(
                drive_traits::Input::new(-t.command, t.command, 0.0),
                drive_traits::Input::new(-before, before, 0.0),
            );
            (continues, t.wheels / t.command, t.interval)
        })
        .collect();
    let continued: Vec<f64> = judged.iter().filter(|j| j.0).map(|j| j.1).collect();
    let followed_share = if continued.len() >= MIN_CONTINUED_TURNS {
        median_or_zero(continued.clone())
    } else {
        f64::NAN
    };
    let is_stalled = |share: f64| share < STALLED_SHARE * followed_share;
    let starts: Vec<f64> = judged.iter().filter(|j| !j.0).map(|j| j.1).collect();
    let stalled_starts: Vec<f64> = starts.iter().copied().filter(|&s| is_stalled(s)).collect();
    let stalled_continued = continued.iter().filter(|&&s| is_stalled(s)).count();
    let stall =
        (followed_share > 0.0 && stalled_starts.len() >= MIN_STALLED_STARTS).then(|| TurnStall {
            probability: stalled_starts.len() as f64 / starts.len() as f64,
            share: (median_or_zero(stalled_starts.clone()) / followed_share).clamp(0.0, 1.0),
        });
    let stalled_intervals = if stall.is_some() {
        judged
            .iter()
            .filter(|j| is_stalled(j.1))
            .map(|j| j.2)
            .collect()
    } else {
        BTreeSet::new()
    };
    let fit = TurnStallFit {
        starts: starts.len(),
        stalled_starts: stalled_starts.len(),
        continued: continued.len(),
        stalled_continued,
        followed_share,
        stall,
    };
    (fit, stalled_intervals)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 200-interval Husky run on gravel, its turns held at their start as `stall` says.
    fn run(stall: Option<TurnStall>, seed: u64) -> Dataset {
        let terrain = Terrain {
            turn_stall: stall,
            ..Terrain::preset("gravel").unwrap()
        };
        husky_run(terrain, 200, seed)
    }

    #[test]
    fn the_stage_counts_the_stalls_a_ground_gives_and_none_where_it_gives_none() {
        let held = TurnStall {
            probability: 0.5,
            share: 0.1,
        };
        let (fit, stalled) = fit_turn_stall(&run(Some(held), 3));
        let s = fit.stall.expect("a stall is found");
        // About a hundred starts: the probability within two binomial sigmas (over twelve
        // seeds the stage counts 547 stalls of 1128 starts, 0.485), the share within half.
        assert!(fit.starts > 60, "{fit:?}");
        assert!((s.probability - 0.5).abs() < 0.1, "{fit:?}");
        assert!((s.share - 0.1).abs() < 0.05, "{fit:?}");
        // A continued turn never stalls; the stalled intervals are the stalled starts.
        assert_eq!(fit.stalled_continued, 0, "{fit:?}");
        assert_eq!(stalled.len(), fit.stalled_starts);
        // The same ground without a stall: none fitted, every interval followed.
        let (fit, stalled) = fit_turn_stall(&run(None, 3));
        assert_eq!(fit.stall, None, "{fit:?}");
        assert!(fit.stalled_starts < MIN_STALLED_STARTS, "{fit:?}");
        assert!(stalled.is_empty());
    }
}
