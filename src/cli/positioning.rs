//! `driftloop positioning`: positioning accuracy statistics and compensation tables from repeated
//! bidirectional approaches (DSTU/GOST 27843-88, VDI 3441, ISO 230-2).

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};

use super::style;
use super::{Format, Global};
use crate::diagnostic::Severity;
use crate::positioning::{
    self, Grid, GridChoice, MIN_APPROACHES, Standard, correction_csv, html_report, read_samples,
    sinumerik_text,
};

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum TableFormat {
    Csv,
    Sinumerik,
}

#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  driftloop positioning fixtures/positioning/paper_row.csv --standard iso230-2 --table comp.csv"
)]
pub struct Args {
    /// Measurements CSV (axis,target_mm,direction,run,deviation_um); `-` reads stdin.
    pub data: PathBuf,
    /// Whose definitions and coverage factor to use (k = 3 for DSTU and VDI, 2 for ISO).
    #[arg(long, value_enum, default_value_t = Standard::Dstu27843)]
    pub standard: Standard,
    /// `human`: tables; `json`: one JSON object with the same numbers.
    #[arg(long, value_enum, default_value_t = Format::Human)]
    pub format: Format,
    /// Write a self-contained HTML report here.
    #[arg(long, value_name = "FILE.html")]
    pub report: Option<PathBuf>,
    /// Write the correction table here (`-` = stdout, replacing the normal output).
    #[arg(long, value_name = "OUT")]
    pub table: Option<PathBuf>,
    /// Table format; default: csv for a `.csv` name or stdout, otherwise Sinumerik text.
    #[arg(long, value_enum)]
    pub table_format: Option<TableFormat>,
    /// Compensation grid in mm, `START:STEP:END`, for every axis or `AXIS=START:STEP:END` for one; repeatable.
    /// Default: from the first target past the last with a 1-2-5 step no coarser than the closest targets.
    #[arg(long, value_name = "[AXIS=]START:STEP:END")]
    pub grid: Vec<String>,
}

pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    super::output::refuse_overwriting(
        &[
            ("--report", args.report.as_deref()),
            ("--table", args.table.as_deref()),
        ],
        &[&args.data],
    )?;
    let grids = args
        .grid
        .iter()
        .map(|g| parse_grid_choice(g))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let from_stdin = args.data == Path::new("-");
    let source = if from_stdin {
        "<stdin>".to_string()
    } else {
        args.data.display().to_string()
    };
    let bytes = if from_stdin {
        let mut text = Vec::new();
        std::io::stdin()
            .read_to_end(&mut text)
            .context("reading stdin")?;
        text
    } else {
        std::fs::read(&args.data).with_context(|| format!("cannot read {source}"))?
    };
    if let Some(why) = crate::text::not_text(&bytes, crate::text::CSV) {
        bail!("{source}: {why}");
    }
    let samples = read_samples(bytes.as_slice(), &source, MIN_APPROACHES)?;
    for choice in &grids {
        if let Some(axis) = &choice.axis
            && !samples.iter().any(|s| &s.axis == axis)
        {
            bail!("--grid names axis {axis}, which is not in {source}");
        }
    }
    let analysis = positioning::analyse(&source, &samples, args.standard, &grids);
    for axis in &analysis.axes {
        let grid = axis.correction.grid;
        let (first, last) = (
            axis.stats.targets[0].target_mm,
            axis.stats.targets[axis.stats.targets.len() - 1].target_mm,
        );
        if grid.start_mm > first || grid.end_mm < last {
            anstream::eprintln!(
                "{} axis {}: grid {grid} mm does not cover the targets {first}…{last} mm; the control holds the end values outside it",
                style::label(Severity::Warning),
                axis.stats.axis
            );
        }
    }

    if let Some(path) = &args.report {
        std::fs::write(path, html_report(&analysis))
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    let mut table_on_stdout = false;
    if let Some(path) = &args.table {
        let to_stdout = path == Path::new("-");
        let is_csv_name = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
        let format = args.table_format.unwrap_or(if to_stdout || is_csv_name {
            TableFormat::Csv
        } else {
            TableFormat::Sinumerik
        });
        let text = match format {
            TableFormat::Csv => correction_csv(&analysis),
            TableFormat::Sinumerik => sinumerik_text(&analysis),
        };
        if to_stdout {
            super::output::print(&text)?;
            table_on_stdout = true;
        } else {
            std::fs::write(path, text)
                .with_context(|| format!("cannot write {}", path.display()))?;
        }
    }
    if !table_on_stdout {
        let text = match args.format {
            Format::Human => positioning::human(&analysis),
            Format::Json => format!(
                "{}\n",
                serde_json::to_string_pretty(&positioning::json(&analysis))?
            ),
        };
        super::output::print(&text)?;
    }
    Ok(ExitCode::SUCCESS)
}

fn parse_grid_choice(text: &str) -> anyhow::Result<GridChoice> {
    let (axis, grid) = match text.split_once('=') {
        Some((axis, grid)) if !axis.trim().is_empty() => (Some(axis.trim().to_string()), grid),
        Some(_) => bail!("--grid {text}: the axis name before `=` is empty"),
        None => (None, text),
    };
    let grid: Grid = grid
        .parse()
        .map_err(|e| anyhow::anyhow!("--grid {text}: {e}"))?;
    Ok(GridChoice { axis, grid })
}
