//! Reference paths for path following: polylines with arc length, the four preset shapes
//! (straight line, circle, figure-eight, zigzag) scaled to a robot, and paths read from a
//! CSV of `x,y`.
//!
//! A path is followed from its first point to its last. It may cross itself (a
//! figure-eight does): where the robot is on it is always searched near where it was
//! ([`ReferencePath::project`] takes an arc-length window), never over the whole path, so
//! a crossing is passed, not jumped.

use drive_traits::{wrap_angle, Pose};
use thiserror::Error;

/// Most points of a path (a path file longer than that is refused).
pub const MAX_PATH_POINTS: usize = 100_000;

/// Largest coordinate of a path point (m): far beyond any test area, small enough that
/// squared distances stay finite.
pub const MAX_PATH_COORDINATE: f64 = 1e6;

/// The weight of the arc length travelled in where a robot is on a path
/// ([`ReferencePath::project_near`]): 0.01 per m^2.
pub const CONTINUITY: f64 = 0.01;

/// Two consecutive points closer than this (m) are one point.
const SAME_POINT_M: f64 = 1e-9;

/// Why a path is refused.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum PathError {
    /// Fewer than two distinct points: nothing to follow.
    #[error("path '{name}': {found} distinct point{}; a path needs at least two", if *.found == 1 { "" } else { "s" })]
    TooFewPoints {
        /// The path's name.
        name: String,
        /// Distinct points found.
        found: usize,
    },
    /// A coordinate is not a finite number within [`MAX_PATH_COORDINATE`].
    #[error("path '{name}', point {index} (x = {}, y = {}): coordinates must be finite numbers within 1e6 m", drive_traits::limits::Short(*.x), drive_traits::limits::Short(*.y))]
    BadPoint {
        /// The path's name.
        name: String,
        /// Index of the point (0-based).
        index: usize,
        /// Its x.
        x: f64,
        /// Its y.
        y: f64,
    },
    /// More than [`MAX_PATH_POINTS`] points.
    #[error("path '{name}': more than {MAX_PATH_POINTS} points")]
    TooManyPoints {
        /// The path's name.
        name: String,
    },
    /// A path file that is not a CSV of `x,y`.
    #[error("path '{name}', line {line}: {message}")]
    Csv {
        /// The path's name (its file).
        name: String,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// An unknown preset shape.
    #[error("unknown path '{0}' (the preset paths are line, circle, figure8 and zigzag; or a CSV file of x,y)")]
    UnknownShape(String),
    /// A preset scale that is not a positive length.
    #[error("a path's scale must be a positive length in m, got {}", drive_traits::limits::Short(*.0))]
    BadScale(f64),
}

/// The preset shapes, each of about the same length for a given scale `L` (so that every
/// path takes about as long at one speed): `line` 6 L straight ahead; `circle` of radius L
/// turning left (2 pi L); `figure8`, a lemniscate of Bernoulli of half-width 1.5 L (about
/// 7.9 L; its tightest turns have a radius of 0.5 L), starting at its crossing; `zigzag`,
/// six legs of length L with 120 degree turns, alternately left and right (sharp corners).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PathShape {
    /// Straight ahead.
    Line,
    /// A circle, counter-clockwise.
    Circle,
    /// A figure-eight (lemniscate of Bernoulli).
    FigureEight,
    /// A zigzag with sharp turns.
    Zigzag,
}

impl PathShape {
    /// Every preset, in the order listed.
    pub const ALL: [PathShape; 4] = [
        PathShape::Line,
        PathShape::Circle,
        PathShape::FigureEight,
        PathShape::Zigzag,
    ];

    /// The shape of a name (`line`, `circle`, `figure8` or `figure-eight`, `zigzag`).
    ///
    /// ```
    /// use drive_control::PathShape;
    /// assert_eq!(PathShape::parse("figure-eight").unwrap(), PathShape::FigureEight);
    /// assert!(PathShape::parse("spiral").is_err());
    /// ```
    pub fn parse(name: &str) -> Result<Self, PathError> {
        match name {
            "line" => Ok(PathShape::Line),
            "circle" => Ok(PathShape::Circle),
            "figure8" | "figure-eight" => Ok(PathShape::FigureEight),
            "zigzag" => Ok(PathShape::Zigzag),
            other => Err(PathError::UnknownShape(other.to_string())),
        }
    }

    /// The name.
    pub fn as_str(self) -> &'static str {
        match self {
            PathShape::Line => "line",
            PathShape::Circle => "circle",
            PathShape::FigureEight => "figure8",
            PathShape::Zigzag => "zigzag",
        }
    }

    /// The shape at scale `scale` (m), starting at the origin along +x.
    ///
    /// ```
    /// use drive_control::PathShape;
    /// let c = PathShape::Circle.at_scale(2.0).unwrap();
    /// assert!((c.length() - 4.0 * std::f64::consts::PI).abs() < 0.01);
    /// let z = PathShape::Zigzag.at_scale(1.0).unwrap();
    /// assert!((z.length() - 6.0).abs() < 1e-9);
    /// ```
    pub fn at_scale(self, scale: f64) -> Result<ReferencePath, PathError> {
        use std::f64::consts::PI;
        if !(scale.is_finite() && scale > 0.0 && scale <= MAX_PATH_COORDINATE / 10.0) {
            return Err(PathError::BadScale(scale));
        }
        let points: Vec<[f64; 2]> = match self {
            PathShape::Line => vec![[0.0, 0.0], [6.0 * scale, 0.0]],
            PathShape::Circle => (0..=200)
                .map(|i| {
                    let a = 2.0 * PI * i as f64 / 200.0;
                    [scale * a.sin(), scale * (1.0 - a.cos())]
                })
                .collect(),
            PathShape::FigureEight => {
                // Lemniscate of Bernoulli x = a cos t / (1 + sin^2 t), y = a sin t cos t /
                // (1 + sin^2 t), from its crossing (t = pi/2) once round, turned so that it
                // leaves the origin along +x (its tangent there is at -45 degrees).
                let a = 1.5 * scale;
                let n = 400;
                let (s, c) = (PI / 4.0).sin_cos();
                (0..=n)
                    .map(|i| {
                        let t = PI / 2.0 + 2.0 * PI * i as f64 / n as f64;
                        let d = 1.0 + t.sin() * t.sin();
                        let (x, y) = (a * t.cos() / d, a * t.sin() * t.cos() / d);
                        // Mirrored, it leaves the crossing at -45 degrees; turned by +45
                        // degrees, along +x.
                        let (x, y) = (-x, y);
                        [c * x - s * y, s * x + c * y]
                    })
                    .collect()
            }
            PathShape::Zigzag => {
                let (s, c) = (PI / 3.0).sin_cos();
                let mut p = vec![[0.0, 0.0]];
                for leg in 1..=6 {
                    let y = if leg % 2 == 1 { scale * s } else { 0.0 };
                    p.push([leg as f64 * scale * c, y]);
                }
                // Turned so that the first leg leaves along +x.
                let (s, c) = (-PI / 3.0).sin_cos();
                p.into_iter()
                    .map(|[x, y]| [c * x - s * y, s * x + c * y])
                    .collect()
            }
        };
        ReferencePath::new(self.as_str(), points)
    }
}

/// `text` for a message: control characters escaped, cut after 40 characters.
fn shown(text: &str) -> String {
    let escaped: String = text.escape_debug().collect();
    match escaped.char_indices().nth(40) {
        Some((cut, _)) => format!(
            "{}... ({} characters)",
            &escaped[..cut],
            text.chars().count()
        ),
        None => escaped,
    }
}

/// A point of a path: where, which way it goes on, and how far along it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPoint {
    /// Position (m).
    pub x: f64,
    /// Position (m).
    pub y: f64,
    /// Direction of the path there (rad, the segment's).
    pub heading: f64,
    /// Arc length from the start (m).
    pub s: f64,
}

impl PathPoint {
    /// As a pose `[x, y, heading]`.
    pub fn pose(&self) -> Pose {
        Pose::new(self.x, self.y, self.heading)
    }
}

/// The point of a path nearest a position within an arc-length window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// The nearest point.
    pub point: PathPoint,
    /// Signed distance from the path (m): positive when the position is to the path's
    /// left.
    pub cross_track: f64,
}

/// A path to follow: a polyline from its first point to its last, with its arc length.
///
/// ```
/// use drive_control::ReferencePath;
/// let p = ReferencePath::new("L", vec![[0.0, 0.0], [2.0, 0.0], [2.0, 1.0]]).unwrap();
/// assert_eq!(p.length(), 3.0);
/// let q = p.point_at(2.5);
/// assert_eq!((q.x, q.y), (2.0, 0.5));
/// assert!((q.heading - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
/// // 0.3 m to the right of the first leg, searched over its first two metres.
/// let near = p.project([1.0, -0.3], 0.0, 2.0);
/// assert!((near.point.s - 1.0).abs() < 1e-12 && (near.cross_track + 0.3).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct ReferencePath {
    name: String,
    points: Vec<[f64; 2]>,
    /// Arc length at each point.
    s: Vec<f64>,
}

impl ReferencePath {
    /// A path through `points` (consecutive repeats dropped); an error for fewer than two
    /// distinct points, a coordinate that is not finite or beyond [`MAX_PATH_COORDINATE`],
    /// or more than [`MAX_PATH_POINTS`] points.
    pub fn new(name: &str, points: Vec<[f64; 2]>) -> Result<Self, PathError> {
        if points.len() > MAX_PATH_POINTS {
            return Err(PathError::TooManyPoints {
                name: name.to_string(),
            });
        }
        let mut kept: Vec<[f64; 2]> = Vec::with_capacity(points.len());
        for (index, &[x, y]) in points.iter().enumerate() {
            let ok = |v: f64| v.is_finite() && v.abs() <= MAX_PATH_COORDINATE;
            if !(ok(x) && ok(y)) {
                return Err(PathError::BadPoint {
                    name: name.to_string(),
                    index,
                    x,
                    y,
                });
            }
            match kept.last() {
                Some(&[px, py]) if (x - px).hypot(y - py) <= SAME_POINT_M => {}
                _ => kept.push([x, y]),
            }
        }
        if kept.len() < 2 {
            return Err(PathError::TooFewPoints {
                name: name.to_string(),
                found: kept.len(),
            });
        }
        let mut s = Vec::with_capacity(kept.len());
        s.push(0.0);
        for w in kept.windows(2) {
            let last = *s.last().unwrap_or(&0.0);
            s.push(last + (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]));
        }
        Ok(ReferencePath {
            name: name.to_string(),
            points: kept,
            s,
        })
    }

    /// A path from a CSV text with the header `x,y` (m) and one point per line; `name` is
    /// its file, for messages.
    ///
    /// ```
    /// use drive_control::ReferencePath;
    /// let p = ReferencePath::from_csv("p.csv", "x,y\n0,0\n3,4\n").unwrap();
    /// assert_eq!(p.length(), 5.0);
    /// let e = ReferencePath::from_csv("p.csv", "x,y\n0,0\n1,nan\n").unwrap_err();
    /// assert!(e.to_string().contains("line 3"));
    /// ```
    pub fn from_csv(name: &str, text: &str) -> Result<Self, PathError> {
        let csv = |line: usize, message: String| PathError::Csv {
            name: name.to_string(),
            line,
            message,
        };
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let Some((_, header)) = lines.next() else {
            return Err(csv(
                1,
                "the file is empty (expected the header 'x,y')".into(),
            ));
        };
        let cols: Vec<&str> = header
            .trim_start_matches('\u{feff}')
            .split(',')
            .map(str::trim)
            .collect();
        if cols != ["x", "y"] {
            return Err(csv(
                1,
                format!(
                    "expected the header 'x,y', found '{}'",
                    shown(header.trim())
                ),
            ));
        }
        let mut points = Vec::new();
        for (i, line) in lines {
            if points.len() >= MAX_PATH_POINTS {
                return Err(PathError::TooManyPoints {
                    name: name.to_string(),
                });
            }
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            if fields.len() != 2 {
                return Err(csv(
                    i + 1,
                    format!("{} fields where the header has 2", fields.len()),
                ));
            }
            let mut v = [0.0; 2];
            for (j, f) in fields.iter().enumerate() {
                let x: f64 = f.parse().map_err(|_| {
                    csv(
                        i + 1,
                        format!("column '{}': '{}' is not a number", cols[j], shown(f)),
                    )
                })?;
                if !(x.is_finite() && x.abs() <= MAX_PATH_COORDINATE) {
                    return Err(csv(
                        i + 1,
                        format!(
                            "column '{}': '{}' is not a finite number within 1e6 m",
                            cols[j],
                            shown(f)
                        ),
                    ));
                }
                v[j] = x;
            }
            points.push(v);
        }
        ReferencePath::new(name, points)
    }

    /// The path's name (its shape or its file).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Its points, after consecutive repeats were dropped.
    pub fn points(&self) -> &[[f64; 2]] {
        &self.points
    }

    /// Its length (m).
    pub fn length(&self) -> f64 {
        *self.s.last().unwrap_or(&0.0)
    }

    /// The segment holding arc length `s` (clamped to the path).
    fn segment(&self, s: f64) -> usize {
        let i = self.s.partition_point(|&x| x <= s);
        i.clamp(1, self.points.len() - 1) - 1
    }

    /// The point at arc length `s`, clamped to `[0, length]`.
    pub fn point_at(&self, s: f64) -> PathPoint {
        let s = s.clamp(0.0, self.length());
        let i = self.segment(s);
        let ([ax, ay], [bx, by]) = (self.points[i], self.points[i + 1]);
        let len = self.s[i + 1] - self.s[i];
        let a = if len > 0.0 {
            ((s - self.s[i]) / len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        PathPoint {
            x: ax + a * (bx - ax),
            y: ay + a * (by - ay),
            heading: (by - ay).atan2(bx - ax),
            s,
        }
    }

    /// The point nearest `position` among those with arc length in `[from, to]` (clamped
    /// to the path; `from > to` searches the single point at `from`).
    pub fn project(&self, position: [f64; 2], from: f64, to: f64) -> Projection {
        self.project_near(position, from, to, 0.0, 0.0)
    }

    /// Where a robot at `position` that was at arc length `near` is on the path, among the
    /// points with arc length in `[from, to]`: the point minimising the squared distance
    /// plus `weight` times the squared arc length from `near`. Where two parts of the path
    /// are about as near (a crossing, a path that doubles back, a zigzag finer than the
    /// robot's noise), the one that continues from `near` wins; a small weight (0.01) moves
    /// the point along the path by 1% of its distance from `near` elsewhere.
    ///
    /// ```
    /// use drive_control::ReferencePath;
    /// // Out along x and back: the same ground twice.
    /// let p = ReferencePath::new("back", vec![[0.0, 0.0], [4.0, 0.0], [0.0, 0.0]]).unwrap();
    /// // At x = 1 after 1 m: the way out, not the way back (s = 7).
    /// let q = p.project_near([1.0, 0.0], 0.0, 8.0, 1.0, 0.01);
    /// assert!((q.point.s - 1.0).abs() < 1e-9);
    /// // At x = 1 having come back 6 m: the way back.
    /// let q = p.project_near([1.0, 0.0], 0.0, 8.0, 6.9, 0.01);
    /// assert!((q.point.s - 7.0).abs() < 0.01);
    /// ```
    pub fn project_near(
        &self,
        position: [f64; 2],
        from: f64,
        to: f64,
        near: f64,
        weight: f64,
    ) -> Projection {
        let from = from.clamp(0.0, self.length());
        let to = to.clamp(from, self.length());
        let weight = if weight.is_finite() {
            weight.max(0.0)
        } else {
            0.0
        };
        let [px, py] = position;
        let mut best: Option<(f64, PathPoint, f64)> = None;
        for i in self.segment(from)..=self.segment(to) {
            let ([ax, ay], [bx, by]) = (self.points[i], self.points[i + 1]);
            let (s0, s1) = (self.s[i], self.s[i + 1]);
            let len = s1 - s0;
            let (dx, dy) = ((bx - ax) / len, (by - ay) / len);
            // The minimum of (t - t_p)^2 + weight (t - (near - s0))^2 over the segment.
            let t_p = (px - ax) * dx + (py - ay) * dy;
            let along = ((t_p + weight * (near - s0)) / (1.0 + weight))
                .clamp(from.max(s0) - s0, to.min(s1) - s0);
            let (qx, qy) = (ax + along * dx, ay + along * dy);
            let d2 = (px - qx).powi(2) + (py - qy).powi(2);
            let cost = d2 + weight * (s0 + along - near).powi(2);
            if best.as_ref().is_none_or(|b| cost < b.0) {
                let cross = dx * (py - ay) - dy * (px - ax);
                let point = PathPoint {
                    x: qx,
                    y: qy,
                    heading: dy.atan2(dx),
                    s: s0 + along,
                };
                best = Some((cost, point, cross.signum() * d2.sqrt()));
            }
        }
        // The loop visits at least one segment: `segment` returns a valid index.
        let (_, point, cross_track) = best.expect("a path has at least one segment");
        Projection { point, cross_track }
    }

    /// The same path moved rigidly so that it starts at `pose`'s position and leaves along
    /// its heading (where a robot standing at `pose` is to follow it).
    ///
    /// ```
    /// use drive_control::ReferencePath;
    /// use drive_traits::Pose;
    /// let p = ReferencePath::new("l", vec![[5.0, 5.0], [5.0, 7.0]]).unwrap();
    /// let q = p.placed_at(&Pose::new(1.0, 0.0, 0.0));
    /// assert!((q.points()[1][0] - 3.0).abs() < 1e-12 && q.points()[1][1].abs() < 1e-12);
    /// ```
    pub fn placed_at(&self, pose: &Pose) -> ReferencePath {
        let [x0, y0] = self.points[0];
        let first = self.point_at(0.0).heading;
        let (s, c) = wrap_angle(pose.z - first).sin_cos();
        let points = self
            .points
            .iter()
            .map(|&[x, y]| {
                let (dx, dy) = (x - x0, y - y0);
                [pose.x + c * dx - s * dy, pose.y + s * dx + c * dy]
            })
            .collect();
        ReferencePath {
            name: self.name.clone(),
            points,
            s: self.s.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn presets_start_at_the_origin_along_x() {
        for shape in PathShape::ALL {
            let p = shape.at_scale(2.0).unwrap();
            let start = p.point_at(0.0);
            assert!(start.x.abs() < 1e-9 && start.y.abs() < 1e-9, "{shape:?}");
            assert!(
                start.heading.abs() < 0.05,
                "{shape:?} leaves at {}",
                start.heading
            );
        }
    }

    #[test]
    fn preset_lengths() {
        let l = |s: PathShape| s.at_scale(1.0).unwrap().length();
        assert!((l(PathShape::Line) - 6.0).abs() < 1e-12);
        assert!((l(PathShape::Circle) - 2.0 * PI).abs() < 1e-3);
        // The lemniscate of Bernoulli of half-width a is 5.2441 a long.
        assert!((l(PathShape::FigureEight) - 5.2441 * 1.5).abs() < 0.01);
        assert!((l(PathShape::Zigzag) - 6.0).abs() < 1e-12);
    }

    #[test]
    fn the_figure_eight_crosses_itself_and_comes_back() {
        let p = PathShape::FigureEight.at_scale(1.0).unwrap();
        let end = p.point_at(p.length());
        assert!(end.x.abs() < 1e-9 && end.y.abs() < 1e-9);
        // Halfway it passes its start again, going the other diagonal.
        let mid = p.point_at(p.length() / 2.0);
        assert!(mid.x.abs() < 0.02 && mid.y.abs() < 0.02);
        assert!((wrap_angle(mid.heading - p.point_at(0.0).heading)).abs() > 1.0);
        // Searched near its start, a point at the crossing projects to the start, not to
        // the middle of the path.
        let near = p.project([0.0, 0.0], 0.0, 1.0);
        assert!(near.point.s < 1e-9);
    }

    #[test]
    fn zigzag_turns_by_120_degrees() {
        let p = PathShape::Zigzag.at_scale(1.0).unwrap();
        let a = p.point_at(0.5).heading;
        let b = p.point_at(1.5).heading;
        assert!((wrap_angle(b - a).abs() - 2.0 * PI / 3.0).abs() < 1e-9);
    }

    #[test]
    fn projection_is_signed_and_windowed() {
        let p =
            ReferencePath::new("u", vec![[0.0, 0.0], [4.0, 0.0], [4.0, 2.0], [0.0, 2.0]]).unwrap();
        // Left of the first leg.
        let q = p.project([1.0, 0.5], 0.0, 3.0);
        assert!((q.cross_track - 0.5).abs() < 1e-12 && (q.point.s - 1.0).abs() < 1e-12);
        // The same position searched over the last leg only: nearest on it, to its left
        // (the last leg runs towards -x, its left is -y).
        let q = p.project([1.0, 0.5], 7.0, 10.0);
        assert!((q.point.s - 9.0).abs() < 1e-12 && (q.cross_track - 1.5).abs() < 1e-12);
        // A window before the start searches the start.
        let q = p.project([-1.0, 0.0], -5.0, -1.0);
        assert_eq!(q.point.s, 0.0);
    }

    #[test]
    fn bad_paths_are_refused() {
        assert!(matches!(
            ReferencePath::new("one", vec![[1.0, 1.0], [1.0, 1.0]]),
            Err(PathError::TooFewPoints { found: 1, .. })
        ));
        assert!(matches!(
            ReferencePath::new("none", vec![]),
            Err(PathError::TooFewPoints { found: 0, .. })
        ));
        assert!(matches!(
            ReferencePath::new("nan", vec![[0.0, 0.0], [f64::NAN, 1.0]]),
            Err(PathError::BadPoint { index: 1, .. })
        ));
        assert!(ReferencePath::new("far", vec![[0.0, 0.0], [1e7, 1.0]]).is_err());
        let e = ReferencePath::from_csv("f.csv", "a,b\n0,0\n").unwrap_err();
        assert!(e.to_string().contains("header 'x,y'"), "{e}");
        let e = ReferencePath::from_csv("f.csv", "x,y\n0,0,1\n").unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
        let e = ReferencePath::from_csv("f.csv", "").unwrap_err();
        assert!(e.to_string().contains("empty"), "{e}");
        let e = ReferencePath::from_csv("f.csv", "x,y\n1,2\n").unwrap_err();
        assert!(e.to_string().contains("1 distinct point;"), "{e}");
        assert!(PathShape::Circle.at_scale(0.0).is_err());
        assert!(PathShape::Circle.at_scale(f64::NAN).is_err());
    }

    #[test]
    fn placing_keeps_lengths_and_turns_the_start() {
        let p = PathShape::Zigzag.at_scale(1.5).unwrap();
        let q = p.placed_at(&Pose::new(3.0, -2.0, 1.0));
        assert_eq!(p.length(), q.length());
        let start = q.point_at(0.0);
        assert!((start.x - 3.0).abs() < 1e-12 && (start.y + 2.0).abs() < 1e-12);
        assert!((start.heading - 1.0).abs() < 1e-9);
    }
}
