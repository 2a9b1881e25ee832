//! Replays the fuzz corpus (`fuzz/corpus/<target>/`) through the fuzz targets' entry points:
//! no input may panic, and the valid seeds are accepted. A run of `cargo fuzz` adds what it
//! finds to the corpus; this test keeps every such input fixed.

use std::path::Path;

fn replay(target: &str, run: fn(&[u8]) -> bool) -> (usize, usize) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fuzz/corpus")
        .join(target);
    let mut entries: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    let mut accepted = 0;
    for path in &entries {
        let bytes = std::fs::read(path).unwrap();
        let ok = std::panic::catch_unwind(|| run(&bytes))
            .unwrap_or_else(|_| panic!("{} panics on {}", target, path.display()));
        accepted += usize::from(ok);
    }
    (entries.len(), accepted)
}

#[test]
fn window_csv_corpus() {
    let (n, accepted) = replay("window_csv", drive::fuzz::window_csv);
    assert!(n >= 5);
    assert!(accepted >= 1, "the valid seed is accepted");
}

#[test]
fn raw_log_corpus() {
    let (n, accepted) = replay("raw_log", drive::fuzz::raw_log);
    assert!(n >= 2);
    assert!(accepted >= 2, "the seeds are read and imported");
}

#[test]
fn sidecar_corpus() {
    let (n, accepted) = replay("sidecar", drive::fuzz::sidecar);
    assert!(n >= 20);
    assert!(accepted >= 3, "the valid seeds are read");
}

#[test]
fn robot_toml_corpus() {
    let (n, accepted) = replay("robot_toml", drive::fuzz::robot_toml);
    assert!(n >= 20);
    assert!(accepted >= 3, "the valid seeds are read");
}

#[test]
fn model_file_corpus() {
    let (n, accepted) = replay("model_file", drive::fuzz::model_file);
    assert!(n >= 4);
    assert!(accepted >= 4, "the four trained models load");
}

#[test]
fn bag_corpus() {
    let (n, accepted) = replay("bag", drive::fuzz::bag);
    assert!(n >= 9);
    assert!(
        accepted >= 2,
        "the valid bags (with and without a chunk CRC) are read"
    );
    // The crafted and damaged seeds are refused, without a panic or an abort (an
    // uncompressed chunk declaring 2^60 bytes, chunk_uncompressed_huge.mcap, is read by its
    // records' own length: no panic, nothing allocated for it).
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/bag");
    for bad in [
        "bad_chunk_crc.mcap",
        "huge_record_length.mcap",
        "record_length_2_45.mcap",
        "truncated.mcap",
        "not_mcap.mcap",
    ] {
        assert!(
            !drive::fuzz::bag(&std::fs::read(dir.join(bad)).unwrap()),
            "{bad}"
        );
    }
}
