//! `input_lag`: a numeric column the model does not declare (a temperature, ambient, coolant, …) acting
//! through a first-order lag: dx/dt = (k·(u − u₀) − x)/τ, u₀ the column's value at the run's first row, so
//! every run starts at equilibrium. θ = τ (min); amplitude k in µm per unit of the column (µm/°C for `_c`).
//! This is the same term `fit --inputs` declares; diagnosis finds it without being told the column.

use super::{Series, lag_into};

/// Unit response (k = 1) for time constant `tau`.
pub fn columns(s: &Series, tau: f64, col: &mut [f64]) {
    let u = s.signal.expect("input_lag reads its signal");
    let mut base = vec![0.0; u.len()];
    for run in s.runs {
        for i in run.clone() {
            base[i] = u[i] - u[run.start];
        }
    }
    lag_into(s, tau, |i| base[i], col);
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{assert_round_trip, series, whole};
    use super::super::{Effect, Kind};

    #[test]
    fn a_step_in_the_signal_is_followed_with_its_time_constant() {
        let t: Vec<f64> = (0..200).map(f64::from).collect();
        let u: Vec<f64> = t
            .iter()
            .map(|&x| if x < 10.0 { 20.0 } else { 22.0 })
            .collect();
        let runs = whole(200);
        let e = Effect {
            kind: Kind::InputLag,
            signal: Some("ambient_c".into()),
            position: None,
            theta: vec![30.0],
            amplitudes: vec![-1.5],
        };
        let y = e.contribution(&series(&t, &runs, None, Some(&u)));
        assert_eq!(y[10], 0.0);
        // One time constant after the step: 63 % of k·Δu = −3 µm.
        let expect = -3.0 * (1.0 - (-1.0f64).exp());
        assert!((y[40] - expect).abs() < 1e-9, "{}", y[40]);
        assert!((y[199] + 3.0).abs() < 0.01);
        assert_round_trip(&e);
    }
}
