//! `driftloop simulate-data DIR [--effect KIND] …`: a virtual machine for trying diagnosis — writes
//! characterisation runs, a production log with one undeclared effect and noise, and the truth beside them.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;

use super::Global;
use crate::data::Minutes;
use crate::diagnose::scenario::{Scenario, simulate};
use crate::model::effects::Kind;

#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  driftloop simulate-data sim --effect input_lag --seed 1")]
pub struct Args {
    /// Directory to write characterisation.csv, production.csv, truth.toml and scenario.json into.
    pub dir: PathBuf,
    /// Undeclared effect in the production log (none: a control without one).
    #[arg(long, value_parser = effect_names())]
    pub effect: Option<String>,
    /// Seed of the random draws (effect parameters, temperatures, speeds, noise).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Measurement noise (standard deviation, µm).
    #[arg(long, value_name = "UM", default_value_t = 0.3)]
    pub noise: f64,
    /// The effect's standard deviation over the log, in multiples of the noise.
    #[arg(long, default_value_t = 5.0)]
    pub size: f64,
    /// Production log length (`24h`, `1440min`; a bare number is minutes).
    #[arg(long, value_name = "TIME", default_value = "1440")]
    pub minutes: Minutes,
    /// Sampling step of the production log (`3min`, `30s`; a bare number is minutes).
    #[arg(long, value_name = "TIME", default_value = "3")]
    pub step: Minutes,
    /// Start of the holdout written to scenario.json (`18h`; a bare number is minutes).
    #[arg(long, value_name = "TIME", default_value = "1080")]
    pub holdout_from: Minutes,
    /// The injected effect's θ instead of a random draw: its time constant in minutes (input_lag,
    /// extra_mode, position_slope), its cooling ratio (cooling_asymmetry) or its time in minutes (step).
    #[arg(long)]
    pub theta: Option<f64>,
}

/// The kinds `diagnose` looks for, and `none`.
fn effect_names() -> clap::builder::PossibleValuesParser {
    let kinds = Kind::DIAGNOSED.iter().map(|k| k.name());
    clap::builder::PossibleValuesParser::new(kinds.chain(["none"]))
}

pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    let (minutes, step) = (args.minutes.0, args.step.0);
    anyhow::ensure!(
        args.noise >= 0.0 && step > 0.0 && minutes > step,
        "--noise must be ≥ 0, --step > 0 and --minutes longer than one step"
    );
    let largest = crate::model::file::LARGEST_UM;
    anyhow::ensure!(
        args.noise <= largest && (0.0..=largest).contains(&args.size),
        "--noise (µm) and --size (multiples of the noise) must be within 0…{largest}"
    );
    crate::data::check_rows(
        minutes / step,
        &format!("--minutes {minutes:?} at --step {step:?} min"),
    )
    .map_err(|e| anyhow::anyhow!("{e}: use a shorter log or a larger --step"))?;
    anyhow::ensure!(
        args.theta
            .is_none_or(|t| t > 0.0 && t <= crate::model::file::TAU_LONGEST_MIN),
        "--theta must be a positive number up to {}",
        crate::model::file::TAU_LONGEST_MIN
    );
    let mut sc = Scenario::new(args.seed, None);
    sc.effect = args.effect.filter(|e| e != "none");
    sc.noise_um = args.noise;
    sc.effect_size = args.size;
    sc.log_min = minutes;
    sc.step_min = step;
    sc.holdout_from_min = args.holdout_from.0;
    sc.theta = args.theta;
    let sim = simulate(&sc)?;
    std::fs::create_dir_all(&args.dir)
        .with_context(|| format!("cannot create {}", args.dir.display()))?;
    let write = |name: &str, bytes: Vec<u8>| {
        let path = args.dir.join(name);
        std::fs::write(&path, bytes).with_context(|| format!("cannot write {}", path.display()))
    };
    let mut csv = Vec::new();
    sim.characterisation.write_csv(&mut csv)?;
    write("characterisation.csv", csv)?;
    let mut csv = Vec::new();
    sim.production.write_csv(&mut csv)?;
    write("production.csv", csv)?;
    write("truth.toml", sim.truth.to_toml().into_bytes())?;
    write(
        "scenario.json",
        (serde_json::to_string_pretty(&sc)? + "\n").into_bytes(),
    )?;
    eprintln!(
        "wrote {}: characterisation.csv, production.csv (channel z_um), truth.toml, scenario.json",
        args.dir.display()
    );
    Ok(ExitCode::SUCCESS)
}
