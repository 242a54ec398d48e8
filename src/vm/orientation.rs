//! The tool orientation a program sets under an orientation transformation (TRAORI), kept as the words
//! that program it. The dry run has no kinematics: an orientation turns no axis it follows and takes no
//! time of its own, but two runs that leave the tool oriented differently differ in control state.

use std::collections::BTreeMap;
use std::fmt;

use crate::views::ORIENTATION_DIRECTION as DIRECTION;
pub use crate::views::orientation_word as word;

/// The orientation as last programmed.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Orientation {
    /// `ORIRESET(…)`: the orientation axes' positions it asked for, until a direction is programmed.
    reset: Option<Vec<f64>>,
    words: BTreeMap<&'static str, f64>,
}

impl Orientation {
    /// The orientation words of one block, in the order written.
    pub fn program(&mut self, block: &[(&'static str, f64)]) {
        for group in DIRECTION {
            if block.iter().any(|(w, _)| group.contains(w)) {
                for g in DIRECTION.iter().flatten() {
                    self.words.remove(g);
                }
                for g in group {
                    self.words.insert(g, 0.0);
                }
                self.reset = None;
            }
        }
        for &(w, v) in block {
            self.words.insert(w, v);
        }
    }

    /// `ORIRESET(a, b, c)`: the tool goes to the initial orientation the positions give; what was
    /// programmed before no longer counts.
    pub fn reset(&mut self, positions: Vec<f64>) {
        self.words.clear();
        self.reset = Some(positions);
    }
}

impl fmt::Display for Orientation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        if let Some(p) = &self.reset {
            let p: Vec<String> = p
                .iter()
                .map(|v| crate::vm::value::format_number(*v))
                .collect();
            parts.push(format!("ORIRESET({})", p.join(", ")));
        }
        for (w, v) in &self.words {
            parts.push(format!("{w}={}", crate::vm::value::format_number(*v)));
        }
        if parts.is_empty() {
            write!(f, "none")
        } else {
            write!(f, "{}", parts.join(" "))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_direction_replaces_the_last_and_zeroes_what_it_leaves_out() {
        let mut o = Orientation::default();
        o.program(&[("A2", 10.0), ("B2", 20.0), ("C2", 30.0)]);
        o.program(&[("C3", 1.0), ("LEAD", 5.0)]);
        assert_eq!(o.to_string(), "A3=0 B3=0 C3=1 LEAD=5");
        o.program(&[("TILT", 2.0)]);
        assert_eq!(o.to_string(), "A3=0 B3=0 C3=1 LEAD=5 TILT=2");
        let mut other = o.clone();
        other.program(&[("B3", -0.5), ("C3", 0.866)]);
        assert_ne!(o, other, "another direction is another state");
        other.reset(vec![0.0, 0.0]);
        assert_eq!(other.to_string(), "ORIRESET(0, 0)");
    }

    #[test]
    fn only_orientation_words_are_words() {
        for w in ["A3", "C2", "LEAD", "THETA", "ZH"] {
            assert_eq!(word(w), Some(w));
        }
        for w in ["A", "A1", "A8", "Z1", "LEADS"] {
            assert_eq!(word(w), None, "{w}");
        }
    }
}
