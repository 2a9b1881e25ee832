//! drive-eval's integration tests, one binary (one link): one module per subject.

mod terrain;
