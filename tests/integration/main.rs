//! The integration tests, one binary (issue 35: one link of the whole library instead of one
//! per file): each module runs the real `drive` command line or the library as a user would.

#[path = "../common/mod.rs"]
mod common;

mod adapt;
mod bad_input;
mod bags;
mod batch;
mod bench;
mod bench_page;
mod car;
mod cli;
mod data_checks;
mod fuzz_corpus;
mod model_files;
mod omnidirectional;
mod other_robot;
mod outputs;
mod outside_vehicle;
mod properties;
mod report_and_matrix;
mod report_parts;
mod score;
mod sim_fit;
mod start_information;
mod start_velocity;
mod step;
mod track;
