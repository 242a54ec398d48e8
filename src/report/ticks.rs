//! "Nice" axis ticks: steps of 1, 2 or 5 times a power of ten that enclose the data range.

/// Tick positions for one axis, with the number of decimals that prints every tick exactly.
#[derive(Debug, Clone, PartialEq)]
pub struct Ticks {
    pub values: Vec<f64>,
    pub step: f64,
    pub decimals: usize,
}

impl Ticks {
    /// The axis range the ticks span (first to last tick).
    pub fn range(&self) -> (f64, f64) {
        (self.values[0], self.values[self.values.len() - 1])
    }
}

/// Ticks covering `[lo, hi]` with about `target` intervals. Non-finite or reversed input is repaired (a
/// chart must still render when a series is all NaN), and a zero-width range is widened around its value.
pub fn nice_ticks(lo: f64, hi: f64, target: usize) -> Ticks {
    let (mut lo, mut hi) = match (lo.is_finite(), hi.is_finite()) {
        (true, true) => (lo.min(hi), lo.max(hi)),
        (true, false) => (lo, lo),
        (false, true) => (hi, hi),
        (false, false) => (0.0, 1.0),
    };
    if hi - lo <= f64::EPSILON * lo.abs().max(1.0) {
        let half = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
        lo -= half;
        hi += half;
    }
    let raw = (hi - lo) / target.max(1) as f64;
    let magnitude = 10f64.powf(raw.log10().floor());
    let fraction = raw / magnitude;
    let nice = if fraction <= 1.0 {
        1.0
    } else if fraction <= 2.0 {
        2.0
    } else if fraction <= 5.0 {
        5.0
    } else {
        10.0
    };
    let step = nice * magnitude;
    // Indices relative to zero keep every tick an exact multiple of the step (no accumulated error).
    let first = (lo / step + 1e-9).floor() as i64;
    let last = (hi / step - 1e-9).ceil() as i64;
    let values = (first..=last).map(|k| k as f64 * step).collect();
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    Ticks {
        values,
        step,
        decimals,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_enclose_the_range_with_a_nice_step() {
        let t = nice_ticks(-1.17, 19.17, 5);
        assert_eq!(t.step, 5.0);
        assert_eq!(t.values, vec![-5.0, 0.0, 5.0, 10.0, 15.0, 20.0]);
        assert_eq!(t.decimals, 0);
    }

    #[test]
    fn small_steps_get_decimals_and_exact_multiples() {
        let t = nice_ticks(0.0, 1.0, 5);
        assert_eq!(t.step, 0.2);
        assert_eq!(t.decimals, 1);
        assert_eq!(t.values.len(), 6);
        assert_eq!(crate::report::fmt_num(t.values[3], t.decimals), "0.6");
        let t = nice_ticks(0.013, 0.048, 4);
        assert_eq!(t.step, 0.01);
        assert_eq!(t.decimals, 2);
        assert_eq!(t.range(), (0.01, 0.05));
    }

    #[test]
    fn exact_tick_boundaries_are_not_padded_by_an_extra_step() {
        let t = nice_ticks(0.0, 100.0, 5);
        assert_eq!(t.values, vec![0.0, 20.0, 40.0, 60.0, 80.0, 100.0]);
    }

    #[test]
    fn degenerate_ranges_still_give_ticks() {
        let flat = nice_ticks(7.0, 7.0, 5);
        assert!(flat.range().0 < 7.0 && flat.range().1 > 7.0);
        let zero = nice_ticks(0.0, 0.0, 5);
        assert_eq!(zero.range(), (-1.0, 1.0));
        let nan = nice_ticks(f64::NAN, f64::NAN, 5);
        assert_eq!(nan.range(), (0.0, 1.0));
        let reversed = nice_ticks(10.0, 0.0, 5);
        assert_eq!(reversed.range(), (0.0, 10.0));
    }
}
