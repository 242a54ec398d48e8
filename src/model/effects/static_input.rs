//! `static_input`: a measured input (a temperature sensor) acting without delay: k·(u(i) − u₀), u₀ its value
//! at the run's first row, evaluated at its own row. No θ; amplitude k in µm per unit of the column (µm/°C
//! for `_c`). The intercept term I(θ) of a temperature-sensor regression (`driftloop sensors`); where
//! [`input_lag`](super::input_lag) follows the input through a lag, this term is its static limit without
//! the one-row delay a lag's piecewise-constant update has.

use super::Series;

/// Unit response (k = 1): the input relative to its run's first row, also the factor of
/// [`input_slope`](super::input_slope).
pub fn columns(s: &Series, col: &mut [f64]) {
    let u = s.signal.expect("the effect reads its signal");
    for run in s.runs {
        for i in run.clone() {
            col[i] = u[i] - u[run.start];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{assert_round_trip, series};
    use super::super::{Effect, Kind};

    #[test]
    fn follows_the_input_at_its_own_row_from_each_run_start() {
        let t = [0.0, 1.0, 2.0, 0.0, 1.0];
        let runs = [0..3, 3..5];
        let u = [20.0, 21.0, 23.0, 25.0, 24.5];
        let e = Effect {
            kind: Kind::StaticInput,
            signal: Some("t3_c".into()),
            position: None,
            theta: vec![],
            amplitudes: vec![2.0],
        };
        let y = e.contribution(&series(&t, &runs, None, Some(&u)));
        // No lag: row 1 already carries its own change; the second run starts from its own value.
        assert_eq!(y, vec![0.0, 2.0, 6.0, 0.0, -1.0]);
        assert_round_trip(&e);
        assert_eq!(
            e.to_spec().params.keys().collect::<Vec<_>>(),
            ["gain_um_per_unit"]
        );
    }
}
