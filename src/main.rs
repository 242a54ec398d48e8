// The command line lives in the binary, not in the library's public API; its modules name library items
// as `crate::…`, which this glob import makes resolve to the library.
#[allow(unused_imports)]
use driftloop::*;

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
