//! `geometric`: the geometric error of an axis, E_G(p) = a·p + b·p², p the axis position column (`position`),
//! at its own row. Its constant part is the model's `offset_um`, so the term has none. No θ; amplitudes a in
//! µm/mm and b in µm/mm². Written by `driftloop sensors --position-column` (the reference state's polynomial,
//! the third paper's E_G); it does not change with time, so on the machine it is part of the zero.

use super::Series;

/// Columns p and p².
pub fn columns(s: &Series, cols: &mut [&mut [f64]]) {
    let p = s.position.expect("geometric reads its position column");
    let (linear, rest) = cols.split_at_mut(1);
    for ((l, q), pi) in linear[0].iter_mut().zip(rest[0].iter_mut()).zip(p) {
        *l = *pi;
        *q = pi * pi;
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{assert_round_trip, whole};
    use super::super::{Effect, Kind, Series};

    #[test]
    fn a_parabola_in_the_position() {
        let t = [0.0, 1.0, 2.0];
        let runs = whole(3);
        let p = [0.0, 100.0, 200.0];
        let e = Effect {
            kind: Kind::Geometric,
            signal: None,
            position: Some("x_mm".into()),
            theta: vec![],
            amplitudes: vec![0.01, -2e-5],
        };
        let s = Series {
            t: &t,
            runs: &runs,
            rpm: None,
            signal: None,
            position: Some(&p),
        };
        let y = e.contribution(&s);
        let expect = [0.0, 1.0 - 0.2, 2.0 - 0.8];
        for (a, b) in y.iter().zip(expect) {
            assert!((a - b).abs() < 1e-12, "{y:?}");
        }
        assert_round_trip(&e);
        let spec = e.to_spec();
        assert_eq!(spec.signal, None);
        assert_eq!(spec.position.as_deref(), Some("x_mm"));
    }
}
