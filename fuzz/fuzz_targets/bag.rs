#![no_main]
//! Fuzz target: `drive::fuzz::bag` (the rosbag2 MCAP reader) must never panic, abort or
//! allocate beyond its limits on any bytes.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = drive::fuzz::bag(data);
});
