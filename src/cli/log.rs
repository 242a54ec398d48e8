//! `driftloop log merge FILE…`: characterisation CSVs and DRIFTLOG files as one measurement series.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;

use super::Global;
use super::style;
use crate::data::merge::{Merged, merge, parse_rename};
use crate::data::{Require, read_path};
use crate::diagnostic::Severity;

#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub command: LogCommand,
}

#[derive(Debug, clap::Subcommand)]
pub enum LogCommand {
    /// Join characterisation CSVs and DRIFTLOG files into one series: each file's runs in order, each from
    /// rest at its own time zero; columns matched by name after --rename.
    Merge(MergeArgs),
}

#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  driftloop log merge fixtures/data/characterisation.csv job1/DRIFTLOG job2/DRIFTLOG -o merged.csv"
)]
pub struct MergeArgs {
    /// Measurement files in the order they were recorded (CSV or DRIFTLOG; `-` reads stdin once).
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Map a column to the merged name, e.g. drift_z_um=ch3_um (repeatable).
    #[arg(long, value_name = "OLD=NEW", value_parser = parse_rename)]
    pub rename: Vec<(String, String)>,
    /// Write the merged CSV here instead of stdout.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
}

/// Reads a measurement file; what the reader filled in goes to stderr as notes.
pub(crate) fn read_data(path: &Path, require: Require) -> anyhow::Result<crate::data::Dataset> {
    let data = read_path(path, require)?;
    for n in &data.notes {
        anstream::eprintln!("{} {n}", style::label(Severity::Note));
    }
    Ok(data)
}

/// An error of the work on `ds` (a fit, a diagnosis) with the file it came from, unless it names it already:
/// the message of a fit that cannot start speaks of rows and samples, which the user finds in that file.
pub(crate) fn of_data(ds: &crate::data::Dataset, e: impl std::fmt::Display) -> anyhow::Error {
    let message = e.to_string();
    if message.starts_with(&ds.source) {
        anyhow::anyhow!(message)
    } else {
        anyhow::anyhow!("{}: {message}", ds.source)
    }
}

/// Reads and merges `files`; the notes go to stderr.
pub(crate) fn read_merged(
    files: &[PathBuf],
    renames: &[(String, String)],
) -> anyhow::Result<crate::data::Dataset> {
    let parts = files
        .iter()
        .map(|f| read_data(f, Require::InputsOnly))
        .collect::<anyhow::Result<Vec<_>>>()?;
    if parts.len() == 1 && renames.is_empty() {
        return Ok(parts.into_iter().next().expect("one part"));
    }
    let Merged { data, notes } = merge(parts, renames)?;
    for n in notes {
        anstream::eprintln!("{} {n}", style::label(Severity::Note));
    }
    Ok(data)
}

pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    match args.command {
        LogCommand::Merge(m) => {
            let inputs: Vec<&Path> = m.files.iter().map(PathBuf::as_path).collect();
            super::output::refuse_overwriting(&[("-o", m.output.as_deref())], &inputs)?;
            let data = read_merged(&m.files, &m.rename)?;
            let mut bytes = Vec::new();
            data.write_csv(&mut bytes)?;
            match &m.output {
                Some(path) if path.as_os_str() != "-" => std::fs::write(path, bytes)
                    .with_context(|| format!("cannot write {}", path.display()))?,
                _ => {
                    use std::io::Write;
                    super::output::stdout().write_all(&bytes)?;
                }
            }
            Ok(ExitCode::SUCCESS)
        }
    }
}
