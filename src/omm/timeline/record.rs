//! What the timeline says about a program: its time, passes, gate sites with the modal state at each,
//! loops, calls, and the registers, labels and offsets it uses.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

use serde::Serialize;

use super::modal::{Modal, field};

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
    /// The block lies between a frame change and the incremental move that traverses it
    /// ([`Timeline::frame_traverses`]).
    pub frame_traverse: bool,
    /// The block lies inside an IF … ELSE … ENDIF of the program: it runs only when its condition holds.
    pub conditional: bool,
    /// The tool may stand in the part there (no rapid clear of what was cut since the last cut): a gate's
    /// retract along the tool axis could run through material.
    pub in_part: bool,
    /// The tool went down its axis without cutting since it last rose or was changed: it may stand in a
    /// bore or under the part with its spindle stopped (a back-boring bar), which a gate's retract along
    /// the tool axis would pull through the part.
    pub lowered: bool,
    /// The block lies between two feed moves of a contour under continuous path (G64 … G645, or no path
    /// mode written, as MD20150 may make G64 the default): a STOPRE there stops the path, and the tool
    /// dwells on the contour and marks it.
    pub in_contour: bool,
    /// The block's arc starts tangent to the move before it (`CT`): a gate's last move (the descent to
    /// the saved height) would give it another tangent, and another arc.
    pub tangent_start: bool,
    /// The move before the block (no move between) rounds or chamfers its end into the next move (`RND`,
    /// `CHF`, `CHR`): that would be a gate's first move.
    pub rounded_into: bool,
}

impl Site {
    /// A site as the fold finds it, before its pass and its flags (loop, frame, IF, part, contour) are
    /// known: they are set once the whole program is read.
    pub(in crate::omm::timeline) fn new(
        block: usize,
        kind: SiteKind,
        time_min: f64,
        before: Modal,
        rpm_after: f64,
        idle_min: f64,
    ) -> Site {
        Site {
            block,
            kind,
            time_min,
            pass: 0,
            before,
            idle_min,
            rpm_after,
            state_varies: false,
            frame_traverse: false,
            conditional: false,
            in_part: false,
            lowered: false,
            in_contour: false,
            tangent_start: false,
            rounded_into: false,
        }
    }
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
    /// Blocks that end the program or return from it (M2, M17, M30, RET, GOTOS).
    pub ends: Vec<usize>,
    /// First block after the transfer header (`%…`, `;$PATH=…`).
    pub header_end: usize,
    /// First block after the declarations (DEF, PROC, EXTERN, DEFINE) at the top.
    pub preamble_end: usize,
    pub used_r: BTreeSet<u32>,
    /// Lines (1-based) that index R-parameters by an expression.
    pub computed_r_lines: Vec<usize>,
    /// Lines (1-based) that set the spindle speed by an expression the timeline cannot evaluate (`S=R1*1.5`,
    /// `S=_RPM` of a PROC), or call a subprogram from a folder that does: the prediction runs on with the
    /// speed before it.
    pub unknown_speed_lines: Vec<usize>,
    pub labels: BTreeSet<String>,
    /// Settable work offsets the program selects, with the first line selecting each.
    pub offsets: Vec<(u32, usize)>,
    /// Blocks that select a settable work offset (G500, G54 …), or call a subprogram from a folder that does.
    pub offset_selections: Vec<usize>,
    /// The first block with a G code of the ISO dialect (Fanuc-style) and that code: `G291`, which switches
    /// to it, or one Siemens mode does not have (G43 tool length with H, G28, G80 … G89 cycles …).
    pub iso_dialect: Option<(usize, u32)>,
    /// The subprogram the program changes tools with (the first one, as called): an `L6` whose M6 the
    /// machine's shop macro wraps. Gates change tools the same way.
    pub tool_change_call: Option<String>,
    /// The first tool-change subprogram that takes its tool as an argument (`TC(4)` of a `PROC TC(INT
    /// _TNR)` that selects `T=_TNR`): (line, 1-based; name). A gate cannot change tools with it.
    pub tool_change_by_argument: Option<(usize, String)>,
    /// Blocks of `ends` and `offset_selections` where inch dimensions are in force, with their G code (70,
    /// 700): what driftloop inserts there switches to metric and back.
    pub inch_at: BTreeMap<usize, u32>,
    /// The plane (17, 18, 19) the program selects before its first cut: where none is written yet, the
    /// machining the program starts with is in it (a milling program that writes `G17` after its first
    /// blocks, though a lathe's plane at reset is G18).
    pub setup_plane: Option<u32>,
    /// Lines (1-based) of `computed_r_lines` and `offsets` that call a subprogram from a folder in which the
    /// thing was found, with the subprogram's name.
    pub found_in_call: BTreeMap<usize, String>,
    /// M-codes of the machine's own the program uses and the profile's `[coolant]` does not list (vice,
    /// air, through-spindle coolant …): a gate leaves them as they are.
    pub machine_m: BTreeSet<u32>,
    /// In a program with no tool change the profile knows, the first machine M-code written beside a `T`
    /// (line, 1-based; code): `T1 M16` on a machine whose builder made M16 the tool change (MD22560).
    pub m_beside_t: Option<(usize, u32)>,
    /// The first tool change that loads a tool the program did not select (an `M6` with no `T` before
    /// it: the operator preselected it in MDA). A probe swap before it would replace that preselection.
    pub outside_load: Option<usize>,
    /// Blocks whose moves could not be timed (expressions, unknown feed).
    pub inexact_blocks: usize,
    /// The program's loops in the order they close (a section repeat at its REPEAT statement).
    pub loops: Vec<Loop>,
    /// Subprogram and cycle calls, whose time the timeline does not know: (line, 1-based; called name).
    pub untimed_calls: Vec<(usize, String)>,
    /// Calls of subprograms the timeline timed (the archive's, or a folder's): (line, name, min per run).
    pub timed_calls: Vec<(usize, String, f64)>,
    /// Where the unit programs the spindle. A call of the unit replays them onto the caller's spindle (a
    /// subprogram may set only S, or only M3, and inherit the rest).
    pub spindle_words: Vec<SpindleWord>,
    /// First block after the unit the timeline covers (the block count, unless the file is an archive).
    pub unit_end: usize,
    /// First block that moves at feed (G1, G2, G3): the first cut.
    pub first_cut: Option<usize>,
    /// The first cut when it is a call of a shop's or builder's subprogram driftloop cannot read (not a
    /// Siemens cycle): (line, name as written).
    pub first_cut_call: Option<(usize, String)>,
    /// The last subprogram called before the first cut that selects a work offset or writes frames (line,
    /// 1-based; name): the program's setup ends after it.
    pub setup_call: Option<(usize, String)>,
    /// The last subprogram called before the first cut (or as it) that loads a tool (line, 1-based; name).
    pub tool_load_call: Option<(usize, String)>,
    /// Where the program first sets the spindle itself (M3/M4/M5, SPOS, a tool change), when it cuts before
    /// that (`usize::MAX`: never): up to there it cuts with the spindle as the operator left it (started in
    /// MDA), which a gate's M5 would stop and could not start again.
    pub hand_spindle: Option<usize>,
    /// When the last cut ended (min from the start).
    pub last_cut_min: f64,
    /// The program moves an axis, or calls a subprogram or cycle that may.
    pub moves: bool,
    /// Blocks that write a frame variable themselves (`$P_UIFR[…]=`, `$P_PFRAME=`, …).
    pub frame_writes: Vec<usize>,
    /// Of those, the blocks that write `$P_IFRAME`, the frame in force.
    pub frame_in_force_writes: Vec<usize>,
    /// Blocks that write cutting-edge data (`$TC_DP…[t,d]=`: a wear, a length), or call a subprogram that
    /// does: a tool setter reads the tool with the new values.
    pub tool_data_writes: Vec<usize>,
    /// Blocks (change, move): a frame change and the incremental move that first traverses it on an axis;
    /// a gate at a block after the change and up to the move could not give the traverse back.
    pub frame_traverses: Vec<(usize, usize)>,
    /// The program's IF … ENDIF structures (IF block, ENDIF block): what lies between runs only sometimes.
    pub conditional: Vec<(usize, usize)>,
    /// The program's forward jumps (jump block, target block): the blocks after the jump up to the target
    /// (its label's block included) run only when the jump is not taken.
    pub skips: Vec<(usize, usize)>,
    /// One past the last block before the first cut that selects a work offset or changes frames or
    /// transformations: the reference measurement goes after the program's own setup.
    pub setup_end: usize,
    /// Run as a subprogram: what it does to its caller's state.
    pub as_callee: CalleeEffect,
    /// Sites whose state is not sure because of a call before them (a subprogram or cycle that may leave
    /// fields otherwise than the timeline has them, not set again by the program since): site block →
    /// (the call's line, 1-based; the name called; the fields, as G codes and words).
    pub unsure_after_call: BTreeMap<usize, (usize, String, String)>,
    /// The first call where the profile's `[calls]` declaration does not fit the program (a tool taken
    /// from an argument the call does not give): (line, 1-based; why). The transform refuses the program.
    pub bad_declaration: Option<(usize, String)>,
}

/// What a unit run as a subprogram does to its caller's modal state.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CalleeEffect {
    /// The fields its blocks set (by [`super::modal::field`] number; not the position, which a gate reads
    /// from the control): the caller's values of the others hold after the call.
    pub touched: [bool; field::COUNT],
    /// It loads a tool (M6): a tool-change subprogram, the `L6` of machines whose M6 calls a cycle.
    pub loads_tool: bool,
    /// A call inside it leaves a state the timeline does not know.
    pub leaves_unknown: bool,
    /// It calls Siemens cycles (declared `SAVE`) and no other call it cannot read, and changes no tool
    /// after the last of them: its caller's places until the next tool change are judged as after the
    /// cycle itself.
    pub after_cycle: bool,
    /// The state it ends in, from the default start: the values of the fields it sets (at its first
    /// return outside any IF or loop, where it has one).
    pub end: Modal,
    /// The fields it sets whose value at its end the timeline does not know for sure (set in an IF, a
    /// loop that may not run, or by a call; or the unit jumps or returns from inside an IF or loop): a
    /// caller takes the end's value of the others.
    pub end_unsure: [bool; field::COUNT],
    /// `PROC … SAVE`: its G codes come back at its end (Siemens, K2 "Subprograms with SAVE attribute").
    pub saves: bool,
    /// Where it leaves the tool, for what its caller's next places are. Taken by the caller where the
    /// subprogram moves (`moves`).
    pub end_standing: Standing,
    /// It moves an axis.
    pub moves: bool,
    /// It changes the tool on every run (M6 outside any IF or loop, no jump): not a change it may skip
    /// where the tool is in the spindle already.
    pub changes_tool_always: bool,
    /// How it selects a tool by an expression (`T=_TNR`, the tool its caller passes): called without that
    /// argument it selects none (T0).
    pub selects: ByExpression,
    /// How it sets the cutting edge by an expression (`D=_SCHN`).
    pub sets_d: ByExpression,
}

/// A unit's spindle words in one block: (min from its start, S, M3/M4/M5), and the place of the `PROC`
/// parameter its S is (`S=_RPM`), whose value a call that passes a number there gives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpindleWord {
    pub at_min: f64,
    pub s: Option<f64>,
    pub direction: Option<u32>,
    pub s_parameter: Option<usize>,
}

/// How a unit sets a field by an expression: never, always by the same one of its `PROC` parameters
/// (untouched by the unit before), or otherwise. A call that passes a literal in that parameter's place
/// (`TC(4)`, `WZW("MILL", 2)`) sets the field to it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub enum ByExpression {
    #[default]
    Never,
    Parameter(usize),
    Other,
}

impl ByExpression {
    /// After one more block sets the field by an expression: by the parameter in `place`, or another.
    pub fn and(self, place: Option<usize>) -> Self {
        match (self, place) {
            (ByExpression::Never, Some(k)) => ByExpression::Parameter(k),
            (ByExpression::Parameter(j), Some(k)) if j == k => self,
            _ => ByExpression::Other,
        }
    }

    pub fn ever(self) -> bool {
        self != ByExpression::Never
    }
}

impl CalleeEffect {
    /// A tool-change subprogram the caller may treat as its own M6: it loads the tool the caller
    /// selected, cuts nothing and leaves a known state.
    pub fn is_tool_change(&self, cuts: bool) -> bool {
        self.loads_tool && !cuts && !self.leaves_unknown && !self.touched[field::SELECTED]
    }

    /// The fields a caller's state may hold otherwise after the call than before it: those it sets, less
    /// the G codes `SAVE` brings back (motion, G90/G91, feed type, plane, path mode, radius compensation,
    /// work offset, DIAMON, unit).
    pub fn left(&self) -> [bool; field::COUNT] {
        let mut left = self.touched;
        if self.saves {
            for f in SAVED {
                left[f] = false;
            }
        }
        left
    }

    /// Of [`CalleeEffect::left`], those a gate gives back whose value after the call is its end's for
    /// sure. Not the feed under `SAVE`: that it stays as the subprogram left it (the G codes come back,
    /// F is none) was not verified on a control, and the dry run brings it back.
    pub fn sure_at_end(&self) -> [bool; field::COUNT] {
        let mut sure = [false; field::COUNT];
        // The modal fields a gate gives back: the G codes SAVE brings back, the cutting edge and the feed.
        for (f, s) in sure.iter_mut().enumerate() {
            let given_back = SAVED.contains(&f) || f == field::D || f == field::FEED;
            *s = given_back && !self.end_unsure[f];
        }
        sure[field::FEED] &= !self.saves;
        let left = self.left();
        for (s, l) in sure.iter_mut().zip(left) {
            *s &= l;
        }
        sure
    }

    /// The fields the call leaves unsure: [`CalleeEffect::left`] less [`CalleeEffect::sure_at_end`].
    pub fn unsure_after(&self) -> [bool; field::COUNT] {
        let mut unsure = self.left();
        for (u, s) in unsure.iter_mut().zip(self.sure_at_end()) {
            *u &= !s;
        }
        unsure
    }
}

/// Where a unit leaves the tool, for the places after its call.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Standing {
    /// Clear of the part: a rapid rose in Z since its last cut (or nothing was cut).
    pub clear: bool,
    /// Its last move a rapid up the tool axis.
    pub retracted: bool,
    /// Its last move a feed along a contour under continuous path.
    pub contour: bool,
    /// A milling or turning cycle ran after its last rapid up and tool change: where that left the tool
    /// is not known (see `machining_cycle_leaves`).
    pub after_cycle: bool,
}

impl Standing {
    /// Where a unit that may return from several places leaves the tool: in the part, on a contour.
    pub const UNKNOWN: Standing = Standing {
        clear: false,
        retracted: false,
        contour: true,
        after_cycle: false,
    };
}

/// The fields `PROC … SAVE` brings back at the subprogram's end (its modal G codes).
const SAVED: [usize; 9] = [
    field::MOTION,
    field::ABSOLUTE,
    field::FEED_MODE,
    field::PLANE,
    field::PATH_MODE,
    field::COMP,
    field::OFFSET,
    field::DIAMETER,
    field::UNITS,
];

/// The statement that makes a loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum LoopKind {
    For,
    While,
    /// `LOOP … ENDLOOP`: endless unless left by a jump.
    Loop,
    /// `REPEAT … UNTIL condition`.
    RepeatUntil,
    /// `REPEAT label [label] P=n`: a section repeated.
    Repeat,
    /// `REPEATB label P=n`: one block repeated.
    RepeatBlock,
}

impl LoopKind {
    pub fn keyword(self) -> &'static str {
        match self {
            LoopKind::For => "FOR",
            LoopKind::While => "WHILE",
            LoopKind::Loop => "LOOP",
            LoopKind::RepeatUntil => "REPEAT…UNTIL",
            LoopKind::Repeat => "REPEAT",
            LoopKind::RepeatBlock => "REPEATB",
        }
    }
}

/// One loop of the program, as the timeline counts it. A loop whose count is known before the program
/// runs — `FOR var = a TO b` with literal bounds (or R-parameters last assigned a literal), a section
/// repeat `REPEAT label [label] P=n` / `REPEATB label P=n` — is counted that often: its further runs are
/// added to the program time where they happen (and `omm::loops::site_runs` lists the sites of its body
/// once per run). Any other loop (WHILE, LOOP, REPEAT … UNTIL, computed bounds) is counted once, and
/// says so.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Loop {
    pub kind: LoopKind,
    /// Block of the loop statement (`FOR …`, `WHILE …`, the `REPEAT` statement).
    pub block: usize,
    /// First and last block of the body or repeated section.
    pub body: (usize, usize),
    /// How often the body runs in all (the run in the program's flow included), when known before the
    /// program runs; `None`: counted once.
    pub runs: Option<u64>,
    /// Why the count is not known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unknown: Option<&'static str>,
    /// Start of the first run and length of one run (min, measurements not included).
    pub start_min: f64,
    pub body_min: f64,
    /// The further runs happen after this block (ENDFOR, the REPEAT statement), from this time on.
    #[serde(skip)]
    pub repeat_block: usize,
    #[serde(skip)]
    pub repeat_min: f64,
}

impl Loop {
    /// The blocks whose gates run again with the body: a gate goes before its block, so the one before a
    /// section's labelled first block stays outside the section.
    pub fn gate_blocks(&self) -> (usize, usize) {
        match self.kind {
            LoopKind::Repeat | LoopKind::RepeatBlock => (self.body.0 + 1, self.body.1),
            _ => self.body,
        }
    }

    /// Runs beyond the one the program's flow makes anyway.
    pub fn further_runs(&self) -> u64 {
        self.runs.map_or(0, |n| n.saturating_sub(1))
    }
}
