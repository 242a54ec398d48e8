//! `driftloop demo`: the paper's stepped-surface experiment replayed on a virtual machine (fit → transform →
//! run → diagnose → transform → run), the before/after table and, with `--plot`, the before/after chart.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;

use super::Global;
use crate::demo::{Outcome, Settings, TARGET_UM, run_demo};
use crate::report::{Chart, Mark, Series};

#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  driftloop demo\n  driftloop demo --out demo-files --plot demo.svg"
)]
pub struct Args {
    /// Write every artefact (models, transformed programs, run reports, probe log, diagnose report) here;
    /// without it they go to a temporary directory that is removed.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Seed of the generated data and the probe noise.
    #[arg(long, default_value_t = Settings::default().seed)]
    pub seed: u64,
    /// Probe repeatability σ in µm.
    #[arg(long, value_name = "UM", default_value_t = Settings::default().probe_noise_um)]
    pub probe_noise: f64,
    /// Drawing tolerance Δ of the part in µm (the transform's default profile has 20).
    #[arg(long, value_name = "UM")]
    pub tolerance: Option<f64>,
    /// Also write the before/after chart (machined error of each pass, µm over min) as an SVG file here.
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
}

/// The stages of the table a reader compares, as they appear in it.
const PLOTTED: [&str; 3] = [
    "uncompensated",
    "compensated (fitted model)",
    "compensated after diagnose",
];

/// Each pass's mean machined error at the middle of its time, one line per stage, and the target.
fn before_after(outcome: &Outcome) -> Chart {
    let mut chart = Chart::new(
        "Stepped surface on a drifting machine: error of each pass",
        "program time in min",
        "machined error (cut − nominal depth) in µm",
    )
    .size(720.0, 400.0);
    let mut span = (f64::INFINITY, f64::NEG_INFINITY);
    for stage in outcome.stages.iter().filter(|s| PLOTTED.contains(&s.name)) {
        let points: Vec<(f64, f64)> = stage
            .passes
            .iter()
            .map(|p| (0.5 * (p.start_min + p.end_min), p.error_um))
            .collect();
        for &(t, _) in &points {
            span = (span.0.min(t), span.1.max(t));
        }
        let name = format!("{} (max {:.1} µm)", stage.name, stage.max_error_um);
        chart = chart.series(Series::new(name, Mark::LineAndPoints, points));
    }
    if span.0 <= span.1 {
        let target = vec![(span.0, TARGET_UM), (span.1, TARGET_UM)];
        chart = chart.series(
            Series::new(
                format!("target: error ≤ {TARGET_UM} µm"),
                Mark::Dashed,
                target,
            )
            .with_color("#555555"),
        );
    }
    chart
}

pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    let settings = Settings {
        seed: args.seed,
        probe_noise_um: args.probe_noise,
        tolerance_um: args.tolerance,
        ..Settings::default()
    };
    let dir = match &args.out {
        Some(dir) => dir.clone(),
        None => std::env::temp_dir().join(format!("driftloop-demo-{}", std::process::id())),
    };
    let outcome = run_demo(&settings, &dir);
    if args.out.is_none() {
        // Best effort: a leftover temp folder is harmless, the demo's result is not.
        let _ = std::fs::remove_dir_all(&dir);
    }
    let outcome = outcome?;
    super::output::print(&outcome.table())?;
    if let Some(path) = &args.plot {
        std::fs::write(path, before_after(&outcome).to_svg())
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    if let Some(out) = &args.out {
        super::output::print(&format!("artefacts written to {}\n", out.display()))?;
    }
    // Like a check that finds something: the demo ran, but its target was not met.
    Ok(if outcome.target_met() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
