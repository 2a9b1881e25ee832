//! Bad input at every entry point of the command line (window CSV, sidecar, raw log, robot
//! TOML, model JSON, arguments): each case is refused with a non-zero exit, one line on
//! stderr naming where and what, no panic, and no output file written.

use std::path::{Path, PathBuf};
use std::process::Command;

/// A file of a case: written before the command runs.
enum File {
    /// A copy of the small valid dataset (CSV and sidecar), edited.
    Dataset {
        csv: fn(String) -> String,
        sidecar: fn(String) -> String,
    },
    /// A raw log with this text.
    Raw(fn(String) -> String),
    /// A robot TOML with this text.
    Robot(&'static str),
    /// A copy of a valid slip-BLR model file, edited.
    Model(fn(String) -> String),
    /// Nothing.
    None,
}

struct Case {
    name: &'static str,
    file: File,
    /// Arguments; `{data}`, `{raw}`, `{robot}`, `{model}`, `{commands}` and `{out}` are
    /// replaced by paths in the case's directory.
    args: &'static [&'static str],
    /// What the error line must say.
    says: &'static [&'static str],
}

fn edit_model(text: &str, f: impl Fn(&mut serde_json::Value)) -> String {
    let mut v: serde_json::Value = serde_json::from_str(text).unwrap();
    f(&mut v);
    v.to_string()
}

/// The composed model inside the calibrated wrapper a default `drive train` writes.
fn composed(v: &mut serde_json::Value) -> &mut serde_json::Value {
    &mut v["model"]["model"]
}

fn zero_noise(m: String) -> String {
    edit_model(&m, |v| {
        let p = &mut composed(v)["slip"]["slip_x"];
        p["a"] = 0.0.into();
        p["b"] = 0.0.into();
    })
}

fn indefinite_covariance(m: String) -> String {
    edit_model(&m, |v| {
        let c = &mut composed(v)["slip"]["slip_yaw"]["covariance"];
        c[0] = (-1.0).into();
    })
}

fn keep(s: String) -> String {
    s
}

fn replace_line(text: &str, n: usize, f: impl Fn(&str) -> String) -> String {
    text.lines()
        .enumerate()
        .map(|(i, l)| if i + 1 == n { f(l) } else { l.to_string() })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n"
}

fn set_field(line: &str, column: usize, value: &str) -> String {
    let mut f: Vec<&str> = line.split(',').collect();
    f[column] = value;
    f.join(",")
}

const RAW_HEADER: &str = "ros_time,joy_switch,icp_index,calib_state,calib_step,meas_left_vel,meas_right_vel,cmd_vel_x,cmd_vel_omega,icp_pos_x,icp_pos_y,icp_pos_z,icp_quat_x,icp_quat_y,icp_quat_z,icp_quat_w,imu_x,imu_y,imu_z";

fn cases() -> Vec<Case> {
    let ds =
        |csv: fn(String) -> String, sidecar: fn(String) -> String| File::Dataset { csv, sidecar };
    vec![
        // Window CSV.
        Case { name: "csv NaN", file: ds(|t| replace_line(&t, 12, |l| set_field(l, 6, "NaN")), keep),
            args: &["eval", "--data", "{data}"], says: &["data.csv, line 12, column 'enc_left'", "not a finite number"] },
        Case { name: "csv text in a number", file: ds(|t| replace_line(&t, 5, |l| set_field(l, 9, "1,5")), keep),
            args: &["eval", "--data", "{data}"], says: &["data.csv, line 5", "13 fields where the header has 12"] },
        Case { name: "csv missing column", file: ds(|t| t.replacen(",imu_yaw_rate", "", 1), keep),
            args: &["eval", "--data", "{data}"], says: &["line 1, column 'imu_yaw_rate'", "missing column"] },
        Case { name: "csv unknown column", file: ds(|t| t.replacen("imu_yaw_rate", "gyro", 1), keep),
            args: &["eval", "--data", "{data}"], says: &["column 'gyro'", "unknown column"] },
        Case { name: "csv bad phase", file: ds(|t| replace_line(&t, 3, |l| l.replace("transient", "warmup")), keep),
            args: &["eval", "--data", "{data}"], says: &["line 3, column 'phase'", "'warmup' is not a phase"] },
        Case { name: "csv short window", file: ds(|t| replace_line(&t, 41, |_| String::new()).replace("\n\n", "\n"), keep),
            args: &["eval", "--data", "{data}"], says: &["window 0 has 39 samples"] },
        Case { name: "csv negative sample index", file: ds(|t| replace_line(&t, 4, |l| set_field(l, 2, "-2")), keep),
            args: &["eval", "--data", "{data}"], says: &["line 4, column 'k'", "not a non-negative integer"] },
        // Sidecar.
        Case { name: "sidecar negative radius", file: ds(keep, |s| s.replace("\"wheel_radius\": 0.3", "\"wheel_radius\": -0.3")),
            args: &["eval", "--data", "{data}"], says: &["data.meta.json, field 'vehicle'", "wheel_radius = -0.3"] },
        Case { name: "sidecar radius in millimetres", file: ds(keep, |s| s.replace("\"wheel_radius\": 0.3", "\"wheel_radius\": 300.0")),
            args: &["eval", "--data", "{data}"], says: &["data.meta.json, field 'vehicle'", "wheel_radius = 300 m is more than 100 m"] },
        Case { name: "sidecar unknown vehicle", file: ds(keep, |s| s.replace("\"differential\"", "\"hovercraft\"")),
            args: &["eval", "--data", "{data}"], says: &["data.meta.json, field 'vehicle'", "hovercraft"] },
        Case { name: "sidecar zero rate", file: ds(keep, |s| s.replace("\"rate_hz\": 20", "\"rate_hz\": 0")),
            args: &["eval", "--data", "{data}"], says: &["data.meta.json, field 'rate_hz'"] },
        Case { name: "sidecar window count", file: ds(keep, |s| s.replace("\"windows\": 12", "\"windows\": 13")),
            args: &["eval", "--data", "{data}"], says: &["field 'windows'", "announces 13 windows"] },
        Case { name: "sidecar unknown position frame", file: ds(keep, |s| s.replace("\"position_frame\": \"first-sample\"", "\"position_frame\": \"map\"")),
            args: &["eval", "--data", "{data}"], says: &["data.meta.json, field 'position_frame'", "\"map\"", "paper-mean5"] },
        Case { name: "sidecar position frame not a string", file: ds(keep, |s| s.replace("\"position_frame\": \"first-sample\"", "\"position_frame\": 5")),
            args: &["eval", "--data", "{data}"], says: &["field 'position_frame'", "found 5"] },
        Case { name: "sidecar not JSON", file: ds(keep, |_| "rate_hz = 20".into()),
            args: &["eval", "--data", "{data}"], says: &["data.meta.json"] },
        Case { name: "sidecar missing", file: File::None,
            args: &["eval", "--data", "{data}"], says: &["the sidecar JSON of", "was not found"] },
        // Raw log.
        Case { name: "raw bench log without localization", file: File::Raw(|_| {
                std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("data/raw_log_warthog_bench.csv")).unwrap()
            }),
            args: &["import", "--raw", "{raw}", "--robot", "warthog", "--out", "{out}"],
            says: &["no usable window in", "localization is all zeros", "nothing written"] },
        Case { name: "raw bad boolean", file: File::Raw(|h| format!("{h}\n1000,maybe,0,calib,0,0,0,0,0,0,0,0,0,0,0,1,0,0,0\n")),
            args: &["import", "--raw", "{raw}", "--robot", "warthog", "--out", "{out}"],
            says: &["raw.csv, line 2, column 'joy_switch'", "'maybe' is not a boolean"] },
        Case { name: "raw time backwards", file: File::Raw(|h| format!("{h}\n2000,False,0,calib,0,0,0,0,0,0,0,0,0,0,0,1,0,0,0\n1000,False,0,calib,0,0,0,0,0,0,0,0,0,0,0,1,0,0,0\n")),
            args: &["import", "--raw", "{raw}", "--robot", "warthog", "--out", "{out}"],
            says: &["line 3, column 'ros_time'", "goes back"] },
        Case { name: "raw missing column", file: File::Raw(|h| h.replace(",cmd_vel_omega", "") + "\n"),
            args: &["import", "--raw", "{raw}", "--robot", "warthog", "--out", "{out}"],
            says: &["line 1, column 'cmd_vel_omega'", "missing column"] },
        Case { name: "raw empty", file: File::Raw(|_| String::new()),
            args: &["import", "--raw", "{raw}", "--robot", "warthog", "--out", "{out}"],
            says: &["raw.csv: the file is empty"] },
        Case { name: "raw no interval", file: File::Raw(|h| format!("{h}\n1000,False,0,idle,0,0,0,0,0,0,0,0,0,0,0,1,0,0,0\n")),
            args: &["import", "--raw", "{raw}", "--robot", "warthog", "--out", "{out}"],
            says: &["no DRIVE interval in the log"] },
        Case { name: "raw non-positive gap limit", file: File::Raw(|h| format!("{h}\n1000,False,0,calib,0,0,0,0,0,0,0,0,0,0,0,1,0,0,0\n")),
            args: &["import", "--raw", "{raw}", "--robot", "warthog", "--out", "{out}", "--max-gap", "0"],
            says: &["max_gap_s", "not a positive number of seconds"] },
        // Robot TOML.
        Case { name: "robot negative baseline", file: File::Robot("name = 'r'\nmass_kg = 50\nwheel_radius = 0.1\nbaseline = -0.5\nmax_speed = 1\nmax_linear_acceleration = 1\nmax_angular_acceleration = 2\n"),
            args: &["protocol", "--robot", "{robot}", "--intervals", "2", "--out", "{out}"], says: &["robot.toml, field 'vehicle'", "baseline = -0.5", "positive"] },
        Case { name: "robot name with an escape sequence", file: File::Robot("name = \"a\\u001b[31mb\"\nmass_kg = 50\nwheel_radius = 0.1\nbaseline = 0.5\nmax_speed = 1\nmax_linear_acceleration = 1\nmax_angular_acceleration = 2\n"),
            args: &["simulate", "--robot", "{robot}", "--terrain", "tile", "--duration", "40", "--out", "{out}"], says: &["robot.toml, field 'name'", "holds a control character"] },
        Case { name: "robot unknown field", file: File::Robot("name = 'r'\nmass_kg = 50\nwheel_radius = 0.1\nbaseline = 0.5\nmax_speed = 1\nmax_linear_acceleration = 1\nmax_angular_acceleration = 2\ntop_speed = 3\n"),
            args: &["protocol", "--robot", "{robot}", "--intervals", "2", "--out", "{out}"], says: &["robot.toml", "unknown field `top_speed`"] },
        Case { name: "robot missing field", file: File::Robot("name = 'r'\nmass_kg = 50\nbaseline = 0.5\nmax_speed = 1\nmax_linear_acceleration = 1\nmax_angular_acceleration = 2\n"),
            args: &["protocol", "--robot", "{robot}", "--intervals", "2", "--out", "{out}"], says: &["robot.toml", "missing field `wheel_radius`"] },
        Case { name: "robot inverted wheel limits", file: File::Robot("name = 'r'\nmass_kg = 50\nwheel_radius = 0.1\nbaseline = 0.5\nmax_speed = 1\nmax_linear_acceleration = 1\nmax_angular_acceleration = 2\nwheel_limits = [5.0, -5.0]\n"),
            args: &["simulate", "--robot", "{robot}", "--terrain", "tile", "--duration", "40", "--out", "{out}"], says: &["field 'wheel_limits'", "omega_min < omega_max"] },
        Case { name: "robot too slow for a window", file: File::Robot("name = 'r'\nmass_kg = 50\nwheel_radius = 0.1\nbaseline = 0.5\nmax_speed = 1\nrate_hz = 0.4\nmax_linear_acceleration = 1\nmax_angular_acceleration = 2\n"),
            args: &["simulate", "--robot", "{robot}", "--terrain", "tile", "--duration", "60", "--out", "{out}"], says: &["field 'rate_hz'", "fewer than 2 samples per 2 s window"] },
        Case { name: "robot unknown preset", file: File::None,
            args: &["import", "--raw", "{raw}", "--robot", "husky2", "--out", "{out}"], says: &["unknown robot 'husky2'"] },
        // Model JSON.
        Case { name: "model newer version", file: File::Model(|m| m.replace("\"format_version\": 2", "\"format_version\": 3")),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json, field 'format_version'", "version 3 is not supported"] },
        Case { name: "model not JSON", file: File::Model(|m| m[..m.len() / 2].to_string()),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json, line", "not a valid model file"] },
        Case { name: "model without version", file: File::Model(|m| m.replace("\"format_version\": 2,", "")),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["field 'format_version': missing"] },
        Case { name: "model unknown type", file: File::Model(|m| m.replace("\"slip-blr\"", "\"gp\"")),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json, field 'model'", "gp"] },
        Case { name: "model negative step", file: File::Model(|m| m.replacen("\"dt\": 0.05", "\"dt\": -0.05", 1)),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json, field 'model'", "dt"] },
        // Arguments.
        Case { name: "split out of range", file: File::None, args: &["eval", "--split", "1.5"], says: &["split fraction 1.5"] },
        Case { name: "empty model list", file: File::None, args: &["eval", "--models", ","], says: &["--models is empty"] },
        Case { name: "zero duration", file: File::None,
            args: &["simulate", "--robot", "husky", "--terrain", "tile", "--duration", "0", "--out", "{out}"], says: &["--duration must be a positive"] },
        Case { name: "negative threshold", file: File::None, args: &["converge", "--thresholds", "-1,0.01"], says: &["--thresholds must be positive"] },
        Case { name: "unknown terrain", file: File::None,
            args: &["simulate", "--robot", "husky", "--terrain", "sand", "--duration", "30", "--out", "{out}"], says: &["unknown terrain 'sand'"] },
        // A missing file for a twin was called an unknown terrain (issue 63, a second sweep).
        Case { name: "missing twin file", file: File::None,
            args: &["sim-fit", "--robot", "husky", "--twin", "missing.csv.gz"], says: &["missing.csv.gz: no such file (a terrain is a terrain TOML file"] },
        Case { name: "zero intervals", file: File::None,
            args: &["protocol", "--robot", "husky", "--intervals", "0", "--out", "{out}"], says: &["--intervals must be at least 1"] },
        // Sizes that drive memory or run time: refused up front, naming the limit.
        Case { name: "sidecar tiny rate", file: ds(keep, |s| s.replace("\"rate_hz\": 20.0", "\"rate_hz\": 0.001")),
            args: &["eval", "--data", "{data}"], says: &["field 'rate_hz'", "outside the supported 1 to 1000 Hz"] },
        Case { name: "sidecar huge window", file: ds(keep, |s| s.replace("\"window_len\": 40", "\"window_len\": 1000000000000")),
            args: &["eval", "--data", "{data}"], says: &["field 'window_len'", "limit of 100000"] },
        Case { name: "robot huge top speed", file: File::Robot("name = 'r'\nmass_kg = 50\nwheel_radius = 0.1\nbaseline = 0.5\nmax_speed = 1e308\nmax_linear_acceleration = 1\nmax_angular_acceleration = 2\n"),
            args: &["protocol", "--robot", "{robot}", "--intervals", "2", "--out", "{out}"], says: &["field 'max_speed'", "1e308 m/s"] },
        Case { name: "robot huge rate", file: File::Robot("name = 'r'\nmass_kg = 50\nwheel_radius = 0.1\nbaseline = 0.5\nmax_speed = 1\nrate_hz = 1e9\nmax_linear_acceleration = 1\nmax_angular_acceleration = 2\n"),
            args: &["protocol", "--robot", "{robot}", "--intervals", "2", "--out", "{out}"], says: &["field 'rate_hz'", "limit of 1000 Hz"] },
        Case { name: "too many intervals", file: File::None,
            args: &["protocol", "--robot", "husky", "--intervals", "1000000000", "--out", "{out}"], says: &["--intervals = 1e9", "--max-samples"] },
        Case { name: "too long a simulation", file: File::None,
            args: &["simulate", "--robot", "husky", "--terrain", "tile", "--duration", "1e12", "--out", "{out}"], says: &["limit of 4e6", "--max-samples"] },
        Case { name: "sample limit raised too far", file: File::None,
            args: &["protocol", "--robot", "husky", "--intervals", "2", "--max-samples", "18446744073709551615", "--out", "{out}"], says: &["--max-samples = 1.84467e19", "limit of 2e7"] },
        Case { name: "too many study runs", file: File::None,
            args: &["compare-protocols", "--seeds", "1000", "--duration", "12,12,12"], says: &["the study's runs", "= 144000 is more than the limit of 100000"] },
        Case { name: "too many seeds", file: File::None,
            args: &["compare-protocols", "--seeds", "1000000000"], says: &["--seeds = 1e9", "limit of 1000"] },
        Case { name: "too many draws", file: File::None,
            args: &["compare-protocols", "--real", "--draws", "1000000000"], says: &["--draws = 1e9", "limit of 10000"] },
        Case { name: "csv corrupted number", file: ds(|t| replace_line(&t, 12, |l| set_field(l, 8, "1e308")), keep),
            args: &["eval", "--data", "{data}"], says: &["data.csv, line 12, column 'x'", "1e308 is beyond +-1e9"] },
        Case { name: "raw corrupted position", file: File::Raw(|h| format!("{h}\n1000,False,0,calib,0,0,0,0,0,1e308,0,0,0,0,0,1,0,0,0\n")),
            args: &["import", "--raw", "{raw}", "--robot", "warthog", "--out", "{out}"],
            says: &["raw.csv, line 2, column 'icp_pos_x'", "1e308 is beyond +-1e9"] },
        Case { name: "negative split", file: File::None, args: &["eval", "--split", "-0.1"], says: &["split fraction -0.1"] },
        // Model files validated on load.
        Case { name: "model zero noise", file: File::Model(zero_noise),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "must be positive"] },
        Case { name: "model indefinite covariance", file: File::Model(indefinite_covariance),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "not positive definite"] },
        Case { name: "model powertrain step", file: File::Model(|m| edit_model(&m, |v| composed(v)["powertrain"]["dt"] = 0.1.into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "powertrain's step 0.1 s is not the model's 0.05 s"] },
        Case { name: "model calibration scale", file: File::Model(|m| edit_model(&m, |v| v["model"]["calibration"]["yaw_scale"][3] = (-2.0).into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "calibration yaw_scale: the scale -2.0 is not a number in [1e-30, 1e30]"] },
        Case { name: "model robot rate", file: File::Model(|m| edit_model(&m, |v| v["robot"]["rate_hz"] = 10.0.into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "not the robot's command period"] },
        // Issue 63: files `train` never writes.
        Case { name: "model other format", file: File::Model(|m| edit_model(&m, |v| v["format"] = "another-tool".into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json, field 'format'", "\"another-tool\" is not a DRIVE motion model file"] },
        Case { name: "model without format", file: File::Model(|m| edit_model(&m, |v| { v.as_object_mut().unwrap().remove("format"); })),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json, field 'format': missing"] },
        Case { name: "model calibrated twice", file: File::Model(|m| edit_model(&m, |v| {
                let inner = v["model"].clone();
                let mut outer = inner.clone();
                outer["model"] = inner;
                v["model"] = outer;
            })),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "2 calibration layers, one inside another"] },
        // The outside sweep of 2026-12-04: a calibrated model inside a blend inside another
        // calibration layer, without `fitted_with`, was calibrated twice.
        Case { name: "model calibrated around a blend of calibrated models", file: File::Model(|m| edit_model(&m, |v| {
                let inner = v["model"].clone();
                let mut outer = inner.clone();
                outer["model"] = serde_json::json!({"type": "blended", "models": [inner], "weights": [1.0]});
                v["model"] = outer;
                v.as_object_mut().unwrap().remove("fitted_with");
            })),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "2 calibration layers, one inside another"] },
        // A twelfth outside sweep: a powertrain whose limits a fit never writes (1e-9 rad/s
        // against commands of about 1 rad/s): a model of a robot that never moves.
        Case { name: "model powertrain that cannot reach its commands", file: File::Model(|m| edit_model(&m, |v| {
                composed(v)["powertrain"]["limits"] = serde_json::json!({"min": [-1e-9, -1e-9], "max": [1e-9, 1e-9]});
            })),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "its powertrain, held at the commands it was fitted on", "less than 0.05 of them on axis 0"] },
        // A second sweep of that session: one wheel held to a twentieth, and a slip that
        // takes every motion (slip-BLR's forward slip mean edited to 1).
        Case { name: "model powertrain with one wheel that cannot turn", file: File::Model(|m| edit_model(&m, |v| {
                composed(v)["powertrain"]["limits"]["min"][0] = (-1e-7).into();
                composed(v)["powertrain"]["limits"]["max"][0] = 1e-7.into();
            })),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "less than 0.05 of them on axis 0"] },
        Case { name: "model whose slip takes every motion", file: File::Model(|m| edit_model(&m, |v| composed(v)["slip"]["slip_x"]["mean"][0] = 1.0.into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "from rest at the commands it was fitted on", "(its parameters are not what a fit writes)"] },
        // A third sweep of that session: a forward slip of 2 (the robot drives backwards),
        // a sideways slip of 1000 (20 m sideways in 4 s), a yaw slip of 1 (it never turns).
        Case { name: "model whose slip reverses the robot", file: File::Model(|m| edit_model(&m, |v| composed(v)["slip"]["slip_x"]["mean"][0] = 2.0.into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "ends on the other side of its start from where the commands take it"] },
        Case { name: "model whose slip slides the robot sideways", file: File::Model(|m| edit_model(&m, |v| composed(v)["slip"]["slip_y"]["mean"][0] = 1000.0.into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "(its parameters are not what a fit writes)"] },
        Case { name: "model whose slip takes every turn", file: File::Model(|m| edit_model(&m, |v| composed(v)["slip"]["slip_yaw"]["mean"] = serde_json::json!([0.0, 0.0, 1.0]))),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "hardly turns (under 0.01 of the turn asked), or turns the other way"] },
        // A third outside sweep: a model's names against what it is built of, and text
        // a sidecar cannot hold.
        Case { name: "model labelled as another model", file: File::Model(|m| edit_model(&m, |v| {
                composed(v)["label"] = "acc-blr+commanded".into();
                v["fitted_with"]["model"] = "acc-blr".into();
                v["fitted_with"]["canonical"] = "acc-blr+commanded".into();
            })),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "labelled 'acc-blr+commanded' but is built of a composed model (slip slip-blr, powertrain fopdt)"] },
        Case { name: "model label not its fitted_with", file: File::Model(|m| edit_model(&m, |v| composed(v)["label"] = "slip-ipem+fopdt".into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "labelled 'slip-ipem+fopdt' and fitted_with.canonical says 'slip-blr+fopdt'"] },
        Case { name: "model fitted_with contradicting itself", file: File::Model(|m| edit_model(&m, |v| v["fitted_with"]["model"] = "naive".into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "fitted_with.model 'naive' is the model 'no-slip+commanded', not 'slip-blr+fopdt'"] },
        Case { name: "model fitted_with model no name", file: File::Model(|m| edit_model(&m, |v| v["fitted_with"]["model"] = "slip-blr\nnaive".into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "fitted_with.model \"slip-blr\\nnaive\" is not a model name"] },
        Case { name: "model robot without a name", file: File::Model(|m| edit_model(&m, |v| v["robot"]["name"] = "".into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "robot.name is empty"] },
        Case { name: "model robot name with a control character", file: File::Model(|m| edit_model(&m, |v| v["robot"]["name"] = "run\u{1b}[31m".into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "robot.name holds a control character"] },
        Case { name: "model robot with a key train never writes", file: File::Model(|m| edit_model(&m, |v| v["robot"]["wheel_slip"] = 0.2.into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "robot", "unknown field `wheel_slip`"] },
        // A sixth outside sweep: a registered robot of another vehicle type, a calibration
        // from other windows than the fit's.
        Case { name: "model registered robot of another vehicle type", file: File::Model(|m| edit_model(&m, |v| v["robot"]["registered_robot"] = "autorally".into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "robot.registered_robot is 'autorally', a robot of vehicle type 'ackermann'"] },
        Case { name: "model calibration of other windows", file: File::Model(|m| edit_model(&m, |v| v["fitted_with"]["training_windows"] = 5.into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "but fitted_with.training_windows 5"] },
        Case { name: "model calibration of no window", file: File::Model(|m| edit_model(&m, |v| v["model"]["calibration"]["windows"] = 0.into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "calibration windows is 0"] },
        Case { name: "model calibration layer taken away", file: File::Model(|m| edit_model(&m, |v| {
                let inner = v["model"]["model"].clone();
                v["model"] = inner;
            })),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "fitted_with.uncertainty is \"calibrated\" but the model has no calibration layer"] },
        // Issue 34: model files no fit writes.
        Case { name: "model calibration of another horizon", file: File::Model(|m| edit_model(&m, |v| {
                for key in ["position_scale", "yaw_scale"] {
                    v["model"]["calibration"][key].as_array_mut().unwrap().push(1.0.into());
                }
            })),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "41 scales for a robot whose windows have 40 samples"] },
        Case { name: "model huge calibration scale", file: File::Model(|m| edit_model(&m, |v| v["model"]["calibration"]["yaw_scale"][3] = 1e300.into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "not a number in [1e-30, 1e30]"] },
        Case { name: "model dead time of years", file: File::Model(|m| edit_model(&m, |v| composed(v)["powertrain"]["axes"][0]["delay"] = 1e9.into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "delay 1e9 is not a number of seconds in [0, 60]"] },
        Case { name: "model noise shape no fit writes", file: File::Model(|m| edit_model(&m, |v| composed(v)["slip"]["slip_x"]["a"] = 1e300.into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "slip_x", "noise shape a = 1e300"] },
        Case { name: "model slip weight no fit writes", file: File::Model(|m| edit_model(&m, |v| composed(v)["slip"]["slip_y"]["mean"][0] = 1e300.into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "weight 1e300"] },
        Case { name: "model powertrain limits no fit writes", file: File::Model(|m| edit_model(&m, |v| composed(v)["powertrain"]["limits"]["max"][0] = 1e300.into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "powertrain limit 1e300"] },
        // From an outside sweep: a noise shape of a predictive without a variance, a rate
        // of 0 (an infinite command period no step compared unequal to).
        Case { name: "model noise shape of infinite variance", file: File::Model(|m| edit_model(&m, |v| composed(v)["slip"]["slip_x"]["a"] = 0.5.into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "slip_x", "noise shape a = 0.5 must be above 1"] },
        Case { name: "model robot rate zero", file: File::Model(|m| edit_model(&m, |v| v["robot"]["rate_hz"] = 0.0.into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "rate_hz = 0 Hz is outside the supported 1 to 1000 Hz"] },
        Case { name: "robot top speed in another unit", file: File::Robot("name = 'r'\nmass_kg = 50\nwheel_radius = 0.1\nbaseline = 0.5\nmax_speed = 1e-300\nmax_linear_acceleration = 1\nmax_angular_acceleration = 2\n"),
            args: &["protocol", "--robot", "{robot}", "--intervals", "2", "--out", "{out}"], says: &["field 'max_speed'", "1e-300 m/s is below 0.001 m/s"] },
        Case { name: "robot wheel in another unit", file: File::Robot("name = 'r'\nmass_kg = 50\nwheel_radius = 1e-300\nbaseline = 0.5\nmax_speed = 1\nmax_linear_acceleration = 1\nmax_angular_acceleration = 2\n"),
            args: &["protocol", "--robot", "{robot}", "--intervals", "2", "--out", "{out}"], says: &["wheel_radius = 1e-300 m is less than 0.001 m"] },
        Case { name: "predict start beyond 1e9", file: File::Model(|m| m),
            args: &["predict", "--model", "{model}", "--commands", "{commands}", "--start", "1e308,1e308,0"], says: &["--start = 1e308 is more than the limit of 1e9"] },
        // Issue 35: a parse error names the path inside the model.
        Case { name: "model field of the wrong type", file: File::Model(|m| edit_model(&m, |v| composed(v)["powertrain"]["dt"] = "fast".into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "model.model.powertrain.dt", "invalid type"] },
        Case { name: "model geometry not the robot's", file: File::Model(|m| edit_model(&m, |v| composed(v)["vehicle"]["baseline"] = 9.0.into())),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json", "is not the robot's"] },
        Case { name: "model duplicated key", file: File::Model(|m| m.replacen("\"format_version\": 2,", "\"format_version\": 2, \"format_version\": 1,", 1)),
            args: &["predict", "--model", "{model}", "--commands", "{commands}"], says: &["model.json, line", "\"format_version\" appears twice"] },
        Case { name: "commands from a device", file: File::None,
            args: &["predict", "--model", "{model}", "--commands", "/dev/zero"], says: &["/dev/zero", "not a regular file"] },
        Case { name: "model from a device", file: File::None,
            args: &["predict", "--model", "/dev/zero", "--commands", "{commands}"], says: &["/dev/zero", "not a regular file"] },
        Case { name: "sweep from a device", file: File::None,
            args: &["matrix", "--config", "/dev/zero", "--out", "{out}"], says: &["/dev/zero", "not a regular file"] },
        // A start beyond what a CSV reader accepts is refused before predicting (it was
        // refused after, as a prediction that is not a finite number).
        Case { name: "prediction beyond the model", file: File::None,
            args: &["predict", "--model", "{model}", "--commands", "{commands}", "--start-wheels", "1e308,1e308"], says: &["--start-wheels = 1e308 is more than the limit of 1e9"] },
    ]
}

fn drive(args: &[String]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_drive"))
        .args(args)
        .env_remove("RUST_BACKTRACE")
        .output()
        .expect("the drive binary runs")
}

/// A small valid dataset (4 intervals of the simulated Warthog), a slip-BLR model file and
/// a command file, made once.
fn fixtures(dir: &Path) -> (String, String, String, String) {
    let csv = dir.join("data.csv");
    let registries = drive::Registries::builtin();
    let data = drive::studies::simulate_protocol(&registries, "warthog", "gravel", "uniform", 4, 2)
        .unwrap()
        .dataset;
    drive::data::write_dataset(&data, &csv).unwrap();
    let model = dir.join("model.json");
    let args: Vec<String> = [
        "train",
        "--data",
        csv.to_str().unwrap(),
        "--model",
        "slip-blr",
        "--out",
        model.to_str().unwrap(),
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    assert!(drive(&args).status.success());
    let commands = dir.join("commands.csv");
    std::fs::write(&commands, "t,cmd_left,cmd_right\n0,1,1\n0.05,1,1\n").unwrap();
    let read = |p: &Path| std::fs::read_to_string(p).unwrap();
    (
        read(&csv),
        read(&dir.join("data.meta.json")),
        read(&model),
        read(&commands),
    )
}

#[test]
fn every_bad_input_is_refused_clearly() {
    let base = tempfile::tempdir().unwrap();
    let (csv, sidecar, model, commands) = fixtures(base.path());
    let all = cases();
    assert!(all.len() >= 25);
    for case in all {
        let dir = tempfile::tempdir().unwrap();
        let at = |name: &str| -> PathBuf { dir.path().join(name) };
        std::fs::write(at("commands.csv"), &commands).unwrap();
        match &case.file {
            File::Dataset { csv: c, sidecar: s } => {
                std::fs::write(at("data.csv"), c(csv.clone())).unwrap();
                std::fs::write(at("data.meta.json"), s(sidecar.clone())).unwrap();
            }
            File::Raw(f) => std::fs::write(at("raw.csv"), f(RAW_HEADER.to_string())).unwrap(),
            File::Robot(text) => std::fs::write(at("robot.toml"), text).unwrap(),
            File::Model(f) => std::fs::write(at("model.json"), f(model.clone())).unwrap(),
            File::None => {
                std::fs::write(at("model.json"), &model).unwrap();
                if case.args.contains(&"{data}") {
                    std::fs::write(at("data.csv"), &csv).unwrap();
                }
            }
        }
        let args: Vec<String> = case
            .args
            .iter()
            .map(|a| {
                let path = |n: &str| at(n).display().to_string();
                match *a {
                    "{data}" => path("data.csv"),
                    "{raw}" => path("raw.csv"),
                    "{robot}" => path("robot.toml"),
                    "{model}" => path("model.json"),
                    "{commands}" => path("commands.csv"),
                    "{out}" => path("out.csv"),
                    other => other.to_string(),
                }
            })
            .collect();
        let out = drive(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        let name = case.name;
        assert_eq!(out.status.code(), Some(1), "{name}: {err}");
        assert!(
            !err.contains("panicked") && !err.contains("backtrace"),
            "{name}: {err}"
        );
        assert_eq!(
            err.trim_end().lines().count(),
            1,
            "{name}: one line expected: {err}"
        );
        assert!(err.starts_with("error: "), "{name}: {err}");
        for needle in case.says {
            assert!(err.contains(needle), "{name}: '{needle}' not in: {err}");
        }
        // The message says each thing once (no cause repeated by the error chain).
        let parts: Vec<&str> = err.trim_end().split(": ").collect();
        for (i, p) in parts.iter().enumerate() {
            assert!(
                p.len() < 12 || !parts[i + 1..].contains(p),
                "{name}: repeated '{p}' in {err}"
            );
        }
        assert!(
            !at("out.csv").exists() && !at("out.json").exists(),
            "{name}: output written"
        );
    }
}

#[test]
fn sweeps_beyond_the_limits_are_refused_before_they_run() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            "learners = [\"no-slip\"]\npowertrains = [\"commanded\"]\n\n[[datasets]]\nbundled = \"husky\"\n\n[bootstrap]\nresamples = 1000000000000\n",
            "bootstrap.resamples = 1e12 is more than the limit of 1e6",
        ),
        (
            "[simulated]\nrobots = [\"husky\"]\nterrains = [\"tile\"]\nsamplers = [\"uniform\"]\ndurations = [60]\nseeds = [SEEDS]\ntest_duration = 60\n",
            "combinations",
        ),
        (
            "learners = [\"no-slip\"]\npowertrains = [\"commanded\"]\n\n[simulated]\nrobots = [\"husky\"]\nterrains = [\"tile\"]\nsamplers = [\"uniform\"]\ndurations = [1e12]\nseeds = [1]\ntest_duration = 60\n",
            "--max-samples",
        ),
    ];
    for (i, (text, says)) in cases.iter().enumerate() {
        let seeds: Vec<String> = (0..20_000).map(|s| s.to_string()).collect();
        let text = text.replace("SEEDS", &seeds.join(", "));
        let sweep = dir.path().join(format!("sweep{i}.toml"));
        std::fs::write(&sweep, text).unwrap();
        let out = dir.path().join(format!("out{i}"));
        let o = drive(&[
            "matrix".to_string(),
            "--config".to_string(),
            sweep.display().to_string(),
            "--out".to_string(),
            out.display().to_string(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains(says), "'{says}' not in {err}");
        assert!(!out.exists(), "{}", out.display());
    }
}

#[test]
fn an_escape_sequence_in_a_cell_or_a_value_never_reaches_the_terminal_raw() {
    let dir = tempfile::tempdir().unwrap();
    let (csv, sidecar, _, _) = fixtures(dir.path());
    // A cell holding an escape sequence (it would turn the terminal red), the sidecar kept.
    let bad = replace_line(&csv, 3, |l| set_field(l, 6, "1\u{1b}[31mRED"));
    let path = dir.path().join("esc.csv");
    std::fs::write(&path, bad).unwrap();
    std::fs::write(dir.path().join("esc.meta.json"), &sidecar).unwrap();
    let data = path.to_str().unwrap().to_string();
    for args in [
        vec!["eval".to_string(), "--data".into(), data.clone()],
        vec![
            "eval".into(),
            "--data".into(),
            dir.path().join("data.csv").to_str().unwrap().into(),
            "--models".into(),
            "naive\u{1b}[31mRED".into(),
        ],
        vec![
            "eval".into(),
            "--data".into(),
            "none\u{1b}]0;title\u{7}.csv".into(),
        ],
        vec!["track".into(), "--path".into(), "circle\u{202e}".into()],
        // A line separator breaks a line in terminals and log viewers that honour it.
        vec!["track".into(), "--path".into(), "circle\u{2028}x".into()],
    ] {
        let out = drive(&args);
        assert!(!out.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !err.contains('\u{1b}')
                && !err.contains('\u{7}')
                && !err.contains('\u{202e}')
                && !err.contains('\u{2028}'),
            "{args:?}: {err:?}"
        );
        assert!(
            err.contains("\\u{1b}") || err.contains("\\u{202e}") || err.contains("\\u{2028}"),
            "{args:?}: {err}"
        );
    }
}
