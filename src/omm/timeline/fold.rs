//! Folding the blocks, in order, into a [`Timeline`]: time, modal state, passes, gate sites, loops and
//! the subprograms calls run. The blocks come as the chunks [`super::read`] made of them, with the runs
//! of moves [`super::moves`] timed in the parser.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::rc::Rc;
use std::sync::Arc;

use crate::omm::profile::{Profile, ToolChange};
use crate::syntax::BlockKind;

use super::modal::{Modal, field, frame, unknown};
use super::moves::RunRef;
use super::read::{Bound, Chunk, Count, Move, Scan, frame_op, head};
use super::record::{Loop, LoopKind, Pass, Site, SiteKind, Timeline};
use super::timing::{TICKS_PER_MIN, move_length, ticks};

/// What a call runs, as the fold asks for it.
pub(super) trait Callees {
    /// The timeline of subprogram `name`, and whether it is in another file (a folder's) rather than in
    /// this one (an archive's unit); `None` for a subprogram or cycle whose time is not known.
    fn timeline(&mut self, name: &str) -> Option<(Rc<Timeline>, bool)>;
}

pub(super) struct Builder<'p> {
    profile: &'p Profile,
    /// The timelines of the subprograms calls may run.
    callees: &'p mut dyn Callees,
    /// A subprogram or cycle ran since the last tool change: the modal state it left (tool, speed, feed,
    /// frame) is not known, so no gate measures, and restores a state, until the next tool change.
    after_call: bool,
    /// The cycle or subprogram an `MCALL` made modal, and how the call lists name it (`MCALL NAME`): it
    /// runs after each block that moves.
    modal_call: Option<(String, String)>,
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
    /// End of the last run of timed moves folded (its blocks in later chunks are skipped).
    run_end: usize,
    /// Until the first cut: the first block after the setup so far, as a [`SiteKind::Start`] site.
    start: Option<Site>,
    /// When the last cut (feed move) ended, in ticks.
    last_cut: u64,
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
    pub(super) fn new(profile: &'p Profile, callees: &'p mut dyn Callees) -> Self {
        Builder {
            profile,
            callees,
            after_call: false,
            modal_call: None,
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
            run_end: 0,
            start: None,
            last_cut: 0,
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
        self.start_site(i, start);
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
        self.movement(i, start, &before, mv, false, None, false, false);
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
        }
        if let Some(f) = run.feed.last {
            self.state.feed = Some(f);
            self.state.unknown &= !unknown::FEED;
        }
        let rapid = self.profile.timeline.rapid_mm_per_min;
        self.t.moves = true;
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
            idle: self.idle_since_cut(start),
            before: before.clone(),
            rpm: self.state.rpm(),
            tool: self
                .state
                .tool
                .clone()
                .or_else(|| self.state.selected.clone()),
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
    }

    /// A subprogram or cycle runs at block `i`, `repeats` times: an archive subprogram adds its time, any
    /// other call is listed as not timed (`shown` is how the list names it).
    fn call(&mut self, i: usize, name: &str, shown: &str, repeats: Option<f64>) {
        // The swivel cycle's effect on the frames is followed (see `frames`).
        self.after_call |= name != "CYCLE800";
        self.t.moves = true;
        if !self.called.contains(name) {
            self.called.insert(name.to_string());
        }
        // A subprogram from a folder is in another file: what it leaves untimed is listed at the call (its
        // own line numbers mean nothing in this program).
        match self.callees.timeline(name) {
            Some((sub, elsewhere)) => {
                self.t
                    .timed_calls
                    .push((i + 1, shown.to_string(), sub.total_min));
                let runs = repeats.filter(|p| *p >= 1.0).unwrap_or(1.0).floor();
                if !sub.spindle_words.is_empty() {
                    self.replay_spindle(i, &sub, runs);
                }
                self.add_minutes(runs * sub.total_min);
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
        let (at, rpm_before, state_before) = (self.time(), self.rpm, self.state.clone());
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
            idle_min: self.idle_since_cut(time_min),
        });
    }

    /// The speed-change site a subprogram's speed asks for, at the first block after its call.
    fn speed_site_after_call(&mut self, i: usize) {
        if self.speed_site_after.is_some_and(|call| call < i) {
            self.speed_site_after = None;
            self.note_site(i);
            self.speed_site(i, self.time(), self.state.clone(), self.rpm);
        }
    }

    /// The site a stop or dressing call before block `i` asked for.
    fn safe_site_after(&mut self, i: usize) {
        if let Some((_, kind)) = self.safe_after.take_if(|(at, _)| *at < i) {
            self.note_site(i);
            self.t.sites.push(Site {
                block: i,
                kind,
                time_min: self.time(),
                pass: 0,
                before: self.state.clone(),
                rpm_after: self.rpm,
                idle_min: self.idle_since_cut(self.time()),
                state_varies: false,
            });
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
        if mv.axes.iter().any(Option::is_some)
            && let Some((name, shown)) = self.modal_call.take()
        {
            self.call(i, &name, &shown, None);
            self.modal_call = Some((name, shown));
        }
    }

    pub(super) fn block(&mut self, i: usize, s: &Scan, kind: BlockKind) {
        self.speed_site_after_call(i);
        self.safe_site_after(i);
        if let Some(name) = &s.call {
            self.call(i, name, name, s.repeats);
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
        self.start_site(i, start);
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
        let setup = s.frame_ops != 0
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
        self.frames(s.frame_ops);
        self.t.moves |= s.other_axes;
        // Modal words first: they hold for this block's move.
        for g in s.g.iter() {
            match g {
                0..=3 => self.state.motion = g,
                90 => self.state.absolute = true,
                91 => self.state.absolute = false,
                93..=95 => {
                    self.per_rev = g == 95;
                    self.state.feed_mode = Some(g);
                }
                17..=19 => self.state.plane = Some(g),
                40..=42 => self.state.comp = g,
                60 | 64 | 641..=645 => self.state.path_mode = Some(g),
                _ => {}
            }
        }
        let dwell = s.g.contains(4);
        self.state.unknown |= s.unknown;
        if let Some(f) = s.mv.f
            && !dwell
        {
            self.state.feed = Some(f);
            self.state.unknown &= !unknown::FEED;
        }
        if let Some(v) = s.s {
            self.state.s = v;
            self.state.unknown &= !unknown::S;
        }
        if let Some(d) = s.d {
            self.state.d = Some(d);
            self.state.unknown &= !unknown::D;
        }
        let mut direction = None;
        for m in s.m.iter() {
            match m {
                3..=5 => direction = Some(m),
                6 => self.m6_seen = true,
                2 | 30 => self.t.ends.push(i),
                7..=9 => self.state.coolant = Some(m),
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
            self.state.selected = Some(tool.clone());
            self.state.unknown &= !unknown::TOOL;
        }
        if tool_change {
            // M6 loads the selected tool (T alone only selects it, in a program that uses M6).
            self.state.tool = self.state.selected.clone();
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
            self.modal_call = modal.as_ref().map(|n| (n.clone(), format!("MCALL {n}")));
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
                let end = self.time();
                // A label defined again: a REPEAT after it searches backward and finds this one.
                self.label_times.insert(
                    l.to_ascii_uppercase(),
                    Label {
                        block: i,
                        start,
                        end,
                        state: prev,
                    },
                );
            }
        }
        self.loops(i, s, kind, start);
        self.start_site_speed(i);
    }

    /// Keeps block `i` as the start site while the setup is over and nothing has cut yet; a later setup
    /// block (work offset, frame) makes the block after it the candidate instead.
    fn start_site(&mut self, i: usize, time_min: f64) {
        if self.t.first_cut.is_some() || !(self.header_done && self.preamble_done) {
            return;
        }
        if self
            .start
            .as_ref()
            .is_some_and(|s| s.block >= self.t.setup_end)
        {
            return;
        }
        // After a call the modal state is not known for sure (as for the other sites, see `call`).
        if self.after_call {
            self.varies.insert(i);
        }
        self.start = Some(Site {
            block: i,
            kind: SiteKind::Start,
            time_min,
            pass: 0,
            before: self.state.clone(),
            rpm_after: self.rpm,
            state_varies: false,
            idle_min: self.idle_since_cut(time_min),
        });
    }

    /// The speed from the start site's block on.
    fn start_site_speed(&mut self, i: usize) {
        if let Some(site) = self.start.as_mut().filter(|s| s.block == i) {
            site.rpm_after = self.rpm;
        }
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
                start_min: self.time(),
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
                repeat_min: self.time(),
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
                repeat_min: self.time(),
            });
        }
    }

    /// Records a loop and adds its further runs to the time.
    fn repeat(&mut self, l: Loop) {
        self.add_minutes(l.further_runs() as f64 * l.body_min);
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
        // Axes written as expressions move too, by an amount the timeline does not know.
        let moves_somehow = moved || inexact;
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
                idle_min: self.idle_since_cut(start),
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
        self.t.moves |= moves_somehow;
        if self.t.first_cut.is_none() && moves_somehow && !g4 && self.state.motion != 0 {
            self.t.first_cut = Some(i);
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
        self.add_minutes(minutes);
        if moves_somehow && !g4 && self.state.motion != 0 {
            self.last_cut = self.ticks;
        }
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

    /// The timeline, with the names the unit calls.
    pub(super) fn finish(mut self) -> (Timeline, BTreeSet<String>) {
        let total = self.time();
        self.t.total_min = total;
        self.t.last_cut_min = self.last_cut as f64 / TICKS_PER_MIN;
        // Without M6 in the program the T word changes the tool.
        let mut starts = self.pass_marks;
        let t_loads = self.profile.probe.tool_change == ToolChange::T;
        if !self.m6_seen && self.profile.passes.tool_change {
            // On a machine that changes tools with M6, a T alone only selects: no change follows it.
            starts.extend(self.tool_marks.into_iter().map(|m| PassMark {
                tool_change: t_loads,
                ..m
            }));
        }
        starts.sort_by_key(|m| m.block);
        starts.dedup_by_key(|m| m.block);
        let ends: Vec<f64> = starts
            .iter()
            .skip(1)
            .map(|m| m.time)
            .chain(std::iter::once(total))
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
                idle_min: m.idle,
            });
        }
        // The start site only counts once it is known to come after the setup.
        if let Some(site) = self.start.take().filter(|s| s.block >= self.t.setup_end) {
            self.t.sites.push(site);
        }
        // One site per block: a pass start wins over a speed change or retract at the same block.
        self.t
            .sites
            .sort_by_key(|s| (s.block, !matches!(s.kind, SiteKind::PassStart { .. })));
        self.t.sites.dedup_by_key(|s| s.block);
        let mut pass = 0;
        for site in &mut self.t.sites {
            site.state_varies = self.varies.contains(&site.block);
            // Without M6 in the program, T loads the tool at once.
            if t_loads {
                site.before.tool = site.before.selected.clone();
            }
            match site.kind {
                SiteKind::PassStart { .. } => pass = site.pass,
                _ => site.pass = pass,
            }
        }
        (self.t, self.called)
    }
}

/// A block that may start a pass, with the state around it.
struct PassMark {
    block: usize,
    tool_change: bool,
    time: f64,
    idle: f64,
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

/// The runs of a `FOR from TO to` loop (counting up by one), or why they are not known.
fn for_runs(from: Option<f64>, to: Option<f64>) -> Result<u64, &'static str> {
    let (Some(a), Some(b)) = (from, to) else {
        return Err("bounds computed at run time");
    };
    if a.fract() != 0.0 || b.fract() != 0.0 {
        return Err("bounds are not whole numbers");
    }
    if b < a {
        return Err("the bounds give no run");
    }
    Ok(((b - a) as u64).saturating_add(1))
}
