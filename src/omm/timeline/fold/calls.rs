//! What a call adds to the timeline: the called subprogram's time (as often as `P` says), its spindle
//! words replayed onto this program's spindle, and what it leaves untimed or uses; an `MCALL`'s cycle after
//! every block that moves.

use std::collections::BTreeMap;
use std::sync::Arc;

use super::Builder;
use super::declared::ToolChangeCall;
use crate::omm::declared_calls;
use crate::omm::timeline::modal::{Modal, POSITIONED, coolant_after, field, is_thread, unknown};
use crate::omm::timeline::read::{CallArg, Move, Scan, measures_workpiece, section_call_labels};
use crate::omm::timeline::record::{ByExpression, CalleeEffect, SpindleWord, Timeline};

impl Builder<'_> {
    /// A subprogram or cycle runs at block `i`, `repeats` times, with the arguments `args`: an archive
    /// subprogram adds its time, any other call is listed as not timed (`shown` is how the list names it).
    /// A tool-change subprogram (see [`CalleeEffect::is_tool_change`]) or a call the profile declares to
    /// load a tool is returned: the caller treats the block as a tool change. A subprogram driftloop finds
    /// is read even where the profile declares its name: what it reads is what runs.
    pub(super) fn call(
        &mut self,
        i: usize,
        name: &str,
        shown: &str,
        repeats: Option<f64>,
        args: &[CallArg],
    ) -> Option<ToolChangeCall> {
        // The high-speed settings cycle sets the path mode (G64x, compressor, tolerances): the path mode is
        // then the cycle's, which a gate leaves as it is.
        if name == "CYCLE832" {
            self.state.path_mode = None;
            self.touched[field::PATH_MODE] = true;
            // A gate writes no path mode back where it is the cycle's.
            self.mark_written(i + 1, field::only(&[field::PATH_MODE]));
        }
        self.t.moves = true;
        if !self.called.contains(name) {
            self.called.insert(name.to_string());
        }
        // A subprogram from a folder is in another file: what it leaves untimed is listed at the call (its
        // own line numbers mean nothing in this program).
        match self.callees.timeline(name) {
            Some((sub, elsewhere)) => {
                let loads = sub.as_callee.is_tool_change(sub.first_cut.is_some());
                let callee = &sub.as_callee;
                if !loads && callee.leaves_unknown {
                    self.state_unknown_after(name);
                    self.unsure_after(i, name, None);
                } else {
                    // Its Siemens cycles leave here what they leave where the program calls them itself.
                    self.after_call |= callee.after_cycle;
                    // Read to its end with no call it cannot read: each field it sets is followed, for this
                    // unit's callers too.
                    for (mine, its) in self.touched.iter_mut().zip(callee.left()) {
                        *mine |= its;
                    }
                    if loads {
                        if callee.saves && callee.touched[field::FEED] {
                            self.unsure_after(i, name, Some(field::only(&[field::FEED])));
                        }
                    } else {
                        // Sure (its end's value, taken after the block) or unsure until the program sets
                        // it again.
                        self.unsure_after(i, name, Some(callee.unsure_after()));
                        self.end_to_take = Some(sub.clone());
                    }
                }
                // A subprogram that selects a work offset or changes frames before the program has cut sets up
                // the coordinates the zero measures in: the zero goes after it, and where it cuts too there is
                // no place for one (before it the probe would go to its point in a frame the program has not
                // set yet).
                if !sub.tool_data_writes.is_empty() {
                    self.t.tool_data_writes.push(i);
                }
                let setup = sub.as_callee.touched[field::OFFSET] || !sub.frame_writes.is_empty();
                if setup && self.t.first_cut.is_none() {
                    self.t.setup_end = i + 1;
                    self.t.setup_call = Some((i + 1, shown.to_string()));
                }
                // A subprogram that loads a tool before the program has cut: a tool setter's zero before
                // it would measure another tool than the one that cuts.
                if sub.as_callee.loads_tool && self.t.first_cut.is_none() {
                    self.t.tool_load_call = Some((i + 1, shown.to_string()));
                }
                // A subprogram that cuts: the reference measurement goes before it.
                if sub.first_cut.is_some() {
                    self.cuts(i, sub.hand_spindle.is_some());
                }
                self.t
                    .timed_calls
                    .push((i + 1, shown.to_string(), sub.total_min));
                let runs = repeats.filter(|p| *p >= 1.0).unwrap_or(1.0).floor();
                if !sub.spindle_words.is_empty() {
                    self.replay_spindle(i, &sub, runs, args);
                }
                self.add_minutes(runs * sub.total_min);
                // A `CALL BLOCK` section's blocks are this unit's own: it lists them itself.
                let own_blocks = section_call_labels(name).is_some();
                if !own_blocks {
                    self.t.inexact_blocks += sub.inexact_blocks;
                }
                let line = |own: usize| if elsewhere { i + 1 } else { own };
                if !sub.offset_selections.is_empty() && self.state.unfit().is_none() {
                    self.t.offset_selections.push(i);
                }
                self.t.unknown_speed_lines.extend(
                    sub.unknown_speed_lines
                        .iter()
                        .filter(|_| !own_blocks)
                        .map(|l| line(*l)),
                );
                self.t.untimed_calls.extend(
                    sub.untimed_calls
                        .iter()
                        .filter(|_| !own_blocks)
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
                loads.then_some(ToolChangeCall::Read(sub))
            }
            None if let Some(decl) = declared_calls::find(&self.profile.calls, name) => self
                .declared(i, shown, decl, args)
                .map(ToolChangeCall::Declared),
            None => {
                // The tool that measures a workpiece or calibrates on one (CYCLE976) is a probe.
                if measures_workpiece(name) || name == "CYCLE976" {
                    self.strokes_measured();
                } else if !cuts_nothing(name) {
                    self.strokes_cut();
                }
                self.state_unknown_after(name);
                self.unsure_after(i, name, None);
                // A cycle or subprogram driftloop cannot see into may cut (a drilling or pocket cycle):
                // the reference measurement goes before it. The swivel, settings and measuring cycles
                // do not cut.
                if !cuts_nothing(name) && !self.profile.cycle_call().starts_with(name) {
                    // Siemens' machining cycles cut at the spindle they find; a shop's subprogram driftloop
                    // cannot read may start its own or cut with the operator's, so the gates before it
                    // check the spindle at run time as before a cycle.
                    if !is_siemens_cycle(&name.to_ascii_uppercase()) && self.t.first_cut.is_none() {
                        self.t.first_cut_call = Some((i + 1, shown.to_string()));
                    }
                    self.cuts(i, true);
                }
                // A milling or turning cycle whose state after it is followed: where it leaves the tool
                // no source read here says, so it may stand in the part (a slot, a groove) until a rapid
                // rises or the tool is changed, and the height the fold holds is no longer the tool's (a
                // rapid of the tool axis alone then counts as rising, as after a subprogram that moves).
                if machining_cycle_leaves(self.runs(name)).is_some() {
                    self.cycle_position = true;
                    self.position_doubt = true;
                }
                self.t.untimed_calls.push((i + 1, shown.to_string()));
                None
            }
        }
    }

    /// After a call of `name` the modal state is not known until the next tool change, unless the cycle
    /// is one that leaves it known.
    fn state_unknown_after(&mut self, name: &str) {
        if !leaves_state_known(name) && self.cycle_leaves(name).is_none() {
            self.after_call = true;
            if !is_siemens_cycle(&self.runs(name).to_ascii_uppercase()) {
                self.after_unknown_call = true;
                self.t.as_callee.leaves_unknown = true;
            }
        }
    }

    /// After the call of `name` at block `i`: the fields it may have left otherwise than the timeline has
    /// them stay unsure at every later site until the program's words set them again (see
    /// [`Builder::note_written`]); a tool change does not set them (a gate before the program's own M6 or
    /// after it gave back the motion and feed from before a subprogram that left G1 F100: the program's
    /// next `Z-2` went down in rapid). What a subprogram the timeline reads sets (`touched`), else every
    /// field but the position; a Siemens cycle (declared `SAVE`: its G codes and programmable frame come
    /// back) or one that leaves the state known, none.
    pub(super) fn unsure_after(
        &mut self,
        i: usize,
        name: &str,
        touched: Option<[bool; field::COUNT]>,
    ) {
        let touched = match self
            .cycle_leaves(name)
            .or_else(|| old_rule_cycle_leaves(name))
        {
            Some(fields) => {
                // A caller of this unit takes them as left by it too.
                for (mine, its) in self.touched.iter_mut().zip(fields) {
                    *mine |= its;
                }
                Some(fields)
            }
            None if leaves_state_known(name) || is_siemens_cycle(self.runs(name)) => return,
            None => touched,
        };
        let mut unsure = touched.unwrap_or([true; field::COUNT]);
        // The position a gate reads from the control; what is not known (expressions) the site's state
        // says itself.
        unsure[field::Z] = false;
        unsure[field::UNKNOWN] = false;
        // What a gate writes back only when the program had set it: unset, the gate writes nothing and
        // the call's value stays (a gate switches coolant off only where the timeline has it on, so a
        // coolant the call left on stays on through the measurement: unsure whatever the timeline has).
        for f in field::SET_ONLY {
            unsure[f] &= !self.state.is_unset(f);
        }
        self.leaves_unsure(i, name, unsure);
    }

    /// Block `i` (`name` says what it is) may leave the fields `unsure` otherwise than the timeline has
    /// them, until the program's words set them again (see [`Builder::mark_unsure_after_calls`]).
    pub(super) fn leaves_unsure(&mut self, i: usize, name: &str, unsure: [bool; field::COUNT]) {
        if !unsure.contains(&true) {
            return;
        }
        // Calls with no site between them: the later one stands for both (what was set since the later
        // call was set since the earlier one too).
        let no_site_since = |call: usize| self.site_changes.last().is_none_or(|(b, ..)| *b <= call);
        if let Some(last) = self.call_unsure.last_mut()
            && no_site_since(last.0)
        {
            for (mine, its) in last.2.iter_mut().zip(unsure) {
                *mine |= its;
            }
            (last.0, last.1) = (i, name.to_string());
            return;
        }
        self.call_unsure.push((i, name.to_string(), unsure));
    }

    /// The sites after each call that made fields unsure ([`Builder::unsure_after`]) where one of them was
    /// not written since: their state varies, and the timeline says which call made it so. The call's own
    /// block counts as not setting them: its words run before the call. Inside a loop body, a repeated
    /// section or what a backward jump runs again, the sites before the call are reached after it on the
    /// later runs too: there a field is sure only where the body writes it before the site.
    pub(super) fn mark_unsure_after_calls(&mut self) {
        let calls = std::mem::take(&mut self.call_unsure);
        if calls.is_empty() {
            return;
        }
        let mut bodies: Vec<(usize, usize)> = self.t.loops.iter().map(|l| l.body).collect();
        for (&from, targets) in &self.jumps {
            bodies.extend(targets.iter().filter(|&&t| t < from).map(|&t| (t, from)));
        }
        // Site block → the last call (by index) that leaves it unsure, and the fields.
        let mut unsure_at: BTreeMap<usize, (usize, [bool; field::COUNT])> = BTreeMap::new();
        for (k, (call, _, unsure)) in calls.iter().enumerate() {
            let open = |(written, written_in), since: usize| {
                let seen =
                    field::set_as_seen_from(since - 1, &[0; field::COUNT], written, written_in);
                let open = field::not_set_since(unsure, since, &seen);
                open.contains(&true).then_some(open)
            };
            let after = self.site_changes.partition_point(|(b, ..)| *b <= *call);
            for (b, _, written, written_in) in &self.site_changes[after..] {
                // Every unsure field set again: so it stays at every later site.
                let Some(fields) = open((written, written_in), call + 1) else {
                    break;
                };
                unsure_at.insert(*b, (k, fields));
            }
            for &(first, _) in bodies.iter().filter(|(a, z)| a <= call && call <= z) {
                let from = self.site_changes.partition_point(|(b, ..)| *b < first);
                let before_call = self.site_changes[from..]
                    .iter()
                    .take_while(|(b, ..)| b <= call);
                for (b, _, written, written_in) in before_call {
                    if let Some(fields) = open((written, written_in), first) {
                        let e = unsure_at.entry(*b).or_insert((k, fields));
                        for (mine, its) in e.1.iter_mut().zip(fields) {
                            *mine |= its;
                        }
                    }
                }
            }
        }
        for (b, (k, fields)) in unsure_at {
            // A feed the program sets again before it uses one is no gate's to give back: what stays
            // unsure beside it decides (nothing: the place measures; the spindle alone: as after a call
            // that leaves only the spindle — a milling cycle leaves its speed and feed, the next tool's
            // block writes F before its first cut).
            let feed_unused = fields[field::FEED] && self.feed_unused_from(b);
            let mut rest = fields;
            rest[field::FEED] &= !feed_unused;
            let spindle_only =
                (0..field::COUNT).all(|f| !rest[f] || f == field::S || f == field::DIRECTION);
            if spindle_only && feed_unused {
                self.feed_not_given.insert(b);
            }
            if !rest.contains(&true) {
                continue;
            }
            if spindle_only {
                self.varies_but_spindle.insert(b);
            } else {
                self.varies.insert(b);
            }
            let (call, name, _) = &calls[k];
            let words: Vec<&str> = (0..field::COUNT)
                .filter(|&f| fields[f])
                .map(field::word)
                .collect();
            self.t
                .unsure_after_call
                .insert(b, (call + 1, name.clone(), words.join(", ")));
        }
    }

    /// The fields block `i`'s words set (`set`, from [`Builder::touch`]) to a value that does not depend
    /// on the state before them. Not a frame (ATRANS, AROT … add to the one in force; TRANS leaves a
    /// transformation or swivel), not M7 or M8 (each adds to the other; M9 ends both), not a machine
    /// coolant code (a pair of the profile's), not an expression. A tool change (M6) sets the tool and
    /// stops the spindle, as the timeline has it; one that `reloads` the tool in the spindle may leave it
    /// turning (a macro that skips it), so it sets the spindle only with the block's own M3/M4/M5.
    pub(super) fn note_written(
        &mut self,
        i: usize,
        s: &Scan,
        set: [bool; field::COUNT],
        no_speed: bool,
        reloads: bool,
    ) {
        let mut whole = set;
        whole[field::FRAMES] = false;
        whole[field::UNKNOWN] = false;
        whole[field::MACHINE_COOLANT] = false;
        whole[field::COOLANT] = s.m.contains(9);
        // G96/G97 or LIMS alone leave the speed value as it was.
        whole[field::S] = s.s.is_some() && !no_speed;
        if s.m.contains(self.profile.probe.tool_change_m) {
            whole[field::TOOL] = true;
            whole[field::DIRECTION] |= !reloads;
        }
        self.mark_written(i + 1, whole);
    }

    /// Notes that the program's words set `fields` wholly, by block `at` (one past the block): a call's
    /// unsureness of them ends there.
    pub(super) fn mark_written(&mut self, at: usize, fields: [bool; field::COUNT]) {
        let within = self.conditional_region(at - 1).map_or(0, |b| b + 1);
        for f in (0..field::COUNT).filter(|&f| fields[f]) {
            self.written[f] = at;
            self.written_in[f] = within;
        }
    }

    /// After a tool-change subprogram at block `i`: the fields it set hold its values (coolant off, rapid
    /// motion …), set by its own words whatever the caller's state. The tool is the caller's selection
    /// (the block is a tool change), the spindle was replayed (see [`Builder::replay_spindle`]), and the
    /// position a gate reads from the control, as after an M6. The frames it changes combine with the
    /// caller's, so sites after the call are unfit until the program sets them again.
    pub(super) fn after_tool_change_call(&mut self, i: usize, sub: &CalleeEffect, entry: &Modal) {
        // The feed under SAVE was made unsure at the call.
        let mut t = sub.left();
        t[field::FEED] &= !sub.saves;
        let (t, end) = (&t, &sub.end);
        let before = self.state.clone();
        self.take_end(end, t);
        if t[field::MACHINE_COOLANT] {
            self.state.machine_coolant = end.machine_coolant;
        }
        if let (true, Some(c)) = (t[field::COOLANT], end.coolant) {
            self.state.coolant = coolant_after(self.state.coolant, c);
        }
        self.state.unknown |= end.unknown;
        self.note_changes(i, &before);
        // What it set it set by its own words, whatever a call before it left; the tool is the one it
        // loaded, and its change stopped the spindle (as the timeline has it after M6). A change it may
        // skip (`IF $P_TOOLNO==$P_TOOLP GOTOF …`: the tool is in the spindle already) leaves what it sets
        // and the spindle as they were on that way: unsure until the program sets them again.
        let mut whole = *t;
        for f in [
            field::FRAMES,
            field::UNKNOWN,
            field::MACHINE_COOLANT,
            field::S,
        ] {
            whole[f] = false;
        }
        whole[field::COOLANT] &= end.coolant == Some(9);
        whole[field::TOOL] = true;
        whole[field::DIRECTION] = true;
        if sub.changes_tool_always {
            self.mark_written(i + 1, whole);
        } else {
            // The way that skips the change: the state before the block, with the selected tool in the
            // spindle (why it skips).
            let mut skipped = entry.clone();
            skipped.tool = self.state.tool.clone();
            self.merge(i, i + 1, &[skipped]);
            self.mark_written(i + 1, field::only(&[field::TOOL]));
        }
        if t[field::FRAMES] {
            self.merges.push((i, i + 1, field::only(&[field::FRAMES])));
        }
    }

    /// After a subprogram at block `i` that is no tool change: the fields it sets whose value at its end
    /// is sure (see [`CalleeEffect::sure_at_end`]) hold that value, set by its own words whatever the
    /// caller's state; the others it sets were made unsure at the call.
    pub(super) fn after_call_end(&mut self, i: usize, sub: &CalleeEffect, cuts: bool) {
        let sure = sub.sure_at_end();
        let before = self.state.clone();
        self.take_end(&sub.end, &sure);
        self.note_changes(i, &before);
        self.mark_written(i + 1, sure);
        // Where it moved, the tool stands where it left it: clear of the part only where a rapid rose in Z
        // after its last cut (or it cut nothing and the tool was clear before), the height the fold holds
        // no longer the tool's.
        if sub.moves {
            let end = sub.end_standing;
            self.clear = end.clear && (cuts || self.clear);
            // A milling or turning cycle it ran last leaves the tool where no rule says, as in this unit.
            self.cycle_position |= end.after_cycle;
            self.lowered = !end.retracted;
            self.last_was_z_retract = end.retracted;
            self.contour = end.contour;
            self.position_doubt = true;
        }
    }

    /// The modal fields `fields` (of those a gate gives back) take the values `end` left, with whether an
    /// expression set the feed or the cutting edge.
    fn take_end(&mut self, end: &Modal, fields: &[bool; field::COUNT]) {
        let s = &mut self.state;
        macro_rules! take {
            ($($f:ident => $name:ident),*) => {
                $(if fields[field::$f] {
                    s.$name = end.$name;
                })*
            };
        }
        take!(D => d, FEED => feed, MOTION => motion, ABSOLUTE => absolute, FEED_MODE => feed_mode,
            PLANE => plane, PATH_MODE => path_mode, COMP => comp, OFFSET => offset,
            DIAMETER => diameter, UNITS => units);
        for (f, bit) in [(field::FEED, unknown::FEED), (field::D, unknown::D)] {
            if fields[f] {
                s.unknown = (s.unknown & !bit) | (end.unknown & bit);
            }
        }
        if fields[field::FEED_MODE] {
            self.per_rev = end.feed_mode == Some(95);
        }
    }

    /// The place of the unit's `PROC` parameter `variable`, where the unit has not assigned it.
    pub(super) fn parameter(&self, variable: &Option<String>) -> Option<usize> {
        let v = variable.as_ref()?;
        self.params.iter().position(|p| p == v)
    }

    /// The literal a call passes in the place of the parameter a subprogram sets a field by.
    pub(super) fn passed(by: ByExpression, args: &[CallArg]) -> Option<Arc<str>> {
        let ByExpression::Parameter(k) = by else {
            return None;
        };
        match args.get(k)? {
            CallArg::Literal(value) => Some(value.clone()),
            _ => None,
        }
    }

    /// After a call of `sub` with `args`: a cutting edge its last `D=` set from a parameter is the one
    /// the call passes.
    pub(super) fn bind_edge(&mut self, sub: &CalleeEffect, args: &[CallArg]) {
        let last_by_expression = sub.end.unknown & unknown::D != 0 && !sub.end_unsure[field::D];
        let passed = Self::passed(sub.sets_d, args).and_then(|d| d.parse::<u32>().ok());
        if let (true, Some(d)) = (last_by_expression, passed) {
            self.state.d = Some(d);
            self.state.unknown &= !unknown::D;
        }
    }

    /// Block `i` changed the fields in which the state differs from `before`.
    fn note_changes(&mut self, i: usize, before: &Modal) {
        for (f, differs) in field::differ(before, &self.state).into_iter().enumerate() {
            if differs {
                self.changed[f] = i + 1;
            }
        }
    }

    /// Notes the fields block words set, for what the unit does to a caller's state (not the position,
    /// which a gate reads from the control); returns them. A field written sets it even to the value it
    /// had: after a jump, a loop or a call the state is then sure again. With `no_speed` the block's S is
    /// no speed (a dwell's revolutions, a speed limit).
    pub(super) fn touch(&mut self, s: &Scan, dwell: bool, no_speed: bool) -> [bool; field::COUNT] {
        let mut set = [false; field::COUNT];
        let t = &mut set;
        for g in s.g.iter() {
            let f = match g {
                0..=3 => field::MOTION,
                g if is_thread(g) => field::MOTION,
                90 | 91 => field::ABSOLUTE,
                93..=95 => field::FEED_MODE,
                96 | 97 => field::S,
                17..=19 => field::PLANE,
                40..=42 => field::COMP,
                60 | 64 | 641..=645 => field::PATH_MODE,
                70 | 71 | 700 | 710 => field::UNITS,
                _ => continue,
            };
            t[f] = true;
        }
        // Rigid tapping takes the spindle into position control.
        t[field::DIRECTION] |= s.g.iter().any(|g| matches!(g, 331 | 332));
        let change_m = self.profile.probe.tool_change_m;
        for m in s.m.iter() {
            t[field::MACHINE_COOLANT] |= self.profile.coolant.follows(m);
            let f = match m {
                3..=5 | POSITIONED | 70 => field::DIRECTION,
                m if m == change_m => field::TOOL,
                7..=9 => field::COOLANT,
                _ => continue,
            };
            t[f] = true;
        }
        // A value an expression sets is set all the same (`F=R1`): a caller's value no longer holds.
        let by_expression = |bit| s.unknown & bit != 0;
        if by_expression(unknown::TOOL) {
            let by = self.t.as_callee.selects;
            self.t.as_callee.selects = by.and(self.parameter(&s.tool_variable));
        }
        if by_expression(unknown::D) {
            let by = self.t.as_callee.sets_d;
            self.t.as_callee.sets_d = by.and(self.parameter(&s.d_variable));
        }
        if !s.params.is_empty() {
            self.params.clone_from(&s.params);
        }
        for (name, _) in &s.var_set {
            for p in self
                .params
                .iter_mut()
                .filter(|p| p.eq_ignore_ascii_case(name))
            {
                p.clear();
            }
        }
        t[field::FEED] |= (s.mv.f.is_some() || by_expression(unknown::FEED)) && !dwell;
        t[field::S] |=
            ((s.s.is_some() || by_expression(unknown::S)) && !no_speed) || s.lims.is_some();
        t[field::D] |= s.d.is_some() || by_expression(unknown::D);
        // A tool an expression selects (`T=_TNR` in a tool-change cycle) is what the cycle's caller asked
        // for: the caller learns it from the unknown bit its end state carries.
        t[field::SELECTED] |= s.tool.is_some();
        t[field::FRAMES] |=
            s.frame_ops != 0 || s.rotary_away | s.rotary_home != 0 || s.tool_carrier.is_some();
        t[field::OFFSET] |= s
            .offsets
            .iter()
            .any(|g| matches!(g, 500 | 54..=57 | 505..=599));
        t[field::DIAMETER] |= s.diameter.is_some();
        t[field::UNKNOWN] |= s.unknown != 0
            || s.sum_offset.is_some()
            || s.rounding.is_some()
            || s.tool_offset_on | s.tool_offset_off != 0;
        for (mine, now) in self.touched.iter_mut().zip(set) {
            *mine |= now;
        }
        set
    }

    /// The spindle words of a subprogram called at block `i` and run `runs` times, applied to this
    /// program's spindle as they come: the speeds follow, and the state after the call is the one it left.
    /// The program's prediction holds one speed from gate to gate and the subprogram has no gates: a gate
    /// before the call takes the call's time-weighted mean speed, the block after it the speed it left.
    fn replay_spindle(&mut self, i: usize, sub: &Timeline, runs: f64, args: &[CallArg]) {
        let (at, rpm_before, state_before) = (self.time(), self.rpm, self.state.clone());
        let first_change = self.t.speeds.len();
        // A speed the subprogram takes from its parameter is the number the call passes there; without
        // one the prediction runs on with the speed before it, as for any speed it cannot evaluate.
        let passed = |k: usize| {
            Self::passed(ByExpression::Parameter(k), args)?
                .parse::<f64>()
                .ok()
        };
        let words: Vec<SpindleWord> = sub
            .spindle_words
            .iter()
            .map(|w| SpindleWord {
                s: w.s.or_else(|| passed(w.s_parameter?)),
                ..*w
            })
            .collect();
        if words
            .iter()
            .any(|w| w.s.is_none() && w.s_parameter.is_some())
        {
            self.t.unknown_speed_lines.push(i + 1);
        }
        // A bound on the speed changes one call adds, for absurd repeat counts.
        let most = 1_000_000 / words.len() as u64;
        for run in 0..(runs as u64).min(most) {
            let offset = at + run as f64 * sub.total_min;
            for w in &words {
                if let Some(s) = w.s {
                    self.state.s = s;
                }
                if let Some(d) = w.direction {
                    self.state.direction = d;
                    self.spindle_set_at(i);
                }
                self.t.spindle_words.push(SpindleWord {
                    at_min: offset + w.at_min,
                    s_parameter: None,
                    ..*w
                });
                let rpm = self.state.rpm();
                if rpm != self.rpm {
                    self.rpm = rpm;
                    self.t.speeds.push((offset + w.at_min, rpm));
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

    /// What a drilling or machining cycle, or a hole pattern running one under `MCALL`, may leave
    /// otherwise than the program had it before the call (see [`drilling_cycle_leaves`] and
    /// [`machining_cycle_leaves`]); `None` for any other call.
    fn cycle_leaves(&self, name: &str) -> Option<[bool; field::COUNT]> {
        let runs = self.runs(name);
        if is_hole_pattern(runs) {
            // With no modal call the pattern only positions the tool.
            return Some([false; field::COUNT]);
        }
        drilling_cycle_leaves(runs).or_else(|| machining_cycle_leaves(runs))
    }

    /// What a call of `name` runs: a hole pattern under `MCALL` runs the modal call at every hole, and
    /// leaves what that leaves (the program's own subprogram there may leave G1, its feed and speed: red
    /// team 3, R1); anything else, itself.
    fn runs<'a>(&'a self, name: &'a str) -> &'a str {
        match &self.modal_call {
            Some((modal, _)) if is_hole_pattern(name) => modal,
            _ => name,
        }
    }

    /// After a block that moves, the cycle an `MCALL` made modal runs.
    #[inline]
    pub(super) fn modal_call_after(&mut self, i: usize, mv: &Move) {
        if mv.axes.iter().any(Option::is_some)
            && let Some((name, shown)) = self.modal_call.take()
        {
            if self.call(i, &name, &shown, None, &[]).is_some() {
                self.bad_declaration(
                    i,
                    format!("{shown}: a tool change made modal runs after every move; driftloop does not follow it"),
                );
            }
            self.modal_call = Some((name, shown));
        }
    }
}

/// The Siemens hole patterns (a row, a circle, a grid, a frame), which run the modal call at each hole.
fn is_hole_pattern(name: &str) -> bool {
    matches!(name, "HOLES1" | "HOLES2" | "CYCLE801" | "CYCLE802")
}

/// The fields a Siemens drilling cycle may leave otherwise than the program had them before the call.
/// The cycles are declared `SAVE`: their G codes and programmable frame come back, and they change no
/// tool, offset or coolant; what they program themselves stays. CYCLE84 and CYCLE840 end with the spindle
/// turning as their SDAC says (CYCLE84 at its own speeds SST/SST1, tapping under G331/G332), CYCLE86
/// starts it again in SDIR after its oriented stop, CYCLE87 and CYCLE88 stop it (M5) for the operator;
/// CYCLE840 taps at a feed it computes from the speed and pitch, CYCLE85 bores and retracts at its own
/// FFR and RFF. CYCLE83's feed factor FRF holds for the first infeed only: it drills on and ends at the
/// program's feed. Places after the others measure as after any block (QA round 14, F8).
fn drilling_cycle_leaves(name: &str) -> Option<[bool; field::COUNT]> {
    let fields: &[usize] = match name {
        "CYCLE81" | "CYCLE82" | "CYCLE83" | "CYCLE89" => &[],
        "CYCLE85" => &[field::FEED],
        "CYCLE84" | "CYCLE840" => &[field::S, field::DIRECTION, field::FEED],
        "CYCLE86" | "CYCLE87" | "CYCLE88" => &[field::S, field::DIRECTION],
        _ => return None,
    };
    Some(field::only(fields))
}

/// The fields a Siemens milling or turning cycle may leave otherwise than the program had them before
/// the call, for the cycles whose end state the manuals establish; `None` for the others, after which no
/// place measures until the next tool change (the old rule).
///
/// Like the drilling cycles they are declared `SAVE` (function manual K2, "Subroutine return with
/// SAVE": the G codes — motion, plane, G90/G91, G94/G95/G96, G40/G41, G60/G64, DIAMON — and the
/// programmable frame come back), and they cut with the tool and edge in force (a call without an
/// active tool offset stops with alarm 61000): no tool, edge, offset or coolant of their own. What they
/// program themselves stays:
/// - every one programs its own feeds (POCKET3/POCKET4 `_FFP1`/`_FFD`, CYCLE71 `_FFP1`/`_FDP`,
///   CYCLE77 `_FFP1`/`_FFD`, CYCLE95 `FF1`…`FF3`, the Operate cycles' `F` "in the unit programmed
///   before the call"): the feed;
/// - POCKET1, POCKET2, SLOT1 and SLOT2 also finish at their own speed `SSF`: the feed and the speed;
/// - those whose parameter list was not read (CYCLE61, CYCLE72, CYCLE76, CYCLE79, CYCLE899, LONGHOLE,
///   engraving CYCLE60, thread milling CYCLE70/CYCLE90), the grooves and undercuts (CYCLE93, CYCLE94,
///   CYCLE96, CYCLE930, CYCLE940), the stock removal CYCLE951 (its ShopTurn form carries its own speed
///   `S`/`V`) and the thread cutting under G33 (CYCLE97, CYCLE98, with the spindle the axes follow):
///   the feed, the speed and the direction, as after a tap.
///
/// Left out, so conservative: the contour pocket and predrilling CYCLE63/CYCLE64 and the contour turning
/// CYCLE950/CYCLE952, which run a program they generate from the contours (programming guide cycles
/// 11.02, CYCLE950; operating manual turning 06/2019, CYCLE952 "PRG"), and every cycle not named here.
/// The position after them is no rule's: [`Builder::call`] takes the tool as standing in the part until
/// a rapid rises or the tool is changed, except at the program's own tool change, whose macro leaves
/// along the tool axis from there as a gate does (docs/safety.md, "What a machining cycle leaves").
fn machining_cycle_leaves(name: &str) -> Option<[bool; field::COUNT]> {
    let fields: &[usize] = match name {
        "POCKET3" | "POCKET4" | "CYCLE71" | "CYCLE77" | "CYCLE95" => &[field::FEED],
        "POCKET1" | "POCKET2" | "SLOT1" | "SLOT2" => &[field::FEED, field::S],
        "CYCLE61" | "CYCLE72" | "CYCLE76" | "CYCLE79" | "CYCLE899" | "LONGHOLE" | "CYCLE60"
        | "CYCLE70" | "CYCLE90" | "CYCLE93" | "CYCLE94" | "CYCLE96" | "CYCLE930" | "CYCLE940"
        | "CYCLE951" | "CYCLE97" | "CYCLE98" => &[field::FEED, field::S, field::DIRECTION],
        _ => return None,
    };
    Some(field::only(fields))
}

/// What a Siemens machining cycle kept on the old rule (CYCLE63, CYCLE64, CYCLE950, CYCLE952, CYCLE99,
/// any cycle not named in [`machining_cycle_leaves`]) leaves past the next tool change: its feed, speed
/// and direction, which are no G codes its `SAVE` brings back. No place measures after it until the next
/// tool change; the gate at that change, and any after it, gave back the feed and speed from before the
/// cycle where the program had not written them since (red team 5). `None` for any other call.
fn old_rule_cycle_leaves(name: &str) -> Option<[bool; field::COUNT]> {
    let upper = name.to_ascii_uppercase();
    (is_siemens_cycle(&upper) && !cuts_nothing(&upper) && !is_hole_pattern(&upper))
        .then(|| field::only(&[field::FEED, field::S, field::DIRECTION]))
}

/// Cycles after which the modal state is still known: the swivel (CYCLE800, whose frames the timeline
/// follows, see `frames`), the high-speed settings (CYCLE832, see `call`), and the blank (WORKPIECE) and
/// contour (CYCLE62) descriptions of ShopMill/ShopTurn programs, which move nothing and set nothing modal.
fn leaves_state_known(name: &str) -> bool {
    name == "CYCLE800" || moves_nothing(name)
}

/// Cycles that move no axis: the high-speed settings and the blank and contour descriptions.
pub(super) fn moves_nothing(name: &str) -> bool {
    matches!(name, "CYCLE832" | "WORKPIECE" | "CYCLE62")
}

/// A Siemens standard cycle (`CYCLE81` … `CYCLE998`, the ShopMill pocket, slot and hole-pattern cycles),
/// declared with `SAVE`.
fn is_siemens_cycle(name: &str) -> bool {
    crate::views::is_numbered_cycle(name)
        || matches!(
            name,
            "POCKET1"
                | "POCKET2"
                | "POCKET3"
                | "POCKET4"
                | "SLOT1"
                | "SLOT2"
                | "LONGHOLE"
                | "HOLES1"
                | "HOLES2"
        )
}

/// Siemens cycles that cut nothing: those above, and the measuring cycles of workpieces and tools
/// (CYCLE961 … CYCLE998), which move the probe and leave the state unknown.
fn cuts_nothing(name: &str) -> bool {
    leaves_state_known(name)
        || matches!(
            name,
            "CYCLE961"
                | "CYCLE971"
                | "CYCLE973"
                | "CYCLE974"
                | "CYCLE976"
                | "CYCLE977"
                | "CYCLE978"
                | "CYCLE979"
                | "CYCLE982"
                | "CYCLE994"
                | "CYCLE996"
                | "CYCLE997"
                | "CYCLE998"
        )
}
