//! drive-sim's integration tests, one binary (one link): one module per subject.

mod car;
mod physics;
mod raw_log;
mod runner;
mod targeted;
