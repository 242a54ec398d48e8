//! `driftloop sensors DATA.csv --channel NAME`: chooses the temperature sensors that explain a channel
//! (correlation with the error, clusters of redundant sensors) and regresses the error on them.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;

use super::{Format, Global};
use crate::data::{Minutes, Require};
use crate::sensors::position::analyse_position;
use crate::sensors::{Options, analyse};

#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  driftloop sensors data.csv --channel ch3_um --holdout-from 16h -o sensors.toml --report sensors.html"
)]
pub struct Args {
    /// Measurement CSV with a displacement channel and `*_c` temperature columns; `-` reads stdin.
    pub data: PathBuf,
    /// Displacement channel to explain, e.g. ch3_um (default: the data's only `*_um` column).
    #[arg(long)]
    pub channel: Option<String>,
    /// Axis position column (`*_mm`): separate the error into E_G(p) + S(θ)·p + I(θ) and explain the slope S
    /// and intercept I per time step (rows sharing a time).
    #[arg(long, value_name = "P")]
    pub position_column: Option<String>,
    /// Sensors with |r| at least this form one cluster; one sensor per cluster is kept.
    #[arg(long, default_value_t = 0.9)]
    pub threshold: f64,
    /// A cluster whose best sensor has |r| with the error below this is dropped as irrelevant.
    #[arg(long, default_value_t = 0.5)]
    pub min_correlation: f64,
    /// Without a `run` column: validate on the rows from this time on (`16h`, `960min`, `57600s`; a bare
    /// number is minutes; default: the last third of the time span).
    #[arg(long, value_name = "TIME")]
    pub holdout_from: Option<Minutes>,
    /// `human`: text; `json`: the analysis as JSON.
    #[arg(long, value_enum, default_value_t = Format::Human)]
    pub format: Format,
    /// Write the regression as a model file that `predict`, `diagnose` and `transform` read (`-` = stdout,
    /// the report then goes to stderr). Terms: `static_input` per sensor; with --position-column also
    /// `input_slope` per sensor and `geometric`.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Write a self-contained HTML report here (inline SVG charts: measured and predicted, residual, the
    /// kept sensors over time; the tables).
    #[arg(long, value_name = "FILE.html")]
    pub report: Option<PathBuf>,
}

pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    super::output::refuse_overwriting(
        &[
            ("-o", args.output.as_deref()),
            ("--report", args.report.as_deref()),
        ],
        &[&args.data],
    )?;
    let ds = super::log::read_data(&args.data, Require::Displacement)?;
    let channel = super::fit::only_channel(&ds, args.channel.as_deref())?;
    let mut opts = Options::new(&channel);
    opts.threshold = args.threshold;
    opts.min_correlation = args.min_correlation;
    opts.holdout_from_min = args.holdout_from.map(|m| m.0);
    let (report, model, html) = match &args.position_column {
        Some(p) => {
            let analysis = analyse_position(&ds, &p.to_ascii_lowercase(), &opts)
                .map_err(|e| super::log::of_data(&ds, e))?;
            let report = match args.format {
                Format::Human => analysis.human(),
                Format::Json => analysis.json(),
            };
            let html = args.report.as_ref().map(|_| analysis.html(&ds));
            (report, analysis.to_model(), html)
        }
        None => {
            let analysis = analyse(&ds, &opts).map_err(|e| super::log::of_data(&ds, e))?;
            let report = match args.format {
                Format::Human => analysis.human(),
                Format::Json => analysis.json(),
            };
            let html = args.report.as_ref().map(|_| analysis.html(&ds));
            (report, analysis.to_model(), html)
        }
    };
    if let (Some(path), Some(html)) = (&args.report, html) {
        std::fs::write(path, html).with_context(|| format!("cannot write {}", path.display()))?;
    }
    super::write_model(args.output.as_deref(), &model, &report)?;
    Ok(ExitCode::SUCCESS)
}
