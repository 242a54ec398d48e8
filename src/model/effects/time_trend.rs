//! `time_trend`: slow linear creep, k µm per hour since the run's first row (no θ). Something the model
//! has no input for — a foundation settling, a slowly warming hall without a sensor.

use super::Series;

/// Hours since the run's start.
pub fn columns(s: &Series, col: &mut [f64]) {
    for run in s.runs {
        for i in run.clone() {
            col[i] = (s.t[i] - s.t[run.start]) / 60.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{assert_round_trip, series};
    use super::super::{Effect, Kind};

    #[test]
    fn grows_by_the_rate_per_hour_in_each_run() {
        let t = [100.0, 160.0, 220.0, 0.0, 30.0];
        let runs = [0..3, 3..5];
        let e = Effect {
            kind: Kind::TimeTrend,
            signal: None,
            position: None,
            theta: vec![],
            amplitudes: vec![0.5],
        };
        let y = e.contribution(&series(&t, &runs, None, None));
        assert_eq!(y, vec![0.0, 0.5, 1.0, 0.0, 0.25]);
        assert_round_trip(&e);
    }
}
