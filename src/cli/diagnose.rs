//! `driftloop diagnose model.toml DATA.csv --channel NAME [--holdout-from T]`: traces the residual of a
//! model on new data to effects the model lacks, adds them, and reports the error before and after.
//! Exit 0 when the model needed nothing beyond recalibration, 1 when effects were added.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;

use super::{Format, Global};
use crate::data::Minutes;
use crate::data::merge::parse_rename;
use crate::diagnose::{Holdout, Options, diagnose};
use crate::model::DriftModel;

/// `--holdout-from`: a time, or `none` for no holdout.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HoldoutArg {
    None,
    From(Minutes),
}

impl std::str::FromStr for HoldoutArg {
    type Err = String;
    fn from_str(s: &str) -> Result<HoldoutArg, String> {
        if s.eq_ignore_ascii_case("none") {
            Ok(HoldoutArg::None)
        } else {
            s.parse().map(HoldoutArg::From)
        }
    }
}

#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  driftloop diagnose model.toml merged.csv -o refined.toml --report diagnose.html\n  driftloop diagnose model.toml characterisation.csv job1/DRIFTLOG --holdout-from none"
)]
pub struct Args {
    /// Model file from `driftloop fit` (or a refined one from an earlier diagnosis).
    pub model: PathBuf,
    /// Measurement files with the model's inputs and channel: a CSV, or characterisation CSVs and DRIFTLOG
    /// files in the order they were recorded (merged as `driftloop log merge` does); `-` reads stdin.
    #[arg(required = true)]
    pub data: Vec<PathBuf>,
    /// Displacement channel to diagnose (default: the model's channel).
    #[arg(long)]
    pub channel: Option<String>,
    /// Rows from this time of the data's time axis on (`16h`, `960min`, `57600s`; a bare number is
    /// minutes) are only scored, never fitted or selected on; `none`: no holdout, every number in-sample.
    /// Default: the last third of the data's time.
    #[arg(long, value_name = "TIME|none")]
    pub holdout_from: Option<HoldoutArg>,
    /// Also report the error when a probe re-zeroes the correction this often (`60min`, `2h`). Default:
    /// the `--profile`'s `limits.max_interval_min`, else 60 min.
    #[arg(long, value_name = "TIME")]
    pub probe_every: Option<Minutes>,
    /// The machine profile the programs run with (a file or a builtin's name, `driftloop profiles`): its
    /// `limits.max_interval_min` is the probing interval the report assumes unless `--probe-every` gives one.
    #[arg(long, value_name = "PROFILE")]
    pub profile: Option<PathBuf>,
    /// At most this many effects are added.
    #[arg(long, default_value_t = 3)]
    pub max_effects: usize,
    /// Map a column of a data file to the merged name, e.g. drift_z_um=ch3_um (repeatable).
    #[arg(long, value_name = "OLD=NEW", value_parser = parse_rename)]
    pub rename: Vec<(String, String)>,
    /// `human`: text; `json`: one JSON object with every number of the report.
    #[arg(long, value_enum, default_value_t = Format::Human)]
    pub format: Format,
    /// Write a self-contained HTML report (inline SVG charts) here.
    #[arg(long, value_name = "FILE.html")]
    pub report: Option<PathBuf>,
    /// Write the refined model (same schema, with the effects) here; `predict` and `diagnose` accept it.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
}

pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    let inputs: Vec<&std::path::Path> = std::iter::once(args.model.as_path())
        .chain(args.data.iter().map(PathBuf::as_path))
        .collect();
    super::output::refuse_overwriting(
        &[
            ("-o", args.output.as_deref()),
            ("--report", args.report.as_deref()),
        ],
        &inputs,
    )?;
    let model = DriftModel::read(&args.model)?;
    let ds = super::log::read_merged(&args.data, &args.rename)?;
    let profile_interval = match &args.profile {
        Some(path) => {
            crate::omm::Profile::read_or_builtin(path)?
                .limits
                .max_interval_min
        }
        None => None,
    };
    let probe_every = args
        .probe_every
        .map_or(profile_interval.unwrap_or(60.0), |m| m.0);
    anyhow::ensure!(probe_every > 0.0, "--probe-every must be a positive time");
    let channel = args
        .channel
        .clone()
        .unwrap_or_else(|| model.channel.clone());
    let mut opts = Options::new(&channel);
    opts.holdout = match args.holdout_from {
        None => Holdout::LastFraction(1.0 / 3.0),
        Some(HoldoutArg::None) => Holdout::None,
        Some(HoldoutArg::From(m)) => Holdout::From(m.0),
    };
    opts.max_effects = args.max_effects;
    opts.probe_every_min = Some(probe_every);
    let d = diagnose(&model, &ds, &opts).map_err(|e| super::log::of_data(&ds, e))?;
    match args.format {
        Format::Human => super::output::print(&d.human())?,
        Format::Json => {
            super::output::print(&format!("{}\n", serde_json::to_string_pretty(&d.json())?))?
        }
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
