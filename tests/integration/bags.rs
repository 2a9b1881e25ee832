//! `drive import --bag`: a rosbag2 recording (MCAP storage) written by an independent
//! library (Python `rosbags`, tests/bags/make_bag.py) from a DRIVE logger CSV gives the same
//! windows as `drive import --raw` on that CSV, and bad bags fail in one line.

use crate::common;
use common::{ok, user_error};
use std::path::{Path, PathBuf};

/// Writes the committed fixtures out: the logger CSV and the bag directory.
fn fixtures(dir: &Path) -> (PathBuf, PathBuf) {
    common::bag_fixtures(dir, "raw.csv", "husky_snow")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `drive import FLAG SOURCE --robot husky --out OUT EXTRA...`.
fn import<'a>(flag: &'a str, source: &'a Path, out: &'a Path, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "import",
        flag,
        s(source),
        "--robot",
        "husky",
        "--out",
        s(out),
    ];
    args.extend(extra);
    args
}

fn medians(csv: &Path) -> Vec<(f64, f64)> {
    let v: serde_json::Value = serde_json::from_str(&ok(&[
        "eval",
        "--json",
        "--data",
        s(csv),
        "--models",
        "naive,powertrain,slip-blr,acc-blr",
    ]))
    .unwrap();
    v["models"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            (
                m["translational_median_m"].as_f64().unwrap(),
                m["rotational_median_rad"].as_f64().unwrap(),
            )
        })
        .collect()
}

#[test]
fn a_bag_gives_the_windows_of_the_logger_csv_of_the_same_run() {
    let dir = tempfile::tempdir().unwrap();
    let (raw, bag) = fixtures(dir.path());
    let from_raw = dir.path().join("from_raw.csv");
    let from_dir = dir.path().join("from_dir.csv");
    let from_file = dir.path().join("from_file.csv");
    ok(&import("--raw", &raw, &from_raw, &[]));
    let report = ok(&import("--bag", &bag, &from_dir, &[]));
    assert!(report.contains("33 windows kept, 0 dropped"), "{report}");
    ok(&import("--bag", &bag.join("bag.mcap"), &from_file, &[]));
    let windows = std::fs::read_to_string(&from_raw).unwrap();
    assert_eq!(std::fs::read_to_string(&from_dir).unwrap(), windows);
    assert_eq!(std::fs::read_to_string(&from_file).unwrap(), windows);
    let (a, b) = (medians(&from_raw), medians(&from_dir));
    assert_eq!(a.len(), 4);
    for (x, y) in a.iter().zip(&b) {
        assert!(
            (x.0 - y.0).abs() <= 1e-6 && (x.1 - y.1).abs() <= 1e-6,
            "{a:?} {b:?}"
        );
    }
    // The JSON report of a bag: the extra IMU columns as the logger exports them.
    let v: serde_json::Value = serde_json::from_str(&ok(&import(
        "--bag",
        &bag,
        &dir.path().join("again.csv"),
        &["--json"],
    )))
    .unwrap();
    assert_eq!(v["rows"], 1801);
    assert_eq!(v["extra_columns"][0], "imu_acceleration_x");
}

#[test]
fn a_topic_can_be_read_under_another_name() {
    let dir = tempfile::tempdir().unwrap();
    let (_, bag) = fixtures(dir.path());
    // Reading the IMU topic as the command: a type mismatch, named.
    let err = user_error(&import(
        "--bag",
        &bag,
        &dir.path().join("x.csv"),
        &["--topic", "cmd=/imu_in"],
    ));
    assert!(
        err.contains(
            "topic /imu_in (cmd) is sensor_msgs/msg/Imu, expected geometry_msgs/msg/Twist"
        ),
        "{err}"
    );
    // The left encoder read from the right one's topic: the import runs on other values,
    // which the data checks call useless (the left wheel answering its commands unlike the
    // right), so it writes them only when told to.
    let swapped = dir.path().join("swapped.csv");
    let remap = ["--topic", "meas_left_vel=/wheel_vel_right_measured"];
    let refused = common::drive(&import("--bag", &bag, &swapped, &remap));
    let err = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(1), "{err}");
    assert!(err.contains("check encoder-command"), "{err}");
    assert!(!swapped.exists());
    ok(&import(
        "--bag",
        &bag,
        &swapped,
        &[remap[0], remap[1], "--allow", "encoder-command"],
    ));
    let text = std::fs::read_to_string(&swapped).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let (l, r) = (
        header.iter().position(|c| *c == "enc_left").unwrap(),
        header.iter().position(|c| *c == "enc_right").unwrap(),
    );
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f[l], f[r]);
    }
}

#[test]
fn bad_bags_fail_in_one_line_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (raw, bag) = fixtures(dir.path());
    let bytes = std::fs::read(bag.join("bag.mcap")).unwrap();
    let truncated = dir.path().join("truncated.mcap");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let empty_dir = dir.path().join("empty");
    std::fs::create_dir(&empty_dir).unwrap();
    let sqlite = dir.path().join("sqlite");
    std::fs::create_dir(&sqlite).unwrap();
    std::fs::write(
        sqlite.join("metadata.yaml"),
        "rosbag2_bagfile_information:\n  storage_identifier: sqlite3\n",
    )
    .unwrap();
    let out = dir.path().join("out.csv");
    let bad = |source: &Path, extra: &[&str]| user_error(&import("--bag", source, &out, extra));
    assert!(bad(&truncated, &[]).contains("a truncated or damaged file"));
    assert!(bad(&raw, &[]).contains("not an MCAP file"));
    assert!(bad(&empty_dir, &[]).contains("no .mcap file in the bag directory"));
    assert!(bad(&sqlite, &[]).contains("the bag's storage is sqlite3, only mcap is read"));
    let missing = bad(&bag, &["--topic", "odometry=/icp_odom"]);
    assert!(
        missing.contains("no topic /icp_odom (odometry;"),
        "{missing}"
    );
    assert!(
        missing.contains("/odometry_in (nav_msgs/msg/Odometry)"),
        "{missing}"
    );
    assert!(bad(&bag, &["--topic", "speed=/x"]).contains("no key \"speed\""));
    assert!(bad(&bag, &["--topic", "cmd=cmd_vel"]).contains("not an absolute ROS topic name"));
    assert!(bad(&bag, &["--topic", "cmd=/cmd_vel:joint"]).contains("only a measured input"));
    assert!(bad(
        &bag,
        &["--topic", "meas_left_vel=/wheel_vel_left_measured:left"]
    )
    .contains("a joint name (:JOINT) is only for a sensor_msgs/JointState topic"));
    // An output that would replace the bag's file, refused.
    assert!(
        user_error(&import("--bag", &bag, &bag.join("bag.mcap"), &[]))
            .contains("would replace that file")
    );
    assert!(
        user_error(&import("--raw", &raw, &out, &["--topic", "cmd=/x"]))
            .contains("--topic names topics of a bag")
    );
    assert!(!out.exists());
    assert_eq!(std::fs::read(bag.join("bag.mcap")).unwrap(), bytes);
}

#[test]
fn damaged_and_crafted_bags_are_refused_before_anything_is_allocated_for_them() {
    let dir = tempfile::tempdir().unwrap();
    let (_, bag) = fixtures(dir.path());
    let bytes = std::fs::read(bag.join("bag.mcap")).unwrap();
    let out = dir.path().join("out.csv");
    let write = |name: &str, b: &[u8]| {
        let p = dir.path().join(name);
        std::fs::write(&p, b).unwrap();
        p
    };
    // The first record's length (after the 8 magic bytes and its opcode) near u64::MAX and
    // at 2^45: refused, nothing allocated for it.
    for length in [u64::MAX - 8, 1u64 << 45] {
        let mut crafted = bytes.clone();
        crafted[9..17].copy_from_slice(&length.to_le_bytes());
        let p = write("crafted.mcap", &crafted);
        let err = user_error(&import("--bag", &p, &out, &[]));
        assert!(
            err.contains("cannot read on after its first 0 messages"),
            "{err}"
        );
    }
    // Two bags joined end to end: refused, rather than read as the first one.
    let joined = write("joined.mcap", &[bytes.clone(), bytes.clone()].concat());
    let err = user_error(&import("--bag", &joined, &out, &[]));
    assert!(err.contains("two files joined"), "{err}");
    // The fixture's chunks carry no CRC (0: rosbags writes none). Given the first chunk its
    // CRC, the bag reads; a byte flipped inside the chunk's records is then refused.
    let chunk = 8 + 9 + 26; // after the magic and the 26-byte header record
    assert_eq!(bytes[chunk], 0x06, "the fixture's second record is a chunk");
    let content = chunk + 9;
    let compression = u32::from_le_bytes(bytes[content + 28..content + 32].try_into().unwrap());
    assert_eq!(compression, 0, "an uncompressed chunk");
    let records_len =
        u64::from_le_bytes(bytes[content + 32..content + 40].try_into().unwrap()) as usize;
    let records = content + 40..content + 40 + records_len;
    let mut crc = flate2::Crc::new();
    crc.update(&bytes[records.clone()]);
    let mut with_crc = bytes.clone();
    with_crc[content + 24..content + 28].copy_from_slice(&crc.sum().to_le_bytes());
    let p = write("with_crc.mcap", &with_crc);
    ok(&import("--bag", &p, &out, &[]));
    std::fs::remove_file(&out).unwrap();
    std::fs::remove_file(out.with_extension("meta.json")).unwrap();
    let mut flipped = with_crc;
    flipped[records.start + records_len / 2] ^= 0x55;
    let p = write("flipped.mcap", &flipped);
    let err = user_error(&import("--bag", &p, &out, &[]));
    assert!(
        err.contains("damaged") && err.contains("Chunk CRC failed"),
        "{err}"
    );
    // A leftover .mcap of another run beside the bag's own: metadata.yaml lists the files.
    std::fs::write(bag.join("old_run.mcap"), b"not this run").unwrap();
    ok(&import("--bag", &bag, &out, &[]));
    assert!(out.exists());
}

/// A bag without an IMU imports as the raw log of the same run with a constant IMU: the
/// yaw rate from localization, the same windows.
#[test]
fn a_bag_without_an_imu_gives_the_windows_of_a_log_with_a_constant_imu() {
    let dir = tempfile::tempdir().unwrap();
    let (raw, bag) = fixtures(dir.path());
    let no_imu = dir.path().join("no_imu.mcap");
    let bytes = std::fs::read(bag.join("bag.mcap")).unwrap();
    let mut writer = mcap::Writer::new(std::io::BufWriter::new(
        std::fs::File::create(&no_imu).unwrap(),
    ))
    .unwrap();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        if m.channel.topic != "/imu_in" {
            writer.write(&m).unwrap();
        }
    }
    writer.finish().unwrap();
    let text = std::fs::read_to_string(&raw).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let cols: Vec<&str> = header.split(',').collect();
    let mut zeroed = format!("{header}\n");
    for line in lines {
        let fields: Vec<&str> = line
            .split(',')
            .enumerate()
            .map(|(i, f)| if cols[i].starts_with("imu_") { "0" } else { f })
            .collect();
        zeroed += &fields.join(",");
        zeroed.push('\n');
    }
    let zeroed_raw = dir.path().join("zeroed.csv");
    std::fs::write(&zeroed_raw, zeroed).unwrap();
    let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.csv"));
    let both = |args: &[&str]| {
        let out = common::drive(args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr)
    };
    let from_raw = both(&import("--raw", &zeroed_raw, &a, &[]));
    let from_bag = both(&import("--bag", &no_imu, &b, &[]));
    assert!(from_bag.contains("imu-constant"), "{from_bag}");
    assert!(from_raw.contains("imu-constant"), "{from_raw}");
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
}

/// The fixture bag rewritten (with the `mcap` crate) keeping only the first message of
/// `topic`.
fn without_later(bag: &Path, topic: &str, out: &Path) {
    let bytes = std::fs::read(bag.join("bag.mcap")).unwrap();
    let mut writer =
        mcap::Writer::new(std::io::BufWriter::new(std::fs::File::create(out).unwrap())).unwrap();
    let mut kept = false;
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        if m.channel.topic == topic {
            if kept {
                continue;
            }
            kept = true;
        }
        writer.write(&m).unwrap();
    }
    writer.finish().unwrap();
}

/// A bag whose localization stops before the protocol starts gives the raw log's drop
/// reason for each interval, and nothing is written.
#[test]
fn a_bag_without_localization_is_refused_with_the_raw_logs_reasons() {
    let dir = tempfile::tempdir().unwrap();
    let (raw, bag) = fixtures(dir.path());
    let frozen_bag = dir.path().join("frozen.mcap");
    without_later(&bag, "/odometry_in", &frozen_bag);
    // The same run as a logger CSV: the first localization held on every row.
    let text = std::fs::read_to_string(&raw).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let cols: Vec<&str> = header.split(',').collect();
    let frozen: Vec<usize> = (0..cols.len())
        .filter(|&i| cols[i].starts_with("icp_"))
        .collect();
    let first: Vec<String> = lines
        .clone()
        .next()
        .unwrap()
        .split(',')
        .map(String::from)
        .collect();
    let mut out = format!("{header}\n");
    for line in lines {
        let mut f: Vec<String> = line.split(',').map(String::from).collect();
        for &i in &frozen {
            f[i] = first[i].clone();
        }
        out += &(f.join(",") + "\n");
    }
    let frozen_raw = dir.path().join("frozen.csv");
    std::fs::write(&frozen_raw, out).unwrap();
    let target = dir.path().join("w.csv");
    let run =
        |flag: &str, source: &Path| common::drive(&import(flag, source, &target, &["--json"]));
    let (a, b) = (run("--raw", &frozen_raw), run("--bag", &frozen_bag));
    for o in [&a, &b] {
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(err.lines().count(), 1, "{err}");
    }
    let reasons = |o: &std::process::Output| {
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        v["dropped_by_reason"].clone()
    };
    assert_eq!(reasons(&a), reasons(&b));
    assert!(
        reasons(&a).to_string().contains("localization"),
        "{}",
        reasons(&a)
    );
    assert!(!target.exists());
}

/// `bytes` (an MCAP file of uncompressed chunks) with each chunk's records compressed by
/// `compress` under the name `codec`, its summary dropped (its offsets no longer hold) and
/// its data section's CRC cleared (the section changed).
fn recompressed(bytes: &[u8], codec: &str, compress: impl Fn(&[u8]) -> Vec<u8>) -> Vec<u8> {
    let magic = &bytes[..8];
    let mut out = magic.to_vec();
    let mut at = 8;
    let mut chunks = 0;
    loop {
        let op = bytes[at];
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        let content = &bytes[at + 9..at + 9 + len];
        match op {
            0x06 => {
                let name = u32::from_le_bytes(content[28..32].try_into().unwrap()) as usize;
                assert_eq!(name, 0, "an uncompressed chunk");
                let packed = compress(&content[40..]);
                let mut chunk = content[..28].to_vec();
                chunk.extend((codec.len() as u32).to_le_bytes());
                chunk.extend(codec.as_bytes());
                chunk.extend((packed.len() as u64).to_le_bytes());
                chunk.extend(packed);
                out.push(0x06);
                out.extend((chunk.len() as u64).to_le_bytes());
                out.extend(chunk);
                chunks += 1;
            }
            0x0F => {
                // Data end without a CRC, then a footer without a summary.
                out.push(0x0F);
                out.extend(4u64.to_le_bytes());
                out.extend([0; 4]);
                out.push(0x02);
                out.extend(20u64.to_le_bytes());
                out.extend([0; 20]);
                out.extend(magic);
                assert!(chunks > 0);
                return out;
            }
            _ => out.extend(&bytes[at..at + 9 + len]),
        }
        at += 9 + len;
    }
}

/// Bags whose chunks are zstd or lz4 compressed (rosbag2's options) give the windows of the
/// same bag uncompressed; a compressed chunk cut short is refused in one line.
#[test]
fn zstd_and_lz4_chunks_give_the_windows_of_the_uncompressed_bag() {
    let dir = tempfile::tempdir().unwrap();
    let (_, bag) = fixtures(dir.path());
    let bytes = std::fs::read(bag.join("bag.mcap")).unwrap();
    let plain = dir.path().join("plain.csv");
    ok(&import("--bag", &bag.join("bag.mcap"), &plain, &[]));
    let zstd = |r: &[u8]| {
        ruzstd::encoding::compress_to_vec(r, ruzstd::encoding::CompressionLevel::Fastest)
    };
    let lz4 = |r: &[u8]| {
        let mut w = lz4_flex::frame::FrameEncoder::new(Vec::new());
        std::io::Write::write_all(&mut w, r).unwrap();
        w.finish().unwrap()
    };
    for (codec, packed) in [
        ("zstd", recompressed(&bytes, "zstd", zstd)),
        ("lz4", recompressed(&bytes, "lz4", lz4)),
    ] {
        assert!(
            packed.len() < bytes.len() / 2,
            "{codec}: {} bytes",
            packed.len()
        );
        let file = dir.path().join(format!("{codec}.mcap"));
        std::fs::write(&file, &packed).unwrap();
        let out = dir.path().join(format!("{codec}.csv"));
        ok(&import("--bag", &file, &out, &[]));
        assert_eq!(
            std::fs::read(&out).unwrap(),
            std::fs::read(&plain).unwrap(),
            "{codec}"
        );
        // The first chunk's compressed records cut in half: refused, not half read.
        let cut = dir.path().join(format!("{codec}_cut.mcap"));
        let chunk = 8 + 9 + 26;
        let content = chunk + 9;
        let name = 4 + codec.len();
        let len_at = content + 28 + name;
        let packed_len = u64::from_le_bytes(packed[len_at..len_at + 8].try_into().unwrap());
        let mut short = packed.clone();
        let half = packed_len / 2;
        short[len_at..len_at + 8].copy_from_slice(&half.to_le_bytes());
        let record_len = u64::from_le_bytes(short[chunk + 1..chunk + 9].try_into().unwrap());
        short[chunk + 1..chunk + 9]
            .copy_from_slice(&(record_len - (packed_len - half)).to_le_bytes());
        let end = len_at + 8 + half as usize;
        short.drain(end..end + (packed_len - half) as usize);
        std::fs::write(&cut, &short).unwrap();
        let err = user_error(&import("--bag", &cut, &dir.path().join("cut.csv"), &[]));
        assert!(err.contains(&format!("{codec} chunk")), "{err}");
    }
}
