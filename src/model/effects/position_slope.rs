//! `position_slope`: the drift grows with an axis position p (a `_mm` column): E = S(θ)·p + I(θ), the
//! composite-error model of the third paper (design.md §1). I(θ) is the drift the model already predicts;
//! the slope follows the spindle-driven thermal state, S = a·x with x a first-order lag (θ = τ) of
//! |rpm|/1000, plus a static slope b (the linear part of the geometric error E_G):
//! contribution = a·p·x + b·p. Amplitudes: a in µm per mm per 1000 rpm at steady state, b in µm per mm.
//! The position is the one at the measurement, so it enters at its own row, unlagged.

use super::{Series, lag_into};

/// Columns p·x (for `tau`) and p.
pub fn columns(s: &Series, tau: f64, cols: &mut [&mut [f64]]) {
    let p = s.signal.expect("position_slope reads its position column");
    let (first, rest) = cols.split_at_mut(1);
    let thermal = &mut *first[0];
    match s.rpm {
        Some(rpm) => lag_into(s, tau, |i| rpm[i].abs() / 1000.0, thermal),
        None => thermal.fill(0.0),
    }
    for (x, pi) in thermal.iter_mut().zip(p) {
        *x *= pi;
    }
    rest[0].copy_from_slice(p);
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{assert_round_trip, series, whole};
    use super::super::{Effect, Kind};

    #[test]
    fn drift_is_proportional_to_position_once_warm() {
        let t: Vec<f64> = (0..=600).map(f64::from).collect();
        let rpm = vec![2000.0; 601];
        let p: Vec<f64> = t
            .iter()
            .map(|&x| {
                if (x as usize / 10) % 2 == 0 {
                    100.0
                } else {
                    400.0
                }
            })
            .collect();
        let runs = whole(601);
        let e = Effect {
            kind: Kind::PositionSlope,
            signal: Some("x_mm".into()),
            position: None,
            theta: vec![60.0],
            amplitudes: vec![0.01, 0.0],
        };
        let y = e.contribution(&series(&t, &runs, Some(&rpm), Some(&p)));
        // Warm (x ≈ 2): 0.01·2·p → 2 µm at 100 mm, 8 µm at 400 mm.
        assert!((y[580] - 2.0).abs() < 0.01, "{}", y[580]);
        assert!((y[590] - 8.0).abs() < 0.02, "{}", y[590]);
        assert_eq!(y[0], 0.0);
        assert_round_trip(&e);
    }
}
