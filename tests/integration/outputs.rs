//! Outputs never replace inputs, and appear all together or not at all: through the real
//! command line.

use crate::common;

use common::{drive, ok, user_error};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Every file under `dir` (recursively) with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.insert(p.clone(), std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

/// A small simulated dataset (`data.csv` and its sidecar), a model and a raw log in `dir`.
fn fixtures(dir: &Path) {
    let at = |n: &str| s(&dir.join(n));
    ok(&[
        "simulate",
        "--robot",
        "warthog",
        "--terrain",
        "gravel",
        "--duration",
        "60",
        "--seed",
        "1",
        "--out",
        &at("data.csv"),
        "--raw-out",
        &at("raw.csv"),
    ]);
    ok(&[
        "train",
        "--data",
        &at("data.csv"),
        "--model",
        "slip-blr",
        "--out",
        &at("model.json"),
    ]);
    std::fs::write(dir.join("sweep.toml"), "learners = [\"no-slip\"]\npowertrains = [\"commanded\"]\n\n[[datasets]]\nfile = \"data.csv\"\n").unwrap();
    // A twin's terrain file, and one inside a matrix's output folder named like one of its
    // outputs, read by a sweep's simulated part.
    let twin = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/husky_twin.toml"),
    )
    .unwrap();
    std::fs::write(dir.join("twin.toml"), &twin).unwrap();
    std::fs::create_dir(dir.join("matrix-out")).unwrap();
    std::fs::write(dir.join("matrix-out/matrix.json"), &twin).unwrap();
    std::fs::write(
        dir.join("twin-sweep.toml"),
        format!(
            "learners = [\"no-slip\"]\npowertrains = [\"commanded\"]\n\n[simulated]\nrobots = [\"husky\"]\nterrains = [\"{}\"]\nsamplers = [\"uniform\"]\ndurations = [60]\nseeds = [1]\ntest_duration = 60\n",
            s(&dir.join("matrix-out/matrix.json"))
        ),
    )
    .unwrap();
}

#[test]
fn an_output_that_would_replace_an_input_is_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    fixtures(dir.path());
    let at = |n: &str| s(&dir.path().join(n));
    #[cfg(unix)]
    std::os::unix::fs::symlink(
        dir.path().join("data.meta.json"),
        dir.path().join("link.json"),
    )
    .unwrap();
    // A raw log named like the sidecar of an import's output.
    std::fs::copy(dir.path().join("raw.csv"), dir.path().join("imp.meta.json")).unwrap();
    let before = snapshot(dir.path());
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec![
                "import".into(),
                "--raw".into(),
                at("raw.csv"),
                "--robot".into(),
                "warthog".into(),
                "--out".into(),
                at("raw.csv"),
            ],
            "--out",
        ),
        (
            vec![
                "import".into(),
                "--raw".into(),
                at("imp.meta.json"),
                "--robot".into(),
                "warthog".into(),
                "--out".into(),
                at("imp.csv"),
            ],
            "sidecar of --out",
        ),
        (
            vec![
                "train".into(),
                "--data".into(),
                at("data.csv"),
                "--model".into(),
                "naive".into(),
                "--out".into(),
                at("data.csv"),
            ],
            "input --data",
        ),
        (
            vec![
                "train".into(),
                "--data".into(),
                at("data.csv"),
                "--model".into(),
                "naive".into(),
                "--out".into(),
                at("data.meta.json"),
            ],
            "sidecar of --data",
        ),
        (
            vec![
                "train".into(),
                "--data".into(),
                at("data.csv"),
                "--model".into(),
                "naive".into(),
                "--out".into(),
                format!(
                    "{}/../{}/data.meta.json",
                    at("."),
                    dir.path().file_name().unwrap().to_string_lossy()
                ),
            ],
            "sidecar of --data",
        ),
        (
            vec![
                "eval".into(),
                "--data".into(),
                at("data.csv"),
                "--per-window".into(),
                at("data.csv"),
            ],
            "--per-window",
        ),
        (
            vec![
                "simulate".into(),
                "--robot".into(),
                "husky".into(),
                "--terrain".into(),
                "tile".into(),
                "--duration".into(),
                "40".into(),
                "--out".into(),
                at("new.csv"),
                "--raw-out".into(),
                at("new.meta.json"),
            ],
            "sidecar of --out",
        ),
        (
            vec![
                "simulate".into(),
                "--robot".into(),
                "husky".into(),
                "--terrain".into(),
                "tile".into(),
                "--duration".into(),
                "40".into(),
                "--out".into(),
                at("new.csv"),
                "--raw-out".into(),
                at("new.meta.json"),
            ],
            "--raw-out",
        ),
        (
            vec![
                "report".into(),
                "--data".into(),
                at("data.csv"),
                "--out".into(),
                at("data.csv"),
            ],
            "--out",
        ),
        // Issue 34: a terrain file is an input like every other.
        (
            vec![
                "simulate".into(),
                "--robot".into(),
                "husky".into(),
                "--terrain".into(),
                at("twin.toml"),
                "--duration".into(),
                "40".into(),
                "--out".into(),
                at("twin.toml"),
            ],
            "the input --terrain",
        ),
        (
            vec![
                "simulate".into(),
                "--robot".into(),
                "husky".into(),
                "--terrain".into(),
                at("twin.toml"),
                "--duration".into(),
                "40".into(),
                "--out".into(),
                at("new.csv"),
                "--raw-out".into(),
                at("twin.toml"),
            ],
            "the input --terrain",
        ),
        (
            vec![
                "matrix".into(),
                "--config".into(),
                at("twin-sweep.toml"),
                "--out".into(),
                at("matrix-out"),
            ],
            "a terrain of --config",
        ),
        (
            vec![
                "matrix".into(),
                "--config".into(),
                at("sweep.toml"),
                "--out".into(),
                at("data.csv"),
            ],
            "a dataset of --config",
        ),
    ];
    #[cfg(unix)]
    let cases = {
        let mut c = cases;
        c.push((
            vec![
                "train".into(),
                "--data".into(),
                at("data.csv"),
                "--model".into(),
                "naive".into(),
                "--out".into(),
                at("link.json"),
            ],
            "sidecar of --data",
        ));
        c
    };
    for (args, says) in &cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let err = user_error(&args);
        assert!(
            err.contains("would replace") && err.contains(says),
            "{args:?}: {err}"
        );
        assert_eq!(
            snapshot(dir.path()),
            before,
            "{args:?} changed the directory"
        );
    }
}

/// Runs `drive` with `args` under a file-size limit of a few kilobytes (with SIGXFSZ at its
/// default, which kills the process: the program ignores it itself, so that a write beyond
/// the limit fails with an error).
fn drive_with_small_file_limit(args: &[&str]) -> std::process::Output {
    let quoted: Vec<String> = args.iter().map(|a| format!("'{a}'")).collect();
    Command::new("sh")
        .arg("-c")
        .arg(format!(
            "trap - XFSZ; ulimit -f 8 && exec '{}' {}",
            env!("CARGO_BIN_EXE_drive"),
            quoted.join(" ")
        ))
        .output()
        .expect("sh runs")
}

#[cfg(unix)]
#[test]
fn a_failed_write_leaves_the_previous_files_byte_identical() {
    let dir = tempfile::tempdir().unwrap();
    fixtures(dir.path());
    let at = |n: &str| s(&dir.path().join(n));
    ok(&["report", "--data", &at("data.csv"), "--out", &at("rep")]);
    let before = snapshot(dir.path());
    let runs: [Vec<String>; 3] = [
        // A new CSV and sidecar over the old pair.
        [
            "simulate",
            "--robot",
            "warthog",
            "--terrain",
            "snow",
            "--duration",
            "60",
            "--seed",
            "2",
            "--out",
            &at("data.csv"),
        ]
        .map(String::from)
        .to_vec(),
        // A report over the old report.
        [
            "report",
            "--data",
            &at("data.csv"),
            "--out",
            &at("rep"),
            "--models",
            "naive,slip-blr",
        ]
        .map(String::from)
        .to_vec(),
        // A report into a new folder: nothing left behind.
        ["report", "--data", &at("data.csv"), "--out", &at("new/rep")]
            .map(String::from)
            .to_vec(),
    ];
    for args in &runs {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = drive_with_small_file_limit(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains("cannot write"), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        let after = snapshot(dir.path());
        assert_eq!(
            after.keys().collect::<Vec<_>>(),
            before.keys().collect::<Vec<_>>(),
            "{args:?}: files added or removed"
        );
        assert!(after == before, "{args:?}: a file changed");
        assert!(!dir.path().join("new").exists());
    }
}

#[test]
fn a_csv_beside_another_runs_sidecar_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let at = |n: &str| s(&dir.path().join(n));
    for (name, seed) in [("a.csv", "1"), ("b.csv", "2")] {
        ok(&[
            "simulate",
            "--robot",
            "husky",
            "--terrain",
            "tile",
            "--duration",
            "40",
            "--seed",
            seed,
            "--out",
            &at(name),
        ]);
    }
    std::fs::copy(dir.path().join("b.csv"), dir.path().join("a.csv")).unwrap();
    let err = user_error(&["eval", "--data", &at("a.csv")]);
    assert!(
        err.contains("a.meta.json, field 'csv'")
            && err.contains("not the CSV this sidecar was written with"),
        "{err}"
    );
}

#[test]
fn two_runs_writing_one_output_leave_a_pair_that_is_one_runs_or_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let at = |n: &str| s(&dir.path().join(n));
    // The two runs' own outputs, for reference.
    for seed in ["1", "2"] {
        ok(&[
            "simulate",
            "--robot",
            "husky",
            "--terrain",
            "tile",
            "--duration",
            "60",
            "--seed",
            seed,
            "--out",
            &at(&format!("ref{seed}.csv")),
        ]);
    }
    let reference: Vec<(Vec<u8>, Vec<u8>)> = ["ref1", "ref2"]
        .iter()
        .map(|r| {
            (
                std::fs::read(dir.path().join(format!("{r}.csv"))).unwrap(),
                std::fs::read(dir.path().join(format!("{r}.meta.json"))).unwrap(),
            )
        })
        .collect();
    for _ in 0..20 {
        let children: Vec<_> = ["1", "2"]
            .iter()
            .map(|seed| {
                Command::new(env!("CARGO_BIN_EXE_drive"))
                    .args([
                        "simulate",
                        "--robot",
                        "husky",
                        "--terrain",
                        "tile",
                        "--duration",
                        "60",
                        "--seed",
                        seed,
                        "--out",
                        &at("same.csv"),
                    ])
                    .stderr(std::process::Stdio::null())
                    .spawn()
                    .unwrap()
            })
            .collect();
        for mut c in children {
            assert!(c.wait().unwrap().success());
        }
        let csv = std::fs::read(dir.path().join("same.csv")).unwrap();
        let side = std::fs::read(dir.path().join("same.meta.json")).unwrap();
        // Every file is whole: one run's or the other's.
        assert!(
            reference.iter().any(|(c, _)| *c == csv),
            "a CSV of neither run"
        );
        let side_of = |s: &[u8]| {
            // The sidecars differ by name, seed and digest only; compare the digest.
            let v: serde_json::Value = serde_json::from_slice(s).unwrap();
            v["csv"].clone()
        };
        assert!(reference.iter().any(|(_, j)| side_of(j) == side_of(&side)));
        let matched = reference
            .iter()
            .any(|(c, j)| *c == csv && side_of(j) == side_of(&side));
        let out = common::drive(&["eval", "--data", &at("same.csv"), "--models", "naive"]);
        if matched {
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
        } else {
            // One run's CSV beside the other's sidecar: refused, never read.
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(
                err.contains("not the CSV this sidecar was written with"),
                "{err}"
            );
        }
    }
    // No temporary file is left behind by either run.
    let stray = std::fs::read_dir(dir.path())
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .starts_with(".drive-tmp")
        })
        .count();
    assert_eq!(stray, 0);
}

#[cfg(unix)]
#[test]
fn standard_streams_and_pipes_are_written_into_not_replaced() {
    // --per-window /dev/stdout: the rows go to this process's output with the table.
    let out = ok(&["eval", "--models", "naive", "--per-window", "/dev/stdout"]);
    assert!(
        out.starts_with("model,window,interval,phase"),
        "{}",
        &out[..80]
    );
    assert!(out.contains("DRIVE model comparison"));
    // A dataset cannot go to a pipe: its sidecar would have nowhere to be.
    let dir = tempfile::tempdir().unwrap();
    let pipe = dir.path().join("pipe");
    if Command::new("mkfifo")
        .arg(&pipe)
        .status()
        .is_ok_and(|s| s.success())
    {
        let err = user_error(&[
            "simulate",
            "--robot",
            "husky",
            "--terrain",
            "tile",
            "--duration",
            "40",
            "--out",
            &s(&pipe),
        ]);
        assert!(err.contains("not a regular file"), "{err}");
        assert!(!dir.path().join("pipe.meta.json").exists());
    }
}

/// Runs `drive COMMAND` through the shell, which applies the redirections written in
/// `command` (`> file`, `2> file`, `>> file`) before drive starts.
fn drive_in_shell(command: &str) -> std::process::Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!("exec '{}' {command}", env!("CARGO_BIN_EXE_drive")))
        .output()
        .expect("sh runs")
}

/// Issue 35: `drive eval --data run.csv --json > run.meta.json` (the shell empties the sidecar
/// before drive starts) says what happened, rather than that the sidecar is empty.
#[cfg(unix)]
#[test]
fn a_redirect_onto_an_input_is_named() {
    let dir = tempfile::tempdir().unwrap();
    fixtures(dir.path());
    let at = |n: &str| s(&dir.path().join(n));
    let dataset = (
        std::fs::read(dir.path().join("data.csv")).unwrap(),
        std::fs::read(dir.path().join("data.meta.json")).unwrap(),
    );
    for (command, target, says) in [
        (
            format!("eval --data '{}' --json", at("data.csv")),
            at("data.meta.json"),
            "the input sidecar of --data",
        ),
        (
            format!("check --data '{}' --json", at("data.csv")),
            at("data.csv"),
            "the input --data",
        ),
        (
            format!(
                "predict --model '{}' --commands '{}'",
                at("model.json"),
                at("model.json")
            ),
            at("model.json"),
            "the input --model",
        ),
    ] {
        let out = drive_in_shell(&format!("{command} > '{target}'"));
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{command}: {err}");
        assert!(
            err.contains("the standard output is") && err.contains(says),
            "{command}: {err}"
        );
        assert!(
            err.contains("the shell emptied it before drive started"),
            "{err}"
        );
    }
    // The standard output onto the command's own output: refused, before anything is
    // written.
    let out = drive_in_shell(&format!(
        "import --raw '{}' --robot warthog --out '{}' --json > '{}'",
        at("raw.csv"),
        at("own.csv"),
        at("own.csv")
    ));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("the standard output is") && err.contains("the output --out"),
        "{err}"
    );
    // The standard error onto an input (`2> data.meta.json`): the message lands in that
    // file, and says what happened to it.
    // (The dataset as the fixtures wrote it: the redirections above emptied it.)
    std::fs::write(dir.path().join("data.csv"), &dataset.0).unwrap();
    std::fs::write(dir.path().join("data.meta.json"), &dataset.1).unwrap();
    let out = drive_in_shell(&format!(
        "eval --data '{}' 2> '{}'",
        at("data.csv"),
        at("data.meta.json")
    ));
    assert_eq!(out.status.code(), Some(1));
    let written = std::fs::read_to_string(dir.path().join("data.meta.json")).unwrap();
    assert!(
        written.contains("the standard error is")
            && written.contains("the input sidecar of --data"),
        "{written}"
    );
    // Appended (`>>`): refused too, and the file kept as it was.
    let commands = dir.path().join("commands.csv");
    std::fs::write(&commands, "t,cmd_left,cmd_right\n0,1,1\n").unwrap();
    let before = std::fs::read(&commands).unwrap();
    let model = dir.path().join("model2.json");
    ok(&["train", "--model", "naive", "--out", &s(&model)]);
    let out = drive_in_shell(&format!(
        "predict --model '{}' --commands '{}' >> '{}'",
        s(&model),
        s(&commands),
        s(&commands)
    ));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("the input --commands: the output would be written onto its end"),
        "{err}"
    );
    assert_eq!(std::fs::read(&commands).unwrap(), before);
}

/// Issue 63: every command checks the files named on its command line before it parses
/// any: a model, a sweep, a robot file or a sidecar emptied by `>` is named as such (not "EOF
/// while parsing" or "no dataset"), and `>>` onto one is refused before it is appended to.
#[cfg(unix)]
#[test]
fn a_redirect_onto_any_named_input_is_refused_before_it_is_read() {
    let dir = tempfile::tempdir().unwrap();
    fixtures(dir.path());
    let at = |n: &str| s(&dir.path().join(n));
    let robot = dir.path().join("robot.toml");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/warthog_1080.toml"),
        &robot,
    )
    .unwrap();
    let keep: Vec<(std::path::PathBuf, Vec<u8>)> = ["model.json", "data.meta.json", "sweep.toml"]
        .iter()
        .map(|n| dir.path().join(n))
        .chain([robot.clone()])
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap();
            (p, bytes)
        })
        .collect();
    for redirect in [">", ">>"] {
        for (command, target, says) in [
            (
                format!(
                    "adapt --prior '{}' --data '{}'",
                    at("model.json"),
                    at("data.csv")
                ),
                at("model.json"),
                "the input --prior",
            ),
            (
                format!("converge --data '{}'", at("data.csv")),
                at("data.meta.json"),
                "the input sidecar of --data",
            ),
            (
                format!("matrix --config '{}' --out '{}'", at("sweep.toml"), at("m")),
                at("sweep.toml"),
                "the input --config",
            ),
            (
                format!("check --data '{}' --robot '{}'", at("data.csv"), s(&robot)),
                s(&robot),
                "the input --robot",
            ),
        ] {
            let out = drive_in_shell(&format!("{command} {redirect} '{target}'"));
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{command} {redirect}: {err}");
            let what = if redirect == ">" {
                "the shell emptied it before drive started"
            } else {
                "the output would be written onto its end"
            };
            assert!(
                err.contains("the standard output is") && err.contains(says) && err.contains(what),
                "{command} {redirect}: {err}"
            );
            if redirect == ">>" {
                // Nothing was appended.
                for (path, bytes) in &keep {
                    assert_eq!(&std::fs::read(path).unwrap(), bytes, "{}", path.display());
                }
            }
        }
        // What `>` emptied, restored for the next round.
        for (path, bytes) in &keep {
            std::fs::write(path, bytes).unwrap();
        }
    }
    // A file the command writes (`--per-window /dev/stdout`) is not an input.
    let out = drive_in_shell(&format!(
        "eval --data '{}' --models naive --per-window /dev/stdout > '{}'",
        at("data.csv"),
        at("windows.txt")
    ));
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A tenth outside sweep: `eval ... 2>> run.meta.json` (the standard error appended onto an
/// input) was refused, and the refusal written onto the end of the sidecar it protected,
/// which then no longer parsed. The refusal now goes to the standard output, or nowhere
/// when that is an input too (`>> input 2>&1`); the input is left as it was.
#[cfg(unix)]
#[test]
fn a_standard_error_appended_onto_an_input_leaves_it_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    fixtures(dir.path());
    let at = |n: &str| s(&dir.path().join(n));
    let keep: Vec<(std::path::PathBuf, Vec<u8>)> = ["model.json", "data.meta.json", "sweep.toml"]
        .iter()
        .map(|n| {
            let p = dir.path().join(n);
            let bytes = std::fs::read(&p).unwrap();
            (p, bytes)
        })
        .collect();
    for (command, target, says) in [
        (
            format!("eval --data '{}' --models naive", at("data.csv")),
            at("data.meta.json"),
            "the input sidecar of --data",
        ),
        (
            format!(
                "adapt --prior '{}' --data '{}'",
                at("model.json"),
                at("data.csv")
            ),
            at("model.json"),
            "the input --prior",
        ),
        (
            format!("matrix --config '{}' --out '{}'", at("sweep.toml"), at("m")),
            at("sweep.toml"),
            "the input --config",
        ),
    ] {
        let out = drive_in_shell(&format!("{command} 2>> '{target}'"));
        let said = String::from_utf8_lossy(&out.stdout);
        assert_eq!(out.status.code(), Some(1), "{command}: {said}");
        assert!(
            said.contains("the standard error is") && said.contains(says),
            "{command}: {said}"
        );
        let out = drive_in_shell(&format!("{command} >> '{target}' 2>&1"));
        assert_eq!(out.status.code(), Some(1), "{command} 2>&1");
        for (path, bytes) in &keep {
            assert_eq!(&std::fs::read(path).unwrap(), bytes, "{}", path.display());
        }
    }
}

/// Issue 35: a dataset's sidecar is `run.meta.json`, so the JSON of `drive eval --data run.csv
/// --json > run.json` replaces nothing; a sidecar of earlier releases (`run.json`) is still
/// read, with a note naming the new name.
#[cfg(unix)]
#[test]
fn json_redirected_to_the_csvs_name_replaces_no_sidecar() {
    let dir = tempfile::tempdir().unwrap();
    fixtures(dir.path());
    let at = |n: &str| s(&dir.path().join(n));
    let sidecar = std::fs::read(dir.path().join("data.meta.json")).unwrap();
    assert!(!dir.path().join("data.json").exists());
    let out = drive_in_shell(&format!(
        "eval --data '{}' --json > '{}'",
        at("data.csv"),
        at("data.json")
    ));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("data.json")).unwrap()).unwrap();
    assert!(json["models"].is_array(), "{json}");
    assert_eq!(
        std::fs::read(dir.path().join("data.meta.json")).unwrap(),
        sidecar
    );
    // The earlier name: read when it is the only sidecar, with a note.
    std::fs::copy(dir.path().join("data.csv"), dir.path().join("old.csv")).unwrap();
    std::fs::write(dir.path().join("old.json"), &sidecar).unwrap();
    let out = drive(&["eval", "--data", &at("old.csv"), "--json"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("old.json, its name in earlier releases") && err.contains("old.meta.json"),
        "{err}"
    );
    // Both present: the current name is read, silently.
    std::fs::write(dir.path().join("old.meta.json"), &sidecar).unwrap();
    let out = drive(&["eval", "--data", &at("old.csv"), "--json"]);
    assert!(out.status.success());
    assert!(!String::from_utf8_lossy(&out.stderr).contains("earlier releases"));
}

/// An error that cannot be written (standard error on /dev/full) still exits 1, and a
/// full standard output is an error, never a panic (exit 101).
#[cfg(target_os = "linux")]
#[test]
fn a_standard_error_that_cannot_be_written_is_no_panic() {
    for (command, code) in [
        ("eval --split 1.5 2>/dev/full", 1),
        ("protocol --intervals 0 2>/dev/full", 2), // an argument error
        ("eval >/dev/full 2>/dev/full", 1),
        ("list >/dev/full", 1),
        ("--help >/dev/full", 1),
    ] {
        let out = drive_in_shell(command);
        assert_eq!(out.status.code(), Some(code), "{command}");
    }
}

#[test]
fn a_dataset_whose_text_fields_the_reader_refuses_is_never_written() {
    let dir = tempfile::tempdir().unwrap();
    // A simulated raw log to import.
    let logs = tempfile::tempdir().unwrap();
    let raw = s(&logs.path().join("raw.csv"));
    ok(&[
        "simulate",
        "--robot",
        "husky",
        "--terrain",
        "snow",
        "--duration",
        "60",
        "--seed",
        "1",
        "--out",
        &s(&logs.path().join("sim.csv")),
        "--raw-out",
        &raw,
    ]);
    let out = s(&dir.path().join("run.csv"));
    let import = |terrain: &str| -> Vec<String> {
        [
            "import",
            "--raw",
            &raw,
            "--robot",
            "husky",
            "--terrain",
            terrain,
            "--out",
            &out,
        ]
        .map(String::from)
        .to_vec()
    };
    let long = "x".repeat(300);
    // A terrain with a tab, or of 300 characters: `eval` would refuse the sidecar; `import`
    // refuses to write it, with the reader's words, and leaves nothing.
    // Nor a line separator (an eleventh outside sweep: U+2028 was written and read, and then
    // `train` refused to write the model: one rule for every file now).
    for (terrain, says) in [
        ("wet\tgrass", "field 'terrain': holds a control character"),
        (
            "grav\u{2028}el",
            "field 'terrain': holds a control character or a line separator",
        ),
        (long.as_str(), "terrain (characters)"),
    ] {
        let args = import(terrain);
        let err = user_error(&args.iter().map(String::as_str).collect::<Vec<_>>());
        assert!(
            err.contains("would not be read back") && err.contains(says),
            "{err}"
        );
        assert!(snapshot(dir.path()).is_empty(), "{terrain:?}");
    }
    // The same terrain without the tab is written and read back.
    let args = import("wet grass");
    ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let out = Path::new(&out);
    let side: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.with_extension("meta.json")).unwrap())
            .unwrap();
    assert_eq!(side["terrain"], "wet grass");
    ok(&["check", "--data", &s(out)]);
}

#[test]
fn an_output_directory_holds_one_runs_set_and_never_loses_a_users_file() {
    let dir = tempfile::tempdir().unwrap();
    fixtures(dir.path());
    let at = |n: &str| s(&dir.path().join(n));
    let rep = dir.path().join("rep");
    // A report with a model of a covariance draws its calibration; one without does not.
    ok(&[
        "report",
        "--data",
        &at("data.csv"),
        "--models",
        "naive,slip-blr",
        "--out",
        &at("rep"),
    ]);
    assert!(rep.join("calibration.png").exists());
    std::fs::write(rep.join("notes.txt"), "mine").unwrap();
    ok(&[
        "report",
        "--data",
        &at("data.csv"),
        "--models",
        "naive",
        "--model",
        "naive",
        "--out",
        &at("rep"),
    ]);
    // The first run's calibration figures are gone with it: what the directory holds is
    // the second run's set, and the user's file.
    assert!(!rep.join("calibration.png").exists());
    assert!(!rep.join("calibration.svg").exists());
    assert!(rep.join("report.md").exists());
    assert_eq!(
        std::fs::read_to_string(rep.join("notes.txt")).unwrap(),
        "mine"
    );
    let listed = std::fs::read_to_string(rep.join(".drive-outputs")).unwrap();
    assert!(listed.lines().any(|l| l == "report.md"), "{listed}");
    assert!(!listed.lines().any(|l| l == "notes.txt"), "{listed}");
}

/// An eleventh outside sweep: `eval --json --per-window /dev/stdout` wrote the per-window CSV
/// and then the JSON document onto the same standard output (a pipe here), which no JSON
/// reader parses. Refused now; without `--json` the CSV on the standard output stays allowed.
#[test]
fn a_per_window_csv_onto_the_json_output_is_refused() {
    let args = [
        "eval",
        "--data",
        "bundled:warthog_grass_2024-08-08",
        "--models",
        "naive",
        "--per-window",
        "/dev/stdout",
    ];
    let err = user_error(&[&args[..], &["--json"]].concat());
    assert!(
        err.contains("is the standard output, where --json prints its document"),
        "{err}"
    );
    let out = ok(&args);
    assert!(out.starts_with("model,window,interval,phase"), "{out}");
}

/// An eleventh outside sweep: a newline in a path file's name or a matrix dataset's name was
/// printed raw, splitting the lines of the tables. A path file's name is shown escaped; a
/// dataset's name with one is refused, as a suite's is.
#[test]
fn names_with_a_newline_never_split_a_tables_lines() {
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("nl\ndir");
    std::fs::create_dir(&folder).unwrap();
    let path = folder.join("p.csv");
    std::fs::write(&path, "x,y\n0,0\n2,0\n4,1\n6,1\n").unwrap();
    let out = ok(&[
        "track",
        "--robot",
        "husky",
        "--path",
        path.to_str().unwrap(),
        "--models",
        "naive",
        "--train-duration",
        "60",
        "--samples",
        "128",
    ]);
    let line = out
        .lines()
        .find(|l| l.starts_with("trained on"))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(line.contains("nl\\ndir/p.csv at 50%"), "{line}");
    let sweep = dir.path().join("sweep.toml");
    std::fs::write(
        &sweep,
        "baseline = \"no-slip+fopdt\"\nlearners = [\"no-slip\"]\npowertrains = [\"fopdt\"]\nsplits = [0.5]\n[[datasets]]\nbundled = \"warthog_grass_2024-08-08\"\nname = \"a\\nb\"\n",
    )
    .unwrap();
    let err = user_error(&[
        "matrix",
        "--config",
        sweep.to_str().unwrap(),
        "--out",
        dir.path().join("m").to_str().unwrap(),
    ]);
    assert!(
        err.contains("its name holds a control character or a line separator"),
        "{err}"
    );
}

/// `drive simulate`'s arguments for a minute of the Husky on tile written to `out`.
fn husky_minute(out: &Path) -> [&str; 9] {
    [
        "simulate",
        "--robot",
        "husky",
        "--terrain",
        "tile",
        "--duration",
        "60",
        "--out",
        out.to_str().unwrap(),
    ]
}

/// Issue 63 and the outside sweep of 2026-12-04: `simulate --out run.json` wrote a window
/// CSV under a .json name without a word, and `--out pair.meta.json` replaced the sidecar of
/// the dataset `pair.csv`. A window CSV's name must not say another kind of file.
#[test]
fn a_window_csv_is_not_written_under_a_name_of_another_kind() {
    let dir = tempfile::tempdir().unwrap();
    let pair = dir.path().join("pair.csv");
    ok(&husky_minute(&pair));
    let sidecar = dir.path().join("pair.meta.json");
    let before = std::fs::read(&sidecar).unwrap();
    for name in ["pair.meta.json", "run.json", "robot.toml", "RUN.JSON"] {
        let out = dir.path().join(name);
        let err = user_error(&husky_minute(&out));
        assert!(err.contains("name it .csv"), "{name}: {err}");
        let raw = dir.path().join("raw.csv");
        let err = user_error(&[
            "import",
            "--raw",
            raw.to_str().unwrap(),
            "--robot",
            "husky",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(err.contains("name it .csv"), "{name}: {err}");
    }
    assert_eq!(std::fs::read(&sidecar).unwrap(), before);
    assert!(!dir.path().join("run.json").exists());
}

/// The outside sweep of 2026-12-04: a dataset's sidecar path that is a link to /dev/null or
/// a FIFO made `simulate` exit 0 with a dataset no command could read, or hang after writing
/// the CSV. Refused before any work, nothing written.
#[cfg(unix)]
#[test]
fn a_dataset_whose_sidecar_would_be_a_device_or_a_pipe_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink("/dev/null", dir.path().join("null.meta.json")).unwrap();
    let fifo = dir.path().join("fifo.meta.json");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    for name in ["null.csv", "fifo.csv"] {
        let out = dir.path().join(name);
        let err = user_error(&husky_minute(&out));
        assert!(
            err.contains("is a device, a pipe or a standard stream"),
            "{name}: {err}"
        );
        assert!(!out.exists(), "{name}");
    }
}

/// Issue 63 and the outside sweep of 2026-12-04: with the standard output on a full device,
/// bench, simulate --json and import exited 1 after their outputs were published (a failed
/// bench replaced an earlier run's files). The standard output is written first: a command
/// that cannot write it fails with nothing new.
#[cfg(target_os = "linux")]
#[test]
fn a_command_that_cannot_write_its_standard_output_publishes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let raw = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/raw_log_warthog_bench.csv");
    let cases: [Vec<String>; 3] = [
        vec!["bench".into(), "--out".into(), d("bench")],
        vec![
            "simulate".into(),
            "--robot".into(),
            "husky".into(),
            "--terrain".into(),
            "tile".into(),
            "--duration".into(),
            "60".into(),
            "--json".into(),
            "--out".into(),
            d("sim.csv"),
        ],
        vec![
            "import".into(),
            "--raw".into(),
            raw.to_str().unwrap().into(),
            "--robot".into(),
            "warthog".into(),
            "--out".into(),
            d("imported.csv"),
        ],
    ];
    for args in cases {
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_drive"))
            .args(&args)
            .stdout(full)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}");
        assert!(
            err.contains("cannot write to standard output"),
            "{args:?}: {err}"
        );
        let left: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert!(left.is_empty(), "{args:?} left {left:?}");
    }
}

/// Issue 63 (a twelfth outside sweep): `train --out run.csv` and `sim-fit --out run.csv`
/// replaced a dataset's CSV with a model file or a twin, its sidecar left beside it, where a
/// CSV under a `.json` name is refused. A name that says a dataset or recording is refused
/// before any work, and the dataset is left as it was.
#[test]
fn a_model_or_twin_is_not_written_under_a_datasets_name() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("run.csv");
    let data = drive::bundled::load("husky_drive").unwrap();
    drive::data::write_dataset(&data, &csv).unwrap();
    let before = std::fs::read(&csv).unwrap();
    let c = csv.to_str().unwrap();
    let said = user_error(&["train", "--model", "naive", "--out", c]);
    assert!(
        said.contains("a model file (JSON) is written there, and the name says .csv"),
        "{said}"
    );
    let said = user_error(&["sim-fit", "--robot", "husky", "--out", c]);
    assert!(
        said.contains("a twin (TOML) is written there, and the name says .csv"),
        "{said}"
    );
    let gz = dir.path().join("run.csv.gz");
    let said = user_error(&["train", "--model", "naive", "--out", gz.to_str().unwrap()]);
    assert!(said.contains("the name says .csv.gz"), "{said}");
    // Nor under an array's name (a second sweep of that session: model.npy was written).
    let npy = dir.path().join("model.npy");
    let said = user_error(&["train", "--model", "naive", "--out", npy.to_str().unwrap()]);
    assert!(said.contains("the name says .npy"), "{said}");
    assert!(!npy.exists());
    // Nor over its sidecar (a second sweep: train --out run.meta.json replaced it).
    let sidecar = dir.path().join("run.meta.json");
    let sidecar_before = std::fs::read(&sidecar).unwrap();
    let said = user_error(&[
        "train",
        "--model",
        "naive",
        "--out",
        sidecar.to_str().unwrap(),
    ]);
    assert!(said.contains("the name says .meta.json"), "{said}");
    assert_eq!(std::fs::read(&sidecar).unwrap(), sidecar_before);
    assert_eq!(std::fs::read(&csv).unwrap(), before);
    // A CSV is written as text: a .gz name (which no reader could open) is refused, and a
    // schedule under another kind's name too.
    let at = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let said = user_error(&[
        "simulate",
        "--robot",
        "husky",
        "--terrain",
        "tile",
        "--duration",
        "30",
        "--out",
        &at("sim.csv.gz"),
    ]);
    assert!(said.contains("the name says .gz"), "{said}");
    for name in ["proto.json", "proto.csv.gz"] {
        let said = user_error(&[
            "protocol",
            "--robot",
            "husky",
            "--intervals",
            "3",
            "--out",
            &at(name),
        ]);
        assert!(
            said.contains("a schedule (CSV, uncompressed) is written there"),
            "{name}: {said}"
        );
        assert!(!dir.path().join(name).exists());
    }
}

/// Issue 63 (a third sweep): outputs written under another kind's name, or over a
/// dataset's: `train --out run.json` replaced the sidecar of `run.csv` by the name of
/// earlier releases (the dataset no longer loaded); `protocol --out p.npy` and
/// `eval --per-window pw.json` wrote CSVs under those names; `--per-window` and
/// `simulate --raw-out` replaced a dataset's CSV (its sidecar left beside a table);
/// `bench --out results.csv` made a directory of that name. Each is refused before any
/// work, and nothing is written.
#[test]
fn outputs_are_named_for_what_they_are_and_never_replace_a_dataset() {
    let dir = tempfile::tempdir().unwrap();
    let at = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let data = drive::bundled::load("husky_drive").unwrap();
    drive::data::write_dataset(&data, std::path::Path::new(&at("run.csv"))).unwrap();
    // A dataset whose sidecar has the name of earlier releases.
    std::fs::copy(at("run.csv"), at("old.csv")).unwrap();
    std::fs::copy(at("run.meta.json"), at("old.json")).unwrap();
    let before: Vec<Vec<u8>> = ["run.csv", "run.meta.json", "old.csv", "old.json"]
        .iter()
        .map(|f| std::fs::read(at(f)).unwrap())
        .collect();
    let cases: [(&[&str], &str); 6] = [
        (
            &["train", "--model", "naive", "--out", &at("old.json")],
            "the sidecar of the dataset",
        ),
        (
            &[
                "protocol",
                "--robot",
                "husky",
                "--intervals",
                "2",
                "--out",
                &at("p.npy"),
            ],
            "the name says .npy",
        ),
        (
            &["eval", "--models", "naive", "--per-window", &at("pw.json")],
            "the name says .json",
        ),
        (
            &["eval", "--models", "naive", "--per-window", &at("run.csv")],
            "a dataset's CSV",
        ),
        (
            &[
                "simulate",
                "--robot",
                "husky",
                "--terrain",
                "tile",
                "--duration",
                "30",
                "--out",
                &at("sim.csv"),
                "--raw-out",
                &at("old.csv"),
            ],
            "a dataset's CSV",
        ),
        (
            &["report", "--models", "naive", "--out", &at("results.csv")],
            "a directory of outputs is written there, and the name says .csv",
        ),
    ];
    for (args, says) in cases {
        let said = user_error(args);
        assert!(said.contains(says), "{args:?}: {said}");
    }
    let after: Vec<Vec<u8>> = ["run.csv", "run.meta.json", "old.csv", "old.json"]
        .iter()
        .map(|f| std::fs::read(at(f)).unwrap())
        .collect();
    assert!(before == after, "a dataset was changed");
    for made in ["p.npy", "pw.json", "sim.csv", "results.csv"] {
        assert!(!dir.path().join(made).exists(), "{made}");
    }
    // A model named after its dataset, whose sidecar is run.meta.json, is not its sidecar.
    ok(&["train", "--model", "naive", "--out", &at("run.json")]);
}
