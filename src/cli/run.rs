//! `driftloop run`: dry run of an NC program on a virtual machine.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;

use super::{Format, Global};
use crate::vm::{self, Config, End, MachineSpec};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// The main program (`-` reads stdin; subprograms are then looked up in the current folder).
    pub program: PathBuf,
    /// Machine file (TOML): timing, probe, initial work offsets, drift (see README); default: no drift.
    #[arg(long)]
    pub machine: Option<PathBuf>,
    /// Standard deviation of the probe noise in µm (overrides the machine file).
    #[arg(long, value_name = "UM")]
    pub probe_noise: Option<f64>,
    /// Seed of the probe noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Further folder searched for subprograms (after the program's own); repeatable.
    #[arg(long = "subprograms", value_name = "DIR")]
    pub subprogram_dirs: Vec<PathBuf>,
    /// Executed blocks beyond the program's own block count after which the run is stopped as an endless loop.
    #[arg(long, default_value_t = 1_000_000)]
    pub max_blocks: u64,
    #[arg(long, value_enum, default_value_t = Format::Human)]
    pub format: Format,
    /// Write the per-block trace (positions, time, spindle speed) as CSV to this file (`-`: stdout).
    #[arg(long, value_name = "FILE")]
    pub trace: Option<PathBuf>,
}

/// Exit 0 when the program ran to its end, 1 when an alarm stopped it, 2 for errors (unsupported construct,
/// endless loop, unreadable files).
pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    let mut cfg = Config {
        max_blocks: args.max_blocks,
        trace: args.trace.is_some(),
        ..Config::default()
    };
    let mut spec = MachineSpec::default();
    if let Some(path) = &args.machine {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let dir = path.parent().unwrap_or(Path::new("."));
        (cfg, spec) = vm::parse_machine_file(&text, dir, cfg)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    }
    cfg.subprogram_dirs = args.subprogram_dirs;
    if let Some(noise) = args.probe_noise {
        anyhow::ensure!(
            noise >= 0.0 && noise.is_finite(),
            "--probe-noise must be ≥ 0"
        );
        spec.noise_um = noise;
    }
    let mut machine = spec.build(args.seed);
    let run = if args.program == Path::new("-") {
        let mut src = Vec::new();
        std::io::stdin()
            .read_to_end(&mut src)
            .context("cannot read stdin")?;
        vm::run_source("<stdin>", &src, Some(Path::new(".")), &cfg, &mut machine)?
    } else {
        vm::run_file(&args.program, &cfg, &mut machine)?
    };
    match args.format {
        Format::Human => print!("{}", run.human()),
        Format::Json => println!("{}", serde_json::to_string_pretty(&run)?),
    }
    if let Some(path) = &args.trace {
        let csv = run.trace_csv();
        if path == Path::new("-") {
            print!("{csv}");
        } else {
            std::fs::write(path, csv)
                .with_context(|| format!("cannot write {}", path.display()))?;
        }
    }
    Ok(match run.end {
        End::Alarm { .. } => ExitCode::from(1),
        _ => ExitCode::SUCCESS,
    })
}
