//! `input_slope`: a slope of the error along an axis that follows a measured input, k·(u(i) − u₀)·p(i): the
//! S(θ)·p term of the third paper's E = E_G(p) + S(θ)·p + I(θ) with S linear in the sensors. u₀ is the
//! input at the run's first row; u and p enter at their own row (the position is the one at the
//! measurement). `signal` names the input, `position` the axis position column. No θ; amplitude k in µm per
//! mm per unit of the input (µm/mm/°C for `_c`). Unlike [`position_slope`](super::position_slope), whose
//! slope follows the spindle.

use super::Series;
use super::static_input;

/// Unit response (k = 1): (u − u₀)·p.
pub fn columns(s: &Series, col: &mut [f64]) {
    let p = s.position.expect("input_slope reads its position column");
    static_input::columns(s, col);
    for (c, pi) in col.iter_mut().zip(p) {
        *c *= pi;
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{assert_round_trip, whole};
    use super::super::{Effect, Kind, Series};

    #[test]
    fn the_slope_grows_with_the_input_and_scales_with_the_position() {
        let t = [0.0, 0.0, 10.0, 10.0];
        let runs = whole(4);
        let u = [20.0, 20.0, 22.0, 22.0];
        let p = [100.0, 300.0, 100.0, 300.0];
        let e = Effect {
            kind: Kind::InputSlope,
            signal: Some("a1_c".into()),
            position: Some("x_mm".into()),
            theta: vec![],
            amplitudes: vec![0.02],
        };
        let s = Series {
            t: &t,
            runs: &runs,
            rpm: None,
            signal: Some(&u),
            position: Some(&p),
        };
        let y = e.contribution(&s);
        // 0.02 µm/mm/°C · 2 °C = 0.04 µm/mm: 4 µm at 100 mm, 12 µm at 300 mm; nothing at the reference.
        let expect = [0.0, 0.0, 4.0, 12.0];
        for (a, b) in y.iter().zip(expect) {
            assert!((a - b).abs() < 1e-12, "{y:?}");
        }
        assert_round_trip(&e);
    }
}
