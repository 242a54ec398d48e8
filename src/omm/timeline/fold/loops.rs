//! How the fold counts loops: a FOR with bounds known before the program runs, a section repeat with its
//! count, any other loop once; the further runs are added to the time at the loop's end, and the sites in
//! a body that a later run reaches in another modal state are marked.

use crate::omm::timeline::modal::{Modal, field};
use crate::omm::timeline::read::{Bound, Count, Scan};
use crate::omm::timeline::record::{Loop, LoopKind};
use crate::syntax::BlockKind;

use super::Builder;

impl Builder<'_> {
    /// Label `label` at block `i`, whose first run took from `start` to now (min) from state `before`. A
    /// label defined again: a REPEAT after it searches backward and finds this one.
    pub(super) fn label_seen(&mut self, label: &str, i: usize, start: f64, before: Modal) {
        let end = self.time();
        let seen = Label {
            block: i,
            start,
            end,
            state: before,
            after: self.state.clone(),
        };
        self.label_times.insert(label.to_ascii_uppercase(), seen);
    }

    /// Loop statements: a loop opens after its statement; at its end (or at a section repeat statement)
    /// the further runs are added to the time.
    pub(super) fn loops(&mut self, i: usize, s: &Scan, kind: BlockKind, start: f64) {
        if s.r.contains(&None) {
            self.r_values.clear();
        }
        for &(n, v) in &s.r_set {
            match v {
                Some(v) => self.r_values.insert(n, v),
                None => self.r_values.remove(&n),
            };
        }
        for (name, v) in &s.var_set {
            match v {
                Some(v) => self.var_values.insert(name.clone(), *v),
                None => self.var_values.remove(name),
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
            // A WHILE, or a FOR not known to run, may skip its body: the program goes on in the state
            // before the loop or in the one its body left.
            let may_skip = match open.kind {
                LoopKind::While => true,
                LoopKind::For => !matches!(open.runs, Ok(n) if n >= 1),
                _ => false,
            };
            if may_skip {
                self.merge(i, i, std::slice::from_ref(&open.entry));
            }
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
                    // The program goes on after the statement in the state the section's last run left,
                    // which its first run shows only for the fields it sets: the sites after it are not
                    // sure of any field that differs, until the program sets it again.
                    if let Some(left) = &sec.left {
                        let differ = field::differ(left, &self.state);
                        if differ.contains(&true) {
                            self.merges.push((i, i, differ));
                        }
                    }
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
        let (last_block, end, left) = match labels.get(1) {
            _ if single => (first.block, first.end, Some(first.after.clone())),
            Some(end) => {
                let last = seen(end)?;
                if last.block < first.block {
                    return Err("the section's labels are in reverse order");
                }
                (last.block, last.end, Some(last.after.clone()))
            }
            None => (i.saturating_sub(1), start, None),
        };
        Ok(Section {
            body: (first.block, last_block),
            start: first.start,
            end,
            entry: first.state.clone(),
            left,
        })
    }

    /// Marks the sites of a body that a later run reaches in another modal state: a field in which the state
    /// at the repeat differs from `entry`, and which the body does not change before the site.
    fn mark_varying(&mut self, entry: &Modal, body: (usize, usize)) {
        let differ = field::differ(entry, &self.state);
        if !differ.contains(&true) {
            return;
        }
        let from = self.site_changes.partition_point(|(b, ..)| *b < body.0);
        for (b, changed, ..) in &self.site_changes[from..] {
            if *b > body.1 {
                break;
            }
            let set_before = |f: usize| changed[f] > body.0 && changed[f] - 1 < *b;
            if (0..field::COUNT).any(|f| differ[f] && !set_before(f)) {
                self.varies.insert(*b);
            }
        }
    }

    /// A jump at block `i` (after its words): forward, the state it leaves in meets the fall-through state
    /// at the target; backward, the blocks from the target to here run again in the state left here, as
    /// a loop body does.
    pub(super) fn jump_from(&mut self, i: usize) {
        let Some(targets) = self.jumps.get(&i).cloned() else {
            return;
        };
        for t in targets {
            if t > i {
                self.t.skips.push((i, t));
                self.merging.entry(t).or_default().push(self.state.clone());
            } else if let Some(entry) = self
                .label_times
                .values()
                .find(|l| l.block == t)
                .map(|l| l.state.clone())
            {
                self.mark_varying(&entry, (t, i));
            }
        }
    }

    /// Block `i`, before its words: a forward jump's target, where the fields in which the jumps' states
    /// differ from the fall-through state are noted.
    pub(super) fn jump_target(&mut self, i: usize) {
        if let Some(states) = self.merging.remove(&i) {
            for jumped in states {
                let differ = field::differ(&jumped, &self.state);
                if differ.contains(&true) {
                    self.merges.push((i, i, differ));
                }
            }
        }
    }

    /// The first block of the innermost stretch block `i` may not run in: an IF or a loop open at it, the
    /// block itself where the skip switch may leave it out, a forward jump passing over it.
    pub(super) fn conditional_region(&self, i: usize) -> Option<usize> {
        let jumped = self
            .t
            .skips
            .iter()
            .filter(|(from, to)| *from < i && i < *to);
        [
            self.open_ifs.last().map(|o| o.block),
            self.open_loops.last().map(|l| l.block),
            self.skippable,
            jumped.map(|(from, _)| *from).max(),
        ]
        .into_iter()
        .flatten()
        .max()
    }

    /// The sites after a label that a jump reaches in another state: a field in which the states differ and
    /// which the program has not set again since the label. (A site at the label's own block runs before
    /// the label, on the fall-through path only.)
    pub(super) fn mark_merges(&mut self) {
        for (t, set_from, differ) in std::mem::take(&mut self.merges) {
            let from = self.site_changes.partition_point(|(b, ..)| *b <= t);
            for k in from..self.site_changes.len() {
                let (b, changed, written, written_in) = self.site_changes[k];
                let set = field::set_as_seen_from(t, &changed, &written, &written_in);
                let unsure = field::not_set_since(&differ, set_from, &set);
                if !unsure.contains(&true) {
                    // Every differing field is set again: so it stays at every later site.
                    break;
                }
                if !self.only_an_unused_feed(b, &unsure) {
                    self.varies.insert(b);
                }
            }
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
}

/// A repeated section: its blocks, the start and end of its first run (min), the state it starts in and,
/// for a section that ends before the statement (REPEATB, `REPEAT a b`), the state its first run left.
struct Section {
    body: (usize, usize),
    start: f64,
    end: f64,
    entry: Modal,
    left: Option<Modal>,
}

/// A label seen: its block, the start and end of its first run (min) and the states before and after it.
pub(super) struct Label {
    block: usize,
    start: f64,
    end: f64,
    state: Modal,
    after: Modal,
}

/// A loop whose closing block has not come yet.
pub(super) struct OpenLoop {
    kind: LoopKind,
    block: usize,
    start_min: f64,
    runs: Result<u64, &'static str>,
    /// The state the first run starts in.
    entry: Modal,
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
