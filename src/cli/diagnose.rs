//! `driftloop diagnose model.toml DATA.csv --channel NAME [--holdout-from T]`: traces the residual of a
//! model on new data to effects the model lacks, adds them, and reports the error before and after.
//! Exit 0 when the model needed nothing beyond recalibration, 1 when effects were added.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;

use super::{Format, Global};
use crate::data::{Require, read_path};
use crate::diagnose::{Options, diagnose};
use crate::model::DriftModel;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Model file from `driftloop fit` (or a refined one from an earlier diagnosis).
    pub model: PathBuf,
    /// Measurement CSV with the model's inputs and channel; `-` reads stdin.
    pub data: PathBuf,
    /// Displacement channel the model is of, e.g. ch3_um.
    #[arg(long)]
    pub channel: String,
    /// Rows from this time on (minutes of the data's time axis) are only scored, never fitted or selected
    /// on. Without it every number is in-sample.
    #[arg(long, value_name = "MINUTES")]
    pub holdout_from: Option<f64>,
    /// At most this many effects are added.
    #[arg(long, default_value_t = 3)]
    pub max_effects: usize,
    #[arg(long, value_enum, default_value_t = Format::Human)]
    pub format: Format,
    /// Write a self-contained HTML report (inline SVG charts) here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the refined model (same schema, with the effects) here; `predict` and `diagnose` accept it.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
}

pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    let model = DriftModel::read(&args.model)?;
    let ds = read_path(&args.data, Require::Displacement)?;
    if let Some(h) = args.holdout_from {
        anyhow::ensure!(h.is_finite(), "--holdout-from must be a number of minutes");
    }
    let mut opts = Options::new(&args.channel);
    opts.holdout_from_min = args.holdout_from;
    opts.max_effects = args.max_effects;
    let d = diagnose(&model, &ds, &opts)?;
    match args.format {
        Format::Human => print!("{}", d.human()),
        Format::Json => println!("{}", serde_json::to_string_pretty(&d.json())?),
    }
    if let Some(path) = &args.output {
        std::fs::write(path, d.refined.to_toml())
            .with_context(|| format!("cannot write the refined model {}", path.display()))?;
    }
    if let Some(path) = &args.report {
        std::fs::write(path, d.html())
            .with_context(|| format!("cannot write the report {}", path.display()))?;
    }
    Ok(if d.effects_added.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
