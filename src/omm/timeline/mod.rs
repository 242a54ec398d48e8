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

use crate::syntax::Program;

use super::loops::Loop;
use super::profile::Profile;
use super::subprograms::Folders;

/// The modal state a gate must restore after it moved the machine, and what makes a place unfit for a gate.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Modal {
    /// The tool in the spindle as written after `T=` or `T` (`"DRILL 8.5"` with quotes, or `12`).
    pub tool: Option<Arc<str>>,
    /// The tool the last `T` selected: the preselection a later bare `M6` loads (equal to `tool` after a
    /// change).
    pub selected: Option<Arc<str>>,
    pub d: Option<u32>,
    /// Programmed spindle speed and direction (3, 4 or 5 = stopped).
    pub s: f64,
    pub direction: u32,
    pub feed: Option<f64>,
    /// Modal motion G code (0, 1, 2, 3).
    pub motion: u32,
    pub absolute: bool,
    pub z: Option<f64>,
    /// G93 / G94 / G95 (G96 / G97 keep G95), when the program set it.
    pub feed_mode: Option<u32>,
    /// G17 / G18 / G19, when the program set it.
    pub plane: Option<u32>,
    /// Exact stop or continuous path: G60, G64, G641 … G645, when the program set it.
    pub path_mode: Option<u32>,
    /// M7 / M8 (on) or M9 (off), when the program set it.
    pub coolant: Option<u32>,
    /// Cutter radius compensation: 40, 41 or 42.
    pub comp: u32,
    /// The work offset selected (54 … 57, 505 … 599, or 500 for none), when the program selected one.
    pub offset: Option<u32>,
    /// X is programmed in diameters (DIAMON, DIAM90).
    pub diameter: bool,
    /// Under constant cutting speed (G96, `s` in m/min): the spindle speed estimated where S was set,
    /// n = 1000·v / (π·D) at the diameter the tool stood at, capped by LIMS.
    pub css_rpm: Option<f64>,
    /// Frames and transformations active ([`frame`] bits).
    pub frames: u8,
    /// Fields the program set by an expression the timeline cannot evaluate ([`unknown`] bits): a gate
    /// cannot write them back.
    pub unknown: u8,
}

/// Bits of [`Modal::frames`].
pub mod frame {
    /// A programmable translation (TRANS, ATRANS, CTRANS with values).
    pub const TRANSLATION: u8 = 1;
    /// A programmable rotation, scale or mirror (ROT, AROT, SCALE, MIRROR, … with values).
    pub const ROTATION: u8 = 2;
    /// A kinematic transformation: TRAORI, TRANSMIT, TRACYL, TRAANG.
    pub const TRANSFORMATION: u8 = 4;
    /// A swivelled plane: CYCLE800 with an angle.
    pub const SWIVEL: u8 = 8;
}

/// Bits of [`Modal::unknown`].
pub mod unknown {
    pub const TOOL: u8 = 1;
    pub const D: u8 = 2;
    pub const S: u8 = 4;
    pub const FEED: u8 = 8;
}

impl Modal {
    /// Speed the spindle turns at (rpm, 0 when stopped).
    pub fn rpm(&self) -> f64 {
        if matches!(self.direction, 3 | 4) {
            self.css_rpm.unwrap_or(self.s).abs()
        } else {
            0.0
        }
    }

    /// Why no inserted block may run here (a STOPRE, a work-offset write or a move would spoil the
    /// contour or move along a tilted axis); `None` when the place is fit.
    pub fn unfit(&self) -> Option<&'static str> {
        if matches!(self.comp, 41 | 42) {
            Some("cutter radius compensation (G41/G42) is active")
        } else if self.frames & frame::SWIVEL != 0 {
            Some("a swivelled plane (CYCLE800) is active")
        } else if self.frames & frame::TRANSFORMATION != 0 {
            Some("a transformation (TRAORI, TRANSMIT, TRACYL) is active")
        } else if self.frames & frame::ROTATION != 0 {
            Some("a rotated, scaled or mirrored frame is active")
        } else {
            None
        }
    }

    /// Why a gate here cannot measure and give the state back, beyond [`Modal::unfit`]; `None` when it can.
    pub fn not_restorable(&self) -> Option<&'static str> {
        if let Some(why) = self.unfit() {
            Some(why)
        } else if self.motion >= 2 {
            Some("a circle (G2/G3) is the modal motion")
        } else if self.unknown & unknown::TOOL != 0 {
            Some("the tool is set by an expression")
        } else if self.d == Some(0) {
            Some("D0 is active: heights are the spindle's, not the tool tip's")
        } else if self.unknown & unknown::D != 0 {
            Some("the D number is set by an expression")
        } else if self.unknown & unknown::S != 0 && self.rpm() > 0.0 {
            Some("the spindle speed is set by an expression")
        } else if self.unknown & unknown::FEED != 0 {
            Some("the feed is set by an expression")
        } else {
            None
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
    /// The block after a programmed stop (M0, M1): the program waits there, the tool clear of the part.
    Stop,
    /// The block after a call of a dressing cycle the profile names: the wheel is off the part.
    Dressing,
    /// The first block after the program's own setup (declarations, work offset, frames) and before its
    /// first cut: where a reference measurement can go when no other site lies between the two.
    Start,
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
    /// Minutes from the end of the last cut (feed move) before the block to its start: the part drifts
    /// in that time without being cut.
    pub idle_min: f64,
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
    /// Calls of subprograms the timeline timed (the archive's, or a folder's): (line, name, min per run).
    pub timed_calls: Vec<(usize, String, f64)>,
    /// Where the unit programs the spindle: (min from its start, S, M3/M4/M5). A call of the unit replays
    /// them onto the caller's spindle (a subprogram may set only S, or only M3, and inherit the rest).
    pub spindle_words: Vec<(f64, Option<f64>, Option<u32>)>,
    /// First block after the unit the timeline covers (the block count, unless the file is an archive).
    pub unit_end: usize,
    /// First block that moves at feed (G1, G2, G3): the first cut.
    pub first_cut: Option<usize>,
    /// When the last cut ended (min from the start).
    pub last_cut_min: f64,
    /// The program moves an axis, or calls a subprogram or cycle that may.
    pub moves: bool,
    /// Blocks that write a frame variable themselves (`$P_UIFR[…]=`, `$P_PFRAME=`, …).
    pub frame_writes: Vec<usize>,
    /// One past the last block before the first cut that selects a work offset or changes frames or
    /// transformations: the reference measurement goes after the program's own setup.
    pub setup_end: usize,
}

/// The timeline of the program's first unit: of the whole file, or of the main program of an archive. The
/// archive's other units are timed on their own, so that a call of one of its subprograms (`%_N_NAME_SPF`)
/// adds that subprogram's time, as often as `P` says; the R-parameters, labels and work offsets they use
/// count as used. So does a call of a subprogram in the profile's folders, with the R-parameters it uses.
pub fn build(program: &Program, profile: &Profile) -> Timeline {
    build_with(program, None, profile, &mut Folders::new(profile))
}

/// [`build`] for a program parsed with [`parse_timed`]: the runs of moves the parser timed are folded
/// without reading their blocks again. The timeline is the one [`build`] makes.
pub fn build_with_moves(program: &Program, moves: &Moves, profile: &Profile) -> Timeline {
    build_with(program, Some(moves), profile, &mut Folders::new(profile))
}

pub(super) fn build_with(
    program: &Program,
    moves: Option<&Moves>,
    profile: &Profile,
    folders: &mut Folders,
) -> Timeline {
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
                moves,
                u.clone(),
                profile,
                &HashMap::new(),
                folders,
            ))
        })
        .collect();
    let calls: Vec<&BTreeSet<String>> = alone.iter().flatten().map(|(_, c)| c).collect();
    let order = callees_first(&names, &calls);
    let mut subprograms = HashMap::new();
    let mut others = Vec::new();
    for k in order {
        let (first, called) = alone[k].take().expect("each unit once");
        let t = if called
            .iter()
            .any(|c| names.iter().flatten().any(|n| n == c))
        {
            let unit = units[k + 1].clone();
            build_unit(program, moves, unit, profile, &subprograms, folders).0
        } else {
            first
        };
        if let Some(name) = &names[k] {
            subprograms.insert(name.clone(), t.clone());
        }
        others.push(t);
    }
    let mut t = build_unit(
        program,
        moves,
        units[0].clone(),
        profile,
        &subprograms,
        folders,
    )
    .0;
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
fn callees_first(names: &[Option<String>], calls: &[&BTreeSet<String>]) -> Vec<usize> {
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
    let src = program.source();
    // Comments and blank lines before the first header belong to its unit (a title above `%_N_…_MPF`).
    let only_comments = |blocks: std::ops::Range<usize>| {
        blocks.into_iter().all(|i| {
            let text = program.content_span(i).slice(src).trim_ascii();
            text.is_empty() || text.starts_with(b";")
        })
    };
    let mut starts = vec![0];
    starts.extend(
        program
            .header_blocks()
            .iter()
            .filter(|&&h| h > 0 && !only_comments(0..h)),
    );
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

fn build_unit<'m>(
    program: &Program,
    moves: Option<&'m Moves>,
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
        scan_chunk(
            program,
            from..count.min(from + CHUNK_BLOCKS),
            &marker,
            moves,
        )
    };
    let read = |blocks: std::ops::Range<usize>| scan_chunk(program, blocks, &marker, None);
    let helpers = rayon::current_num_threads().saturating_sub(1);
    if chunks <= 1 || helpers == 0 {
        (0..chunks).for_each(|k| b.fold(&scan(k), &read));
        let called = std::mem::take(&mut b.called);
        return (b.finish(), called);
    }
    // Reading the blocks is independent line by line, the fold is not. Helpers read chunks in order of a
    // shared counter, at most AHEAD chunks past the fold (so the records never hold the whole program);
    // this thread folds them in order and, while the next one is not ready, reads chunks itself.
    const AHEAD: usize = 8;
    let next = AtomicUsize::new(0);
    let ready: Mutex<(Vec<Option<Chunk<'m>>>, usize)> =
        Mutex::new(((0..chunks).map(|_| None).collect(), 0));
    let changed = Condvar::new();
    let put = |k: usize, chunk: Chunk<'m>| {
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
            b.fold(&chunk, &read);
            ready.lock().expect("no panic while held").1 = k + 1;
            changed.notify_all();
        }
    });
    let called = std::mem::take(&mut b.called);
    (b.finish(), called)
}

mod fold;
mod moves;
mod read;
#[cfg(test)]
mod tests;

use fold::Builder;
pub(crate) use fold::on_tick;
pub use moves::{Moves, parse_timed};
use read::{CHUNK_BLOCKS, Chunk, scan_chunk};
