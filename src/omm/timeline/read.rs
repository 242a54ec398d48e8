//! Reading blocks for the timeline: a word scanner for the plain lines CAM output is made of, the syntax
//! tree for any other block, and the packing of plain moves into chunks.

use std::sync::Arc;

use crate::syntax::{Block, BlockKind, Node, NodeKind, Program, decimal_prefix};
use crate::views::{AxisMode, Value, VarName, WorkOffset, facts, is_predefined_command};

use super::modal::unknown;

/// What one block says, reduced to what the timeline needs (built in parallel).
#[derive(Debug, Default, Clone, PartialEq)]
pub(super) struct Scan {
    pub(super) g: Codes,
    pub(super) mv: Move,
    pub(super) inexact: bool,
    pub(super) s: Option<f64>,
    pub(super) m: Codes,
    pub(super) tool: Option<Arc<str>>,
    pub(super) d: Option<u32>,
    pub(super) marker: bool,
    pub(super) declaration: bool,
    pub(super) path_comment: bool,
    pub(super) kind_header: bool,
    pub(super) r: Vec<Option<u32>>,
    pub(super) label: Option<String>,
    pub(super) offsets: Vec<u32>,
    /// R-parameters the block assigns, with the value when it is a literal.
    pub(super) r_set: Vec<(u32, Option<f64>)>,
    /// FOR bounds or a section repeat's labels and count.
    pub(super) count: Option<Count>,
    /// A subprogram or cycle the block calls.
    pub(super) call: Option<String>,
    /// `MCALL NAME`: NAME runs after each later block that moves; `MCALL` alone (`Some(None)`) ends that.
    pub(super) modal_call: Option<Option<String>>,
    /// `P`: how often the call runs.
    pub(super) repeats: Option<f64>,
    /// What the block does to frames and transformations ([`frame_op`] bits).
    pub(super) frame_ops: u8,
    /// Fields the block sets by an expression ([`super::unknown`] bits).
    pub(super) unknown: u8,
    /// The block holds a statement the timeline does not read (a variable assignment, a control
    /// statement, a call): it ends the declarations at the top.
    pub(super) statement: bool,
    /// The block moves an axis other than X, Y, Z (a rotary axis, say).
    pub(super) other_axes: bool,
}

/// Bits of [`Scan::frame_ops`].
pub(super) mod frame_op {
    /// TRANS, ATRANS, CTRANS with values.
    pub const TRANSLATE: u8 = 1;
    /// ROT, AROT, SCALE, MIRROR, … with values.
    pub const ROTATE: u8 = 2;
    /// TRANS, ROT, SCALE or MIRROR alone: the programmable frame is deleted.
    pub const CLEAR: u8 = 4;
    /// TRAORI, TRANSMIT, TRACYL, TRAANG.
    pub const TRANSFORM_ON: u8 = 8;
    /// TRAFOOF.
    pub const TRANSFORM_OFF: u8 = 16;
    /// CYCLE800 with an angle or an expression.
    pub const SWIVEL_ON: u8 = 32;
    /// CYCLE800() or CYCLE800 with every angle 0.
    pub const SWIVEL_OFF: u8 = 64;
    /// A write to a frame variable (`$P_UIFR[…]`, `$P_PFRAME`, …).
    pub const WRITE: u8 = 128;
}

/// The words of a block a move needs: axes (value, written with AC), arc centre or radius, feed.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub(super) struct Move {
    pub(super) axes: [Option<(f64, bool)>; 3],
    pub(super) centre: [Option<f64>; 3],
    pub(super) radius: Option<f64>,
    pub(super) f: Option<f64>,
}

/// A loop bound or repeat count as written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Bound {
    Number(f64),
    R(u32),
    Other,
}

/// What a FOR header or a section repeat statement says about the count.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Count {
    For {
        from: Bound,
        to: Bound,
    },
    /// `REPEAT a [b] P=n` (`single`: REPEATB). `times` is P (1 when absent).
    Section {
        labels: Vec<String>,
        single: bool,
        times: Bound,
    },
}

/// Blocks read as one piece of work.
pub(super) const CHUNK_BLOCKS: usize = 1 << 15;

/// The blocks of one chunk as the fold needs them: a plain move (the lines CAM output is made of) as a
/// head of bits and its numbers, any other block as its whole [`Scan`] (4 bytes per typical CAM line
/// instead of a few hundred).
pub(super) struct Chunk {
    pub(super) first: usize,
    pub(super) heads: Vec<u16>,
    pub(super) numbers: Vec<f64>,
    pub(super) others: Vec<(BlockKind, Scan)>,
    /// The blocks of the chunk that runs of moves the parser timed cover: not read, one head
    /// [`head::RUN`] for each range (the fold takes them from the runs).
    pub(super) covered: Vec<std::ops::Range<usize>>,
}

/// Bits of a chunk's head: which numbers follow (x, y, z, i, j, k, cr, f in that order), the axes written
/// with AC, the motion code, the block being one of the chunk's `others`, or in a run of timed moves.
pub(super) mod head {
    pub const AC: u16 = 8;
    pub const MOTION: u16 = 1 << 11;
    pub const MOTION_CODE: u16 = 12;
    pub const RUN: u16 = 1 << 14;
    pub const OTHER: u16 = 1 << 15;
}

/// Reads the blocks of `blocks` but those in `covered` (ranges in order, within `blocks`).
pub(super) fn scan_chunk(
    program: &Program,
    blocks: std::ops::Range<usize>,
    marker: &str,
    covered: Vec<std::ops::Range<usize>>,
) -> Chunk {
    let uncovered = blocks.len() - covered.iter().map(|c| c.len()).sum::<usize>();
    let mut chunk = Chunk {
        first: blocks.start,
        heads: Vec::with_capacity(uncovered + covered.len()),
        numbers: Vec::with_capacity(uncovered * 4),
        others: Vec::new(),
        covered: Vec::new(),
    };
    // One buffer for the word scanner, filled in place line after line: no per-line copies.
    let mut words = Scan::default();
    let src = program.source();
    let mut covered = covered.into_iter().peekable();
    let mut i = blocks.start;
    while i < blocks.end {
        if let Some(run) = covered.next_if(|c| c.start == i) {
            chunk.heads.push(head::RUN);
            i = run.end;
            chunk.covered.push(run);
            continue;
        }
        scan_block(program, src, i, marker, &mut words, &mut chunk);
        i += 1;
    }
    chunk
}

/// Reads block `i` into the chunk.
fn scan_block(
    program: &Program,
    src: &[u8],
    i: usize,
    marker: &str,
    words: &mut Scan,
    chunk: &mut Chunk,
) {
    let kind = program.block_kind(i);
    let content = program.content_span(i);
    if kind == BlockKind::Plain && scan_words_into(&src[content.start..content.end], marker, words)
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
            && self.modal_call.is_none()
            && self.frame_ops == 0
            && self.unknown == 0
            && !self.statement;
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
    pub(super) fn decode(h: u16, numbers: &mut impl Iterator<Item = f64>) -> Move {
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

pub(super) fn scan_tree(program: &Program, i: usize, marker: &str) -> Scan {
    let block = program.block(i);
    let f = facts(&block);
    let mut s = Scan {
        kind_header: block.kind == BlockKind::Header,
        label: f.label.clone(),
        statement: block.root.significant().any(|n| match n.kind {
            NodeKind::Comment
            | NodeKind::BlockNumber
            | NodeKind::Def
            | NodeKind::Proc
            | NodeKind::Extern
            | NodeKind::Define
            | NodeKind::Header
            | NodeKind::Word => false,
            // `CR=5`, `X=R1`: an address with a value, read like a word.
            NodeKind::Assign => !n.children.first().is_some_and(|t| {
                let name = block.text(t);
                t.kind == NodeKind::Var
                    && name.len() <= 2
                    && name.iter().all(u8::is_ascii_alphabetic)
            }),
            _ => true,
        }),
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
            _ => {
                s.other_axes = true;
                continue;
            }
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
    if f.feed.is_some() && s.mv.f.is_none() {
        s.unknown |= unknown::FEED;
    }
    let speed = f
        .spindle_speeds
        .iter()
        .find(|a| a.extension.is_none_or(|e| e == 1));
    s.s = speed.and_then(|a| num(&a.value));
    if speed.is_some() && s.s.is_none() {
        s.unknown |= unknown::S;
    }
    for v in f
        .m_codes
        .iter()
        .filter(|a| a.extension.is_none_or(|e| e == 1))
        .filter_map(|a| num(&a.value))
    {
        s.m.push(v as u32);
    }
    if let Some(a) = f.tools.first() {
        let text = tool_text(&block, a.span);
        if is_tool_literal(text) {
            s.tool = Some(Arc::from(String::from_utf8_lossy(text).as_ref()));
        } else {
            s.unknown |= unknown::TOOL;
        }
    }
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
                s.frame_ops |= transformation_op(&name);
                if name == "CYCLE800" {
                    s.frame_ops |= swivel_op(&block, node);
                }
                if !TIMELESS_PROCEDURES.contains(&name.as_str()) {
                    s.call = Some(name);
                }
            }
            NodeKind::Command => {
                let name = String::from_utf8_lossy(block.text(node)).to_ascii_uppercase();
                s.frame_ops |= transformation_op(&name) | frame_command_op(&name, &f, &block);
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
    if f.work_offsets
        .iter()
        .any(|w| matches!(w, WorkOffset::FrameWrite(_)))
    {
        s.frame_ops |= frame_op::WRITE;
    }
    // The axis words of a frame command are its values, not a move.
    if s.frame_ops & (frame_op::TRANSLATE | frame_op::ROTATE) != 0 {
        s.mv.axes = [None; 3];
        s.inexact = false;
    }
    s
}

/// A tool written as a name in quotes or a number: what a gate can write back as it is.
fn is_tool_literal(text: &[u8]) -> bool {
    let quoted = text.len() >= 2 && text[0] == b'"' && text[text.len() - 1] == b'"';
    quoted || (!text.is_empty() && text.iter().all(u8::is_ascii_digit))
}

/// TRAORI, TRANSMIT, TRACYL, TRAANG switch a transformation on, TRAFOOF off.
fn transformation_op(name: &str) -> u8 {
    match name {
        "TRAORI" | "TRANSMIT" | "TRACYL" | "TRAANG" => frame_op::TRANSFORM_ON,
        "TRAFOOF" => frame_op::TRANSFORM_OFF,
        _ => 0,
    }
}

/// A frame command with its values (axis words, `RPL=`), or an absolute one alone, which deletes the
/// programmable frame.
fn frame_command_op(name: &str, f: &crate::views::BlockFacts, block: &Block<'_>) -> u8 {
    let rpl = block.root.significant().any(|n| {
        n.kind == NodeKind::Assign
            && n.children
                .first()
                .is_some_and(|t| block.text(t).eq_ignore_ascii_case(b"RPL"))
    });
    let valued = !f.axes.is_empty() || rpl;
    match name {
        "TRANS" | "ATRANS" | "CTRANS" if valued => frame_op::TRANSLATE,
        "ROT" | "AROT" | "CROT" | "ROTS" | "AROTS" | "CROTS" | "SCALE" | "ASCALE" | "CSCALE"
        | "MIRROR" | "AMIRROR" | "CMIRROR"
            if valued =>
        {
            frame_op::ROTATE
        }
        "TRANS" | "ROT" | "SCALE" | "MIRROR" => frame_op::CLEAR,
        _ => 0,
    }
}

/// `CYCLE800()` and a CYCLE800 whose every numeric argument from the fifth on (the swivel's offsets and
/// angles) is 0 or empty end the swivel; any other call swivels (an expression counts as an angle).
fn swivel_op(block: &Block<'_>, call: &Node) -> u8 {
    let args = call.call_arguments();
    let tilted = args.iter().skip(4).flatten().any(|a| {
        // Strings (the swivel data record's name) and empty arguments do not tilt.
        a.kind != NodeKind::Str && literal(block, a) != Some(0.0)
    });
    if tilted {
        frame_op::SWIVEL_ON
    } else {
        frame_op::SWIVEL_OFF
    }
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
pub(super) fn scan_words_into(line: &[u8], marker: &str, s: &mut Scan) -> bool {
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
        // Read here so arcs stay on this path.
        if at_radius(line, i) {
            let (radius, end) = radius_at(line, i)?;
            s.mv.radius = Some(radius);
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
pub(super) struct Codes {
    pub(super) len: u8,
    pub(super) v: [u16; Codes::CAP],
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

    pub(super) fn iter(&self) -> impl Iterator<Item = u32> + '_ {
        self.v[..usize::from(self.len)]
            .iter()
            .map(|&c| u32::from(c))
    }

    pub(super) fn contains(&self, code: u32) -> bool {
        self.iter().any(|c| c == code)
    }

    pub(super) fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// `[+-]digits[.digits]` as f64, for the word scanner: exact for up to 15 significant digits, which is
/// what CAM output carries; anything else (exponents, more digits) returns `None` and takes the tree path.
pub(super) fn decimal(text: &[u8]) -> Option<f64> {
    decimal_prefix(text).and_then(|(v, len)| (len == text.len()).then_some(v))
}

/// Whether `line[i..]` starts `CR=`, the radius of an arc: the one assignment CAM arcs carry.
pub(super) fn at_radius(line: &[u8], i: usize) -> bool {
    line.get(i..i + 3)
        .is_some_and(|t| t.eq_ignore_ascii_case(b"CR="))
}

/// The radius of the `CR=` at `line[i..]` and where it ends (at a blank, `;` or the line's end); `None` when
/// it is not a plain number.
pub(super) fn radius_at(line: &[u8], i: usize) -> Option<(f64, usize)> {
    let end = line[i + 3..]
        .iter()
        .position(|c| matches!(c, b' ' | b'\t' | b';'))
        .map_or(line.len(), |p| i + 3 + p);
    Some((decimal(&line[i + 3..end])?, end))
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
    let Some((address, number)) = node.address_and_number() else {
        return;
    };
    let letter = block.text(address).to_ascii_uppercase();
    let value = std::str::from_utf8(block.text(number))
        .ok()
        .and_then(|t| t.parse::<f64>().ok());
    match (letter.as_slice(), value) {
        (b"D", Some(d)) if d >= 0.0 && d.fract() == 0.0 => s.d = Some(d as u32),
        (b"D", _) => s.unknown |= unknown::D,
        (b"I", Some(v)) => s.mv.centre[0] = Some(v),
        (b"J", Some(v)) => s.mv.centre[1] = Some(v),
        (b"K", Some(v)) => s.mv.centre[2] = Some(v),
        // `L123 P3`: subprogram 123, run three times.
        (b"P", Some(p)) => s.repeats = Some(p),
        (b"L", Some(_)) => {
            s.call = Some(format!("L{}", String::from_utf8_lossy(block.text(number))))
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
        b"D" => match v {
            Some(d) if d >= 0.0 && d.fract() == 0.0 => s.d = Some(d as u32),
            _ => s.unknown |= unknown::D,
        },
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
