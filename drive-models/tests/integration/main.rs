//! drive-models's integration tests, one binary (one link): one module per subject.

mod models;
mod registry;
