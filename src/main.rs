use std::process::ExitCode;

fn main() -> ExitCode {
    driftloop::cli::main()
}
