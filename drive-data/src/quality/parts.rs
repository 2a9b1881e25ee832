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
    localization, three_digits, yaw_units, Check, Finding, Severity, Short, Windows,
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
    out.extend(yaw_units(w.data, &w.windows));
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
    for f in scales(w) {
        let shown = |g: &Finding| g.check == f.check && g.severity == Severity::Fatal;
        if !whole.iter().any(shown) && !out.iter().any(shown) {
            out.push(f);
        }
    }
    // The commands' forward speed and yaw rate exchanged in a part turn the robot against
    // them there too (`direction`): the exchange is the cause, said first.
    out.sort_by_key(|f| !f.message.contains("forward speed and yaw rate exchanged"));
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
    let mut out: Vec<Finding> = Vec::new();
    for (name, members) in part_sets(w) {
        let where_ = format!("in {name} alone");
        for f in direction_of(members.iter().map(|&i| &signals[i])) {
            add_new(f, &where_, whole, &mut out);
        }
    }
    out
}

/// The parts [`directions`] and [`scales`] read, each named, as the indices of its windows.
fn part_sets(w: &Windows<'_>) -> Vec<(String, Vec<usize>)> {
    let n = w.windows.len();
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
    parts
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

/// Sums for a least-squares line through the origin, `y = gain x`, and for the mean of `y -
/// gain x` under another line's gain, kept so that the rest of the run is the whole run's
/// sums less a part's.
#[derive(Debug, Clone, Copy, Default)]
struct Line {
    n: f64,
    x: f64,
    y: f64,
    xx: f64,
    xy: f64,
    yy: f64,
}

impl Line {
    fn add(&mut self, x: f64, y: f64) {
        self.n += 1.0;
        self.x += x;
        self.y += y;
        self.xx += x * x;
        self.xy += x * y;
        self.yy += y * y;
    }

    fn plus(self, o: Line) -> Line {
        self.with(o, 1.0)
    }

    fn less(self, o: Line) -> Line {
        self.with(o, -1.0)
    }

    /// These sums and `sign` times `o`'s.
    fn with(self, o: Line, sign: f64) -> Line {
        Line {
            n: self.n + sign * o.n,
            x: self.x + sign * o.x,
            y: self.y + sign * o.y,
            xx: self.xx + sign * o.xx,
            xy: self.xy + sign * o.xy,
            yy: self.yy + sign * o.yy,
        }
    }

    /// The gain of the line through the origin and its standard error, over ten points or
    /// more.
    fn gain(&self) -> Option<(f64, f64)> {
        if self.n < SCALE_MIN_WINDOWS || self.xx <= 0.0 {
            return None;
        }
        let g = self.xy / self.xx;
        let scatter = (self.yy - g * self.xy).max(0.0) / (self.n - 1.0);
        Some((g, (scatter / self.xx).sqrt()))
    }

    /// The mean of `y - gain x` and its standard error, over ten points or more.
    fn offset(&self, gain: f64) -> Option<(f64, f64)> {
        if self.n < SCALE_MIN_WINDOWS {
            return None;
        }
        let mean = (self.y - gain * self.x) / self.n;
        let squares = self.yy - 2.0 * gain * self.xy + gain * gain * self.xx;
        let scatter = (squares - self.n * mean * mean).max(0.0) / (self.n - 1.0);
        Some((mean, (scatter / self.n).sqrt()))
    }
}

/// The fewest windows a part (and the rest of the run) must hold of a kind for [`scales`]
/// to compare them.
const SCALE_MIN_WINDOWS: f64 = 10.0;

/// A part's gain and the rest's that differ by this factor or more (either way) differ in
/// [`scales`], when the difference is also beyond [`SCALE_SIGNIFICANCE`] standard errors.
/// On 330 real and simulated runs and their parts cut out as runs of their own, the largest
/// factor between a part and the rest was 1.95 (commands beyond the Husky's reach, held by
/// some parts more than others); a column scaled by 3 or by 0.3 in a part gives 2.8-3.5.
const SCALE_FACTOR: f64 = 2.2;

/// How many standard errors a part's gain or offset must differ from the rest's by.
const SCALE_SIGNIFICANCE: f64 = 4.0;

/// A part's measured inputs offset from the rest's (at the commands under
/// [`LOW_COMMAND`] of the largest) by this share of the axis's largest command or more
/// differ in [`scales`].
const SCALE_OFFSET: f64 = 0.1;

/// The commands [`scales`] reads an offset on: under this share of the axis's largest.
const LOW_COMMAND: f64 = 0.3;

/// The commands [`scales`] reads a gain on: this share of the axis's largest or more.
const GAIN_COMMAND: f64 = 0.2;

/// A window's sums for [`scales`]: per input axis, a steady window's mean command and
/// measurement (as shares of the axis's largest command) where it commands
/// [`GAIN_COMMAND`] of the largest or more, and where it commands under [`LOW_COMMAND`];
/// the forward travel localization saw against the one the encoders imply, where they imply
/// 0.2 m or more.
#[derive(Debug, Clone, Copy, Default)]
struct ScaleSums {
    commanded: [Line; drive_traits::MAX_INPUTS],
    low: [Line; drive_traits::MAX_INPUTS],
    forward: Line,
}

impl ScaleSums {
    fn plus(&self, o: &ScaleSums) -> ScaleSums {
        self.with(o, 1.0)
    }

    fn less(&self, o: &ScaleSums) -> ScaleSums {
        self.with(o, -1.0)
    }

    /// These sums and `sign` times `o`'s.
    fn with(&self, o: &ScaleSums, sign: f64) -> ScaleSums {
        let mut out = *self;
        for i in 0..drive_traits::MAX_INPUTS {
            out.commanded[i] = self.commanded[i].with(o.commanded[i], sign);
            out.low[i] = self.low[i].with(o.low[i], sign);
        }
        out.forward = self.forward.with(o.forward, sign);
        out
    }
}

/// Each interval's steady windows as one point per input axis: the means of its command
/// and of its measurement over them, as shares of the axis's largest command (`None` where
/// that is zero or not finite), given to the first of them (`None` for the other windows'
/// axes).
/// An interval's steady windows hold one command and answer it alike: counted as two, they
/// would halve the standard errors' variance for nothing.
fn interval_points(
    w: &Windows<'_>,
    axes: usize,
) -> Vec<[Option<(f64, f64)>; drive_traits::MAX_INPUTS]> {
    let mut largest = [0.0f64; drive_traits::MAX_INPUTS];
    for win in &w.windows {
        for c in &win.command {
            for (i, l) in largest.iter_mut().enumerate().take(axes) {
                *l = l.max(c[i].abs());
            }
        }
    }
    let n = w.windows.len();
    let mut means = vec![[None; drive_traits::MAX_INPUTS]; n];
    let mut k = 0;
    while k < n {
        let mut end = k;
        while end < n && w.windows[end].interval == w.windows[k].interval {
            end += 1;
        }
        let steady: Vec<&&drive_traits::Window> = w.windows[k..end]
            .iter()
            .filter(|win| win.phase == drive_traits::Phase::Steady)
            .collect();
        if let Some(first) = (k..end).find(|&j| w.windows[j].phase == drive_traits::Phase::Steady) {
            let samples = steady.iter().map(|win| win.len()).sum::<usize>() as f64;
            let mut point = [None; drive_traits::MAX_INPUTS];
            for (i, l) in largest.iter().enumerate().take(axes) {
                // Scaled by the largest command, so that tiny commands do not underflow.
                let (c, m) = steady.iter().fold((0.0, 0.0), |(c, m), win| {
                    (
                        c + win.command.iter().map(|u| u[i] / l).sum::<f64>(),
                        m + win.measured.iter().map(|u| u[i] / l).sum::<f64>(),
                    )
                });
                if *l > 0.0 && l.is_finite() {
                    point[i] = Some((c / samples, m / samples));
                }
            }
            means[first] = point;
        }
        k = end;
    }
    means
}

/// Per input axis, how much of each other axis's command its measurement follows where it is
/// commanded little ([`LOW_COMMAND`]), over the whole run: `coupling[i][j]`, the gain through
/// the origin of axis `i`'s measurement less its own gain times its command on axis `j`'s
/// command, fitted one other axis after the other. A powertrain that limits the body's
/// velocity drags a slow wheel with the fast one (the Husky's firmware: 0.2-0.3 of the other
/// wheel's command): read as an offset, a stretch that spins one way more than the rest
/// would differ from it by that much. Zero where the axes answer alone.
fn coupling(
    means: &[[Option<(f64, f64)>; drive_traits::MAX_INPUTS]],
    axes: usize,
) -> [[f64; drive_traits::MAX_INPUTS]; drive_traits::MAX_INPUTS] {
    let mut out = [[0.0; drive_traits::MAX_INPUTS]; drive_traits::MAX_INPUTS];
    let points: Vec<&[Option<(f64, f64)>; drive_traits::MAX_INPUTS]> = means
        .iter()
        .filter(|p| p.iter().take(axes).all(Option::is_some))
        .collect();
    for i in 0..axes {
        let own = points.iter().fold(Line::default(), |mut l, p| {
            let (c, m) = p[i].unwrap_or_default();
            if c.abs() >= GAIN_COMMAND {
                l.add(c, m);
            }
            l
        });
        let Some((gain, _)) = own.gain() else {
            continue;
        };
        let low: Vec<&&[Option<(f64, f64)>; drive_traits::MAX_INPUTS]> = points
            .iter()
            .filter(|p| p[i].is_some_and(|(c, _)| c.abs() < LOW_COMMAND))
            .collect();
        let mut residual: Vec<f64> = low
            .iter()
            .map(|p| {
                let (c, m) = p[i].unwrap_or_default();
                m - gain * c
            })
            .collect();
        for j in (0..axes).filter(|&j| j != i) {
            let (xy, xx) = low
                .iter()
                .zip(&residual)
                .fold((0.0, 0.0), |(xy, xx), (p, r)| {
                    let c = p[j].unwrap_or_default().0;
                    (xy + c * r, xx + c * c)
                });
            if low.len() < SCALE_MIN_WINDOWS as usize || xx <= 0.0 {
                continue;
            }
            let h = xy / xx;
            out[i][j] = h;
            for (p, r) in low.iter().zip(residual.iter_mut()) {
                *r -= h * p[j].unwrap_or_default().0;
            }
        }
    }
    out
}

/// Each window's [`ScaleSums`].
fn scale_sums(w: &Windows<'_>, axes: usize) -> Vec<ScaleSums> {
    let means = interval_points(w, axes);
    let coupling = coupling(&means, axes);
    w.windows
        .iter()
        .zip(&w.travels)
        .zip(means)
        .map(|((_, (seen, implied, _)), point)| {
            let mut s = ScaleSums::default();
            for (i, (c, m)) in point
                .iter()
                .enumerate()
                .take(axes)
                .filter_map(|(i, p)| Some((i, (*p)?)))
            {
                if c.abs() >= GAIN_COMMAND {
                    s.commanded[i].add(c, m);
                }
                if c.abs() < LOW_COMMAND {
                    // What the other axes' commands drag this one by is not an offset.
                    let dragged: f64 = (0..axes)
                        .filter(|&j| j != i)
                        .map(|j| coupling[i][j] * point[j].map_or(0.0, |p| p.0))
                        .sum();
                    s.low[i].add(c, m - dragged);
                }
            }
            if implied[0].abs() >= 0.2 {
                s.forward.add(implied[0], seen[0]);
            }
            s
        })
        .collect()
}

/// Whether `part`'s gain differs from `rest`'s (see [`SCALE_FACTOR`]): the factor between
/// them (`part / rest`), when it does.
fn scaled(part: (f64, f64), rest: (f64, f64)) -> Option<f64> {
    let ((a, sa), (b, sb)) = (part, rest);
    let factor = a / b;
    let far = !(1.0 / SCALE_FACTOR..=SCALE_FACTOR).contains(&factor);
    (far && (a - b).abs() > SCALE_SIGNIFICANCE * sa.hypot(sb)).then_some(factor)
}

/// `encoder-command` and `encoder-units` on every part of [`part_sets`] against the rest of
/// the run: a measured input that follows its command with another gain there than in the
/// rest (by a factor of [`SCALE_FACTOR`] or more, or the other sign), or offset from the
/// rest's (by [`SCALE_OFFSET`] of its largest command), and localization that saw another
/// share of the forward travel the encoders imply there (by that factor: where the rest
/// saw half of it or more and the part less, a warning, for wheels spin on a slippery
/// stretch; the part more than 1.5 times it, fatal, for no robot travels faster than its
/// wheels). A run is one robot with one set of sensors: its columns' units and signs do
/// not change halfway, and its wheels follow their commands alike on any ground. The part
/// that differs most is named.
fn scales(w: &Windows<'_>) -> Vec<Finding> {
    let axes_desc = w.data.robot.vehicle.axes();
    let axes = axes_desc.len().min(drive_traits::MAX_INPUTS);
    let sums = scale_sums(w, axes);
    let total = sums.iter().fold(ScaleSums::default(), |acc, s| acc.plus(s));
    // The whole run's gain per axis, for the offsets.
    let gains: Vec<Option<f64>> = (0..axes)
        .map(|i| total.commanded[i].gain().map(|g| g.0))
        .collect();
    // Per check, the part that differs most: (how far, its finding).
    let mut command: Option<(f64, Finding)> = None;
    let mut units: Option<(f64, Finding)> = None;
    let keep = |slot: &mut Option<(f64, Finding)>, far: f64, message: String, check, severity| {
        if slot.as_ref().is_none_or(|(f, _)| far > *f) {
            *slot = Some((
                far,
                Finding {
                    check,
                    severity,
                    message,
                },
            ));
        }
    };
    for (name, members) in part_sets(w) {
        let part = members
            .iter()
            .fold(ScaleSums::default(), |acc, &k| acc.plus(&sums[k]));
        let rest = total.less(&part);
        let travel = match (part.forward.gain(), rest.forward.gain()) {
            (Some(p), Some(r)) => Some((p, r)),
            _ => None,
        };
        for (i, axis) in axes_desc.iter().enumerate().take(axes) {
            let (measured, commanded) = (axis.measured_column, axis.command_column);
            if let (Some(p), Some(r)) = (part.commanded[i].gain(), rest.commanded[i].gain()) {
                if r.0 >= 0.3 {
                    if let Some(factor) = scaled(p, r) {
                        let which = if p.0 < 0.0 {
                            "moves against its commands there: its sign, or its command's, flipped in that part".to_string()
                        } else {
                            // The encoders scaled change the travel localization saw of
                            // theirs; the commands scaled do not.
                            let encoders = travel.is_some_and(|(tp, tr)| {
                                let seen = tp.0 / tr.0;
                                (seen - 1.0 / factor).abs() < (seen - 1.0).abs()
                            });
                            if encoders {
                                format!("'{measured}' scaled there (localization saw a share of its travel changed alike): in another unit in that part?")
                            } else {
                                format!("'{measured}' or '{commanded}' scaled there: in another unit in that part?")
                            }
                        };
                        keep(
                            &mut command,
                            factor.abs().ln().abs() + if p.0 < 0.0 { 10.0 } else { 0.0 },
                            format!(
                                "'{measured}' follows its commands '{commanded}' with a gain of {:.3} in {name} and {:.3} in the rest of the run (least squares over {} and {} intervals' steady windows): {which}",
                                p.0, r.0, part.commanded[i].n, rest.commanded[i].n
                            ),
                            Check::EncoderCommand,
                            Severity::Fatal,
                        );
                    }
                }
            }
            let Some(g) = gains[i] else { continue };
            if let (Some(p), Some(r)) = (part.low[i].offset(g), rest.low[i].offset(g)) {
                let d = p.0 - r.0;
                if d.abs() >= SCALE_OFFSET && d.abs() > SCALE_SIGNIFICANCE * p.1.hypot(r.1) {
                    keep(
                        &mut command,
                        d.abs(),
                        format!(
                            "'{measured}' reads {:+.3} of its largest command more in {name} than in the rest of the run, at the same small commands (over {} and {} intervals commanding under {}% of the largest): an offset added to '{measured}' or '{commanded}' in that part?",
                            d, part.low[i].n, rest.low[i].n, LOW_COMMAND * 100.0
                        ),
                        Check::EncoderCommand,
                        Severity::Fatal,
                    );
                }
            }
        }
        if let Some((p, r)) = travel {
            let lost = r.0 >= 0.5 && p.0 < r.0;
            let faster = p.0 > 1.5 && p.0 > r.0;
            if let Some(factor) = scaled(p, r).filter(|_| lost || faster) {
                // Seeing less: the wheels spun there (a simulated robot driving from tile
                // onto ice: 0.10 of the travel against 0.65), or localization scaled or
                // frozen there (whose turn the IMU tells: [`turn_faults`]): a warning.
                // Seeing more than the wheels drive: fatal.
                keep(
                    &mut units,
                    factor.abs().ln().abs() + if faster { 10.0 } else { 0.0 },
                    format!(
                        "localization saw {:.3} of the forward travel the encoders imply in {name} and {:.3} in the rest of the run (least squares over {} and {} windows): {}",
                        p.0,
                        r.0,
                        part.forward.n,
                        rest.forward.n,
                        if faster {
                            "localization scaled there (no robot travels faster than its wheels), or the encoders?"
                        } else {
                            "the wheels spinning there (ice, mud), or localization scaled or frozen there?"
                        }
                    ),
                    Check::EncoderUnits,
                    Severity::fatal_if(faster),
                );
            }
        }
    }
    command
        .into_iter()
        .chain(units)
        .map(|(_, f)| match f.severity {
            Severity::Fatal => Finding {
                message: format!(
                    "{}; part of the run corrupted, or joined from another run or robot?",
                    f.message
                ),
                ..f
            },
            Severity::Warning => f,
        })
        .collect()
}

/// What [`turn_faults`] found: localization's turn at odds with both the IMU's and the
/// encoders' in a part (which agree with each other there as elsewhere), or the IMU's sign
/// flipped in a part (at odds with both there).
pub(super) enum TurnFault {
    /// Localization mirrored, frozen or from another run in a part (fatal).
    Localization(Finding),
    /// The IMU read backwards in a part only (a warning, as for a whole run read so).
    ImuFlipped(Finding),
    /// The IMU scaled in a part only (fatal where it reads under half or over twice the
    /// turn, as for a whole run).
    ImuScaled(Finding),
}

/// The three turns of a run's parts against each other: localization's and the encoders'
/// on the IMU's, part against the rest of the run (every part of [`part_sets`], over the
/// windows where the IMU turned 0.2 rad or more). `imu-yaw-rate` compares the IMU with
/// localization only, and blames the IMU for a localization corrupted in a part (mirrored,
/// frozen, another run's); a run joined from two, one of whose IMUs read backwards, reads
/// little of the turn in the whole. The third sensor tells which one is odd: the part
/// whose localization turns another way from the IMU while its encoders turn with it as in
/// the rest of the run, or whose IMU turns against both. `None` without an IMU that varies.
pub(super) fn turn_faults(w: &Windows<'_>) -> Option<TurnFault> {
    let dt = w.data.robot.dt();
    let mut imu = w.windows.iter().flat_map(|win| win.imu_yaw_rate.iter());
    let first = imu.next().copied()?;
    if imu.all(|v| *v == first) {
        return None;
    }
    // Per window: [localization, encoders] on the IMU.
    let lines: Vec<[Line; 2]> = w
        .windows
        .iter()
        .zip(&w.motions)
        .zip(&w.travels)
        .map(|((win, m), travel)| {
            let mut out = [Line::default(); 2];
            let turn: f64 = win.imu_yaw_rate.iter().take(win.len() - 1).sum::<f64>() * dt;
            if turn.is_finite() && turn.abs() >= 0.2 {
                out[0].add(turn, m.3);
                out[1].add(turn, travel.2);
            }
            out
        })
        .collect();
    let sum = |members: &mut dyn Iterator<Item = usize>| {
        members.fold([Line::default(); 2], |acc, k| {
            [acc[0].plus(lines[k][0]), acc[1].plus(lines[k][1])]
        })
    };
    let total = sum(&mut (0..lines.len()));
    let agrees = |g: f64| (0.75..=1.0 / 0.75).contains(&g);
    let flipped = |g: f64| (-1.0 / 0.75..=-0.75).contains(&g);
    let mut best: Option<(f64, TurnFault)> = None;
    for (name, members) in part_sets(w) {
        let part = sum(&mut members.iter().copied());
        let rest = [total[0].less(part[0]), total[1].less(part[1])];
        let (Some(lp), Some(lr), Some(ep), Some(er)) = (
            part[0].gain(),
            rest[0].gain(),
            part[1].gain(),
            rest[1].gain(),
        ) else {
            continue;
        };
        if (lp.0 - lr.0).abs() <= SCALE_SIGNIFICANCE * lp.1.hypot(lr.1) {
            continue;
        }
        let how_far = (lp.0 - lr.0).abs() / lp.1.hypot(lr.1);
        // Localization odd: the encoders on the IMU as in the rest (a change of ground moves
        // them by up to a fifth). The IMU scaled: localization and the encoders on it moved
        // alike (within 30% of each other), by half again or more.
        let encoders_with_imu = (0.7..=1.4).contains(&(ep.0 / er.0));
        let (moved_l, moved_e) = (lp.0 / lr.0, ep.0 / er.0);
        let imu_scaled = agrees(lr.0)
            && er.0 > 0.0
            && moved_l > 0.0
            && moved_e > 0.0
            && (moved_l.ln() - moved_e.ln()).abs() < 1.3f64.ln()
            && moved_l.ln().abs() > 1.5f64.ln();
        // The IMU backwards in one of the two and not the other, the encoders turning with
        // localization in both (against the IMU where it is backwards).
        let imu_flipped_in = if flipped(lp.0) && agrees(lr.0) && ep.0 < 0.0 && er.0 > 0.0 {
            Some("that part")
        } else if agrees(lp.0) && flipped(lr.0) && ep.0 > 0.0 && er.0 < 0.0 {
            Some("the rest of the run")
        } else {
            None
        };
        let localization_odd =
            agrees(lr.0) && er.0 > 0.0 && encoders_with_imu && (lp.0 < 0.5 || lp.0 > 2.0);
        let fault = if localization_odd {
            TurnFault::Localization(Finding {
                check: Check::LocalizationSync,
                severity: Severity::Fatal,
                message: format!(
                    "localization turns {} times the IMU's turn in {name} and {} times in the rest of the run, while the encoders turn alike with the IMU in both ({} and {} times; least squares over {} and {} windows where the IMU turned 0.2 rad or more): localization mirrored, frozen or from another run in that part, not the IMU; part of the run corrupted, or joined from another run or robot?",
                    Short(three_digits(lp.0)),
                    Short(three_digits(lr.0)),
                    Short(three_digits(ep.0)),
                    Short(three_digits(er.0)),
                    part[0].n,
                    rest[0].n
                ),
            })
        } else if imu_scaled {
            // The IMU reads 1 / lp of localization's turn there.
            let gain = 1.0 / lp.0;
            TurnFault::ImuScaled(Finding {
                check: Check::ImuYawRate,
                severity: Severity::fatal_if(!(0.5..=2.0).contains(&gain)),
                message: format!(
                    "the IMU's yaw rate integrates to {} times the turn localization saw in {name} and {} times in the rest of the run, and to {} times the encoders' there against {} elsewhere (least squares over {} and {} windows where the IMU turned 0.2 rad or more): the IMU scaled in that part (another unit, or another signal?); part of the run corrupted, or joined from another run or robot?",
                    Short(three_digits(gain)),
                    Short(three_digits(1.0 / lr.0)),
                    Short(three_digits(1.0 / ep.0)),
                    Short(three_digits(1.0 / er.0)),
                    part[0].n,
                    rest[0].n
                ),
            })
        } else if let Some(which) = imu_flipped_in {
            TurnFault::ImuFlipped(Finding {
                check: Check::ImuYawRate,
                severity: Severity::Warning,
                message: format!(
                    "the IMU's yaw rate integrates to {} times the turn localization saw in {name} and {} times in the rest of the run, the encoders turning with localization in both (least squares over {} and {} windows where the IMU turned 0.2 rad or more): its sign flipped in {which} (a run joined from two recordings?): the models that start from the IMU's yaw rate (slip-ipem, acc-BLR, --start encoders+imu) start turning the wrong way there; negate the imu_yaw_rate column in {which}, or give --start encoders",
                    Short(three_digits(lp.0)),
                    Short(three_digits(lr.0)),
                    part[0].n,
                    rest[0].n
                ),
            })
        } else {
            continue;
        };
        if best.as_ref().is_none_or(|(f, _)| how_far > *f) {
            best = Some((how_far, fault));
        }
    }
    best.map(|(_, f)| f)
}
