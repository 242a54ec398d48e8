//! `driftloop transform PATH… --model model.toml [--profile machine.toml]`: inserts the measurement and
//! correction blocks. Programs are transformed in parallel; nothing is written unless every program could
//! be transformed, so a batch never ends half done.

use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use rayon::prelude::*;
use serde::Serialize;
use sha2::{Digest, Sha256};

use super::progress::Progress;
use super::style;
use super::{Format, Global};
use crate::Edits;
use crate::diagnostic::Severity;
use crate::model::DriftModel;
use crate::omm::{self, ModelRef, Profile, Summary};
use crate::walk::{self, Input};

#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  driftloop transform PART.MPF --model model.toml --profile tool-setter -o PART_DL.MPF\n  driftloop transform PART.MPF --model model.toml --diff\n  driftloop transform programs/ --model model.toml -o out/ --keep-going"
)]
pub struct Args {
    /// Programs or directories (walked recursively for .mpf .spf .arc .nc .def); `-` reads stdin.
    #[arg(required = true, value_name = "PATH")]
    paths: Vec<PathBuf>,
    #[command(flatten)]
    setup: Setup,
    /// Output file (`-`: stdout), or with several inputs / a directory, a directory mirroring the inputs.
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    output: Option<PathBuf>,
    /// Replace each input file (atomically: temp file in the same directory, then rename).
    #[arg(long, conflicts_with = "output")]
    in_place: bool,
    /// Write nothing; exit 1 if any output would differ from the file at `-o` (or the input without `-o`), 0
    /// if none would; an input that is transformed already counts as unchanged.
    #[arg(long)]
    check: bool,
    /// Print a unified diff of each input against its output instead of writing; exit 1 if there is a
    /// difference, 0 if not (an input that is transformed already).
    #[arg(long)]
    diff: bool,
    /// `human`: summary on stderr; `json`: one JSON object per file (on stdout unless the program goes there).
    #[arg(long, value_enum, default_value_t = Format::Human)]
    format: Format,
    /// Transform programs with syntax errors too.
    #[arg(long)]
    force: bool,
    /// In a batch, write the programs that transform even when others are refused (exit 2 all the same);
    /// without it one refusal writes nothing at all.
    #[arg(long)]
    keep_going: bool,
    /// Do not run the safety audit on the output (by default every transformed program is run side by side
    /// with the original on the virtual machine, and refused when an inserted block breaks the state).
    #[arg(long)]
    no_audit: bool,
    /// Machine file for the safety audit's dry run (`driftloop run --machine`, docs/commands/run.md): the
    /// values it cannot know (`[variables]`: R-parameters, inputs `$A_IN[n]`, machine data, GUD), machine
    /// axis names, the timing. The audit's own start states (work offsets, a tool in force, the spindle
    /// turning) still apply to its runs that test them.
    #[arg(long, value_name = "MACHINE.toml", conflicts_with = "no_audit")]
    machine: Option<PathBuf>,
}

/// Model and profile, shared by `transform` and `plan`.
#[derive(Debug, clap::Args)]
pub struct Setup {
    /// The drift model file (`driftloop fit` writes it); repeated, one per measured axis when the profile
    /// measures several (`[[position.also]]` names each further axis's channel).
    #[arg(long, value_name = "MODEL.toml", required = true)]
    pub model: Vec<PathBuf>,
    /// The machine profile: a TOML file, or the name of a builtin profile (`driftloop profiles` lists
    /// them: blum-tc50, siemens-cycle978, tool-setter, grinder-gauge, lathe-setter); blum-tc50 when absent.
    #[arg(long, value_name = "MACHINE.toml|NAME")]
    pub profile: Option<PathBuf>,
    /// Folder holding the control's subprograms: a call of one (`NAME.SPF`, `NAME.MPF`, `_N_NAME_SPF`, any
    /// case) adds its time to the plan and the R-parameters it uses are left alone; repeatable, after the
    /// profile's own `subprograms`. The program's own folder is searched first without it, as the control
    /// does.
    #[arg(long = "subprograms", value_name = "DIR")]
    pub subprogram_dirs: Vec<PathBuf>,
    /// Refuse a program whose plan has a stretch where the predicted change exceeds δ' (or Δ) with no place
    /// to measure in between (without it, such stretches are warnings).
    #[arg(long)]
    pub strict: bool,
}

impl Setup {
    /// The models with the SHA-256 of their files, and the profile.
    pub fn load(&self) -> anyhow::Result<(Vec<(DriftModel, String)>, Profile)> {
        let mut models = Vec::new();
        for path in &self.model {
            let text = crate::text::read_utf8(path, crate::text::TOML)
                .with_context(|| format!("{}: cannot read", path.display()))?;
            let model = DriftModel::from_toml(&text, &path.display().to_string())?;
            let sha: String = Sha256::digest(text.as_bytes())
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect();
            models.push((model, sha));
        }
        let mut profile = match &self.profile {
            Some(path) => Profile::read_or_builtin(path)?,
            None => Profile::default_profile(),
        };
        let dirs = &mut profile.timeline.subprograms;
        dirs.extend(self.subprogram_dirs.iter().cloned());
        if let Some(missing) = dirs.iter().find(|d| !d.is_dir()) {
            anyhow::bail!("subprogram folder {} is not a folder", missing.display());
        }
        Ok((models, profile))
    }
}

/// One input with where its output goes.
struct Job {
    input: Input,
    target: Target,
}

#[derive(Debug, Clone, PartialEq)]
enum Target {
    Stdout,
    File(PathBuf),
    /// `--diff`, or `--check` without `-o`: compared with the input, nothing written.
    None,
}

/// A transformed program: the input and the blocks to insert, so a batch holds each program once, not
/// twice, until it is known that every program transforms; the output is streamed from them.
struct Outcome {
    /// The input, parsed (its source is the original bytes, kept without a copy).
    program: crate::Program,
    edits: Edits,
    summary: Summary,
    audit: Option<AuditNote>,
}

impl Outcome {
    fn bytes(&self) -> Vec<u8> {
        self.edits.to_bytes(&self.program)
    }

    fn write_to(&self, w: &mut impl Write) -> io::Result<()> {
        let mut w = io::BufWriter::with_capacity(1 << 16, w);
        self.edits.write_to(&self.program, &mut w)?;
        w.flush()
    }
}

/// Why a program was not transformed: the kind (what the batch summary counts) and the message.
struct Refusal {
    reason: &'static str,
    message: String,
}

impl Refusal {
    fn new(reason: &'static str, message: impl ToString) -> Refusal {
        Refusal {
            reason,
            message: message.to_string(),
        }
    }
}

/// What became of one input that was not refused.
enum Done {
    Transformed(Box<Outcome>),
    /// `--check` or `--diff` on a program that carries driftloop's header (line): nothing would change, as
    /// rustfmt says of a formatted file; written normally it is a refusal, since a second transform would
    /// measure twice.
    AlreadyTransformed(usize),
}

#[derive(Serialize)]
struct JsonFile<'a> {
    path: String,
    output: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    error: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    reason: Option<&'static str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    changed: Option<bool>,
    /// The line of driftloop's header in an input `--check`/`--diff` found transformed already.
    #[serde(skip_serializing_if = "Option::is_none")]
    already_transformed: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    summary: Option<&'a Summary>,
    #[serde(skip_serializing_if = "Option::is_none")]
    audit: Option<&'a AuditNote>,
}

impl<'a> JsonFile<'a> {
    /// The record of `path` with nothing said about it yet.
    fn of(path: String, output: Option<String>) -> JsonFile<'a> {
        JsonFile {
            path,
            output,
            error: None,
            reason: None,
            changed: None,
            already_transformed: None,
            summary: None,
            audit: None,
        }
    }
}

/// What the safety audit said of a transformed program that it accepted.
#[derive(Serialize, Default)]
struct AuditNote {
    /// Findings that come from the profile rather than the inserted blocks (the probe point).
    warnings: Vec<String>,
    /// Why the audit could not run the programs to their end, or at all.
    #[serde(skip_serializing_if = "Option::is_none")]
    incomplete: Option<String>,
    /// What the dry run took without knowing it (values read as 0, synchronized actions not run).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    notes: Vec<String>,
    resume_points: u64,
    abort_paths: u64,
}

pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    let (models, profile) = args.setup.load()?;
    let machine = match &args.machine {
        Some(path) => super::run::read_machine_file(path, crate::vm::Config::default())?.0,
        None => crate::vm::Config::default(),
    };
    let jobs = jobs(&args)?;
    if !args.in_place && !args.check {
        let mut inputs: Vec<&Path> = jobs
            .iter()
            .filter_map(|j| match &j.input {
                Input::File(p) => Some(p.as_path()),
                _ => None,
            })
            .collect();
        inputs.extend(args.setup.model.iter().map(PathBuf::as_path));
        let outputs: Vec<(&str, Option<&Path>)> = jobs
            .iter()
            .filter_map(|j| match &j.target {
                Target::File(out) => Some(("-o", Some(out.as_path()))),
                _ => None,
            })
            .collect();
        super::output::refuse_overwriting(&outputs, &inputs)?;
    }
    let progress = Progress::new("transformed", jobs.len());
    let results: Vec<Result<Done, Refusal>> = jobs
        .par_iter()
        .map(|job| {
            let r = transform_one(&job.input, &models, &profile, &machine, &args);
            progress.tick();
            r
        })
        .collect();
    progress.finish();

    let mut stderr = anstream::stderr().lock();
    let refused = results.iter().filter(|r| r.is_err()).count();
    let mut changed = 0;
    let mut json = Vec::new();
    let to_stdout = jobs.iter().any(|j| j.target == Target::Stdout);
    for (job, result) in jobs.iter().zip(&results) {
        let path = job.input.to_string();
        let output = match &job.target {
            Target::File(p) => Some(p.display().to_string()),
            Target::Stdout => Some("-".into()),
            Target::None => None,
        };
        match result {
            Err(e) => {
                writeln!(
                    stderr,
                    "{} {path}: {}",
                    style::label(Severity::Error),
                    e.message
                )?;
                json.push(JsonFile {
                    error: Some(e.message.clone()),
                    reason: Some(e.reason),
                    ..JsonFile::of(path, output)
                });
            }
            Ok(Done::AlreadyTransformed(line)) => {
                if args.format == Format::Human {
                    writeln!(
                        stderr,
                        "{path}: already transformed (driftloop header on line {line}); nothing would change"
                    )?;
                }
                json.push(JsonFile {
                    changed: Some(false),
                    already_transformed: Some(*line),
                    ..JsonFile::of(path, output)
                });
            }
            Ok(Done::Transformed(o)) => {
                let differs = if args.check {
                    let current = match &job.target {
                        Target::File(p) => std::fs::read(p).ok(),
                        _ => Some(o.program.source().to_vec()),
                    };
                    current != Some(o.bytes())
                } else {
                    true
                };
                changed += usize::from(differs);
                if args.format == Format::Human {
                    let s = &o.summary;
                    for w in &s.warnings {
                        writeln!(stderr, "{} {path}: {w}", style::label(Severity::Warning))?;
                    }
                    for n in &s.notes {
                        writeln!(stderr, "{} {path}: {n}", style::label(Severity::Note))?;
                    }
                    if let Some(a) = &o.audit {
                        for w in &a.warnings {
                            writeln!(stderr, "{} {path}: {w}", style::label(Severity::Warning))?;
                        }
                        for n in &a.notes {
                            writeln!(
                                stderr,
                                "{} {path}: audit: {n}",
                                style::label(Severity::Note)
                            )?;
                        }
                        if let Some(why) = &a.incomplete {
                            writeln!(
                                stderr,
                                "{} {path}: audit incomplete, written without the safety audit from there on: {why}; prove the output out on the machine (single block, dry run) or make the program run on `driftloop run`",
                                style::label(Severity::Warning)
                            )?;
                        }
                    }
                    writeln!(
                        stderr,
                        "{path}: {} passes, {} gates, {} measurements planned, {} blocks inserted, predicted drift up to {:.1} µm, R-parameters up to R{} (MD28050 MM_NUM_R_PARAM ≥ {}){}{}",
                        s.passes,
                        s.gates,
                        s.measurements_planned,
                        s.blocks_inserted,
                        s.predicted_max_drift_um,
                        s.r_parameters_needed.saturating_sub(1),
                        s.r_parameters_needed,
                        match s.untimed_calls {
                            0 => String::new(),
                            n => format!(
                                "; {n} subprogram/cycle call(s) not timed, 0 min assumed for each (`plan` lists them; give their folder with --subprograms DIR)"
                            ),
                        },
                        if args.check && differs {
                            " — would change"
                        } else {
                            ""
                        }
                    )?;
                }
                json.push(JsonFile {
                    changed: (args.check || args.diff).then_some(differs),
                    summary: Some(&o.summary),
                    audit: o.audit.as_ref(),
                    ..JsonFile::of(path, output)
                });
            }
        }
    }
    let emit_json = |json: &[JsonFile]| -> anyhow::Result<()> {
        if args.format != Format::Json {
            return Ok(());
        }
        let text = serde_json::to_string_pretty(json)?;
        if to_stdout && !args.check && !args.diff {
            writeln!(io::stderr(), "{text}")?;
        } else {
            writeln!(super::output::stdout(), "{text}")?;
        }
        Ok(())
    };
    if jobs.len() > 1 && args.format == Format::Human {
        write_coverage(&mut stderr, &results)?;
    }
    if refused > 0 && !args.keep_going {
        emit_json(&json)?;
        writeln!(
            stderr,
            "{refused} of {} program(s) refused; nothing written (--keep-going writes the others)",
            jobs.len()
        )?;
        return Ok(ExitCode::from(2));
    }
    let outcomes: Vec<(&Job, &Outcome)> = jobs
        .iter()
        .zip(&results)
        .filter_map(|(job, r)| match r {
            Ok(Done::Transformed(o)) => Some((job, o.as_ref())),
            _ => None,
        })
        .collect();
    if args.diff {
        let mut out = super::output::stdout();
        for &(job, o) in &outcomes {
            write_diff(
                &mut out,
                &job.input.to_string(),
                o.program.source(),
                &o.bytes(),
            )?;
        }
    } else if !args.check {
        for &(job, o) in &outcomes {
            match &job.target {
                Target::Stdout => o
                    .write_to(&mut super::output::stdout())
                    .map_err(super::output::program_not_written)?,
                Target::File(p) => write_atomic(p, |w| o.write_to(w))?,
                Target::None => {}
            }
        }
    }
    emit_json(&json)?;
    if refused > 0 {
        writeln!(
            io::stderr(),
            "{refused} of {} program(s) refused; the other {} {}",
            jobs.len(),
            outcomes.len(),
            if args.check || args.diff {
                "checked"
            } else {
                "written"
            }
        )?;
        return Ok(ExitCode::from(2));
    }
    Ok(if (args.check || args.diff) && changed > 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

/// Folders a control searches for a called subprogram after its caller's own: an SPF folder inside the
/// program's (any case).
const SPF_FOLDERS: &[&str] = &["_N_SPF_DIR", "SPF", "SUBPROGRAMS", "SUBROUTINES", "SUBS"];

/// A folder of main programs and its subprograms' folder beside it: an archive's or data backup's
/// `_N_MPF_DIR` / `_N_SPF_DIR`, a shop's `routines` / `subroutines`. Only a pair: any folder that happens
/// to sit beside the program's (in a temporary or home folder) is not the control's.
const SPF_BESIDE: &[(&str, &str)] = &[
    ("_N_MPF_DIR", "_N_SPF_DIR"),
    ("MPF", "SPF"),
    ("ROUTINES", "SUBROUTINES"),
    ("PROGRAMS", "SUBPROGRAMS"),
];

/// The folders in `base` whose name is one of `names` (any case), sorted.
fn folders_named(base: &std::path::Path, names: &[&str]) -> Vec<std::path::PathBuf> {
    let Ok(entries) = std::fs::read_dir(base) else {
        return Vec::new();
    };
    let mut found: Vec<_> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.is_dir()
                && p.file_name().is_some_and(|n| {
                    names
                        .iter()
                        .any(|f| n.to_string_lossy().eq_ignore_ascii_case(f))
                })
        })
        .collect();
    found.sort();
    found
}

/// The [`SPF_FOLDERS`] inside `dir`, then the [`SPF_BESIDE`] partner of `dir` beside it.
fn spf_folders(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut found = folders_named(dir, SPF_FOLDERS);
    let name = std::fs::canonicalize(dir).ok().and_then(|d| {
        d.file_name()
            .map(|n| n.to_string_lossy().to_ascii_uppercase())
    });
    if let Some((_, spf)) = SPF_BESIDE
        .iter()
        .find(|(mpf, _)| Some(*mpf) == name.as_deref())
    {
        found.extend(folders_named(&dir.join(".."), &[spf]));
    }
    found
}

/// The profile with the program's own folder first among the subprogram folders, as the control finds a
/// called subprogram beside its caller (and the audit runs it from there), then its SPF folders
/// ([`SPF_FOLDERS`]) after the profile's: the registers a subprogram uses and its time count. `None` when
/// every one is already listed, or the input is not a file. `plan` times the program the same way.
pub(super) fn beside_program(input: &Input, profile: &Profile) -> Option<Profile> {
    let Input::File(path) = input else {
        return None;
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    let mut with = profile.clone();
    let listed = &mut with.timeline.subprograms;
    if !listed.contains(&dir) {
        listed.insert(0, dir.clone());
    }
    for spf in spf_folders(&dir) {
        if !listed.contains(&spf) {
            listed.push(spf);
        }
    }
    (with.timeline.subprograms != profile.timeline.subprograms).then_some(with)
}

fn transform_one(
    input: &Input,
    models: &[(DriftModel, String)],
    profile: &Profile,
    machine: &crate::vm::Config,
    args: &Args,
) -> Result<Done, Refusal> {
    let bytes = input.read().map_err(|e| Refusal::new("unreadable", e))?;
    if let Some(why) = crate::text::not_text(&bytes, crate::text::NC_PROGRAM) {
        return Err(Refusal::new("not a text program", why));
    }
    if (args.check || args.diff)
        && let Some(line) = omm::transformed_line(&bytes)
    {
        return Ok(Done::AlreadyTransformed(line));
    }
    let (program, moves) = omm::parse_timed(bytes);
    let beside = beside_program(input, profile);
    let profile = beside.as_ref().unwrap_or(profile);
    let refs: Vec<ModelRef<'_>> = models
        .iter()
        .map(|(model, sha)| ModelRef { model, sha256: sha })
        .collect();
    let prepared = omm::prepare_timed(&program, &moves, &refs, profile, args.force)
        .map_err(|e| Refusal::new(e.reason(), e))?;
    let on_hand_spindle = prepared
        .plan
        .gates
        .iter()
        .any(|g| g.can_measure && g.hand_spindle);
    let (edits, summary) = prepared.into_edits();
    if args.setup.strict
        && let Some(w) = summary.warnings.first()
    {
        return Err(Refusal::new(
            "plan warnings (--strict)",
            format!("--strict: {w}"),
        ));
    }
    let audit = if args.no_audit {
        None
    } else {
        let subject = Audited {
            input,
            program: &program,
            models: &refs,
            machine,
        };
        let note = audit_output(&subject, &edits, profile, Start::Bare, "")?;
        // The same program with every gate measuring has the same gates, each taking its measuring branch,
        // audited on work offsets that are not 0 and with a tool in force.
        let audit_measuring = |start: Start, variant: &str| {
            let mut measuring = profile.clone();
            measuring.log.measure_every_gate = true;
            let (every, _) = omm::prepare_timed(&program, &moves, &refs, &measuring, args.force)
                .map_err(|e| Refusal::new(e.reason(), e))?
                .into_edits();
            audit_output(&subject, &every, &measuring, start, variant)
        };
        if profile.log.measure_every_gate && omm::plan::reads_tool(profile) {
            // The first run had no tool in force, so gates that read the tool took their way around the
            // probe; this one has a tool in force, and their swap and its check run.
            audit_output(
                &subject,
                &edits,
                profile,
                Start::Shifted,
                " with a tool in force at the start",
            )?;
        } else if !profile.log.measure_every_gate {
            // The dry run takes each gate's Cycle_in decision as the plan predicts it, so most gates skip
            // their measuring branch there; on the machine a pause (a stop, a feed hold) makes the
            // predicted change grow and the branch runs: it must pass too. It runs on work offsets that
            // are not 0 (and put the clearance below a reference in machine coordinates): a gate must hold
            // under whatever offsets the machine has.
            audit_measuring(
                Start::Shifted,
                " with every gate measuring (as a gate does when a pause makes the predicted change exceed δ′; `[log] measure_every_gate = true` in the profile writes that program)",
            )?;
        }
        if on_hand_spindle {
            // The runs above start with the spindle standing, so the gates before the program sets its
            // spindle measured there; on the machine the operator may have started it in MDA, and a gate
            // that stopped it then would leave the program cutting with a standing spindle.
            audit_measuring(
                Start::ShiftedTurning,
                " with the spindle turning at the start (started in MDA) and every gate measuring",
            )?;
        }
        Some(note)
    };
    Ok(Done::Transformed(Box::new(Outcome {
        program,
        edits,
        summary,
        audit,
    })))
}

/// The program an audit runs, and what every run of it shares: the models the machine drifts by and the
/// machine file's configuration.
struct Audited<'a> {
    input: &'a Input,
    program: &'a crate::Program,
    models: &'a [ModelRef<'a>],
    machine: &'a crate::vm::Config,
}

/// How the machine stands when an audit's dry run starts.
#[derive(Clone, Copy, PartialEq)]
enum Start {
    /// No work offsets, no tool, the spindle standing.
    Bare,
    /// Work offsets that are not 0 and a tool in force (`shifted` below).
    Shifted,
    /// As `Shifted`, with the spindle turning as the operator started it in MDA.
    ShiftedTurning,
}

/// Runs the transformed program beside the original on a virtual machine that drifts as the model predicts
/// (the safety audit, `driftloop run --audit`): a finding the inserted blocks caused refuses the program; one
/// the profile caused (its probe point in the part's cut) is a warning; a construct the dry run cannot run
/// ends the audit there, with a note. Shifted (`start` not `Start::Bare`), the machine starts with the work
/// offsets of [`crate::vm::audit::AuditSettings::shifted_offsets`] and a tool in force, as one loaded by
/// hand: a gate that reads the tool at run time swaps the probe for it (without one it goes around the
/// probe).
fn audit_output(
    subject: &Audited<'_>,
    edits: &Edits,
    profile: &Profile,
    start: Start,
    variant: &str,
) -> Result<AuditNote, Refusal> {
    use crate::vm::audit::{AuditSettings, audit_owned};
    let Audited {
        input,
        program,
        models,
        machine,
    } = *subject;
    let shifted = start != Start::Bare;
    // The virtual machine drifts as each axis's model predicts from the spindle; the terms it reads from
    // sensors have no signal there and are left out.
    let ordered = omm::models_for_axes(profile, models, |m: ModelRef<'_>| m.model.channel.as_str())
        .map_err(|e| Refusal::new(e.reason(), e))?;
    let spindle_parts: Vec<DriftModel> = ordered
        .iter()
        .map(|m| {
            let mut part = m.model.clone();
            part.inputs.clear();
            part.effects
                .retain(|e| e.signal.is_none() && e.position.is_none());
            part
        })
        .collect();
    let parts: Vec<&DriftModel> = spindle_parts.iter().collect();
    let mut settings = AuditSettings::from_profile(profile)
        .drifting_as_axes(&parts)
        .map_err(|e| Refusal::new("audit setup", e))?;
    // Subprograms are looked up beside the program, as the control finds them in its folder.
    if let Input::File(path) = input {
        settings.dir = path.parent().map(|d| d.to_path_buf());
        settings.original_name = path.display().to_string();
    }
    let mut cfg = crate::vm::Config {
        subprogram_dirs: profile.timeline.subprograms.clone(),
        ..machine.clone()
    };
    if shifted {
        cfg.offsets = settings.shifted_offsets();
        cfg.start_tool = Some(crate::vm::audit::hand_loaded_tool());
    }
    if start == Start::ShiftedTurning {
        cfg.start_spindle = Some(crate::vm::audit::hand_started_spindle());
    }
    let transformed = edits.to_bytes(program);
    let found = match audit_owned(program.source().to_vec(), transformed, &settings, &cfg) {
        Ok(found) => found,
        Err(e) => {
            return Ok(AuditNote {
                incomplete: Some(format!("the dry run cannot run the program: {e}")),
                ..AuditNote::default()
            });
        }
    };
    let (warnings, caused): (Vec<_>, Vec<_>) = found
        .findings
        .iter()
        .partition(|f| f.kind.is_probe_point_warning());
    if let Some(f) = caused.first() {
        return Err(Refusal::new(
            "audit findings",
            format!(
                "the safety audit found {} hazard(s) in the output{variant}, nothing written; first: {}: {}: {} (`driftloop run --audit` on the output shows them all)",
                caused.len(),
                f.place(),
                f.kind.name(),
                f.message
            ),
        ));
    }
    Ok(AuditNote {
        warnings: warnings
            .iter()
            .map(|f| format!("{}: {}: {}", f.place(), f.kind.name(), f.message))
            .collect(),
        incomplete: found.stopped.clone(),
        notes: found.notes.clone(),
        resume_points: found.resume_points,
        abort_paths: found.abort_runs,
    })
}

/// The batch's count: how many programs transform, and the refusals by kind.
fn write_coverage(w: &mut impl Write, results: &[Result<Done, Refusal>]) -> io::Result<()> {
    let mut reasons: std::collections::BTreeMap<&str, usize> = Default::default();
    for e in results.iter().filter_map(|r| r.as_ref().err()) {
        *reasons.entry(e.reason).or_default() += 1;
    }
    let already = results
        .iter()
        .filter(|r| matches!(r, Ok(Done::AlreadyTransformed(_))))
        .count();
    let ok = results.len() - reasons.values().sum::<usize>() - already;
    write!(
        w,
        "{ok} of {} programs transform ({:.1} %)",
        results.len(),
        100.0 * ok as f64 / results.len() as f64
    )?;
    if already > 0 {
        write!(w, "; already transformed: {already}")?;
    }
    if !reasons.is_empty() {
        let list: Vec<String> = reasons.iter().map(|(r, n)| format!("{r}: {n}")).collect();
        write!(w, "; refused: {}", list.join(", "))?;
    }
    writeln!(w)
}

/// Subprograms and definition files: a directory's are timed through the main programs that call them
/// (`--subprograms`), not transformed themselves.
fn is_subprogram(input: &Input) -> bool {
    let Input::File(path) = input else {
        return false;
    };
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("spf") || e.eq_ignore_ascii_case("def"))
}

/// Pairs every input with its output according to the options.
fn jobs(args: &Args) -> anyhow::Result<Vec<Job>> {
    let mut jobs = Vec::new();
    let several = args.paths.len() > 1 || args.paths.iter().any(|p| p.is_dir());
    for root in &args.paths {
        let walked = walk::expand(std::slice::from_ref(root));
        let skipped = if root.is_dir() {
            walked.iter().filter(|i| is_subprogram(i)).count()
        } else {
            0
        };
        if skipped > 0 {
            anstream::eprintln!(
                "{} {}: {skipped} subprogram file(s) (.spf, .def) not transformed: gates go into the main programs, which time the subprograms they call (--subprograms DIR)",
                style::label(Severity::Note),
                root.display()
            );
        }
        for input in walked
            .into_iter()
            .filter(|i| !(root.is_dir() && is_subprogram(i)))
        {
            let target = if args.diff {
                Target::None
            } else if args.in_place {
                match &input {
                    Input::Stdin => bail!("--in-place cannot replace stdin; use -o"),
                    Input::File(p) | Input::Unreadable { path: p, .. } => Target::File(p.clone()),
                }
            } else if let Some(out) = &args.output {
                if several {
                    Target::File(mirrored(out, root, &input)?)
                } else if out == Path::new("-") {
                    Target::Stdout
                } else {
                    Target::File(out.clone())
                }
            } else if args.check {
                match &input {
                    Input::Stdin => Target::None,
                    Input::File(p) | Input::Unreadable { path: p, .. } => Target::File(p.clone()),
                }
            } else if several {
                bail!("several programs need -o DIRECTORY, --in-place, --check or --diff");
            } else {
                Target::Stdout
            };
            jobs.push(Job { input, target });
        }
    }
    Ok(jobs)
}

/// `out/<path of the input below its root>`; a file named directly keeps its file name.
fn mirrored(out: &Path, root: &Path, input: &Input) -> anyhow::Result<PathBuf> {
    let Input::File(path) = input else {
        bail!("stdin cannot be mirrored into a directory; transform it alone")
    };
    let relative = if root.is_dir() {
        path.strip_prefix(root).unwrap_or(path).to_path_buf()
    } else {
        PathBuf::from(path.file_name().context("input without a file name")?)
    };
    Ok(out.join(relative))
}

/// Writes the file `path` with `write` through a temporary file in the same directory, synced to disk and
/// renamed over `path` (`tempfile`'s persist): a reader sees the old file or the new one, never half of
/// one. A file that existed keeps its permissions and, where the process may give it, its owner. A device
/// or pipe (`/dev/null`, a FIFO) is written directly, never replaced; a symbolic link keeps pointing where
/// it did, and its target is replaced. The temporary file is removed when anything fails, and on an
/// interrupt or termination signal ([`super::signals`]).
pub(super) fn write_atomic(
    path: &Path,
    write: impl Fn(&mut std::fs::File) -> io::Result<()>,
) -> anyhow::Result<()> {
    let resolved;
    let path = match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => {
            resolved = std::fs::canonicalize(path)
                .with_context(|| format!("cannot resolve {}", path.display()))?;
            resolved.as_path()
        }
        _ => path,
    };
    let existing = std::fs::metadata(path).ok();
    if existing
        .as_ref()
        .is_some_and(|m| !m.is_file() && !m.is_dir())
    {
        return std::fs::OpenOptions::new()
            .write(true)
            .open(path)
            .and_then(|mut f| write(&mut f))
            .with_context(|| format!("cannot write {}", path.display()));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir).with_context(|| {
        format!(
            "cannot write {}: cannot create its folder {}",
            path.display(),
            dir.display()
        )
    })?;
    let name = path.file_name().context("output without a file name")?;
    let written = (|| -> io::Result<()> {
        let (mut tmp, _registered) = super::signals::create_registered(
            || {
                tempfile::Builder::new()
                    .prefix(&format!(".{}.", name.to_string_lossy()))
                    .suffix(".driftloop.tmp")
                    .tempfile_in(&dir)
            },
            |t| t.path(),
        )?;
        write(tmp.as_file_mut())?;
        keep_mode_and_owner(tmp.as_file(), existing.as_ref())?;
        tmp.as_file().sync_all()?;
        tmp.persist(path).map_err(|e| e.error)?;
        // The rename itself is durable once the directory is synced; not every system can sync one.
        let _ = std::fs::File::open(&dir).and_then(|d| d.sync_all());
        Ok(())
    })();
    written.with_context(|| format!("cannot write {}", path.display()))
}

/// Gives the new file the permissions of the one it replaces (a new file: read-write as the umask allows,
/// like any file the process creates) and, where allowed, its owner and group.
fn keep_mode_and_owner(
    file: &std::fs::File,
    existing: Option<&std::fs::Metadata>,
) -> io::Result<()> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::{MetadataExt, PermissionsExt};
        match existing {
            Some(meta) => {
                file.set_permissions(meta.permissions())?;
                // Only a privileged process may give a file away; others keep it as their own.
                let _ = std::os::unix::fs::fchown(file, Some(meta.uid()), Some(meta.gid()));
            }
            None => {
                let umask = current_umask();
                file.set_permissions(std::fs::Permissions::from_mode(0o666 & !umask))?;
            }
        }
    }
    #[cfg(not(unix))]
    if let Some(meta) = existing {
        file.set_permissions(meta.permissions())?;
    }
    Ok(())
}

/// The process's umask, read from /proc where there is one (setting it to read it races with threads).
#[cfg(unix)]
fn current_umask() -> u32 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("Umask:"))
                .and_then(|v| u32::from_str_radix(v.trim(), 8).ok())
        })
        .unwrap_or(0o022)
}

/// A unified diff with the inserted lines; bytes that are not UTF-8 are shown as the replacement character.
fn write_diff(out: &mut impl Write, name: &str, old: &[u8], new: &[u8]) -> io::Result<()> {
    let old = String::from_utf8_lossy(old);
    let new = String::from_utf8_lossy(new);
    let diff = similar::TextDiff::from_lines(old.as_ref(), new.as_ref());
    write!(
        out,
        "{}",
        diff.unified_diff()
            .context_radius(2)
            .header(&format!("a/{name}"), &format!("b/{name}"))
    )
}
