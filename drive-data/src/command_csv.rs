//! Command files (`drive predict --commands`): the header `t,<the vehicle's command
//! columns>`, then one command per line at the model's command period.

use drive_traits::limits::{self, Short, TooLarge};
use drive_traits::Input;
use std::path::Path;
use thiserror::Error;

/// Longest line of a command file (bytes): a line is a few numbers.
pub const MAX_COMMAND_LINE_BYTES: u64 = 4096;

/// Most commands of one file: about 14 hours at 20 Hz.
pub const MAX_COMMANDS: usize = 1_000_000;

/// Why a command file cannot be read; each message names the file, and the line and column
/// where there is one.
#[derive(Debug, Error)]
pub enum CommandFileError {
    /// The file cannot be opened or is not a regular file.
    #[error("reading {name}")]
    Read {
        /// The file.
        name: String,
        /// Why.
        #[source]
        error: std::io::Error,
    },
    /// A line longer than [`MAX_COMMAND_LINE_BYTES`].
    #[error("{name}, line {line}: longer than {MAX_COMMAND_LINE_BYTES} bytes: not a command file")]
    LineTooLong {
        /// The file.
        name: String,
        /// Line number (1-based).
        line: usize,
    },
    /// A line cannot be read (not UTF-8, an I/O error).
    #[error("{name}, line {line}: cannot read: {error}")]
    LineUnreadable {
        /// The file.
        name: String,
        /// Line number (1-based).
        line: usize,
        /// Why.
        error: std::io::Error,
    },
    /// No line at all.
    #[error("{name}: the file is empty")]
    Empty {
        /// The file.
        name: String,
    },
    /// The header is not `t` and the vehicle's command columns.
    #[error("{name}, line 1: expected the header '{expected}', found '{found}'")]
    Header {
        /// The file.
        name: String,
        /// The header expected.
        expected: String,
        /// The header found.
        found: String,
    },
    /// A line with another number of fields than the header.
    #[error("{name}, line {line}: {found} fields where the header has {expected}")]
    FieldCount {
        /// The file.
        name: String,
        /// Line number (1-based).
        line: usize,
        /// Fields on the line.
        found: usize,
        /// Fields of the header.
        expected: usize,
    },
    /// A field that is not a number.
    #[error("{name}, line {line}, column '{column}': '{text}' is not a number")]
    NotANumber {
        /// The file.
        name: String,
        /// Line number (1-based).
        line: usize,
        /// The column.
        column: String,
        /// The field.
        text: String,
    },
    /// A field that is infinite or NaN.
    #[error("{name}, line {line}, column '{column}': '{text}' is not a finite number")]
    NotFinite {
        /// The file.
        name: String,
        /// Line number (1-based).
        line: usize,
        /// The column.
        column: String,
        /// The field.
        text: String,
    },
    /// A value beyond [`limits::MAX_ABS_MEASUREMENT`] (a corrupted number, as in the CSV
    /// readers), or a time beyond [`limits::MAX_ABS_TIME_S`].
    #[error(transparent)]
    TooLarge(#[from] TooLarge),
    /// A time off the model's command period.
    #[error("{name}, line {line}, column 't': t = {} but the model's command period is {} s (expected t = {})", Time(*t), Short(*dt), Time(*expected))]
    OffGrid {
        /// The file.
        name: String,
        /// Line number (1-based).
        line: usize,
        /// The time found (s).
        t: f64,
        /// The model's command period (s).
        dt: f64,
        /// The time expected (s).
        expected: f64,
    },
    /// More than [`MAX_COMMANDS`] commands.
    #[error(
        "{name}, line {line}: more than {MAX_COMMANDS} commands (the limit of one prediction)"
    )]
    TooMany {
        /// The file.
        name: String,
        /// Line number (1-based).
        line: usize,
    },
    /// A header and no command.
    #[error("{name}: no command rows")]
    NoRows {
        /// The file.
        name: String,
    },
}

/// How far a command's time may be from the model's grid (`t0 + i dt`), as a share of the
/// period: the rounding of a printed time, not a command meant for another instant.
pub const GRID_TOLERANCE: f64 = 0.01;

/// The commands of a command file and the time of the first.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandFile {
    /// One command per line, in order.
    pub commands: Vec<Input>,
    /// The first line's time (s).
    pub t0: f64,
}

/// Reads a command file with the header `t,<columns>` (or a schedule's, `drive protocol`'s
/// `t,interval,phase,<columns>`) sampled at period `dt` (s): each
/// line's time within [`GRID_TOLERANCE`] of a period of `t0 + i dt` (a time further off is
/// refused, never moved onto the grid). The file is read line by line (never held
/// whole), each line capped at [`MAX_COMMAND_LINE_BYTES`], at most [`MAX_COMMANDS`] commands.
///
/// ```
/// let dir = std::env::temp_dir().join(format!("drive-commands-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("commands.csv");
/// std::fs::write(&path, "t,cmd_left,cmd_right\n0,1,2\n0.05,1.5,2\n").unwrap();
/// let file = drive_data::read_commands(&path, &["cmd_left", "cmd_right"], 0.05).unwrap();
/// assert_eq!(file.commands.len(), 2);
/// assert_eq!(file.commands[1].x, 1.5);
/// std::fs::write(&path, "t,cmd_left,cmd_right\n0,1,2\n0.2,1.5,2\n").unwrap();
/// let err = drive_data::read_commands(&path, &["cmd_left", "cmd_right"], 0.05).unwrap_err();
/// assert!(err.to_string().contains("expected t = 0.05"));
/// // Off by a fifth of a period: refused, not snapped onto the grid.
/// std::fs::write(&path, "t,cmd_left,cmd_right\n0,1,2\n0.06,1.5,2\n").unwrap();
/// assert!(drive_data::read_commands(&path, &["cmd_left", "cmd_right"], 0.05).is_err());
/// // A schedule drive protocol wrote: its commands.
/// std::fs::write(&path, "t,interval,phase,cmd_left,cmd_right\n0,0,transient,1,2\n0.05,0,transient,1,2\n").unwrap();
/// let file = drive_data::read_commands(&path, &["cmd_left", "cmd_right"], 0.05).unwrap();
/// assert_eq!(file.commands[1].y, 2.0);
/// std::fs::remove_dir_all(&dir).unwrap();
/// ```
pub fn read_commands(
    path: &Path,
    columns: &[&str],
    dt: f64,
) -> Result<CommandFile, CommandFileError> {
    use std::io::BufRead as _;
    use std::io::Read as _;
    let name = path.display().to_string();
    let read = |error| CommandFileError::Read {
        name: name.clone(),
        error,
    };
    drive_traits::files::regular(path).map_err(read)?;
    let file = std::fs::File::open(path).map_err(read)?;
    let mut reader = std::io::BufReader::new(file);
    let mut number = 0;
    let mut failed = false;
    let mut lines = std::iter::from_fn(|| {
        if failed {
            return None;
        }
        let mut line = String::new();
        let read = (&mut reader)
            .take(MAX_COMMAND_LINE_BYTES + 1)
            .read_line(&mut line);
        let i = number;
        number += 1;
        match read {
            Ok(0) => None,
            Ok(n) if n as u64 > MAX_COMMAND_LINE_BYTES => {
                failed = true;
                Some(Err(CommandFileError::LineTooLong {
                    name: name.clone(),
                    line: i + 1,
                }))
            }
            Ok(_) => Some(Ok((i, line.trim_end_matches(['\n', '\r']).to_string()))),
            Err(error) => {
                failed = true;
                Some(Err(CommandFileError::LineUnreadable {
                    name: name.clone(),
                    line: i + 1,
                    error,
                }))
            }
        }
    })
    .filter(|l| l.as_ref().map_or(true, |(_, l)| !l.trim().is_empty()));
    let Some(first) = lines.next() else {
        return Err(CommandFileError::Empty { name });
    };
    let (_, header) = first?;
    let header = header.trim_start_matches('\u{feff}');
    let expected: Vec<&str> = std::iter::once("t")
        .chain(columns.iter().copied())
        .collect();
    let cols: Vec<&str> = header
        .split(',')
        .map(|f| crate::window_csv::unquoted(f.trim()))
        .collect();
    // The columns read: all of them, or of a schedule `drive protocol` writes (`t`,
    // `interval`, `phase`, then the commands), its time and its commands.
    let schedule: Vec<&str> = ["t", "interval", "phase"]
        .into_iter()
        .chain(columns.iter().copied())
        .collect();
    let read_columns: Vec<usize> = if cols == expected {
        (0..expected.len()).collect()
    } else if cols == schedule {
        std::iter::once(0).chain(3..schedule.len()).collect()
    } else {
        return Err(CommandFileError::Header {
            name,
            expected: expected.join(","),
            found: header.to_string(),
        });
    };
    let mut out = Vec::new();
    let mut t0 = None;
    for line in lines {
        let (i, line) = line?;
        let fields: Vec<&str> = line
            .split(',')
            .map(|f| crate::window_csv::unquoted(f.trim()))
            .collect();
        if fields.len() != cols.len() {
            return Err(CommandFileError::FieldCount {
                name,
                line: i + 1,
                found: fields.len(),
                expected: cols.len(),
            });
        }
        let mut v = [0.0; 1 + drive_traits::MAX_INPUTS];
        for (slot, &j) in read_columns.iter().enumerate() {
            let f = &fields[j];
            let field = |column: &str| (name.clone(), i + 1, column.to_string(), f.trim().into());
            let x: f64 = f.trim().parse().map_err(|_| {
                let (name, line, column, text) = field(cols[j]);
                CommandFileError::NotANumber {
                    name,
                    line,
                    column,
                    text,
                }
            })?;
            if !x.is_finite() {
                let (name, line, column, text) = field(cols[j]);
                return Err(CommandFileError::NotFinite {
                    name,
                    line,
                    column,
                    text,
                });
            }
            // The times may be a clock's since the Unix epoch (a ROS recording's).
            let limit = if slot == 0 {
                limits::MAX_ABS_TIME_S
            } else {
                limits::MAX_ABS_MEASUREMENT
            };
            // Named only when refused (this runs on every value); a negative value with its
            // sign, its magnitude against the limit.
            if x.abs() > limit {
                let at = format!("{name}, line {}, column '{}'", i + 1, cols[j]);
                let what = if x < 0.0 {
                    format!("the magnitude of {at} (= {})", Short(x))
                } else {
                    at
                };
                limits::at_most(&what, x.abs(), limit, "")?;
            }
            v[slot] = x;
        }
        let t0 = *t0.get_or_insert(v[0]);
        let expected = t0 + out.len() as f64 * dt;
        let off = (v[0] - expected).abs();
        if off.is_nan() || off > GRID_TOLERANCE * dt {
            return Err(CommandFileError::OffGrid {
                name,
                line: i + 1,
                t: v[0],
                dt,
                expected,
            });
        }
        if out.len() == MAX_COMMANDS {
            return Err(CommandFileError::TooMany { name, line: i + 1 });
        }
        out.push(Input::new(v[1], v[2], v[3]));
    }
    match t0 {
        Some(t0) if !out.is_empty() => Ok(CommandFile { commands: out, t0 }),
        _ => Err(CommandFileError::NoRows { name }),
    }
}

/// A time for a message, to the microsecond without trailing zeros: an epoch time
/// (1733300000.07) keeps the digits that tell it from its neighbours.
struct Time(f64);

impl std::fmt::Display for Time {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = format!("{:.6}", self.0);
        let s = s.trim_end_matches('0').trim_end_matches('.');
        f.write_str(if s == "-0" { "0" } else { s })
    }
}
