//! The checks of localization against itself and against the encoders: its positions
//! against its own heading (`localization-frame`), its motion per window against the
//! encoders' (`localization-sync`), and the grid its positions lie on (`position-steps`).

use super::{Check, Finding, Severity, Windows};
use drive_traits::limits::Short;
use drive_traits::{Dataset, Window};

/// Fewest windows a localization check judges on.
const MIN_WINDOWS: usize = 10;
/// The interquartile range of the windows' angles (degrees) beyond which a median offset is
/// a robot sliding, not a yaw offset (see `frame`).
const OFFSET_SPREAD_DEGREES: f64 = 15.0;

/// `localization-frame`, a constant offset: the median signed angle (degrees) between the
/// travel localization saw and the one the encoders imply, in the body frame, at or beyond
/// which the heading is from another frame than the positions (0.0-7.8 on the bundled runs,
/// their halves and subsets, and simulated skid-steers, cars and a mecanum base; a yaw offset
/// of 30 degrees gives 25-30).
const OFFSET_DEGREES: f64 = 20.0;

/// `localization-frame`, any disagreement: the median unsigned angle (degrees) at or beyond
/// which the positions do not move where the heading points (1-25 on the same runs: a
/// Warthog's turns slip sideways, a mecanum base's rollers; x and y swapped give 86-118, a
/// car's or mecanum base's yaw in degrees 58-71).
const ANGLE_DEGREES: f64 = 45.0;

/// `localization-frame`: a median unsigned angle beyond which the positions move backwards
/// along the heading: `direction`'s finding, not this one's.
const BACKWARDS_DEGREES: f64 = 135.0;

/// `localization-sync`: the best correlation over the axes that vary under which
/// localization does not follow the encoders (0.77-1.0 on the same runs; another run's
/// localization: under 0.21; one clearly negative, -0.7 or less, is `direction`'s).
const MIN_CORRELATION: f64 = 0.3;

/// `localization-sync`: how much better the window before's or after's encoders must explain
/// localization than its own window's, on every axis, for localization shifted by a window
/// (own-window correlations beat the neighbours' by 0.02-0.27 on the bundled and norlab runs,
/// the gravel run's turn the least; shifted one window later, the neighbour wins by 0.086 on
/// the turn, 0.148 on the travel: the windows of one interval share their command, so a
/// neighbour still explains much).
pub(super) const SHIFT_MARGIN: f64 = 0.05;

/// `position-steps`: the grid (m) from which positions are coarse (a warning), and from
/// which fatal.
const STEP_WARNING: f64 = 0.02;
/// See [`STEP_WARNING`].
const STEP_FATAL: f64 = 0.1;

/// A window's travel in the robot's body frame, summed step by step: as localization saw it
/// (each step's displacement turned by localization's own heading at its start) and as the
/// encoders imply it (eq. 4's body velocity times the step), each (forward, sideways); and
/// the turn the encoders imply.
pub(super) fn body_travel(data: &Dataset, w: &Window) -> ([f64; 2], [f64; 2], f64) {
    let dt = data.robot.dt();
    let (mut seen, mut implied, mut turn) = ([0.0; 2], [0.0; 2], 0.0);
    for k in 0..w.len().saturating_sub(1) {
        let (p, q) = (w.pose[k], w.pose[k + 1]);
        let (dx, dy) = (q.x - p.x, q.y - p.y);
        let (sin, cos) = p.z.sin_cos();
        seen[0] += cos * dx + sin * dy;
        seen[1] += -sin * dx + cos * dy;
        let v = data.robot.vehicle.body_velocity(&w.measured[k]);
        implied[0] += v.x * dt;
        implied[1] += v.y * dt;
        turn += v.z * dt;
    }
    (seen, implied, turn)
}

/// Per window ([seen forward, sideways, turn], [implied forward, sideways, turn]): the
/// rotation (degrees) of the least-squares map from the implied travel to the seen one, and
/// the share of the seen sideways travel's sum of squares that map explains. The implied
/// sideways travel is a regressor only when it varies (`crabs`). `None` when the implied
/// forward travel never varies.
fn travel_rotation(rows: &[([f64; 3], [f64; 3])], crabs: bool) -> Option<(f64, f64)> {
    // Normal equations of seen[k] = m[k][0] * implied forward + m[k][1] * implied sideways.
    let (mut ff, mut fs, mut ss) = (0.0, 0.0, 0.0);
    let (mut fy, mut sy) = ([0.0; 2], [0.0; 2]);
    for (seen, implied) in rows {
        let (f, s) = (implied[0], if crabs { implied[1] } else { 0.0 });
        ff += f * f;
        fs += f * s;
        ss += s * s;
        for k in 0..2 {
            fy[k] += f * seen[k];
            sy[k] += s * seen[k];
        }
    }
    let det = ff * ss - fs * fs;
    let m: [[f64; 2]; 2] = if crabs && det > 1e-12 * ff * ss {
        std::array::from_fn(|k| {
            [
                (ss * fy[k] - fs * sy[k]) / det,
                (ff * sy[k] - fs * fy[k]) / det,
            ]
        })
    } else if ff > 0.0 {
        std::array::from_fn(|k| [fy[k] / ff, 0.0])
    } else {
        return None;
    };
    // m = [[c, d], [a, b]] ~ R(theta) diag(gx, gy): a - d and c + b are (gx + gy) times the
    // sine and cosine.
    let rotation = (m[1][0] - m[0][1]).atan2(m[0][0] + m[1][1]).to_degrees();
    let (mut residual, mut total) = (0.0, 0.0);
    for (seen, implied) in rows {
        let s = if crabs { implied[1] } else { 0.0 };
        residual += (seen[1] - m[1][0] * implied[0] - m[1][1] * s).powi(2);
        total += seen[1] * seen[1];
    }
    Some((
        rotation,
        if total > 0.0 {
            1.0 - residual / total
        } else {
            0.0
        },
    ))
}

/// Pearson's correlation of the pairs; 0 when either side does not vary.
pub(super) fn correlation(pairs: impl Iterator<Item = (f64, f64)> + Clone) -> f64 {
    let (mut n, mut sa, mut sb) = (0.0, 0.0, 0.0);
    for (a, b) in pairs.clone() {
        n += 1.0;
        sa += a;
        sb += b;
    }
    if n < 2.0 {
        return 0.0;
    }
    let (ma, mb) = (sa / n, sb / n);
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (a, b) in pairs {
        ab += (a - ma) * (b - mb);
        aa += (a - ma).powi(2);
        bb += (b - mb).powi(2);
    }
    if aa > 0.0 && bb > 0.0 {
        ab / (aa * bb).sqrt()
    } else {
        0.0
    }
}

/// `localization-frame`: where the encoders imply 0.3 m of travel and localization saw
/// 0.15 m, the angle between the two in the body frame (localization's own heading turning
/// its positions' steps): a median signed angle of 20 degrees or more is a heading from
/// another frame (a yaw offset); a median unsigned one of 45 degrees or more, positions
/// that do not move where the heading points (x and y swapped, a yaw in degrees). And where
/// the path the positions draw clearly turns (0.1 m travelled in the window's first and
/// last quarter, 0.3 rad of yaw between them), it turns against the yaw in over four
/// fifths of the windows: y (or x) negated alone. Fatal: a model fitted on it learns a
/// robot driving sideways.
pub(super) fn frame(w: &Windows<'_>) -> Vec<Finding> {
    let (mut signed, mut course, mut course_agree) = (Vec::new(), 0usize, 0usize);
    for ((win, &(seen, implied, _)), m) in w.windows.iter().zip(&w.travels).zip(&w.motions) {
        // Nearly straight windows only (localization turned under 0.2 rad): through a turn
        // on a slippery ground the body slides where its heading no longer points (a
        // simulated Warthog on ice, 45 degrees).
        // And where the encoders drive along the heading (sideways under 0.3 of forward: a
        // mecanum base's rollers slip when it crabs, 22 degrees).
        if implied[0].hypot(implied[1]) >= 0.3
            && implied[1].abs() <= 0.3 * implied[0].abs()
            && seen[0].hypot(seen[1]) >= 0.15
            && m.3.abs() < 0.2
        {
            let cross = implied[0] * seen[1] - implied[1] * seen[0];
            let dot = implied[0] * seen[0] + implied[1] * seen[1];
            signed.push(cross.atan2(dot).to_degrees());
        }
        let n = win.len();
        let q = n / 4;
        if q < 2 {
            continue;
        }
        let direction = |a: usize, b: usize| {
            let (p, r) = (win.pose[a], win.pose[b]);
            ((r.x - p.x).hypot(r.y - p.y), (r.y - p.y).atan2(r.x - p.x))
        };
        let ((d0, c0), (d1, c1)) = (direction(0, q), direction(n - 1 - q, n - 1));
        let yaw = drive_traits::net_turn(&win.pose[q / 2..=n - 1 - q / 2]);
        if d0 >= 0.1 && d1 >= 0.1 && yaw.abs() >= 0.3 {
            let turned = (c1 - c0).sin().atan2((c1 - c0).cos());
            course += 1;
            course_agree += usize::from(turned.signum() == yaw.signum());
        }
    }
    let mut out = Vec::new();
    let windows = signed.len();
    if windows >= MIN_WINDOWS {
        let mut unsigned: Vec<f64> = signed.iter().map(|a| a.abs()).collect();
        // How much the windows agree: a yaw offset turns every window by it (interquartile
        // range 0.6-2.5 degrees on real runs with 0.4 rad added to the heading), a robot
        // sliding on ice by what each window's past left it (34 degrees).
        let spread = {
            let mut sorted = signed.clone();
            sorted.sort_by(f64::total_cmp);
            let at = |q: f64| sorted[((sorted.len() - 1) as f64 * q).round() as usize];
            at(0.75) - at(0.25)
        };
        let (offset, angle) = (
            drive_traits::median(&mut signed),
            drive_traits::median(&mut unsigned),
        );
        if angle >= BACKWARDS_DEGREES {
            // Moving backwards along the heading: direction's (encoders sign-flipped, the
            // heading turned half a turn).
        } else if angle >= ANGLE_DEGREES
            && (spread > OFFSET_SPREAD_DEGREES || offset.abs() < OFFSET_DEGREES)
        {
            // Most of the windows at 45 degrees or more either way, scattered (no robot
            // slides so: sliding turns the motion a few tens of degrees) or with no offset
            // one way.
            out.push(Finding {
                check: Check::LocalizationFrame,
                severity: Severity::Fatal,
                message: format!(
                    "localization's positions move {} degrees either way from where its own heading points, where the encoders drive along it (median over {windows} windows): x and y swapped, one axis negated, a yaw in degrees, or each window's positions in the world's orientation rather than turned into its start frame?",
                    Short(angle.round())
                ),
            });
        } else if offset.abs() >= OFFSET_DEGREES && spread > OFFSET_SPREAD_DEGREES {
            out.push(Finding {
                check: Check::LocalizationFrame,
                severity: Severity::Warning,
                message: format!(
                    "localization's positions move {} degrees from where its own heading points, where the encoders drive along it (median over {windows} windows), but scattered ({} degrees between the quartiles; a yaw offset turns every window alike): the robot sliding sideways (ice)?",
                    Short(offset.round()),
                    Short(spread.round())
                ),
            });
        } else if offset.abs() >= OFFSET_DEGREES {
            out.push(Finding {
                check: Check::LocalizationFrame,
                severity: Severity::Fatal,
                message: format!(
                    "localization's positions move {} degrees from where its own heading points, where the encoders drive along it (median over {windows} windows): a heading from another frame than the positions (a yaw offset), or the positions' axes turned?",
                    Short(offset.round())
                ),
            });
        }
    }
    if out.is_empty()
        && course >= MIN_WINDOWS
        && (course_agree as f64) < super::DIRECTION_MAX_AGREEING * course as f64
    {
        out.push(Finding {
            check: Check::LocalizationFrame,
            severity: Severity::Fatal,
            message: format!(
                "the path localization's positions draw turns against its own yaw in {} of {course} windows where both turn: y (or x) negated alone, or x and y swapped?",
                course - course_agree
            ),
        });
    }
    out
}

/// `localization-sync`: per window, localization's forward and sideways travel and its turn
/// against the encoders' (over the axes whose implied values spread by 0.05 m or rad or more,
/// at least twenty windows): the best correlation under 0.3 is localization that does not
/// follow the encoders (another run's); on every such axis a correlation with the window
/// before's or after's encoders higher by [`SHIFT_MARGIN`], and 0.7 or more, is localization
/// shifted by a window. Fatal: the model would learn motions from commands that did not cause them. Not
/// where localization slides sideways half as much as it moves forwards and the wheels
/// imply no sideways motion: a robot on ice follows no wheel.
pub(super) fn sync(w: &Windows<'_>) -> Vec<Finding> {
    if w.windows.len() < 2 * MIN_WINDOWS {
        return Vec::new();
    }
    // Per window: ([seen forward, sideways, turn], [implied ...]).
    let rows: Vec<([f64; 3], [f64; 3])> = w
        .travels
        .iter()
        .zip(&w.motions)
        .map(|(&(seen, implied, turn), m)| {
            ([seen[0], seen[1], m.3], [implied[0], implied[1], turn])
        })
        .collect();
    let n = rows.len() as f64;
    // The spread over the windows of each axis: [seen, implied].
    let spread = |axis: usize| {
        [0, 1].map(|side| {
            let value = |r: &([f64; 3], [f64; 3])| if side == 0 { r.0[axis] } else { r.1[axis] };
            let mean = rows.iter().map(value).sum::<f64>() / n;
            (rows.iter().map(|r| (value(r) - mean).powi(2)).sum::<f64>() / n).sqrt()
        })
    };
    let spreads = [spread(0), spread(1), spread(2)];
    // Sliding: localization moves sideways half as much as forwards where the wheels say
    // the robot cannot (a car on ice): its motion follows no wheel, and that is the ground,
    // not the log.
    let sliding = spreads[1][0] >= 0.5 * spreads[0][0] && spreads[1][1] < 0.5 * spreads[1][0];
    // The axes whose implied values vary (0.05 m or rad) and whose seen ones move (1 cm or
    // 0.01 rad: a localization that does not is not-moving's).
    let axes: Vec<usize> = (0..3)
        .filter(|&a| spreads[a][1] >= 0.05 && spreads[a][0] >= 0.01)
        .collect();
    if axes.is_empty() {
        return Vec::new();
    }
    // The correlation of the implied values of window i with the seen ones of window i + lag.
    let table = &rows;
    let at = |axis: usize, lag: isize| {
        let rows = table;
        let len = rows.len() as isize;
        correlation(
            (0..len)
                .filter(move |i| (0..len).contains(&(i + lag)))
                .map(move |i| (rows[i as usize].1[axis], rows[(i + lag) as usize].0[axis])),
        )
    };
    let names = ["forward travel", "sideways travel", "turn"];
    let own: Vec<(usize, f64)> = axes.iter().map(|&a| (a, at(a, 0))).collect();
    let best = own
        .iter()
        .copied()
        .fold((0, f64::NEG_INFINITY), |b, c| if c.1 > b.1 { c } else { b });
    // A localization moving clearly against the encoders is direction's (a sign flipped);
    // sideways (which direction does not read) here.
    let against = own.iter().any(|&(_, r)| r <= -0.7);
    if let Some(&(_, r)) = own.iter().find(|&&(a, r)| a == 1 && r <= -0.7) {
        return vec![Finding {
            check: Check::Direction,
            severity: Severity::Fatal,
            message: format!(
                "localization moves sideways against the encoders (correlation {} over {} windows): the sideways columns sign-flipped, or the localization mirrored?",
                Short((r * 100.0).round() / 100.0),
                rows.len()
            ),
        }];
    }
    if best.1 < MIN_CORRELATION && !against && !sliding {
        return vec![Finding {
            check: Check::LocalizationSync,
            severity: Severity::Fatal,
            message: format!(
                "localization does not follow the encoders: over {} windows its {} correlates with theirs at {} at best: another run's localization, or its timestamps shifted?",
                rows.len(),
                names[best.0],
                Short((best.1 * 100.0).round() / 100.0)
            ),
        }];
    }
    // The forward travel not following the encoders while the turn does: the positions
    // turned against the heading (a yaw offset of a quarter turn) on any vehicle, crabbing
    // ones included.
    let r = |axis: usize| own.iter().find(|&&(a, _)| a == axis).map(|&(_, r)| r);
    if let (Some(forward), Some(turn)) = (r(0), r(2)) {
        if forward.abs() < MIN_CORRELATION && turn >= 0.7 && !sliding {
            return vec![Finding {
                check: Check::LocalizationFrame,
                severity: Severity::Fatal,
                message: format!(
                    "the forward travel localization saw does not follow the encoders' (correlation {} over {} windows) while its turn does ({}): a heading from another frame than the positions (a quarter turn off), or x and y swapped?",
                    Short((forward * 100.0).round() / 100.0),
                    rows.len(),
                    Short((turn * 100.0).round() / 100.0)
                ),
            }];
        }
    }
    // The linear map from the implied travel (forward, sideways) to the seen one, by least
    // squares through the origin over every window: a frame turned against the heading by
    // theta maps it by a rotation (the slips scale each axis), so that the sideways travel
    // follows the implied forward one. Fatal where that rotation is 20 degrees or more
    // (0-10 on the bundled and simulated runs, a car sliding on ice 18) and the map explains
    // the sideways travel (R^2 0.6 or more: 0.81-0.99 for turned frames on firm ground,
    // 0.53-0.67 on snow and ice; a slide on ice does not follow the wheels, 0.04-0.38 where
    // the rotation reached 10 degrees or more).
    if let Some((rotation, explained)) = travel_rotation(&rows, spreads[1][1] >= 0.05) {
        // And only where localization turns with the encoders (0.9 or more): a car spinning
        // out on ice moves sideways as its wheels never say, and turns as they never say.
        let turns_along = own.iter().all(|&(a, r)| a != 2 || r >= 0.9);
        if rotation.abs() >= OFFSET_DEGREES
            && rotation.abs() < BACKWARDS_DEGREES
            && explained >= 0.6
            && turns_along
        {
            return vec![Finding {
                check: Check::LocalizationFrame,
                severity: Severity::Fatal,
                message: format!(
                    "localization's positions are turned {} degrees from its own heading against the travel the encoders imply (the best linear map over {} windows, explaining {}% of the sideways travel): a heading from another frame than the positions, or the positions rotated alone?",
                    Short(rotation.round()),
                    rows.len(),
                    Short((explained * 100.0).round())
                ),
            }];
        }
    }
    for (lag, which) in [(-1, "before"), (1, "after")] {
        let shifted: Vec<f64> = own.iter().map(|&(a, _)| at(a, lag)).collect();
        if own
            .iter()
            .zip(&shifted)
            .all(|(&(_, r0), &r)| r >= 0.7 && r >= r0 + SHIFT_MARGIN)
        {
            let (axis, r0) = own[0];
            return vec![Finding {
                check: Check::LocalizationSync,
                severity: Severity::Fatal,
                message: format!(
                    "localization follows the encoders of the window {which} better than its own window's (the {} correlates at {} against {}, over {} windows): its timestamps shifted by a window?",
                    names[axis],
                    Short((shifted[0] * 100.0).round() / 100.0),
                    Short((r0 * 100.0).round() / 100.0),
                    rows.len()
                ),
            }];
        }
    }
    Vec::new()
}

/// The lost-axis rule of `localization-frame` over tracks of positions (x, y) in their world
/// frame: what `drive import` runs on a raw log's positions, where a world axis fixed
/// becomes a moving one once each window is turned into its start frame.
///
/// ```
/// use drive_data::quality::{fixed_position_axis, Severity};
/// // y held at its first value while x moves: a column fixed.
/// let track: Vec<[f64; 2]> = (0..200).map(|k| [0.01 * k as f64, 3.0]).collect();
/// let finding = fixed_position_axis(&[track]).unwrap();
/// assert_eq!(finding.severity, Severity::Fatal);
/// assert!(finding.message.contains("localization's y never changes"));
/// ```
pub fn fixed_position_axis(tracks: &[Vec<[f64; 2]>]) -> Option<Finding> {
    let mut changes = [0usize; 2];
    for p in tracks.iter().flat_map(|t| t.windows(2)) {
        changes[0] += usize::from(p[1][0] != p[0][0]);
        changes[1] += usize::from(p[1][1] != p[0][1]);
    }
    let (fixed, moving) = match changes {
        [0, m] if m >= 100 => ("x", m),
        [m, 0] if m >= 100 => ("y", m),
        _ => return None,
    };
    Some(Finding {
        check: Check::LocalizationFrame,
        severity: Severity::Fatal,
        message: format!(
            "localization's {fixed} never changes while the other position moves on {moving} steps: a column fixed, or not recorded?"
        ),
    })
}

/// The checks of the windows' positions as tracks (x, y), one per window, collected once:
/// `position-steps` (on each position axis, the smallest change between two samples that
/// differ, when at least 20 changes, 95% of them, are whole multiples of it: a grid of 2 cm
/// or coarser is a warning, 10 cm or coarser fatal; world coordinates stored as 32-bit
/// floats give 0.5 m steps at 5,000 km from the origin), then `localization-frame`'s lost
/// axis (one position axis that never changes over a hundred or more steps where the other
/// changes: a column fixed, or not recorded; fatal).
pub(super) fn positions(w: &Windows<'_>) -> Vec<Finding> {
    let tracks: Vec<Vec<[f64; 2]>> = w
        .windows
        .iter()
        .map(|win| win.pose.iter().map(|p| [p.x, p.y]).collect())
        .collect();
    position_grid(&tracks)
        .into_iter()
        .chain(fixed_position_axis(&tracks))
        .collect()
}

/// The `position-steps` check over tracks of positions (x, y) in their world frame, one after
/// another: what `drive import` runs on a raw log's positions before each window is turned
/// into its own start frame (which leaves the grid off the axes).
///
/// ```
/// use drive_data::quality::{position_grid, Severity};
/// // Positions of a robot driving diagonally, stored as 32-bit floats 5,000 km from the origin.
/// let track: Vec<[f64; 2]> = (0..200)
///     .map(|k| {
///         let d = 0.07 * k as f64;
///         [(512_345.0 + d) as f32 as f64, (5_012_345.0 + d) as f32 as f64]
///     })
///     .collect();
/// let finding = position_grid(&[track]).unwrap();
/// assert_eq!(finding.severity, Severity::Fatal);
/// assert!(finding.message.contains("steps of 0.5 m"));
/// ```
pub fn position_grid(tracks: &[Vec<[f64; 2]>]) -> Option<Finding> {
    let mut coarsest: Option<(&str, f64)> = None;
    for (axis, name) in [(0, "x"), (1, "y")] {
        let steps: Vec<f64> = tracks
            .iter()
            .flat_map(|t| t.windows(2))
            .map(|p| (p[1][axis] - p[0][axis]).abs())
            .filter(|d| *d > 0.0 && d.is_finite())
            .collect();
        if steps.len() < 20 {
            continue;
        }
        let grid = steps.iter().copied().fold(f64::INFINITY, f64::min);
        if grid < 0.999 * STEP_WARNING {
            continue;
        }
        let on_grid = steps
            .iter()
            .filter(|d| {
                let m = *d / grid;
                (m - m.round()).abs() <= 0.02
            })
            .count();
        if on_grid * 20 >= steps.len() * 19 && coarsest.is_none_or(|(_, g)| grid > g) {
            coarsest = Some((name, grid));
        }
    }
    let (name, grid) = coarsest?;
    Some(Finding {
        check: Check::PositionSteps,
        // A grid of 0.1 m computed as 0.0999...: fatal too.
        severity: Severity::fatal_if(grid >= 0.999 * STEP_FATAL),
        message: format!(
            "localization's {name} moves in steps of {} m (every change a multiple of it): world coordinates stored as 32-bit floats, or written to too few digits? Every error includes that grid",
            Short((grid * 1e4).round() / 1e4)
        ),
    })
}
