//! The profile's `[coolant]` section: machine M-codes that switch a coolant on and off beyond M7/M8/M9
//! (through-spindle coolant, air blast through the spindle). A gate that changes to the probe or travels to
//! a reference must switch them off first and give them back where the program resumes, so the timeline and
//! the dry run follow them as they follow M7 and M8.

use serde::{Deserialize, Serialize};

/// At most this many pairs: the state of each is one bit.
pub const MAX_PAIRS: usize = 8;

/// M-codes the control itself gives a meaning (stops, ends, spindle, tool change, M7/M8/M9, subprogram
/// end, spindle positioning, gear stages, spindle to axis mode), as against the machine's own PLC functions.
pub fn is_control_m(m: u32) -> bool {
    matches!(m, 0..=9 | 17 | 19 | 30 | 40..=45 | 70)
}

/// Why `m` cannot be a machine's tool-change M-code (MD22560): M6, or a code the control leaves to the
/// machine.
pub fn tool_change_m_fault(m: u32) -> Option<String> {
    (m != 6 && (is_control_m(m) || m > 99_999)).then(|| format!(
        "M{m} cannot be the tool change (M0 … M9 but M6, M17, M19, M30, M40 … M45 and M70 have their own meaning on the control; at most M99999)"
    ))
}

/// `[coolant]`: the machine's own coolant M-codes.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineCoolant {
    /// `[on, off]` pairs, as the machine's PLC reads them: `[[50, 51]]`.
    pub codes: Vec<[u32; 2]>,
    /// Whether M9 also switches these off on this machine (the PLC's choice; no default, as either guess
    /// is a hazard on the other kind of machine).
    pub m9_ends: bool,
}

impl MachineCoolant {
    pub fn is_default(&self) -> bool {
        self.codes.is_empty()
    }

    /// The pairs' state (bit k: pair k on) after the M-code `m` in state `on`.
    pub fn after(&self, on: u8, m: u32) -> u8 {
        if m == 9 && self.m9_ends {
            return 0;
        }
        self.codes
            .iter()
            .enumerate()
            .fold(on, |on, (k, [start, stop])| {
                if m == *start {
                    on | 1 << k
                } else if m == *stop {
                    on & !(1 << k)
                } else {
                    on
                }
            })
    }

    /// Whether `m` changes the pairs' state in some state.
    pub fn follows(&self, m: u32) -> bool {
        (m == 9 && self.m9_ends) || self.codes.iter().flatten().any(|c| *c == m)
    }

    /// The block that switches off every pair on in `on` (`M51`), or nothing.
    pub fn off_block(&self, on: u8) -> Option<String> {
        self.block(on, 1)
    }

    /// The block that switches every pair on in `on` on again (`M50`), or nothing.
    pub fn on_block(&self, on: u8) -> Option<String> {
        self.block(on, 0)
    }

    /// The `which` code (0 on, 1 off) of every pair on in `on`, in one block.
    fn block(&self, on: u8, which: usize) -> Option<String> {
        let words: Vec<String> = self
            .codes
            .iter()
            .enumerate()
            .filter(|(k, _)| on & 1 << k != 0)
            .map(|(_, pair)| format!("M{}", pair[which]))
            .collect();
        (!words.is_empty()).then(|| words.join(" "))
    }

    /// What serde cannot check: codes the control gives another meaning, a code in two places, too many.
    pub fn validate(&self) -> Result<(), String> {
        if self.codes.len() > MAX_PAIRS {
            return Err(format!(
                "coolant.codes: {} pairs, at most {MAX_PAIRS}",
                self.codes.len()
            ));
        }
        let mut seen = Vec::new();
        for [on, off] in &self.codes {
            for c in [on, off] {
                if is_control_m(*c) || *c > 99_999 {
                    return Err(format!(
                        "coolant.codes: M{c} is not a machine coolant code (M0 … M9, M17, M19, M30, M40 … M45 and M70 have their own meaning on the control; at most M99999)"
                    ));
                }
                if seen.contains(c) {
                    return Err(format!(
                        "coolant.codes: M{c} appears twice: each pair needs an on and an off code of its own"
                    ));
                }
                seen.push(*c);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tsc_and_air() -> MachineCoolant {
        MachineCoolant {
            codes: vec![[50, 51], [24, 25]],
            m9_ends: false,
        }
    }

    #[test]
    fn pairs_switch_their_own_bit_and_m9_only_when_the_machine_says() {
        let c = tsc_and_air();
        assert_eq!(c.after(0, 50), 1);
        assert_eq!(c.after(1, 24), 3);
        assert_eq!(c.after(3, 51), 2);
        assert_eq!(c.after(3, 9), 3);
        assert_eq!(c.after(3, 8), 3);
        let ends = MachineCoolant {
            m9_ends: true,
            ..c.clone()
        };
        assert_eq!(ends.after(3, 9), 0);
        assert!(ends.follows(9) && !c.follows(9) && c.follows(25));
        assert_eq!(c.off_block(3).as_deref(), Some("M51 M25"));
        assert_eq!(c.on_block(2).as_deref(), Some("M24"));
        assert_eq!(c.on_block(0), None);
    }

    #[test]
    fn reserved_repeated_and_too_many_codes_are_refused() {
        let bad = |codes: Vec<[u32; 2]>| {
            MachineCoolant {
                codes,
                m9_ends: true,
            }
            .validate()
            .unwrap_err()
        };
        assert!(bad(vec![[8, 51]]).contains("M8 is not"));
        assert!(bad(vec![[50, 50]]).contains("twice"));
        assert!(bad(vec![[50, 51], [51, 52]]).contains("twice"));
        assert!(bad((0..9).map(|k| [100 + 2 * k, 101 + 2 * k]).collect()).contains("at most"));
        assert!(tsc_and_air().validate().is_ok());
    }
}
