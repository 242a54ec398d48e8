//! The program's timeline, estimated from its moves: feed moves take distance / F (arcs by their length,
//! G95 feeds per revolution by F·S), rapids distance / rapid rate, dwells their time, tool changes the
//! profile's time. It also collects what the emitter needs to know about the program: where passes start,
//! where the spindle speed changes, where the tool is retracted (safe points for extra measurements),
//! where the program ends, and which R-parameters and labels it already uses.
//!
//! The program is read once, in order, without running it: loops and jumps are counted once, expressions
//! as coordinates count as no move (`inexact_blocks` says how many blocks that affected).

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex};

use crate::syntax::{Block, BlockKind, Node, NodeKind, Program};
use crate::views::{AxisMode, Value, VarName, WorkOffset, facts, is_predefined_command};

use super::loops::{Bound, Count, Loop, LoopKind, for_runs};
use super::profile::Profile;
use super::subprograms::Folders;

/// The modal state a gate must restore after it moved the machine.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Modal {
    /// The tool as written after `T=` or `T` (`"DRILL 8.5"` with quotes, or `12`).
    pub tool: Option<Arc<str>>,
    pub d: Option<u32>,
    /// Programmed spindle speed and direction (3, 4 or 5 = stopped).
    pub s: f64,
    pub direction: u32,
    pub feed: Option<f64>,
    /// Modal motion G code (0, 1, 2, 3).
    pub motion: u32,
    pub absolute: bool,
    pub z: Option<f64>,
}

impl Modal {
    /// Speed the spindle turns at (rpm, 0 when stopped).
    pub fn rpm(&self) -> f64 {
        if matches!(self.direction, 3 | 4) {
            self.s.abs()
        } else {
            0.0
        }
    }
}

/// Why a gate site exists.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SiteKind {
    /// A technological pass starts at this block; `tool_change` when the block itself changes the tool.
    PassStart { tool_change: bool },
    /// A rapid move or a dwell right after a Z-only retract: the tool is clear of the part. `first_in_loop`: the first
    /// such move in the body of a loop of the program (the timeline counts a loop once, so the plan
    /// cannot know how long it really runs; a gate there lets the program decide on every iteration).
    Retract { first_in_loop: bool },
    /// The spindle speed changes at this block.
    SpeedChange,
}

/// A block before which driftloop may insert a gate, with the state the program is in there.
#[derive(Debug, Clone, PartialEq)]
pub struct Site {
    pub block: usize,
    pub kind: SiteKind,
    /// Estimated time the block starts (min from program start).
    pub time_min: f64,
    /// Pass the block belongs to (1-based; 0 before the first pass).
    pub pass: usize,
    /// The state before the block.
    pub before: Modal,
    /// Spindle speed from this block on (rpm).
    pub rpm_after: f64,
    /// The block is in the body of a loop (or a repeated section) whose later runs reach it in another modal
    /// state than the first (a value the body changes after this block and does not set before it): a gate
    /// here could not restore the state after measuring.
    pub state_varies: bool,
}

/// One technological pass.
#[derive(Debug, Clone, PartialEq)]
pub struct Pass {
    pub number: usize,
    pub first_block: usize,
    pub start_min: f64,
    pub end_min: f64,
    /// Tool of the pass as written, when known.
    pub tool: Option<Arc<str>>,
    /// Highest spindle speed in the pass (rpm).
    pub max_rpm: f64,
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct Timeline {
    pub total_min: f64,
    pub passes: Vec<Pass>,
    /// Pass starts, retracts and speed changes, in block order.
    pub sites: Vec<Site>,
    /// Spindle speed from each time on: (min, rpm), starting at (0, 0).
    pub speeds: Vec<(f64, f64)>,
    /// Blocks that end the program (M2, M30).
    pub ends: Vec<usize>,
    /// First block after the transfer header (`%…`, `;$PATH=…`).
    pub header_end: usize,
    /// First block after the declarations (DEF, PROC, EXTERN, DEFINE) at the top.
    pub preamble_end: usize,
    pub used_r: BTreeSet<u32>,
    /// Lines (1-based) that index R-parameters by an expression.
    pub computed_r_lines: Vec<usize>,
    pub labels: BTreeSet<String>,
    /// Settable work offsets the program selects, with the first line selecting each.
    pub offsets: Vec<(u32, usize)>,
    /// Lines (1-based) of `computed_r_lines` and `offsets` that call a subprogram from a folder in which the
    /// thing was found, with the subprogram's name.
    pub found_in_call: BTreeMap<usize, String>,
    /// Blocks whose moves could not be timed (expressions, unknown feed).
    pub inexact_blocks: usize,
    /// The program's loops in the order they close (a section repeat at its REPEAT statement).
    pub loops: Vec<Loop>,
    /// Subprogram and cycle calls, whose time the timeline does not know: (line, 1-based; called name).
    pub untimed_calls: Vec<(usize, String)>,
    /// Where the unit programs the spindle: (min from its start, S, M3/M4/M5). A call of the unit replays
    /// them onto the caller's spindle (a subprogram may set only S, or only M3, and inherit the rest).
    pub spindle_words: Vec<(f64, Option<f64>, Option<u32>)>,
    /// First block after the unit the timeline covers (the block count, unless the file is an archive).
    pub unit_end: usize,
}

/// What one block says, reduced to what the timeline needs (built in parallel).
#[derive(Debug, Default, Clone, PartialEq)]
struct Scan {
    g: Codes,
    mv: Move,
    inexact: bool,
    s: Option<f64>,
    m: Codes,
    tool: Option<Arc<str>>,
    d: Option<u32>,
    marker: bool,
    declaration: bool,
    path_comment: bool,
    kind_header: bool,
    r: Vec<Option<u32>>,
    label: Option<String>,
    offsets: Vec<u32>,
    /// R-parameters the block assigns, with the value when it is a literal.
    r_set: Vec<(u32, Option<f64>)>,
    /// FOR bounds or a section repeat's labels and count.
    count: Option<Count>,
    /// A subprogram or cycle the block calls.
    call: Option<String>,
    /// `MCALL NAME`: NAME runs after each later block that moves; `MCALL` alone (`Some(None)`) ends that.
    modal_call: Option<Option<String>>,
    /// `P`: how often the call runs.
    repeats: Option<f64>,
}

/// The words of a block a move needs: axes (value, written with AC), arc centre or radius, feed.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
struct Move {
    axes: [Option<(f64, bool)>; 3],
    centre: [Option<f64>; 3],
    radius: Option<f64>,
    f: Option<f64>,
}

/// The timeline of the program's first unit: of the whole file, or of the main program of an archive. The
/// archive's other units are timed on their own, so that a call of one of its subprograms (`%_N_NAME_SPF`)
/// adds that subprogram's time, as often as `P` says; the R-parameters, labels and work offsets they use
/// count as used. So does a call of a subprogram in the profile's folders, with the R-parameters it uses.
pub fn build(program: &Program, profile: &Profile) -> Timeline {
    build_with(program, profile, &mut Folders::new(profile))
}

pub(super) fn build_with(program: &Program, profile: &Profile, folders: &mut Folders) -> Timeline {
    let units = units(program);
    let names: Vec<Option<String>> = units[1..]
        .iter()
        .map(|u| subprogram_name(program, u.start))
        .collect();
    // Each subprogram on its own first, for the names it calls; then each again after those it calls (a
    // recursive call stays untimed), unless it calls none of the archive's subprograms.
    let mut alone: Vec<Option<(Timeline, BTreeSet<String>)>> = units[1..]
        .iter()
        .map(|u| {
            Some(build_unit(
                program,
                u.clone(),
                profile,
                &HashMap::new(),
                folders,
            ))
        })
        .collect();
    let calls: Vec<BTreeSet<String>> = alone.iter().flatten().map(|(_, c)| c.clone()).collect();
    let order = callees_first(&names, &calls);
    let mut subprograms = HashMap::new();
    let mut others = Vec::new();
    for k in order {
        let (first, called) = alone[k].take().expect("each unit once");
        let t = if called.iter().any(|c| names.contains(&Some(c.clone()))) {
            let unit = units[k + 1].clone();
            build_unit(program, unit, profile, &subprograms, folders).0
        } else {
            first
        };
        if let Some(name) = &names[k] {
            subprograms.insert(name.clone(), t.clone());
        }
        others.push(t);
    }
    let mut t = build_unit(program, units[0].clone(), profile, &subprograms, folders).0;
    for other in others {
        t.used_r.extend(other.used_r);
        t.labels.extend(other.labels);
        t.computed_r_lines.extend(other.computed_r_lines);
        t.offsets.extend(other.offsets);
    }
    t.computed_r_lines.sort_unstable();
    t.unit_end = units[0].end;
    t
}

/// The units (by index into `names`) ordered so that each comes after the units it calls, when they do not
/// call it back.
fn callees_first(names: &[Option<String>], calls: &[BTreeSet<String>]) -> Vec<usize> {
    let index: HashMap<&str, usize> = names
        .iter()
        .enumerate()
        .filter_map(|(k, n)| Some((n.as_deref()?, k)))
        .collect();
    let mut seen = vec![false; names.len()];
    let mut order = Vec::with_capacity(names.len());
    for root in 0..names.len() {
        if seen[root] {
            continue;
        }
        seen[root] = true;
        // Depth first, iteratively: (unit, its callees still to visit).
        let mut stack = vec![(root, calls[root].iter())];
        while let Some((k, callees)) = stack.last_mut() {
            let k = *k;
            match callees.find_map(|c| index.get(c.as_str()).copied().filter(|&j| !seen[j])) {
                Some(j) => {
                    seen[j] = true;
                    stack.push((j, calls[j].iter()));
                }
                None => {
                    order.push(k);
                    stack.pop();
                }
            }
        }
    }
    order
}

/// The block ranges of the program's units: a new one starts at each `%` header after the first block.
fn units(program: &Program) -> Vec<std::ops::Range<usize>> {
    let count = program.block_count();
    let mut starts: Vec<usize> = (1..count)
        .filter(|&i| program.block_kind(i) == BlockKind::Header)
        .collect();
    starts.insert(0, 0);
    starts.push(count);
    starts.windows(2).map(|w| w[0]..w[1]).collect()
}

/// `NAME` of a unit headed `%_N_NAME_SPF` (as it is called: `NAME`, `CALL "NAME"`, `L123` for `L123`).
fn subprogram_name(program: &Program, block: usize) -> Option<String> {
    let header = program.content_span(block).slice(program.source());
    let name = String::from_utf8_lossy(header).trim().to_ascii_uppercase();
    let name = name.strip_prefix("%_N_")?.strip_suffix("_SPF")?;
    (!name.is_empty()).then(|| name.to_string())
}

fn build_unit(
    program: &Program,
    blocks: std::ops::Range<usize>,
    profile: &Profile,
    subprograms: &HashMap<String, Timeline>,
    folders: &mut Folders,
) -> (Timeline, BTreeSet<String>) {
    let marker = profile.passes.marker.to_ascii_uppercase();
    let mut b = Builder::new(profile, subprograms, folders);
    let (first, count) = (blocks.start, blocks.end);
    let chunks = (count - first).div_ceil(CHUNK_BLOCKS);
    let scan = |k: usize| {
        let from = first + k * CHUNK_BLOCKS;
        scan_chunk(program, from..count.min(from + CHUNK_BLOCKS), &marker)
    };
    let helpers = rayon::current_num_threads().saturating_sub(1);
    if chunks <= 1 || helpers == 0 {
        (0..chunks).for_each(|k| b.fold(&scan(k)));
        let called = std::mem::take(&mut b.called);
        return (b.finish(), called);
    }
    // Reading the blocks is independent line by line, the fold is not. Helpers read chunks in order of a
    // shared counter, at most AHEAD chunks past the fold (so the records never hold the whole program);
    // this thread folds them in order and, while the next one is not ready, reads chunks itself.
    const AHEAD: usize = 8;
    let next = AtomicUsize::new(0);
    let ready: Mutex<(Vec<Option<Chunk>>, usize)> =
        Mutex::new(((0..chunks).map(|_| None).collect(), 0));
    let changed = Condvar::new();
    let put = |k: usize, chunk: Chunk| {
        ready.lock().expect("no panic while held").0[k] = Some(chunk);
        changed.notify_all();
    };
    std::thread::scope(|threads| {
        for _ in 0..helpers {
            threads.spawn(|| {
                loop {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    if k >= chunks {
                        return;
                    }
                    let mut slots = ready.lock().expect("no panic while held");
                    while k > slots.1 + AHEAD {
                        slots = changed.wait(slots).expect("no panic while held");
                    }
                    drop(slots);
                    put(k, scan(k));
                }
            });
        }
        for k in 0..chunks {
            let chunk = loop {
                let mut slots = ready.lock().expect("no panic while held");
                if let Some(chunk) = slots.0[k].take() {
                    break chunk;
                }
                drop(slots);
                let j = next.fetch_add(1, Ordering::Relaxed);
                if j < chunks {
                    put(j, scan(j));
                    continue;
                }
                let mut slots = ready.lock().expect("no panic while held");
                while slots.0[k].is_none() {
                    slots = changed.wait(slots).expect("no panic while held");
                }
            };
            b.fold(&chunk);
            ready.lock().expect("no panic while held").1 = k + 1;
            changed.notify_all();
        }
    });
    let called = std::mem::take(&mut b.called);
    (b.finish(), called)
}

/// Blocks read as one piece of work.
const CHUNK_BLOCKS: usize = 1 << 15;

/// The blocks of one chunk as the fold needs them: a plain move (the lines CAM output is made of) as a
/// head of bits and its numbers, any other block as its whole [`Scan`] (4 bytes per typical CAM line
/// instead of a few hundred).
struct Chunk {
    first: usize,
    heads: Vec<u16>,
    numbers: Vec<f64>,
    others: Vec<(BlockKind, Scan)>,
}

/// Bits of a chunk's head: which numbers follow (x, y, z, i, j, k, cr, f in that order), the axes written
/// with AC, the motion code, or the block being one of the chunk's `others`.
mod head {
    pub const AC: u16 = 8;
    pub const MOTION: u16 = 1 << 11;
    pub const MOTION_CODE: u16 = 12;
    pub const OTHER: u16 = 1 << 15;
}

fn scan_chunk(program: &Program, blocks: std::ops::Range<usize>, marker: &str) -> Chunk {
    let mut chunk = Chunk {
        first: blocks.start,
        heads: Vec::with_capacity(blocks.len()),
        numbers: Vec::with_capacity(blocks.len() * 4),
        others: Vec::new(),
    };
    // One buffer for the word scanner, filled in place line after line: no per-line copies.
    let mut words = Scan::default();
    let src = program.source();
    for i in blocks {
        let kind = program.block_kind(i);
        let content = program.content_span(i);
        if kind == BlockKind::Plain
            && scan_words_into(&src[content.start..content.end], marker, &mut words)
        {
            match words.pack_move(&mut chunk.numbers) {
                Some(head) => chunk.heads.push(head),
                None => {
                    chunk.heads.push(head::OTHER);
                    chunk.others.push((kind, words.clone()));
                }
            }
        } else {
            chunk.heads.push(head::OTHER);
            chunk.others.push((kind, scan_tree(program, i, marker)));
        }
    }
    chunk
}

impl Scan {
    /// For a block that only moves (motion codes, axes, arc, feed): its numbers appended to `out` and its
    /// head; `None` for any other block.
    fn pack_move(&self, out: &mut Vec<f64>) -> Option<u16> {
        let only_moves = self.g.iter().all(|g| g <= 3)
            && self.m.is_empty()
            && self.s.is_none()
            && self.tool.is_none()
            && self.d.is_none()
            && !(self.inexact
                || self.marker
                || self.declaration
                || self.path_comment
                || self.kind_header)
            && self.r.is_empty()
            && self.label.is_none()
            && self.offsets.is_empty()
            && self.r_set.is_empty()
            && self.count.is_none()
            && self.call.is_none()
            && self.modal_call.is_none();
        if !only_moves {
            return None;
        }
        let mut h = 0;
        for (k, v) in self.mv.numbers().into_iter().enumerate() {
            if let Some(v) = v {
                out.push(v);
                h |= 1 << k;
            }
        }
        for (k, a) in self.mv.axes.iter().enumerate() {
            h |= u16::from(a.is_some_and(|(_, ac)| ac)) << (head::AC + k as u16);
        }
        if let Some(g) = self.g.iter().last() {
            h |= head::MOTION | (g as u16) << head::MOTION_CODE;
        }
        Some(h)
    }
}

impl Move {
    /// x, y, z, i, j, k, cr, f: the order of a chunk's numbers.
    fn numbers(&self) -> [Option<f64>; 8] {
        let axis = |k: usize| self.axes[k].map(|(v, _)| v);
        [
            axis(0),
            axis(1),
            axis(2),
            self.centre[0],
            self.centre[1],
            self.centre[2],
            self.radius,
            self.f,
        ]
    }

    /// The move a head and its numbers describe (the inverse of [`Scan::pack_move`]).
    fn decode(h: u16, numbers: &mut impl Iterator<Item = f64>) -> Move {
        let mut v = [None; 8];
        for (k, slot) in v.iter_mut().enumerate() {
            if h & (1 << k) != 0 {
                *slot = numbers.next();
            }
        }
        let ac = |k: u16| h & (1 << (head::AC + k)) != 0;
        Move {
            axes: [
                v[0].map(|x| (x, ac(0))),
                v[1].map(|x| (x, ac(1))),
                v[2].map(|x| (x, ac(2))),
            ],
            centre: [v[3], v[4], v[5]],
            radius: v[6],
            f: v[7],
        }
    }
}

fn scan_tree(program: &Program, i: usize, marker: &str) -> Scan {
    let block = program.block(i);
    let f = facts(&block);
    let mut s = Scan {
        kind_header: block.kind == BlockKind::Header,
        label: f.label.clone(),
        ..Scan::default()
    };
    for v in &f.variables {
        if let VarName::R(n) = v.name {
            s.r.push(n);
        }
    }
    for a in &f.axes {
        let k = match a.axis.as_str() {
            "X" => 0,
            "Y" => 1,
            "Z" => 2,
            _ => continue,
        };
        match (&a.value, a.mode) {
            (Value::Number(v), AxisMode::Modal | AxisMode::Ac) => {
                s.mv.axes[k] = Some((*v, a.mode == AxisMode::Ac))
            }
            (Value::Number(v), AxisMode::Ic) => s.mv.axes[k] = Some((*v, false)),
            _ => s.inexact = true,
        }
    }
    let num = |v: &Value| match v {
        Value::Number(x) => Some(*x),
        _ => None,
    };
    s.mv.f = f.feed.as_ref().and_then(|a| num(&a.value));
    s.s = f
        .spindle_speeds
        .iter()
        .find(|a| a.extension.is_none_or(|e| e == 1))
        .and_then(|a| num(&a.value));
    for v in f
        .m_codes
        .iter()
        .filter(|a| a.extension.is_none_or(|e| e == 1))
        .filter_map(|a| num(&a.value))
    {
        s.m.push(v as u32);
    }
    s.tool = f
        .tools
        .first()
        .map(|a| Arc::from(String::from_utf8_lossy(tool_text(&block, a.span)).as_ref()));
    for &g in &f.g_codes {
        if !s.g.contains(g) {
            s.g.push(g);
        }
    }
    for w in &f.work_offsets {
        if let WorkOffset::G(g) = w {
            s.offsets.push(*g);
        }
    }
    for node in block.root.children.iter() {
        match node.kind {
            NodeKind::Word => word(&block, node, &mut s),
            NodeKind::Assign => assign(&block, node, &mut s),
            NodeKind::Comment => comment(block.text(node), marker, &mut s),
            NodeKind::Def | NodeKind::Proc | NodeKind::Extern | NodeKind::Define => {
                s.declaration = true
            }
            NodeKind::For => s.count = for_bounds(&block, node),
            NodeKind::Repeat => s.count = section_repeat(&block, node),
            NodeKind::Call => {
                let name = String::from_utf8_lossy(block.text(&node.children[0]));
                let name = name.to_ascii_uppercase();
                if !TIMELESS_PROCEDURES.contains(&name.as_str()) {
                    s.call = Some(name);
                }
            }
            NodeKind::Command => {
                let name = String::from_utf8_lossy(block.text(node)).to_ascii_uppercase();
                if !is_predefined_command(&name) {
                    s.call = Some(name);
                }
            }
            NodeKind::ProgramCall => match program_call(&block, node) {
                Some(ProgramCall::Once(name)) => s.call = s.call.take().or(Some(name)),
                Some(ProgramCall::Modal(name)) => s.modal_call = Some(name),
                None => {}
            },
            _ => {}
        }
    }
    s
}

/// Built-in procedures called like cycles that take no machine time: no note that they are not timed.
const TIMELESS_PROCEDURES: &[&str] = &[
    "MSG", "SETAL", "WRITE", "SETMS", "GETT", "GETSELT", "STOPRE",
];

/// What a `CALL`, `PCALL`, `EXTCALL`, `ISOCALL` or `MCALL` statement does.
enum ProgramCall {
    /// Runs the program now: `NAME` for `CALL`, `KEYWORD NAME` for the others.
    Once(String),
    /// `MCALL NAME` (the cycle's name) or `MCALL` alone, which ends the modal call.
    Modal(Option<String>),
}

fn program_call(block: &Block<'_>, node: &Node) -> Option<ProgramCall> {
    let mut parts = node.significant();
    let keyword = String::from_utf8_lossy(block.text(parts.next()?)).to_ascii_uppercase();
    let Some(target) = parts.next() else {
        return (keyword == "MCALL").then_some(ProgramCall::Modal(None));
    };
    // A cycle with its arguments (`MCALL CYCLE82(…)`) is named by its name.
    let target = match target.kind {
        NodeKind::FnCall => &target.children[0],
        _ => target,
    };
    let text = String::from_utf8_lossy(block.text(target));
    let name = text.trim_matches('"').to_ascii_uppercase();
    Some(match keyword.as_str() {
        "CALL" => ProgramCall::Once(name),
        "MCALL" => ProgramCall::Modal(Some(name)),
        _ => ProgramCall::Once(format!("{keyword} {name}")),
    })
}

/// `FOR var = from TO to`: the bounds.
fn for_bounds(block: &Block<'_>, node: &Node) -> Option<Count> {
    let parts: Vec<&Node> = node.significant().collect();
    match parts.as_slice() {
        [_, _, _, from, _, to] => Some(Count::For {
            from: bound(block, from),
            to: bound(block, to),
        }),
        _ => None,
    }
}

/// `REPEAT a [b]` / `REPEATB a` with its labels (`P=n` follows as an assignment); `None` for the REPEAT
/// that opens a REPEAT … UNTIL loop.
fn section_repeat(block: &Block<'_>, node: &Node) -> Option<Count> {
    let mut parts = node.significant();
    let keyword = block.text(parts.next()?);
    let labels: Vec<String> = parts
        .filter(|n| n.kind == NodeKind::Name)
        .map(|n| String::from_utf8_lossy(block.text(n)).to_ascii_uppercase())
        .collect();
    (!labels.is_empty()).then(|| Count::Section {
        labels,
        single: keyword.eq_ignore_ascii_case(b"REPEATB"),
        times: Bound::Number(1.0),
    })
}

fn bound(block: &Block<'_>, node: &Node) -> Bound {
    if let Some(v) = literal(block, node) {
        return Bound::Number(v);
    }
    match node.kind {
        NodeKind::RParam => r_number(block.text(node)).map_or(Bound::Other, Bound::R),
        _ => Bound::Other,
    }
}

/// `R12` → 12 (not `R[…]`).
fn r_number(text: &[u8]) -> Option<u32> {
    let digits = text
        .strip_prefix(b"R")
        .or_else(|| text.strip_prefix(b"r"))?;
    std::str::from_utf8(digits).ok()?.parse().ok()
}

/// The same facts without a syntax tree, for the lines CAM output is made of: one-letter address words with
/// plain numbers and an optional comment (`N120 G1 X10.5 Y-3 F800 ; finish`). Anything else — `=`, names,
/// strings, labels, R-parameters — returns `None` and takes the tree path.
fn scan_words_into(line: &[u8], marker: &str, s: &mut Scan) -> bool {
    s.g.len = 0;
    s.m.len = 0;
    s.mv.axes = [None; 3];
    s.mv.centre = [None; 3];
    (s.mv.radius, s.mv.f, s.s, s.tool, s.d) = (None, None, None, None, None);
    (s.marker, s.path_comment) = (false, false);
    s.offsets.clear();
    scan_words(line, marker, s).is_some()
}

/// The word scanner proper; `None` hands the line to the tree path (the buffer is then left half filled).
fn scan_words(line: &[u8], marker: &str, s: &mut Scan) -> Option<()> {
    let mut i = 0;
    while i < line.len() {
        let b = line[i];
        if matches!(b, b' ' | b'\t') {
            i += 1;
            continue;
        }
        if b == b';' {
            comment(&line[i..], marker, s);
            break;
        }
        // `CR=radius` is the one assignment CAM arcs carry; it is read here so arcs stay on this path.
        if matches!(b, b'C' | b'c')
            && line.len() >= i + 3
            && line[i..i + 3].eq_ignore_ascii_case(b"CR=")
        {
            let end = line[i + 3..]
                .iter()
                .position(|c| matches!(c, b' ' | b'\t' | b';'))
                .map_or(line.len(), |p| i + 3 + p);
            s.mv.radius = Some(decimal(&line[i + 3..end])?);
            i = end;
            continue;
        }
        let letter = b.to_ascii_uppercase();
        // R-parameters, and `L` subprogram calls with their `P`, which the tree path reads.
        if !letter.is_ascii_uppercase() || matches!(letter, b'R' | b'L' | b'P') {
            return None;
        }
        let start = i + 1;
        if letter == b'N' {
            // Block numbers only need skipping.
            let digits = line[start..]
                .iter()
                .take_while(|c| c.is_ascii_digit())
                .count();
            i = start + digits;
            if digits == 0
                || line
                    .get(i)
                    .is_some_and(|c| !matches!(c, b' ' | b'\t' | b';'))
            {
                return None;
            }
            continue;
        }
        let (v, len) = decimal_prefix(&line[start..])?;
        let end = start + len;
        if line
            .get(end)
            .is_some_and(|c| !matches!(c, b' ' | b'\t' | b';'))
        {
            return None;
        }
        i = end;
        let digits = &line[start..end];
        // Only G, M and D need whole numbers: the conversion is left to them.
        let int = || (v >= 0.0 && v == (v as u32) as f64).then_some(v as u32);
        match letter {
            b'G' => {
                let g = int()?;
                if matches!(g, 53 | 153 | 500 | 54..=57 | 505..=599) {
                    s.offsets.push(g);
                }
                if !s.g.push(g) {
                    return None;
                }
            }
            b'X' => s.mv.axes[0] = Some((v, false)),
            b'Y' => s.mv.axes[1] = Some((v, false)),
            b'Z' => s.mv.axes[2] = Some((v, false)),
            b'I' => s.mv.centre[0] = Some(v),
            b'J' => s.mv.centre[1] = Some(v),
            b'K' => s.mv.centre[2] = Some(v),
            b'F' => s.mv.f = Some(v),
            b'S' => s.s = Some(v),
            // The guard stores the code; a block with more codes than fit goes to the tree path.
            b'M' if !s.m.push(int()?) => return None,
            b'T' => s.tool = Some(Arc::from(std::str::from_utf8(digits).ok()?)),
            b'D' => s.d = Some(int()?),
            _ => {}
        }
    }
    Some(())
}

/// The G or M codes of one block, without a heap allocation per block. A block holds far fewer than
/// [`Codes::CAP`]; should one hold more, the word scanner hands it to the tree path, which keeps the first
/// ones (the timeline only needs motion, G4, G90/G91, G94/G95, work offsets, M3/M4/M5/M6/M2/M30).
#[derive(Debug, Default, Clone, Copy)]
struct Codes {
    len: u8,
    v: [u16; Codes::CAP],
}

/// Equal when the codes held are, whatever the unused slots keep from an earlier line.
impl PartialEq for Codes {
    fn eq(&self, other: &Codes) -> bool {
        self.iter().eq(other.iter())
    }
}

impl Codes {
    const CAP: usize = 16;

    /// Adds a code; false when it does not fit.
    fn push(&mut self, code: u32) -> bool {
        let (Ok(code), true) = (u16::try_from(code), usize::from(self.len) < Codes::CAP) else {
            return false;
        };
        self.v[usize::from(self.len)] = code;
        self.len += 1;
        true
    }

    fn iter(&self) -> impl Iterator<Item = u32> + '_ {
        self.v[..usize::from(self.len)]
            .iter()
            .map(|&c| u32::from(c))
    }

    fn contains(&self, code: u32) -> bool {
        self.iter().any(|c| c == code)
    }

    fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// `[+-]digits[.digits]` as f64, for the word scanner: exact for up to 15 significant digits, which is
/// what CAM output carries; anything else (exponents, more digits) returns `None` and takes the tree path.
fn decimal(text: &[u8]) -> Option<f64> {
    decimal_prefix(text).and_then(|(v, len)| (len == text.len()).then_some(v))
}

/// The decimal at the start of `text` and its length in bytes, in one pass over the bytes.
fn decimal_prefix(text: &[u8]) -> Option<(f64, usize)> {
    static POW10: [f64; 16] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
    ];
    let (negative, mut i) = match text.first()? {
        b'-' => (true, 1),
        b'+' => (false, 1),
        _ => (false, 0),
    };
    let mut mantissa: u64 = 0;
    let (mut digits, mut scale, mut point) = (0usize, 0usize, false);
    while let Some(&b) = text.get(i) {
        match b {
            b'0'..=b'9' => {
                mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(b - b'0'));
                digits += 1;
                scale += usize::from(point);
            }
            b'.' if !point => point = true,
            _ => break,
        }
        i += 1;
    }
    if digits == 0 || digits > 15 {
        return None;
    }
    // At most 15 digits: the mantissa and the power of ten are exact doubles, the quotient is rounded once
    // (as `str::parse` rounds); the signed conversion is the one x86 does in one instruction.
    let whole = mantissa as i64 as f64;
    let v = if scale == 0 {
        whole
    } else {
        whole / POW10[scale]
    };
    Some((if negative { -v } else { v }, i))
}

/// Marker and `;$PATH` facts of a comment (`text` starts at the `;`).
fn comment(text: &[u8], marker: &str, s: &mut Scan) {
    s.path_comment = text.starts_with(b";$PATH");
    let words = text[1..].trim_ascii_start();
    s.marker = !marker.is_empty()
        && words.len() >= marker.len()
        && words[..marker.len()].eq_ignore_ascii_case(marker.as_bytes());
}

/// The text after `T`/`T=` in a tool word or assignment.
fn tool_text<'a>(block: &'a Block<'_>, span: crate::Span) -> &'a [u8] {
    let node = Node::leaf(NodeKind::Text, span);
    let text = block.text(&node);
    let text = &text[1..];
    let text = text.strip_prefix(b"=").unwrap_or(text);
    text.trim_ascii()
}

fn word(block: &Block<'_>, node: &Node, s: &mut Scan) {
    let letter = block.text(&node.children[0]).to_ascii_uppercase();
    let value = std::str::from_utf8(block.text(&node.children[1]))
        .ok()
        .and_then(|t| t.parse::<f64>().ok());
    match (letter.as_slice(), value) {
        (b"D", Some(d)) if d >= 0.0 && d.fract() == 0.0 => s.d = Some(d as u32),
        (b"I", Some(v)) => s.mv.centre[0] = Some(v),
        (b"J", Some(v)) => s.mv.centre[1] = Some(v),
        (b"K", Some(v)) => s.mv.centre[2] = Some(v),
        // `L123 P3`: subprogram 123, run three times.
        (b"P", Some(p)) => s.repeats = Some(p),
        (b"L", Some(_)) => {
            s.call = Some(String::from_utf8_lossy(block.text(node)).to_ascii_uppercase())
        }
        _ => {}
    }
}

fn assign(block: &Block<'_>, node: &Node, s: &mut Scan) {
    let mut parts = node.significant();
    let (Some(target), _, Some(value)) = (parts.next(), parts.next(), parts.next()) else {
        return;
    };
    let name = block.text(target).to_ascii_uppercase();
    let v = literal(block, value);
    if target.kind == NodeKind::RParam {
        if let Some(n) = r_number(&name) {
            s.r_set.push((n, v));
        }
        return;
    }
    match name.as_slice() {
        b"P" => {
            if let Some(Count::Section { times, .. }) = &mut s.count {
                *times = bound(block, value);
            }
        }
        b"CR" => s.mv.radius = v,
        b"I" => s.mv.centre[0] = v,
        b"J" => s.mv.centre[1] = v,
        b"K" => s.mv.centre[2] = v,
        _ => {}
    }
}

/// A number written as such, with an optional sign (`12.5`, `-3`); `None` for any other expression.
fn literal(block: &Block<'_>, node: &Node) -> Option<f64> {
    match node.kind {
        NodeKind::Number => std::str::from_utf8(block.text(node)).ok()?.parse().ok(),
        NodeKind::Unary => {
            let mut parts = node.significant();
            let sign = match block.text(parts.next()?) {
                b"-" => -1.0,
                b"+" => 1.0,
                _ => return None,
            };
            Some(sign * literal(block, parts.next()?)?)
        }
        _ => None,
    }
}

struct Builder<'p> {
    profile: &'p Profile,
    /// The archive's subprograms that a call may run, with their timelines.
    subprograms: &'p HashMap<String, Timeline>,
    /// The subprograms in the profile's folders, timed when first called.
    folders: &'p mut Folders,
    /// A subprogram or cycle ran since the last tool change: the modal state it left (tool, speed, feed,
    /// frame) is not known, so no gate measures, and restores a state, until the next tool change.
    after_call: bool,
    /// The cycle or subprogram an `MCALL` made modal: it runs after each block that moves.
    modal_call: Option<String>,
    /// Names the unit calls (archive subprograms or not), for the order in which an archive's units are timed.
    called: BTreeSet<String>,
    /// A subprogram called at this block changed the spindle speed: the next block gets a speed-change site,
    /// so that the program's prediction takes the new speed there.
    speed_site_after: Option<usize>,
    t: Timeline,
    state: Modal,
    pos: [Option<f64>; 3],
    per_rev: bool,
    time: f64,
    last_was_z_retract: bool,
    header_done: bool,
    preamble_done: bool,
    pass_marks: Vec<PassMark>,
    tool_marks: Vec<PassMark>,
    m6_seen: bool,
    rpm: f64,
    loop_depth: usize,
    /// A loop started and no retract site in its body yet.
    loop_gate_pending: bool,
    open_loops: Vec<OpenLoop>,
    /// R-parameters whose last assignment (in program order) was a literal.
    r_values: BTreeMap<u32, f64>,
    /// Labels seen: block, start and end of its first run (min).
    label_times: HashMap<String, Label>,
    /// Block (+1) where each of the modal fields a gate restores last changed (see [`field`]).
    changed: [usize; field::COUNT],
    /// Blocks that may get a site or pass mark, with `changed` there.
    site_changes: Vec<(usize, [usize; field::COUNT])>,
    /// Blocks whose modal state differs between the runs of a loop around them.
    varies: BTreeSet<usize>,
}

/// A repeated section: its blocks, the start and end of its first run (min) and the state it starts in.
struct Section {
    body: (usize, usize),
    start: f64,
    end: f64,
    entry: Modal,
}

/// A label seen: its block, the start and end of its first run (min) and the state before it.
struct Label {
    block: usize,
    start: f64,
    end: f64,
    state: Modal,
}

/// The modal fields a gate restores after measuring, as bits.
mod field {
    use super::Modal;

    pub const COUNT: usize = 8;
    const TOOL: usize = 0;
    const D: usize = 1;
    const S: usize = 2;
    const DIRECTION: usize = 3;
    pub const FEED: usize = 4;
    pub const MOTION: usize = 5;
    const ABSOLUTE: usize = 6;
    pub const Z: usize = 7;

    /// The fields in which two states differ.
    pub fn differ(a: &Modal, b: &Modal) -> [bool; COUNT] {
        let mut d = [false; COUNT];
        d[TOOL] = a.tool != b.tool;
        d[D] = a.d != b.d;
        d[S] = a.s != b.s;
        d[DIRECTION] = a.direction != b.direction;
        d[FEED] = a.feed != b.feed;
        d[MOTION] = a.motion != b.motion;
        d[ABSOLUTE] = a.absolute != b.absolute;
        d[Z] = a.z != b.z;
        d
    }
}

/// A loop whose closing block has not come yet.
struct OpenLoop {
    kind: LoopKind,
    block: usize,
    start_min: f64,
    runs: Result<u64, &'static str>,
    /// The state the first run starts in.
    entry: Modal,
}

impl<'p> Builder<'p> {
    fn new(
        profile: &'p Profile,
        subprograms: &'p HashMap<String, Timeline>,
        folders: &'p mut Folders,
    ) -> Self {
        Builder {
            profile,
            subprograms,
            folders,
            after_call: false,
            modal_call: None,
            called: BTreeSet::new(),
            speed_site_after: None,
            t: Timeline {
                speeds: vec![(0.0, 0.0)],
                ..Timeline::default()
            },
            state: Modal {
                direction: 5,
                absolute: true,
                ..Modal::default()
            },
            pos: [None; 3],
            per_rev: false,
            time: 0.0,
            last_was_z_retract: false,
            header_done: false,
            preamble_done: false,
            pass_marks: Vec::new(),
            tool_marks: Vec::new(),
            m6_seen: false,
            rpm: 0.0,
            loop_depth: 0,
            loop_gate_pending: false,
            open_loops: Vec::new(),
            r_values: BTreeMap::new(),
            label_times: HashMap::new(),
            changed: [0; field::COUNT],
            site_changes: Vec::new(),
            varies: BTreeSet::new(),
        }
    }

    /// Folds the blocks of a chunk, in order.
    fn fold(&mut self, chunk: &Chunk) {
        let mut numbers = chunk.numbers.iter().copied();
        let mut others = chunk.others.iter();
        for (k, &h) in chunk.heads.iter().enumerate() {
            let i = chunk.first + k;
            if h & head::OTHER != 0 {
                let (kind, scan) = others.next().expect("one scan per other block");
                self.block(i, scan, *kind);
            } else {
                let motion =
                    (h & head::MOTION != 0).then_some(u32::from(h >> head::MOTION_CODE & 3));
                self.plain_move(i, motion, &Move::decode(h, &mut numbers));
            }
        }
    }

    /// A block that only moves (see [`Scan::pack_move`]): most of what [`Builder::block`] looks at is absent.
    fn plain_move(&mut self, i: usize, motion: Option<u32>, mv: &Move) {
        if self.speed_site_after.is_some() {
            self.speed_site_after_call(i);
        }
        let before = if self.last_was_z_retract || !self.profile.passes.lines.is_empty() {
            self.state.clone()
        } else {
            Modal::default()
        };
        let start = self.time;
        let blank = motion.is_none() && mv.axes.iter().all(Option::is_none);
        self.header_and_preamble(i, false, false, blank);
        if let Some(g) = motion
            && g != self.state.motion
        {
            self.state.motion = g;
            self.changed[field::MOTION] = i + 1;
        }
        if let Some(f) = mv.f
            && self.state.feed != Some(f)
        {
            self.state.feed = Some(f);
            self.changed[field::FEED] = i + 1;
        }
        if self.profile.passes.lines.contains(&(i + 1)) {
            let mark = self.mark(i, false, start, &before);
            self.pass_marks.push(mark);
            self.note_site(i);
        }
        self.movement(i, start, &before, mv, false, None, false, false);
        self.modal_call_after(i, mv);
    }

    /// Header lines (`%…`, `;$PATH`) and the declarations after them: no gate may come before their end.
    fn header_and_preamble(&mut self, i: usize, header: bool, declaration: bool, blank: bool) {
        if !self.header_done {
            if header {
                self.t.header_end = i + 1;
            } else {
                self.header_done = true;
            }
        }
        if !self.preamble_done {
            if declaration || blank {
                self.t.preamble_end = i + 1;
            } else {
                self.preamble_done = true;
            }
        }
    }

    fn mark(&self, i: usize, tool_change: bool, start: f64, before: &Modal) -> PassMark {
        PassMark {
            block: i,
            tool_change,
            time: start,
            before: before.clone(),
            rpm: self.state.rpm(),
            tool: self.state.tool.clone(),
        }
    }

    /// A subprogram or cycle runs at block `i`, `repeats` times: an archive subprogram adds its time, any
    /// other call is listed as not timed (`shown` is how the list names it).
    fn call(&mut self, i: usize, name: &str, shown: &str, repeats: Option<f64>) {
        self.after_call = true;
        self.called.insert(name.to_string());
        // A subprogram from a folder is in another file: what it leaves untimed is listed at the call (its
        // own line numbers mean nothing in this program).
        let from_folder;
        let found = match self.subprograms.get(name) {
            Some(sub) => Some((sub, false)),
            None => {
                from_folder = self.folders.timeline(name, self.profile);
                from_folder.as_deref().map(|sub| (sub, true))
            }
        };
        match found {
            Some((sub, elsewhere)) => {
                let runs = repeats.filter(|p| *p >= 1.0).unwrap_or(1.0).floor();
                if !sub.spindle_words.is_empty() {
                    self.replay_spindle(i, sub, runs);
                }
                self.time += runs * sub.total_min;
                self.t.inexact_blocks += sub.inexact_blocks;
                let line = |own: usize| if elsewhere { i + 1 } else { own };
                self.t.untimed_calls.extend(
                    sub.untimed_calls
                        .iter()
                        .map(|(own, name)| (line(*own), name.clone())),
                );
                // R-parameters are global: those a subprogram from a folder uses are taken, and what it
                // does that the transform refuses (R indexed by expressions, another work offset) is
                // refused at the call (the archive's units count whether called or not).
                if elsewhere {
                    self.t.used_r.extend(&sub.used_r);
                    if !sub.computed_r_lines.is_empty() {
                        self.t.computed_r_lines.push(i + 1);
                    }
                    for &(g, _) in &sub.offsets {
                        self.offset(g, i);
                    }
                    if !(sub.computed_r_lines.is_empty() && sub.offsets.is_empty()) {
                        self.t.found_in_call.insert(i + 1, name.to_string());
                    }
                }
            }
            None => self.t.untimed_calls.push((i + 1, shown.to_string())),
        }
    }

    /// The spindle words of a subprogram called at block `i` and run `runs` times, applied to this
    /// program's spindle as they come: the speeds follow, and the state after the call is the one it left.
    /// The program's prediction holds one speed from gate to gate and the subprogram has no gates: a gate
    /// before the call takes the call's time-weighted mean speed, the block after it the speed it left.
    fn replay_spindle(&mut self, i: usize, sub: &Timeline, runs: f64) {
        let (at, rpm_before, state_before) = (self.time, self.rpm, self.state.clone());
        let first_change = self.t.speeds.len();
        // A bound on the speed changes one call adds, for absurd repeat counts.
        let most = 1_000_000 / sub.spindle_words.len() as u64;
        for run in 0..(runs as u64).min(most) {
            let offset = at + run as f64 * sub.total_min;
            for &(t, s, direction) in &sub.spindle_words {
                if let Some(s) = s {
                    self.state.s = s;
                }
                if let Some(d) = direction {
                    self.state.direction = d;
                }
                self.t.spindle_words.push((offset + t, s, direction));
                let rpm = self.state.rpm();
                if rpm != self.rpm {
                    self.rpm = rpm;
                    self.t.speeds.push((offset + t, rpm));
                }
            }
        }
        let end = at + runs * sub.total_min;
        let (mut sum, mut from, mut rpm) = (0.0, at, rpm_before);
        for &(t, next) in &self.t.speeds[first_change..] {
            sum += rpm * (t.min(end) - from);
            (from, rpm) = (t.min(end), next);
        }
        sum += rpm * (end - from);
        let mean = if end > at { sum / (end - at) } else { rpm };
        let mut predicted = rpm_before;
        if mean != rpm_before {
            self.note_site(i);
            self.speed_site(i, at, state_before, mean);
            predicted = mean;
        }
        if self.rpm != predicted {
            self.speed_site_after = Some(i);
        }
    }

    /// A gate site where the program's prediction takes another speed (`rpm` from block `i` on); it
    /// replaces one a call before this block asked for.
    fn speed_site(&mut self, i: usize, time_min: f64, before: Modal, rpm: f64) {
        if self
            .t
            .sites
            .last()
            .is_some_and(|l| l.block == i && l.kind == SiteKind::SpeedChange)
        {
            self.t.sites.pop();
        }
        self.t.sites.push(Site {
            block: i,
            kind: SiteKind::SpeedChange,
            time_min,
            pass: 0,
            before,
            rpm_after: rpm,
            state_varies: false,
        });
    }

    /// The speed-change site a subprogram's speed asks for, at the first block after its call.
    fn speed_site_after_call(&mut self, i: usize) {
        if self.speed_site_after.is_some_and(|call| call < i) {
            self.speed_site_after = None;
            self.note_site(i);
            self.speed_site(i, self.time, self.state.clone(), self.rpm);
        }
    }

    /// A settable work offset selected at block `i` (noted at its first selection).
    fn offset(&mut self, g: u32, i: usize) {
        if matches!(g, 54..=57 | 505..=599) && !self.t.offsets.iter().any(|(o, _)| *o == g) {
            self.t.offsets.push((g, i + 1));
        }
    }

    /// After a block that moves, the cycle an `MCALL` made modal runs.
    #[inline]
    fn modal_call_after(&mut self, i: usize, mv: &Move) {
        if let Some(name) = &self.modal_call
            && mv.axes.iter().any(Option::is_some)
        {
            let name = name.clone();
            self.call(i, &name, &format!("MCALL {name}"), None);
        }
    }

    fn block(&mut self, i: usize, s: &Scan, kind: BlockKind) {
        self.speed_site_after_call(i);
        if let Some(name) = &s.call {
            self.call(i, name, name, s.repeats);
        }
        // Changes matter only inside a loop body or a section that may be repeated.
        let tracked =
            (!self.open_loops.is_empty() || !self.label_times.is_empty() || s.label.is_some())
                .then(|| self.state.clone());
        match kind {
            BlockKind::While | BlockKind::For | BlockKind::Loop | BlockKind::Repeat => {
                self.loop_depth += 1;
                self.loop_gate_pending = true;
            }
            BlockKind::EndWhile | BlockKind::EndFor | BlockKind::EndLoop | BlockKind::Until => {
                self.loop_depth = self.loop_depth.saturating_sub(1);
            }
            _ => {}
        }
        // The state before the block is kept only where a site or pass mark can arise: a copy per block
        // would cost more than the rest of the scan.
        let may_mark = !s.m.is_empty()
            || s.s.is_some()
            || s.tool.is_some()
            || s.marker
            || self.last_was_z_retract
            || !self.profile.passes.lines.is_empty();
        let before = if may_mark {
            self.state.clone()
        } else {
            Modal::default()
        };
        let start = self.time;
        let blank = s.g.is_empty()
            && s.mv.axes.iter().all(Option::is_none)
            && s.m.is_empty()
            && s.tool.is_none()
            && s.s.is_none()
            && s.r.is_empty();
        self.header_and_preamble(
            i,
            s.kind_header || s.path_comment,
            s.declaration || s.kind_header,
            blank,
        );
        for r in &s.r {
            match r {
                Some(n) => {
                    self.t.used_r.insert(*n);
                }
                None => self.t.computed_r_lines.push(i + 1),
            }
        }
        if let Some(l) = &s.label {
            self.t.labels.insert(l.clone());
        }
        for &g in &s.offsets {
            self.offset(g, i);
        }
        // Modal words first: they hold for this block's move.
        for g in s.g.iter() {
            match g {
                0..=3 => self.state.motion = g,
                90 => self.state.absolute = true,
                91 => self.state.absolute = false,
                94 => self.per_rev = false,
                95 => self.per_rev = true,
                _ => {}
            }
        }
        let dwell = s.g.contains(4);
        if let Some(f) = s.mv.f
            && !dwell
        {
            self.state.feed = Some(f);
        }
        if let Some(v) = s.s {
            self.state.s = v;
        }
        if let Some(d) = s.d {
            self.state.d = Some(d);
        }
        let mut direction = None;
        for m in s.m.iter() {
            match m {
                3..=5 => direction = Some(m),
                6 => self.m6_seen = true,
                2 | 30 => self.t.ends.push(i),
                _ => {}
            }
        }
        if let Some(d) = direction {
            self.state.direction = d;
        }
        if s.s.is_some() || direction.is_some() {
            self.t.spindle_words.push((start, s.s, direction));
        }
        let tool_change = s.m.contains(6);
        if let Some(tool) = &s.tool {
            self.state.tool = Some(tool.clone());
        }
        let rpm = self.state.rpm();
        if s.tool.is_some() {
            let mark = self.mark(i, true, start, &before);
            self.tool_marks.push(mark);
        }
        let p = &self.profile.passes;
        let marked = s.marker || p.lines.contains(&(i + 1));
        if (p.tool_change && tool_change) || marked {
            let mark = self.mark(i, tool_change, start, &before);
            self.pass_marks.push(mark);
            if self.after_call && !tool_change {
                self.varies.insert(i);
            }
        }
        self.after_call &= !tool_change;
        if s.tool.is_some() || (p.tool_change && tool_change) || marked || rpm != self.rpm {
            self.note_site(i);
        }
        if rpm != self.rpm {
            self.rpm = rpm;
            self.t.speeds.push((start, rpm));
            self.speed_site(i, start, before.clone(), rpm);
        }
        if let Some(modal) = &s.modal_call {
            self.modal_call = modal.clone();
        }
        self.movement(i, start, &before, &s.mv, dwell, s.s, s.inexact, tool_change);
        self.modal_call_after(i, &s.mv);
        if let Some(prev) = tracked {
            for (f, differs) in field::differ(&prev, &self.state).into_iter().enumerate() {
                if differs {
                    self.changed[f] = i + 1;
                }
            }
            if let Some(l) = &s.label {
                self.label_times
                    .entry(l.to_ascii_uppercase())
                    .or_insert(Label {
                        block: i,
                        start,
                        end: self.time,
                        state: prev,
                    });
            }
        }
        self.loops(i, s, kind, start);
    }

    /// Loop statements: a loop opens after its statement; at its end (or at a section repeat statement)
    /// the further runs are added to the time.
    fn loops(&mut self, i: usize, s: &Scan, kind: BlockKind, start: f64) {
        if s.r.contains(&None) {
            self.r_values.clear();
        }
        for &(n, v) in &s.r_set {
            match v {
                Some(v) => self.r_values.insert(n, v),
                None => self.r_values.remove(&n),
            };
        }
        let opened = match kind {
            BlockKind::For => Some(LoopKind::For),
            BlockKind::While => Some(LoopKind::While),
            BlockKind::Loop => Some(LoopKind::Loop),
            BlockKind::Repeat => Some(LoopKind::RepeatUntil),
            _ => None,
        };
        if let Some(kind) = opened {
            let runs = match &s.count {
                Some(Count::For { from, to }) => for_runs(self.value(*from), self.value(*to)),
                _ if kind == LoopKind::For => Err("bounds computed at run time"),
                _ => Err("ends on a condition at run time"),
            };
            self.open_loops.push(OpenLoop {
                kind,
                block: i,
                start_min: self.time,
                runs,
                entry: self.state.clone(),
            });
            return;
        }
        let closes = matches!(
            kind,
            BlockKind::EndWhile | BlockKind::EndFor | BlockKind::EndLoop | BlockKind::Until
        );
        if closes && let Some(open) = self.open_loops.pop() {
            self.mark_varying(&open.entry, (open.block + 1, i));
            let (runs, unknown) = match open.runs {
                Ok(n) => (Some(n), None),
                Err(why) => (None, Some(why)),
            };
            self.repeat(Loop {
                kind: open.kind,
                block: open.block,
                body: (open.block + 1, i),
                runs,
                unknown,
                start_min: open.start_min,
                body_min: start - open.start_min,
                repeat_block: i,
                repeat_min: self.time,
            });
        }
        if let Some(Count::Section {
            labels,
            single,
            times,
        }) = &s.count
        {
            let section = self.section(i, labels, *single, start);
            let times = self
                .value(*times)
                .filter(|n| *n >= 0.0 && n.fract() == 0.0)
                .ok_or("repeat count computed at run time");
            let (body, start_min, body_min, runs, unknown) = match (section, times) {
                (Ok(sec), Ok(n)) => {
                    self.mark_varying(&sec.entry, (sec.body.0 + 1, sec.body.1));
                    (
                        sec.body,
                        sec.start,
                        sec.end - sec.start,
                        Some((n as u64).saturating_add(1)),
                        None,
                    )
                }
                (Err(why), _) | (_, Err(why)) => ((i, i), start, 0.0, None, Some(why)),
            };
            self.repeat(Loop {
                kind: if *single {
                    LoopKind::RepeatBlock
                } else {
                    LoopKind::Repeat
                },
                block: i,
                body,
                runs,
                unknown,
                start_min,
                body_min,
                repeat_block: i,
                repeat_min: self.time,
            });
        }
    }

    /// Records a loop and adds its further runs to the time.
    fn repeat(&mut self, l: Loop) {
        self.time += l.further_runs() as f64 * l.body_min;
        self.t.loops.push(l);
    }

    /// The blocks and time span (first run) of the section a REPEAT statement at block `i` repeats: from
    /// the label to the statement, from the first label to the second, or (REPEATB) the labelled block.
    /// Only a section the program ran through before the statement is known.
    /// Returns the blocks, the start and end of the first run and the state it starts in.
    fn section(
        &self,
        i: usize,
        labels: &[String],
        single: bool,
        start: f64,
    ) -> Result<Section, &'static str> {
        let seen = |label: &String| {
            self.label_times
                .get(label)
                .ok_or("the section is not before the REPEAT statement")
        };
        let first = seen(&labels[0])?;
        let (last_block, end) = match labels.get(1) {
            _ if single => (first.block, first.end),
            Some(end) => {
                let last = seen(end)?;
                if last.block < first.block {
                    return Err("the section's labels are in reverse order");
                }
                (last.block, last.end)
            }
            None => (i.saturating_sub(1), start),
        };
        Ok(Section {
            body: (first.block, last_block),
            start: first.start,
            end,
            entry: first.state.clone(),
        })
    }

    /// Marks the sites of a body that a later run reaches in another modal state: a field in which the state
    /// at the repeat differs from `entry`, and which the body does not change before the site.
    fn mark_varying(&mut self, entry: &Modal, body: (usize, usize)) {
        let differ = field::differ(entry, &self.state);
        if !differ.contains(&true) {
            return;
        }
        let from = self.site_changes.partition_point(|(b, _)| *b < body.0);
        for (b, changed) in &self.site_changes[from..] {
            if *b > body.1 {
                break;
            }
            let set_before = |f: usize| changed[f] > body.0 && changed[f] - 1 < *b;
            if (0..field::COUNT).any(|f| differ[f] && !set_before(f)) {
                self.varies.insert(*b);
            }
        }
    }

    /// Notes a block where a site or pass mark arises, with the fields' last changes.
    fn note_site(&mut self, i: usize) {
        if !self.open_loops.is_empty() || !self.label_times.is_empty() {
            self.site_changes.push((i, self.changed));
        }
    }

    /// A bound's value: a number, or an R-parameter last assigned a literal.
    fn value(&self, b: Bound) -> Option<f64> {
        match b {
            Bound::Number(v) => Some(v),
            Bound::R(n) => self.r_values.get(&n).copied(),
            Bound::Other => None,
        }
    }

    /// The block's move (or dwell, with G4: F seconds or S revolutions) and the tool change's time, with
    /// the modal state already updated by the block's words.
    #[allow(clippy::too_many_arguments)]
    fn movement(
        &mut self,
        i: usize,
        start: f64,
        before: &Modal,
        mv: &Move,
        g4: bool,
        revolutions: Option<f64>,
        mut inexact: bool,
        tool_change: bool,
    ) {
        let rpm = self.state.rpm();
        let moved = mv.axes.iter().any(Option::is_some);
        // A dwell right after the retract is as clear of the part as the next rapid, and a gate before it is
        // the only one a long dwell can have.
        let dwell = g4 && !moved;
        let retract_candidate = self.last_was_z_retract
            && self.state.motion == 0
            && self.state.absolute
            && (dwell || (moved && mv.axes[2].is_none()));
        if retract_candidate {
            if self.after_call {
                self.varies.insert(i);
            }
            self.note_site(i);
            let first_in_loop = self.loop_depth > 0 && self.loop_gate_pending;
            self.loop_gate_pending &= !first_in_loop;
            self.t.sites.push(Site {
                block: i,
                kind: SiteKind::Retract { first_in_loop },
                time_min: start,
                pass: 0,
                before: before.clone(),
                rpm_after: rpm,
                state_varies: false,
            });
        }
        let from = self.pos;
        let mut to = self.pos;
        for k in 0..3 {
            if let Some((v, absolute)) = mv.axes[k] {
                to[k] = if absolute || self.state.absolute {
                    Some(v)
                } else {
                    Some(from[k].unwrap_or(0.0) + v)
                };
            }
        }
        let mut minutes = 0.0;
        if g4 {
            minutes += match (mv.f, revolutions) {
                (Some(sec), _) => sec / 60.0,
                (None, Some(rev)) if rpm > 0.0 => rev / rpm,
                _ => {
                    inexact = true;
                    0.0
                }
            };
        } else if moved {
            let length = self.move_length(from, to, mv);
            if self.state.motion == 0 {
                minutes += length / self.profile.timeline.rapid_mm_per_min;
            } else {
                let feed = self
                    .state
                    .feed
                    .map(|f| if self.per_rev { f * rpm } else { f });
                match feed {
                    Some(f) if f > 0.0 => minutes += length / f,
                    _ => inexact = true,
                }
            }
        }
        if tool_change {
            minutes += self.profile.timeline.tool_change_s / 60.0;
        }
        self.t.inexact_blocks += usize::from(inexact);
        self.last_was_z_retract = moved
            && self.state.motion == 0
            && mv.axes[0].is_none()
            && mv.axes[1].is_none()
            && match (from[2], to[2]) {
                (Some(a), Some(b)) => b > a,
                (None, Some(_)) => true,
                _ => false,
            };
        self.pos = to;
        if self.state.z != to[2] {
            self.state.z = to[2];
            self.changed[field::Z] = i + 1;
        }
        self.time += minutes;
    }

    /// Length of the move from `from` to `to`: straight, or along the arc for G2/G3 (XY plane).
    fn move_length(&self, from: [Option<f64>; 3], to: [Option<f64>; 3], mv: &Move) -> f64 {
        let a = from.map(|v| v.unwrap_or(0.0));
        let b = to.map(|v| v.unwrap_or(0.0));
        let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let straight = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if !matches!(self.state.motion, 2 | 3) {
            return straight;
        }
        let cw = self.state.motion == 2;
        let (r, sweep) = match (mv.centre[0], mv.centre[1], mv.radius) {
            (i, j, _) if i.is_some() || j.is_some() => {
                let c = [a[0] + i.unwrap_or(0.0), a[1] + j.unwrap_or(0.0)];
                let r = ((a[0] - c[0]).powi(2) + (a[1] - c[1]).powi(2)).sqrt();
                let a0 = (a[1] - c[1]).atan2(a[0] - c[0]);
                let a1 = (b[1] - c[1]).atan2(b[0] - c[0]);
                let mut sweep = if cw { a0 - a1 } else { a1 - a0 };
                if sweep <= 1e-12 {
                    sweep += std::f64::consts::TAU;
                }
                (r, sweep)
            }
            (_, _, Some(cr)) => {
                let chord = (d[0] * d[0] + d[1] * d[1]).sqrt();
                let r = cr.abs().max(chord / 2.0);
                let small = 2.0 * (chord / (2.0 * r)).clamp(-1.0, 1.0).asin();
                // CR < 0 selects the arc over 180°.
                (
                    r,
                    if cr < 0.0 {
                        std::f64::consts::TAU - small
                    } else {
                        small
                    },
                )
            }
            _ => return straight,
        };
        ((r * sweep).powi(2) + d[2] * d[2]).sqrt()
    }

    fn finish(mut self) -> Timeline {
        self.t.total_min = self.time;
        // Without M6 in the program the T word changes the tool.
        let mut starts = self.pass_marks;
        if !self.m6_seen && self.profile.passes.tool_change {
            starts.extend(self.tool_marks);
        }
        starts.sort_by_key(|m| m.block);
        starts.dedup_by_key(|m| m.block);
        let ends: Vec<f64> = starts
            .iter()
            .skip(1)
            .map(|m| m.time)
            .chain(std::iter::once(self.time))
            .collect();
        for (k, (m, end)) in starts.into_iter().zip(ends).enumerate() {
            self.t.passes.push(Pass {
                number: k + 1,
                first_block: m.block,
                start_min: m.time,
                end_min: end,
                tool: m.tool,
                max_rpm: speed_max(&self.t.speeds, m.time, end),
            });
            self.t.sites.push(Site {
                block: m.block,
                kind: SiteKind::PassStart {
                    tool_change: m.tool_change,
                },
                time_min: m.time,
                pass: k + 1,
                before: m.before,
                rpm_after: m.rpm,
                state_varies: false,
            });
        }
        // One site per block: a pass start wins over a speed change or retract at the same block.
        self.t
            .sites
            .sort_by_key(|s| (s.block, !matches!(s.kind, SiteKind::PassStart { .. })));
        self.t.sites.dedup_by_key(|s| s.block);
        let mut pass = 0;
        for site in &mut self.t.sites {
            site.state_varies = self.varies.contains(&site.block);
            match site.kind {
                SiteKind::PassStart { .. } => pass = site.pass,
                _ => site.pass = pass,
            }
        }
        self.t
    }
}

/// A block that may start a pass, with the state around it.
struct PassMark {
    block: usize,
    tool_change: bool,
    time: f64,
    before: Modal,
    rpm: f64,
    tool: Option<Arc<str>>,
}

/// Highest speed held at any time in [from, to).
fn speed_max(speeds: &[(f64, f64)], from: f64, to: f64) -> f64 {
    let mut max: f64 = 0.0;
    for (k, &(t, rpm)) in speeds.iter().enumerate() {
        let next = speeds.get(k + 1).map_or(f64::INFINITY, |s| s.0);
        if next > from && t < to.max(from + 1e-12) {
            max = max.max(rpm);
        }
    }
    max
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every line the word scanner accepts gives the same facts as the syntax tree.
    #[test]
    fn word_scanner_agrees_with_the_tree() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut sources = vec![
            b"N10 G1 X10.5 Y-3 F800 ; PASS finish\nG0 Z50.\nT12 M6\nS3000 M3 D2\nG2 X1 Y2 I-.5 J0\nG54 G90\nG3 X5 Y5 CR=-12.5 F100\n"
                .to_vec(),
        ];
        for name in ["handwritten.mpf", "crlf.mpf", "latin1.mpf"] {
            sources.push(std::fs::read(dir.join("fixtures/omm").join(name)).unwrap());
        }
        // The real CAM program joins the sources when ../shared is there.
        if let Some(cam) =
            crate::shared_data::path("corpus/sinumerik-840d-sl-cas-package/Approach A/CAM TEST.MPF")
        {
            sources.push(std::fs::read(cam).unwrap());
        }
        let mut fast = 0;
        for src in sources {
            let program = crate::parse(&src);
            // One buffer for all lines, as `build` uses it: a field left over from a line shows here.
            let mut quick = Scan::default();
            for i in 0..program.block_count() {
                let span = program.content_span(i);
                if scan_words_into(&program.source()[span.start..span.end], "PASS", &mut quick) {
                    let mut tree = scan_tree(&program, i, "PASS");
                    let mut copy = quick.clone();
                    let len = usize::from(copy.g.len);
                    copy.g.v[..len].sort_unstable();
                    let len = usize::from(tree.g.len);
                    tree.g.v[..len].sort_unstable();
                    assert_eq!(copy, tree, "line {}", i + 1);
                    fast += 1;
                }
            }
        }
        assert!(fast > 50, "the scanner took only {fast} lines");
    }

    /// The timeline of a program folded block by block from whole scans, as before chunks existed.
    fn block_by_block(program: &Program, profile: &Profile) -> Timeline {
        let subprograms = HashMap::new();
        let mut folders = Folders::new(profile);
        let mut b = Builder::new(profile, &subprograms, &mut folders);
        let mut words = Scan::default();
        for i in 0..program.block_count() {
            let span = program.content_span(i);
            let kind = program.block_kind(i);
            let line = &program.source()[span.start..span.end];
            if kind == BlockKind::Plain && scan_words_into(line, "PASS", &mut words) {
                b.block(i, &words, kind);
            } else {
                b.block(i, &scan_tree(program, i, "PASS"), kind);
            }
        }
        let mut t = b.finish();
        t.unit_end = program.block_count();
        t
    }

    /// Large programs are read in parallel chunks, moves packed into heads and numbers: the timeline is the
    /// one the blocks give one by one, site for site and bit for bit.
    #[test]
    fn chunks_give_the_block_by_block_timeline() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut text = std::fs::read(dir.join("fixtures/omm/handwritten.mpf")).unwrap();
        text.truncate(text.len() - b"M5\nM30\n".len());
        let mut n = 0u64;
        while text.len() < 3_000_000 {
            let x = (n * 37 % 4000) as f64 / 10.0;
            let line = match n % 9 {
                0 => format!("N{n} G1 X{x} Y-{x} Z-1.5 F900\n"),
                1 => format!("N{n} G3 X{x} Y{x} CR=-12.5\n"),
                2 => format!("G2 X0 Y{x} I-{x} J.5 ; arc\n"),
                3 => "G0 Z50\n".to_string(),
                4 => format!("X{x} Y{x}\n"),
                5 if n % 1000 == 5 => {
                    format!("T{} M6 ; PASS\nS{} M3\nG4 F2\n", n % 7, 1000 + n % 5000)
                }
                6 => format!("G1 X=AC({x}) Y=IC(2) Z=R1\n"),
                7 if n % 500 == 7 => "WHILE R1<2\nG0 Z10\nG0 X1\nENDWHILE\n".to_string(),
                _ => format!("G91 G1 X1 F{}\nG90\n", 100 + n % 50),
            };
            text.extend_from_slice(line.as_bytes());
            n += 1;
        }
        text.extend_from_slice(b"M5\nM30\n");
        let program = crate::parse(&text);
        assert!(program.block_count() > 3 * CHUNK_BLOCKS);
        let profile = Profile::default_profile();
        let chunked = build(&program, &profile);
        assert!(chunked.sites.len() > 100 && chunked.passes.len() > 10);
        assert_eq!(chunked, block_by_block(&program, &profile));
    }

    fn timeline_of(text: &str) -> Timeline {
        build(&crate::parse(text.as_bytes()), &Profile::default_profile())
    }

    /// One minute of cutting at F100 over 100 mm, then the way back as a rapid.
    const BODY: &str = "G1 X100 F100\nG0 Z50\nG0 X0\nG1 Z0 F6000\n";

    fn loop_time(t: &Timeline) -> f64 {
        t.loops[0].body_min
    }

    /// The times of the first retract site's runs.
    fn retract_times(t: &Timeline) -> Vec<f64> {
        let retract = t
            .sites
            .iter()
            .position(|s| matches!(s.kind, SiteKind::Retract { .. }))
            .unwrap();
        let runs = crate::omm::loops::site_runs(t);
        assert!(runs.complete);
        runs.sites
            .iter()
            .filter(|(k, _)| *k == retract)
            .map(|(_, time)| *time)
            .collect()
    }

    /// The time of the tool change every test program starts with.
    fn base() -> f64 {
        timeline_of("T1 M6\nS1000 M3\nM30\n").total_min
    }

    #[test]
    fn a_for_loop_with_literal_bounds_runs_its_body_that_often() {
        let once = timeline_of(&format!("T1 M6\nS1000 M3\n{BODY}M30\n"));
        let t = timeline_of(&format!(
            "T1 M6\nS1000 M3\nFOR R1 = 3 TO 7\n{BODY}ENDFOR\nM30\n"
        ));
        let l = &t.loops[0];
        assert_eq!((l.kind, l.runs, l.unknown), (LoopKind::For, Some(5), None));
        assert_eq!((l.block, l.body, l.repeat_block), (2, (3, 7), 7));
        assert!((loop_time(&t) - (once.total_min - base())).abs() < 1e-9);
        assert!((t.total_min - base() - 5.0 * loop_time(&t)).abs() < 1e-9);
        // The retract site in the body is listed once per run, a body apart.
        let times = retract_times(&t);
        assert_eq!(times.len(), 5);
        for pair in times.windows(2) {
            assert!((pair[1] - pair[0] - loop_time(&t)).abs() < 1e-9);
        }
    }

    #[test]
    fn r_parameter_bounds_count_when_last_assigned_a_literal() {
        let t = timeline_of(&format!(
            "R5=4\nT1 M6\nS1000 M3\nFOR R1 = 1 TO R5\n{BODY}ENDFOR\nR5=R5+1\nFOR R2 = 1 TO R5\n{BODY}ENDFOR\nM30\n"
        ));
        assert_eq!(t.loops[0].runs, Some(4));
        assert_eq!(t.loops[1].runs, None);
        assert_eq!(t.loops[1].unknown, Some("bounds computed at run time"));
        assert!((t.total_min - base() - 5.0 * loop_time(&t)).abs() < 1e-9);
    }

    #[test]
    fn loops_ending_on_a_condition_are_counted_once() {
        let t = timeline_of(&format!(
            "T1 M6\nS1000 M3\nWHILE R1<3\n{BODY}R1=R1+1\nENDWHILE\nREPEAT\n{BODY}UNTIL R1>5\nFOR R2 = 5 TO 1\n{BODY}ENDFOR\nM30\n"
        ));
        let kinds: Vec<_> = t.loops.iter().map(|l| (l.kind, l.runs)).collect();
        assert_eq!(
            kinds,
            [
                (LoopKind::While, None),
                (LoopKind::RepeatUntil, None),
                (LoopKind::For, None)
            ]
        );
        assert_eq!(t.loops[2].unknown, Some("the bounds give no run"));
        assert!((t.total_min - base() - 3.0 * loop_time(&t)).abs() < 1e-9);
    }

    #[test]
    fn section_repeats_add_their_runs_at_the_statement() {
        let t = timeline_of(&format!(
            "T1 M6\nS1000 M3\nSTART: G0 X0\n{BODY}REPEAT START P=2\nONE: G1 X100 F100\nG0 X0\nREPEATB ONE P=3\nREPEAT LATER P=2\nLATER: G0 X0\nM30\n"
        ));
        let counted: Vec<_> = t
            .loops
            .iter()
            .map(|l| (l.kind, l.block, l.body, l.runs))
            .collect();
        assert_eq!(
            counted,
            [
                (LoopKind::Repeat, 7, (2, 6), Some(3)),
                (LoopKind::RepeatBlock, 10, (8, 8), Some(4)),
                (LoopKind::Repeat, 11, (11, 11), None),
            ]
        );
        assert_eq!(
            t.loops[2].unknown,
            Some("the section is not before the REPEAT statement")
        );
        // The section: one minute of cutting plus rapids, three times; the repeated block one minute, four
        // times; the rapid back in between.
        let section = t.loops[0].body_min;
        assert!((t.loops[1].body_min - 1.0).abs() < 1e-9);
        let rapid_back = 100.0 / Profile::default_profile().timeline.rapid_mm_per_min;
        assert!((t.total_min - base() - (3.0 * section + 4.0 + rapid_back)).abs() < 1e-9);
    }

    #[test]
    fn nested_counted_loops_multiply() {
        let t = timeline_of(&format!(
            "T1 M6\nS1000 M3\nFOR R1 = 1 TO 3\nFOR R2 = 1 TO 4\n{BODY}ENDFOR\nENDFOR\nM30\n"
        ));
        let inner = t.loops[0].body_min;
        assert!((t.loops[1].body_min - 4.0 * inner).abs() < 1e-9);
        assert!((t.total_min - base() - 12.0 * inner).abs() < 1e-9);
        let times = retract_times(&t);
        assert_eq!(times.len(), 12);
        assert!(times.windows(2).all(|w| (w[1] - w[0] - inner).abs() < 1e-9));
    }

    #[test]
    fn a_loop_of_millions_of_runs_is_timed_but_not_listed_run_by_run() {
        let t = timeline_of(&format!(
            "T1 M6\nS1000 M3\nFOR R1 = 1 TO 5000000\n{BODY}ENDFOR\nM30\n"
        ));
        assert!((t.total_min - base() - 5e6 * loop_time(&t)).abs() < 1e-3);
        let runs = crate::omm::loops::site_runs(&t);
        assert!(!runs.complete);
        assert_eq!(runs.sites.len(), crate::omm::loops::MAX_SITE_RUNS);
        // Counts past u64 and a section that is its own statement neither overflow nor hang.
        let t = timeline_of(&format!(
            "START: REPEAT START P=2\nT1 M6\nFOR R1 = 0 TO 99999999999999999999\n{BODY}ENDFOR\nM30\n"
        ));
        assert_eq!(t.loops[1].runs, Some(u64::MAX));
        assert_eq!(t.loops[0].runs, Some(3));
        assert!(t.total_min.is_finite());
    }

    /// A gate in a loop body restores the state of the body's first run: where a later run reaches the
    /// block in another state (the spindle speed set after it in the body), the site says so.
    #[test]
    fn sites_reached_in_another_state_by_later_runs_are_marked() {
        let text = "T1 M6\nS1000 M3\nG0 X0 Y0 Z10\nFOR R1 = 1 TO 3\nG0 Z50\nG0 X10\nG1 Z-1 F100\nS2000 M3\nG1 X100\nG0 Z40\nG0 X0\nENDFOR\nM30\n";
        let t = timeline_of(text);
        let retracts: Vec<(usize, bool)> = t
            .sites
            .iter()
            .filter(|s| matches!(s.kind, SiteKind::Retract { .. }))
            .map(|s| (s.block, s.state_varies))
            .collect();
        // Before `G0 X10` the speed is 1000 rpm in the first run and 2000 in later ones; before `G0 X0` it
        // was set in the same run.
        assert_eq!(retracts, [(5, true), (10, false)]);
        let (_, plan) = crate::omm::plan_program(
            &crate::parse(text.as_bytes()),
            &crate::model::DriftModel::read(
                std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("fixtures/omm/model.toml")
                    .as_ref(),
            )
            .unwrap(),
            &Profile::default_profile(),
        )
        .unwrap();
        let gate = plan.gates.iter().find(|g| g.block == 5).unwrap();
        assert!(!gate.can_measure);
        // Without the speed change, and with the feed set before the loop: every run alike.
        let same = timeline_of(
            &text
                .replace("S2000 M3\n", "")
                .replace("G0 X0 Y0 Z10", "G0 X0 Y0 Z10 F100"),
        );
        assert!(same.sites.iter().all(|s| !s.state_varies));
    }

    #[test]
    fn subprogram_and_cycle_calls_are_listed_as_not_timed() {
        let t = timeline_of(
            "G0 X0 Y0\nMSG(\"roughing\")\nCYCLE81(10,0,2,-5)\nN40 L100 P3\nCALL \"CONTOUR\"\nMCALL CYCLE82(10,0,2,-5,,1)\nX10\nY10\nF200\nMCALL\nSETAL(65000)\nG1 X20 F100\nPOCKET\nSTOPRE\nTRANS Z1\nSOFT\nSUB2 P3\nM30\n",
        );
        let calls: Vec<(usize, &str)> = t
            .untimed_calls
            .iter()
            .map(|(line, name)| (*line, name.as_str()))
            .collect();
        assert_eq!(
            calls,
            [
                (3, "CYCLE81"),
                (4, "L100"),
                (5, "CONTOUR"),
                // A modal call runs after each block that moves, until `MCALL` alone.
                (7, "MCALL CYCLE82"),
                (8, "MCALL CYCLE82"),
                // A bare name calls a subprogram unless the control predefines it.
                (13, "POCKET"),
                (17, "SUB2"),
            ]
        );
    }

    #[test]
    fn archive_subprograms_are_timed_in_the_order_they_call_each_other() {
        // SUBA calls SUBB, which comes before it; SUBC and SUBD call each other.
        let archive = "%_N_MAIN_MPF\n;$PATH=/_N_MPF_DIR\nG90 G0 X0 Y0 Z0\nT1 M6\nSUBA P2\nMCALL SUBB\nG0 X10\nG0 X0\nMCALL\nSUBC\nM30\n\
                       %_N_SUBB_SPF\nG91 G1 X10 F100\nG90\nM17\n\
                       %_N_SUBA_SPF\nG91 G1 X100 F100\nG90\nSUBB\nM17\n\
                       %_N_SUBC_SPF\nG91 G1 Z100 F100\nG90\nSUBD\nM17\n\
                       %_N_SUBD_SPF\nG91 G1 Z50 F100\nG90\nSUBC\nM17\n";
        let t = timeline_of(archive);
        let tool_change = Profile::default_profile().timeline.tool_change_s / 60.0;
        let rapid = |mm: f64| mm / Profile::default_profile().timeline.rapid_mm_per_min;
        // SUBA twice (1 + 0.1 min each), SUBB after both moves of the modal call (0.1 min each), SUBC
        // (1 min) with SUBD (0.5 min) once: the call back from SUBD to SUBC is not followed.
        let expected = tool_change + 2.0 * 1.1 + 2.0 * (rapid(10.0) + 0.1) + 1.5;
        assert!(
            (t.total_min - expected).abs() < 1e-9,
            "{} vs {expected}",
            t.total_min
        );
        assert_eq!(t.untimed_calls, [(29, "SUBC".to_string())]);
    }

    #[test]
    fn an_archive_times_its_main_program_and_the_subprograms_it_calls() {
        let main = |call: &str| {
            format!(
                "%_N_MAIN_MPF\n;$PATH=/_N_MPF_DIR\nG90 G0 X0 Y0 Z0\nT1 M6\nG1 X100 F100\n{call}G0 Z50\nM30\n"
            )
        };
        let subprograms = "%_N_L100_SPF\n;$PATH=/_N_SPF_DIR\nG91 G1 X10 F100\nG90\nT2 M6\nR55=1\nM17\n\
                           %_N_OTHER_SPF\nG0 Z10\nG55\nM17\n";
        let alone = timeline_of(&main(""));
        let t = timeline_of(&(main("L100 P3\n") + subprograms));
        // Three runs of 10 mm at F100 and a tool change, nothing of the other units.
        let tool_change = Profile::default_profile().timeline.tool_change_s / 60.0;
        let added = t.total_min - alone.total_min;
        assert!((added - 3.0 * (0.1 + tool_change)).abs() < 1e-9, "{added}");
        assert_eq!(t.unit_end, 8);
        assert!(t.sites.iter().all(|s| s.block < 8) && t.passes.len() == 1);
        assert_eq!(t.ends.len(), 1);
        // What the other units use is taken all the same: R-parameters are global on the control.
        assert!(t.used_r.contains(&55));
        assert!(t.offsets.iter().any(|(g, _)| *g == 55));
        assert!(t.untimed_calls.is_empty());
        // A subprogram not in the archive stays untimed.
        let t = timeline_of(&(main("L200\n") + subprograms));
        assert_eq!(t.untimed_calls, [(6, "L200".to_string())]);
    }

    #[test]
    fn subprograms_in_the_profiles_folders_add_their_time_and_take_their_r_parameters() {
        let dir = tempfile::tempdir().unwrap();
        let write = |name: &str, text: &str| std::fs::write(dir.path().join(name), text).unwrap();
        // ROUGH cuts 100 mm and calls DRILLIT (10 mm) and a cycle; LOOPA and LOOPB call each other.
        write(
            "rough.spf",
            "G91 G1 X100 F100\nR905=1\nDRILLIT\nCYCLE81(1,0,1,-1)\nG90\nM17\n",
        );
        write("_N_DRILLIT_SPF", "G91 G1 Z-10 F100\nG90\nM17\n");
        write("LOOPA.SPF", "G91 G1 X50 F100\nG90\nLOOPB\nM17\n");
        write("LOOPB.SPF", "G91 G1 X50 F100\nG90\nLOOPA\nM17\n");
        let mut profile = Profile::default_profile();
        profile.timeline.subprograms = vec![dir.path().to_path_buf()];
        let program = "G90 G0 X0 Y0 Z0\nT1 M6\nROUGH P2\nLOOPA\nOTHER\nM30\n";
        let t = build(&crate::parse(program.as_bytes()), &profile);
        let alone = timeline_of(program);
        // ROUGH twice (1 + 0.1 min), LOOPA with LOOPB once (1 min): the call back to LOOPA is not followed.
        let added = t.total_min - alone.total_min;
        assert!((added - (2.0 * 1.1 + 1.0)).abs() < 1e-9, "{added}");
        // What the subprograms leave untimed is listed at the call in this program.
        let calls: Vec<(usize, &str)> = t
            .untimed_calls
            .iter()
            .map(|(line, name)| (*line, name.as_str()))
            .collect();
        assert_eq!(calls, [(3, "CYCLE81"), (4, "LOOPA"), (5, "OTHER")]);
        assert!(t.used_r.contains(&905) && !alone.used_r.contains(&905));
    }

    #[test]
    fn the_spindle_a_subprogram_programs_is_followed_through_the_call() {
        // ROUGH starts the spindle itself; FINISH sets only S (the spindle already turns) and stops it.
        let t = timeline_of(
            "%_N_MAIN_MPF\n;$PATH=/_N_MPF_DIR\nG90 G0 X0 Y0 Z0\nT1 M6\nROUGH\nG0 Z50\nFINISH\nG0 Z60\nM30\n\
             %_N_ROUGH_SPF\nS6000 M3\nG91 G1 X100 F100\nG90\nM17\n\
             %_N_FINISH_SPF\nS2000\nG91 G1 X100 F100\nG90\nM5\nM17\n",
        );
        let tc = Profile::default_profile().timeline.tool_change_s / 60.0;
        let finish = tc + 1.0 + 50.0 / Profile::default_profile().timeline.rapid_mm_per_min;
        let expected = [
            (0.0, 0.0),
            (tc, 6000.0),
            (finish, 2000.0),
            (finish + 1.0, 0.0),
        ];
        assert_eq!(t.speeds.len(), expected.len(), "{:?}", t.speeds);
        for (got, want) in t.speeds.iter().zip(expected) {
            assert!(
                (got.0 - want.0).abs() < 1e-9 && got.1 == want.1,
                "{got:?} vs {want:?}"
            );
        }
        let changes: Vec<(usize, f64)> = t
            .sites
            .iter()
            .filter(|s| s.kind == SiteKind::SpeedChange)
            .map(|s| (s.block + 1, s.rpm_after))
            .collect();
        // A gate before each call takes the call's mean speed (the subprogram has no gates of its own), the
        // block after it the speed the subprogram left, where that differs.
        assert_eq!(changes, [(5, 6000.0), (7, 2000.0), (8, 0.0)]);
    }

    #[test]
    fn after_a_call_no_gate_restores_a_state_until_the_next_tool_change() {
        let t = timeline_of(
            "T1 M6\nS2000 M3\nG0 X0 Y0 Z2\nG1 Z-1 F100\nG0 Z50\nG0 X10\nCYCLE81(10,0,2,-5)\nG1 Z-1\nG0 Z50\nG0 X20\nT2 M6\nG0 Z2\nG1 Z-1 F100\nG0 Z50\nG0 X30\nM30\n",
        );
        let retracts: Vec<(usize, bool)> = t
            .sites
            .iter()
            .filter(|s| matches!(s.kind, SiteKind::Retract { .. }))
            .map(|s| (s.block + 1, s.state_varies))
            .collect();
        // The cycle may have left another speed, feed or frame: the retract after it cannot measure.
        assert_eq!(retracts, [(6, false), (10, true), (15, false)]);
    }

    #[test]
    fn decimals_match_the_standard_parser() {
        for t in [
            "0",
            "-0.5",
            "+12.",
            ".25",
            "165.356",
            "-224.452",
            "19083.899",
            "123456789012345",
            "12345678",
            "-123456789.1234",
            "0.000001",
            "98765432.0",
            "1.2345678912",
            "00000000000042",
        ] {
            assert_eq!(
                decimal(t.as_bytes()),
                Some(t.parse::<f64>().unwrap()),
                "{t}"
            );
        }
        for t in ["", "-", "1.2.3", "1e5", "1234567890123456", "12a"] {
            assert_eq!(decimal(t.as_bytes()), None, "{t}");
        }
    }

    #[test]
    fn a_dwell_after_a_retract_is_a_site() {
        let text = "T1 M6\nS4000 M3\nG0 X0 Y0 Z2\nG1 Z-1 F300\nG1 X50 F1200\nG0 Z5\nG4 F600\nG1 X0\nG4 F60\nM30\n";
        let program = crate::parse(text.as_bytes());
        let t = build(&program, &Profile::default_profile());
        let retracts: Vec<usize> = t
            .sites
            .iter()
            .filter(|s| matches!(s.kind, SiteKind::Retract { .. }))
            .map(|s| s.block)
            .collect();
        // The dwell after `G0 Z5` (block 6), not the one after a feed move (block 8).
        assert_eq!(retracts, [6]);
    }
}
