//! The `drive` command line with the project's parts (see `drive::cli` to run it with
//! your own).

fn main() -> std::process::ExitCode {
    drive::cli::main(drive::Registries::builtin())
}
