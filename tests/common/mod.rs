//! Running the `drive` command line from the integration tests.

#![allow(dead_code)] // each test file uses some of these

use std::process::{Command, Output};

/// Runs `drive` with `args`.
pub fn drive(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_drive"))
        .args(args)
        .output()
        .expect("the drive binary runs")
}

/// Runs `drive`, asserting success; its standard output.
pub fn ok(args: &[&str]) -> String {
    let out = drive(args);
    assert!(
        out.status.success(),
        "drive {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// A user error: non-zero exit, one clear line on stderr, nothing on stdout.
pub fn user_error(args: &[&str]) -> String {
    let out = drive(args);
    assert!(!out.status.success(), "drive {args:?} should fail");
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(
        err.trim_end().lines().count(),
        1,
        "one line expected: {err}"
    );
    assert!(err.starts_with("error: "), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(out.stdout.is_empty());
    err
}
