//! `step`: a sudden offset from a time on (θ = the time in minutes on the data's axis; amplitude the
//! offset in µm) — a crash, a re-clamped fixture, a probe re-qualified. The time enters the fit
//! discontinuously, so the refit scans it on a grid rather than iterating it.

use super::Series;

/// 1 from `at` on, else 0.
pub fn columns(s: &Series, at: f64, col: &mut [f64]) {
    for (c, &t) in col.iter_mut().zip(s.t) {
        *c = if t >= at { 1.0 } else { 0.0 };
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{assert_round_trip, series, whole};
    use super::super::{Effect, Kind};

    #[test]
    fn offset_from_the_step_on() {
        let t = [0.0, 10.0, 20.0, 30.0];
        let runs = whole(4);
        let e = Effect {
            kind: Kind::Step,
            signal: None,
            position: None,
            theta: vec![20.0],
            amplitudes: vec![-4.0],
        };
        assert_eq!(
            e.contribution(&series(&t, &runs, None, None)),
            vec![0.0, 0.0, -4.0, -4.0]
        );
        assert_round_trip(&e);
    }
}
