//! Warm start (`[warm_start]`): the spindle mode states go into a store of retentive R-parameters at every
//! gate and at the end, stamped with the control's clock; the next job's initial block reads them back,
//! decays them over the time since (the spindle stands between jobs: x ← x·e^(−Δt/τ)) and starts from there.
//! The prediction counts from the zero, so the warm states' sum at the zero is taken off it.
//!
//! The stamp is a day number (from `$A_YEAR`, `$A_MONTH`, `$A_DAY`, so month and year ends count right) and
//! the seconds of the day. A store without the marker, of another model (fingerprint), stamped in the future
//! or older than `max_age_tau` times the longest time constant is ignored: a cold start.

use super::{Emitter, r};
use crate::omm::nc::number;
use crate::omm::warm::{HEADER, MARKER};

/// Scratch and per-axis registers of the warm start (in the profile's range).
#[derive(Debug, Clone)]
pub(super) struct WarmRegisters {
    day: u32,
    second: u32,
    elapsed: u32,
    /// Per measured axis: the prediction at the zero (the warm states' sum; 0 after a cold start).
    at_zero: Vec<u32>,
}

impl WarmRegisters {
    pub(super) fn count(axes: usize) -> usize {
        3 + axes
    }

    pub(super) fn take(axes: usize, next: &mut impl FnMut() -> u32) -> WarmRegisters {
        WarmRegisters {
            day: next(),
            second: next(),
            elapsed: next(),
            at_zero: (0..axes).map(|_| next()).collect(),
        }
    }

    pub(super) fn all(&self) -> impl Iterator<Item = u32> + '_ {
        [self.day, self.second, self.elapsed]
            .into_iter()
            .chain(self.at_zero.iter().copied())
    }
}

impl Emitter<'_> {
    /// `-Rp0` for axis `k`: the prediction counts from the zero.
    pub(super) fn minus_at_zero(&self, k: usize) -> Option<String> {
        self.regs
            .warm
            .as_ref()
            .map(|w| format!("-{}", r(w.at_zero[k])))
    }

    /// The store's registers in order after the header: every spindle mode state of every axis.
    fn stored_states(&self) -> Vec<(u32, u32, f64)> {
        let first = self.profile.warm_start.as_ref().map_or(0, |w| w.r_first) + HEADER;
        let mut n = first;
        let mut v = Vec::new();
        for k in 0..self.axes.len() {
            for (x, tau) in self.reg(k).x.iter().zip(self.axes[k].predictor.taus()) {
                v.push((n, *x, *tau));
                n += 1;
            }
        }
        v
    }

    /// The control's clock as a day number and the seconds of the day (after a STOPRE).
    fn read_clock(&self, w: &WarmRegisters) -> Vec<String> {
        let (day, second) = (r(w.day), r(w.second));
        vec![
            format!("{day}=$A_YEAR"),
            "IF $A_MONTH<=2".into(),
            format!("{day}={day}-1"),
            "ENDIF".into(),
            format!(
                "{day}=365*{day}+({day} DIV 4)-({day} DIV 100)+({day} DIV 400)+((153*(($A_MONTH+9) MOD 12)+2) DIV 5)+$A_DAY"
            ),
            format!("{second}=3600*$A_HOUR+60*$A_MINUTE+$A_SECOND"),
        ]
    }

    /// In the initial block, after the states were set to 0: the stored states, decayed, when the store is
    /// valid; then the prediction at the zero.
    pub(super) fn warm_load(&self) -> Vec<String> {
        let (Some(w), Some(settings)) = (&self.regs.warm, &self.profile.warm_start) else {
            return Vec::new();
        };
        let s = settings.r_first;
        let longest = self
            .axes
            .iter()
            .flat_map(|a| a.predictor.taus().iter().copied())
            .fold(0.0, f64::max);
        let elapsed = r(w.elapsed);
        let mut v = vec![
            "; driftloop warm start: the states of the last job, decayed over the time since"
                .into(),
        ];
        v.extend(self.read_clock(w));
        v.push(format!(
            "IF (R{s}=={MARKER}) AND (R{}=={})",
            s + 1,
            self.fingerprint
        ));
        v.push(format!(
            "{elapsed}=({}-R{})*1440+({}-R{})/60",
            r(w.day),
            s + 2,
            r(w.second),
            s + 3
        ));
        v.push(format!(
            "IF ({elapsed}>=0) AND ({elapsed}<={})",
            number(settings.max_age_tau * longest)
        ));
        for (stored, x, tau) in self.stored_states() {
            v.push(format!(
                "{}=R{stored}*EXP(-{elapsed}/{})",
                r(x),
                number(tau)
            ));
        }
        v.push("ENDIF".into());
        v.push("ENDIF".into());
        for k in 0..self.axes.len() {
            let sum: Vec<String> = self.reg(k).x.iter().map(|x| r(*x)).collect();
            let sum = if sum.is_empty() {
                "0".to_string()
            } else {
                sum.join("+")
            };
            v.push(format!("{}={sum}", r(w.at_zero[k])));
        }
        v
    }

    /// The states as they are now into the store, with the clock: the marker goes last, so a store cut
    /// short by a RESET is no valid one.
    pub(super) fn warm_store(&self) -> Vec<String> {
        let (Some(w), Some(settings)) = (&self.regs.warm, &self.profile.warm_start) else {
            return Vec::new();
        };
        let s = settings.r_first;
        let mut v = vec![format!("R{s}=0")];
        v.extend(self.read_clock(w));
        v.push(format!("R{}={}", s + 2, r(w.day)));
        v.push(format!("R{}={}", s + 3, r(w.second)));
        for (stored, x, _) in self.stored_states() {
            v.push(format!("R{stored}={}", r(x)));
        }
        v.push(format!("R{}={}", s + 1, self.fingerprint));
        v.push(format!("R{s}={MARKER}"));
        v
    }

    /// How many R-parameters the store takes from `warm_start.r_first` on.
    pub fn store_len(&self) -> u32 {
        HEADER + self.stored_states().len() as u32
    }
}
