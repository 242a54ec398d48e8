//! `driftloop strip PATH… [-o OUT | --in-place | --check]`: removes the lines `transform` inserted (those
//! ending in the `;DL` marker) and gives the original program back, byte for byte.

use std::io::{self, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::bail;

use super::Global;
use super::transform::write_atomic;
use crate::strip::strip;
use crate::walk::{self, Input};

#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  driftloop strip PART_DL.MPF -o PART.MPF\n  driftloop strip --check programs/"
)]
pub struct Args {
    /// Transformed programs or directories (walked recursively for .mpf .spf .arc .nc .def); `-` reads stdin.
    #[arg(required = true, value_name = "PATH")]
    paths: Vec<PathBuf>,
    /// Output file (`-`: stdout) for a single input. Without it, and without --in-place or --check, a single
    /// input is written to stdout.
    #[arg(short = 'o', long = "output", value_name = "OUT", conflicts_with_all = ["in_place", "check"])]
    output: Option<PathBuf>,
    /// Replace each transformed input file (atomically: temp file in the same directory, then rename); files
    /// without driftloop's header are not touched.
    #[arg(long, conflicts_with = "check")]
    in_place: bool,
    /// Write nothing; exit 1 if any input carries driftloop's blocks.
    #[arg(long)]
    check: bool,
}

/// Exit 0 when done (or with --check when no input carries driftloop's blocks), 1 with --check when one
/// does, 2 on errors.
pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    let inputs = walk::expand(&args.paths);
    let several = inputs.len() > 1;
    if several && !args.in_place && !args.check {
        bail!(
            "{} programs given: strip several with --in-place or --check (-o and stdout take one)",
            inputs.len()
        );
    }
    if args.in_place && inputs.contains(&Input::Stdin) {
        bail!("--in-place cannot replace stdin");
    }
    let paths: Vec<&std::path::Path> = args.paths.iter().map(PathBuf::as_path).collect();
    super::output::refuse_overwriting(&[("-o", args.output.as_deref())], &paths)?;
    let mut stderr = io::stderr().lock();
    let mut transformed = 0;
    let mut unreadable = 0;
    for input in &inputs {
        // One input that cannot be read is reported in its place; the others are still stripped.
        let src = match input.read() {
            Ok(src) => src,
            Err(e) => {
                writeln!(stderr, "error: {e}")?;
                unreadable += 1;
                continue;
            }
        };
        let stripped = strip(&src);
        let name = input.to_string();
        match stripped.header {
            Some(line) => {
                transformed += 1;
                writeln!(
                    stderr,
                    "{name}: {} inserted line(s) {} (driftloop header at line {})",
                    stripped.removed.len(),
                    if args.check {
                        "would be removed"
                    } else {
                        "removed"
                    },
                    line + 1
                )?;
            }
            None if stripped.marked_without_header > 0 => writeln!(
                stderr,
                "{name}: no driftloop header, nothing removed ({} line(s) end in ;DL but were not \
                 written by a transform that left its header)",
                stripped.marked_without_header
            )?,
            None => writeln!(stderr, "{name}: no driftloop header, nothing to strip")?,
        }
        if args.check {
            continue;
        }
        let target = if args.in_place {
            if stripped.header.is_none() {
                continue;
            }
            match input {
                Input::File(path) | Input::Unreadable { path, .. } => Some(path.clone()),
                Input::Stdin => None,
            }
        } else {
            args.output.clone().filter(|o| o.as_os_str() != "-")
        };
        match target {
            Some(path) => write_atomic(&path, |f| f.write_all(&stripped.bytes))?,
            None => {
                let mut out = super::output::stdout();
                out.write_all(&stripped.bytes)
                    .and_then(|()| out.flush())
                    .map_err(super::output::program_not_written)?;
            }
        }
    }
    Ok(if unreadable > 0 {
        ExitCode::from(2)
    } else if args.check && transformed > 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}
