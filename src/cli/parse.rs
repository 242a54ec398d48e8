//! `driftloop parse FILE`: shows the tree the parser built (`json`) or prints the program back from it
//! (`source`, byte-identical to the input).

use std::io::{self, BufWriter, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use super::Global;
use crate::walk::Input;

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// The syntax tree and diagnostics as JSON.
    Json,
    /// The program re-emitted from the tree.
    Source,
}

#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  driftloop parse fixtures/omm/handwritten.mpf > tree.json\n  driftloop parse --format source PART.MPF | cmp - PART.MPF"
)]
pub struct Args {
    /// The program to parse; `-` reads stdin.
    #[arg(value_name = "FILE")]
    file: PathBuf,
    /// `json`: the syntax tree and diagnostics; `source`: the program printed back from the tree.
    #[arg(long, value_enum, default_value_t = Format::Json)]
    format: Format,
}

pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    let input = if args.file.as_os_str() == "-" {
        Input::Stdin
    } else {
        Input::File(args.file)
    };
    let program = crate::parse_owned(input.read()?);
    let mut out = BufWriter::new(super::output::stdout());
    let written = match args.format {
        Format::Json => serde_json::to_writer(&mut out, &program)
            .map_err(io::Error::from)
            .and_then(|()| writeln!(out)),
        Format::Source => program.write_to(&mut out),
    }
    .and_then(|()| out.flush());
    // A reader that stops early (`| head`) is quiet: `cli::main` recognises the broken pipe.
    written?;
    Ok(ExitCode::SUCCESS)
}
