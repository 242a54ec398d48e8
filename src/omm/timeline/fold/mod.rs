//! Folding the blocks, in order, into a [`Timeline`]: time, modal state, passes, gate sites, loops and
//! the subprograms calls run. The blocks come as the chunks `read` made of them, with the runs of moves
//! `moves` timed in the parser. The fold of one block and its move is here; what a call adds is in
//! `calls`, how loops are counted in `loops`, where gates may go (sites, passes) in `sites`.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::rc::Rc;

use crate::MM_PER_INCH;
use crate::omm::machine_coolant::is_control_m;
use crate::omm::profile::{OffsetMethod, Profile};
use crate::syntax::BlockKind;

use super::modal::{Modal, POSITIONED, coolant_after, field, frame, is_thread, unknown};
use super::moves::{Run, RunRef};
use super::read::{Chunk, Move, Scan, frame_op, head, measures_workpiece};
use super::record::{Site, SiteKind, SpindleWord, Standing, Timeline};
use super::timing::{TICKS_PER_MIN, move_length, ticks};

mod calls;
mod declared;
mod liveness;
mod loops;
mod sites;

use declared::{DeclaredTool, ToolChangeCall};
use loops::{Label, OpenLoop};
use sites::PassMark;

/// How the plan names the program's M6 of the tool already in the spindle where it left the spindle unsure.
const RELOAD: &str = "M6 of the tool already in the spindle";

/// What a call runs, as the fold asks for it.
pub(super) trait Callees {
    /// The timeline of subprogram `name`, and whether it is in another file (a folder's) rather than in
    /// this one (an archive's unit); `None` for a subprogram or cycle whose time is not known.
    fn timeline(&mut self, name: &str) -> Option<(Rc<Timeline>, bool)>;
}

/// An IF whose ENDIF has not come yet: its block, the state before its body, and the state at the end
/// of its THEN body once an ELSE came.
struct OpenIf {
    block: usize,
    before: Modal,
    then_end: Option<Modal>,
    /// Loops open at the IF.
    loop_depth: usize,
    /// The body so far ends the program on every run of it (M2, M30, M17, RET in it, outside any inner
    /// IF or loop).
    ended: bool,
}

/// Per field, a block (one past it) where the fold last saw it set, or 0.
type SetMarks = [usize; field::COUNT];

/// The spindle and path mode before a block's call: the call's own (its spindle words replayed, CYCLE832's
/// path mode) come after a gate before it, which must give back the program's.
#[derive(Clone, Copy)]
pub(super) struct BeforeCall {
    s: f64,
    direction: u32,
    css_rpm: Option<f64>,
    path_mode: Option<u32>,
}

impl BeforeCall {
    fn of(m: &Modal) -> Self {
        BeforeCall {
            s: m.s,
            direction: m.direction,
            css_rpm: m.css_rpm,
            path_mode: m.path_mode,
        }
    }

    /// `state` with the spindle and path mode from before the block's call, if it has one.
    pub(super) fn state(entry: Option<Self>, state: &Modal) -> Modal {
        let mut b = state.clone();
        if let Some(e) = entry {
            (b.s, b.direction, b.css_rpm, b.path_mode) = (e.s, e.direction, e.css_rpm, e.path_mode);
        }
        b
    }
}

/// What a unit leaves its caller (see [`Builder::exit_here`]).
struct Exit {
    state: Modal,
    unsure: [bool; field::COUNT],
    standing: Standing,
}

pub(super) struct Builder<'p> {
    profile: &'p Profile,
    /// The timelines of the subprograms calls may run.
    callees: &'p mut dyn Callees,
    /// A subprogram or cycle ran since the last tool change: the modal state it left (tool, speed, feed,
    /// frame) is not known, so no gate measures, and restores a state, until the next tool change.
    after_call: bool,
    /// Of [`Builder::after_call`]: a call other than a Siemens cycle ran since the last tool change. A
    /// unit whose only such calls are Siemens cycles (declared `SAVE`) leaves its caller what the caller
    /// would have after the cycles themselves (see [`CalleeEffect::after_cycle`]).
    after_unknown_call: bool,
    /// The cycle or subprogram an `MCALL` made modal, and how the call lists name it (`MCALL NAME`): it
    /// runs after each block that moves.
    modal_call: Option<(String, String)>,
    /// The block of the call that opened the table definition the fold is in (`CTABDEF` … `CTABEND`,
    /// `CONTPRON`/`CONTDCON` … `EXECUTE`): its blocks describe a curve or contour for the control to
    /// store, and a gate's blocks among them would go into the table. They are folded as any (the opening
    /// call, which driftloop cannot read, leaves the state unsure after it), but no gate goes before them.
    table_open: Option<usize>,
    /// The table definitions: the opening call's block and the closing one's, spans as the IFs' are (a
    /// gate may go before the opening call, not before the others).
    tables: Vec<(usize, usize)>,
    /// Names the unit calls (archive subprograms or not), for the order in which an archive's units are timed.
    called: BTreeSet<String>,
    /// A subprogram called at this block changed the spindle speed: the next block gets a speed-change site,
    /// so that the program's prediction takes the new speed there.
    speed_site_after: Option<usize>,
    /// A stop or dressing call at this block: the next block gets a site of that kind.
    safe_after: Option<(usize, SiteKind)>,
    t: Timeline,
    state: Modal,
    pos: [Option<f64>; 3],
    per_rev: bool,
    /// The time so far, in [`TICKS_PER_MIN`] ticks.
    ticks: u64,
    last_was_z_retract: bool,
    /// The block being folded moves in machine coordinates (G53, G153, SUPA).
    machine_move: bool,
    header_done: bool,
    preamble_done: bool,
    pass_marks: Vec<PassMark>,
    tool_marks: Vec<PassMark>,
    m6_seen: bool,
    /// The program set the spindle (M3/M4/M5, SPOS, a tool change): before that it is the operator's.
    spindle_set: bool,
    rpm: f64,
    loop_depth: usize,
    /// A loop started and no retract site in its body yet.
    loop_gate_pending: bool,
    open_loops: Vec<OpenLoop>,
    /// R-parameters whose last assignment (in program order) was a literal.
    r_values: BTreeMap<u32, f64>,
    /// Plain variables whose last assignment (in program order) was a literal.
    var_values: HashMap<String, f64>,
    /// Labels seen: block, start and end of its first run (min).
    label_times: HashMap<String, Label>,
    /// Block (+1) where each of the modal fields a gate restores last changed (see [`field`]).
    changed: [usize; field::COUNT],
    /// Block (+1) where the program's words last set each field to a value that does not depend on the
    /// state before them (G1, F100, M9; not M8, which adds to an M7, nor a frame, which combines): what
    /// makes a field sure again after a call (see [`Builder::unsure_after`]).
    written: [usize; field::COUNT],
    /// Per field, where its last write in `written` ran: one past the block that began the innermost IF,
    /// loop, skippable block or jumped-over stretch open at it (0: none), see [`field::set_as_seen_from`].
    written_in: [usize; field::COUNT],
    /// The block being read, when the operator's skip switch may leave it out.
    skippable: Option<usize>,
    /// Blocks that may get a site or pass mark, with `changed`, `written` and `written_in` there.
    site_changes: Vec<(usize, SetMarks, SetMarks, SetMarks)>,
    /// Calls after which fields may hold otherwise than the timeline has them: (call block, name called,
    /// the fields).
    call_unsure: Vec<(usize, String, [bool; field::COUNT])>,
    /// Blocks whose modal state differs between the runs of a loop around them.
    varies: BTreeSet<usize>,
    /// Blocks where a call left only the spindle (speed, direction) unsure: a spindle probe's gate before
    /// the program's own M6 gives neither back (the change stops the spindle), so only other gates vary.
    varies_but_spindle: BTreeSet<usize>,
    /// The programmed tool offsets set to other than 0 (bits of the scan's `tool_offset_on`): the state's
    /// [`unknown::TOOL_OFFSET`] ends only when each of them is 0 again.
    tool_offsets: u16,
    /// The program set working-area limits (`G25`/`G26` with axis values), and `WALIMOF` does not switch
    /// their monitoring off: the state's [`unknown::WORK_AREA`] holds while both do.
    work_area: (bool, bool),
    /// The axes under travel to fixed stop (`FXS[axis]=1` until `FXS[axis]=0`).
    fixed_stops: Vec<String>,
    /// `GEOAX` with arguments assigned other channel axes to the geometry axes, and no `GEOAX()` since.
    geometry_axes_swapped: bool,
    /// End of the last run of timed moves folded (its blocks in later chunks are skipped).
    run_end: usize,
    /// Until the first cut: the first block after the setup so far, as a [`SiteKind::Start`] site.
    start: Option<Site>,
    /// The speed limit under constant cutting speed (`LIMS=`).
    lims: Option<f64>,
    /// When the last cut (feed move) ended, in ticks.
    last_cut: u64,
    /// Per axis X, Y, Z: the first block of a frame change (TRANS, ROT, G54 …) the axis has not been
    /// programmed absolutely since.
    frame_pending: [Option<usize>; 3],
    /// The unit's jumps with a resolved target (GOTOF, GOTOB, GOTO, GOTOC, conditional or not): source
    /// block → target blocks.
    pub(super) jumps: HashMap<usize, Vec<usize>>,
    /// IF blocks whose ENDIF has not come yet.
    open_ifs: Vec<OpenIf>,
    /// Forward jumps not yet reached: target block → the states the jumps leave from.
    merging: HashMap<usize, Vec<Modal>>,
    /// Places after which some fields are not known on every path: sites after block `.0` are unfit while a
    /// field marked in `.2` has not been set again at a block from `.1` on. A label reached both by falling
    /// through and by a forward jump (the fields in which the two states differ), a tool-change subprogram
    /// (the fields it sets).
    merges: Vec<(usize, usize, [bool; field::COUNT])>,
    /// The fields this unit's blocks set (what it does to a caller's state).
    touched: [bool; field::COUNT],
    /// The tool is clear of the part: a rapid rose in Z since the last cut (out of a pocket, from under
    /// the part, out of a lathe's bore in front of its face), or nothing was cut yet.
    clear: bool,
    /// A move wrote an axis by an expression and Z was not written plainly since: the height the fold
    /// holds may be stale.
    position_doubt: bool,
    /// Sites noted where the tool was not clear: a gate there could retract through the part.
    in_part: BTreeSet<usize>,
    /// A milling or turning cycle ran since the last rapid that rose and the last tool change: where it
    /// left the tool no rule says (see `machining_cycle_leaves`), so it may stand in the part.
    cycle_position: bool,
    /// Sites noted while [`Builder::cycle_position`] held: in the part unless the program's own tool
    /// change follows there (its change macro leaves along the tool axis from the same place).
    in_part_after_cycle: BTreeSet<usize>,
    /// The tool went down its axis without cutting since it last rose or was changed (into a bore, under
    /// the part, as a back-boring bar does before its spindle starts).
    lowered: bool,
    /// Sites noted while the tool was lowered.
    lowered_at: BTreeSet<usize>,
    /// Blocks whose arc starts tangent to the move before them (`CT`).
    tangent_starts: BTreeSet<usize>,
    /// The last move rounds or chamfers its end into the next (`RND`, `CHF`, `CHR`), and the sites noted
    /// since.
    rounds_into: bool,
    rounded_into: BTreeSet<usize>,
    /// The last move was a feed along a contour (not straight up the tool axis) under continuous path.
    contour: bool,
    /// Sites noted since that move: in the contour when the next move is a feed too.
    contour_sites: Vec<usize>,
    /// Sites between two feed moves of a contour under continuous path.
    in_contour: BTreeSet<usize>,
    /// The lead (I, J or K) the last thread or tapping block wrote.
    lead: Option<f64>,
    /// Rotary axes the program itself sent away from 0 (bits as in [`frame::ROTARY`], unshifted).
    rotary_sent: u8,
    /// A subprogram called at this block that is no tool change, whose end state the block takes after
    /// its own words (which run before the call).
    end_to_take: Option<Rc<Timeline>>,
    /// The block of the unit's first return outside any IF or loop (M17, M2, M30, RET).
    exit_block: Option<usize>,
    /// What the unit leaves a caller, taken at that return (see [`Builder::exit_here`]).
    exit: Option<Exit>,
    /// A return inside an IF or loop: the unit may leave a caller any state its blocks reach.
    exits_early: bool,
    /// An M6 outside any IF or loop.
    m6_always: bool,
    /// A swivel (CYCLE800 with an angle) turned its rotary axes, and no block has sent them home since.
    swivel_turned: bool,
    /// The unit's `PROC` parameters (upper case) in their places; one the unit assigns is blanked: it no
    /// longer holds what the caller passed.
    params: Vec<String>,
    /// How each block uses the feed, in block order ([`liveness`]).
    feed_uses: Vec<(usize, liveness::FeedUse)>,
    /// Sites whose feed is not known but not used either: their gates give no feed back.
    feed_not_given: BTreeSet<usize>,
    /// Before the first cut, the first feed move made with the spindle positioned (SPOS, M19): a probe's
    /// measuring stroke if the tool calls a workpiece measuring cycle before it is changed or the spindle
    /// turns, else a cut (broaching, shaping with a standing spindle), counted as the first cut then.
    stroke: Option<usize>,
    /// The tool in the spindle called a workpiece measuring cycle, and it has not been changed nor the
    /// spindle turned since: a probe, whose feed moves are no cuts.
    probing: bool,
    /// The measuring cycles' result number `_KNUM` was last set to 0 by a literal: a cycle called without
    /// arguments writes no work offset.
    knum_zero: bool,
}

impl<'p> Builder<'p> {
    pub(super) fn new(profile: &'p Profile, callees: &'p mut dyn Callees) -> Self {
        Builder {
            profile,
            callees,
            after_call: false,
            after_unknown_call: false,
            modal_call: None,
            table_open: None,
            tables: Vec::new(),
            called: BTreeSet::new(),
            speed_site_after: None,
            safe_after: None,
            t: Timeline {
                speeds: vec![(0.0, 0.0)],
                ..Timeline::default()
            },
            state: Modal {
                direction: 5,
                absolute: true,
                comp: 40,
                ..Modal::default()
            },
            pos: [None; 3],
            per_rev: false,
            ticks: 0,
            last_was_z_retract: false,
            machine_move: false,
            header_done: false,
            preamble_done: false,
            pass_marks: Vec::new(),
            tool_marks: Vec::new(),
            m6_seen: false,
            spindle_set: false,
            rpm: 0.0,
            loop_depth: 0,
            loop_gate_pending: false,
            open_loops: Vec::new(),
            r_values: BTreeMap::new(),
            var_values: HashMap::new(),
            label_times: HashMap::new(),
            changed: [0; field::COUNT],
            written: [0; field::COUNT],
            written_in: [0; field::COUNT],
            skippable: None,
            site_changes: Vec::new(),
            call_unsure: Vec::new(),
            varies: BTreeSet::new(),
            varies_but_spindle: BTreeSet::new(),
            tool_offsets: 0,
            work_area: (false, true),
            fixed_stops: Vec::new(),
            geometry_axes_swapped: false,
            run_end: 0,
            start: None,
            lims: None,
            last_cut: 0,
            frame_pending: [None; 3],
            jumps: HashMap::new(),
            open_ifs: Vec::new(),
            merging: HashMap::new(),
            merges: Vec::new(),
            touched: [false; field::COUNT],
            clear: true,
            position_doubt: false,
            in_part: BTreeSet::new(),
            cycle_position: false,
            in_part_after_cycle: BTreeSet::new(),
            lowered: false,
            lowered_at: BTreeSet::new(),
            tangent_starts: BTreeSet::new(),
            rounds_into: false,
            rounded_into: BTreeSet::new(),
            contour: false,
            contour_sites: Vec::new(),
            in_contour: BTreeSet::new(),
            lead: None,
            rotary_sent: 0,
            end_to_take: None,
            exit_block: None,
            exit: None,
            params: Vec::new(),
            feed_uses: Vec::new(),
            feed_not_given: BTreeSet::new(),
            exits_early: false,
            m6_always: false,
            swivel_turned: false,
            stroke: None,
            probing: false,
            knum_zero: false,
        }
    }

    /// Block `i` is the first cut; `by_hand`: it cuts at the spindle it finds (a subprogram that sets the
    /// spindle before its first cut does not), so before the program sets the spindle, the operator's.
    pub(super) fn cuts(&mut self, i: usize, by_hand: bool) {
        // A stroke not yet known to be a probe's came first.
        let i = self.stroke.take().map_or(i, |stroke| stroke.min(i));
        self.t.first_cut.get_or_insert(i);
        if by_hand && !self.spindle_set {
            self.t.hand_spindle.get_or_insert(usize::MAX);
        }
    }

    /// A feed move at block `i` before the first cut: the first cut, or a stroke that may be a probe's (see
    /// [`Builder::stroke`]). Only straight and circular feeds count as strokes: a thread or tapping move
    /// also runs with the spindle in position control, and cuts. Nor where the program addresses another
    /// spindle: on a mill-turn machine a driven tool cuts while the main spindle stands positioned.
    fn feed_move_before_cut(&mut self, i: usize) {
        let other_spindle = self.state.unknown & unknown::OTHER_SPINDLE != 0;
        if self.state.direction == POSITIONED
            && matches!(self.state.motion, 1..=3)
            && !other_spindle
        {
            if !self.probing {
                self.stroke.get_or_insert(i);
            }
        } else {
            self.cuts(i, true);
        }
    }

    /// The strokes so far were a probe's, and so are the next ones: the tool calls a workpiece measuring
    /// cycle.
    fn strokes_measured(&mut self) {
        self.stroke = None;
        self.probing = true;
    }

    /// The tool is changed, the spindle turns, a call may cut or the unit ends: the strokes since the last
    /// measuring cycle were cuts, and the next ones are strokes to be judged again.
    fn strokes_cut(&mut self) {
        self.probing = false;
        if let Some(stroke) = self.stroke {
            self.cuts(stroke, true);
        }
    }

    /// [`frame_op::WRITE`] where the block calls a workpiece measuring cycle without arguments (CAM posts
    /// set its parameters before: `_MVAR=100 _KNUM=1`, `CYCLE978`) and `_KNUM`, which says into which work
    /// offset the result goes, is not known to be 0; the block's own assignments come first.
    fn parameter_measuring_write(&mut self, s: &Scan) -> u8 {
        if let Some((_, v)) = s
            .var_set
            .iter()
            .rev()
            .find(|(n, _)| n.eq_ignore_ascii_case("_KNUM"))
        {
            self.knum_zero = *v == Some(0.0);
        }
        let bare = s.call_args.is_empty();
        if bare && s.call.as_deref().is_some_and(measures_workpiece) && !self.knum_zero {
            frame_op::WRITE
        } else {
            0
        }
    }

    /// Block `i` sets the spindle: where the operator's spindle ends, if the program cut with it.
    pub(super) fn spindle_set_at(&mut self, i: usize) {
        if !self.spindle_set {
            self.spindle_set = true;
            if self.t.hand_spindle.is_some() {
                self.t.hand_spindle = Some(i);
            }
        }
    }

    /// Folds the blocks of a chunk, in order, with the runs of timed moves that start in it; `read(blocks)`
    /// reads the blocks of a run whose assumptions the state at its start does not meet.
    pub(super) fn fold(
        &mut self,
        chunk: &Chunk,
        runs: &[RunRef<'_>],
        read: &dyn Fn(std::ops::Range<usize>) -> Chunk,
    ) {
        let mut numbers = chunk.numbers.iter().copied();
        let mut others = chunk.others.iter();
        let mut runs = runs.iter();
        let mut covered = chunk.covered.iter();
        let mut i = chunk.first;
        for &h in &chunk.heads {
            if h & head::RUN != 0 {
                let blocks = covered.next().expect("one range per run head");
                // A run begun in an earlier chunk was folded there.
                if blocks.start >= self.run_end {
                    let run = runs
                        .next()
                        .expect("a run starts where its first range does");
                    if !self.timed_run(run) {
                        self.fold(&read(run.blocks()), &[], read);
                    }
                    self.run_end = run.blocks().end;
                }
                i = blocks.end;
                continue;
            }
            if h & head::OTHER != 0 {
                let (kind, scan) = others.next().expect("one scan per other block");
                self.block(i, scan, *kind);
            } else {
                let motion =
                    (h & head::MOTION != 0).then_some(u32::from(h >> head::MOTION_CODE & 3));
                self.plain_move(i, motion, &Move::decode(h, &mut numbers));
            }
            i += 1;
        }
    }

    /// The feed in force as the units `g` (G70, G71, G700, G710) read it. G700 reads a programmed F in
    /// inch/min, the others in the basic system's unit (mm/min: MD10240 metric, as the dry run has it):
    /// the feed does not change, the number a gate writes back for it does (`F60.` under G700 is F1524
    /// after G71).
    fn feed_in_units(&mut self, g: u32) {
        let (was, will) = (self.state.units == Some(700), g == 700);
        if let (true, Some(f)) = (was != will, self.state.feed) {
            self.state.feed = Some(if was {
                f * MM_PER_INCH
            } else {
                f / MM_PER_INCH
            });
        }
    }

    /// A block that only moves (see [`Scan::pack_move`]): most of what [`Builder::block`] looks at is absent.
    fn plain_move(&mut self, i: usize, motion: Option<u32>, mv: &Move) {
        if self.speed_site_after.is_some() {
            self.speed_site_after_call(i);
        }
        if self.safe_after.is_some() {
            self.safe_site_after(i);
        }
        let before = if self.last_was_z_retract || !self.profile.passes.lines.is_empty() {
            self.state.clone()
        } else {
            Modal::default()
        };
        let start = self.time();
        let blank = motion.is_none() && mv.axes.iter().all(Option::is_none);
        self.header_and_preamble(i, false, false, blank);
        self.start_site(i, start, !self.open_ifs.is_empty(), None);
        self.touched[field::MOTION] |= motion.is_some();
        self.touched[field::FEED] |= mv.f.is_some();
        self.mark_written(i + 1, field::motion_feed(motion.is_some(), mv.f.is_some()));
        if motion.is_some() {
            self.state.unknown &= !unknown::SPLINE;
        }
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
        if mv.f.is_some() {
            self.state.unknown &= !unknown::FEED;
        }
        if self.profile.passes.lines.contains(&(i + 1)) {
            let mark = self.mark(i, false, start, &before);
            self.pass_marks.push(mark);
            self.note_site(i);
        }
        // A blank line, a comment or a block number alone between the retract and the next rapid leaves
        // the tool where the retract put it.
        let keeps_clear = blank && self.last_was_z_retract;
        self.movement(i, start, &before, mv, false, None, false, false);
        self.note_move_feed_use(i, mv);
        self.last_was_z_retract |= keeps_clear;
        self.modal_call_after(i, mv);
        self.start_site_speed(i);
    }

    /// A run of moves the parser timed (see [`super::moves`]): what [`Builder::plain_move`] would make of its
    /// blocks, at once. False, with nothing folded, when the state at its start is not the one the run
    /// assumed (incremental dimensions, feeds per revolution), or its blocks need more than a plain move's
    /// fold (a pass line, a modal call, the header or preamble not yet over, a possible retract site).
    fn timed_run(&mut self, r: &RunRef<'_>) -> bool {
        let run = r.run;
        let blocks = r.blocks();
        let plain = self.header_done
            && self.preamble_done
            && self.t.first_cut.is_some()
            && self.state.absolute
            && !self.per_rev
            && self.modal_call.is_none()
            && self.speed_site_after.is_none()
            && self.safe_after.is_none()
            && !(self.last_was_z_retract && run.first_could_retract)
            // Pass lines are 1-based.
            && !self
                .profile
                .passes
                .lines
                .iter()
                .any(|&l| l > blocks.start && l <= blocks.end);
        if !plain {
            return false;
        }
        self.note_run_feed_use(run);
        self.rounds_into = false;
        if let Some((b, g)) = run.motion.first
            && g != self.state.motion
        {
            self.changed[field::MOTION] = b + 1;
        }
        if let Some((b, f)) = run.feed.first
            && self.state.feed != Some(f)
        {
            self.changed[field::FEED] = b + 1;
        }
        if self.state.z != run.first_z.or(self.pos[2]) {
            self.changed[field::Z] = run.first + 1;
        }
        for (k, change) in [
            (field::MOTION, run.motion.change),
            (field::FEED, run.feed.change),
            (field::Z, run.z_change),
        ] {
            if let Some(b) = change {
                self.changed[k] = b + 1;
            }
        }
        if let Some(g) = run.motion.last {
            self.state.motion = g;
            self.state.unknown &= !unknown::SPLINE;
        }
        if let Some(f) = run.feed.last {
            self.state.feed = Some(f);
            self.state.unknown &= !unknown::FEED;
        }
        let rapid = self.profile.timeline.rapid_mm_per_min;
        self.t.moves = true;
        self.touched[field::MOTION] |= run.motion.first.is_some();
        self.touched[field::FEED] |= run.feed.first.is_some();
        // No site lies inside a run: its end stands for the block that wrote last.
        self.mark_written(
            blocks.end,
            field::motion_feed(run.motion.first.is_some(), run.feed.first.is_some()),
        );
        self.ticks = self.ticks.saturating_add(run.feed_ticks);
        // Ticks add up in any order: the run's cut ends after its feed moves and the rapids before the
        // last of them.
        let (during, after) = r.rapids.split_at(r.rapids.len() - run.rapids_after_cut);
        for &length in during {
            self.add_minutes(length / rapid);
        }
        if run.cuts {
            self.last_cut = self.ticks;
        }
        if let Some(clear) = run.clear_after {
            self.clear = clear;
        }
        if let Some(lowered) = run.lowered_after {
            self.lowered = lowered;
        }
        self.contour_run(run);
        for &length in after {
            self.add_minutes(length / rapid);
        }
        for (p, end) in self.pos.iter_mut().zip(run.end_pos) {
            if end.is_some() {
                *p = end;
            }
        }
        self.state.z = self.pos[2];
        self.last_was_z_retract = run.end_retract;
        true
    }

    /// The contour state after a run, as its blocks one by one would leave it (see [`Builder::movement`]).
    fn contour_run(&mut self, run: &Run) {
        let conditional = !self.open_ifs.is_empty();
        let continuous = self.state.continuous_path();
        let resolves = if conditional {
            run.cuts.then_some(true)
        } else {
            run.first_feed
        };
        match resolves {
            Some(true) => self.in_contour.extend(self.contour_sites.drain(..)),
            Some(false) => self.contour_sites.clear(),
            None => {}
        }
        if let Some(last) = run.contour_after {
            let any = conditional && run.any_contour;
            self.contour = continuous && (last || any) || (conditional && self.contour);
        }
    }

    /// Header lines (`%…`, `;$PATH`) and the declarations after them: no gate may come before their end.
    fn header_and_preamble(&mut self, i: usize, header: bool, declaration: bool, blank: bool) {
        // Comments and blank lines may stand around the `%` header lines: driftloop's header goes after the
        // last of those header lines.
        if !self.header_done {
            if header {
                self.t.header_end = i + 1;
            } else if !blank {
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

    /// A cutting edge selected (D, or the edge a tool change brings) without `DL=` in the block ends the
    /// sum offset, as on a control whose MD20272 `SUMCORR_DEFAULT` is 0 (the default). With another value
    /// the new edge brings that sum offset again, which a gate's own D selection brings back alike.
    fn new_cutting_edge(&mut self, s: &Scan) {
        if s.sum_offset.is_none() {
            self.state.unknown &= !unknown::SUM_OFFSET;
        }
    }

    /// What a block's frame commands leave active.
    fn frames(&mut self, ops: u8) {
        use frame_op as op;
        let f = &mut self.state.frames;
        if ops & op::CLEAR != 0 {
            *f &= !(frame::TRANSLATION | frame::ROTATION);
        }
        for (on, off, bit) in [
            (op::TRANSLATE, 0, frame::TRANSLATION),
            (op::ROTATE, 0, frame::ROTATION),
            (op::TRANSFORM_ON, op::TRANSFORM_OFF, frame::TRANSFORMATION),
            (op::SWIVEL_ON, op::SWIVEL_OFF, frame::SWIVEL),
        ] {
            if ops & on != 0 {
                *f |= bit;
            } else if ops & off != 0 {
                *f &= !bit;
            }
        }
        // The swivel turns the rotary axes of its data set (which ones, the kinematics say), and its
        // deselection (`CYCLE800()`) deletes its frames without moving them back: the part stays turned
        // under a probe point in work coordinates until the program sends the axes home itself.
        if ops & op::SWIVEL_ON != 0 {
            *f |= frame::ROTARY;
            self.swivel_turned = true;
        }
    }

    /// The states of red team 5 a gate cannot run in or give back: a spline or polynomial as the modal
    /// motion (a G group 1 code ends it), travel to fixed stop, geometry axes reassigned (the frames the
    /// switch deletes count as lost until a `GEOAX()` and a work offset selected after it).
    fn machine_functions(&mut self, s: &Scan) {
        let group_1 = |g: u32| matches!(g, 0..=3) || is_thread(g);
        if s.g.iter().any(group_1) {
            self.state.unknown &= !unknown::SPLINE;
        }
        if s.spline {
            self.state.unknown |= unknown::SPLINE;
        }
        for (axis, on) in &s.fixed_stop {
            self.fixed_stops.retain(|a| a != axis);
            if *on {
                self.fixed_stops.push(axis.clone());
            }
            // Only the program's own deselection ends it (one a called unit left stays).
            if self.fixed_stops.is_empty() {
                self.state.unknown &= !unknown::FIXED_STOP;
            } else {
                self.state.unknown |= unknown::FIXED_STOP;
            }
        }
        if let Some(swapped) = s.geometry_axes {
            self.geometry_axes_swapped = swapped;
            self.state.unknown |= unknown::GEOMETRY_AXES;
        } else if !self.geometry_axes_swapped && s.offsets.iter().any(|&g| g != 53) {
            self.state.unknown &= !unknown::GEOMETRY_AXES;
        }
    }

    /// A program end at block `i`: recorded, and an end of the innermost IF's body when no loop opened in it.
    fn program_end(&mut self, i: usize) {
        self.t.ends.push(i);
        if self.open_ifs.is_empty() && self.loop_depth == 0 {
            self.exit_block.get_or_insert(i);
        } else {
            self.exits_early = true;
        }
        let depth = self.loop_depth;
        if let Some(open) = self.open_ifs.last_mut().filter(|o| o.loop_depth == depth) {
            open.ended = true;
        }
    }

    /// After an ENDIF the state is one of the branches': the body may not have run (or the ELSE body ran
    /// instead). The fold runs the bodies one after the other, so a field any of them set may differ from
    /// what the program has there: sites after it are unsure of it until the program sets it again, as
    /// after a label a jump reaches (a gate would give back a speed or a feed the branch taken never set).
    fn if_merge(&mut self, i: usize, open: OpenIf) {
        // A body without ELSE that ends the program (`IF R30>=R31` / `M30` / `ENDIF`, a piece counter)
        // leaves the state before the IF to what follows.
        if open.then_end.is_none() && open.ended {
            self.state = open.before;
            return;
        }
        let states: Vec<Modal> = [Some(open.before), open.then_end]
            .into_iter()
            .flatten()
            .collect();
        self.merge(i, i, &states);
    }

    /// After block `i` the state is the fold's or one of `others` (the ways here differ): a field in
    /// which they differ is unsure at the sites after it until the program sets it again at a block after
    /// `set_from` (`i`, or one past it where block `i`'s own words set the field on one way only).
    pub(super) fn merge(&mut self, i: usize, set_from: usize, others: &[Modal]) {
        let states: Vec<&Modal> = others.iter().chain([&self.state]).collect();
        let mut differ = [false; field::COUNT];
        for (k, a) in states.iter().enumerate() {
            for b in &states[k + 1..] {
                for (d, x) in differ.iter_mut().zip(field::differ(a, b)) {
                    *d |= x;
                }
            }
        }
        // A feed, plane, feed type or path mode one way leaves unset (the program had set none there) is
        // given back by no gate: each way keeps its own value through the gate, so it is no doubt (a WHILE
        // that may not run, after `G1 … F1800` in its body and no F before it).
        let unset = field::SET_ONLY.map(|f| differ[f] && states.iter().any(|m| m.is_unset(f)));
        for (f, unset) in field::SET_ONLY.into_iter().zip(unset) {
            if unset {
                differ[f] = false;
                self.state.unset(f);
            }
        }
        // A tool one branch loads is not known after the IF (`IF $P_TOOLNO<>12` / `T12 M6` / `ENDIF`): a
        // gate reads it at run time where the profile lets it, as where the program names none.
        if differ[field::TOOL] || differ[field::SELECTED] {
            self.state.tool = None;
            self.state.selected = None;
            differ[field::TOOL] = false;
            differ[field::SELECTED] = false;
        }
        // A gate that corrects the offset in force selects none: whichever branch selected it, the gate
        // measures and corrects under it (a tombstone's `IF FIX==2` / `G55` / `ENDIF`).
        if self.profile.offset.method == OffsetMethod::Active {
            differ[field::OFFSET] = false;
        }
        if differ.contains(&true) {
            self.merges.push((i, set_from, differ));
        }
    }

    /// A settable work offset selected at block `i` (noted at its first selection).
    fn offset(&mut self, g: u32, i: usize) {
        if matches!(g, 54..=57 | 505..=599) && !self.t.offsets.iter().any(|(o, _)| *o == g) {
            self.t.offsets.push((g, i + 1));
        }
    }

    /// Block `i`. One the operator's skip switch may leave out (`/T2 M6`, `/M8`) runs or not: after it the
    /// state is either way's (fields it sets are unsure until the program sets them again, a tool it
    /// loads is not known), a tool change in it is not certain (the gate before it gives the cutting
    /// tool back) and a retract in it may not have happened.
    pub(super) fn block(&mut self, i: usize, s: &Scan, kind: BlockKind) {
        let known = self.speed_from_variable(s);
        let s = known.as_ref().unwrap_or(s);
        if !s.skippable {
            return self.block_words(i, s, kind);
        }
        let (entry, clear) = (self.state.clone(), self.last_was_z_retract);
        self.skippable = Some(i);
        self.block_words(i, s, kind);
        self.skippable = None;
        self.merge(i, i + 1, &[entry]);
        self.last_was_z_retract &= clear;
    }

    fn block_words(&mut self, i: usize, s: &Scan, kind: BlockKind) {
        self.table_definition(i, s);
        self.speed_site_after_call(i);
        self.safe_site_after(i);
        let mut call_loads = None;
        // The spindle and path mode before a call: the call's own (its spindle words replayed, CYCLE832's
        // path mode) come after a gate before it, which must give back the program's.
        let entry = s.call.as_ref().map(|_| BeforeCall::of(&self.state));
        if let Some(name) = &s.call {
            let shown = s.call_shown.as_ref().unwrap_or(name);
            call_loads = self.call(i, name, shown, s.repeats, &s.call_args);
            if self
                .profile
                .passes
                .dressing
                .iter()
                .any(|d| d.eq_ignore_ascii_case(name))
            {
                self.safe_after = Some((i, SiteKind::Dressing));
            }
        }
        if s.m.iter().any(|m| m <= 1) {
            self.safe_after = Some((i, SiteKind::Stop));
        }
        self.jump_target(i);
        // Changes matter only inside a loop body or a section that may be repeated, or jumped over, or
        // after a call that left fields unknown.
        let tracked = (!self.open_loops.is_empty()
            || !self.label_times.is_empty()
            || s.label.is_some()
            || !self.merging.is_empty()
            || !self.merges.is_empty())
        .then(|| self.state.clone());
        match kind {
            BlockKind::While | BlockKind::For | BlockKind::Loop | BlockKind::Repeat => {
                self.loop_depth += 1;
                self.loop_gate_pending = true;
            }
            BlockKind::EndWhile | BlockKind::EndFor | BlockKind::EndLoop | BlockKind::Until => {
                self.loop_depth = self.loop_depth.saturating_sub(1);
            }
            BlockKind::If => self.open_ifs.push(OpenIf {
                block: i,
                before: self.state.clone(),
                then_end: None,
                loop_depth: self.loop_depth,
                ended: false,
            }),
            BlockKind::Else => {
                if let Some(open) = self.open_ifs.last_mut() {
                    open.then_end = Some(self.state.clone());
                }
            }
            BlockKind::EndIf => {
                if let Some(open) = self.open_ifs.pop() {
                    self.t.conditional.push((open.block, i));
                    self.if_merge(i, open);
                }
            }
            _ => {}
        }
        // The state before the block is kept only where a site or pass mark can arise: a copy per block
        // would cost more than the rest of the scan. A gate there gives back this state, so every way a
        // block can mark must be here: a tool-change call (its pass), and every way the speed can change
        // without S or M (G94/G95/G97 ending constant cutting speed, a move under it, LIMS, an expression);
        // a default state there gave back G91 and no spindle.
        let may_mark = !s.m.is_empty()
            || call_loads.is_some()
            || s.s.is_some()
            || s.tool.is_some()
            || s.marker
            || self.last_was_z_retract
            || !self.profile.passes.lines.is_empty()
            || self.state.css_rpm.is_some()
            || s.lims.is_some()
            || s.unknown != 0
            || s.g.iter().any(|g| matches!(g, 93..=97 | 331 | 332));
        let before = if may_mark {
            BeforeCall::state(entry, &self.state)
        } else {
            Modal::default()
        };
        let start = self.time();
        let blank = !s.statement
            && !s.inexact
            && s.g.is_empty()
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
        // A gate before an ELSE or ENDIF is inside the IF it closes.
        let inside_if =
            !self.open_ifs.is_empty() || matches!(kind, BlockKind::Else | BlockKind::EndIf);
        self.start_site(i, start, inside_if, entry);
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
        // Under a swivel or a transformation no inserted block writes the frame in force (a post that
        // selects `G54 D1` after CYCLE800): the correction the selection dropped stays off until the next
        // gate, which reads back what is in force.
        if s.offsets
            .iter()
            .any(|g| matches!(g, 500 | 54..=57 | 505..=599))
            && self.state.unfit().is_none()
        {
            self.t.offset_selections.push(i);
        }
        let frame_ops = s.frame_ops | self.parameter_measuring_write(s);
        // A kinematic transformation (TRAORI, TRANSMIT …) is no setup of the work coordinates the zero
        // measures in: the zero goes before it.
        let setup = frame_ops & !(frame_op::TRANSFORM_ON | frame_op::TRANSFORM_OFF) != 0
            || s.offsets
                .iter()
                .any(|g| matches!(g, 500 | 54..=57 | 505..=599));
        if setup && self.t.first_cut.is_none() {
            self.t.setup_end = i + 1;
        }
        if let Some(&g) = s
            .offsets
            .iter()
            .rev()
            .find(|g| matches!(g, 500 | 54..=57 | 505..=599))
        {
            self.state.offset = Some(g);
        }
        if frame_ops & frame_op::WRITE != 0 {
            self.t.frame_writes.push(i);
        }
        if s.writes_frame_in_force {
            self.t.frame_in_force_writes.push(i);
        }
        if s.writes_tool_data {
            self.t.tool_data_writes.push(i);
        }
        if s.tangent_start {
            self.tangent_starts.insert(i);
        }
        let frame_changes =
            frame_op::TRANSLATE | frame_op::ROTATE | frame_op::CLEAR | frame_op::WRITE;
        if setup && (frame_ops & frame_changes != 0 || !s.offsets.is_empty()) {
            for pending in &mut self.frame_pending {
                pending.get_or_insert(i);
            }
        }
        self.frames(frame_ops);
        self.rotary_axes(s);
        self.t.moves |= s.other_axes;
        if let Some(on) = s.diameter {
            self.state.diameter = on;
        }
        // Modal words first: they hold for this block's move.
        for g in s.g.iter() {
            match g {
                // Thread cutting and tapping are cuts (see [`is_thread`]): no place while one is the
                // modal motion is fit for a gate.
                g @ (0..=3) => self.state.motion = g,
                g if is_thread(g) => self.state.motion = g,
                90 => self.state.absolute = true,
                91 => self.state.absolute = false,
                93..=95 => {
                    self.per_rev = g == 95;
                    self.state.feed_mode = Some(g);
                }
                // Constant cutting speed is feed per revolution (group 15, as G95), and G97 after it keeps
                // that: a gate after `G96 … G97` in a program that began in G94 gives back G95.
                96 => {
                    self.per_rev = true;
                    self.state.feed_mode = Some(95);
                }
                17..=19 => {
                    // The control keeps the polar angle and radius only until the plane changes.
                    if self.state.plane != Some(g) {
                        self.state.unknown &= !unknown::POLAR;
                    }
                    self.state.plane = Some(g);
                    if self.t.first_cut.is_none() {
                        self.t.setup_plane.get_or_insert(g);
                    }
                }
                40..=42 => self.state.comp = g,
                60 | 64 | 641..=645 => self.state.path_mode = Some(g),
                70 | 71 | 700 | 710 => {
                    self.feed_in_units(g);
                    self.state.units = Some(g);
                }
                g if is_iso_only(g) => {
                    self.t.iso_dialect.get_or_insert((i, g));
                }
                _ => {}
            }
        }
        let dwell = s.g.contains(4);
        // G25 / G26: S is a speed limit and the axis values are the working area's limits.
        let limits = s.g.contains(25) || s.g.contains(26);
        // S is then no speed: a dwell's revolutions or a speed limit.
        let no_speed = dwell || limits;
        let own_m6 = s.m.contains(self.profile.probe.tool_change_m);
        // The tool already in the spindle loaded again by the program's own M6: the machine's change macro
        // may skip it and leave the spindle turning, as a guarded subprogram does (red team 3, R2).
        let reloads = own_m6
            && self.state.tool.is_some()
            && s.tool.as_ref().or(self.state.selected.as_ref()) == self.state.tool.as_ref();
        let set = self.touch(s, dwell, no_speed);
        self.note_written(i, s, set, no_speed, reloads);
        // A PROC's speed parameter (`S=_RPM`) is its caller's to give (see `replay_spindle`).
        let speed_parameter = self.parameter(&s.speed_var);
        if s.unknown & unknown::S != 0 && s.s.is_none() && !no_speed && speed_parameter.is_none() {
            self.t.unknown_speed_lines.push(i + 1);
        }
        self.state.unknown |= s.unknown;
        match s.sum_offset {
            Some(true) => self.state.unknown |= unknown::SUM_OFFSET,
            Some(false) => self.state.unknown &= !unknown::SUM_OFFSET,
            None => {}
        }
        match s.rounding {
            Some(true) => self.state.unknown |= unknown::ROUNDING,
            Some(false) => self.state.unknown &= !unknown::ROUNDING,
            None => {}
        }
        if s.cancels_sync_actions {
            self.state.unknown &= !unknown::SYNC_ACTION;
        }
        self.machine_functions(s);
        if s.polar || s.g.iter().any(|g| matches!(g, 110..=112)) {
            self.state.unknown |= unknown::POLAR;
        }
        if limits && (s.mv.axes.iter().any(Option::is_some) || s.other_axes) {
            self.work_area.0 = true;
        }
        if let Some(on) = s.work_area_monitor {
            self.work_area.1 = on;
        }
        if self.work_area == (true, true) {
            self.state.unknown |= unknown::WORK_AREA;
        } else {
            self.state.unknown &= !unknown::WORK_AREA;
        }
        if s.tool_offset_on | s.tool_offset_off != 0 {
            self.tool_offsets = (self.tool_offsets & !s.tool_offset_off) | s.tool_offset_on;
            if self.tool_offsets == 0 {
                self.state.unknown &= !unknown::TOOL_OFFSET;
            } else {
                self.state.unknown |= unknown::TOOL_OFFSET;
            }
        }
        match s.tool_carrier {
            Some(true) => self.state.frames |= frame::TOOL_CARRIER,
            Some(false) => self.state.frames &= !frame::TOOL_CARRIER,
            None => {}
        }
        if let Some(f) = s.mv.f
            && !dwell
        {
            self.state.feed = Some(f);
            self.state.unknown &= !unknown::FEED;
        }
        // In a G4 block S is the dwell in spindle revolutions, not a speed: the speed programmed before it
        // stays (as F does).
        let speed = s.s.filter(|_| !no_speed);
        if let Some(v) = speed {
            self.state.s = v;
            self.state.unknown = (self.state.unknown & !unknown::S) | (s.unknown & unknown::S);
        }
        if let Some(l) = s.lims {
            self.lims = Some(l);
        }
        // G93 … G95 and G97 share G96's group: each ends constant cutting speed.
        if s.g.iter().any(|g| matches!(g, 93..=95 | 97)) {
            self.state.css_rpm = None;
        } else if s.g.contains(96)
            || (self.state.css_rpm.is_some() && (speed.is_some() || s.lims.is_some()))
        {
            self.state.css_rpm = Some(self.css_rpm());
        }
        if let Some(d) = s.d {
            self.state.d = Some(d);
            self.state.unknown &= !unknown::D;
            self.new_cutting_edge(s);
        }
        let mut direction = None;
        let change_m = self.profile.probe.tool_change_m;
        for m in s.m.iter() {
            match m {
                3..=5 | POSITIONED => direction = Some(m),
                // M70: the spindle becomes a C axis, stopped in position control (SPOS's state).
                70 => direction = Some(POSITIONED),
                m if m == change_m => {
                    self.m6_seen = true;
                    self.m6_always |= self.open_ifs.is_empty() && self.loop_depth == 0;
                }
                // M17 ends a main program as M30 does, and returns from a subprogram.
                2 | 17 | 30 => self.program_end(i),
                7..=9 => self.state.coolant = coolant_after(self.state.coolant, m),
                _ if !self.profile.coolant.follows(m) && !is_control_m(m) => {
                    self.t.machine_m.insert(m);
                    if s.tool.is_some() {
                        self.t.m_beside_t.get_or_insert((i + 1, m));
                    }
                }
                _ => {}
            }
            let machine = &self.profile.coolant;
            self.state.machine_coolant = machine.after(self.state.machine_coolant, m);
        }
        // G331 / G332 turn the spindle in position control with the axis (SPOS before them or not): it
        // stands positioned after them until M3 / M4 / M5 switch it back to speed control.
        if s.g.iter().any(|g| matches!(g, 331 | 332)) {
            direction = Some(POSITIONED);
        }
        if let Some(d) = direction {
            if d != POSITIONED {
                self.strokes_cut();
            }
            self.state.direction = d;
            self.spindle_set_at(i);
        }
        if s.leaves {
            self.program_end(i);
        }
        let s_parameter = speed_parameter.filter(|_| speed.is_none());
        if speed.is_some() || direction.is_some() || s_parameter.is_some() {
            self.t.spindle_words.push(SpindleWord {
                at_min: start,
                s: speed,
                direction,
                s_parameter,
            });
        }
        // A tool-change subprogram loads the selected tool as M6 does.
        let tool_change = own_m6 || call_loads.is_some();
        // One that may skip its change leaves the spindle turning on that way: the pass's gate is then
        // no gate before a tool change (it gives the spindle back).
        let certain_change = own_m6
            || match &call_loads {
                Some(ToolChangeCall::Read(sub)) => sub.as_callee.changes_tool_always,
                Some(ToolChangeCall::Declared(_)) => true,
                None => false,
            };
        if let (Some(ToolChangeCall::Read(sub)), Some(name)) = (&call_loads, &s.call) {
            if sub.as_callee.selects.ever() {
                self.t
                    .tool_change_by_argument
                    .get_or_insert_with(|| (i + 1, name.clone()));
            } else {
                self.t.tool_change_call.get_or_insert_with(|| name.clone());
            }
        }
        self.m6_seen |= call_loads.is_some();
        // A declared call that takes its tool as an argument selects it as it loads it, and so does a
        // read one called with the tool it selects by its parameter.
        let passed = match &call_loads {
            Some(ToolChangeCall::Read(sub)) => Self::passed(sub.as_callee.selects, &s.call_args),
            _ => None,
        };
        let selects = match &call_loads {
            Some(ToolChangeCall::Declared(DeclaredTool::Named(tool))) => Some(tool),
            _ => passed.as_ref().or(s.tool.as_ref()),
        };
        if let Some(tool) = selects {
            self.state.selected = Some(tool.clone());
            self.state.unknown &= !unknown::TOOL;
        }
        if let Some(ToolChangeCall::Declared(DeclaredTool::Unknown)) = &call_loads {
            self.state.selected = None;
            self.state.unknown |= unknown::TOOL;
        }
        if tool_change {
            self.strokes_cut();
            self.spindle_set_at(i);
            if self.state.selected.is_none() && self.state.unknown & unknown::TOOL == 0 {
                self.t.outside_load.get_or_insert(i);
            }
            // M6 loads the selected tool (T alone only selects it, in a program that uses M6).
            self.state.tool = self.state.selected.clone();
            // Without a D in the block the new tool has the control's default edge (MD20270, usually D1),
            // not the last tool's D: a gate that loads it again gets the same default and writes no D.
            if s.d.is_none() {
                self.state.d = None;
                self.state.unknown &= !unknown::D;
            }
            self.new_cutting_edge(s);
            // The change cycle stops the spindle (a positioned one too); the program starts it again for
            // the new tool (a gate that gave back the last tool's speed would spin the new one at it).
            if !s.m.iter().any(|m| matches!(m, 3 | 4)) {
                self.state.direction = 5;
            }
        }
        let rpm = self.state.rpm();
        if s.tool.is_some() {
            let mark = self.mark(i, true, start, &before);
            self.tool_marks.push(mark);
        }
        let p = &self.profile.passes;
        let marked = s.marker || p.lines.contains(&(i + 1));
        if (p.tool_change && tool_change) || marked {
            let mark = self.mark(
                i,
                certain_change && !reloads && !s.skippable,
                start,
                &before,
            );
            self.pass_marks.push(mark);
            if self.after_call && !tool_change {
                self.varies.insert(i);
            }
        }
        // The stop or speed site a call before this block asked for is this tool change's place too: what
        // the call may have left is judged by the fields it left unsure (see `unsure_after`), as at any
        // tool change, not by the call alone.
        if tool_change && self.after_call {
            self.varies.remove(&i);
        }
        self.after_call &= !tool_change;
        self.after_unknown_call &= !tool_change;
        self.zero_after_tool_setup(s, tool_change);
        if s.tool.is_some() || (p.tool_change && tool_change) || marked || rpm != self.rpm {
            self.note_site(i);
        }
        // Or the change leaves the spindle turning: a macro that skips the change to the tool in the
        // spindle (red team 4, S1). Which one the machine does is unsure until the program writes M3/M4/M5
        // again: a gate between would give back a stopped spindle where the program's next cut relies on
        // the turning one. Noted after this block's own site, which lies before the change.
        if reloads && direction.is_none() {
            self.leaves_unsure(i, RELOAD, field::only(&[field::DIRECTION]));
        }
        if rpm != self.rpm {
            self.rpm = rpm;
            self.t.speeds.push((start, rpm));
            self.speed_site(i, start, before.clone(), rpm);
        }
        if let Some(modal) = &s.modal_call {
            self.modal_call = modal.as_ref().map(|n| (n.clone(), format!("MCALL {n}")));
            self.state.modal_call = self.modal_call.is_some();
        }
        let mv = if limits { Move::default() } else { s.mv };
        // A block that only switches (coolant, a stop, the spindle, a preselection, an assignment, the
        // high-speed settings a post calls at each operation) leaves the tool where the retract put it:
        // `M9` between the retract and the next rapid keeps that place.
        // One that may move it some other way, or that a jump may reach from elsewhere, does not.
        // A swivel back to the untilted plane (CYCLE800 with no angle) retracts along the tool axis, if at
        // all, and turns the part home under the retracted tool: a post's return to the top plane.
        let untilts = s.call.as_deref() == Some("CYCLE800") && s.frame_ops == frame_op::SWIVEL_OFF;
        let keeps_clear = self.last_was_z_retract
            && kind == BlockKind::Plain
            && !tool_change
            && !s.inexact
            && mv.axes.iter().all(Option::is_none)
            && !s.other_axes
            && (s.call.as_deref().is_none_or(calls::moves_nothing) || untilts)
            && s.modal_call.is_none()
            && s.label.is_none()
            && (s.frame_ops == 0 || untilts)
            && !s.writes_frame_in_force
            && !s.leaves
            && !s.g.iter().any(|g| matches!(g, 74 | 75));
        self.machine_move = s.offsets.iter().any(|g| matches!(g, 53 | 153));
        self.movement(i, start, &before, &mv, dwell, s.s, s.inexact, own_m6);
        self.rounds_into |= s.joins_next;
        self.last_was_z_retract |= keeps_clear;
        // G9: this block's move ends in an exact stop.
        self.contour &= !s.g.contains(9);
        self.modal_call_after(i, &s.mv);
        if let Some(prev) = tracked {
            for (f, differs) in field::differ(&prev, &self.state).into_iter().enumerate() {
                if differs {
                    self.changed[f] = i + 1;
                }
            }
            if let Some(l) = &s.label {
                self.label_seen(l, i, start, prev);
            }
        }
        match call_loads {
            Some(ToolChangeCall::Read(sub)) => {
                self.after_tool_change_call(i, &sub.as_callee, &before);
                if passed.is_some() {
                    self.state.unknown &= !unknown::TOOL;
                }
                self.bind_edge(&sub.as_callee, &s.call_args);
            }
            Some(ToolChangeCall::Declared(tool)) => {
                self.after_declared_change(i, !matches!(tool, DeclaredTool::Preselected))
            }
            None => {}
        }
        if let Some(sub) = self.end_to_take.take() {
            self.after_call_end(i, &sub.as_callee, sub.first_cut.is_some());
            self.bind_edge(&sub.as_callee, &s.call_args);
        }
        if s.saves {
            self.t.as_callee.saves = true;
        }
        if self.exit_block == Some(i) && self.exit.is_none() {
            self.exit = Some(self.exit_here());
        }
        if let (true, Some(g)) = (self.state.inch(), self.state.units)
            && (self.t.ends.last() == Some(&i) || self.t.offset_selections.last() == Some(&i))
        {
            self.t.inch_at.insert(i, g);
        }
        self.note_feed_use(i, s, kind, &set);
        self.loops(i, s, kind, start);
        self.jump_from(i);
        self.start_site_speed(i);
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
        // Axes written as expressions move too, by an amount the timeline does not know.
        let moves_somehow = moved || inexact;
        self.rounds_into &= !moves_somehow;
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
            let idle = self.idle_since_cut(start);
            let kind = SiteKind::Retract { first_in_loop };
            self.t
                .sites
                .push(Site::new(i, kind, start, before.clone(), rpm, idle));
        }
        let from = self.pos;
        let mut to = self.pos;
        for k in 0..3 {
            if let Some((v, ac)) = mv.axes[k] {
                let absolute = ac || (self.state.absolute && !mv.incremental[k]);
                to[k] = if absolute {
                    Some(v)
                } else {
                    Some(from[k].unwrap_or(0.0) + v)
                };
                // An incremental move carries the frame change not yet traversed on its axis
                // (MD42440 FRAME_OFFSET_INCR_PROG = 1): a gate in between, which goes back to where
                // the axis is, would take that traverse away.
                if let Some(change) = self.frame_pending[k].take()
                    && !absolute
                {
                    self.t.frame_traverses.push((change, i));
                }
            }
        }
        self.t.moves |= moves_somehow;
        // A rapid along Z alone, and one that rises (from a height not known, it counts as rising).
        let z_rapid =
            moved && self.state.motion == 0 && mv.axes[0].is_none() && mv.axes[1].is_none();
        let rises = match (from[2], to[2]) {
            (Some(a), Some(b)) => b > a,
            (None, Some(_)) => z_rapid,
            _ => false,
        };
        // A post's retract to the tool-change height in machine coordinates (`G0 SUPA Z0 D0`, `G53 Z0`):
        // its height in work coordinates is not known, and it is where the post sends the tool clear of
        // everything.
        let z_retract = z_rapid && (rises || self.machine_move);
        if z_retract && self.machine_move {
            to[2] = None;
        }
        if tool_change {
            self.contour = false;
            self.contour_sites.clear();
            self.lowered = false;
            // The change macro took the tool out of wherever a cycle left it.
            self.cycle_position = false;
        }
        if moves_somehow && !g4 {
            let feed = self.state.motion != 0;
            // A move in one branch of an IF may not run: the contour stays open through it.
            let conditional = !self.open_ifs.is_empty();
            if feed {
                self.in_contour.extend(self.contour_sites.drain(..));
            } else if !conditional {
                self.contour_sites.clear();
            }
            let straight_up = rises && mv.axes[0].is_none() && mv.axes[1].is_none();
            let continuous = self.state.continuous_path();
            let contour = feed && !straight_up && continuous && !tool_change;
            self.contour = contour || (conditional && self.contour);
            // A rapid of the tool axis alone to a height held in a variable (`G0 Z=_ZSICHER`, a shop's
            // clearance in a GUD or R-parameter) leaves the cut as a literal one does: a rapid down into
            // what was just cut would crash the program itself.
            let z_expression_rapid = !feed
                && mv.expression == [false, false, true]
                && mv.axes.iter().all(Option::is_none);
            if feed {
                self.clear = false;
            } else if rises || (z_rapid && self.position_doubt) || z_expression_rapid {
                self.clear = true;
                self.cycle_position = false;
            }
            // A cut leaves the tool in the part (`clear`) until it rises: only a rapid down lowers it.
            if rises || feed {
                self.lowered = false;
            } else if matches!((from[2], to[2]), (Some(a), Some(b)) if b < a) {
                self.lowered = true;
            }
            if inexact {
                self.position_doubt = true;
            } else if mv.axes[2].is_some() {
                self.position_doubt = false;
            }
        }
        if self.t.first_cut.is_none() && moves_somehow && !g4 && self.state.motion != 0 {
            self.feed_move_before_cut(i);
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
            let (a, b) = (from.map(|v| v.unwrap_or(0.0)), to.map(|v| v.unwrap_or(0.0)));
            let length = move_length(self.state.motion, a, b, mv.centre, mv.radius);
            if self.state.motion == 0 {
                minutes += length / self.profile.timeline.rapid_mm_per_min;
            } else if is_thread(self.state.motion) && self.state.motion != 63 {
                // The axis follows the spindle: the lead (mm per revolution) times its speed.
                if let Some(lead) = mv.centre.iter().flatten().map(|l| l.abs()).reduce(f64::max) {
                    self.lead = Some(lead);
                }
                let speed = if self.state.direction == POSITIONED {
                    self.state.s.abs()
                } else {
                    rpm
                };
                match self.lead.map(|l| l * speed) {
                    Some(f) if f > 0.0 => minutes += length / f,
                    _ => inexact = true,
                }
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
        // A dwell leaves the tool where the retract put it: the rapid after it is still clear of the part.
        self.last_was_z_retract = (dwell && self.last_was_z_retract) || z_retract;
        self.pos = to;
        if self.state.z != to[2] {
            self.state.z = to[2];
            self.changed[field::Z] = i + 1;
        }
        self.add_minutes(minutes);
        if moves_somehow && !g4 && self.state.motion != 0 {
            self.last_cut = self.ticks;
        }
    }

    /// The spindle speed under constant cutting speed (G96): 1000·v / (π·D) at the diameter the tool stands
    /// at (X, a diameter under DIAMON), capped by LIMS; LIMS (or v itself) where no diameter is known yet.
    fn css_rpm(&self) -> f64 {
        let v = self.state.s.abs();
        let diameter = self.pos[0].map(|x| {
            if self.state.diameter.on() {
                x.abs()
            } else {
                2.0 * x.abs()
            }
        });
        let n = match diameter {
            Some(d) if d > 1.0 => 1000.0 * v / (std::f64::consts::PI * d),
            _ => self.lims.unwrap_or(v),
        };
        self.lims.map_or(n, |l| n.min(l))
    }

    /// Minutes from the end of the last cut to `at_min`.
    fn idle_since_cut(&self, at_min: f64) -> f64 {
        (at_min - self.last_cut as f64 / TICKS_PER_MIN).max(0.0)
    }

    /// The time so far (min).
    fn time(&self) -> f64 {
        self.ticks as f64 / TICKS_PER_MIN
    }

    fn add_minutes(&mut self, minutes: f64) {
        self.ticks = self.ticks.saturating_add(ticks(minutes));
    }

    /// What the unit leaves a caller if it returns here: the state, the fields not sure in it and where
    /// the tool stands (clear, just retracted, on a contour), as unsure as the state where the unit may
    /// return from elsewhere too.
    fn exit_here(&self) -> Exit {
        Exit {
            state: self.state.clone(),
            unsure: self.unsure_here(),
            standing: if self.returns_from_several_places() {
                Standing::UNKNOWN
            } else {
                Standing {
                    clear: self.clear,
                    retracted: self.last_was_z_retract,
                    contour: self.contour,
                    after_cycle: self.cycle_position,
                }
            },
        }
    }

    /// Notes where block `i` opens or closes a table definition (see [`Builder::table_open`]).
    fn table_definition(&mut self, i: usize, s: &Scan) {
        match (s.call.as_deref(), self.table_open) {
            (Some("CTABDEF" | "CONTPRON" | "CONTDCON"), None) => self.table_open = Some(i),
            (Some("CTABEND" | "EXECUTE"), Some(open)) => {
                self.tables.push((open, i));
                self.table_open = None;
            }
            _ => {}
        }
    }

    /// The unit jumps, or returns from inside an IF or loop: what it leaves a caller is one of several
    /// states.
    fn returns_from_several_places(&self) -> bool {
        self.exits_early || !self.jumps.is_empty()
    }

    /// The fields whose value here the fold does not know for sure: set differently on the ways here (an
    /// IF's branches, a jump, a loop that may not run) or left by a call, and not set again since. All of
    /// them where the unit jumps or returns from inside an IF or loop (its end state is then one of
    /// several).
    fn unsure_here(&self) -> [bool; field::COUNT] {
        if self.returns_from_several_places() {
            return [true; field::COUNT];
        }
        let seen = |t: usize, changed: &[usize; field::COUNT]| {
            field::set_as_seen_from(t, changed, &self.written, &self.written_in)
        };
        let merges = self.merges.iter().map(|(t, set_from, differ)| {
            field::not_set_since(differ, *set_from, &seen(*t, &self.changed))
        });
        let calls = self.call_unsure.iter().map(|(call, _, unsure)| {
            field::not_set_since(unsure, call + 1, &seen(*call, &[0; field::COUNT]))
        });
        let mut open = [false; field::COUNT];
        for fields in merges.chain(calls) {
            for (o, f) in open.iter_mut().zip(fields) {
                *o |= f;
            }
        }
        open
    }

    /// The timeline, with the names the unit calls.
    pub(super) fn finish(mut self) -> (Timeline, BTreeSet<String>) {
        self.strokes_cut();
        let total = self.time();
        self.t.total_min = total;
        self.t.last_cut_min = self.last_cut as f64 / TICKS_PER_MIN;
        let exit = self.exit.take().unwrap_or_else(|| self.exit_here());
        self.mark_merges();
        self.mark_unsure_after_calls();
        self.t.as_callee.touched = self.touched;
        self.t.as_callee.loads_tool |= self.m6_seen;
        if self.m6_seen {
            self.t.m_beside_t = None;
        }
        self.t.as_callee.leaves_unknown |= self.after_unknown_call;
        self.t.as_callee.after_cycle = self.after_call && !self.after_unknown_call;
        let always = self.m6_always && !self.returns_from_several_places();
        let callee = &mut self.t.as_callee;
        callee.end = exit.state;
        callee.end_unsure = exit.unsure;
        callee.end_standing = exit.standing;
        callee.moves = self.t.moves;
        callee.changes_tool_always = always;
        self.place_passes_and_sites(total);
        (self.t, self.called)
    }
}

/// G codes of the ISO dialect (G291 mode) that Siemens mode does not have: a program with them runs in ISO
/// mode, where Siemens-mode blocks are read otherwise (tool length comes from G43 H, cycles from G81 …).
fn is_iso_only(g: u32) -> bool {
    matches!(
        g,
        10 | 11 | 15 | 16 | 20 | 21 | 28..=30 | 43 | 44 | 49 | 65..=69 | 73 | 76 | 80..=89 | 98 | 99 | 291
    )
}
