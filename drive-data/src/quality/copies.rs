//! `duplicate-windows`, copies re-cut: a run (or part of it) written again with its windows
//! cut a few samples later, so that no window equals another, sample for sample, within any
//! tolerance. What stays is the order: window after window, the copy's mean command and
//! mean measured input agree with the original's at one constant offset in the dataset.

use super::{Check, Finding, Severity};
use drive_traits::Window;
use std::collections::HashMap;

/// A window's mean command and mean measured input, per axis.
type Means = (Vec<f64>, Vec<f64>);

/// How far two windows' mean commands may be apart per axis to agree, against the range of
/// the windows' mean commands (a copy re-cut by five samples of forty moves a steady
/// window's mean command by nothing, its mean measurement by its noise).
const COMMAND_TOLERANCE: f64 = 0.02;
/// See [`COMMAND_TOLERANCE`]: the mean measured inputs, against their range.
const MEASURED_TOLERANCE: f64 = 0.03;

/// The share of the driven windows whose agreeing window lies at the most common offset from
/// which a part of the dataset is a copy (a real run appended again, re-cut 1-5 samples
/// later: 0.37-0.50; chance agreements on the real runs spread over the offsets, 0.017 at
/// most at one, and on 200 simulated runs 0.077 at most, a car's angular sampler holding
/// its speed).
const COPY_SHARE: f64 = 0.2;
/// See [`COPY_SHARE`]: and at least this many windows.
const MIN_COPIES: usize = 10;

/// Windows of the dataset agreeing with others (mean command and measurement per axis) at
/// one constant offset, in intervals two or more apart: `Some` when those are
/// [`COPY_SHARE`] of the driven windows or more.
pub(super) fn shifted_copies(windows: &[&Window]) -> Option<Finding> {
    let means: Vec<Option<Means>> = windows
        .iter()
        .map(|w| {
            let n = w.len() as f64;
            let axes = w.command.first()?.len();
            let mean =
                |v: &[drive_traits::Input], a: usize| v.iter().map(|u| u[a]).sum::<f64>() / n;
            let c: Vec<f64> = (0..axes).map(|a| mean(&w.command, a)).collect();
            let m: Vec<f64> = (0..axes).map(|a| mean(&w.measured, a)).collect();
            c.iter().chain(&m).all(|v| v.is_finite()).then_some((c, m))
        })
        .collect();
    let axes = means.iter().flatten().map(|(c, _)| c.len()).max()?;
    let range = |pick: &dyn Fn(&Means) -> &Vec<f64>, a: usize| {
        let (lo, hi) = means
            .iter()
            .flatten()
            .filter_map(|m| pick(m).get(a).copied())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                (l.min(v), h.max(v))
            });
        (hi - lo).max(0.0)
    };
    let command_tol: Vec<f64> = (0..axes)
        .map(|a| COMMAND_TOLERANCE * range(&|m| &m.0, a))
        .collect();
    let measured_tol: Vec<f64> = (0..axes)
        .map(|a| MEASURED_TOLERANCE * range(&|m| &m.1, a))
        .collect();
    let widest = command_tol.iter().copied().fold(0.0, f64::max);
    if !(widest > 0.0 && widest.is_finite()) {
        return None;
    }
    // Driven: commanded or measured beyond a twentieth of the range (a robot at rest
    // repeats itself at every offset).
    let driven = |(c, m): &Means| {
        (0..axes).any(|a| c[a].abs() > 2.5 * command_tol[a] || m[a].abs() > 2.5 * measured_tol[a])
    };
    let cell_size = |a: usize| command_tol[a].max(widest * 1e-3);
    let cell = |c: &[f64]| -> [i64; 2] {
        [0, 1].map(|a| c.get(a).map_or(0, |v| (v / cell_size(a)).floor() as i64))
    };
    let mut cells: HashMap<[i64; 2], Vec<usize>> = HashMap::new();
    let mut count = 0usize;
    for (i, m) in means.iter().enumerate() {
        if let Some(m) = m.as_ref().filter(|m| driven(m)) {
            cells.entry(cell(&m.0)).or_default().push(i);
            count += 1;
        }
    }
    let agree = |(c1, m1): &Means, (c2, m2): &Means| {
        (0..axes).all(|a| {
            (c1[a] - c2[a]).abs() <= command_tol[a] && (m1[a] - m2[a]).abs() <= measured_tol[a]
        })
    };
    let mut offsets: HashMap<usize, usize> = HashMap::new();
    for (i, m) in means.iter().enumerate() {
        let Some(m) = m.as_ref().filter(|m| driven(m)) else {
            continue;
        };
        let [a, b] = cell(&m.0);
        let mut seen: Vec<usize> = Vec::new();
        for da in -1..=1 {
            for db in -1..=1 {
                for &j in cells.get(&[a + da, b + db]).into_iter().flatten() {
                    let apart = windows[j].interval.abs_diff(windows[i].interval) >= 2;
                    if j > i
                        && apart
                        && !seen.contains(&(j - i))
                        && means[j].as_ref().is_some_and(|o| agree(m, o))
                    {
                        seen.push(j - i);
                    }
                }
            }
        }
        for d in seen {
            *offsets.entry(d).or_default() += 1;
        }
    }
    let (offset, pairs) = offsets
        .into_iter()
        .max_by_key(|&(d, n)| (n, usize::MAX - d))?;
    (pairs >= MIN_COPIES && pairs as f64 >= COPY_SHARE * count as f64).then(|| Finding {
        check: Check::DuplicateWindows,
        severity: Severity::Fatal,
        message: format!(
            "{pairs} of the {count} driven windows agree with the window {offset} places later (mean command and measured input per axis, within {}% and {}% of their ranges), in order: the run or a part of it written again, its windows cut a few samples later? A split would score the models on windows they were fitted on",
            COMMAND_TOLERANCE * 100.0,
            MEASURED_TOLERANCE * 100.0
        ),
    })
}
