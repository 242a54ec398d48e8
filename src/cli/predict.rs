//! `driftloop predict model.toml (--schedule … | --data DATA.csv)`: predicted drift vs time as CSV.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;

use super::Global;
use super::style;
use crate::data::{Dataset, Minutes, Require, SPINDLE};
use crate::diagnostic::Severity;
use crate::model::{DriftModel, Schedule, extrapolation_warning};

#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  driftloop predict model.toml --schedule 5000:1h,0:30min --step 5min\n  driftloop predict model.toml --data log.csv -o predicted.csv"
)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["schedule", "data"])))]
pub struct Args {
    /// Model file from `driftloop fit`.
    pub model: PathBuf,
    /// Spindle schedule from rest, RPM:DURATION segments, e.g. "3000:60,0:30,5000:2h" (a bare duration is
    /// minutes).
    #[arg(long, value_name = "RPM:TIME,…")]
    pub schedule: Option<Schedule>,
    /// Predict for the times and inputs of a measurement CSV (`-` reads stdin); output in its time unit.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Output step for --schedule (`30s`, `5min`; a bare number is minutes); segment boundaries are always
    /// included.
    #[arg(long, value_name = "TIME", default_value = "1min")]
    pub step: Minutes,
    /// Write the CSV here instead of stdout.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
}

pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    let inputs: Vec<&std::path::Path> = std::iter::once(args.model.as_path())
        .chain(args.data.as_deref())
        .collect();
    super::output::refuse_overwriting(&[("-o", args.output.as_deref())], &inputs)?;
    let model = DriftModel::read(&args.model)?;
    let step = args.step.0;
    let input = match (&args.schedule, &args.data) {
        (Some(schedule), _) => {
            anyhow::ensure!(step > 0.0, "--step must be a positive time");
            crate::data::check_rows(
                schedule.rows(step),
                &format!(
                    "--schedule of {:?} min at --step {:?} min",
                    schedule.minutes(),
                    step
                ),
            )
            .map_err(|e| anyhow::anyhow!("{e}: use a larger --step"))?;
            schedule.to_dataset(step)
        }
        (None, Some(path)) => super::log::read_data(path, Require::InputsOnly)?,
        (None, None) => anyhow::bail!("give --schedule or --data"),
    };
    warn_extrapolation(&model, &input);
    let predicted = model.predict(&input)?;
    let out = prediction_table(&model, &input, predicted);
    let mut bytes = Vec::new();
    out.write_csv(&mut bytes)?;
    match &args.output {
        Some(path) if path.as_os_str() != "-" => std::fs::write(path, bytes)
            .with_context(|| format!("cannot write {}", path.display()))?,
        // A reader that stops early (`| head`) is quiet: `cli::main` recognises the broken pipe.
        _ => super::output::stdout().write_all(&bytes)?,
    }
    Ok(ExitCode::SUCCESS)
}

/// Time (and runs) of the input, its declared inputs, `predicted_um`, and — when the input measured the
/// model's channel — that channel and `residual_um` (measured − predicted; NaN, written as an empty cell,
/// where the row has no reading).
fn prediction_table(model: &DriftModel, input: &Dataset, predicted: Vec<f64>) -> Dataset {
    let mut out = Dataset::new(
        input.source.clone(),
        input.time_unit,
        input.time_min.clone(),
    );
    out.run_starts = input.run_starts.clone();
    out.run_labels = input.run_labels.clone();
    for name in model.declared_inputs() {
        if let Some(v) = input.values(&name) {
            out.push_column(&name, v.to_vec());
        }
    }
    if let Some(measured) = input.values(&model.channel) {
        let residual = measured
            .iter()
            .zip(&predicted)
            .map(|(m, p)| m - p)
            .collect();
        out.push_column(&model.channel, measured.to_vec());
        out.push_column("predicted_um", predicted);
        out.push_column("residual_um", residual);
    } else {
        out.push_column("predicted_um", predicted);
    }
    out
}

/// Says so on stderr when the input runs the spindle faster than the model was characterised, naming the
/// fastest speed and the law the gains are extrapolated by.
fn warn_extrapolation(model: &DriftModel, input: &Dataset) {
    let fastest = input
        .values(SPINDLE)
        .map_or(0.0, |v| v.iter().fold(0.0f64, |a, s| a.max(s.abs())));
    if let Some(w) = extrapolation_warning(model, fastest) {
        anstream::eprintln!("{} {w}", style::label(Severity::Warning));
    }
}
