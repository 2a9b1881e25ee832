//! rosbag2 recordings (MCAP storage) read into the DRIVE logger's rows, so that
//! [`crate::import_raw`] cuts them into windows exactly as it cuts a logger CSV.
//!
//! Every message of the selected topics is decoded from CDR (with `cdr-encoding`); one row
//! is made per command message, at its receive time (`log_time`), holding the latest
//! message of every other topic as the DRIVE logger does (norlab-ulaval/DRIVE,
//! `drive/pose_cmds_logger_node.py`: it logs the last value of each subscription at each
//! tick, and the logger's defaults before a topic's first message). `icp_index` counts the
//! localization messages received so far.

use crate::raw_log::{CalibState, RawLog, RawRow};
use crate::{DataError, DataErrorKind, Location};
use drive_traits::CommandModel;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

mod messages;
use messages::{decode, plausible, Value};

/// What a topic carries, in the logger's terms.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Signal {
    CalibStep,
    JoySwitch,
    CalibState,
    Odometry,
    Measured(usize),
    Imu,
    Command,
}

impl Signal {
    /// The message types accepted on a topic of this signal.
    fn types(self) -> &'static [&'static str] {
        match self {
            Signal::CalibStep => &["std_msgs/msg/Int32"],
            Signal::JoySwitch => &["std_msgs/msg/Bool"],
            Signal::CalibState => &["std_msgs/msg/String"],
            Signal::Odometry => &[
                "nav_msgs/msg/Odometry",
                "geometry_msgs/msg/PoseStamped",
                "geometry_msgs/msg/PoseWithCovarianceStamped",
            ],
            Signal::Measured(_) => &["std_msgs/msg/Float64", "sensor_msgs/msg/JointState"],
            Signal::Imu => &["sensor_msgs/msg/Imu"],
            Signal::Command => &["geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped"],
        }
    }
}

/// The topics a bag is read from, by key: the DRIVE logger's subscriptions by default
/// ([`BagTopics::drive_logger`]), each overridable with `KEY=/topic`.
///
/// The keys are `calib_step` (std_msgs/Int32), `joy_switch` (std_msgs/Bool, optional:
/// never pressed when absent), `calib_state` (std_msgs/String), `odometry`
/// (nav_msgs/Odometry, geometry_msgs/PoseStamped or PoseWithCovarianceStamped), the
/// vehicle's two measured inputs under their raw-log column names (`meas_left_vel`,
/// `meas_right_vel` for a differential drive; `meas_speed`, `meas_steering` for a car:
/// std_msgs/Float64, or sensor_msgs/JointState as `/topic:joint`, the joint's velocity),
/// `imu` (sensor_msgs/Imu, optional: when absent the import takes the yaw rate from
/// localization, as for a raw log whose IMU is constant) and `cmd` (geometry_msgs/Twist or
/// TwistStamped).
///
/// ```
/// use drive_data::BagTopics;
/// let husky = drive_traits::vehicles::DifferentialDrive::new(0.165, 0.555);
/// let mut topics = BagTopics::drive_logger(&husky);
/// assert_eq!(topics.topic("cmd"), Some("/doughnut_cmd_vel"));
/// topics.set("cmd=/cmd_vel").unwrap();
/// topics.set("meas_left_vel=/joint_states:front_left_wheel").unwrap();
/// assert_eq!(topics.topic("cmd"), Some("/cmd_vel"));
/// assert!(topics.set("speed=/x").is_err()); // not a key
/// assert!(topics.set("cmd=cmd_vel").is_err()); // not an absolute topic name
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct BagTopics {
    /// (key, signal, topic, joint of a JointState topic)
    entries: Vec<(String, Signal, String, Option<String>)>,
}

impl BagTopics {
    /// The DRIVE logger's topics, with the vehicle's measured-input keys.
    pub fn drive_logger(vehicle: &dyn CommandModel) -> Self {
        let measured = vehicle.logger_measured_columns();
        // A vehicle has at least two axes (checked at registration); the names are only keys.
        let m0 = measured.first().copied().unwrap_or("measured_0");
        let m1 = measured.get(1).copied().unwrap_or("measured_1");
        let entries = [
            ("calib_step", Signal::CalibStep, "/calib_step"),
            ("joy_switch", Signal::JoySwitch, "/drive/joy_switch"),
            ("calib_state", Signal::CalibState, "/calib_state"),
            ("odometry", Signal::Odometry, "/odometry_in"),
            (m0, Signal::Measured(0), "/wheel_vel_left_measured"),
            (m1, Signal::Measured(1), "/wheel_vel_right_measured"),
            ("imu", Signal::Imu, "/imu_in"),
            ("cmd", Signal::Command, "/doughnut_cmd_vel"),
        ];
        BagTopics {
            entries: entries
                .into_iter()
                .map(|(k, s, t)| (k.to_string(), s, t.to_string(), None))
                .collect(),
        }
    }

    /// The keys, in order.
    pub fn keys(&self) -> Vec<&str> {
        self.entries.iter().map(|e| e.0.as_str()).collect()
    }

    /// The topic of a key.
    pub fn topic(&self, key: &str) -> Option<&str> {
        self.entries
            .iter()
            .find(|e| e.0 == key)
            .map(|e| e.2.as_str())
    }

    /// Sets a key's topic from `KEY=/topic` (`KEY=/topic:joint` for a JointState topic).
    pub fn set(&mut self, assignment: &str) -> Result<(), TopicAssignmentError> {
        let keys = self.keys().join(", ");
        let Some((key, value)) = assignment.split_once('=') else {
            return Err(TopicAssignmentError(format!(
                "--topic {assignment:?} is not KEY=/topic (keys: {keys})"
            )));
        };
        let (topic, joint) = match value.split_once(':') {
            Some((t, j)) if !j.is_empty() => (t, Some(j.to_string())),
            Some(_) => {
                return Err(TopicAssignmentError(format!(
                    "--topic {assignment:?}: the joint name is empty"
                )))
            }
            None => (value, None),
        };
        let valid = topic.len() > 1
            && topic.starts_with('/')
            && topic
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '/' || c == '~');
        if !valid {
            return Err(TopicAssignmentError(format!(
                "--topic {assignment:?}: {topic:?} is not an absolute ROS topic name (like /cmd_vel)"
            )));
        }
        let Some(entry) = self.entries.iter_mut().find(|e| e.0 == key) else {
            return Err(TopicAssignmentError(format!(
                "--topic {assignment:?}: no key {key:?} (keys: {keys})"
            )));
        };
        if joint.is_some() && !matches!(entry.1, Signal::Measured(_)) {
            return Err(TopicAssignmentError(format!(
                "--topic {assignment:?}: only a measured input can name a joint"
            )));
        }
        entry.2 = topic.to_string();
        entry.3 = joint;
        Ok(())
    }
}

/// The files of a bag: the `.mcap` file itself, or those of a rosbag2 directory: the files
/// its `metadata.yaml` lists (`relative_file_paths`, in its order; a leftover `.mcap` of
/// another run in the folder is not read), or, without a `metadata.yaml`, its `.mcap`
/// files in name order.
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// std::fs::write(dir.path().join("run_0.mcap"), b"").unwrap();
/// std::fs::write(dir.path().join("old_run.mcap"), b"").unwrap();
/// std::fs::write(
///     dir.path().join("metadata.yaml"),
///     "rosbag2_bagfile_information:\n  storage_identifier: \"mcap\"\n  relative_file_paths:\n    - run_0.mcap\n",
/// )
/// .unwrap();
/// assert_eq!(drive_data::bag_files(dir.path()).unwrap(), [dir.path().join("run_0.mcap")]);
/// ```
pub fn bag_files(path: &Path) -> Result<Vec<PathBuf>, DataError> {
    let name = path.display().to_string();
    let err = |kind| Err(DataError::new(Location::file(&name), kind));
    if !path.is_dir() {
        return Ok(vec![path.to_path_buf()]);
    }
    let metadata = path.join("metadata.yaml");
    if metadata.exists() {
        let text = match drive_traits::files::read_text(&metadata, 1 << 20) {
            Ok(t) => t,
            Err(e) => {
                return err(DataErrorKind::Io(format!("{}: {e}", metadata.display())));
            }
        };
        let listed = match bag_metadata(&text) {
            Ok(l) => l,
            Err(e) => {
                return err(DataErrorKind::Inconsistent(format!("metadata.yaml: {e}")));
            }
        };
        return Ok(listed.into_iter().map(|f| path.join(f)).collect());
    }
    let mut files: Vec<PathBuf> = match std::fs::read_dir(path) {
        Ok(entries) => entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
            .collect(),
        Err(e) => return err(DataErrorKind::Io(e.to_string())),
    };
    files.sort();
    if files.is_empty() {
        return err(DataErrorKind::Inconsistent(
            "no .mcap file in the bag directory".into(),
        ));
    }
    Ok(files)
}

/// The files a rosbag2 `metadata.yaml` lists (`relative_file_paths`, as a block list or
/// inline `[a, b]`), after checking its `storage_identifier` is mcap. Only these two keys
/// are read, each name plain or quoted; a name that leaves the bag's folder is refused.
fn bag_metadata(text: &str) -> Result<Vec<String>, String> {
    let unquote = |v: &str| v.trim().trim_matches(|c| c == '"' || c == '\'').to_string();
    let lines: Vec<&str> = text.lines().collect();
    let value_of = |key: &str| {
        lines.iter().enumerate().find_map(|(i, l)| {
            let t = l.trim_start();
            t.strip_prefix(key)
                .and_then(|rest| rest.strip_prefix(':'))
                .map(|rest| (i, l.len() - t.len(), rest.trim().to_string()))
        })
    };
    if let Some((_, _, storage)) = value_of("storage_identifier") {
        let storage = unquote(&storage);
        if storage != "mcap" {
            return Err(format!(
                "the bag's storage is {storage}, only mcap is read (ros2 bag convert can rewrite it as mcap)"
            ));
        }
    }
    let Some((at, indent, inline)) = value_of("relative_file_paths") else {
        return Err("no relative_file_paths: which files make the bag is not said".into());
    };
    let files: Vec<String> = if let Some(list) = inline.strip_prefix('[') {
        let list = list
            .strip_suffix(']')
            .ok_or("relative_file_paths: an inline list without its closing ]")?;
        list.split(',')
            .map(unquote)
            .filter(|f| !f.is_empty())
            .collect()
    } else {
        lines[at + 1..]
            .iter()
            .take_while(|l| {
                let t = l.trim_start();
                t.is_empty() || (t.starts_with('-') && l.len() - t.len() >= indent)
            })
            .filter_map(|l| l.trim_start().strip_prefix('-').map(unquote))
            .filter(|f| !f.is_empty())
            .collect()
    };
    if files.is_empty() {
        return Err("relative_file_paths lists no file".into());
    }
    if let Some(f) = files.iter().find(|f| {
        !Path::new(f)
            .components()
            .all(|c| matches!(c, std::path::Component::Normal(_)))
    }) {
        return Err(format!(
            "the listed file {f:?} is not inside the bag's folder"
        ));
    }
    Ok(files)
}

/// What the reader keeps of a bag's channel: its topic, its schema's name (the message type,
/// empty without a schema) and its message encoding.
#[derive(PartialEq)]
struct Channel {
    topic: String,
    ty: String,
    encoding: String,
}

/// What the messages of a bag's files give: every selected message, and what the bag holds.
#[derive(Default)]
struct Collected {
    /// (log_time, entry, value) of every selected message.
    messages: Vec<(u64, usize, Value)>,
    /// topic -> (type, encoding) of every channel, for messages about what the bag holds.
    seen: BTreeMap<String, (String, String)>,
    /// Messages read, on every topic.
    count: usize,
}

impl Collected {
    /// Reads one MCAP stream (`fname`: its name in messages, empty for the bag itself):
    /// streamed record by record with mcap's sans-io reader (the magic bytes are checked
    /// first; memory is bounded by the largest record), every length checked against
    /// [`MAX_BAG_RECORD_BYTES`] before it is read, each chunk's CRC and the data section's
    /// checked where the bag carries them. Of schemas and channels only the names are kept
    /// (at most [`MAX_BAG_NAME_BYTES`] each, [`MAX_BAG_CHANNELS`] channels), never a schema's
    /// text.
    fn read(
        &mut self,
        mut source: impl std::io::Read,
        fname: &str,
        topics: &BagTopics,
        fail: &dyn Fn(DataErrorKind) -> DataError,
    ) -> Result<(), DataError> {
        use crate::chunk_codecs::ChunkDecoder;
        use mcap::records::{op, Record};
        use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
        let options = LinearReaderOptions::default()
            .with_record_length_limit(MAX_BAG_RECORD_BYTES)
            .with_prevalidate_chunk_crcs(true)
            .with_validate_data_section_crc(true);
        let mut reader = LinearReader::new_with_options(options);
        // Names that are not empty: registering cannot fail.
        for codec in [ChunkDecoder::zstd(), ChunkDecoder::lz4()] {
            reader
                .add_decompressor(codec)
                .map_err(|e| fail(DataErrorKind::Inconsistent(format!("{fname}{e}"))))?;
        }
        // schema id -> name; channel id -> (topic, schema name, encoding).
        let mut schemas: std::collections::HashMap<u16, String> = Default::default();
        let mut channels: std::collections::HashMap<u16, Channel> = Default::default();
        let mut n = 0usize;
        let damaged = |n: usize, e: &mcap::McapError| {
            let why = match e {
                mcap::McapError::BadMagic => {
                    "not an MCAP file (rosbag2's sqlite3 .db3 files: ros2 bag convert them to MCAP first)".to_string()
                }
                mcap::McapError::BadChunkCrc { .. } | mcap::McapError::BadDataCrc { .. } => {
                    format!("damaged after its first {n} messages: {e}")
                }
                _ => format!(
                    "cannot read on after its first {n} messages ({e}; a truncated or damaged file, or a record beyond the {} MB read?)",
                    MAX_BAG_RECORD_BYTES >> 20
                ),
            };
            fail(DataErrorKind::Inconsistent(format!("{fname}{why}")))
        };
        let name_of = |what: &str, text: &str| {
            if text.len() > MAX_BAG_NAME_BYTES {
                Err(fail(DataErrorKind::Implausible(format!(
                    "{fname}a {what} of {} bytes, more than the {MAX_BAG_NAME_BYTES} read",
                    text.len()
                ))))
            } else {
                Ok(text.to_string())
            }
        };
        while let Some(event) = reader.next_event() {
            let (opcode, data) = match event.map_err(|e| damaged(n, &e))? {
                LinearReadEvent::ReadRequest(need) => {
                    let read = source
                        .read(reader.insert(need))
                        .map_err(|e| fail(DataErrorKind::Io(format!("{fname}{e}"))))?;
                    reader.notify_read(read);
                    continue;
                }
                LinearReadEvent::Record { opcode, data } => (opcode, data),
            };
            // Every record to the end magic is read: the summary after the data section
            // repeats schemas and channels (the same, or refused below), and a data end
            // record does not end the messages (one inside a chunk, or partway, is no end).
            if !matches!(opcode, op::SCHEMA | op::CHANNEL | op::MESSAGE) {
                continue;
            }
            let record = mcap::parse_record(opcode, data).map_err(|e| damaged(n, &e))?;
            match record {
                Record::Schema { header, .. } => {
                    let name = name_of("schema name", &header.name)?;
                    if let Some(before) = schemas.get(&header.id) {
                        if *before != name {
                            return Err(fail(DataErrorKind::Inconsistent(format!(
                                "{fname}schema {} is defined twice, as {before} and as {name}",
                                header.id
                            ))));
                        }
                    }
                    schemas.insert(header.id, name);
                }
                Record::Channel(channel) => {
                    if channels.len() >= MAX_BAG_CHANNELS && !channels.contains_key(&channel.id) {
                        return Err(fail(DataErrorKind::Implausible(format!(
                            "{fname}more than {MAX_BAG_CHANNELS} channels"
                        ))));
                    }
                    let ty = if channel.schema_id == 0 {
                        String::new()
                    } else {
                        schemas.get(&channel.schema_id).cloned().ok_or_else(|| {
                            fail(DataErrorKind::Inconsistent(format!(
                                "{fname}channel {} names schema {}, which the bag does not hold before it",
                                channel.id, channel.schema_id
                            )))
                        })?
                    };
                    let entry = Channel {
                        topic: name_of("topic name", &channel.topic)?,
                        ty,
                        encoding: name_of("message encoding", &channel.message_encoding)?,
                    };
                    if let Some(before) = channels.get(&channel.id) {
                        if *before != entry {
                            return Err(fail(DataErrorKind::Inconsistent(format!(
                                "{fname}channel {} is defined twice, as {} and as {}",
                                channel.id, before.topic, entry.topic
                            ))));
                        }
                    }
                    channels.insert(channel.id, entry);
                }
                Record::Message { header, data } => {
                    n += 1;
                    self.count += 1;
                    if self.count > MAX_BAG_MESSAGES {
                        return Err(fail(DataErrorKind::Implausible(format!(
                            "{fname}more than {MAX_BAG_MESSAGES} messages on all its topics: ros2 bag filter the DRIVE topics out first"
                        ))));
                    }
                    let channel = channels.get(&header.channel_id).ok_or_else(|| {
                            fail(DataErrorKind::Inconsistent(format!(
                                "{fname}message {n} is on channel {}, which the bag does not define before it",
                                header.channel_id
                            )))
                        })?;
                    if !self.seen.contains_key(&channel.topic) {
                        self.seen.insert(
                            channel.topic.clone(),
                            (channel.ty.clone(), channel.encoding.clone()),
                        );
                    }
                    self.message(n, header.log_time, &data, channel, fname, topics, fail)?;
                }
                _ => {}
            }
        }
        // Nothing after the end magic (two bags joined would import as the first one).
        let mut probe = [0u8; 1];
        if source.read(&mut probe).is_ok_and(|read| read > 0) {
            return Err(fail(DataErrorKind::Inconsistent(format!(
                "{fname}bytes after the MCAP file's end (two files joined?), after its first {n} messages"
            ))));
        }
        Ok(())
    }

    /// Decodes message `n` (received at `log_time` on `channel`) when one of `topics`
    /// selects it.
    #[allow(clippy::too_many_arguments)]
    fn message(
        &mut self,
        n: usize,
        log_time: u64,
        data: &[u8],
        channel: &Channel,
        fname: &str,
        topics: &BagTopics,
        fail: &dyn Fn(DataErrorKind) -> DataError,
    ) -> Result<(), DataError> {
        let Channel {
            topic,
            ty,
            encoding,
        } = channel;
        let ty = ty.as_str();
        for (i, (key, signal, wanted, joint)) in topics.entries.iter().enumerate() {
            if wanted != topic {
                continue;
            }
            if encoding != "cdr" {
                return Err(fail(DataErrorKind::Inconsistent(format!(
                    "topic {topic} ({key}) is encoded as {encoding:?}, only ROS 2 cdr is read"
                ))));
            }
            if !signal.types().contains(&ty) {
                return Err(fail(DataErrorKind::Inconsistent(format!(
                    "topic {topic} ({key}) is {}, expected {}",
                    if ty.is_empty() {
                        "without a schema"
                    } else {
                        ty
                    },
                    signal.types().join(" or ")
                ))));
            }
            if ty != "sensor_msgs/msg/JointState" && joint.is_some() {
                return Err(fail(DataErrorKind::Inconsistent(format!(
                    "topic {topic} ({key}) is {ty}: a joint name (:JOINT) is only for a sensor_msgs/JointState topic"
                ))));
            }
            if ty == "sensor_msgs/msg/JointState" && joint.is_none() {
                return Err(fail(DataErrorKind::Inconsistent(format!(
                    "topic {topic} ({key}) is a JointState: name its joint with --topic {key}={topic}:JOINT"
                ))));
            }
            let value = decode(ty, data, joint.as_deref())
                .and_then(plausible)
                .map_err(|e| {
                    fail(DataErrorKind::Inconsistent(format!(
                        "{fname}message {n} on {topic} ({key}, {ty}): {e}"
                    )))
                })?;
            self.messages.push((log_time, i, value));
        }
        Ok(())
    }
}

/// The largest bag read (bytes): far beyond a DRIVE run (20 minutes at 20 Hz are a few MB).
/// A bag is streamed, never held whole: its memory is bounded by
/// [`MAX_BAG_RECORD_BYTES`] and [`MAX_BAG_MESSAGES`], not by its size.
pub const MAX_BAG_BYTES: u64 = 4 << 30;

/// The largest record of a bag (bytes), a chunk's compressed and its decompressed size
/// included: a length beyond it (a corrupt or crafted file) is refused before anything is
/// allocated for it.
pub const MAX_BAG_RECORD_BYTES: usize = 64 << 20;

/// The most messages a bag may hold, on every topic (a 20-minute DRIVE run with its IMU at
/// 200 Hz holds a few hundred thousand): two million selected messages stay well under 1 GB
/// of memory.
pub const MAX_BAG_MESSAGES: usize = 2_000_000;

/// The longest schema name, topic name, message encoding or decoded text (a `calib_state`
/// string) read from a bag, in bytes.
pub const MAX_BAG_NAME_BYTES: usize = 1024;

/// The most channels a bag may define.
pub const MAX_BAG_CHANNELS: usize = 4096;

/// Reads a rosbag2 recording (a `.mcap` file or a bag directory) into the DRIVE logger's
/// rows: one row per message on the `cmd` topic, every other topic's latest message held
/// (see the module documentation). The rows' `line` is their line in the logger CSV they
/// would make (header on line 1), so that [`crate::import_raw`]'s drop reasons point into
/// [`crate::write_raw_log`]'s output of them. `imu_acceleration_x/y/z` are kept as extra
/// columns, as the logger exports them.
///
/// Fails with the file and the reason on a file that is not MCAP or is truncated, a missing
/// topic, a topic of another message type or encoding, or a message that does not decode.
pub fn read_bag(path: &Path, topics: &BagTopics) -> Result<RawLog, DataError> {
    let name = path.display().to_string();
    let at = || Location::file(&name);
    let fail = |kind| DataError::new(at(), kind);
    let files = bag_files(path)?;
    let mut collected = Collected::default();
    for file in &files {
        // Messages name the file inside a bag directory (the bag itself is the location).
        let fname = if file == path {
            String::new()
        } else {
            format!("{}: ", file.display())
        };
        drive_traits::files::regular(file)
            .map_err(|e| fail(DataErrorKind::Io(format!("{fname}{e}"))))?;
        let size = std::fs::metadata(file)
            .map_err(|e| fail(DataErrorKind::Io(format!("{fname}{e}"))))?
            .len();
        if size > MAX_BAG_BYTES {
            return Err(fail(DataErrorKind::Implausible(format!(
                "{fname}{size} bytes, more than the {MAX_BAG_BYTES} read"
            ))));
        }
        let opened = std::fs::File::open(file)
            .map_err(|e| fail(DataErrorKind::Io(format!("{fname}{e}"))))?;
        collected.read(opened, &fname, topics, &fail)?;
    }
    rows_of(collected, topics, &name, &fail)
}

/// A bag given as the bytes of one `.mcap` file (`name` in messages): [`read_bag`] without
/// the files (for the fuzz target).
pub fn read_bag_bytes(name: &str, bytes: &[u8], topics: &BagTopics) -> Result<RawLog, DataError> {
    let fail = |kind| DataError::new(Location::file(name), kind);
    let mut collected = Collected::default();
    collected.read(bytes, "", topics, &fail)?;
    rows_of(collected, topics, name, &fail)
}

/// The logger's rows of the collected messages (see [`read_bag`]).
fn rows_of(
    collected: Collected,
    topics: &BagTopics,
    name: &str,
    fail: &dyn Fn(DataErrorKind) -> DataError,
) -> Result<RawLog, DataError> {
    let Collected {
        mut messages, seen, ..
    } = collected;
    for (key, signal, topic, _) in &topics.entries {
        // The operator's switch and the IMU may be absent: never pressed, and the yaw rate
        // from localization (the raw import's imu-constant fallback).
        let optional = matches!(signal, Signal::JoySwitch | Signal::Imu);
        if !optional && !seen.contains_key(topic) {
            let list: Vec<String> = seen
                .iter()
                .map(|(t, (ty, _))| format!("{t} ({ty})"))
                .collect();
            return Err(fail(DataErrorKind::Inconsistent(format!(
                "no topic {topic} ({key}; --topic {key}=/other to read another); the bag's topics: {}",
                if list.is_empty() { "none".to_string() } else { list.join(", ") }
            ))));
        }
    }
    let command = topics
        .entries
        .iter()
        .position(|e| e.1 == Signal::Command)
        .expect("BagTopics always has a cmd entry"); // built by drive_logger only
                                                     // Receive order; a command's row holds what arrived at its time too; messages of one
                                                     // time otherwise keep their order in the file.
    messages.sort_by_key(|m| (m.0, m.1 == command));
    let mut log = RawLog {
        file: name.to_string(),
        rows: Vec::new(),
        extra_columns: [
            "imu_acceleration_x",
            "imu_acceleration_y",
            "imu_acceleration_z",
        ]
        .map(String::from)
        .to_vec(),
        placeholder_rows: 0,
    };
    // The logger's state: its defaults until a topic's first message.
    let mut row = RawRow::at_rest(0, 0);
    row.calib_state = CalibState::Unset;
    row.quaternion = [0.0; 4];
    let mut acceleration = [0.0; 3];
    let mut localizations = 0u64;
    for (time, entry, value) in messages {
        let signal = topics.entries[entry].1;
        match (signal, value) {
            (Signal::CalibStep, Value::Step(s)) => row.calib_step = s.max(0) as u64,
            (Signal::JoySwitch, Value::Bool(b)) => row.joy_switch = b,
            (Signal::CalibState, Value::Text(t)) => row.calib_state = CalibState::from_logger(&t),
            (Signal::Odometry, Value::Pose(p, q)) => {
                localizations += 1;
                row.icp_index = localizations;
                row.position = p;
                row.quaternion = q;
            }
            (Signal::Measured(0), Value::Number(v)) => row.measured.x = v,
            (Signal::Measured(_), Value::Number(v)) => row.measured.y = v,
            (Signal::Imu, Value::Imu(w, a)) => {
                row.imu_rate = w;
                acceleration = a;
            }
            (Signal::Command, Value::Twist(c)) => row.body_command = c,
            // decode gives each signal's types their value only.
            _ => unreachable!("a value of another signal's type"),
        }
        if entry == command {
            let Ok(time_ns) = i64::try_from(time) else {
                return Err(fail(DataErrorKind::Implausible(format!(
                    "a message time of {time} ns"
                ))));
            };
            let mut r = row.clone();
            r.line = log.rows.len() + 2;
            r.time_ns = time_ns;
            r.extra = acceleration.map(Some).to_vec();
            log.rows.push(r);
        }
    }
    if log.rows.is_empty() {
        return Err(fail(DataErrorKind::Inconsistent(format!(
            "no message on the command topic {}",
            topics.entries[command].2
        ))));
    }
    Ok(log)
}

#[cfg(test)]
mod tests;

/// A `--topic KEY=/topic` assignment that cannot be applied ([`BagTopics::set`]), with why.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct TopicAssignmentError(pub String);
