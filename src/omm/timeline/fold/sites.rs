//! Where gates may go: the sites the fold notes as it reads (speed changes, stops, dressing, the start
//! after the setup), the pass starts, and at the end the passes and the sites in block order.

use std::sync::Arc;

use crate::omm::profile::{ProbeKind, ToolChange};
use crate::omm::timeline::modal::{Modal, field, frame};
use crate::omm::timeline::read::Scan;
use crate::omm::timeline::record::{Pass, Site, SiteKind};

use super::{BeforeCall, Builder};

impl Builder<'_> {
    pub(super) fn mark(&self, i: usize, tool_change: bool, start: f64, before: &Modal) -> PassMark {
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

    /// A gate site where the program's prediction takes another speed (`rpm` from block `i` on); it
    /// replaces one a call before this block asked for.
    pub(super) fn speed_site(&mut self, i: usize, time_min: f64, before: Modal, rpm: f64) {
        if self
            .t
            .sites
            .last()
            .is_some_and(|l| l.block == i && l.kind == SiteKind::SpeedChange)
        {
            self.t.sites.pop();
        }
        if self.after_call {
            self.varies.insert(i);
        }
        let idle = self.idle_since_cut(time_min);
        self.t.sites.push(Site::new(
            i,
            SiteKind::SpeedChange,
            time_min,
            before,
            rpm,
            idle,
        ));
    }

    /// The speed-change site a subprogram's speed asks for, at the first block after its call.
    pub(super) fn speed_site_after_call(&mut self, i: usize) {
        if self.speed_site_after.is_some_and(|call| call < i) {
            self.speed_site_after = None;
            self.note_site(i);
            self.speed_site(i, self.time(), self.state.clone(), self.rpm);
        }
    }

    /// The site a stop or dressing call before block `i` asked for.
    pub(super) fn safe_site_after(&mut self, i: usize) {
        if let Some((_, kind)) = self.safe_after.take_if(|(at, _)| *at < i) {
            self.note_site(i);
            let time = self.time();
            let site = Site::new(
                i,
                kind,
                time,
                self.state.clone(),
                self.rpm,
                self.idle_since_cut(time),
            );
            self.t.sites.push(site);
        }
    }

    /// Keeps block `i` as the start site while the setup is over and nothing has cut yet; a later setup
    /// block (work offset, frame) makes the block after it the candidate instead. Not inside an IF: the
    /// zero must be measured on every run.
    pub(super) fn start_site(
        &mut self,
        i: usize,
        time_min: f64,
        inside_if: bool,
        entry: Option<BeforeCall>,
    ) {
        // A call that cuts is this block's first cut only once the gate before it has run.
        if self.t.first_cut.is_some_and(|cut| cut < i)
            || !(self.header_done && self.preamble_done)
            || inside_if
        {
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
        if !self.merges.is_empty() || !self.call_unsure.is_empty() {
            self.site_changes
                .push((i, self.changed, self.written, self.written_in));
        }
        self.start = Some(Site::new(
            i,
            SiteKind::Start,
            time_min,
            BeforeCall::state(entry, &self.state),
            self.rpm,
            self.idle_since_cut(time_min),
        ));
    }

    /// A tool setter measures its zero with the tool that cuts, under the D number it cuts with: a tool
    /// load before the first cut, or a D word after a tool was named, makes the block after it the start
    /// site's candidate. (A program that names no tool cuts with the D of the control's reset state.)
    pub(super) fn zero_after_tool_setup(&mut self, s: &Scan, tool_change: bool) {
        let loads =
            tool_change || (self.profile.probe.tool_change == ToolChange::T && s.tool.is_some());
        let tool_named = self.state.tool.is_some() || self.state.selected.is_some();
        if self.profile.probe.kind == ProbeKind::ToolSetter
            && self.t.first_cut.is_none()
            && (loads || (s.d.is_some() && tool_named))
        {
            self.start = None;
        }
    }

    /// The value of a variable or R-parameter (`_A_HOME`, `R5`, upper case) where the fold knows it: last
    /// assigned a literal.
    pub(super) fn literal_value(&self, name: &str) -> Option<f64> {
        match name.strip_prefix('R').and_then(|n| n.parse::<u32>().ok()) {
            Some(n) => self.r_values.get(&n).copied(),
            None => self.var_values.get(name).copied(),
        }
    }

    /// The block with its spindle speed taken from a variable or R-parameter last assigned a literal
    /// (`R1=4000` … `S=R1`), for the prediction. It stays a speed set by an expression: the fold reads the
    /// program in order, and on another way (an IF's other branch) the variable may hold another value, so
    /// a gate gives back no speed there. `None` where the block's speed is no such name, or its value is
    /// not known.
    pub(super) fn speed_from_variable(&self, s: &Scan) -> Option<Scan> {
        let v = self.literal_value(s.speed_var.as_deref()?)?;
        let mut known = s.clone();
        known.s = Some(v);
        Some(known)
    }

    /// Rotary axes the block positions: away from 0 they turn the part ([`frame::ROTARY`]); a variable or
    /// R-parameter last assigned a literal counts as that literal, any other as away.
    pub(super) fn rotary_axes(&mut self, s: &Scan) {
        let (mut away, mut home) = (s.rotary_away, s.rotary_home);
        for (bit, name) in &s.rotary_vars {
            if self.literal_value(name) == Some(0.0) {
                home |= bit;
            } else {
                away |= bit;
            }
        }
        self.rotary_sent = (self.rotary_sent & !home) | away;
        let f = &mut self.state.frames;
        *f = (*f & !(home << frame::ROTARY_SHIFT)) | (away << frame::ROTARY_SHIFT);
        // An orientation turns the rotary axes the kinematics choose, as a swivel does, and TRAFOOF leaves
        // them where they stand.
        if s.orients {
            *f |= frame::ROTARY;
            self.swivel_turned = true;
        }
        // A five-axis post brings a swivel's two axes home in one block (`G0 A0 C0`, `G0 B0 C0`); one
        // axis alone may leave the other turned.
        if self.swivel_turned && home.count_ones() >= 2 {
            self.swivel_turned = false;
            *f = (*f & !frame::ROTARY) | (self.rotary_sent << frame::ROTARY_SHIFT);
        }
    }

    /// The speed from the start site's block on.
    pub(super) fn start_site_speed(&mut self, i: usize) {
        if let Some(site) = self.start.as_mut().filter(|s| s.block == i) {
            site.rpm_after = self.rpm;
        }
    }

    /// Notes a block where a site or pass mark arises, with the fields' last changes.
    pub(super) fn note_site(&mut self, i: usize) {
        if !self.clear {
            self.in_part.insert(i);
        }
        if self.cycle_position {
            self.in_part_after_cycle.insert(i);
        }
        if self.lowered {
            self.lowered_at.insert(i);
        }
        if self.rounds_into {
            self.rounded_into.insert(i);
        }
        if self.contour {
            self.contour_sites.push(i);
        }
        if !self.open_loops.is_empty()
            || !self.label_times.is_empty()
            || !self.merges.is_empty()
            || !self.call_unsure.is_empty()
        {
            self.site_changes
                .push((i, self.changed, self.written, self.written_in));
        }
        // What a subprogram or cycle left (feed, motion, …) is not known until the next tool change.
        if self.after_call {
            self.varies.insert(i);
        }
    }

    /// The passes from the pass marks (ending at `total`, min), their start sites with the others, one
    /// site per block in block order, each with its pass.
    pub(super) fn place_passes_and_sites(&mut self, total: f64) {
        // Without M6 in the program the T word changes the tool.
        let mut starts = std::mem::take(&mut self.pass_marks);
        let t_loads = self.profile.probe.tool_change == ToolChange::T;
        if !self.m6_seen && self.profile.passes.tool_change {
            // On a machine that changes tools with M6, a T alone only selects: no change follows it.
            let tool_marks = std::mem::take(&mut self.tool_marks);
            starts.extend(tool_marks.into_iter().map(|m| PassMark {
                tool_change: t_loads,
                ..m
            }));
        }
        starts.sort_by_key(|m| m.block);
        // A pass marked at a block whose T loads the tool (a turret) is still a tool change: the zero and the
        // tool setter's comparisons must not come before it.
        starts.dedup_by(|later, kept| {
            let same = later.block == kept.block;
            if same {
                kept.tool_change |= later.tool_change;
            }
            same
        });
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
            let kind = SiteKind::PassStart {
                tool_change: m.tool_change,
            };
            self.t.sites.push(Site {
                pass: k + 1,
                ..Site::new(m.block, kind, m.time, m.before, m.rpm, m.idle)
            });
        }
        // The start site only counts once it is known to come after the setup.
        if let Some(site) = self.start.take().filter(|s| s.block >= self.t.setup_end) {
            self.t.sites.push(site);
        }
        // Nothing goes into a table definition, one the program leaves open included.
        if let Some(open) = self.table_open.take() {
            self.tables.push((open, usize::MAX));
        }
        let tables = Spans::new(&self.tables);
        self.t.sites.retain(|s| !tables.contains(s.block));
        // One site per block: a pass start wins over a speed change or retract at the same block.
        self.t
            .sites
            .sort_by_key(|s| (s.block, !matches!(s.kind, SiteKind::PassStart { .. })));
        self.t.sites.dedup_by_key(|s| s.block);
        let mut pass = 0;
        let traverses = Spans::new(&self.t.frame_traverses);
        let conditional = Spans::new(&self.t.conditional);
        let spindle_probe = self.profile.probe.kind == ProbeKind::SpindleProbe
            && self.profile.probe.tool_change == ToolChange::M6;
        for site in &mut self.t.sites {
            let change_follows = matches!(site.kind, SiteKind::PassStart { tool_change: true });
            site.state_varies = self.varies.contains(&site.block)
                || (self.varies_but_spindle.contains(&site.block)
                    && !(spindle_probe && change_follows));
            if !site.state_varies && self.feed_not_given.contains(&site.block) {
                site.before.unset(field::FEED);
            }
            site.frame_traverse = traverses.contains(site.block);
            site.conditional = conditional.contains(site.block);
            // Where a milling or turning cycle left the tool is not known: no gate there, but at the
            // program's own tool change, whose macro retracts along the tool axis from that place too.
            site.in_part = self.in_part.contains(&site.block)
                || (self.in_part_after_cycle.contains(&site.block) && !change_follows);
            site.lowered = self.lowered_at.contains(&site.block);
            site.in_contour = self.in_contour.contains(&site.block);
            site.tangent_start = self.tangent_starts.contains(&site.block);
            site.rounded_into = self.rounded_into.contains(&site.block);
            // Without M6 in the program, T loads the tool at once.
            if t_loads {
                site.before.tool = site.before.selected.clone();
            }
            match site.kind {
                SiteKind::PassStart { .. } => pass = site.pass,
                _ => site.pass = pass,
            }
        }
    }
}

/// A block that may start a pass, with the state around it.
pub(super) struct PassMark {
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
    // The schedule is in time order: the speeds in force from `from` on start with the last one set at
    // or before it, found by bisection, so a pass costs its own speeds, not the whole program's (60 000
    // passes scanned 60 000 speeds each).
    let first = speeds.partition_point(|s| s.0 <= from).saturating_sub(1);
    let until = to.max(from + 1e-12);
    speeds[first..]
        .iter()
        .take_while(|s| s.0 < until)
        .fold(0.0, |max: f64, s| max.max(s.1))
}

/// Blocks in any of some ranges (start, end] (the start excluded: a gate there runs before it), kept as
/// their union, disjoint and in order, so a block is looked up by bisection.
struct Spans(Vec<(usize, usize)>);

impl Spans {
    fn new(ranges: &[(usize, usize)]) -> Spans {
        let mut sorted = ranges.to_vec();
        sorted.sort_unstable();
        let mut union: Vec<(usize, usize)> = Vec::with_capacity(sorted.len());
        for (start, end) in sorted {
            match union.last_mut() {
                Some(last) if start <= last.1 => last.1 = last.1.max(end),
                _ => union.push((start, end)),
            }
        }
        Spans(union)
    }

    fn contains(&self, block: usize) -> bool {
        let k = self.0.partition_point(|r| r.1 < block);
        self.0.get(k).is_some_and(|r| r.0 < block && block <= r.1)
    }
}

#[cfg(test)]
mod tests {
    use super::Spans;

    #[test]
    fn spans_hold_the_union_with_each_start_excluded() {
        let s = Spans::new(&[(10, 20), (3, 5), (12, 30), (30, 31), (40, 41)]);
        let inside: Vec<usize> = (0..45).filter(|&b| s.contains(b)).collect();
        let expected: Vec<usize> = (4..=5).chain(11..=31).chain([41]).collect();
        assert_eq!(inside, expected);
        assert!(!Spans::new(&[]).contains(0));
    }
}
