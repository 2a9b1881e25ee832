//! drive-data's integration tests, one binary (one link): one module per subject.

mod bad_input;
mod raw_import;
