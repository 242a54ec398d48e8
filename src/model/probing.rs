//! What the probe gates buy: the compensated error when, besides the model's correction, a probe
//! measures the real error every P minutes and the correction is re-zeroed on it. Between two probings the
//! error is the model's error minus what it was at the last probing, so the model only has to be right
//! about the drift *since* the last probing.
//!
//! Optionally a probing also re-estimates the error's trend: the rate between the last two probings of a
//! run, scaled by a gain g ∈ [0, 1], is continued until the next probing. In NC this is R-parameter
//! arithmetic at each gate: with e the probed error (reading − model) at time t, and e₀, t₀ the previous
//! probing's, the offset is e and the rate r = g·(e − e₀)/(t − t₀); between gates the correction is
//! model(t′) + e + r·(t′ − t). g = 0 is the plain re-zeroing; `fit --kind dlag` chooses g by forward
//! validation.

use std::ops::Range;

use serde::{Deserialize, Serialize};

/// How often a probe re-zeroes the correction, and how much of the error's last rate it continues.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Probing {
    pub every_min: f64,
    /// Share of the rate between the last two probings continued until the next (0: re-zero only).
    pub trend_gain: f64,
}

impl Probing {
    /// Re-zeroing only.
    pub fn every(every_min: f64) -> Probing {
        Probing {
            every_min,
            trend_gain: 0.0,
        }
    }
}

/// The error series corrected at a probing every `probing.every_min` minutes: in each run, the first
/// probing is at its first reading in `window`, the next at its first reading at or after that time plus
/// the interval, and so on; from a probing on, the error at the probing is subtracted, and from a run's
/// second probing on also the trend (above). Rows before a run's first probing keep their error; rows
/// without a reading (`err` NaN) stay NaN and are never a probing.
pub fn rezeroed(
    t: &[f64],
    runs: &[Range<usize>],
    err: &[f64],
    window: &[bool],
    probing: Probing,
) -> Vec<f64> {
    let mut out = err.to_vec();
    for run in runs {
        let Some(first) = run.clone().find(|&i| window[i] && !err[i].is_nan()) else {
            continue;
        };
        let mut next = t[first];
        // The last probing: its time, the error there and the rate continued from it.
        let mut last: Option<(f64, f64, f64)> = None;
        for i in first..run.end {
            if t[i] >= next && !err[i].is_nan() {
                let rate = last.map_or(0.0, |(t0, e0, _)| {
                    probing.trend_gain * (err[i] - e0) / (t[i] - t0)
                });
                last = Some((t[i], err[i], rate));
                // The schedule keeps its own clock; a reading missing at a probing time delays only it.
                while next <= t[i] {
                    next += probing.every_min;
                }
            }
            if let Some((t0, e0, rate)) = last {
                out[i] = err[i] - e0 - rate * (t[i] - t0);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_probe_re_zeroes_the_error_on_its_schedule() {
        let t: Vec<f64> = (0..10).map(|i| f64::from(i) * 10.0).collect();
        let err: Vec<f64> = t.iter().map(|x| x / 10.0).collect();
        let runs: Vec<Range<usize>> = std::iter::once(0..10).collect();
        let from20: Vec<bool> = t.iter().map(|&x| x >= 20.0).collect();
        let out = rezeroed(&t, &runs, &err, &from20, Probing::every(30.0));
        // Probings at 20, 50, 80 min.
        assert_eq!(out, vec![0.0, 1.0, 0.0, 1.0, 2.0, 0.0, 1.0, 2.0, 0.0, 1.0]);
        // A missing reading at a probing time: the next reading is the probing, the clock is kept.
        let mut gappy = err.clone();
        gappy[5] = f64::NAN;
        let out = rezeroed(&t, &runs, &gappy, &from20, Probing::every(30.0));
        assert!(out[5].is_nan());
        assert_eq!(out[6], 0.0);
        assert_eq!(out[7], 1.0);
        assert_eq!(out[8], 0.0);
    }

    #[test]
    fn every_run_is_probed_from_its_first_reading_in_the_window() {
        let t = [0.0, 10.0, 20.0, 0.0, 10.0, 20.0];
        let err = [5.0, 6.0, 8.0, 1.0, 3.0, 4.0];
        let window: Vec<bool> = t.iter().map(|&x| x >= 10.0).collect();
        let out = rezeroed(&t, &[0..3, 3..6], &err, &window, Probing::every(60.0));
        assert_eq!(out, vec![5.0, 0.0, 2.0, 1.0, 0.0, 1.0]);
    }

    #[test]
    fn a_trend_gain_continues_the_rate_between_the_last_two_probings() {
        let t: Vec<f64> = (0..10).map(|i| f64::from(i) * 10.0).collect();
        // An error growing 0.1 µm/min: from the second probing on, a full trend gain removes it.
        let err: Vec<f64> = t.iter().map(|x| 0.1 * x).collect();
        let runs: Vec<Range<usize>> = std::iter::once(0..10).collect();
        let all = [true; 10];
        let full = Probing {
            every_min: 30.0,
            trend_gain: 1.0,
        };
        let out = rezeroed(&t, &runs, &err, &all, full);
        // Probings at 0, 30, 60, 90 min: before the second only the offset is known.
        for (i, o) in out.iter().enumerate() {
            let expected = if i < 3 { 0.1 * t[i] } else { 0.0 };
            assert!((o - expected).abs() < 1e-12, "row {i}: {o}");
        }
        // Half the gain leaves half the growth since the last probing.
        let half = Probing {
            trend_gain: 0.5,
            ..full
        };
        let out = rezeroed(&t, &runs, &err, &all, half);
        assert!((out[4] - 0.5).abs() < 1e-12, "{}", out[4]);
        // A rate is never carried from one run into the next.
        let two = rezeroed(&t, &[0..5, 5..10], &err, &all, full);
        assert!((two[6] - 1.0).abs() < 1e-12, "{}", two[6]);
    }
}
