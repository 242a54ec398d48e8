//! Passes and the machined error.
//!
//! A tool path segment is the run of feed moves between two rapid moves (or a spindle stop, tool change, or the
//! end of the program) with the spindle turning. Its pass is what it cuts at its lowest programmed Z: the
//! planar moves at that Z (weighted by length), or, when it has none there, the end points of the moves that
//! reach it (a plunge). The machined error of a pass is the depth actually cut minus the nominal depth, in µm
//! (nominal Z minus the Z the tool centre point really was at): the thermal drift minus the correction applied
//! to the work offset since program start. Positive means cut too deep.

use std::rc::Rc;

use serde::Serialize;

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Pass {
    pub number: usize,
    pub file: String,
    /// Line of the first move that cut at the pass's depth.
    pub line: usize,
    pub start_min: f64,
    pub end_min: f64,
    /// Programmed Z of the pass (work coordinates).
    pub nominal_z_mm: f64,
    pub spindle_rpm: f64,
    /// Mean machined error over the pass (µm).
    pub error_um: f64,
    /// Largest machined error in magnitude over the pass (µm).
    pub worst_um: f64,
    /// Mean thermal drift during the pass (µm): the error had no correction been applied.
    pub drift_um: f64,
}

/// One cutting sample: where and when, its error and its weight (length of a planar move; 0 for a plunge end).
#[derive(Debug, Clone)]
pub struct Cut {
    pub file: Rc<str>,
    pub line: usize,
    pub start_min: f64,
    pub end_min: f64,
    pub z_mm: f64,
    pub spindle_rpm: f64,
    pub error_um: f64,
    pub drift_um: f64,
    pub planar_length_mm: f64,
}

/// Running sums over the cuts at one depth, so a long segment costs no memory.
#[derive(Debug, Clone)]
struct Level {
    first: Cut,
    last_end_min: f64,
    /// Over planar cuts, then over plunge ends.
    planar: Sums,
    plunge: Sums,
    /// First planar cut, which names the pass when there is one.
    first_planar: Option<Cut>,
}

#[derive(Debug, Clone, Copy, Default)]
struct Sums {
    error: f64,
    drift: f64,
    weight: f64,
    worst: f64,
}

impl Sums {
    fn add(&mut self, cut: &Cut, weight: f64) {
        self.error += weight * cut.error_um;
        self.drift += weight * cut.drift_um;
        self.weight += weight;
        if cut.error_um.abs() > self.worst.abs() {
            self.worst = cut.error_um;
        }
    }
}

#[derive(Debug, Default)]
pub struct PassTracker {
    level: Option<Level>,
    pub passes: Vec<Pass>,
}

const Z_EQUAL_MM: f64 = 1e-6;

impl PassTracker {
    /// A feed move with the spindle on that ends at `cut.z_mm` (planar when `planar_length_mm` > 0).
    pub fn feed_move(&mut self, cut: Cut) {
        let z = cut.z_mm;
        let level = match &mut self.level {
            Some(l) if z > l.first.z_mm + Z_EQUAL_MM => return,
            Some(l) if z >= l.first.z_mm - Z_EQUAL_MM => l,
            slot => slot.insert(Level {
                first: cut.clone(),
                last_end_min: cut.end_min,
                planar: Sums::default(),
                plunge: Sums::default(),
                first_planar: None,
            }),
        };
        level.last_end_min = cut.end_min;
        if cut.planar_length_mm > 0.0 {
            level.planar.add(&cut, cut.planar_length_mm);
            level.first_planar.get_or_insert(cut);
        } else {
            level.plunge.add(&cut, 1.0);
        }
    }

    /// Closes the current segment and records its pass.
    pub fn end_segment(&mut self) {
        let Some(level) = self.level.take() else {
            return;
        };
        let (first, sums) = match level.first_planar {
            Some(first) => (first, level.planar),
            None => (level.first, level.plunge),
        };
        self.passes.push(Pass {
            number: self.passes.len() + 1,
            file: first.file.to_string(),
            line: first.line,
            start_min: first.start_min,
            end_min: level.last_end_min,
            nominal_z_mm: first.z_mm,
            spindle_rpm: first.spindle_rpm,
            error_um: sums.error / sums.weight,
            worst_um: sums.worst,
            drift_um: sums.drift / sums.weight,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cut(line: usize, z: f64, len: f64, err: f64) -> Cut {
        Cut {
            file: Rc::from("p"),
            line,
            start_min: line as f64,
            end_min: line as f64 + 1.0,
            z_mm: z,
            spindle_rpm: 1000.0,
            error_um: err,
            drift_um: err + 1.0,
            planar_length_mm: len,
        }
    }

    #[test]
    fn pass_is_the_planar_cut_at_the_lowest_z_weighted_by_length() {
        let mut t = PassTracker::default();
        t.feed_move(cut(1, -1.0, 0.0, 9.0)); // plunge to -1
        t.feed_move(cut(2, -1.0, 30.0, 2.0));
        t.feed_move(cut(3, -1.0, 10.0, 6.0));
        t.feed_move(cut(4, 5.0, 0.0, 0.0)); // retract: above, ignored
        t.end_segment();
        assert_eq!(t.passes.len(), 1);
        let p = &t.passes[0];
        assert_eq!((p.line, p.nominal_z_mm), (2, -1.0));
        assert!((p.error_um - 3.0).abs() < 1e-12);
        assert!((p.drift_um - 4.0).abs() < 1e-12);
        assert_eq!(p.worst_um, 6.0);
    }

    #[test]
    fn deeper_cut_replaces_and_plunge_alone_counts() {
        let mut t = PassTracker::default();
        t.feed_move(cut(1, -1.0, 10.0, 1.0));
        t.feed_move(cut(2, -2.0, 0.0, -4.0));
        t.end_segment();
        t.end_segment();
        assert_eq!(t.passes.len(), 1, "an empty segment is no pass");
        assert_eq!(t.passes[0].nominal_z_mm, -2.0);
        assert_eq!(t.passes[0].error_um, -4.0);
    }
}
