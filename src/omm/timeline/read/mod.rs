//! Reading blocks for the timeline: each block reduced to a [`Scan`] of what the timeline needs — by the
//! word scanner (`words`) for the plain lines CAM output is made of, from the syntax tree (`tree`) for any
//! other — and a chunk's plain moves packed into heads and numbers.

use std::sync::Arc;

use super::modal::Diameter;
use crate::syntax::{BlockKind, Program};

mod tree;
mod words;

pub(super) use tree::{measures_workpiece, scan_tree, section_call_labels};
#[cfg(test)]
pub(super) use words::decimal;
pub(super) use words::{at_radius, radius_at, scan_words_into};

/// What one block says, reduced to what the timeline needs (built in parallel).
#[derive(Debug, Default, Clone, PartialEq)]
pub(super) struct Scan {
    /// A skip level (`/`, `/0` … `/9`): the operator's skip switch may leave the block out.
    pub(super) skippable: bool,
    pub(super) g: Codes,
    pub(super) mv: Move,
    pub(super) inexact: bool,
    pub(super) s: Option<f64>,
    pub(super) m: Codes,
    pub(super) tool: Option<Arc<str>>,
    pub(super) d: Option<u32>,
    pub(super) marker: bool,
    pub(super) declaration: bool,
    /// `PROC … SAVE`: the unit's G codes come back at its end.
    pub(super) saves: bool,
    /// The names of a `PROC`'s parameters, in order (upper case).
    pub(super) params: Vec<String>,
    /// `T=_NR`: the variable a tool is selected by, where the expression is one name alone.
    pub(super) tool_variable: Option<String>,
    /// `D=_SCHN`: the same for the cutting edge.
    pub(super) d_variable: Option<String>,
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
    /// How the block writes that call where it is not by the name alone (`EXTCALL ROUGH` for
    /// `EXTCALL "D:/JOBS/ROUGH.SPF"`), for what driftloop says about it.
    pub(super) call_shown: Option<String>,
    /// The arguments of the call written with parentheses, for a call declared to load the tool one of
    /// them gives (`L706(, 5, , "1")`).
    pub(super) call_args: Vec<CallArg>,
    /// `MCALL NAME`: NAME runs after each later block that moves; `MCALL` alone (`Some(None)`) ends that.
    pub(super) modal_call: Option<Option<String>>,
    /// `P`: how often the call runs.
    pub(super) repeats: Option<f64>,
    /// What the block does to frames and transformations ([`frame_op`] bits).
    pub(super) frame_ops: u8,
    /// Fields the block sets by an expression ([`super::unknown`] bits).
    pub(super) unknown: u16,
    /// The block holds a statement the timeline does not read (a variable assignment, a control
    /// statement, a call): it ends the declarations at the top.
    pub(super) statement: bool,
    /// The block moves an axis other than X, Y, Z (a rotary axis, say).
    pub(super) other_axes: bool,
    /// DIAMON, DIAM90 or DIAMOF: how X values are read from here on.
    pub(super) diameter: Option<Diameter>,
    /// `LIMS=`: the speed limit under constant cutting speed (rpm).
    pub(super) lims: Option<f64>,
    /// `GOTOS` (back to the program's start) or `RET` (back to the caller): for what driftloop restores,
    /// an end.
    pub(super) leaves: bool,
    /// A write to `$P_IFRAME`, the frame in force, which the gates correct or select anew.
    pub(super) writes_frame_in_force: bool,
    /// Rotary axes A, B, C (bits 1, 2, 4) the block positions away from 0, or to 0.
    pub(super) rotary_away: u8,
    pub(super) rotary_home: u8,
    /// Rotary axes given a variable (`A=_A_HOME`, `C=R5`): its bit and the name, for the value the fold
    /// knows.
    pub(super) rotary_vars: Vec<(u8, String)>,
    /// The spindle speed given by a variable or R-parameter (`S=R1`, `S=_DREHZAHL`): its name, for the
    /// value the fold knows.
    pub(super) speed_var: Option<String>,
    /// The block programs the tool's orientation (`A3=`, `B2=`, `LEAD=` … under TRAORI): the rotary axes
    /// the kinematics turn for it stay turned after TRAFOOF.
    pub(super) orients: bool,
    /// `DL=`: a sum offset selected (`true`) or deselected with `DL=0` (`false`).
    pub(super) sum_offset: Option<bool>,
    /// `RNDM=`: modal rounding switched on (`true`, also by an expression) or off with `RNDM=0` (`false`).
    pub(super) rounding: Option<bool>,
    /// Programmed tool offsets (`TOFFL=`, `TOFFR=`, `TOFF[axis]=`, the online offsets of `TOFFON(axis)`,
    /// one bit each) the block sets to something other than 0 (or switches on), and those it sets to 0
    /// (or `TOFFOF` switches off).
    pub(super) tool_offset_on: u16,
    pub(super) tool_offset_off: u16,
    /// A write to cutting-edge data, `$TC_DP…[t,d]=`.
    pub(super) writes_tool_data: bool,
    /// `CT`: the block's arc starts tangent to the move before it.
    pub(super) tangent_start: bool,
    /// `RND=`, `CHF=`, `CHR=`: the block's end is rounded or chamfered into the next move.
    pub(super) joins_next: bool,
    /// `CANCEL` with no argument: every modal synchronized action ends.
    pub(super) cancels_sync_actions: bool,
    /// `AP=` or `RP=`: the block programs in polar coordinates.
    pub(super) polar: bool,
    /// `ASPLINE`, `BSPLINE`, `CSPLINE` or `POLY`: a spline or polynomial becomes the modal motion.
    pub(super) spline: bool,
    /// `FXS[axis]=…`: travel to fixed stop selected on the axis (`true`) or deselected with 0 (`false`).
    pub(super) fixed_stop: Vec<(String, bool)>,
    /// `GEOAX(…)`: geometry axes assigned to other channel axes (`true`) or, with no argument, back to the
    /// machine's basic assignment (`false`).
    pub(super) geometry_axes: Option<bool>,
    /// `WALIMON` (`true`) or `WALIMOF` (`false`): working-area limits monitored or not.
    pub(super) work_area_monitor: Option<bool>,
    /// `TCARR=`: an orientable toolholder selected (`true`) or deselected with `TCARR=0` (`false`).
    pub(super) tool_carrier: Option<bool>,
    /// Plain variables the block assigns, with the value when it is a literal.
    pub(super) var_set: Vec<(String, Option<f64>)>,
}

/// An argument of a call as written.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum CallArg {
    /// Left out (`L706(, 5)`'s first).
    Empty,
    /// A name in quotes or a number: what a gate can write back as a tool.
    Literal(Arc<str>),
    /// Anything else (an R-parameter, an expression).
    Other,
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
    /// The axis is written with IC(…): incremental whatever G90/G91 say.
    pub(super) incremental: [bool; 3],
    pub(super) centre: [Option<f64>; 3],
    pub(super) radius: Option<f64>,
    pub(super) f: Option<f64>,
    /// The axis is written by an expression (`Z=R20`, `Z=_ZSICHER`): it moves somewhere the timeline does
    /// not know.
    pub(super) expression: [bool; 3],
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
            && !self.statement
            && self.rotary_away | self.rotary_home == 0
            && self.sum_offset.is_none()
            && self.rounding.is_none()
            && self.tool_offset_on | self.tool_offset_off == 0
            && !self.writes_tool_data
            && !self.tangent_start
            && !self.polar
            && !self.cancels_sync_actions
            && !self.spline
            && self.fixed_stop.is_empty()
            && self.geometry_axes.is_none()
            && !self.joins_next
            && self.work_area_monitor.is_none()
            && self.tool_carrier.is_none()
            // The head has no room for IC(…): such a block keeps its whole scan.
            && !self.mv.incremental.contains(&true);
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
            incremental: [false; 3],
            expression: [false; 3],
        }
    }
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

/// Marker and `;$PATH` facts of a comment (`text` starts at the `;`).
fn comment(text: &[u8], marker: &str, s: &mut Scan) {
    s.path_comment = text.starts_with(b";$PATH");
    let words = text[1..].trim_ascii_start();
    // The marker as a word: `PASS 2`, `PASS:` but not `Passung`.
    s.marker = !marker.is_empty()
        && words.len() >= marker.len()
        && words[..marker.len()].eq_ignore_ascii_case(marker.as_bytes())
        && words
            .get(marker.len())
            .is_none_or(|b| !b.is_ascii_alphanumeric() && *b != b'_');
}
