//! The interpreter: executes blocks one after the other, like the control's text cursor, with control
//! structures resolved through the structure pass and jumps searched at run time in their direction.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::rc::Rc;

use crate::syntax::{BlockKind, Node, NodeKind};

use super::VmError;
use super::config::Config;
use super::eval::{R_COUNT, arg_nodes, index_nodes};
use super::machine::{Machine, ProbeCall, ProbeResult, SpindleHistory};
use super::motion::{ArcSpec, Dim, Saved, State, arc_length};
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
    /// `REPEAT` section (first block, last block) to run `P` times.
    section: Option<(usize, usize)>,
}

/// Commands that change nothing the dry run models (display, single block, acceleration and look-ahead modes,
/// the default feed profile; TRAFOOF because no kinematic transformation is modelled), accepted by name.
const NO_EFFECT_COMMANDS: &[&str] = &[
    "FNORM",
    "TRAFOOF",
    "STOPRE",
    "DISPLOF",
    "DISPLON",
    "SBLOF",
    "SBLON",
    "SOFT",
    "BRISK",
    "DRIVE",
    "FFWON",
    "FFWOF",
    "CFC",
    "CFTCP",
    "CFIN",
    "STOPFIFO",
    "STARTFIFO",
    "SAVE",
];

const MM_PER_INCH: f64 = 25.4;

/// Frame commands that take axis values; the bare form of an absolute one deletes the programmable frame.
const ABSOLUTE_FRAMES: &[&str] = &["TRANS", "ROT", "SCALE", "MIRROR"];

pub(super) struct Interp<'m> {
    pub(super) cfg: &'m Config,
    machine: &'m mut dyn Machine,
    pub(super) r: Vec<f64>,
    pub(super) stack: Vec<Frame>,
    pub(super) motion: State,
    pub(super) time_min: f64,
    spindle: SpindleHistory,
    passes: PassTracker,
    run: Run,
    listings: HashMap<PathBuf, HashMap<String, PathBuf>>,
    loaded: HashMap<PathBuf, Rc<Unit>>,
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
                    let saved = proc_has_save(&callee).then(|| self.motion.save());
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

    // ---- control structures ----

    fn block(&mut self, u: &Rc<Unit>, i: usize) -> Result<Flow, String> {
        let root = u.root(i);
        let kind = u.program.block_kind(i);
        if kind == BlockKind::Plain {
            return self.plain(u, i, &root);
        }
        let partner = |map: &HashMap<usize, usize>| {
            map.get(&i).copied().ok_or_else(|| {
                format!(
                    "this control keyword has no partner: {}",
                    first_message(u, i).unwrap_or("unbalanced structure".into())
                )
            })
        };
        let stmt = root
            .significant()
            .find(|c| {
                !matches!(
                    c.kind,
                    NodeKind::BlockNumber | NodeKind::Label | NodeKind::Skip
                )
            })
            .ok_or("control block without statement")?;
        match kind {
            BlockKind::If => {
                let cond = self.condition(u, stmt)?;
                if cond {
                    Ok(Flow::Next)
                } else {
                    let to = partner(&u.forward)?;
                    // IF → ELSE: continue after the ELSE; IF → ENDIF: after the ENDIF.
                    Ok(Flow::Jump(to + 1))
                }
            }
            BlockKind::Else => Ok(Flow::Jump(partner(&u.forward)? + 1)),
            BlockKind::EndIf | BlockKind::Repeat | BlockKind::Loop => Ok(Flow::Next),
            BlockKind::While => {
                if self.condition(u, stmt)? {
                    Ok(Flow::Next)
                } else {
                    Ok(Flow::Jump(partner(&u.forward)? + 1))
                }
            }
            BlockKind::EndWhile => Ok(Flow::Jump(partner(&u.backward)?)),
            BlockKind::Until => {
                if self.condition(u, stmt)? {
                    Ok(Flow::Next)
                } else {
                    Ok(Flow::Jump(partner(&u.backward)? + 1))
                }
            }
            BlockKind::EndLoop => Ok(Flow::Jump(partner(&u.backward)? + 1)),
            BlockKind::For => {
                let parts: Vec<&Node> = stmt.significant().collect();
                // FOR target = start TO end
                let [_, target, _, start, _, end] = parts[..] else {
                    return Err("FOR needs `FOR variable = start TO end`".into());
                };
                let (start, end) = (self.num(u, start)?, self.num(u, end)?);
                self.store(u, target, Value::Num(start), &mut Words::default())?;
                self.top().for_ends.insert(i, end);
                if start <= end {
                    Ok(Flow::Next)
                } else {
                    Ok(Flow::Jump(partner(&u.forward)? + 1))
                }
            }
            BlockKind::EndFor => {
                let open = partner(&u.backward)?;
                let opener = u.root(open);
                let parts: Vec<&Node> = opener
                    .significant()
                    .find(|c| c.kind == NodeKind::For)
                    .map(|f| f.significant().collect())
                    .unwrap_or_default();
                let target = parts.get(1).ok_or("FOR without variable")?;
                let end = *self
                    .top()
                    .for_ends
                    .get(&open)
                    .ok_or("ENDFOR reached without running its FOR")?;
                let next = self.num(u, target)? + 1.0;
                self.store(u, target, Value::Num(next), &mut Words::default())?;
                if next <= end {
                    Ok(Flow::Jump(open + 1))
                } else {
                    Ok(Flow::Next)
                }
            }
            BlockKind::Plain | BlockKind::Header => Ok(Flow::Next),
        }
    }

    /// The expression after IF / WHILE / UNTIL.
    fn condition(&mut self, u: &Unit, stmt: &Node) -> Result<bool, String> {
        let expr = stmt.significant().nth(1).ok_or("condition missing")?;
        self.eval(u, expr)?.truth()
    }

    fn jump_target(&self, u: &Unit, node: &Node) -> Result<JumpTarget, String> {
        let as_number = |s: &str| {
            s.strip_prefix('N')
                .or_else(|| s.strip_prefix(':'))
                .filter(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
                .and_then(|d| d.parse().ok())
        };
        match node.kind {
            NodeKind::Var if node.find(NodeKind::Index).is_none() => {
                let name = u.upper(node);
                Ok(as_number(&name).map_or(JumpTarget::Label(name), JumpTarget::Number))
            }
            NodeKind::Number => Ok(JumpTarget::Number(
                u.upper(node).parse().map_err(|_| "bad block number")?,
            )),
            _ => match self.eval(u, node)? {
                Value::Str(s) => {
                    let s = s.to_ascii_uppercase();
                    Ok(as_number(&s).map_or(JumpTarget::Label(s), JumpTarget::Number))
                }
                Value::Num(n) if n >= 0.0 && n.fract() == 0.0 => Ok(JumpTarget::Number(n as u64)),
                Value::Num(n) => Err(format!("jump target {n} is not a block number")),
            },
        }
    }

    /// Resolves a `Goto` node to the block to continue at (`None`: GOTOC without target, fall through).
    fn goto(&self, u: &Unit, i: usize, node: &Node) -> Result<Option<usize>, String> {
        let parts: Vec<&Node> = node.significant().collect();
        let keyword = u.upper(parts[0]);
        if keyword == "GOTOS" {
            // Restart happens only on a PLC request; without one the control carries on.
            return Ok(None);
        }
        let target = self.jump_target(u, parts.get(1).ok_or("jump without target")?)?;
        let (fwd, back) = match keyword.as_str() {
            "GOTOF" => (true, false),
            "GOTOB" => (false, true),
            _ => (true, true),
        };
        match u.search(i, &target, fwd, back) {
            Some(to) => Ok(Some(to)),
            None if keyword == "GOTOC" => Ok(None),
            None => Err(format!(
                "{keyword} {target}: jump target not found (alarm 14080)"
            )),
        }
    }

    /// `REPEAT start [end]` (from the start label to the end label, or to the block before the REPEAT) and
    /// `REPEATB label` (that one block). The start label is searched towards the beginning first.
    fn section(&self, u: &Unit, i: usize, node: &Node) -> Result<(usize, usize), String> {
        let parts: Vec<&Node> = node.significant().collect();
        let keyword = u.upper(parts[0]);
        let names: Vec<String> = parts[1..].iter().map(|n| u.upper(n)).collect();
        let find = |name: &str, from: usize| {
            let target = JumpTarget::Label(name.to_string());
            u.search(from, &target, false, true)
                .or_else(|| u.search(from, &target, true, false))
                .ok_or_else(|| format!("{keyword}: label {name} not found (alarm 14080)"))
        };
        let start = find(
            names.first().ok_or("REPEAT without a label")?,
            i.saturating_sub(1),
        )?;
        let end = match (keyword.as_str(), names.get(1)) {
            ("REPEATB", _) => start,
            (_, Some(end)) => {
                let target = JumpTarget::Label(end.clone());
                u.search(start.saturating_sub(1), &target, true, false)
                    .filter(|&e| e >= start)
                    .ok_or_else(|| {
                        format!("{keyword}: end label {end} not found after {}", names[0])
                    })?
            }
            (_, None) => i
                .checked_sub(1)
                .filter(|&e| e >= start)
                .ok_or("REPEAT section is empty")?,
        };
        if (start..=end).contains(&i) {
            return Err(format!("{keyword} would repeat itself"));
        }
        Ok((start, end))
    }

    fn case(&self, u: &Unit, i: usize, node: &Node) -> Result<Option<usize>, String> {
        let mut parts = node.significant();
        parts.next(); // CASE
        let selector = self.eval(u, parts.next().ok_or("CASE without expression")?)?;
        for arm in parts.filter(|p| p.kind == NodeKind::CaseArm) {
            let items: Vec<&Node> = arm.significant().collect();
            let (Some(head), Some(goto)) = (items.first(), items.last()) else {
                continue;
            };
            let hit = head.kind == NodeKind::Keyword
                || super::eval::binary("==", selector.clone(), self.eval(u, head)?)?.truth()?;
            if hit {
                return self.goto(u, i, goto);
            }
        }
        Ok(None)
    }

    // ---- plain blocks ----

    fn plain(&mut self, u: &Rc<Unit>, i: usize, root: &Node) -> Result<Flow, String> {
        let mut w = Words::default();
        let mut condition = true;
        for node in root.significant() {
            match node.kind {
                NodeKind::BlockNumber | NodeKind::Label | NodeKind::Skip | NodeKind::Header => {}
                NodeKind::Error => {
                    return Err(
                        first_message(u, i).unwrap_or_else(|| "the block cannot be parsed".into())
                    );
                }
                NodeKind::Word => self.word(u, node, &mut w)?,
                NodeKind::Assign => {
                    let parts: Vec<&Node> = node.significant().collect();
                    let [target, _, value] = parts[..] else {
                        return Err("malformed assignment".into());
                    };
                    self.assign(u, i, target, value, &mut w)?;
                }
                NodeKind::Call => self.call(u, i, node, &mut w)?,
                NodeKind::Command => self.command(u, node, &mut w)?,
                NodeKind::If => condition = self.condition(u, node)?,
                NodeKind::Goto if condition => {
                    w.jump = self.goto(u, i, node)?;
                }
                NodeKind::Goto => {}
                NodeKind::Case => w.jump = self.case(u, i, node)?,
                NodeKind::Def => self.def(u, node)?,
                // Parameters are bound when the program is called; EXTERN only declares a signature.
                NodeKind::Proc | NodeKind::Extern => {}
                NodeKind::ProgramCall => self.program_call(u, node, &mut w)?,
                NodeKind::Repeat => w.section = Some(self.section(u, i, node)?),
                k => {
                    return Err(format!(
                        "{} `{}` is not supported by the dry run",
                        k.name(),
                        String::from_utf8_lossy(u.text(node)).trim()
                    ));
                }
            }
        }
        self.apply(u, i, w)
    }

    fn word(&mut self, u: &Unit, node: &Node, w: &mut Words) -> Result<(), String> {
        let letter = u.upper(&node.children[0]);
        let value = super::eval::parse_number(&u.upper(&node.children[1]))?;
        let whole = || {
            if value >= 0.0 && value.fract() == 0.0 {
                Ok(value as u32)
            } else {
                Err(format!("{letter}{value} needs a whole number"))
            }
        };
        match letter.as_str() {
            "G" => w.g.push(whole()?),
            "M" => w.m.push(whole()?),
            "F" => w.feed = Some(value),
            "S" => w.s = Some(value),
            "T" => w.tool = Some(value),
            "D" => w.d = Some(value),
            "L" => w.call = Some((format!("L{}", whole()?), Vec::new(), Vec::new())),
            "P" => w.repeat = Some(whole()?),
            "I" | "J" | "K" => w.centre[ijk(&letter)] = Some((value, false)),
            _ => match self.axis_index(&letter) {
                Some(a) => w.axes.push((a, Dim::Modal, value)),
                None => return Err(format!("address {letter} is not supported by the dry run")),
            },
        }
        Ok(())
    }

    fn assign(
        &mut self,
        u: &Unit,
        i: usize,
        target: &Node,
        value: &Node,
        w: &mut Words,
    ) -> Result<(), String> {
        if target.kind == NodeKind::Var && target.find(NodeKind::Index).is_none() {
            let name = u.upper(target);
            if let Some(a) = self.axis_index(&name) {
                let (dim, v) = self.axis_value(u, value)?;
                w.axes.push((a, dim, v));
                return Ok(());
            }
            if self.variable(&name).is_none() && self.address(u, &name, value, w)? {
                return Ok(());
            }
        }
        if target.kind == NodeKind::SysVar {
            return self.write_sysvar(u, i, target, value);
        }
        let v = self.eval(u, value)?;
        self.store(u, target, v, w)
    }

    /// `NAME = value` where NAME is an address: F, S, S1, T, D, M, Mn, CR, I, J, K.
    fn address(
        &mut self,
        u: &Unit,
        name: &str,
        value: &Node,
        w: &mut Words,
    ) -> Result<bool, String> {
        match name {
            "F" => w.feed = Some(self.num(u, value)?),
            "S" | "S1" => w.s = Some(self.num(u, value)?),
            "D" => w.d = Some(self.num(u, value)?),
            "CR" => w.cr = Some(self.num(u, value)?),
            "T" => {
                w.tool = Some(match self.eval(u, value)? {
                    Value::Num(n) => n,
                    // A tool named by string: the dry run knows no tool table, only that one was selected.
                    Value::Str(_) => 0.0,
                })
            }
            "I" | "J" | "K" => w.centre[ijk(name)] = Some(self.centre_value(u, value)?),
            "M" => w.m.push(self.num(u, value)? as u32),
            "P" => {
                let p = self.num(u, value)?;
                if p < 1.0 || p.fract() != 0.0 {
                    return Err(format!("P={p}: repetitions must be a whole number ≥ 1"));
                }
                w.repeat = Some(p as u32);
            }
            _ if name.starts_with('M') && name[1..].bytes().all(|b| b.is_ascii_digit()) => {
                if &name[1..] != "1" {
                    return Err(format!("{name}=: only spindle 1 is modelled"));
                }
                w.m.push(self.num(u, value)? as u32);
            }
            _ if name.starts_with('S') && name[1..].bytes().all(|b| b.is_ascii_digit()) => {
                return Err(format!("{name}=: only spindle 1 is modelled"));
            }
            "PW" | "SD" | "PL" => {
                return Err(format!("{name}= (spline interpolation) is not supported"));
            }
            "AP" | "RP" => return Err(format!("{name}= (polar coordinates) is not supported")),
            _ => return Ok(false),
        }
        Ok(true)
    }

    fn centre_value(&self, u: &Unit, value: &Node) -> Result<(f64, bool), String> {
        let (dim, v) = self.axis_value(u, value)?;
        Ok((v, dim == Dim::Absolute))
    }

    /// `AC(v)`, `IC(v)` or a plain value.
    fn axis_value(&self, u: &Unit, value: &Node) -> Result<(Dim, f64), String> {
        if value.kind == NodeKind::FnCall {
            let name = u.upper(&value.children[0]);
            let dim = match name.as_str() {
                "AC" => Some(Dim::Absolute),
                "IC" => Some(Dim::Incremental),
                "DC" | "ACP" | "ACN" => {
                    return Err(format!(
                        "{name}() (rotary axis positioning) is not supported"
                    ));
                }
                _ => None,
            };
            if let Some(dim) = dim {
                let args = value
                    .find(NodeKind::Args)
                    .map(arg_nodes)
                    .unwrap_or_default();
                let [Some(arg)] = args[..] else {
                    return Err(format!("{name}() takes one value"));
                };
                return Ok((dim, self.num(u, arg)?));
            }
        }
        Ok((Dim::Modal, self.num(u, value)?))
    }

    /// Stores into an R parameter or a user variable.
    fn store(&mut self, u: &Unit, target: &Node, v: Value, w: &mut Words) -> Result<(), String> {
        match target.kind {
            NodeKind::RParam => {
                let i = self.r_index(u, target)?;
                self.r[i] = v.num()?;
                Ok(())
            }
            NodeKind::Var => {
                let name = u.upper(target.find(NodeKind::Name).ok_or("variable without name")?);
                let index = self.indices(u, target)?;
                let axis = self.axis_index(&name).filter(|_| index.is_empty());
                match (self.top().vars.get_mut(&name), axis) {
                    (Some(var), _) => var.set(&index, v),
                    (None, Some(a)) => {
                        w.axes.push((a, Dim::Modal, v.num()?));
                        Ok(())
                    }
                    (None, None) => Err(format!("variable {name} is not defined (alarm 12550)")),
                }
            }
            k => Err(format!("cannot assign to {}", k.name())),
        }
    }

    fn write_sysvar(
        &mut self,
        u: &Unit,
        i: usize,
        target: &Node,
        value: &Node,
    ) -> Result<(), String> {
        let name = u.upper(
            target
                .find(NodeKind::Name)
                .ok_or("system variable without name")?,
        );
        let idx: Vec<&Node> = target
            .find(NodeKind::Index)
            .map(index_nodes)
            .unwrap_or_default();
        match (name.as_str(), idx.as_slice()) {
            ("$P_UIFR", [frame, axis, part]) => {
                let (f, a, fine) = self.uifr_address(u, frame, axis, part)?;
                let new = self.num(u, value)?;
                let frames = &mut self.motion.frames;
                let slot = if fine {
                    &mut frames.fine[f][a]
                } else {
                    &mut frames.table[f][a]
                };
                let old = std::mem::replace(slot, new);
                self.run.corrections.push(Correction {
                    at: self.at(u, i),
                    frame: f,
                    component: if fine { "FI" } else { "TR" }.to_string(),
                    axis: self.cfg.axes[a].clone(),
                    old_mm: old,
                    new_mm: new,
                });
                Ok(())
            }
            _ => Err(format!("writing {name} is not supported by the dry run")),
        }
    }

    fn def(&mut self, u: &Unit, node: &Node) -> Result<(), String> {
        let mut ty = None;
        for c in node.significant() {
            match c.kind {
                NodeKind::Keyword => {
                    let word = u.upper(c);
                    if let Some(t) = VarType::from_keyword(&word) {
                        ty = Some(t);
                    } else if matches!(word.as_str(), "AXIS" | "FRAME") {
                        return Err(format!("DEF {word} variables are not supported"));
                    }
                }
                NodeKind::Declarator => {
                    let ty = ty.ok_or("DEF without a type")?;
                    self.declare(u, ty, c)?;
                }
                _ => {}
            }
        }
        Ok(())
    }

    fn declare(&mut self, u: &Unit, ty: VarType, d: &Node) -> Result<(), String> {
        let name = u.upper(d.find(NodeKind::Name).ok_or("declarator without name")?);
        let dims: Vec<usize> = match d.find(NodeKind::Index) {
            Some(ix) => index_nodes(ix)
                .into_iter()
                .map(|e| {
                    let v = self.num(u, e)?;
                    if v >= 1.0 && v.fract() == 0.0 {
                        Ok(v as usize)
                    } else {
                        Err(format!("array size {v} must be a whole number ≥ 1"))
                    }
                })
                .collect::<Result<_, String>>()?,
            None => Vec::new(),
        };
        let mut var = Variable::new(ty, dims);
        let init = d
            .significant()
            .skip_while(|c| !(c.kind == NodeKind::Punct && u.text(c) == b"="))
            .nth(1);
        if let Some(init) = init {
            self.initialise(u, &mut var, init)?;
        }
        self.top().vars.insert(name, var);
        Ok(())
    }

    /// `= value`, `= SET(a, , c)`, `= (a, b)`, `= REP(v [, n])`.
    fn initialise(&self, u: &Unit, var: &mut Variable, init: &Node) -> Result<(), String> {
        let fn_name = (init.kind == NodeKind::FnCall).then(|| u.upper(&init.children[0]));
        let list = match (init.kind, fn_name.as_deref()) {
            (NodeKind::Args, _) => Some(arg_nodes(init)),
            (NodeKind::FnCall, Some("SET")) => init.find(NodeKind::Args).map(arg_nodes),
            (NodeKind::FnCall, Some("REP")) => {
                let args = init.find(NodeKind::Args).map(arg_nodes).unwrap_or_default();
                let (v, n) = match args[..] {
                    [Some(v)] => (self.eval(u, v)?, var.data.len()),
                    [Some(v), Some(n)] => (self.eval(u, v)?, self.num(u, n)? as usize),
                    _ => return Err("REP takes a value and an optional count".into()),
                };
                let v = var.ty.convert(v)?;
                for slot in var.data.iter_mut().take(n) {
                    *slot = v.clone();
                }
                return Ok(());
            }
            _ => None,
        };
        match list {
            Some(items) => {
                if items.len() > var.data.len() {
                    return Err(format!(
                        "{} initial values for {} elements",
                        items.len(),
                        var.data.len()
                    ));
                }
                for (slot, item) in var.data.iter_mut().zip(items) {
                    if let Some(item) = item {
                        *slot = var.ty.convert(self.eval(u, item)?)?;
                    }
                }
                Ok(())
            }
            None if var.dims.is_empty() => var.set(&[], self.eval(u, init)?),
            None => Err("an array is initialised with SET(…) or REP(…)".into()),
        }
    }

    // ---- calls ----

    fn call(&mut self, u: &Unit, i: usize, node: &Node, w: &mut Words) -> Result<(), String> {
        let name = u.upper(&node.children[0]);
        let args = node.find(NodeKind::Args).map(arg_nodes).unwrap_or_default();
        let mut values = Vec::with_capacity(args.len());
        for a in &args {
            values.push(match a {
                Some(a) => Some(self.eval(u, a)?),
                None => None,
            });
        }
        let refs = args
            .iter()
            .map(|a| a.and_then(|a| self.reference(u, a)))
            .collect();
        match name.as_str() {
            "MSG" => {
                if let Some(Some(v)) = values.first() {
                    let text = v.text();
                    let at = self.at(u, i);
                    self.run.messages.push(Message { at, text });
                }
            }
            "SETAL" => {
                let number = match values.first() {
                    Some(Some(v)) => v.num()? as i64,
                    _ => return Err("SETAL needs an alarm number".into()),
                };
                let text = values.get(1).and_then(|v| v.as_ref()).map(Value::text);
                w.alarm = Some((number, text));
            }
            "WRITE" => {
                let ([Some(status), Some(_), Some(_)], [_, Some(file), Some(line)]) =
                    (&args[..], &values[..])
                else {
                    return Err("WRITE needs (status variable, file, text)".into());
                };
                let (file, line) = (file.text(), line.text());
                let content = self.run.files.entry(file.to_ascii_uppercase()).or_default();
                content.push_str(&line);
                content.push('\n');
                self.store(u, status, Value::Num(0.0), w)?;
            }
            // Master spindle 1 is the only spindle; CYCLE800() without values resets the swivel plane.
            "SETMS"
                if values
                    .iter()
                    .all(|v| v.as_ref().is_none_or(|v| *v == Value::Num(1.0))) => {}
            "CYCLE800" if values.iter().all(Option::is_none) => {}
            _ if self.cfg.probe_cycles.contains(&name) => {
                let nums = values
                    .iter()
                    .map(|v| v.as_ref().and_then(|v| v.num().ok()))
                    .collect();
                w.probe = Some((name, nums));
            }
            _ => w.call = Some((name, values, refs)),
        }
        Ok(())
    }

    /// The variable an argument names, if it is one (for `VAR` parameters).
    fn reference(&self, u: &Unit, arg: &Node) -> Option<Ref> {
        match arg.kind {
            NodeKind::RParam => self.r_index(u, arg).ok().map(Ref::R),
            NodeKind::Var => {
                let name = u.upper(arg.find(NodeKind::Name)?);
                self.variable(&name)?;
                Some(Ref::Var(name, self.indices(u, arg).ok()?))
            }
            _ => None,
        }
    }

    fn command(&mut self, u: &Unit, node: &Node, w: &mut Words) -> Result<(), String> {
        let name = u.upper(node);
        match name.as_str() {
            "RET" => w.ret = true,
            "SUPA" => w.suppress_frames = true,
            "TRANS" | "ATRANS" | "ROT" | "AROT" | "SCALE" | "ASCALE" | "MIRROR" | "AMIRROR" => {
                w.frame_command = Some(name)
            }
            _ if NO_EFFECT_COMMANDS.contains(&name.as_str()) => {}
            _ => w.call = Some((name, Vec::new(), Vec::new())),
        }
        Ok(())
    }

    fn program_call(&mut self, u: &Unit, node: &Node, w: &mut Words) -> Result<(), String> {
        let parts: Vec<&Node> = node.significant().collect();
        let keyword = u.upper(parts[0]);
        match (keyword.as_str(), parts.get(1)) {
            ("CALL", Some(target)) if target.kind != NodeKind::Text => {
                let name = self.eval(u, target)?.text().to_ascii_uppercase();
                w.call = Some((name, Vec::new(), Vec::new()));
                Ok(())
            }
            _ => Err(format!("{keyword} is not supported by the dry run")),
        }
    }

    /// Finds `NAME.SPF` / `NAME.MPF` (any case, or `_N_NAME_SPF`) beside the calling program, then in the
    /// configured subprogram folders (the control's SPF directory).
    fn load(&mut self, from: &Unit, name: &str) -> Result<Rc<Unit>, String> {
        let dirs: Vec<PathBuf> = from
            .dir
            .iter()
            .chain(&self.cfg.subprogram_dirs)
            .cloned()
            .collect();
        let found = dirs.iter().find_map(|dir| {
            let listing = self
                .listings
                .entry(dir.clone())
                .or_insert_with(|| list_programs(dir));
            listing.get(name).map(|path| (dir.clone(), path.clone()))
        });
        let Some((dir, path)) = found else {
            let searched: Vec<String> = dirs.iter().map(|d| d.display().to_string()).collect();
            return Err(format!(
                "{name} is neither a supported command nor a subprogram (no {name}.SPF or {name}.MPF in {})",
                if searched.is_empty() {
                    "any folder: the program was not read from a file".to_string()
                } else {
                    searched.join(", ")
                }
            ));
        };
        if let Some(unit) = self.loaded.get(&path) {
            return Ok(unit.clone());
        }
        let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let display = path.file_name().map_or_else(
            || path.display().to_string(),
            |f| f.to_string_lossy().into_owned(),
        );
        let unit = Rc::new(Unit::new(display, Some(dir), crate::parse_owned(bytes)));
        self.loaded.insert(path, unit.clone());
        Ok(unit)
    }

    /// Local variables of a program from its PROC parameters and the call's arguments.
    fn bind_params(&self, unit: &Unit, args: &[Option<Value>]) -> Result<Bound, String> {
        let mut vars = HashMap::new();
        let mut by_ref = Vec::new();
        let proc = unit.proc();
        let params: Vec<&Node> = proc
            .as_ref()
            .and_then(|p| p.find(NodeKind::Args))
            .map(|a| {
                a.significant()
                    .filter(|c| c.kind == NodeKind::Param)
                    .collect()
            })
            .unwrap_or_default();
        if args.len() > params.len() {
            return Err(format!(
                "{} takes {} parameter(s), the call passes {}",
                unit.name,
                params.len(),
                args.len()
            ));
        }
        for (k, p) in params.iter().enumerate() {
            let mut ty = None;
            let mut var_param = false;
            for c in p.significant().filter(|c| c.kind == NodeKind::Keyword) {
                let word = unit.upper(c);
                var_param |= word == "VAR";
                ty = ty.or(VarType::from_keyword(&word));
            }
            let ty = ty.ok_or("PROC parameter without a supported type")?;
            if p.find(NodeKind::Index).is_some() {
                return Err("array parameters are not supported".into());
            }
            let name = unit.upper(
                p.find(NodeKind::Name)
                    .ok_or("PROC parameter without name")?,
            );
            let mut var = Variable::new(ty, Vec::new());
            if let Some(Some(v)) = args.get(k) {
                var.set(&[], v.clone())?;
            }
            if var_param {
                by_ref.push((name.clone(), k));
            }
            vars.insert(name, var);
        }
        Ok((vars, by_ref))
    }

    // ---- applying a block ----

    fn apply(&mut self, u: &Rc<Unit>, i: usize, w: Words) -> Result<Flow, String> {
        let mut dwell = false;
        let mut suppress = w.suppress_frames;
        let planes = [
            self.plane(["X", "Y", "Z"]),
            self.plane(["Z", "X", "Y"]),
            self.plane(["Y", "Z", "X"]),
        ];
        for &g in &w.g {
            let modal = &mut self.motion.modal;
            match g {
                0..=3 => modal.motion = g,
                4 => dwell = true,
                // Exact stop / continuous path: change corners, not the path length this dry run times.
                9 | 60 | 64 | 601..=603 | 641..=645 => {}
                17..=19 => modal.plane = planes[g as usize - 17],
                // Cutter radius compensation moves the contour in the plane, never the depth.
                40..=42 => {}
                53 | 153 => suppress = true,
                54..=57 => self.motion.frames.select(g as usize - 53),
                505..=599 => self.motion.frames.select(g as usize - 500),
                500 => self.motion.frames.select(0),
                70 | 700 | 71 | 710 => {
                    modal.inch = matches!(g, 70 | 700);
                    modal.inch_feed = g == 700;
                }
                90 => modal.absolute = true,
                91 => modal.absolute = false,
                94 => modal.feed_per_rev = false,
                95 => modal.feed_per_rev = true,
                _ => return Err(format!("G{g} is not supported by the dry run")),
            }
        }
        let mut w = w;
        if self.motion.modal.inch {
            for (_, _, v) in &mut w.axes {
                *v *= MM_PER_INCH;
            }
            for (v, _) in w.centre.iter_mut().flatten() {
                *v *= MM_PER_INCH;
            }
            if let Some(cr) = &mut w.cr {
                *cr *= MM_PER_INCH;
            }
        }
        if let Some(f) = w.feed.filter(|_| !dwell) {
            let unit = if self.motion.modal.inch_feed {
                MM_PER_INCH
            } else {
                1.0
            };
            self.motion.modal.feed = Some(f * unit);
        }
        if let Some(s) = w.s.filter(|_| !dwell) {
            self.motion.s = s;
            if self.motion.rotation != 0 {
                self.spindle.set(self.time_min, s);
            }
        }
        if let Some(t) = w.tool {
            self.motion.pending_tool = Some(t);
        }
        if let Some(d) = w.d {
            self.motion.d = d;
        }
        let mut end = None;
        for &m in &w.m {
            match m {
                3 | 4 => {
                    self.motion.rotation = m;
                    self.spindle.set(self.time_min, self.motion.s);
                }
                6 => {
                    self.passes.end_segment();
                    self.motion.tool_number = self.motion.pending_tool.take().unwrap_or(0.0);
                    self.time_min += self.cfg.tool_change_min;
                }
                5 | 0 | 1 | 2 | 30 | 17 => {}
                _ => *self.run.aux_functions.entry(format!("M{m}")).or_default() += 1,
            }
        }
        if let Some(frame) = &w.frame_command {
            self.frame_command(frame, &w.axes)?;
        } else if !w.axes.is_empty() {
            self.travel(u, i, &w, suppress)?;
        }
        if dwell {
            let minutes = match (w.feed, w.s) {
                (Some(s), None) => s / 60.0,
                (None, Some(rev)) if self.motion.spindle_rpm() > 0.0 => {
                    rev / self.motion.spindle_rpm()
                }
                (None, Some(_)) => {
                    return Err(
                        "G4 S… dwells spindle revolutions, but the spindle is stopped".into(),
                    );
                }
                _ => return Err("G4 needs exactly one of F (seconds) or S (revolutions)".into()),
            };
            self.time_min += minutes;
        }
        for &m in &w.m {
            match m {
                5 => {
                    self.passes.end_segment();
                    self.motion.rotation = 0;
                    self.spindle.set(self.time_min, 0.0);
                }
                0 | 1 => self.time_min += self.cfg.stop_min,
                2 | 30 => {
                    end = Some(End::ProgramEnd {
                        code: format!("M{m}"),
                    })
                }
                17 => end = end.or(Some(End::ProgramEnd { code: "M17".into() })),
                _ => {}
            }
        }
        if let Some((cycle, args)) = &w.probe {
            self.probe(u, i, cycle, args);
        }
        if let Some((number, text)) = w.alarm {
            self.run.alarms.push(Alarm {
                at: self.at(u, i),
                number,
                text,
            });
            return Ok(Flow::End(End::Alarm { number }));
        }
        match end {
            Some(End::ProgramEnd { code }) if code == "M17" => return Ok(Flow::Return),
            Some(end) => return Ok(Flow::End(end)),
            None => {}
        }
        if w.ret {
            return Ok(Flow::Return);
        }
        if let Some((name, args, refs)) = w.call {
            let unit = self.load(u, &name)?;
            return Ok(Flow::Call {
                unit,
                args,
                refs,
                repeats: w.repeat.unwrap_or(1).max(1),
            });
        }
        if let Some((start, end)) = w.section {
            let passes = w.repeat.unwrap_or(1);
            self.top().sections.push(Section {
                start,
                end,
                left: passes - 1,
                resume: i + 1,
            });
            return Ok(Flow::Jump(start));
        }
        if w.repeat.is_some() {
            return Err("P (repetitions) without a subprogram call or REPEAT".into());
        }
        Ok(w.jump.map_or(Flow::Next, Flow::Jump))
    }

    fn plane(&self, names: [&str; 3]) -> [Option<usize>; 3] {
        names.map(|n| self.axis_index(n))
    }

    fn frame_command(&mut self, name: &str, axes: &[(usize, Dim, f64)]) -> Result<(), String> {
        let f = &mut self.motion.frames;
        match name {
            "TRANS" | "ATRANS" => {
                if name == "TRANS" {
                    f.trans.iter_mut().for_each(|t| *t = 0.0);
                }
                for &(a, _, v) in axes {
                    f.trans[a] += v;
                }
                Ok(())
            }
            _ if ABSOLUTE_FRAMES.contains(&name) && axes.is_empty() => {
                f.trans.iter_mut().for_each(|t| *t = 0.0);
                Ok(())
            }
            _ => Err(format!(
                "{name} with values is not supported (the dry run models translations only)"
            )),
        }
    }

    /// Moves the programmed axes: geometry, time, and the cut it makes.
    fn travel(&mut self, u: &Unit, i: usize, w: &Words, suppress: bool) -> Result<(), String> {
        let st = &mut self.motion;
        let start_local = st.local.clone();
        let start_machine = st.machine.clone();
        for &(a, dim, v) in &w.axes {
            let absolute = match dim {
                Dim::Modal => st.modal.absolute,
                Dim::Absolute => true,
                Dim::Incremental => false,
            };
            let offset = if suppress { 0.0 } else { st.frames.offset(a) };
            st.local[a] = if absolute { v } else { st.local[a] + v };
            st.machine[a] = st.local[a] + offset;
            st.moved |= 1 << a;
        }
        let motion = st.modal.motion;
        let chord: f64 = start_machine
            .iter()
            .zip(&st.machine)
            .map(|(a, b)| (b - a).powi(2))
            .sum::<f64>()
            .sqrt();
        let length = if matches!(motion, 2 | 3) {
            let [Some(p), Some(q), infeed] = st.modal.plane else {
                return Err("circle in a plane whose axes this machine lacks".into());
            };
            let centre_of = |axis: usize| -> Option<(f64, bool)> {
                let name = self.cfg.axes[axis].as_str();
                let k = ["X", "Y", "Z"].iter().position(|&n| n == name)?;
                w.centre[k]
            };
            let (cp, cq) = (centre_of(p), centre_of(q));
            let centre = match (cp, cq) {
                (None, None) => None,
                _ => Some([cp.map_or(0.0, |c| c.0), cq.map_or(0.0, |c| c.0)]),
            };
            let centre_absolute = cp.is_some_and(|c| c.1) || cq.is_some_and(|c| c.1);
            let arc = ArcSpec {
                clockwise: motion == 2,
                centre,
                centre_absolute,
                radius: w.cr,
            };
            let rise = infeed.map_or(0.0, |k| st.local[k] - start_local[k]);
            arc_length(
                &arc,
                [start_local[p], start_local[q]],
                [st.local[p], st.local[q]],
                rise,
            )?
        } else {
            chord
        };
        let minutes = if motion == 0 {
            length / self.cfg.rapid_mm_min
        } else {
            let feed = st
                .modal
                .feed
                .or(self.cfg.default_feed_mm_min)
                .ok_or("feed move without a programmed feed F (alarm 10860)")?;
            let rate = if st.modal.feed_per_rev {
                let rpm = st.spindle_rpm();
                if rpm <= 0.0 {
                    return Err("G95 feed per revolution with the spindle stopped".into());
                }
                feed * rpm
            } else {
                feed
            };
            if rate <= 0.0 {
                return Err(format!("feed {rate} mm/min must be positive"));
            }
            length / rate
        };
        let t0 = self.time_min;
        self.time_min += minutes;
        if motion == 0 {
            self.passes.end_segment();
            return Ok(());
        }
        let rpm = self.motion.spindle_rpm();
        let Some(z) = self.axis_index("Z") else {
            return Ok(());
        };
        if rpm <= 0.0 || length == 0.0 {
            return Ok(());
        }
        let mid = (t0 + self.time_min) / 2.0;
        let drift = self.machine.drift_um("Z", mid, &self.spindle);
        let correction = if suppress {
            0.0
        } else {
            self.motion.frames.correction(z) * 1000.0
        };
        let planar = (start_local[z] - self.motion.local[z]).abs() < 1e-9;
        self.passes.feed_move(Cut {
            file: u.name.clone(),
            line: i + 1,
            start_min: t0,
            end_min: self.time_min,
            z_mm: self.motion.local[z],
            spindle_rpm: rpm,
            error_um: drift + correction,
            planar_length_mm: if planar { length } else { 0.0 },
        });
        Ok(())
    }

    fn probe(&mut self, u: &Unit, i: usize, cycle: &str, args: &[Option<f64>]) {
        self.passes.end_segment();
        let axis = self.cfg.probe_axis.clone();
        let t = self.time_min;
        let true_drift = self.machine.drift_um(&axis, t, &self.spindle);
        let result = self.machine.probe(&ProbeCall {
            cycle,
            args,
            axis: &axis,
            t_min: t,
            spindle: &self.spindle,
        });
        let r = self.cfg.probe_result_r;
        let offset = self
            .axis_index(&axis)
            .map_or(0.0, |a| self.motion.frames.offset(a));
        match result {
            // The probe triggers when the real tool tip reaches the surface, so the control reads the surface
            // minus the drift.
            ProbeResult::Drift(d) => self.r[r] = self.cfg.probe_surface_mm - offset - d / 1000.0,
            ProbeResult::Raw(v) => self.r[r] = v,
            ProbeResult::Nothing => {}
        }
        let at = self.at(u, i);
        self.run.measurements.push(Measurement {
            at,
            cycle: cycle.to_string(),
            axis,
            true_drift_um: true_drift,
            result,
            value_mm: self.r[r],
        });
        self.time_min += self.cfg.probe_min;
    }
}

fn ijk(letter: &str) -> usize {
    match letter {
        "I" => 0,
        "J" => 1,
        _ => 2,
    }
}

fn proc_has_save(unit: &Unit) -> bool {
    unit.proc().is_some_and(|p| {
        p.significant()
            .any(|c| c.kind == NodeKind::Name && unit.upper(c) == "SAVE")
    })
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

/// Upper-cased program name → path, for the `.SPF` / `.MPF` files of a folder (`_N_NAME_SPF` too).
fn list_programs(dir: &Path) -> HashMap<String, PathBuf> {
    let mut out = HashMap::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return out;
    };
    for e in entries.flatten() {
        let file = e.file_name().to_string_lossy().to_ascii_uppercase();
        let stem = file
            .strip_suffix(".SPF")
            .or_else(|| file.strip_suffix(".MPF"))
            .or_else(|| {
                file.strip_prefix("_N_")
                    .and_then(|f| f.strip_suffix("_SPF").or_else(|| f.strip_suffix("_MPF")))
            });
        if let Some(stem) = stem {
            out.entry(stem.to_string()).or_insert(e.path());
        }
    }
    out
}
