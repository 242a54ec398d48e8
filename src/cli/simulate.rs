//! `driftloop simulate-data DIR [--effect KIND] …`: a virtual machine for trying diagnosis — writes
//! characterisation runs, a production log with one undeclared effect and noise, and the truth beside them.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;

use super::Global;
use crate::diagnose::scenario::{Scenario, simulate};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Directory to write characterisation.csv, production.csv, truth.toml and scenario.json into.
    pub dir: PathBuf,
    /// Undeclared effect in the production log: input_lag, extra_mode, cooling_asymmetry,
    /// position_slope, time_trend, periodic, step; none for a control.
    #[arg(long)]
    pub effect: Option<String>,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Measurement noise (standard deviation, µm).
    #[arg(long, default_value_t = 0.3)]
    pub noise: f64,
    /// The effect's standard deviation over the log, in multiples of the noise.
    #[arg(long, default_value_t = 5.0)]
    pub size: f64,
    /// Production log length and sampling step, minutes.
    #[arg(long, default_value_t = 1440.0)]
    pub minutes: f64,
    #[arg(long, default_value_t = 3.0)]
    pub step: f64,
    /// Start of the holdout written to scenario.json, minutes.
    #[arg(long, default_value_t = 1080.0)]
    pub holdout_from: f64,
}

pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(
        args.noise >= 0.0 && args.step > 0.0 && args.minutes > args.step,
        "--noise must be ≥ 0, --step > 0 and --minutes longer than one step"
    );
    let mut sc = Scenario::new(args.seed, None);
    sc.effect = args.effect.filter(|e| e != "none");
    sc.noise_um = args.noise;
    sc.effect_size = args.size;
    sc.log_min = args.minutes;
    sc.step_min = args.step;
    sc.holdout_from_min = args.holdout_from;
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
