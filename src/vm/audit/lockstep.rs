//! The two runs side by side: the transformed run executes its inserted blocks (checked as they go), then
//! both execute the same original block; the states are compared where the original resumes and at the end.
//! Before a gate's first probe call, `aborts` follows the abort paths the clean run does not take.

mod aborts;

use std::rc::Rc;

use super::state::{self, Correction, Difference};
use super::{Audit, AuditSettings, Finding, Kind, cycles, geometry};
use crate::omm::nc::shown as num;
use crate::vm::VmError;
use crate::vm::config::Config;
use crate::vm::interp::{Done, Interp, Movement, SkippedCall};
use crate::vm::motion::{SPLINE, Tool, is_thread};
use crate::vm::polynomial::POLY;
use crate::vm::report::End;
use crate::vm::unit::{Source, Unit};

/// Which blocks of the transformed program were inserted, and which original block each other one is.
pub(super) struct Lines {
    /// 0-based inserted blocks, ascending.
    inserted: Vec<usize>,
    /// The transformed program's own file.
    main: Rc<Source>,
}

/// A block as both runs can name it: a block of the original program (by its index there) or of a
/// subprogram file (by file and index), or a block driftloop inserted.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Key {
    Inserted,
    Main(usize),
    Other(Rc<str>, usize),
}

impl Lines {
    pub(super) fn key(&self, unit: &Unit, block: usize) -> Key {
        if !Rc::ptr_eq(&unit.source, &self.main) {
            return Key::Other(unit.source.file.clone(), block);
        }
        match self.inserted.binary_search(&block) {
            Ok(_) => Key::Inserted,
            Err(before) => Key::Main(block - before),
        }
    }
}

impl Lines {
    /// The key of the transformed run's next block, `block` of `unit`: a block of a subprogram an inserted
    /// block called (a gate's tool change through the program's `L6`) is inserted too.
    pub(super) fn key_in(&self, t: &Interp<'_>, unit: &Unit, block: usize) -> Key {
        if t.callers().any(|(u, b)| self.key(u, b) == Key::Inserted) {
            Key::Inserted
        } else {
            self.key(unit, block)
        }
    }
}

fn original_key(main: &Rc<Source>, unit: &Unit, block: usize) -> Key {
    if Rc::ptr_eq(&unit.source, main) {
        Key::Main(block)
    } else {
        Key::Other(unit.source.file.clone(), block)
    }
}

/// Where a finding points: the transformed program's line (or a subprogram's) and the original line.
#[derive(Debug, Clone)]
pub(super) struct At {
    pub line: usize,
    pub file: Option<String>,
    pub original_line: Option<usize>,
}

impl At {
    pub(super) fn of(lines: &Lines, unit: &Unit, block: usize) -> At {
        let main = Rc::ptr_eq(&unit.source, &lines.main);
        At {
            line: block + 1,
            file: (!main).then(|| unit.name.to_string()),
            original_line: match lines.key(unit, block) {
                Key::Main(i) => Some(i + 1),
                Key::Other(_, i) => Some(i + 1),
                Key::Inserted => None,
            },
        }
    }

    pub(super) fn finding(&self, kind: Kind, message: String) -> Finding {
        Finding {
            kind,
            line: self.line,
            message,
            original_line: self.original_line,
            file: self.file.clone(),
            times: 1,
        }
    }
}

/// What the checks remember from block to block of the transformed run.
#[derive(Default)]
struct Watch {
    /// Line of the probe call the tool is still at (no move since).
    at_probe: Option<usize>,
    /// The last move was a feed move of the original under continuous path that did not leave the contour
    /// upwards.
    in_contour: bool,
    /// An inserted STOPRE executed inside a continuous-path contour, waiting for the next original move.
    stopre: Option<At>,
    /// The probe point was found in the machined volume (reported once).
    machined: bool,
    /// The milling cycles whose region is not known, reported (once each).
    unknown_cycles: std::collections::BTreeSet<String>,
    /// Inserted STOPREs and offset writes that ran under a transformation: the finding, with the kinds that
    /// were active, waiting for the machine to move while one of them still is.
    under_transform: Vec<(At, String, Vec<&'static str>)>,
    /// An inserted block ran where the original's modal motion is a thread or tap (reported once until the
    /// original runs on).
    in_thread: bool,
}

pub(super) fn run(
    original: Vec<u8>,
    transformed: Vec<u8>,
    settings: &AuditSettings,
    cfg: &Config,
) -> Result<Audit, VmError> {
    let mut audit = Audit::default();
    let found = crate::strip::inserted(&transformed);
    if let Some(finding) = changed_line(&transformed, &found, &original) {
        audit.add(finding);
        return Ok(audit);
    }
    let t_unit = Unit::new(
        settings.transformed_name.clone(),
        None,
        crate::parse_owned(transformed),
    );
    let o_unit = Unit::new(
        settings.original_name.clone(),
        None,
        crate::parse_owned(original),
    );
    let lines = Lines {
        inserted: found.lines,
        main: t_unit.source.clone(),
    };
    let o_main = o_unit.source.clone();
    let (mut t_machine, mut o_machine) = (
        settings.machine.build(settings.seed),
        settings.machine.build(settings.seed),
    );
    let mut t = Interp::new(cfg, &mut t_machine);
    let mut o = Interp::new(cfg, &mut o_machine);
    t.start(t_unit)?;
    o.start(o_unit)?;
    let mut runner = Runner {
        settings,
        lines,
        o_main,
        audit,
        watch: Watch::default(),
        last: None,
        pending: None,
        over_call: None,
        abort_paths_followed: std::collections::HashMap::new(),
    };
    runner.lockstep(&mut t, &mut o)?;
    let mut audit = runner.audit;
    // What the dry run assumed of the original (the transformed run assumed the same).
    audit.notes.extend(
        o.report()
            .assumptions
            .iter()
            .map(|m| format!("{}:{}: {}", m.at.file, m.at.line, m.text)),
    );
    audit.transformed_blocks = t.report().blocks_executed;
    audit.original_blocks = o.report().blocks_executed;
    Ok(audit)
}

/// The first line where the transformed program without its inserted lines differs from the original,
/// compared without building that program.
fn changed_line(
    transformed: &[u8],
    found: &crate::strip::Inserted,
    original: &[u8],
) -> Option<Finding> {
    let mut pos = 0;
    let mut differs_at = None;
    for run in crate::strip::kept(transformed, found) {
        let part = &transformed[run];
        let theirs = &original[pos.min(original.len())..];
        if !theirs.starts_with(part) {
            differs_at = Some(pos + part.iter().zip(theirs).take_while(|(a, b)| a == b).count());
            break;
        }
        pos += part.len();
    }
    if differs_at.is_none() && pos != original.len() {
        differs_at = Some(pos);
    }
    let at = differs_at?;
    let k = crate::source::raw_lines(original)
        .take_while(|l| l.end <= at)
        .count();
    // The transformed line of original line k: each inserted line at or before it moves it down one.
    let mut line = k;
    for &r in &found.lines {
        if r > line {
            break;
        }
        line += 1;
    }
    Some(Finding {
        kind: Kind::OriginalChanged,
        line: line + 1,
        message: format!(
            "without its ;DL lines the transformed program differs from the original at original line {}: a \
             transform may only insert lines; nothing else was compared",
            k + 1
        ),
        original_line: Some(k + 1),
        file: None,
        times: 1,
    })
}

/// A resume point whose first acting original block calls a subprogram. Where both runs change tools in
/// it (a tool-change subprogram such as `L6`, which the program calls right after a gate that left the
/// probe in the spindle and the program's tool preselected), the states are compared when it returns, as
/// at the program's own M6: its change puts the preselected tool in and goes to the change position from
/// wherever the gate left the machine. Otherwise its first block that acts is judged as for any resume
/// point.
struct OverCall {
    resume: At,
    before: [Vec<Difference>; 3],
    /// The stack depth of the calling block.
    depth: usize,
    tool_changed: bool,
    /// The findings at the subprogram's first block that acts.
    first_inner: Option<Vec<Finding>>,
}

/// How often the abort paths of one probe call are followed.
const ABORT_PATH_RUNS: u32 = 3;

pub(super) struct Runner<'a> {
    pub settings: &'a AuditSettings,
    pub lines: Lines,
    o_main: Rc<Source>,
    pub audit: Audit,
    watch: Watch,
    /// The transformed run's last executed block, and whether it was an inserted one.
    last: Option<(At, bool)>,
    /// A resume point whose comparison waits for the first original block that acts.
    pending: Option<At>,
    /// A resume point whose first acting block called a subprogram: judged when it returns.
    over_call: Option<OverCall>,
    /// How often the abort paths of each probe call (file, line) were followed.
    abort_paths_followed: std::collections::HashMap<(Option<String>, usize), u32>,
}

impl Runner<'_> {
    pub(super) fn add(&mut self, finding: Finding) {
        self.audit.add(finding);
    }

    fn lockstep(&mut self, t: &mut Interp<'_>, o: &mut Interp<'_>) -> Result<(), VmError> {
        loop {
            let resumed = self.inserted_run(t, o)?;
            let t_next = t.peek();
            let o_next = o.peek();
            let (t_unit, t_block) = match (t_next, o_next) {
                (None, None) => {
                    self.close_pending(t, o);
                    self.at_end(t, o);
                    return Ok(());
                }
                (None, Some((ou, ob))) => {
                    self.close_pending(t, o);
                    self.wrong_tool_at_stop(t, o);
                    self.ended_early(&ou, ob);
                    return Ok(());
                }
                (Some((tu, tb)), None) => {
                    let at = At::of(&self.lines, &tu, tb);
                    self.add(at.finding(
                        Kind::FlowChanged,
                        format!(
                            "the transformed program runs on here while the original has ended ({})",
                            describe_end(o.ended())
                        ),
                    ));
                    return Ok(());
                }
                (Some((tu, tb)), Some((ou, ob))) => {
                    let (tk, ok) = (
                        self.lines.key_in(t, &tu, tb),
                        original_key(&self.o_main, &ou, ob),
                    );
                    if tk != ok {
                        let at = At::of(&self.lines, &tu, tb);
                        self.add(at.finding(
                            Kind::FlowChanged,
                            format!(
                                "the transformed program runs {} next where the original runs {}: the inserted \
                                 blocks changed the flow of the original's blocks; nothing after this was compared",
                                describe_key(&tk),
                                describe_key(&ok)
                            ),
                        ));
                        return Ok(());
                    }
                    (tu, tb)
                }
            };
            let at = At::of(&self.lines, &t_unit, t_block);
            if resumed {
                self.audit.resume_points += 1;
                self.pending = Some(at.clone());
            }
            let first_inner = self
                .over_call
                .as_ref()
                .is_some_and(|c| c.first_inner.is_none());
            let before = (self.pending.is_some() || first_inner).then(|| self.differences(t, o));
            let depth = t.depth();
            let t_step = t.step()?.expect("peeked");
            let o_step = o.step()?.expect("peeked");
            // A tool change takes both machines to the change position, wherever each stood before: from
            // here on their positions are the same again (the virtual machine's M6 does not move).
            if t_step.tool_change && o_step.tool_change {
                t.motion.local.clone_from(&o.motion.local);
                t.motion.machine.clone_from(&o.motion.machine);
            }
            let acting = acts(&t_step) || acts(&o_step);
            if let Some(resume) = self.pending.take_if(|_| acting) {
                let before = before.expect("compared before the step");
                let enters = t_step.call && o_step.call && t.depth() > depth;
                if enters && t_step.movement.is_none() && !t_step.tool_change {
                    self.over_call = Some(OverCall {
                        resume,
                        before,
                        depth,
                        tool_changed: false,
                        first_inner: None,
                    });
                } else {
                    let after = self.differences(t, o);
                    self.report_resume(&resume, before, &after, Some(&t_step));
                }
            } else if self.over_call.is_some() {
                self.within_call(t, o, (&t_step, &o_step), before.filter(|_| acting));
            }
            self.original_step(&at, (&t_step, &o_step), t, o);
            self.last = Some((at, false));
        }
    }

    /// Runs the transformed program's inserted blocks up to the next original block; `true` if it ran any.
    fn inserted_run(&mut self, t: &mut Interp<'_>, o: &Interp<'_>) -> Result<bool, VmError> {
        let mut ran = false;
        let mut forked = false;
        while let Some((unit, block)) = t.peek() {
            if self.lines.key_in(t, &unit, block) != Key::Inserted {
                break;
            }
            if !ran {
                self.close_pending(t, o);
            }
            ran = true;
            let at = At::of(&self.lines, &unit, block);
            let probe_call = t.calls_probe(&unit, block);
            if probe_call {
                self.probe_in_spindle(&at, t);
            }
            if !forked && probe_call {
                forked = true;
                // A gate in a loop runs its abort paths from the same code each time: following them the
                // first few times checks them, following them on every run costs a fork of the whole
                // run per run (quadratic in a long or endless loop).
                let runs = self
                    .abort_paths_followed
                    .entry((at.file.clone(), at.line))
                    .or_insert(0);
                *runs += 1;
                if *runs <= ABORT_PATH_RUNS {
                    aborts::follow(self, t, o)?;
                }
            }
            let corrections = t.report().corrections.len();
            let trans = t.motion.frames.trans.clone();
            let step = t.step()?.expect("peeked");
            let wrote_offset =
                t.report().corrections.len() > corrections || t.motion.frames.trans != trans;
            self.inserted_step(&at, &step, t, o, wrote_offset);
            self.last = Some((at, true));
        }
        Ok(ran)
    }

    /// A spindle probe's cycle runs with the probe in the spindle: a gate whose swap loaded another tool
    /// (or none: a tool-change subprogram called without the argument that names the tool) would drive
    /// that tool, or the bare spindle, onto the part.
    fn probe_in_spindle(&mut self, at: &At, t: &Interp<'_>) {
        let Some(probe) = &self.settings.probe_tool else {
            return;
        };
        if !is_the_probe(&t.motion.tool, probe) {
            self.add(at.finding(
                Kind::ToolState,
                format!(
                    "the probe cycle runs with {} in the spindle, not the probe {probe}",
                    state::tool_text(&t.motion.tool)
                ),
            ));
        }
    }

    /// Checks one executed inserted block.
    fn inserted_step(
        &mut self,
        at: &At,
        step: &Done,
        t: &Interp<'_>,
        o: &Interp<'_>,
        wrote_offset: bool,
    ) {
        let done = step;
        let acts = done.movement.is_some()
            || done.probe
            || done.stopre
            || wrote_offset
            || done.tool_change
            || done.stop.is_some();
        let motion = o.motion.modal.motion;
        if acts && is_thread(motion) && !self.watch.in_thread {
            self.watch.in_thread = true;
            self.add(at.finding(
                Kind::GateInThread,
                format!(
                    "inserted blocks run where the original's modal motion is G{motion} (thread cutting or \
                     tapping): the tool may stand in the thread, and the gate retracts it or stops the spindle there"
                ),
            ));
        }
        if let Some(m) = &done.movement {
            self.moved(t);
            // A gate moves under no rotation, scale or mirror: a machine coordinate is the work
            // coordinate plus the settable offset in force.
            let frames = &t.motion.frames;
            let retract = frames.geo[self.settings.retract_axis];
            let to_machine = retract.map_or(0.0, |a| frames.active[a]);
            // `G0 SUPA Z0` / `G153 Z0`: the tool axis at its machine zero, the reference point at the top
            // of travel on a Siemens mill, where a tool-change macro travels (a side changer's `SUPA
            // X-450`); the dry run's machine coordinates equal its work coordinates at offset 0.
            let at_machine_top =
                retract.is_some_and(|a| {
                    t.motion.suppressed & (1 << a) != 0 && t.motion.machine[a] >= -geometry::EPS
                }) && (m.to[self.settings.retract_axis] - m.from[self.settings.retract_axis]).abs()
                    <= geometry::EPS;
            self.inserted_move(at, m, to_machine, at_machine_top);
            self.watch.in_contour = false;
            self.watch.stopre = None;
            self.moves_under_sync_actions(at, t);
        }
        if done.tool_change {
            self.watch.in_contour = false;
        }
        let what = match (done.probe, done.stopre, wrote_offset) {
            (true, _, _) => Some("the probe cycle call"),
            (_, true, _) => Some("STOPRE"),
            (_, _, true) => Some("the work-offset write"),
            _ => None,
        };
        let active = what.map(|_| state::transforms_active(&t.motion));
        if let (Some(what), Some(active)) = (what, active)
            && !active.is_empty()
        {
            let texts: Vec<&str> = active.iter().map(|a| a.1.as_str()).collect();
            let message = format!("{what} runs while {} is active", texts.join(", "));
            if done.probe {
                self.add(at.finding(Kind::MeasureUnderTransform, message));
            } else {
                // A STOPRE or an offset write under a transformation matters once the machine moves under
                // it; before the program's end, whose reset ends a TRAORI or a swivel, nothing moves.
                let kinds = active.iter().map(|a| a.0).collect();
                self.watch
                    .under_transform
                    .push((at.clone(), message, kinds));
            }
        }
        if done.stopre && self.watch.in_contour {
            self.watch.stopre = Some(at.clone());
        }
        if done.probe {
            self.watch.at_probe = Some(at.line);
        }
        if done.stop.is_some() || done.end.is_some() {
            self.offset_on_stop(at, step, t, o);
        }
    }

    /// The machine moves: a STOPRE or offset write waiting under a transformation of a kind still active is
    /// a finding; one whose transformation has ended since is none.
    fn moved(&mut self, t: &Interp<'_>) {
        if self.watch.under_transform.is_empty() {
            return;
        }
        let now: Vec<&str> = state::transforms_active(&t.motion)
            .iter()
            .map(|a| a.0)
            .collect();
        for (at, message, kinds) in std::mem::take(&mut self.watch.under_transform) {
            if kinds.iter().any(|k| now.contains(k)) {
                self.add(at.finding(Kind::MeasureUnderTransform, message));
            }
        }
    }

    /// An inserted move while a modal or static synchronized action is active: the dry run does not check
    /// its condition, so the note says the action could fire on the gate's moves.
    fn moves_under_sync_actions(&mut self, at: &At, t: &Interp<'_>) {
        for &(n, is_static, line) in &t.motion.sync_actions {
            let id = format!("{}={n}", if is_static { "IDS" } else { "ID" });
            if self
                .audit
                .notes
                .iter()
                .any(|note| note.contains(&format!("action {id} of")))
            {
                continue;
            }
            self.audit.notes.push(format!(
                "the synchronized action {id} of line {line} is active while inserted blocks move (first at \
                 line {}): the dry run does not check its condition; make sure the gates' moves cannot \
                 trigger its action",
                at.line
            ));
        }
    }

    /// Travel across the tool axis below the clearance height (work coordinates) or below the start point
    /// of a reference in machine coordinates (the work coordinate plus `to_machine`), and the move out of
    /// the probe point: straight up the tool axis, or — where the probe left the tool at the travel height
    /// (a reference's start point the gate came to at that height) — across at it.
    fn inserted_move(&mut self, at: &At, m: &Movement, to_machine: f64, at_machine_top: bool) {
        let s = self.settings;
        let r = s.retract_axis;
        let low = m.from[r].min(m.to[r]);
        let across: Vec<usize> = (0..3).filter(|&k| k != r).collect();
        let point = |p: [f64; 3]| {
            across
                .iter()
                .map(|&k| format!("{}{}", AXES[k], num(p[k])))
                .collect::<Vec<_>>()
                .join(" ")
        };
        let travels = geometry::moves_across(m, r);
        let below_clearance = low < s.clearance - geometry::EPS && !at_machine_top;
        if travels && below_clearance {
            self.add(at.finding(
                Kind::XyBelowClearance,
                format!(
                    "travel from {} to {} at {}{} below the clearance height {}{} ([position] clearance)",
                    point(m.from),
                    point(m.to),
                    AXES[r],
                    num(low),
                    AXES[r],
                    num(s.clearance)
                ),
            ));
        }
        let below_reference = s
            .reference_start
            .filter(|start| low + to_machine < start - geometry::EPS);
        if let Some(start) = below_reference.filter(|_| travels) {
            self.add(at.finding(
                Kind::XyBelowClearance,
                format!(
                    "travel from {} to {} at {}{} (machine coordinates) below the reference's start point {}{} (machine coordinates) under the work offset in force",
                    point(m.from),
                    point(m.to),
                    AXES[r],
                    num(low + to_machine),
                    AXES[r],
                    num(start)
                ),
            ));
        }
        // A move that goes nowhere (a retract to where the probe left the tool) is not the move out.
        if geometry::stands_still(m) {
            return;
        }
        let level_at_travel_height = travels
            && (m.to[r] - m.from[r]).abs() <= geometry::EPS
            && !below_clearance
            && below_reference.is_none();
        if let Some(probe_line) = self.watch.at_probe.take()
            && !geometry::straight_up(m, r)
            && !level_at_travel_height
        {
            let point = |p: [f64; 3]| format!("X{} Y{} Z{}", num(p[0]), num(p[1]), num(p[2]));
            self.add(at.finding(
                Kind::XyBelowClearance,
                format!(
                    "the move out of the probe point (probe call at line {probe_line}) is not straight up the \
                     tool axis {}: from {} to {}",
                    AXES[r],
                    point(m.from),
                    point(m.to)
                ),
            ));
        }
    }

    /// An inserted stop or alarm: the persistent corrected offset must be back where the original has it.
    pub(super) fn offset_on_stop(&mut self, at: &At, step: &Done, t: &Interp<'_>, o: &Interp<'_>) {
        let Some(left) = persistent_left(t, o) else {
            return;
        };
        let what = match (&step.end, step.stop) {
            (Some(End::Alarm { number }), _) => format!("alarm {number} stops the program"),
            (_, Some(m)) => format!("M{m} stops the program"),
            (Some(_), None) => "the program ends".to_string(),
            (None, None) => return,
        };
        self.add(at.finding(Kind::OffsetLeftOnAbort, format!("{what} {left}")));
    }

    /// Tool state, modal state and positions of the two runs, item by item.
    fn differences(&self, t: &Interp<'_>, o: &Interp<'_>) -> [Vec<Difference>; 3] {
        let axes = &t.cfg.axes;
        let (ts, os) = (&t.motion, &o.motion);
        // A gate goes back to where an axis is, in the frame of the corrections so far: the programmed
        // position may differ by as much as the corrections have moved that axis's offset, no more.
        let corrected: Vec<f64> = axes
            .iter()
            .map(|name| {
                t.report()
                    .corrections
                    .iter()
                    .filter(|c| c.axis == *name)
                    .map(|c| (c.new_mm - c.old_mm).abs())
                    .sum()
            })
            .collect();
        [
            state::tools(ts, os),
            state::modal(ts, os, self.settings, axes),
            state::positions(ts, os, axes, &corrected),
        ]
    }

    /// A resume point whose original blocks did nothing before the next inserted ones or the end: its
    /// differences are reported as they are (a call still running: as at its return).
    fn close_pending(&mut self, t: &Interp<'_>, o: &Interp<'_>) {
        if let Some(resume) = self.pending.take() {
            let now = self.differences(t, o);
            self.report_resume(&resume, now.clone(), &now, None);
        }
        if let Some(call) = self.over_call.take() {
            self.returned(call, t, o);
        }
    }

    /// A step inside the call of an [`OverCall`]: a tool change in both runs, the findings at its first
    /// block that acts (`before` it, given when the step acts and none were taken yet), its return.
    fn within_call(
        &mut self,
        t: &Interp<'_>,
        o: &Interp<'_>,
        (t_step, o_step): (&Done, &Done),
        before: Option<[Vec<Difference>; 3]>,
    ) {
        let Some(mut call) = self.over_call.take() else {
            return;
        };
        call.tool_changed |= t_step.tool_change && o_step.tool_change;
        if let Some(before) = before {
            let after = self.differences(t, o);
            call.first_inner =
                Some(self.resume_findings(&call.resume, before, &after, Some(t_step)));
        }
        if t.depth() <= call.depth {
            self.returned(call, t, o);
        } else {
            self.over_call = Some(call);
        }
    }

    /// The judgement of an [`OverCall`] once its call has returned (or the run ended inside it).
    fn returned(&mut self, call: OverCall, t: &Interp<'_>, o: &Interp<'_>) {
        let found = match (call.tool_changed, call.first_inner) {
            (false, Some(found)) => found,
            (changed, _) => {
                let now = self.differences(t, o);
                let change = Done {
                    tool_change: changed,
                    ..Done::default()
                };
                self.resume_findings(&call.resume, call.before, &now, Some(&change))
            }
        };
        for f in found {
            self.add(f);
        }
    }

    /// Reports the differences where the original resumes, judged at the first original block after it
    /// that acts (moves, calls, changes the tool, stops): `before` and `after` that block. A tool or modal
    /// item the block sets itself before it can matter (a tool change, a G code, F or S of its own) differs
    /// before but not after: it is no hazard. A position difference is none when the block is a rapid that
    /// ends where the original's does and travels across the tool axis (if at all) at or above the clearance
    /// height — the way back the design allows — or a tool change, whose macro goes to the change position.
    fn report_resume(
        &mut self,
        at: &At,
        before: [Vec<Difference>; 3],
        after: &[Vec<Difference>; 3],
        t_step: Option<&Done>,
    ) {
        for f in self.resume_findings(at, before, after, t_step) {
            self.add(f);
        }
    }

    /// The findings [`Runner::report_resume`] reports.
    fn resume_findings(
        &self,
        at: &At,
        before: [Vec<Difference>; 3],
        after: &[Vec<Difference>; 3],
        t_step: Option<&Done>,
    ) -> Vec<Finding> {
        let mut found = Vec::new();
        let [tools, modal, positions] = before;
        for (kind, before, after) in [
            (Kind::ToolState, tools, &after[0]),
            (Kind::ModalNotRestored, modal, &after[1]),
        ] {
            let lasting: Vec<String> = before
                .into_iter()
                .filter(|d| after.iter().any(|a| a.what == d.what))
                .map(|d| d.text)
                .collect();
            if !lasting.is_empty() {
                found.push(at.finding(
                    kind,
                    format!("where the original resumes: {}", lasting.join("; ")),
                ));
            }
        }
        let (r, clearance) = (self.settings.retract_axis, self.settings.clearance);
        let rapid_back = after[2].is_empty()
            && t_step.and_then(|d| d.movement.as_ref()).is_some_and(|m| {
                m.motion == 0
                    && (!geometry::moves_across(m, r)
                        || m.from[r].min(m.to[r]) >= clearance - geometry::EPS)
            });
        // A tool change takes the machine to the change position, wherever it stood.
        let way_back = rapid_back || t_step.is_some_and(|d| d.tool_change);
        if !positions.is_empty() && !way_back {
            let texts: Vec<String> = positions.into_iter().map(|d| d.text).collect();
            found.push(at.finding(
                Kind::PositionNotRestored,
                format!("where the original resumes: {}", texts.join("; ")),
            ));
        }
        found
    }

    /// Checks on a block both runs executed: the probe point against the original's cutting moves, and a
    /// STOPRE waiting for the next move of the contour.
    fn original_step(
        &mut self,
        at: &At,
        (t_step, o_step): (&Done, &Done),
        t: &Interp<'_>,
        o: &Interp<'_>,
    ) {
        self.watch.in_thread = false;
        if let Some(m) = &t_step.movement {
            self.moved(t);
            let feed = is_feed(m.motion);
            if let Some(stopre) = self.watch.stopre.take()
                && feed
            {
                self.add(stopre.finding(
                    Kind::StopreInContour,
                    format!(
                        "STOPRE stops the path between two feed moves of a continuous-path contour (G{}): the \
                         tool dwells on the contour until line {} moves on",
                        o.motion.modal.path, at.line
                    ),
                ));
            }
            // The path mode of the move decides how it ends: under G60 it stops anyway.
            self.watch.in_contour = feed
                && is_continuous(o.motion.modal.path)
                && !geometry::straight_up(m, self.settings.retract_axis);
            self.watch.at_probe = None;
        }
        if t_step.tool_change {
            self.watch.in_contour = false;
            self.watch.stopre = None;
        }
        let Some(point) = self.settings.probe_point else {
            return;
        };
        // A point on the machine table, in the work coordinates the original cuts in at this block.
        let frames = &o.motion.frames;
        let work = if self.settings.probe_point_in_machine {
            std::array::from_fn(|k| point[k] - frames.geo[k].map_or(0.0, |a| frames.offset(a)))
        } else {
            point
        };
        if let Some(m) = &o_step.movement
            && is_feed(m.motion)
        {
            self.cut_near_probe(at, o, work, |s, work| {
                geometry::touches(m, work, s.axis, s.probe_margin_mm)
                    .then(|| "this cutting move passes".to_string())
            });
        }
        if let Some(call) = &o_step.skipped {
            self.cycle_near_probe(at, call, o, work);
        }
    }

    /// A milling cycle the dry run skipped: the region it machines against the probe point, as a cutting
    /// move's path; a region it cannot know is reported once per cycle name where a spindle probe touches
    /// the part.
    fn cycle_near_probe(&mut self, at: &At, call: &SkippedCall, o: &Interp<'_>, work: [f64; 3]) {
        let Some(region) = cycles::machined(call, &o.motion) else {
            return;
        };
        let name = &call.name;
        match region {
            Ok(boxes) => self.cut_near_probe(at, o, work, |s, work| {
                let b = boxes
                    .iter()
                    .find(|b| geometry::box_touches(b, work, s.axis, s.probe_margin_mm))?;
                let extent: Vec<String> = (0..3)
                    .map(|k| format!("{}{}…{}", AXES[k], num(b.lo[k]), num(b.hi[k])))
                    .collect();
                Some(format!(
                    "{name} machines {} (its region as a box), which comes",
                    extent.join(" ")
                ))
            }),
            Err(why) => {
                if !self.settings.spindle_probe || !self.watch.unknown_cycles.insert(name.clone()) {
                    return;
                }
                let point = self.probe_point_text();
                self.add(at.finding(
                    Kind::MachinedVolumeUnknown,
                    format!(
                        "the region {name} machines is not known here ({why}): the probe point ({point}) is not \
                         checked against it; make sure the probe does not touch a face it machines"
                    ),
                ));
            }
        }
    }

    /// The probe point against what the original machines at a block, while its spindle turns: `near`
    /// says, given the point in the block's work coordinates, what passes within the margin of it. Reported
    /// once per program.
    fn cut_near_probe(
        &mut self,
        at: &At,
        o: &Interp<'_>,
        work: [f64; 3],
        near: impl FnOnce(&AuditSettings, [f64; 3]) -> Option<String>,
    ) {
        let s = self.settings;
        if self.watch.machined || o.motion.spindle_rpm() <= 0.0 {
            return;
        }
        let Some(what) = near(s, work) else {
            return;
        };
        self.watch.machined = true;
        let (i, j) = geometry::plane_of(s.axis);
        let names = ["x", "y", "z"];
        self.add(at.finding(
            Kind::ProbeInMachinedVolume,
            format!(
                "{what} within {} mm of the probe point ({}): the probe would touch machined material; move it \
                 with [position] {}, {} in the profile",
                num(s.probe_margin_mm),
                self.probe_point_text(),
                names[i],
                names[j]
            ),
        ));
    }

    /// The probe point as the profile gives it: `X0 Y0 at Z0`.
    fn probe_point_text(&self) -> String {
        let s = self.settings;
        let Some(point) = s.probe_point else {
            return String::new();
        };
        let (i, j) = geometry::plane_of(s.axis);
        format!(
            "{}{} {}{} at {}{}{}",
            AXES[i],
            num(point[i]),
            AXES[j],
            num(point[j]),
            AXES[s.axis],
            num(point[s.axis]),
            if s.probe_point_in_machine {
                ", machine coordinates"
            } else {
                ""
            }
        )
    }

    /// Both programs ended: the tool in the spindle and the persistent offset.
    fn at_end(&mut self, t: &Interp<'_>, o: &Interp<'_>) {
        let (ts, os) = (&t.motion, &o.motion);
        let Some((at, _)) = self.last.clone() else {
            return;
        };
        if ts.tool != os.tool {
            let probe = (self.settings.probe_tool.as_ref())
                .is_some_and(|probe| is_the_probe(&ts.tool, probe));
            self.add(at.finding(
                Kind::ToolState,
                format!(
                    "at the end {} is in the spindle{}, the original leaves {}",
                    state::tool_text(&ts.tool),
                    if probe { " (the probe)" } else { "" },
                    state::tool_text(&os.tool)
                ),
            ));
        }
        if let Some(left) = persistent_left(t, o) {
            self.add(at.finding(Kind::OffsetLeftOnAbort, format!("the program ends {left}")));
        }
    }

    /// A gate's check of the tool it read at run time stopped the program: it loaded another tool or edge
    /// than the one it swapped the probe for. The check keeps the machine from cutting with it, but the gate
    /// is wrong.
    fn wrong_tool_at_stop(&mut self, t: &Interp<'_>, o: &Interp<'_>) {
        let Some(alarm) = self.settings.tool_alarm else {
            return;
        };
        let Some((at, true)) = self.last.clone() else {
            return;
        };
        if t.report().alarms.last().map(|a| a.number) != Some(i64::from(alarm)) {
            return;
        }
        let (ts, os) = (&t.motion, &o.motion);
        self.add(at.finding(
            Kind::ToolState,
            format!(
                "the inserted blocks stop the program (alarm {alarm}) with {} D{} in force where the original has {} D{}: the tool loaded after the probe is another than the one before it",
                state::tool_text(&ts.tool),
                crate::vm::value::format_number(ts.d),
                state::tool_text(&os.tool),
                crate::vm::value::format_number(os.d)
            ),
        ));
    }

    /// The transformed run ended while the original goes on: an abort in inserted blocks (the machine's
    /// probe values or its work offsets led to one), or a flow change.
    fn ended_early(&mut self, o_unit: &Unit, o_block: usize) {
        let Some((at, inserted)) = self.last.clone() else {
            return;
        };
        let continues = format!(
            "{}line {}",
            if Rc::ptr_eq(&o_unit.source, &self.o_main) {
                String::new()
            } else {
                format!("{} ", o_unit.name)
            },
            o_block + 1
        );
        if inserted {
            self.audit.stopped = Some(format!(
                "line {} (inserted) ended the transformed program on this machine's probe values or \
                 work offsets; the original from {continues} on was not compared",
                at.line
            ));
        } else {
            self.add(at.finding(
                Kind::FlowChanged,
                format!(
                    "the transformed program ended here while the original goes on at {continues}"
                ),
            ));
        }
    }
}

/// Whether a block does something the control state matters for.
fn acts(d: &Done) -> bool {
    d.movement.is_some()
        || d.call
        || d.tool_change
        || d.probe
        || d.stop.is_some()
        || d.end.is_some()
}

const AXES: [&str; 3] = ["X", "Y", "Z"];

fn is_feed(motion: u32) -> bool {
    matches!(motion, 1..=3 | SPLINE | POLY) || is_thread(motion)
}

fn is_continuous(path: u32) -> bool {
    matches!(path, 64 | 641..=645)
}

fn describe_key(key: &Key) -> String {
    match key {
        Key::Inserted => "an inserted block".into(),
        Key::Main(i) => format!("original line {}", i + 1),
        Key::Other(file, i) => format!("{file} line {}", i + 1),
    }
}

fn describe_end(end: Option<&End>) -> String {
    match end {
        Some(End::ProgramEnd { code }) => code.clone(),
        Some(End::Alarm { number }) => format!("alarm {number}"),
        Some(End::EndOfProgram) | None => "end of text".into(),
    }
}

/// What persists past a stop that the original would not leave: a settable work-offset entry, else the
/// temperature compensation.
fn persistent_left(t: &Interp<'_>, o: &Interp<'_>) -> Option<String> {
    let axes = &t.cfg.axes;
    state::persistent_difference(&t.motion.frames, &o.motion.frames, axes)
        .map(|entry| describe_entry(&entry))
        .or_else(|| state::temp_comp_difference(&t.motion, &o.motion, axes))
}

fn describe_entry(c: &Correction) -> String {
    format!(
        "with {} = {} mm where the original has {} mm: the work offset stays shifted",
        c.name(),
        num(c.transformed),
        num(c.original)
    )
}

/// The tool in the spindle is the probe the profile names (by name, or by number where the machine
/// selects tools by plain T numbers).
fn is_the_probe(tool: &Option<Tool>, probe: &str) -> bool {
    match tool {
        Some(Tool::Name(name)) => name.eq_ignore_ascii_case(probe.trim_matches('"')),
        Some(Tool::Number(n)) => probe.parse::<f64>() == Ok(*n),
        None => false,
    }
}
