//! The interpreter: executes blocks one after the other, like the control's text cursor, with control
//! structures resolved through the structure pass and jumps searched at run time in their direction.
//! `control` runs control structures and jumps, `statements` the statements of a plain block, `calls`
//! subprogram calls and built-in procedures, `apply` what a block does to the machine.

mod apply;
mod calls;
mod control;
mod statements;

use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;
use std::rc::Rc;

use crate::syntax::{BlockKind, Node, NodeKind};

use super::VmError;
use super::config::{Config, ProbeTarget};
use super::eval::{R_COUNT, arg_nodes, index_nodes};
use super::machine::{Machine, ProbeCall, ProbeResult, SpindleHistory};
use super::motion::{ArcSpec, Dim, SPLINE, Saved, State, arc_length};
use super::passes::{Cut, PassTracker};
use super::report::{Alarm, At, Correction, End, Measurement, Message, Run, Totals, TraceRow};
use super::unit::{JumpTarget, Unit};
use super::value::{Value, VarType, Variable};

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
    tool: Option<f64>,
    d: Option<f64>,
    /// I, J, K (index 0..3) and whether given as AC().
    centre: [Option<(f64, bool)>; 3],
    cr: Option<f64>,
    frame_command: Option<String>,
    suppress_frames: bool,
    call: Option<(String, CallArgs, Vec<Option<Ref>>)>,
    repeat: Option<u32>,
    jump: Option<usize>,
    probe: Option<(String, Vec<Option<f64>>)>,
    alarm: Option<(i64, Option<String>)>,
    ret: bool,
    /// BSPLINE / ASPLINE / CSPLINE.
    spline: bool,
    /// `REPEAT` section (first block, last block) to run `P` times.
    section: Option<(usize, usize)>,
}

const MM_PER_INCH: f64 = 25.4;

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
    run: Run,
    listings: HashMap<PathBuf, HashMap<String, PathBuf>>,
    loaded: HashMap<PathBuf, Rc<Unit>>,
    /// Units of archive files, by (file, first block).
    archive_units: HashMap<(usize, usize), Rc<Unit>>,
}

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
        motion.frames.trans_is_correction = cfg.trans_is_correction;
        Interp {
            cfg,
            machine,
            r: vec![0.0; R_COUNT],
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
            run: Run {
                program: String::new(),
                end: End::EndOfProgram,
                blocks_executed: 0,
                time_min: 0.0,
                axes: cfg.axes.clone(),
                passes: Vec::new(),
                totals: Totals::default(),
                measurements: Vec::new(),
                corrections: Vec::new(),
                alarms: Vec::new(),
                messages: Vec::new(),
                aux_functions: BTreeMap::new(),
                files: BTreeMap::new(),
                spindle: SpindleHistory::default(),
                trace: Vec::new(),
            },
            listings: HashMap::new(),
            loaded: HashMap::new(),
            archive_units: HashMap::new(),
        }
    }

    pub(super) fn run(mut self, main: Unit) -> Result<Run, VmError> {
        self.run.program = main.name.to_string();
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
        });
        let limit = self.cfg.max_blocks + self.stack[0].unit.end as u64;
        let end = loop {
            let frame = self.stack.last().expect("a frame while running");
            let (unit, pc) = (frame.unit.clone(), frame.pc);
            if pc >= unit.end {
                match self.ret() {
                    Some(()) => continue,
                    None => break End::EndOfProgram,
                }
            }
            self.run.blocks_executed += 1;
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
            let flow = self.block(&unit, pc).map_err(|e| err_at(&unit, pc, e))?;
            self.trace(&unit, pc);
            match flow {
                Flow::Next => self.top().pc = self.next_block(pc),
                Flow::Jump(to) => self.top().pc = to,
                Flow::Call {
                    unit: callee,
                    args,
                    refs,
                    repeats,
                } => {
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
                    });
                }
                Flow::Return => {
                    if self.ret().is_none() {
                        break End::ProgramEnd { code: "M17".into() };
                    }
                }
                Flow::End(end) => break end,
            }
        };
        self.passes.end_segment();
        self.spindle.set(self.time_min, 0.0);
        let mut run = self.run;
        run.end = end;
        run.time_min = self.time_min;
        run.passes = self.passes.passes;
        run.totals = Totals::of(&run.passes);
        run.spindle = self.spindle;
        Ok(run)
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
            block_number: u.numbers[i],
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
