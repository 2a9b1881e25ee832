#![no_main]
//! Fuzz target: `drive::fuzz::robot_toml` must never panic on any bytes.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = drive::fuzz::robot_toml(data);
});
