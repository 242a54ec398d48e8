//! `extra_mode`: another spindle-driven mode with its own time constant — typically a slower mode the
//! characterisation runs were too short to show. Its target is proportional to the speed,
//! g = k·|rpm|/1000, so it adds one amplitude (k, µm per 1000 rpm at steady state) and one θ = τ (min).

use super::{Series, lag_into};

/// Unit response (k = 1 µm per 1000 rpm) for time constant `tau`.
pub fn columns(s: &Series, tau: f64, col: &mut [f64]) {
    match s.rpm {
        Some(rpm) => lag_into(s, tau, |i| rpm[i].abs() / 1000.0, col),
        None => col.fill(0.0),
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{assert_round_trip, series, whole};
    use super::super::{Effect, Kind};

    #[test]
    fn heats_towards_gain_times_speed_and_cools_back() {
        let t: Vec<f64> = (0..=1200).map(f64::from).collect();
        let rpm: Vec<f64> = t
            .iter()
            .map(|&x| if x < 600.0 { 3000.0 } else { 0.0 })
            .collect();
        let runs = whole(1201);
        let e = Effect {
            kind: Kind::ExtraMode,
            signal: None,
            position: None,
            theta: vec![100.0],
            amplitudes: vec![2.0],
        };
        let y = e.contribution(&series(&t, &runs, Some(&rpm), None));
        let at100 = 6.0 * (1.0 - (-1.0f64).exp());
        assert!((y[100] - at100).abs() < 1e-9);
        assert!((y[600] - 6.0).abs() < 0.02);
        assert!(y[1200] < 0.02);
        assert_round_trip(&e);
    }
}
