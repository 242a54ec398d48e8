//! `periodic`: a daily cycle (the hall's day and night), A·cos(2π(t − t_peak)/24 h) on the data's time
//! axis. Fitted as sine and cosine parts (linear, no θ); written to the model file as `amplitude_um` and
//! `peak_min` (where on the time axis, modulo one day, the cycle peaks).

use std::collections::BTreeMap;
use std::f64::consts::TAU;

use super::Series;

/// Minutes in the period.
pub const PERIOD_MIN: f64 = 1440.0;

/// The parameters as written in the model file.
pub const PARAM_NAMES: [&str; 2] = ["amplitude_um", "peak_min"];

/// sin and cos of the time axis' phase.
pub fn columns(s: &Series, cols: &mut [&mut [f64]]) {
    for (i, &t) in s.t.iter().enumerate() {
        let w = TAU * t / PERIOD_MIN;
        cols[0][i] = w.sin();
        cols[1][i] = w.cos();
    }
}

/// `amplitude_um`, `peak_min` of a·sin + b·cos.
pub fn params_from_amplitudes(ab: &[f64]) -> BTreeMap<String, f64> {
    let (a, b) = (ab[0], ab[1]);
    let phase = a.atan2(b).rem_euclid(TAU);
    BTreeMap::from([
        (PARAM_NAMES[0].to_string(), a.hypot(b)),
        (PARAM_NAMES[1].to_string(), phase / TAU * PERIOD_MIN),
    ])
}

/// [a, b] from `amplitude_um`, `peak_min`.
pub fn amplitudes_from_params(p: &BTreeMap<String, f64>) -> Option<[f64; 2]> {
    let amp = p.get(PARAM_NAMES[0]).copied().filter(|v| v.is_finite())?;
    let peak = p.get(PARAM_NAMES[1]).copied().filter(|v| v.is_finite())?;
    let phase = TAU * peak / PERIOD_MIN;
    Some([amp * phase.sin(), amp * phase.cos()])
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{assert_round_trip, series, whole};
    use super::super::{Effect, Kind};
    use super::*;

    #[test]
    fn peaks_where_the_file_says() {
        let t: Vec<f64> = (0..2880).map(f64::from).collect();
        let runs = whole(2880);
        let params = BTreeMap::from([
            ("amplitude_um".to_string(), 3.0),
            ("peak_min".to_string(), 900.0),
        ]);
        let ab = amplitudes_from_params(&params).unwrap();
        let e = Effect {
            kind: Kind::Periodic,
            signal: None,
            position: None,
            theta: vec![],
            amplitudes: ab.to_vec(),
        };
        let y = e.contribution(&series(&t, &runs, None, None));
        assert!((y[900] - 3.0).abs() < 1e-9 && (y[900 + 1440] - 3.0).abs() < 1e-9);
        assert!((y[180] + 3.0).abs() < 1e-9);
        let back = e.to_spec().params;
        assert!((back["peak_min"] - 900.0).abs() < 1e-9);
        assert_round_trip(&e);
    }
}
