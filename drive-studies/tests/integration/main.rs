//! drive-studies' integration tests, one binary (one link): one module per subject.

mod protocols;
