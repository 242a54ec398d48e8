//! `driftloop run`: dry run of an NC program on a virtual machine; with `--audit`, the transformed program
//! run side by side with its original and checked for what the inserted blocks break.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;

use super::{Format, Global};
use crate::data::Minutes;
use crate::model::DriftModel;
use crate::omm::Profile;
use crate::vm::audit::AuditSettings;
use crate::vm::{self, Config, End, MachineSpec};

#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  driftloop run PART_DL.MPF --machine vm.toml\n  driftloop run --audit PART_DL.MPF --model model.toml --profile machine.toml\n  driftloop run PART_DL.MPF --machine vm.toml --jobs 3 --pause 30min"
)]
pub struct Args {
    /// The main program (`-` reads stdin; subprograms are then looked up in the current folder).
    pub program: PathBuf,
    /// Machine file (TOML): timing, probe, initial work offsets, drift (docs/commands/run.md); default: a
    /// machine that does not drift.
    #[arg(long, value_name = "MACHINE.toml")]
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
    /// `human`: the report as text; `json`: the run as one JSON object (passes, measurements, corrections, alarms, files).
    #[arg(long, value_enum, default_value_t = Format::Human)]
    pub format: Format,
    /// Write the per-block trace (positions, time, spindle speed) as CSV to this file (`-`: stdout).
    #[arg(long, value_name = "FILE", conflicts_with = "audit")]
    pub trace: Option<PathBuf>,
    /// Write the files the program writes with WRITE (e.g. the DRIFTLOG of a transformed program) into this
    /// folder, replacing files of the same name: one folder per job (the virtual machine's clock starts at 0
    /// in every run, so two jobs in one file would share a run label).
    #[arg(long, value_name = "DIR", conflicts_with = "audit")]
    pub write_files: Option<PathBuf>,
    /// Safety audit: PROGRAM is a transformed program; run it beside its original and report where the
    /// inserted blocks leave the control in another state than the original would be in (exit 1).
    #[arg(long)]
    pub audit: bool,
    /// The original program (default: PROGRAM without the lines ending in `;DL`).
    #[arg(long, value_name = "ORIGINAL", requires = "audit")]
    pub original: Option<PathBuf>,
    /// The machine profile the program was transformed with (clearance, probe tool and point, corrected
    /// offset): a file or a builtin's name (`driftloop profiles`); the shipped default profile when absent.
    #[arg(long, value_name = "MACHINE.toml|NAME", requires = "audit")]
    pub profile: Option<PathBuf>,
    /// The drift model the program was transformed with: the machine then drifts as it predicts, so the
    /// probe values agree with the program's predictions (without it the machine does not drift, and a
    /// program whose model predicts more than the tolerance stops as scrap at its first measurement).
    #[arg(long, value_name = "MODEL.toml", requires = "audit")]
    pub model: Option<PathBuf>,
    /// Run the program this many times in a row on the same machine: R-parameters (retentive on the
    /// control) and the machine's warmth carry from one job to the next, the clock runs on.
    #[arg(long, default_value_t = 1, value_name = "N", conflicts_with = "audit")]
    pub jobs: u32,
    /// Time between the end of one job and the start of the next (spindle stopped), with `--jobs`: `90s`,
    /// `30min`, `1h`; a bare number is minutes.
    #[arg(long, default_value = "0min", value_name = "TIME", requires = "jobs")]
    pub pause: Minutes,
    /// A cutting move of the original this close to the probe point (mm, across the measured axis) touches it.
    #[arg(long, value_name = "MM", default_value_t = vm::audit::DEFAULT_PROBE_MARGIN_MM, requires = "audit")]
    pub probe_margin: f64,
}

/// The machine file at `path` (docs/commands/run.md) over `base`: the configuration and the machine.
pub(super) fn read_machine_file(
    path: &Path,
    base: Config,
) -> anyhow::Result<(Config, MachineSpec)> {
    let text = crate::text::read_utf8(path, crate::text::TOML)
        .with_context(|| format!("cannot read {}", path.display()))?;
    let dir = path.parent().unwrap_or(Path::new("."));
    vm::parse_machine_file(&text, dir, base).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}

/// Exit 0 when the program ran to its end, 1 when an alarm stopped it, 2 for errors (unsupported construct,
/// endless loop, unreadable files). With `--audit`: 0 clean, 1 findings, 2 errors.
pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    let inputs: Vec<&Path> = [Some(&args.program), args.machine.as_ref()]
        .into_iter()
        .flatten()
        .map(PathBuf::as_path)
        .collect();
    super::output::refuse_overwriting(&[("--trace", args.trace.as_deref())], &inputs)?;
    let mut cfg = Config {
        max_blocks: args.max_blocks,
        trace: args.trace.is_some(),
        ..Config::default()
    };
    let mut spec = MachineSpec::default();
    if let Some(path) = &args.machine {
        (cfg, spec) = read_machine_file(path, cfg)?;
    }
    if let Some(missing) = args.subprogram_dirs.iter().find(|d| !d.is_dir()) {
        anyhow::bail!("--subprograms {}: not a folder", missing.display());
    }
    cfg.subprogram_dirs = args.subprogram_dirs.clone();
    if let Some(noise) = args.probe_noise {
        anyhow::ensure!(
            noise >= 0.0 && noise.is_finite(),
            "--probe-noise must be ≥ 0"
        );
        spec.noise_um = noise;
    }
    if args.audit {
        return audit(&args, &cfg, spec);
    }
    let mut machine = spec.build(args.seed);
    if args.jobs > 1 {
        return jobs(&args, cfg, &mut machine);
    }
    let run = if args.program == Path::new("-") {
        vm::run_source(
            "<stdin>",
            &read_stdin()?,
            Some(Path::new(".")),
            &cfg,
            &mut machine,
        )?
    } else {
        // The virtual machine names a file and line; a file that cannot be opened has no line.
        std::fs::File::open(&args.program)
            .with_context(|| format!("cannot read {}", args.program.display()))?;
        vm::run_file(&args.program, &cfg, &mut machine)?
    };
    match args.format {
        Format::Human => super::output::print(&run.human())?,
        Format::Json => {
            super::output::print(&format!("{}\n", serde_json::to_string_pretty(&run)?))?
        }
    }
    if let Some(path) = &args.trace {
        let csv = run.trace_csv();
        if path == Path::new("-") {
            super::output::print(&csv)?;
        } else {
            std::fs::write(path, csv)
                .with_context(|| format!("cannot write {}", path.display()))?;
        }
    }
    if let Some(dir) = &args.write_files {
        write_files(dir, &run.files)?;
    }
    Ok(match run.end {
        End::Alarm { .. } => ExitCode::from(1),
        _ => ExitCode::SUCCESS,
    })
}

/// `--jobs N`: the program run N times, each job starting `--pause` minutes after the last ended, with the
/// R-parameters the last left, on a machine still as warm as the history makes it. Each job's report in
/// turn (JSON: an array); the exit code of the last.
fn jobs(args: &Args, mut cfg: Config, machine: &mut vm::SimpleMachine) -> anyhow::Result<ExitCode> {
    let pause = args.pause.0;
    anyhow::ensure!(pause >= 0.0, "--pause must be a time ≥ 0");
    anyhow::ensure!(
        args.program != Path::new("-"),
        "--jobs needs a program file"
    );
    std::fs::File::open(&args.program)
        .with_context(|| format!("cannot read {}", args.program.display()))?;
    let mut before = vm::SpindleHistory::default();
    let mut start = 0.0;
    let mut runs = Vec::new();
    for _ in 0..args.jobs {
        let mut job = vm::LaterJob {
            machine: &mut *machine,
            before: before.clone(),
            start_min: start,
        };
        let run = vm::run_file(&args.program, &cfg, &mut job)?;
        for &(t, rpm) in &run.spindle.steps {
            before.set(start + t, rpm);
        }
        before.set(start + run.time_min, 0.0);
        let clock = cfg.clock_start_min;
        cfg.r_initial = run.r_final.clone();
        cfg.clock_start_min = clock + run.time_min + pause;
        start += run.time_min + pause;
        runs.push(run);
    }
    match args.format {
        Format::Human => {
            let text: Vec<String> = runs
                .iter()
                .enumerate()
                .map(|(k, r)| format!("job {} of {}: {}", k + 1, runs.len(), r.human()))
                .collect();
            super::output::print(&text.join("\n"))?
        }
        Format::Json => {
            super::output::print(&format!("{}\n", serde_json::to_string_pretty(&runs)?))?
        }
    }
    Ok(match runs.last().map(|r| &r.end) {
        Some(End::Alarm { .. }) => ExitCode::from(1),
        _ => ExitCode::SUCCESS,
    })
}

/// Writes each file the program wrote to `dir/NAME`, creating the folder as needed.
fn write_files(
    dir: &Path,
    files: &std::collections::BTreeMap<String, String>,
) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    for (name, text) in files {
        anyhow::ensure!(
            !name.is_empty() && !name.contains(['/', '\\']) && name != "." && name != "..",
            "the program writes to `{name}`, which is not a plain file name"
        );
        let path = dir.join(name);
        std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(())
}

fn read_stdin() -> anyhow::Result<Vec<u8>> {
    let mut src = Vec::new();
    std::io::stdin()
        .read_to_end(&mut src)
        .context("cannot read stdin")?;
    Ok(src)
}

/// `--audit`: exit 0 when clean, 1 with findings, 2 when the virtual machine cannot run a construct.
fn audit(args: &Args, cfg: &Config, machine: MachineSpec) -> anyhow::Result<ExitCode> {
    let read = |path: &Path| -> anyhow::Result<Vec<u8>> {
        if path == Path::new("-") {
            read_stdin()
        } else {
            std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))
        }
    };
    let transformed = read(&args.program)?;
    let original = match &args.original {
        Some(path) => read(path)?,
        None => crate::strip::strip(&transformed).bytes,
    };
    let profile = match &args.profile {
        Some(path) => Profile::read_or_builtin(path)?,
        None => Profile::default_profile(),
    };
    anyhow::ensure!(
        args.probe_margin >= 0.0 && args.probe_margin.is_finite(),
        "--probe-margin must be ≥ 0 mm"
    );
    let name = |path: &Path| {
        if path == Path::new("-") {
            "<stdin>".to_string()
        } else {
            path.display().to_string()
        }
    };
    let program_name = name(&args.program);
    let dir = match args.program.parent() {
        _ if args.program == Path::new("-") => Some(PathBuf::from(".")),
        Some(d) if d.as_os_str().is_empty() => Some(PathBuf::from(".")),
        d => d.map(Path::to_path_buf),
    };
    let mut settings = AuditSettings {
        probe_margin_mm: args.probe_margin,
        machine,
        seed: args.seed,
        original_name: args
            .original
            .as_deref()
            .map_or_else(|| format!("{program_name} without ;DL lines"), name),
        transformed_name: program_name.clone(),
        dir,
        ..AuditSettings::from_profile(&profile)
    };
    if let Some(path) = &args.model {
        let model = DriftModel::read(path)?;
        settings = settings.drifting_as(&model).map_err(|e| {
            anyhow::anyhow!(
                "{}: {e}; describe the machine with --machine (its [models] and [signals]) instead",
                path.display()
            )
        })?;
    }
    let found = vm::audit::audit_owned(original, transformed, &settings, cfg)?;
    match args.format {
        Format::Human => super::output::print(&found.human(&program_name))?,
        Format::Json => {
            super::output::print(&format!("{}\n", serde_json::to_string_pretty(&found)?))?
        }
    }
    Ok(if found.findings.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
