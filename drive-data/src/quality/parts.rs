//! The consistency checks on each part of a run: a corruption confined to part of it (the
//! encoder columns swapped from the middle on, a log's second half in another unit, a
//! command sign flipped halfway) is diluted in the whole run's statistics, where the other
//! part's windows outvote it, and passes. Each half and each third of the run (its windows
//! in their order, cut at interval boundaries) is checked on its own by the checks that
//! compare the run's columns with each other (the encoders with their commands and with
//! localization, localization with itself, the IMU with localization's turn); a fatal
//! finding of a part that the whole run does not show as fatal is reported with the part
//! named. A run's parts are the same robot on the same ground with the same sensors: what
//! one part's columns say of each other, the other parts' say too, whatever the ground.

use super::{
    direction_of, direction_signals, encoder_command_in, encoder_units_in, imu_yaw_rate,
    localization, Finding, Severity, Windows,
};

/// The parts a run is cut into: halves and thirds.
const PARTS: [usize; 2] = [2, 3];

/// The fewest windows a part must hold to be checked on its own: the checks' own minimum
/// counts (ten turning windows, ten straight ones) need a part of a few dozen.
const MIN_PART_WINDOWS: usize = 40;

/// The consistency checks of one part of the run (see the module's doc).
fn consistency(w: &Windows<'_>) -> Vec<Finding> {
    let mut out = encoder_command_in(w.data, &w.windows, false);
    out.extend(encoder_units_in(w, false));
    out.extend(localization::frame(w));
    out.extend(imu_yaw_rate(w));
    out
}

/// The fatal findings of the run's parts that `whole` (the whole run's findings) does not
/// show as fatal, each named by its part and its first and last window, at most one per
/// check (the first part to show it). A part's warnings are not said: its fewer windows
/// scatter more, and on real and simulated runs they came from slip alone.
pub(super) fn parts(w: &Windows<'_>, whole: &[Finding]) -> Vec<Finding> {
    let n = w.windows.len();
    let mut out: Vec<Finding> = directions(w, whole);
    for count in PARTS {
        if n / count < MIN_PART_WINDOWS {
            continue;
        }
        for part in 0..count {
            let (start, end) = (cut(w, part, count), cut(w, part + 1, count));
            if end - start < MIN_PART_WINDOWS {
                continue;
            }
            let sub = Windows {
                data: w.data,
                windows: w.windows[start..end].to_vec(),
                motions: w.motions[start..end].to_vec(),
                travels: w.travels[start..end].to_vec(),
            };
            let where_ = format!(
                "in {} of the run alone (its windows {} to {})",
                name(part, count),
                w.windows[start].index,
                w.windows[end - 1].index
            );
            for f in consistency(&sub) {
                add_new(f, &where_, whole, &mut out);
            }
        }
    }
    out
}

/// `direction` on many parts of the run, from each window's signals computed once: every
/// stretch of a half, a third, ... down to a sixth of the windows, starting at every half of
/// its own length (a quarter or a fifth of the run corrupted, wherever it lies, fills one of
/// them), and the intervals taken every other or every third (a corruption of every other
/// interval fills one). A part's fatal finding the whole run does not show is fatal, the part
/// named. (Its rule asks four in five of a part's turning or driving windows against the
/// encoders: a robot sliding on ice, whose windows disagree at random, does not reach it.)
fn directions(w: &Windows<'_>, whole: &[Finding]) -> Vec<Finding> {
    let signals = direction_signals(w);
    let n = signals.len();
    let mut parts: Vec<(String, Vec<usize>)> = Vec::new();
    for count in 2..=MAX_STRETCHES {
        let len = n / count;
        if len < MIN_PART_WINDOWS {
            break;
        }
        let step = (len / 2).max(1);
        let mut start = 0;
        while start + len <= n {
            parts.push((
                format!(
                    "the stretch of a {} from its window {} to {}",
                    ["", "", "half", "third", "quarter", "fifth", "sixth"][count],
                    w.windows[start].index,
                    w.windows[start + len - 1].index
                ),
                (start..start + len).collect(),
            ));
            start += step;
        }
    }
    for every in [2usize, 3] {
        for class in 0..every {
            let members: Vec<usize> = (0..n)
                .filter(|&i| w.windows[i].interval % every == class)
                .collect();
            if members.len() >= MIN_PART_WINDOWS && members.len() < n {
                let which = if every == 2 { "other" } else { "third" };
                parts.push((
                    format!("every {which} interval (from interval {class})"),
                    members,
                ));
            }
        }
    }
    let mut out: Vec<Finding> = Vec::new();
    for (name, members) in parts {
        let where_ = format!("in {name} alone");
        for f in direction_of(members.iter().map(|&i| &signals[i])) {
            add_new(f, &where_, whole, &mut out);
        }
    }
    out
}

/// Adds `f`, a finding of a part (`where_` says which), to `out` when it is fatal and
/// neither `whole` (the whole run's findings) nor `out` already has that check fatal.
fn add_new(f: Finding, where_: &str, whole: &[Finding], out: &mut Vec<Finding>) {
    let shown = |g: &Finding| g.check == f.check && g.severity == Severity::Fatal;
    if f.severity != Severity::Fatal || whole.iter().any(shown) || out.iter().any(shown) {
        return;
    }
    out.push(Finding {
        check: f.check,
        severity: f.severity,
        message: format!(
            "{where_}: {}; part of the run corrupted, or joined from another run or robot?",
            f.message
        ),
    });
}

/// The most stretches [`directions`] cuts the run into: down to a sixth of it.
const MAX_STRETCHES: usize = 6;

/// Where part `part` of `count` starts (`part == count`: the end): the window at that share
/// of the run, moved on to the start of its interval's next one (a part holds whole
/// intervals, so that a transient window and its steady ones are checked together).
fn cut(w: &Windows<'_>, part: usize, count: usize) -> usize {
    let n = w.windows.len();
    let mut i = n * part / count;
    if part == 0 || i >= n {
        return i.min(n);
    }
    while i < n && w.windows[i].interval == w.windows[i - 1].interval {
        i += 1;
    }
    i
}

/// A part's name: "the first half", "the second third", ...
fn name(part: usize, count: usize) -> String {
    let ordinal = ["first", "second", "third"][part.min(2)];
    let of = if count == 2 { "half" } else { "third" };
    format!("the {ordinal} {of}")
}
