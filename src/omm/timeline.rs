//! The program's timeline, estimated from its moves: feed moves take distance / F (arcs by their length,
//! G95 feeds per revolution by F·S), rapids distance / rapid rate, dwells their time, tool changes the
//! profile's time. It also collects what the emitter needs to know about the program: where passes start,
//! where the spindle speed changes, where the tool is retracted (safe points for extra measurements),
//! where the program ends, and which R-parameters and labels it already uses.
//!
//! The program is read once, in order, without running it: loops and jumps are counted once, expressions
//! as coordinates count as no move (`inexact_blocks` says how many blocks that affected).

use std::collections::BTreeSet;
use std::sync::Arc;

use crate::syntax::{Block, BlockKind, Node, NodeKind, Program};
use crate::views::{AxisMode, Value, VarName, WorkOffset, facts};

use super::profile::Profile;

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

#[derive(Debug, Clone, Default)]
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
    /// Blocks whose moves could not be timed (expressions, unknown feed).
    pub inexact_blocks: usize,
}

/// What one block says, reduced to what the timeline needs (built in parallel).
#[derive(Debug, Default, Clone, PartialEq)]
struct Scan {
    g: Codes,
    axes: [Option<(f64, bool)>; 3],
    inexact: bool,
    centre: [Option<f64>; 3],
    radius: Option<f64>,
    f: Option<f64>,
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
}

pub fn build(program: &Program, profile: &Profile) -> Timeline {
    let marker = profile.passes.marker.to_ascii_uppercase();
    let mut b = Builder::new(profile);
    // One buffer for the word scanner, filled in place line after line: no per-line copies.
    let mut words = Scan::default();
    for i in 0..program.block_count() {
        let content = program.content_span(i);
        let line = &program.source()[content.start..content.end];
        if program.block_kind(i) == BlockKind::Plain && scan_words_into(line, &marker, &mut words) {
            b.block(i, &words, program.block_kind(i));
        } else {
            b.block(i, &scan_tree(program, i, &marker), program.block_kind(i));
        }
    }
    b.finish()
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
                s.axes[k] = Some((*v, a.mode == AxisMode::Ac))
            }
            (Value::Number(v), AxisMode::Ic) => s.axes[k] = Some((*v, false)),
            _ => s.inexact = true,
        }
    }
    let num = |v: &Value| match v {
        Value::Number(x) => Some(*x),
        _ => None,
    };
    s.f = f.feed.as_ref().and_then(|a| num(&a.value));
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
            _ => {}
        }
    }
    s
}

/// The same facts without a syntax tree, for the lines CAM output is made of: one-letter address words with
/// plain numbers and an optional comment (`N120 G1 X10.5 Y-3 F800 ; finish`). Anything else — `=`, names,
/// strings, labels, R-parameters — returns `None` and takes the tree path.
fn scan_words_into(line: &[u8], marker: &str, s: &mut Scan) -> bool {
    s.g.len = 0;
    s.m.len = 0;
    s.axes = [None; 3];
    s.centre = [None; 3];
    (s.radius, s.f, s.s, s.tool, s.d) = (None, None, None, None, None);
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
            s.radius = Some(decimal(&line[i + 3..end])?);
            i = end;
            continue;
        }
        let letter = b.to_ascii_uppercase();
        if !letter.is_ascii_uppercase() || letter == b'R' {
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
        let int = (v >= 0.0 && v == (v as u32) as f64).then_some(v as u32);
        match letter {
            b'G' => {
                let g = int?;
                if matches!(g, 53 | 153 | 500 | 54..=57 | 505..=599) {
                    s.offsets.push(g);
                }
                if !s.g.push(g) {
                    return None;
                }
            }
            b'X' => s.axes[0] = Some((v, false)),
            b'Y' => s.axes[1] = Some((v, false)),
            b'Z' => s.axes[2] = Some((v, false)),
            b'I' => s.centre[0] = Some(v),
            b'J' => s.centre[1] = Some(v),
            b'K' => s.centre[2] = Some(v),
            b'F' => s.f = Some(v),
            b'S' => s.s = Some(v),
            // The guard stores the code; a block with more codes than fit goes to the tree path.
            b'M' if !s.m.push(int?) => return None,
            b'T' => s.tool = Some(Arc::from(std::str::from_utf8(digits).ok()?)),
            b'D' => s.d = Some(int?),
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
    const POW10: [f64; 16] = [
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
    let v = mantissa as f64 / POW10[scale];
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
        (b"I", Some(v)) => s.centre[0] = Some(v),
        (b"J", Some(v)) => s.centre[1] = Some(v),
        (b"K", Some(v)) => s.centre[2] = Some(v),
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
    match name.as_slice() {
        b"CR" => s.radius = v,
        b"I" => s.centre[0] = v,
        b"J" => s.centre[1] = v,
        b"K" => s.centre[2] = v,
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
}

impl<'p> Builder<'p> {
    fn new(profile: &'p Profile) -> Self {
        Builder {
            profile,
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
        }
    }

    fn block(&mut self, i: usize, s: &Scan, kind: BlockKind) {
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
        if !self.header_done {
            if s.kind_header || s.path_comment {
                self.t.header_end = i + 1;
            } else {
                self.header_done = true;
            }
        }
        let blank = s.g.is_empty()
            && s.axes.iter().all(Option::is_none)
            && s.m.is_empty()
            && s.tool.is_none()
            && s.s.is_none()
            && s.r.is_empty();
        if !self.preamble_done {
            if s.declaration || s.kind_header || blank {
                self.t.preamble_end = i + 1;
            } else {
                self.preamble_done = true;
            }
        }
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
            if matches!(g, 54..=57 | 505..=599) && !self.t.offsets.iter().any(|(o, _)| *o == g) {
                self.t.offsets.push((g, i + 1));
            }
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
        if let Some(f) = s.f
            && !s.g.contains(4)
        {
            self.state.feed = Some(f);
        }
        if let Some(v) = s.s {
            self.state.s = v;
        }
        if let Some(d) = s.d {
            self.state.d = Some(d);
        }
        for m in s.m.iter() {
            match m {
                3..=5 => self.state.direction = m,
                6 => self.m6_seen = true,
                2 | 30 => self.t.ends.push(i),
                _ => {}
            }
        }
        let tool_change = s.m.contains(6);
        if let Some(tool) = &s.tool {
            self.state.tool = Some(tool.clone());
        }
        let rpm = self.state.rpm();
        let mark = |tool_change| PassMark {
            block: i,
            tool_change,
            time: start,
            before: before.clone(),
            rpm,
            tool: self.state.tool.clone(),
        };
        if s.tool.is_some() {
            self.tool_marks.push(mark(true));
        }
        let p = &self.profile.passes;
        let marked = s.marker || p.lines.contains(&(i + 1));
        if (p.tool_change && tool_change) || marked {
            self.pass_marks.push(mark(tool_change));
        }
        if rpm != self.rpm {
            self.rpm = rpm;
            self.t.speeds.push((start, rpm));
            self.t.sites.push(Site {
                block: i,
                kind: SiteKind::SpeedChange,
                time_min: start,
                pass: 0,
                before: before.clone(),
                rpm_after: rpm,
            });
        }
        // The move.
        let moved = s.axes.iter().any(Option::is_some);
        // A dwell right after the retract is as clear of the part as the next rapid, and a gate before it is
        // the only one a long dwell can have.
        let dwell = s.g.contains(4) && !moved;
        let retract_candidate = self.last_was_z_retract
            && self.state.motion == 0
            && self.state.absolute
            && (dwell || (moved && s.axes[2].is_none()));
        if retract_candidate {
            let first_in_loop = self.loop_depth > 0 && self.loop_gate_pending;
            self.loop_gate_pending &= !first_in_loop;
            self.t.sites.push(Site {
                block: i,
                kind: SiteKind::Retract { first_in_loop },
                time_min: start,
                pass: 0,
                before: before.clone(),
                rpm_after: rpm,
            });
        }
        let from = self.pos;
        let mut to = self.pos;
        for k in 0..3 {
            if let Some((v, absolute)) = s.axes[k] {
                to[k] = if absolute || self.state.absolute {
                    Some(v)
                } else {
                    Some(from[k].unwrap_or(0.0) + v)
                };
            }
        }
        let mut minutes = 0.0;
        let mut inexact = s.inexact;
        if s.g.contains(4) {
            minutes += match (s.f, s.s) {
                (Some(sec), _) => sec / 60.0,
                (None, Some(rev)) if rpm > 0.0 => rev / rpm,
                _ => {
                    inexact = true;
                    0.0
                }
            };
        } else if moved {
            let length = self.move_length(from, to, s);
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
            && s.axes[0].is_none()
            && s.axes[1].is_none()
            && match (from[2], to[2]) {
                (Some(a), Some(b)) => b > a,
                (None, Some(_)) => true,
                _ => false,
            };
        self.pos = to;
        self.state.z = to[2];
        self.time += minutes;
    }

    /// Length of the move from `from` to `to`: straight, or along the arc for G2/G3 (XY plane).
    fn move_length(&self, from: [Option<f64>; 3], to: [Option<f64>; 3], s: &Scan) -> f64 {
        let a = from.map(|v| v.unwrap_or(0.0));
        let b = to.map(|v| v.unwrap_or(0.0));
        let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let straight = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if !matches!(self.state.motion, 2 | 3) {
            return straight;
        }
        let cw = self.state.motion == 2;
        let (r, sweep) = match (s.centre[0], s.centre[1], s.radius) {
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
            });
        }
        // One site per block: a pass start wins over a speed change or retract at the same block.
        self.t
            .sites
            .sort_by_key(|s| (s.block, !matches!(s.kind, SiteKind::PassStart { .. })));
        self.t.sites.dedup_by_key(|s| s.block);
        let mut pass = 0;
        for site in &mut self.t.sites {
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
        let cam =
            dir.join("../shared/corpus/sinumerik-840d-sl-cas-package/Approach A/CAM TEST.MPF");
        match std::fs::read(&cam) {
            Ok(bytes) => sources.push(bytes),
            Err(_) => eprintln!("skipped: {} is absent", cam.display()),
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
