//! Whether a feed a site cannot know matters there: after a loop that may not run, or a subprogram that
//! sets it in an IF, the feed at a site is one of several, and a gate cannot give it back. Where the
//! program sets a feed before its next feed move, the one in force at the site is never used: the gate
//! need not give it back, and the site is no worse than one whose state is known.

use super::Builder;
use crate::omm::timeline::modal::{field, is_thread};
use crate::omm::timeline::moves::Run;
use crate::omm::timeline::read::{Move, Scan};
use crate::syntax::BlockKind;

/// What a block does with the feed in force before it, in the order the control runs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum FeedUse {
    /// It sets a feed (for its own move too).
    Sets,
    /// A feed move without F: the feed in force is used.
    Reads,
    /// Control flow (a loop, IF, label, jump, call or return): what runs next is not the next block.
    Ends,
    Neither,
}

impl Builder<'_> {
    /// Notes how block `i` (its words `s` already folded into the state) uses the feed; `set` is what
    /// [`Builder::touch`] found it sets.
    pub(super) fn note_feed_use(
        &mut self,
        i: usize,
        s: &Scan,
        kind: BlockKind,
        set: &[bool; field::COUNT],
    ) {
        let moves = s.mv.axes.iter().any(Option::is_some) || s.other_axes;
        let ends = kind != BlockKind::Plain
            || s.label.is_some()
            || self.jumps.contains_key(&i)
            || s.call.is_some()
            || s.leaves;
        self.note_use(i, set[field::FEED], ends, moves);
    }

    /// Notes how a block that only moves uses the feed (its motion already in the state).
    pub(super) fn note_move_feed_use(&mut self, i: usize, mv: &Move) {
        let moves = mv.axes.iter().any(Option::is_some);
        self.note_use(i, mv.f.is_some(), false, moves);
    }

    /// Block `i` sets a feed, ends the straight run of blocks, or moves (at a feed if the motion in force
    /// is one). A modal call ends it too: the cycle it runs after a move drills at the feed in force.
    fn note_use(&mut self, i: usize, sets: bool, ends: bool, moves: bool) {
        let use_ = if sets {
            FeedUse::Sets
        } else if ends || self.modal_call.is_some() {
            FeedUse::Ends
        } else if moves && self.feeds() {
            FeedUse::Reads
        } else {
            FeedUse::Neither
        };
        self.feed_uses.push((i, use_));
    }

    /// Notes how a run of moves folded at once uses the feed, at its first block (no site lies inside).
    pub(super) fn note_run_feed_use(&mut self, run: &Run) {
        let use_ = match run.feed_read_first {
            Some(true) => FeedUse::Reads,
            Some(false) => FeedUse::Sets,
            None if run.feed.first.is_some() => FeedUse::Sets,
            None => FeedUse::Neither,
        };
        self.feed_uses.push((run.first, use_));
    }

    /// The modal motion moves at a feed (G1, G2, G3, a thread).
    fn feeds(&self) -> bool {
        matches!(self.state.motion, 1..=3) || is_thread(self.state.motion)
    }

    /// Whether the program sets a feed from block `b` on before any feed move reads one, with no control
    /// flow between.
    pub(super) fn feed_unused_from(&self, b: usize) -> bool {
        let from = self.feed_uses.partition_point(|(i, _)| *i < b);
        for (_, use_) in &self.feed_uses[from..] {
            match use_ {
                FeedUse::Sets => return true,
                FeedUse::Reads | FeedUse::Ends => return false,
                FeedUse::Neither => {}
            }
        }
        false
    }

    /// At site `b` the fields `unsure` are not known: true where that is only the feed and the program
    /// does not use it (the site is noted as one whose gate gives no feed back).
    pub(super) fn only_an_unused_feed(&mut self, b: usize, unsure: &[bool; field::COUNT]) -> bool {
        let only_feed = (0..field::COUNT).all(|f| unsure[f] == (f == field::FEED));
        let unused = only_feed && self.feed_unused_from(b);
        if unused {
            self.feed_not_given.insert(b);
        }
        unused
    }
}
