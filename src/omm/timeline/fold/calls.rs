//! What a call adds to the timeline: the called subprogram's time (as often as `P` says), its spindle
//! words replayed onto this program's spindle, and what it leaves untimed or uses; an `MCALL`'s cycle after
//! every block that moves.

use super::Builder;
use crate::omm::timeline::read::Move;
use crate::omm::timeline::record::Timeline;

impl Builder<'_> {
    /// A subprogram or cycle runs at block `i`, `repeats` times: an archive subprogram adds its time, any
    /// other call is listed as not timed (`shown` is how the list names it).
    pub(super) fn call(&mut self, i: usize, name: &str, shown: &str, repeats: Option<f64>) {
        // The high-speed settings cycle sets the path mode (G64x, compressor, tolerances): the path mode is
        // then the cycle's, which a gate leaves as it is.
        if name == "CYCLE832" {
            self.state.path_mode = None;
        }
        self.after_call |= !leaves_state_known(name);
        self.t.moves = true;
        if !self.called.contains(name) {
            self.called.insert(name.to_string());
        }
        // A subprogram from a folder is in another file: what it leaves untimed is listed at the call (its
        // own line numbers mean nothing in this program).
        match self.callees.timeline(name) {
            Some((sub, elsewhere)) => {
                // A subprogram that cuts: the reference measurement goes before it.
                if sub.first_cut.is_some() {
                    self.t.first_cut.get_or_insert(i);
                }
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
                if !sub.offset_selections.is_empty() {
                    self.t.offset_selections.push(i);
                }
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
            None => {
                // A cycle or subprogram driftloop cannot see into may cut (a drilling or pocket cycle):
                // the reference measurement goes before it. The swivel, settings and measuring cycles
                // do not cut.
                if !cuts_nothing(name) && !self.profile.cycle_call().starts_with(name) {
                    self.t.first_cut.get_or_insert(i);
                }
                self.t.untimed_calls.push((i + 1, shown.to_string()))
            }
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

    /// After a block that moves, the cycle an `MCALL` made modal runs.
    #[inline]
    pub(super) fn modal_call_after(&mut self, i: usize, mv: &Move) {
        if mv.axes.iter().any(Option::is_some)
            && let Some((name, shown)) = self.modal_call.take()
        {
            self.call(i, &name, &shown, None);
            self.modal_call = Some((name, shown));
        }
    }
}

/// Cycles after which the modal state is still known: the swivel (CYCLE800, whose frames the timeline
/// follows, see `frames`), the high-speed settings (CYCLE832, see `call`), and the blank (WORKPIECE) and
/// contour (CYCLE62) descriptions of ShopMill/ShopTurn programs, which move nothing and set nothing modal.
fn leaves_state_known(name: &str) -> bool {
    matches!(name, "CYCLE800" | "CYCLE832" | "WORKPIECE" | "CYCLE62")
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
