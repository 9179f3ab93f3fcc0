//! The `aisle` binary: everything lives in the library (`cli::main`).

fn main() -> std::process::ExitCode {
    aisle_supervisor::cli::main()
}
