//! The plain moves of a program timed while the parser reads them: the parser hands each plain block's words
//! (with their values, read in the same pass that recognises the numbers) to a [`Mover`], and the text of a
//! line its grammar found plain (a radius arc, `G3 X1 Y1 CR=5`), which the mover reads itself. The mover
//! works out the length of every move it can from what the blocks before it in the same piece said, and
//! keeps runs of consecutive such blocks, with their feed moves' time summed in the timeline's ticks. The timeline then folds a run at once instead of reading its blocks again;
//! every other block (and every run whose assumptions the program's state at its start does not meet) is
//! read from its text as before, so the timeline is the same either way (a test checks this).

use crate::syntax::{Decimal, Program, Words, parse_owned_with, word_end_with};

use super::read::{at_radius, radius_at};
use super::timing::{move_length, ticks};

/// Parses `src` and times its plain moves in the same pass (see [`super::build_with_moves`]).
pub fn parse_timed(src: Vec<u8>) -> (Program, Moves) {
    let (program, pieces) = parse_owned_with(src, Mover::new);
    (program, Moves::from_pieces(pieces))
}

/// The runs of timed moves of a program: one record per run, plus the length of each rapid move in them.
#[derive(Debug, Clone)]
pub struct Moves {
    pieces: Vec<Piece>,
}

#[derive(Debug, Clone)]
struct Piece {
    /// Sorted by first block, not overlapping.
    runs: Vec<Run>,
    /// The lengths of the rapid moves of the runs, in order (their time depends on the profile's rapid rate).
    rapids: Vec<f64>,
}

/// Consecutive blocks that only move (`N`, `G0`-`G3`, `X Y Z I J K F`, `CR=`) and whose lengths are known from the
/// blocks before them, in absolute dimensions with feeds per minute. A run starts after any block that is
/// not such a move, or whose move depends on what came before the piece, and ends before the next, or with
/// the piece's first cut ([`Mover::end_run_at_first_cut`]).
#[derive(Debug, Clone)]
pub(super) struct Run {
    pub(super) first: usize,
    pub(super) count: usize,
    /// Where its rapid moves' lengths start in its piece, and how many there are.
    at: usize,
    rapid_count: usize,
    /// The time of its feed moves (length / F), in the timeline's ticks.
    pub(super) feed_ticks: u64,
    /// It has a feed move (a cut), and how many of its rapid moves come after the last one.
    pub(super) cuts: bool,
    pub(super) rapids_after_cut: usize,
    /// The first block is a rapid move without Z: a retract site if the block before it retracted.
    pub(super) first_could_retract: bool,
    pub(super) motion: Field<u32>,
    pub(super) feed: Field<f64>,
    /// Z the first block writes (`None`: it keeps the Z it starts at).
    pub(super) first_z: Option<f64>,
    /// The last block after the first whose move changes Z.
    pub(super) z_change: Option<usize>,
    /// Bit per axis the run's blocks write.
    axes: u8,
    /// The position after the run on the axes the run writes.
    pub(super) end_pos: [Option<f64>; 3],
    /// The last block is a rapid Z-only move up.
    pub(super) end_retract: bool,
    /// After its last cut a rapid rose in Z (`Some(true)`), or it ends with a cut (`Some(false)`); `None`
    /// when it neither cuts nor rises: whether the tool is clear of the part after it (see the fold).
    pub(super) clear_after: Option<bool>,
    /// Its last move along Z is a rapid down (`Some(true)`), or a rapid up or a cut (`Some(false)`);
    /// `None` when it moves no Z: whether the tool went down without cutting since it last rose.
    pub(super) lowered_after: Option<bool>,
    /// Its first block that moves is a feed move (`None`: none moves).
    pub(super) first_feed: Option<bool>,
    /// Its first feed move uses the feed in force before the run (`Some(false)`: a block of the run set
    /// one first; `None`: no feed move).
    pub(super) feed_read_first: Option<bool>,
    /// Its last block that moves is a feed along a contour, not straight up Z (`None`: none moves).
    pub(super) contour_after: Option<bool>,
    /// One of its blocks is such a feed.
    pub(super) any_contour: bool,
}

impl Run {
    /// Block numbers counted from the program's start instead of the piece's.
    fn shift(&mut self, by: usize) {
        self.first += by;
        let blocks = [
            self.motion.first.as_mut().map(|f| &mut f.0),
            self.motion.change.as_mut(),
            self.feed.first.as_mut().map(|f| &mut f.0),
            self.feed.change.as_mut(),
            self.z_change.as_mut(),
        ];
        for b in blocks.into_iter().flatten() {
            *b += by;
        }
    }
}

/// A modal value the run's blocks write: the first block writing it (whether that is a change depends on
/// the state before the run), the last block changing it after that, and its value at the end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Field<T> {
    pub(super) first: Option<(usize, T)>,
    pub(super) change: Option<usize>,
    pub(super) last: Option<T>,
}

impl<T: Copy + PartialEq> Field<T> {
    fn none() -> Self {
        Field {
            first: None,
            change: None,
            last: None,
        }
    }

    fn write(&mut self, block: usize, value: T) {
        match self.last {
            None => self.first = Some((block, value)),
            Some(v) if v != value => self.change = Some(block),
            Some(_) => {}
        }
        self.last = Some(value);
    }
}

/// A run with the lengths of its rapid moves.
#[derive(Debug, Clone, Copy)]
pub(super) struct RunRef<'m> {
    pub(super) run: &'m Run,
    pub(super) rapids: &'m [f64],
}

impl RunRef<'_> {
    pub(super) fn blocks(&self) -> std::ops::Range<usize> {
        self.run.first..self.run.first + self.run.count
    }
}

impl Moves {
    fn from_pieces(pieces: Vec<(usize, Mover)>) -> Moves {
        let pieces = pieces
            .into_iter()
            .map(|(first, mover)| {
                let (mut runs, rapids) = mover.finish();
                for r in &mut runs {
                    r.shift(first);
                }
                Piece { runs, rapids }
            })
            .collect();
        Moves { pieces }
    }

    /// The byte ranges of `program`'s source outside the runs, in order. A block in a run holds nothing but
    /// move words and a radius (`N G X Y Z I J K F`, `CR=`, digits, signs, points, blanks), so a search for
    /// text with any other letter in it needs to read only these (widened by the text's length, so a match
    /// across a run's edge is found too).
    pub(crate) fn untimed_bytes(&self, program: &Program) -> Vec<std::ops::Range<usize>> {
        let mut out = Vec::new();
        let mut from = 0;
        for r in self.overlapping(0..program.block_count()) {
            let blocks = r.blocks();
            let start = program.block_span(blocks.start).start;
            if start > from {
                out.push(from..start);
            }
            from = program.block_span(blocks.end - 1).end;
        }
        if from < program.source().len() {
            out.push(from..program.source().len());
        }
        out
    }

    /// The runs for a chunk of blocks the timeline reads: those that start in it, and the ranges of the
    /// chunk that runs cover (a run begun in an earlier chunk covers the start of this one), in order.
    pub(super) fn in_chunk(
        &self,
        blocks: std::ops::Range<usize>,
    ) -> (Vec<RunRef<'_>>, Vec<std::ops::Range<usize>>) {
        let runs = self.overlapping(blocks.clone());
        let covered = runs
            .iter()
            .map(|r| r.run.first.max(blocks.start)..r.blocks().end.min(blocks.end))
            .collect();
        let starting = runs
            .into_iter()
            .filter(|r| r.run.first >= blocks.start)
            .collect();
        (starting, covered)
    }

    /// The runs that cover any of `blocks`, in order.
    pub(super) fn overlapping(&self, blocks: std::ops::Range<usize>) -> Vec<RunRef<'_>> {
        let mut out = Vec::new();
        for piece in &self.pieces {
            let from = piece
                .runs
                .partition_point(|r| r.first + r.count <= blocks.start);
            for run in piece.runs[from..]
                .iter()
                .take_while(|r| r.first < blocks.end)
            {
                out.push(RunRef {
                    run,
                    rapids: &piece.rapids[run.at..run.at + run.rapid_count],
                });
            }
        }
        out
    }
}

/// What an address letter is to a move: a value slot (x, y, z, i, j, k, f), the block number, the motion
/// code, or anything else (the block does more than move).
const SLOT_F: usize = 6;
const BLOCK_NUMBER: u8 = 7;
const MOTION: u8 = 8;
static LETTER: [u8; 256] = {
    let mut t = [u8::MAX; 256];
    let slots = *b"XYZIJKFNG";
    let mut k = 0;
    while k < slots.len() {
        t[slots[k] as usize] = k as u8;
        t[slots[k].to_ascii_lowercase() as usize] = k as u8;
        k += 1;
    }
    t
};

/// Times the moves of one piece of the program as the parser reads it.
#[derive(Debug)]
pub struct Mover {
    /// The line being read: its values by slot, where X, Y and Z hold the position before the line until
    /// the line writes them (so the position after a move needs no merging); a bit per slot written; its
    /// motion code ([`NO_MOTION`]: none); whether it does nothing but move so far.
    vals: [f64; 7],
    written: u8,
    motion_word: u32,
    /// The arc radius of a line the grammar read (`CR=`), see [`Mover::read_radius_line`].
    radius: Option<f64>,
    moves_only: bool,
    /// What the blocks of the piece so far say, as far as it does not depend on what came before the piece
    /// or on a block that is not a plain move: the axes in `known` (the others at 0), the motion code
    /// ([`NO_MOTION`] when not known), the feed when `feed_known`, and whether the last block retracted
    /// (`retract`: 0 no, 1 yes, [`UNKNOWN`]).
    pos: [f64; 3],
    known: u8,
    motion: u32,
    feed: f64,
    feed_known: bool,
    retract: u8,
    /// A feed move of the piece was timed (see [`Mover::finish_line`]).
    cut_seen: bool,
    block: usize,
    /// The run being extended, pushed to `runs` when a block ends it.
    open: Option<Run>,
    runs: Vec<Run>,
    rapids: Vec<f64>,
}

/// What a timed block adds to its run.
enum Timed {
    Still,
    Rapid(f64),
    Feed(f64),
}

const UNKNOWN: u8 = 2;
const NO_MOTION: u32 = u32::MAX;

impl Mover {
    fn new() -> Mover {
        Mover {
            vals: [0.0; 7],
            written: 0,
            motion_word: NO_MOTION,
            radius: None,
            moves_only: true,
            pos: [0.0; 3],
            known: 0,
            motion: NO_MOTION,
            feed: 0.0,
            feed_known: false,
            retract: UNKNOWN,
            cut_seen: false,
            block: 0,
            open: None,
            runs: Vec::new(),
            rapids: Vec::new(),
        }
    }

    /// The runs and their rapid moves' lengths, the open run closed.
    fn finish(mut self) -> (Vec<Run>, Vec<f64>) {
        self.close();
        (self.runs, self.rapids)
    }

    /// Ends the open run after the block read last: what that block left is where the run ends.
    fn close(&mut self) {
        if let Some(mut run) = self.open.take() {
            for (k, end) in run.end_pos.iter_mut().enumerate() {
                if run.axes >> k & 1 != 0 {
                    *end = Some(self.pos[k]);
                }
            }
            run.end_retract = self.retract == 1;
            self.runs.push(run);
        }
    }

    /// Nothing is known after a block read from its text.
    fn forget(&mut self) {
        self.close();
        (self.pos, self.known, self.motion) = ([0.0; 3], 0, NO_MOTION);
        self.vals[..3].fill(0.0);
        (self.feed_known, self.retract) = (false, UNKNOWN);
    }

    fn written(&self, slot: usize) -> Option<f64> {
        (self.written >> slot & 1 != 0).then_some(self.vals[slot])
    }

    /// The line's axes, its motion code and feed with the ones before it (whether the feed is known).
    #[inline(always)]
    fn modal(&self) -> (u8, u32, f64, bool) {
        let motion = match self.motion_word {
            NO_MOTION => self.motion,
            g => g,
        };
        let feed_written = self.written >> SLOT_F & 1 != 0;
        let feed = if feed_written {
            self.vals[SLOT_F]
        } else {
            self.feed
        };
        (
            self.written & 7,
            motion,
            feed,
            feed_written || self.feed_known,
        )
    }

    /// A line that moves only: its length when known, the run it joins, and what it leaves known.
    #[inline(always)]
    fn plain_move(&mut self, i: usize) {
        let (axes, motion, feed, feed_known) = self.modal();
        // The block CAM output is made of, a feed move on known axes with a known feed, in short: it retracts
        // nothing and cannot be a retract site, and its time is its straight length over the feed.
        if motion == 1 && axes != 0 && axes & !self.known == 0 && feed_known && feed > 0.0 {
            let (from, to) = (self.pos, [self.vals[0], self.vals[1], self.vals[2]]);
            let minutes = move_length(1, from, to, [None; 3], None) / feed;
            self.extend(i, Timed::Feed(minutes), false, [from[2], to[2]]);
            (self.pos, self.motion, self.feed, self.retract) = (to, motion, feed, 0);
            self.feed_known = true;
        } else {
            self.other_move(i);
        }
    }

    /// [`Mover::plain_move`] for any other line that moves only.
    #[inline(never)]
    fn other_move(&mut self, i: usize) {
        let (axes, motion, feed, feed_known) = self.modal();
        let from = self.pos;
        let to = [self.vals[0], self.vals[1], self.vals[2]];
        let rapid_xy = axes != 0 && motion == 0 && axes & 4 == 0;
        // A rapid Z-only move up retracts (an unknown start counts as below, as the fold has it). A line
        // that writes neither an axis nor a motion code (blank, a comment, a block number, F alone) leaves
        // the tool where it was: a blank line between the retract and the next rapid is no reason to lose
        // the place after it.
        let retracts = if axes == 0 && self.motion_word == NO_MOTION {
            self.retract
        } else if axes != 4 || (motion != 0 && motion != NO_MOTION) {
            0
        } else if motion == NO_MOTION || self.known & 4 == 0 {
            UNKNOWN
        } else {
            u8::from(to[2] > from[2])
        };
        let value = if axes == 0 {
            // It opens no run: the rapid after it must be a run's first block to be a retract site.
            self.open.is_some().then_some(Timed::Still)
        } else if motion == NO_MOTION
            || axes & !self.known != 0
            || (motion >= 2 && self.known & 3 != 3)
            || (self.retract == 1 && rapid_xy)
        {
            None
        } else {
            let centre = if motion >= 2 {
                [3, 4, 5].map(|k| self.written(k))
            } else {
                [None; 3]
            };
            let length = move_length(motion, from, to, centre, self.radius);
            match motion {
                0 => Some(Timed::Rapid(length)),
                _ if feed_known && feed > 0.0 => Some(Timed::Feed(length / feed)),
                _ => None,
            }
        };
        match value {
            Some(v) => self.extend(i, v, rapid_xy, [from[2], to[2]]),
            None => self.close(),
        }
        (self.pos, self.known, self.motion) = (to, self.known | axes, motion);
        (self.feed, self.feed_known, self.retract) = (feed, feed_known, retracts);
    }

    /// Adds block `i` to the open run, or opens one with it.
    #[inline(always)]
    fn extend(&mut self, i: usize, value: Timed, rapid_xy: bool, [from_z, to_z]: [f64; 2]) {
        let (z_moves, rises, falls) = (from_z != to_z, to_z > from_z, to_z < from_z);
        let written = self.written;
        let run = match &mut self.open {
            Some(run) => {
                if z_moves && written & 4 != 0 {
                    run.z_change = Some(i);
                }
                run
            }
            None => self.open.insert(Run {
                first: i,
                count: 0,
                at: self.rapids.len(),
                rapid_count: 0,
                feed_ticks: 0,
                cuts: false,
                rapids_after_cut: 0,
                first_could_retract: self.retract == UNKNOWN && rapid_xy,
                motion: Field::none(),
                feed: Field::none(),
                first_z: (written & 4 != 0).then_some(self.vals[2]),
                z_change: None,
                axes: 0,
                end_pos: [None; 3],
                end_retract: false,
                clear_after: None,
                lowered_after: None,
                first_feed: None,
                feed_read_first: None,
                contour_after: None,
                any_contour: false,
            }),
        };
        run.count += 1;
        run.axes |= written & 7;
        if self.motion_word != NO_MOTION {
            run.motion.write(i, self.motion_word);
        }
        if written >> SLOT_F & 1 != 0 {
            run.feed.write(i, self.vals[SLOT_F]);
        }
        match value {
            Timed::Still => {}
            Timed::Rapid(length) => {
                self.rapids.push(length);
                run.rapid_count += 1;
                run.rapids_after_cut += 1;
                if rises {
                    run.clear_after = Some(true);
                    run.lowered_after = Some(false);
                } else if falls {
                    run.lowered_after = Some(true);
                }
                run.first_feed.get_or_insert(false);
                run.contour_after = Some(false);
            }
            Timed::Feed(minutes) => {
                run.feed_ticks = run.feed_ticks.saturating_add(ticks(minutes));
                run.cuts = true;
                run.rapids_after_cut = 0;
                run.clear_after = Some(false);
                run.lowered_after = Some(false);
                run.first_feed.get_or_insert(true);
                run.feed_read_first.get_or_insert(run.feed.first.is_none());
                let contour = !(rises && written & 3 == 0);
                run.contour_after = Some(contour);
                run.any_contour |= contour;
            }
        }
    }
}

impl Words for Mover {
    type Number = Decimal;

    #[inline(always)]
    fn skip_level(&mut self) {
        self.moves_only = false;
    }

    #[inline(always)]
    fn word(&mut self, letter: u8, number: &Decimal) {
        match LETTER[usize::from(letter)] {
            slot @ 0..=6 => match number.value() {
                Some(v) if self.written >> slot & 1 == 0 => {
                    self.written |= 1 << slot;
                    self.vals[usize::from(slot)] = v;
                }
                _ => self.moves_only = false,
            },
            BLOCK_NUMBER => self.moves_only &= number.whole().is_some(),
            MOTION => match number.whole() {
                Some(g @ 0..=3) if self.motion_word == NO_MOTION => self.motion_word = g as u32,
                _ => self.moves_only = false,
            },
            _ => self.moves_only = false,
        }
    }

    #[inline(always)]
    fn comment(&mut self) {
        self.moves_only = false;
    }

    #[inline(always)]
    fn end_line(&mut self) {
        self.finish_line(self.moves_only);
    }

    fn other_line(&mut self, plain: Option<&[u8]>) {
        (self.written, self.motion_word, self.moves_only) = (0, NO_MOTION, true);
        let moves = plain.is_some_and(|text| self.read_radius_line(text).is_some());
        self.finish_line(moves && self.moves_only);
    }
}

impl Mover {
    /// Times the line if `moves`, else forgets what is known; then starts the next line.
    #[inline(always)]
    fn finish_line(&mut self, moves: bool) {
        let i = self.block;
        self.block += 1;
        if moves {
            self.plain_move(i);
            self.end_run_at_first_cut();
        } else {
            self.forget();
        }
        (self.written, self.motion_word, self.moves_only) = (0, NO_MOTION, true);
        self.radius = None;
    }

    /// Ends the open run after the piece's first timed cut. The fold reads the blocks up to the program's
    /// first cut one by one (the set-up's sites are found there), so a run holding that cut is read again
    /// from its text; in a CAM program that run is the whole first piece. Ended here, only the run up to
    /// the cut is read, and the moves after it start a run the fold takes at once.
    #[inline(always)]
    fn end_run_at_first_cut(&mut self) {
        if !self.cut_seen && self.open.as_ref().is_some_and(|run| run.cuts) {
            self.cut_seen = true;
            self.close();
        }
    }

    /// Reads a line the recogniser left to the grammar because of a `CR=radius` (the one assignment CAM
    /// arcs carry) as its words and that radius; `None` for anything else. Only lines the grammar found
    /// plain come here, so the words are the grammar's words.
    fn read_radius_line(&mut self, text: &[u8]) -> Option<()> {
        let mut k = 0;
        loop {
            while text.get(k).is_some_and(|&b| matches!(b, b' ' | b'\t')) {
                k += 1;
            }
            let Some(&letter) = text.get(k) else {
                return self.radius.map(|_| ());
            };
            if self.radius.is_none() && at_radius(text, k) {
                let (radius, end) = radius_at(text, k)?;
                self.radius = Some(radius);
                k = end;
                continue;
            }
            let mut number = Decimal::default();
            k = word_end_with(text, k, &mut number)?.1;
            self.word(letter, &number);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::omm::profile::Profile;
    use crate::omm::timeline::{build, build_with_moves};

    /// Parses `src` in pieces of about `piece` bytes with its moves timed.
    fn timed(src: &[u8], piece: usize) -> (Program, Moves) {
        let (program, pieces) =
            crate::syntax::parse_owned_in_pieces(src.to_vec(), piece, Mover::new);
        (program, Moves::from_pieces(pieces))
    }

    fn covered_share(program: &Program, moves: &Moves) -> f64 {
        let blocks: usize = moves
            .overlapping(0..program.block_count())
            .iter()
            .map(|r| r.run.count)
            .sum();
        blocks as f64 / program.block_count().max(1) as f64
    }

    /// The timeline with the parser's timed runs is the one reading every block gives, bit for bit, for
    /// every way of cutting the source into pieces.
    fn assert_same_timeline(src: &[u8], profile: &Profile) -> f64 {
        let plain = build(&crate::parse(src), profile);
        let mut share: f64 = 0.0;
        for piece in [usize::MAX / 2, 100_000, 777, 1] {
            let (program, moves) = timed(src, piece);
            assert_eq!(
                build_with_moves(&program, &moves, profile),
                plain,
                "pieces of {piece} bytes"
            );
            let covered = covered_share(&program, &moves);
            share = share.max(covered);
            // The runs are folded, not read again: times doubled in them show in the total.
            let mut doubled = moves.clone();
            for p in &mut doubled.pieces {
                p.rapids.iter_mut().for_each(|v| *v *= 2.0);
                p.runs.iter_mut().for_each(|r| r.feed_ticks *= 2);
            }
            let total = build_with_moves(&program, &doubled, profile).total_min;
            let timed = moves.pieces.iter().any(|p| {
                p.rapids.iter().any(|&v| v > 0.0) || p.runs.iter().any(|r| r.feed_ticks > 0)
            });
            assert!(!timed || total > plain.total_min, "pieces of {piece} bytes");
        }
        share
    }

    /// Lines that only move, written in the ways CAM and people write them, between blocks that change
    /// the state the moves are timed in (incremental dimensions, feeds per revolution, retracts, passes).
    fn awkward_program(repeat: usize) -> Vec<u8> {
        let mut text =
            b"%_N_AWK_MPF\n;$PATH=/_N_MPF_DIR\nDEF REAL A\n\nG17 G90 G94\nT1 M6\nS2000 M3\n"
                .to_vec();
        for k in 0..repeat {
            let x = (k * 37 % 400) as f64 / 8.0;
            let lines = format!(
                "N{k} G1 X{x} Y-{x} Z-1.5 F900\nx{x} y2 z-1\nN{k}G01X1.5Y{x}\nG1 X{x} Y1 Z.5 F0\nX3\n\
                 G0 Z50\nG0 X1 Y1\nG0 Z60\nG4 F1\nG0 Z70\nZ80\nX5 Y5\nG2 X{x} Y0 I-.5 J2\nG3 X0 Y{x} I1\n\
                 G2 X1 Y1 CR=5\nX2 Y2\nG1.0 X4\nX1 X2\n/ X7 Y1\nX8 ; note\nX9 Y9 Z1.5EX1\nX1.234567890123456\n\
                 G91 G1 X1 F{}\nX1 Y1\nZ-1\nG90\nX1 Y2 Z3\nX2 Y3 Z4\nG95 F0.1\nX10\nX20 Y20\nG94 F800\nX3 Y3\n\
                 G1 X=AC({x}) Y=IC(2)\nX4 Y4 Z4\nX5\nF0\nX6\nF700\nX7\nG0\nX8\nG1\nX9 Y0 Z0\n",
                100 + k
            );
            text.extend_from_slice(lines.as_bytes());
            if k % 5 == 4 {
                text.extend_from_slice(b"T2 M6 ; PASS\nS3000 M4\nG0 X0 Y0 Z5\nG1 Z-2 F300\n");
            }
        }
        text.extend_from_slice(b"M5\nM30\n");
        text
    }

    #[test]
    fn timed_runs_give_the_timeline_of_the_blocks() {
        let profile = Profile::default_profile();
        let share = assert_same_timeline(&awkward_program(40), &profile);
        assert!(share > 0.2, "runs cover {share}");
        // A profile that names pass lines: runs that hold one are read block by block.
        let mut lines = profile.clone();
        lines.passes.lines = vec![9, 30, 31, 200, 481];
        assert_same_timeline(&awkward_program(40), &lines);
        // A loop or a modal call around moves.
        let looped = b"T1 M6\nS1000 M3\nG0 X0 Y0 Z5\nLBL: G1 X1 F100\nG1 X2 Y2 F100\nX3\nX4 Y4\nWHILE R1<2\nG1 X1 Y1 F200\nX4\nX5\nENDWHILE\nMCALL CYCLE81(5)\nG0 X1 Y1\nX2\nX3\nMCALL\nX4\nX5\nREPEAT LBL LBL P=3\nM30\n";
        assert_same_timeline(looped, &profile);
    }

    #[test]
    fn fixtures_and_corpus_give_the_same_timeline() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut dirs = vec![root.join("fixtures/nc"), root.join("fixtures/omm")];
        dirs.extend(crate::shared_data::path("corpus"));
        let files: Vec<std::path::PathBuf> = crate::walk::expand(&dirs)
            .into_iter()
            .filter_map(|input| match input {
                crate::walk::Input::File(f) => Some(f),
                _ => None,
            })
            .collect();
        let profile = Profile::default_profile();
        let mut checked = 0;
        for file in files {
            let src = std::fs::read(&file).unwrap();
            let plain = build(&crate::parse(&src), &profile);
            for piece in [usize::MAX / 2, 300] {
                let (program, moves) = timed(&src, piece);
                assert_eq!(
                    build_with_moves(&program, &moves, &profile),
                    plain,
                    "{}",
                    file.display()
                );
            }
            checked += 1;
        }
        assert!(checked > 20, "{checked} files");
    }

    /// Arcs CAM writes with a radius (`CR=`, which the grammar reads) join the runs like any move, in the
    /// ways they are written; lines with anything more are read from their text.
    #[test]
    fn arcs_with_a_radius_stay_in_the_runs() {
        let mut text = String::from("T1 M6\nS1000 M3\nG0 X0 Y0 Z5\nG1 Z-1 F100\n");
        for k in 0..60 {
            let x = k as f64 / 4.0;
            text.push_str(&match k % 6 {
                0 => format!("N{k} G3 X{x} Y1 CR=8 F900\n"),
                1 => format!("G2 X{x} Y-1 cr=-3.5\n"),
                2 => format!("X{x} Y{x} CR=+2 Z-1.5\n"),
                _ => format!("G1 X{x} Y2\n"),
            });
        }
        let profile = Profile::default_profile();
        let (program, moves) = timed(text.as_bytes(), usize::MAX / 2);
        assert_eq!(
            build_with_moves(&program, &moves, &profile),
            build(&crate::parse(text.as_bytes()), &profile)
        );
        let share = covered_share(&program, &moves);
        assert!(share > 0.9, "runs cover {share}");
        for other in [
            "G2 X1 Y1 CR=5 M8",
            "G2 X1 Y1 CR = 5",
            "G2 X1 Y1 CR=5 CR=6",
            "G2 X1 Y1 CR=R1",
            "R1=5",
        ] {
            let (program, moves) = timed(format!("G0 X0 Y0\n{other}\n").as_bytes(), 100);
            let runs = moves.overlapping(0..program.block_count());
            assert!(runs.iter().all(|r| r.run.first == 0), "{other}");
        }
    }

    /// The header search outside the runs finds what a search of the whole source finds, wherever the
    /// header is: on a line of its own between moves, after a move, at the very end.
    #[test]
    fn the_header_is_found_outside_the_runs() {
        use crate::omm::{TransformError, check, check_timed};
        let base = String::from_utf8(awkward_program(3)).unwrap();
        let lines: Vec<&str> = base.lines().collect();
        let line_of = |r: Result<(), TransformError>| match r {
            Err(TransformError::AlreadyTransformed(line)) => Some(line),
            Err(e) => panic!("{e}"),
            Ok(()) => None,
        };
        let mut cases = vec![base.clone()];
        for at in [0, 7, 8, 9, 20, 21, lines.len()] {
            for header in [
                "; driftloop-omm 1.0",
                "G1 X1 Y1 ; driftloop-omm",
                "MSG(\"driftloop-omm\")",
            ] {
                let mut l = lines.clone();
                l.insert(at, header);
                cases.push(l.join("\n"));
            }
        }
        for text in cases {
            let whole = line_of(check(&crate::parse(text.as_bytes()), true));
            assert_eq!(whole.is_some(), text.contains("driftloop-omm"));
            for piece in [usize::MAX / 2, 50] {
                let (program, moves) = timed(text.as_bytes(), piece);
                assert_eq!(
                    line_of(check_timed(&program, &moves, true)),
                    whole,
                    "{text}"
                );
            }
        }
    }

    /// One line of a random program: mostly moves in the ways CAM writes them, sometimes a block that
    /// changes the state moves are timed in.
    fn line(kind: u8, a: i32, b: i32, c: i32) -> String {
        let (x, y, z) = (a as f64 / 100.0, b as f64 / 1000.0, c as f64 / 10.0);
        match kind % 16 {
            0..=4 => format!("N{a} G1 X{x} Y{y} Z{z}"),
            5 => format!("X{x} Y{y}"),
            6 => format!("G0 Z{}", z.abs() + 1.0),
            7 => format!("G0 X{x} Y{y}"),
            8 => format!("G{} X{x} Y{y} I{z} J{x}", 2 + (a & 1)),
            9 => format!("G3 X{x} Y{y} CR={z}"),
            10 => format!("F{}", b.unsigned_abs() % 3000),
            11 => format!("Z{z} ; c"),
            12 => ["G91", "G90", "G95 F0.1", "G94 F500", "M8", "S2000 M3"]
                [a.unsigned_abs() as usize % 6]
                .into(),
            13 => format!("G1 X=AC({x}) Y{y}"),
            14 => "T2 M6".into(),
            _ => format!("G{} Z{z}", a.unsigned_abs() % 4),
        }
    }

    proptest::proptest! {
        #[test]
        fn any_program_gives_the_timeline_of_its_blocks(
            lines in proptest::collection::vec((0u8..16, -40_000i32..40_000, -9_000i32..9_000, -60i32..60), 1..120),
            piece in 1usize..400,
        ) {
            let mut text = String::from("T1 M6\nS1000 M3\n");
            for (kind, a, b, c) in lines {
                text.push_str(&line(kind, a, b, c));
                text.push('\n');
            }
            text.push_str("M30\n");
            let profile = Profile::default_profile();
            let plain = build(&crate::parse(text.as_bytes()), &profile);
            let (program, moves) = timed(text.as_bytes(), piece);
            proptest::prop_assert_eq!(build_with_moves(&program, &moves, &profile), plain);
        }
    }
}
