//! The interpreter: executes blocks one after the other, like the control's text cursor, with control
//! structures resolved through the structure pass and jumps searched at run time in their direction.
//! `control` runs control structures and jumps, `statements` the statements of a plain block, `calls`
//! subprogram calls and built-in procedures, `apply` what a block does to the machine.

mod apply;
mod calls;
mod control;
mod eval;
mod external;
mod statements;
mod sync;

use std::cell::RefCell;
use std::collections::{BTreeSet, HashMap};
use std::path::PathBuf;
use std::rc::Rc;

use crate::syntax::{BlockKind, Node, NodeKind};

use super::VmError;
use super::config::{Config, ProbeTarget};
use super::cycle_extent::Arg;
use super::machine::{Machine, ProbeCall, ProbeResult, SpindleHistory};
use super::motion::{
    ArcSpec, Dim, FeedMode, IDENTITY, Matrix, SPINDLES, SPLINE, Saved, State, Tool, arc_length,
    is_thread, multiply, rotation, setting,
};
use super::passes::{Cut, PassTracker};
use super::polynomial::{self, AxisCurve, POLY};
use super::report::{
    Alarm, At, Correction, End, Measurement, Message, Run, TempCompWrite, Totals, TraceRow,
};
use super::unit::{JumpTarget, Unit};
use super::value::{Value, VarType, Variable};
use eval::{R_COUNT, index_nodes};

#[derive(Clone)]
pub(super) struct Frame {
    unit: Rc<Unit>,
    pc: usize,
    pub(super) vars: HashMap<String, Variable>,
    /// End value of each active FOR loop, by its block.
    for_ends: HashMap<usize, f64>,
    /// Active section repetitions (`REPEAT`), innermost last.
    sections: Vec<Section>,
    /// Further passes of a subprogram called with `P n`, and the arguments to bind again.
    repeats_left: u32,
    args: Vec<Option<Value>>,
    saved: Option<Saved>,
    /// `VAR` parameters: written back into the caller's variable on return.
    write_back: Vec<(String, Ref)>,
    /// `MCALL NAME`: the subprogram this program calls after each of its blocks that moves, until `MCALL`
    /// alone.
    modal_call: Option<(String, CallArgs)>,
    /// This program runs as such a modal call (`$P_MC`).
    called_modally: bool,
}

type CallArgs = Vec<Option<Value>>;

/// A program's local variables, and its `VAR` parameters with the argument position each is bound to.
type Bound = (HashMap<String, Variable>, Vec<(String, usize)>);

/// A program section being repeated: blocks `start..=end`, `left` more passes, then on at `resume`.
#[derive(Debug, Clone, Copy)]
struct Section {
    start: usize,
    end: usize,
    left: u32,
    resume: usize,
}

/// A caller's variable passed to a `VAR` parameter.
#[derive(Debug, Clone)]
enum Ref {
    R(usize),
    Var(String, Vec<usize>),
}

enum Flow {
    Next,
    Jump(usize),
    Call {
        unit: Rc<Unit>,
        args: Vec<Option<Value>>,
        refs: Vec<Option<Ref>>,
        repeats: u32,
        /// Called by `MCALL` after a move.
        modally: bool,
    },
    Return,
    End(End),
}

/// Everything one block asks for, collected in statement order and applied together.
#[derive(Default)]
struct Words {
    g: Vec<u32>,
    axes: Vec<(usize, Dim, f64)>,
    feed: Option<f64>,
    s: Option<f64>,
    m: Vec<u32>,
    tool: Option<Tool>,
    d: Option<f64>,
    /// `RPL=`: rotation in the working plane (ROT / AROT).
    rpl: Option<f64>,
    stopre: bool,
    /// I, J, K (index 0..3) and whether given as AC().
    centre: [Option<(f64, bool)>; 3],
    cr: Option<f64>,
    /// `TURN=`: full turns a helix makes before its end point.
    turn: Option<f64>,
    /// `LIMS=`: the speed limit under constant cutting speed.
    lims: Option<f64>,
    frame_command: Option<String>,
    suppress_frames: bool,
    call: Option<(String, CallArgs, Vec<Option<Ref>>)>,
    /// The call's arguments given but not evaluated (a cycle's symbolic argument where missing calls are
    /// skipped): `true` at their positions.
    call_unknown: Vec<bool>,
    /// `MCALL NAME(…)` (`Some(Some(…))`) or `MCALL` alone, which ends the modal call (`Some(None)`).
    modal_call: Option<Option<(String, CallArgs)>>,
    repeat: Option<u32>,
    jump: Option<usize>,
    probe: Option<(String, Vec<Option<f64>>)>,
    alarm: Option<(i64, Option<String>)>,
    ret: bool,
    /// BSPLINE / ASPLINE / CSPLINE.
    spline: bool,
    /// `REPEAT` section (first block, last block) to run `P` times.
    section: Option<(usize, usize)>,
    /// `DL=`: the sum offset.
    dl: Option<f64>,
    /// `TCARR=`: the orientable toolholder.
    tool_carrier: Option<f64>,
    /// `OFFN=`.
    offn: Option<f64>,
    /// `SPOS=`, `SPOSA=`, `SPOS[n]=`: spindle (1 = master) and angle (NaN: not known).
    spos: Vec<(usize, f64)>,
    /// `Sn=` and `Mn=` of spindles other than the master: (spindle, value).
    other_s: Vec<(usize, f64)>,
    other_m: Vec<(usize, u32)>,
    /// `ID=n` (false) or `IDS=n` (true) before a synchronized action.
    sync_id: Option<(u32, bool)>,
    /// `FP=n` of G75: the fixed point (1 … 4) its axes go to.
    fixed_point: Option<u32>,
    /// Orientation words (`A3=`, `LEAD=`, …) under TRAORI.
    orientation: Vec<(&'static str, f64)>,
    /// POLY: polynomial interpolation from this block on.
    poly: bool,
    /// `PO[axis]=(end, a2 …)`: the coefficients a2 … a5 of each axis given so.
    poly_coefficients: Vec<(usize, [f64; 4])>,
    /// `PL=`: the parameter interval of a polynomial (or a spline) block.
    pl: Option<f64>,
}

/// Frame commands that take axis values; the bare form of an absolute one deletes the programmable frame.
const ABSOLUTE_FRAMES: &[&str] = &["TRANS", "ROT", "SCALE", "MIRROR"];

pub(super) struct Interp<'m> {
    pub(super) cfg: &'m Config,
    machine: &'m mut dyn Machine,
    pub(super) r: Vec<f64>,
    /// Global variables: the probe result array (`_OVR`).
    pub(super) globals: HashMap<String, Variable>,
    pub(super) stack: Vec<Frame>,
    pub(super) motion: State,
    pub(super) time_min: f64,
    spindle: SpindleHistory,
    passes: PassTracker,
    /// Machine coordinate of each probed axis's surface, fixed at its first probing
    /// ([`Config::probe_surface_at_first_probing`]).
    surfaces_at_first_probing: std::collections::BTreeMap<String, f64>,
    run: Run,
    listings: HashMap<PathBuf, HashMap<String, PathBuf>>,
    loaded: HashMap<PathBuf, Rc<Unit>>,
    /// Units of archive files, by (file, first block).
    archive_units: HashMap<(usize, usize), Rc<Unit>>,
    /// How the run ended, once it has.
    ended: Option<End>,
    /// What the block being executed did, for [`Interp::step`].
    done: Done,
    /// External variables ([`external`]) the program wrote, by key.
    written: HashMap<String, f64>,
    /// External variables the block being executed read as 0 (nothing gave them a value).
    assumed: RefCell<Vec<String>>,
    /// What the run has noted as assumed already.
    noted: BTreeSet<String>,
    /// The tools the program selected by name, for `$TC_TP2[number]` (a gate reads the name of the tool
    /// in force to load it again after the probe).
    pub(super) named_tools: Vec<Rc<str>>,
}

/// What one executed block did, as far as a caller watching the run block by block needs to know.
#[derive(Debug, Clone, Default)]
pub(in crate::vm) struct Done {
    /// The move it made, if any.
    pub movement: Option<Movement>,
    pub stopre: bool,
    /// It called a probe cycle.
    pub probe: bool,
    /// It changed the tool (M6).
    pub tool_change: bool,
    /// It called a subprogram.
    pub call: bool,
    /// A call it skipped as doing nothing (a cycle the dry run cannot find), with its arguments.
    pub skipped: Option<SkippedCall>,
    /// M0, M1, M2 or M30.
    pub stop: Option<u32>,
    /// It ended the run (program end or alarm).
    pub end: Option<End>,
}

/// A call the dry run skipped: what it knows of the arguments, for what the cycle would have machined.
#[derive(Debug, Clone)]
pub(in crate::vm) struct SkippedCall {
    pub name: String,
    pub args: Vec<Arg>,
    /// Called by `MCALL` after a move.
    pub modally: bool,
    /// The call `MCALL` made modal where this one is no modal call itself: what a hole pattern calls at
    /// each of its positions.
    pub under: Option<(String, Vec<Arg>)>,
}

impl SkippedCall {
    fn new(
        name: &str,
        args: &[Option<Value>],
        unknown: &[bool],
        modally: bool,
        under: Option<&(String, CallArgs)>,
    ) -> SkippedCall {
        let read = |args: &[Option<Value>], unknown: &[bool]| {
            args.iter()
                .enumerate()
                .map(|(k, v)| match v {
                    Some(Value::Num(n)) => Arg::Num(*n),
                    Some(Value::Str(_)) => Arg::Text,
                    None if unknown.get(k).copied().unwrap_or(false) => Arg::Unknown,
                    None => Arg::Omitted,
                })
                .collect()
        };
        SkippedCall {
            name: name.to_string(),
            args: read(args, unknown),
            modally,
            under: under.map(|(n, a)| (n.clone(), read(a, &[]))),
        }
    }
}

/// A move: its motion mode and the geometry axes X, Y, Z before and after it, programmed positions in the
/// coordinates of the settable work offset ([`State::work_geometry`]).
#[derive(Debug, Clone, Copy)]
pub(in crate::vm) struct Movement {
    pub motion: u32,
    pub from: [f64; 3],
    pub to: [f64; 3],
    /// Circles: centre in the same coordinates (its infeed coordinate is that of the start).
    pub centre: Option<[f64; 3]>,
    /// The working plane's axes (first, second, infeed) as positions among X, Y, Z.
    pub plane: [Option<usize>; 3],
}

/// The axes of G17, G18 and G19 in their order: abscissa, ordinate, applicate (the tool axis).
const PLANES: [[&str; 3]; 3] = [["X", "Y", "Z"], ["Z", "X", "Y"], ["Y", "Z", "X"]];

fn err_at(u: &Unit, i: usize, message: impl Into<String>) -> VmError {
    VmError {
        file: u.name.to_string(),
        line: i + 1,
        message: message.into(),
    }
}

impl<'m> Interp<'m> {
    pub(super) fn new(cfg: &'m Config, machine: &'m mut dyn Machine) -> Self {
        let axes = cfg.axes.len();
        let mut motion = State::new(axes);
        for (frame, axis, v) in &cfg.offsets {
            if let Some(a) = cfg.axes.iter().position(|x| x == axis) {
                motion.frames.table[*frame][a] = *v;
            }
        }
        motion.frames.mark_initial();
        if let Some(t) = &cfg.start_tool {
            motion.tool = Some(t.tool());
            motion.preselected = motion.tool.clone();
            motion.d = t.d;
        }
        if let Some(sp) = &cfg.start_spindle {
            motion.s = sp.rpm;
            motion.rotation = sp.direction;
        }
        for (a, name) in cfg.axes.iter().enumerate() {
            motion.temp_comp[a] = cfg.temp_comp_start.get(name).copied().unwrap_or(0.0);
        }
        motion
            .frames
            .select(cfg.reset_frame.min(super::motion::FRAMES - 1));
        motion.frames.trans_is_correction = cfg.trans_is_correction;
        motion.frames.geo = ["X", "Y", "Z"].map(|g| cfg.axes.iter().position(|a| a == g));
        Interp {
            cfg,
            machine,
            r: {
                let mut r = cfg.r_initial.clone();
                r.resize(R_COUNT, 0.0);
                r
            },
            globals: match &cfg.probe_result {
                ProbeTarget::Array(name, index) => HashMap::from([(
                    name.clone(),
                    Variable::new(VarType::Real, vec![(index + 1).max(32)]),
                )]),
                ProbeTarget::R(_) => HashMap::new(),
            },
            stack: Vec::new(),
            motion,
            time_min: 0.0,
            spindle: SpindleHistory::default(),
            passes: PassTracker::default(),
            surfaces_at_first_probing: std::collections::BTreeMap::new(),
            run: Run::empty(cfg.axes.clone()),
            listings: HashMap::new(),
            loaded: HashMap::new(),
            archive_units: HashMap::new(),
            ended: None,
            done: Done::default(),
            written: HashMap::new(),
            assumed: RefCell::default(),
            noted: BTreeSet::new(),
            named_tools: Vec::new(),
        }
    }

    pub(super) fn run(mut self, main: Unit) -> Result<Run, VmError> {
        self.start(main)?;
        while self.step()?.is_some() {}
        Ok(self.finish())
    }

    /// Makes `main` the program to run.
    pub(super) fn start(&mut self, main: Unit) -> Result<(), VmError> {
        self.run.program = main.name.to_string();
        self.global_user_data(&main)?;
        let main = Rc::new(main);
        let (vars, _) = self
            .bind_params(&main, &[])
            .map_err(|e| err_at(&main, main.start, e))?;
        self.stack.push(Frame {
            pc: main.start,
            unit: main,
            vars,
            for_ends: HashMap::new(),
            sections: Vec::new(),
            repeats_left: 0,
            args: Vec::new(),
            saved: None,
            write_back: Vec::new(),
            modal_call: None,
            called_modally: false,
        });
        Ok(())
    }

    /// The calls the running block is inside, outermost first: each caller's unit and its call block.
    pub(in crate::vm) fn callers(&self) -> impl Iterator<Item = (&Unit, usize)> {
        let below_top = self.stack.len().saturating_sub(1);
        self.stack[..below_top]
            .iter()
            .map(|f| (f.unit.as_ref(), f.pc.saturating_sub(1)))
    }

    /// How many programs are running: 1 in the main program, one more in each subprogram called.
    pub(in crate::vm) fn depth(&self) -> usize {
        self.stack.len()
    }

    /// The block that runs next, after returning from subprograms that have run off their end; `None` once
    /// the run has ended.
    pub(super) fn peek(&mut self) -> Option<(Rc<Unit>, usize)> {
        if self.ended.is_some() {
            return None;
        }
        loop {
            let frame = self.stack.last()?;
            if frame.pc < frame.unit.end {
                return Some((frame.unit.clone(), frame.pc));
            }
            if self.ret().is_none() {
                self.ended = Some(End::EndOfProgram);
                return None;
            }
        }
    }

    /// Executes the next block (the one [`Interp::peek`] names) and tells what it did; `None` once the run
    /// has ended.
    pub(super) fn step(&mut self) -> Result<Option<Done>, VmError> {
        let Some((unit, pc)) = self.peek() else {
            return Ok(None);
        };
        self.run.blocks_executed += 1;
        let limit = self.cfg.max_blocks + self.stack[0].unit.end as u64;
        if self.run.blocks_executed > limit {
            return Err(err_at(
                &unit,
                pc,
                format!(
                    "iteration limit reached: {limit} executed blocks ({} more than the program has; \
                     endless loop?)",
                    self.cfg.max_blocks
                ),
            ));
        }
        self.done = Done::default();
        let flow = self.block(&unit, pc).map_err(|e| err_at(&unit, pc, e))?;
        if !self.assumed.get_mut().is_empty() {
            self.note_assumed(&unit, pc);
        }
        self.trace(&unit, pc);
        match flow {
            Flow::Next => self.top().pc = self.next_block(pc),
            Flow::Jump(to) => self.top().pc = to,
            Flow::Call {
                unit: callee,
                args,
                refs,
                repeats,
                modally,
            } => {
                self.done.call = true;
                self.top().pc = pc + 1;
                let (vars, by_ref) = self
                    .bind_params(&callee, &args)
                    .map_err(|e| err_at(&unit, pc, e))?;
                let mut write_back = Vec::new();
                for (name, k) in by_ref {
                    let target = refs.get(k).cloned().flatten().ok_or_else(|| {
                        err_at(
                            &unit,
                            pc,
                            format!("VAR parameter {name} needs a variable as argument"),
                        )
                    })?;
                    write_back.push((name, target));
                }
                let saved = calls::proc_has_save(&callee).then(|| self.motion.save());
                self.stack.push(Frame {
                    pc: callee.start,
                    unit: callee,
                    vars,
                    for_ends: HashMap::new(),
                    sections: Vec::new(),
                    repeats_left: repeats.saturating_sub(1),
                    args,
                    saved,
                    write_back,
                    modal_call: None,
                    called_modally: modally,
                });
            }
            Flow::Return => {
                if self.ret().is_none() {
                    self.ended = Some(End::ProgramEnd { code: "M17".into() });
                }
            }
            Flow::End(end) => self.ended = Some(end),
        }
        let mut done = std::mem::take(&mut self.done);
        done.end = self.ended.clone();
        Ok(Some(done))
    }

    /// The run's outcome (passes closed, the spindle stopped at the end).
    pub(super) fn finish(mut self) -> Run {
        self.passes.end_segment();
        self.spindle.set(self.time_min, 0.0);
        let mut run = self.run;
        run.end = self.ended.unwrap_or(End::EndOfProgram);
        run.time_min = self.time_min;
        run.passes = self.passes.passes;
        run.totals = Totals::of(&run.passes);
        run.spindle = self.spindle;
        run.r_final = self.r;
        run
    }

    /// A copy of this run at this point that carries on against `machine`, as if the program had been run
    /// on it from the start: to follow a branch (an abort) the run itself does not take. Its report starts
    /// empty and its spindle schedule holds only the present speed.
    pub(super) fn fork<'f>(&self, machine: &'f mut dyn Machine) -> Interp<'f>
    where
        'm: 'f,
    {
        let mut spindle = SpindleHistory::default();
        spindle.set(self.time_min, self.motion.spindle_rpm());
        Interp {
            cfg: self.cfg,
            machine,
            r: self.r.clone(),
            globals: self.globals.clone(),
            stack: self.stack.clone(),
            motion: self.motion.clone(),
            time_min: self.time_min,
            spindle,
            passes: PassTracker::default(),
            surfaces_at_first_probing: self.surfaces_at_first_probing.clone(),
            run: Run {
                program: self.run.program.clone(),
                blocks_executed: self.run.blocks_executed,
                ..Run::empty(self.cfg.axes.clone())
            },
            listings: self.listings.clone(),
            loaded: self.loaded.clone(),
            archive_units: self.archive_units.clone(),
            ended: self.ended.clone(),
            done: Done::default(),
            written: self.written.clone(),
            assumed: RefCell::default(),
            noted: self.noted.clone(),
            named_tools: self.named_tools.clone(),
        }
    }

    /// What the run has recorded so far (measurements, corrections, alarms, blocks executed).
    pub(super) fn report(&self) -> &Run {
        &self.run
    }

    /// How the run ended, once it has.
    pub(super) fn ended(&self) -> Option<&End> {
        self.ended.as_ref()
    }

    /// The machine's drift along `axis` now (µm).
    pub(super) fn drift_now(&mut self, axis: &str) -> f64 {
        self.machine.drift_um(axis, self.time_min, &self.spindle)
    }

    /// Whether block `i` of `u` calls one of the configured probe cycles.
    pub(super) fn calls_probe(&self, u: &Unit, i: usize) -> bool {
        u.root(i)
            .significant()
            .filter(|n| n.kind == NodeKind::Call)
            .any(|n| self.cfg.probe_cycles.contains(&u.upper(&n.children[0])))
    }

    /// The block after `pc`, or the start of the next pass of a repeated section that ends at `pc`.
    fn next_block(&mut self, pc: usize) -> usize {
        let frame = self.top();
        match frame.sections.last_mut() {
            Some(s) if s.end == pc && s.left > 0 => {
                s.left -= 1;
                s.start
            }
            Some(s) if s.end == pc => {
                let resume = s.resume;
                frame.sections.pop();
                resume
            }
            _ => pc + 1,
        }
    }

    /// Counts an auxiliary function output to the PLC (no effect in the dry run).
    pub(super) fn aux(&mut self, name: String) {
        *self.run.aux_functions.entry(name).or_default() += 1;
    }

    /// How far the temperature compensation moves axis `a` now (mm): the change of SD43900 since the start,
    /// where MD32750 bit 0 switches it on. It acts in the machine axis, under SUPA/G53 too, and the actual
    /// value the control reports (and a probe reads) does not contain it.
    pub(super) fn temp_comp_shift(&self, a: usize) -> f64 {
        let name = &self.cfg.axes[a];
        if self.cfg.temp_comp_type(name) & 1 == 0 {
            return 0.0;
        }
        self.motion.temp_comp[a] - self.cfg.temp_comp_start.get(name).copied().unwrap_or(0.0)
    }

    pub(super) fn machine_input(&self, n: usize) -> Option<f64> {
        self.machine.analog_input(n, self.time_min)
    }

    fn top(&mut self) -> &mut Frame {
        self.stack.last_mut().expect("a frame while running")
    }

    /// Leaves the current subprogram (or starts its next `P` pass). `None` in the main program.
    fn ret(&mut self) -> Option<()> {
        if self.stack.len() == 1 {
            return None;
        }
        let frame = self.top();
        if frame.repeats_left > 0 {
            frame.repeats_left -= 1;
            frame.pc = frame.unit.start;
            frame.for_ends.clear();
            frame.sections.clear();
            let (unit, args) = (frame.unit.clone(), frame.args.clone());
            // Binding succeeded on the first pass with the same arguments.
            if let Ok((vars, _)) = self.bind_params(&unit, &args) {
                self.top().vars = vars;
            }
            return Some(());
        }
        let frame = self.stack.pop().expect("checked above");
        if let Some(saved) = frame.saved {
            self.motion.restore(saved);
        }
        for (name, target) in frame.write_back {
            let Some(v) = frame.vars.get(&name).and_then(|v| v.get(&[]).ok()) else {
                continue;
            };
            match target {
                Ref::R(i) => self.r[i] = v.num().unwrap_or(f64::NAN),
                Ref::Var(var, index) => {
                    if let Some(caller) = self.top().vars.get_mut(&var) {
                        // The caller's type converts as on any assignment; a mismatch leaves it unchanged.
                        let _ = caller.set(&index, v);
                    }
                }
            }
        }
        Some(())
    }

    fn at(&self, u: &Unit, i: usize) -> At {
        At {
            file: u.name.to_string(),
            line: i + 1,
            time_min: self.time_min,
        }
    }

    fn trace(&mut self, u: &Unit, i: usize) {
        if !self.cfg.trace {
            return;
        }
        self.run.trace.push(TraceRow {
            file: u.name.clone(),
            line: i + 1,
            block_number: u.number(i),
            time_min: self.time_min,
            spindle_rpm: self.motion.spindle_rpm(),
            programmed: self.motion.local.clone(),
            machine: self.motion.machine.clone(),
            moved_axes: self.motion.moved,
        });
    }
}

/// The parser's first diagnostic on block `i`.
fn first_message(u: &Unit, i: usize) -> Option<String> {
    let span = u.program.block_span(i);
    u.program
        .diagnostics()
        .iter()
        .find(|d| d.span.start >= span.start && d.span.start < span.end.max(span.start + 1))
        .map(|d| d.message.clone())
}
