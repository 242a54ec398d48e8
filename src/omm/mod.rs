//! On-machine measurement: the program's timeline ([`timeline`]), the measurement plan from the drift model
//! ([`plan`]), and the blocks that carry it out on the control ([`emit`]), configured by a machine
//! [`profile`]. [`transform`] puts them together: every original block stays byte for byte, in order; only
//! new blocks are inserted, each parsed again before it is accepted.

pub mod continuous;
pub mod declared_calls;
pub mod emit;
mod iso;
pub mod loops;
pub mod machine_coolant;
pub mod nc;
pub mod plan;
pub mod profile;
pub mod report;
pub mod timeline;
pub mod warm;

use serde::Serialize;

use crate::edit::{EditError, Editor, Edits};
use crate::model::DriftModel;
use crate::syntax::Program;

pub use plan::{Gate, GateKind, Plan, PlanError, Predictor};
pub use profile::{DEFAULT_PROFILE, OffsetMethod, ProbeKind, Profile, ProfileError};
pub use timeline::{Moves, Timeline, parse_timed};

use emit::{Emitter, Registers, SIGNATURE};

/// Longest block the control accepts (characters).
pub const MAX_BLOCK: usize = 512;

/// The model as the transform sees it: the model and the SHA-256 (hex) of its file, named in the header.
#[derive(Debug, Clone, Copy)]
pub struct ModelRef<'a> {
    pub model: &'a DriftModel,
    pub sha256: &'a str,
}

/// Why a program is refused. Nothing is written for a refused program.
#[derive(Debug, thiserror::Error)]
pub enum TransformError {
    #[error(
        "the program has {count} syntax error(s), the first at line {line}, column {column}: {first}; fix them (`driftloop check` shows each with a hint) or pass --force"
    )]
    ParseErrors {
        count: usize,
        line: usize,
        column: usize,
        first: String,
    },
    #[error(
        "the program already carries driftloop's blocks (line {0}: `{SIGNATURE}` header); transform the original program instead"
    )]
    AlreadyTransformed(usize),
    #[error(
        "this looks like a PC-format archive (binary bytes in the first line, a header with a checksum): editing it would break the checksum; transform the program in punched-tape (text) format"
    )]
    PcArchive,
    #[error(
        "{0} indexes R-parameters by an expression (R[…]): driftloop cannot prove its R-parameters are free"
    )]
    ComputedR(String),
    #[error(
        "the program selects {found} ({at}) but the profile corrects {profile}: set [offset] select = \"{found}\" (and its frame), or correct whichever offset is in force with [offset] method = \"active\""
    )]
    OtherOffset {
        found: String,
        /// `line 12`, or `line 12, in subprogram NAME called there`.
        at: String,
        profile: String,
    },
    #[error(
        "a measurement at gate {0} would need to re-load the cutting tool, but no tool is known there"
    )]
    UnknownTool(usize),
    #[error(transparent)]
    Plan(#[from] PlanError),
    #[error(
        "the program writes a frame itself at line {0} (a frame variable, or a call the profile declares with leaves = [\"frames\"]), after the zero: the corrections driftloop writes into the work offset and its restore at the end would overwrite it (or be overwritten); move the write before the first cut"
    )]
    FrameWrite(usize),
    #[error(
        "the program writes the frame in force ($P_IFRAME) itself at line {0}: a gate corrects that frame or selects the work offset again, which would drop the program's own shift; driftloop does not transform such a program (write the shift into a settable offset, $P_UIFR, and select it)"
    )]
    FrameInForceWrite(usize),
    #[error(
        "line {line}: {word} is {}: driftloop inserts Siemens-mode blocks, which that mode reads otherwise, and a gate's tool change would drop a tool length compensation given with G43 H; driftloop transforms Siemens-mode programs only (run this one as it is)",
        iso::what_word_is(word)
    )]
    IsoDialect { line: usize, word: String },
    #[error(
        "line {line}: {call} coordinates this program with another channel of the control, which may be cutting the same part or turning the same spindle while a gate stops the spindle, changes tools or moves this channel's axes; driftloop transforms the program of one channel only (a program with START, INIT, WAITM, WAITMC, WAITE, SETM or CLEARM is refused: run it without the gates)"
    )]
    Channels { line: usize, call: String },
    #[error("{0}")]
    Other(String),
    #[error(
        "an inserted block would be longer than the control's 512 characters (shorten the profile's texts): `{0}`"
    )]
    LongBlock(String),
    #[error("internal error: an inserted block does not parse: {0}")]
    Emit(#[from] EditError),
    #[error(
        "internal error: the output would have a syntax error the program does not, at line {line}, column {column}: {message}; nothing written (please report it with the program and the profile)"
    )]
    OutputSyntax {
        line: usize,
        column: usize,
        message: String,
    },
    #[error(
        "an inserted block would carry the number {0}, which no NC program should (finite, at most ±999999999): check the model, the profile and the program's own values (speeds, feeds, times)"
    )]
    Unwritable(String),
}

impl TransformError {
    /// The kind of refusal, in a few words: what a batch report counts.
    pub fn reason(&self) -> &'static str {
        match self {
            TransformError::ParseErrors { .. } => "syntax errors",
            TransformError::AlreadyTransformed(_) => "already transformed",
            TransformError::PcArchive => "PC-format archive",
            TransformError::ComputedR(_) => "R-parameters indexed by expressions",
            TransformError::OtherOffset { .. } => "another work offset than the profile's",
            TransformError::UnknownTool(_) => "tool not known at a gate",
            TransformError::Plan(PlanError::NothingToCompensate) => "moves no axis",
            TransformError::Plan(PlanError::NoReference(_)) => "no place for the reference",
            TransformError::Plan(PlanError::Model(_)) => "model not predictable in NC",
            TransformError::Plan(PlanError::Declaration(_)) => "a declared call does not fit",
            TransformError::FrameWrite(_) => "writes a work offset itself",
            TransformError::FrameInForceWrite(_) => "writes the frame in force itself",
            TransformError::IsoDialect { .. } => "ISO dialect",
            TransformError::Channels { .. } => "coordinates several channels",
            TransformError::Other(_) => "profile or registers",
            TransformError::LongBlock(_) => "block too long",
            TransformError::Emit(_) | TransformError::OutputSyntax { .. } => "internal error",
            TransformError::Unwritable(_) => "number out of range",
        }
    }
}

/// What the transform did to one program.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    pub blocks_inserted: usize,
    pub passes: usize,
    pub gates: usize,
    pub measurements_planned: usize,
    pub predicted_max_drift_um: f64,
    pub program_min: f64,
    pub r_parameters: Vec<u32>,
    pub labels: Vec<String>,
    /// Blocks whose time could not be estimated (expressions as coordinates, no feed).
    pub inexact_blocks: usize,
    /// Subprogram and cycle calls, whose time the plan does not count (`plan` lists them).
    pub untimed_calls: usize,
    /// The control needs at least this many R-parameters (machine data MD28050 MM_NUM_R_PARAM): one more
    /// than the highest the inserted blocks use.
    pub r_parameters_needed: u32,
    /// Stretches of the plan where the predicted change exceeds δ' or Δ with no place to measure.
    pub warnings: Vec<String>,
    /// What the operator should know that is no fault of the plan (machine M-codes a gate leaves alone).
    pub notes: Vec<String>,
}

/// A transformed program.
#[derive(Debug)]
pub struct Transformed {
    pub bytes: Vec<u8>,
    pub summary: Summary,
    pub plan: Plan,
}

/// Whether a file is a PC-format archive: binary header bytes (NUL or other control characters) on its
/// first line.
pub fn is_pc_archive(src: &[u8]) -> bool {
    let first = src.split(|&b| b == b'\n').next().unwrap_or(&[]);
    first
        .iter()
        .any(|&b| b < 0x20 && !matches!(b, b'\t' | b'\r' | 0x0B | 0x0C))
}

/// Line (1-based) of a driftloop header comment, if the program carries one.
pub fn transformed_line(src: &[u8]) -> Option<usize> {
    let at = memchr::memmem::find(src, SIGNATURE.as_bytes())?;
    Some(line_of(src, at))
}

fn line_of(src: &[u8], at: usize) -> usize {
    memchr::memchr_iter(b'\n', &src[..at]).count() + 1
}

/// The checks every transform makes before planning; also used by `plan`.
pub fn check(program: &Program, force: bool) -> Result<(), TransformError> {
    check_with(program, None, force)
}

/// [`check`] for a program parsed with [`timeline::parse_timed`]: the header is searched for only outside
/// the timed moves, which cannot hold it (its name has letters no move word has).
pub fn check_timed(program: &Program, moves: &Moves, force: bool) -> Result<(), TransformError> {
    check_with(program, Some(moves), force)
}

fn check_with(program: &Program, moves: Option<&Moves>, force: bool) -> Result<(), TransformError> {
    let src = program.source();
    if is_pc_archive(src) {
        return Err(TransformError::PcArchive);
    }
    let signature = SIGNATURE.as_bytes();
    let header = match moves {
        None => transformed_line(src),
        Some(moves) => {
            let finder = memchr::memmem::Finder::new(signature);
            let reach = signature.len() - 1;
            moves.untimed_bytes(program).into_iter().find_map(|r| {
                let from = r.start.saturating_sub(reach);
                let to = (r.end + reach).min(src.len());
                finder.find(&src[from..to]).map(|k| line_of(src, from + k))
            })
        }
    };
    if let Some(line) = header {
        return Err(TransformError::AlreadyTransformed(line));
    }
    // Before the syntax errors: an ISO program's `(…)` comments do not parse in Siemens mode, and fixing
    // them would not make it transformable.
    if let Some((line, word)) = iso::iso_word(src) {
        return Err(TransformError::IsoDialect { line, word });
    }
    let mut errors = program.errors();
    if let Some(first) = errors.next()
        && !force
    {
        let (line, column) = crate::source::LineIndex::new(src).line_col(first.span.start);
        return Err(TransformError::ParseErrors {
            count: 1 + errors.count(),
            line,
            column,
            first: first.message.clone(),
        });
    }
    Ok(())
}

/// Timeline and plan of a program.
pub fn plan_program(
    program: &Program,
    model: &DriftModel,
    profile: &Profile,
) -> Result<(Timeline, Plan), TransformError> {
    plan_with(program, None, &[model], profile)
}

/// The models in the order of the profile's measured axes ([`Profile::measured`]): an `also` axis takes
/// the model of the channel it names, `[position]`'s axis the one model left.
pub fn models_for_axes<'m, M: Copy>(
    profile: &Profile,
    models: &[M],
    channel: impl Fn(M) -> &'m str,
) -> Result<Vec<M>, TransformError> {
    let also = &profile.position.also;
    let find = |name: &str| models.iter().copied().find(|m| channel(*m) == name);
    let mut out = Vec::new();
    let rest: Vec<M> = models
        .iter()
        .copied()
        .filter(|m| !also.iter().any(|a| a.channel == channel(*m)))
        .collect();
    match rest.as_slice() {
        [one] => out.push(*one),
        _ => {
            return Err(TransformError::Other(format!(
                "the profile measures {} with the model left over after its `also` channels ({}), but {} model(s) are left: give one model per measured axis",
                profile.position.axis.name(),
                also.iter()
                    .map(|a| a.channel.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
                rest.len()
            )));
        }
    }
    for a in also {
        out.push(find(&a.channel).ok_or_else(|| {
            TransformError::Other(format!(
                "the profile measures {} with the model of channel `{}`, which no --model file holds",
                a.axis.name(),
                a.channel
            ))
        })?);
    }
    Ok(out)
}

/// [`plan_program`] for a program parsed with [`timeline::parse_timed`]: the same plan, without reading the
/// moves the parser timed again.
pub fn plan_timed(
    program: &Program,
    moves: &Moves,
    models: &[&DriftModel],
    profile: &Profile,
) -> Result<(Timeline, Plan), TransformError> {
    plan_with(program, Some(moves), models, profile)
}

fn plan_with(
    program: &Program,
    moves: Option<&Moves>,
    models: &[&DriftModel],
    profile: &Profile,
) -> Result<(Timeline, Plan), TransformError> {
    let models = models_for_axes(profile, models, |m: &DriftModel| m.channel.as_str())?;
    let timeline = match moves {
        Some(moves) => timeline::build_with_moves(program, moves, profile),
        None => timeline::build(program, profile),
    };
    refusals(&timeline, profile)?;
    let plan = plan::plan(&timeline, &models, profile)?;
    Ok((timeline, plan))
}

/// The procedures that start, stop or wait for another channel: while a program that calls them runs,
/// another channel may cut the same part with the same spindle.
const CHANNEL_COORDINATION: &[&str] = &[
    "START", "INIT", "WAITM", "WAITMC", "WAITE", "SETM", "CLEARM",
];

/// What the timeline shows that no plan can mend: R-parameters driftloop cannot prove free, another work
/// offset than the profile corrects.
fn refusals(timeline: &Timeline, profile: &Profile) -> Result<(), TransformError> {
    let at = |line: usize| match timeline.found_in_call.get(&line) {
        Some(name) => format!("line {line}, in subprogram {name} called there,"),
        None => format!("line {line}"),
    };
    if let Some((block, code)) = timeline.iso_dialect {
        return Err(TransformError::IsoDialect {
            line: block + 1,
            word: format!("G{code}"),
        });
    }
    if let Some((line, call)) = timeline
        .untimed_calls
        .iter()
        .find(|(_, name)| CHANNEL_COORDINATION.contains(&name.as_str()))
    {
        return Err(TransformError::Channels {
            line: *line,
            call: call.clone(),
        });
    }
    if let Some(&line) = timeline.computed_r_lines.first() {
        return Err(TransformError::ComputedR(at(line)));
    }
    let wanted = profile.offset_g().expect("validated profile");
    // `active` corrects whichever offset is in force.
    let one_offset = profile.offset.method != OffsetMethod::Active;
    if let Some(&(g, line)) = timeline
        .offsets
        .iter()
        .find(|(g, _)| one_offset && *g != wanted)
    {
        return Err(TransformError::OtherOffset {
            found: format!("G{g}"),
            at: at(line).trim_end_matches(',').to_string(),
            profile: profile.offset.select.clone(),
        });
    }
    Ok(())
}

/// Inserts the measurement and correction blocks into `program`.
pub fn transform(
    program: &Program,
    model: ModelRef<'_>,
    profile: &Profile,
    force: bool,
) -> Result<Transformed, TransformError> {
    prepare(program, model, profile, force).map(Prepared::into_transformed)
}

/// A transformed program not yet written out: the edits over the input's own bytes.
pub struct Prepared<'p> {
    editor: Editor<'p>,
    pub summary: Summary,
    pub plan: Plan,
}

impl Prepared<'_> {
    /// Streams the output: untouched runs of the input as they are, the inserted blocks between them — no
    /// copy of the whole program is made.
    pub fn write_to<W: std::io::Write>(&self, w: &mut W) -> std::io::Result<()> {
        self.editor.write_to(w)
    }

    /// The edits (written later with [`Edits::write_to`] against the same program) and the summary.
    pub fn into_edits(self) -> (Edits, Summary) {
        (self.editor.into_edits(), self.summary)
    }

    pub fn into_transformed(self) -> Transformed {
        Transformed {
            bytes: self.editor.to_bytes(),
            summary: self.summary,
            plan: self.plan,
        }
    }
}

/// [`transform`] without producing the output bytes: write them with [`Prepared::write_to`].
pub fn prepare<'p>(
    program: &'p Program,
    model: ModelRef<'_>,
    profile: &Profile,
    force: bool,
) -> Result<Prepared<'p>, TransformError> {
    prepare_with(program, None, &[model], profile, force)
}

/// [`prepare`] for a program parsed with [`timeline::parse_timed`] (what the `transform` command does): the
/// same output, without reading the moves the parser timed again.
pub fn prepare_timed<'p>(
    program: &'p Program,
    moves: &Moves,
    models: &[ModelRef<'_>],
    profile: &Profile,
    force: bool,
) -> Result<Prepared<'p>, TransformError> {
    prepare_with(program, Some(moves), models, profile, force)
}

fn prepare_with<'p>(
    program: &'p Program,
    moves: Option<&Moves>,
    models: &[ModelRef<'_>],
    profile: &Profile,
    force: bool,
) -> Result<Prepared<'p>, TransformError> {
    let models = models_for_axes(profile, models, |m: ModelRef<'_>| m.model.channel.as_str())?;
    let drift: Vec<&DriftModel> = models.iter().map(|m| m.model).collect();
    // The checks search the source (outside the timed moves, when there are) while the timeline is folded.
    let (checked, planned) = rayon::join(
        || check_with(program, moves, force),
        || plan_with(program, moves, &drift, profile),
    );
    checked?;
    let (timeline, plan) = planned?;
    if let Some(&b) = timeline.frame_in_force_writes.first() {
        return Err(TransformError::FrameInForceWrite(b + 1));
    }
    let zero = plan.gates.first().map_or(0, |g| g.block);
    if let Some(&b) = timeline.frame_writes.iter().find(|&&b| b >= zero) {
        return Err(TransformError::FrameWrite(b + 1));
    }
    let measured = profile.measured();
    let predictors: Vec<Predictor> = models
        .iter()
        .zip(&measured)
        .map(|(m, at)| Predictor::new(m.model, &profile.log.inputs, at))
        .collect::<Result<_, _>>()
        .map_err(TransformError::Other)?;
    let regs = Registers::allocate(
        profile,
        &predictors,
        &timeline.used_r,
        emit::reads_tool(&plan, profile),
    )
    .map_err(TransformError::Other)?;
    let label_prefix = ["DL", "DLOMM", "DRIFTLOOP"]
        .into_iter()
        .find(|p| !timeline.labels.iter().any(|l| l.starts_with(p)))
        .map(str::to_string)
        .ok_or_else(|| {
            TransformError::Other("the program's labels use every prefix driftloop knows".into())
        })?;
    let emitter = Emitter {
        profile,
        regs: &regs,
        axes: measured
            .into_iter()
            .zip(&predictors)
            .zip(&models)
            .map(|((at, predictor), m)| emit::MeasuredAxis {
                at,
                predictor,
                channel: &m.model.channel,
            })
            .collect(),
        label_prefix,
        fingerprint: warm::fingerprint(&models.iter().map(|m| m.sha256).collect::<Vec<_>>()),
        tool_change_call: timeline.tool_change_call.clone(),
    };
    if let Some(w) = &profile.warm_start {
        let store = w.r_first..w.r_first + emitter.store_len();
        if let Some(n) = timeline.used_r.iter().find(|n| store.contains(n)) {
            return Err(TransformError::Other(format!(
                "the program uses R{n}, which lies in the warm-start store R{}…R{} ([warm_start] r_first): no other program may use it",
                store.start,
                store.end - 1
            )));
        }
    }
    let mut editor = Editor::new(program);
    let mut inserted = 0;
    let mut insert = |editor: &mut Editor, block: usize, text: String| {
        if let Some(long) = text.lines().find(|l| l.len() > MAX_BLOCK) {
            return Err(TransformError::LongBlock(long.to_string()));
        }
        if let Some(value) = nc::find_unwritable(&text) {
            return Err(TransformError::Unwritable(value.to_string()));
        }
        inserted += text.lines().count();
        Ok(editor.insert_before(block, &text)?)
    };
    let pass_tool = |pass: usize| {
        timeline
            .passes
            .get(pass.wrapping_sub(1))
            .and_then(|p| p.tool.as_deref())
    };
    let header_at = timeline
        .header_end
        .min(program.block_count().saturating_sub(1));
    let shas: Vec<(&str, &str)> = models
        .iter()
        .map(|m| (m.model.channel.as_str(), m.sha256))
        .collect();
    insert(&mut editor, header_at, emitter.header(&shas))?;
    if let Some(text) = emitter.no_correction_yet() {
        insert(&mut editor, timeline.preamble_end, text)?;
    }
    let mut labels = Vec::new();
    let cut_rpm = plan
        .gates
        .iter()
        .map(|g| g.rpm)
        .find(|rpm| *rpm > 0.0)
        .unwrap_or(0.0);
    // The gates' texts are independent of each other (a large program has hundreds): written on all cores,
    // inserted in order.
    let texts: Vec<String> = {
        use rayon::prelude::*;
        plan.gates
            .par_iter()
            .map(|gate| match gate.kind {
                GateKind::Reference => emitter.reference(gate, pass_tool(gate.pass), cut_rpm),
                GateKind::Refresh => emitter.refresh(gate),
                _ => emitter.gate(gate, pass_tool(gate.pass)),
            })
            .collect()
    };
    for (gate, text) in plan.gates.iter().zip(texts) {
        let needs_tool = profile.probe.kind == ProbeKind::SpindleProbe
            && gate.can_measure
            && !gate.tool_change_follows;
        if needs_tool && gate.before.tool.is_none() && !plan::reads_tool(profile) {
            return Err(TransformError::UnknownTool(gate.number));
        }
        if gate.can_measure {
            labels.push(format!("{}SKIP{}", emitter.label_prefix, gate.number));
        }
        insert(&mut editor, gate.block, text)?;
    }
    let last_rpm = plan.gates.last().map_or(0.0, |g| g.rpm);
    for &end in &timeline.ends {
        let inch = timeline.inch_at.get(&end).copied();
        insert(&mut editor, end, emitter.end(last_rpm, inch))?;
    }
    if timeline.ends.is_empty() && timeline.unit_end > 0 {
        let last = &timeline.as_callee.end;
        let end = emitter.end(last_rpm, last.units.filter(|_| last.inch()));
        inserted += end.lines().count();
        editor.insert_after(timeline.unit_end - 1, &end)?;
    }
    for &b in timeline
        .offset_selections
        .iter()
        .filter(|&&b| b >= timeline.preamble_end)
    {
        if let Some(text) = emitter.reapply(timeline.inch_at.get(&b).copied()) {
            inserted += text.lines().count();
            editor.insert_after(b, &text)?;
        }
    }
    output_parses_as_the_input(program, &editor)?;
    Ok(Prepared {
        editor,
        summary: Summary {
            blocks_inserted: inserted,
            // A program without marked passes is one pass from the zero on.
            passes: timeline.passes.len().max(1),
            gates: plan.gates.len(),
            measurements_planned: plan.measurements,
            predicted_max_drift_um: plan.max_predicted_um,
            program_min: plan.total_min,
            r_parameters: regs.all(),
            labels,
            inexact_blocks: timeline.inexact_blocks,
            untimed_calls: timeline.untimed_calls.len(),
            // The warm-start store lies above the profile's range.
            r_parameters_needed: regs.all().last().map_or(0, |r| r + 1).max(
                profile
                    .warm_start
                    .as_ref()
                    .map_or(0, |w| w.r_first + emitter.store_len()),
            ),
            warnings: plan
                .warnings
                .iter()
                .cloned()
                .chain(other_mains(program))
                .collect(),
            notes: machine_m_note(&timeline, profile).into_iter().collect(),
        },
        plan,
    })
}

/// An archive of several main programs: the gates go into the first, the others stay as they are.
fn other_mains(program: &Program) -> Option<String> {
    let mains = program.main_sections();
    let [(_, first), others @ ..] = &mains[..] else {
        return None;
    };
    (!others.is_empty()).then(|| {
        let names: Vec<&str> = others.iter().map(|(_, n)| n.as_str()).collect();
        format!(
            "the archive holds {} main programs: gates go into the first, {first}; {} left as they are (transform each from a file of its own to gate it)",
            mains.len(),
            names.join(", ")
        )
    })
}

/// Each inserted text parses on its own when it is inserted, but a slip in how they nest (an ENDIF without
/// its IF, a label twice) shows only in the whole output, and the control would refuse that program at
/// its start: the output may have no syntax error the program lacks.
fn output_parses_as_the_input(
    program: &Program,
    editor: &Editor<'_>,
) -> Result<(), TransformError> {
    let mut known: Vec<&str> = program.errors().map(|d| d.message.as_str()).collect();
    let bytes = editor.to_bytes();
    let output = crate::parse(&bytes);
    for d in output.errors() {
        match known.iter().position(|m| *m == d.message) {
            Some(i) => {
                known.swap_remove(i);
            }
            None => {
                let (line, column) = crate::source::LineIndex::new(&bytes).line_col(d.span.start);
                return Err(TransformError::OutputSyntax {
                    line,
                    column,
                    message: d.message.clone(),
                });
            }
        }
    }
    Ok(())
}

/// The machine M-codes the program uses that a gate which moves leaves as they are: a coolant through the
/// spindle among them would go through the probe, and stay off for the tool after a probe swap, unless the
/// profile's `[coolant]` lists it.
fn machine_m_note(timeline: &Timeline, profile: &Profile) -> Option<String> {
    if timeline.machine_m.is_empty() || profile.probe.kind == ProbeKind::Gauge {
        return None;
    }
    let codes: Vec<String> = timeline.machine_m.iter().map(|m| format!("M{m}")).collect();
    Some(format!(
        "{} {} a gate leaves as {}: if one switches a coolant or air through the spindle, list its on/off pair in the profile's [coolant] codes (docs/profiles.md), so gates switch it off before they move and give it back",
        codes.join(", "),
        if codes.len() == 1 {
            "is a machine M-code"
        } else {
            "are machine M-codes"
        },
        if codes.len() == 1 {
            "it is"
        } else {
            "they are"
        }
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_with_a_nesting_slip_is_refused() {
        let program = crate::parse(b"G0 X1\nG1 X2 F100\nM30\n");
        let mut editor = Editor::new(&program);
        editor.insert_before(1, "IF R1==0\nG0 Z5\nENDIF\n").unwrap();
        assert!(output_parses_as_the_input(&program, &editor).is_ok());
        // Each line parses as a block on its own; the ENDIF has no IF in the output.
        editor.insert_before(2, "ENDIF\n").unwrap();
        match output_parses_as_the_input(&program, &editor) {
            Err(TransformError::OutputSyntax { line, .. }) => assert_eq!(line, 6),
            other => panic!("expected the output's syntax error, got {other:?}"),
        }
    }

    #[test]
    fn the_programs_own_syntax_errors_are_not_the_outputs() {
        let program = crate::parse(b"G0 X1\nENDIF\nM30\n");
        assert!(program.has_errors());
        let mut editor = Editor::new(&program);
        editor.insert_before(2, "G0 Z5\n").unwrap();
        assert!(output_parses_as_the_input(&program, &editor).is_ok());
    }
}
