//! What the probe gates buy: the compensated error when, besides the model's correction, a probe
//! measures the real error every P minutes and the correction is re-zeroed on it. Between two probings the
//! error is the model's error minus what it was at the last probing, so the model only has to be right
//! about the drift *since* the last probing.

use std::ops::Range;

/// The error series re-zeroed by a probing every `every_min` minutes: in each run, the first probing is at
/// its first reading in `window`, the next at its first reading at or after that time plus `every_min`, and
/// so on; from a probing on, the error at the probing is subtracted. Rows before a run's first probing keep
/// their error; rows without a reading (`err` NaN) stay NaN and are never a probing.
pub fn rezeroed(
    t: &[f64],
    runs: &[Range<usize>],
    err: &[f64],
    window: &[bool],
    every_min: f64,
) -> Vec<f64> {
    let mut out = err.to_vec();
    for run in runs {
        let Some(first) = run.clone().find(|&i| window[i] && !err[i].is_nan()) else {
            continue;
        };
        let mut next = t[first];
        let mut zero: Option<f64> = None;
        for i in first..run.end {
            if t[i] >= next && !err[i].is_nan() {
                zero = Some(err[i]);
                // The schedule keeps its own clock; a reading missing at a probing time delays only it.
                while next <= t[i] {
                    next += every_min;
                }
            }
            if let Some(z) = zero {
                out[i] = err[i] - z;
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
        let out = rezeroed(&t, &runs, &err, &from20, 30.0);
        // Probings at 20, 50, 80 min.
        assert_eq!(out, vec![0.0, 1.0, 0.0, 1.0, 2.0, 0.0, 1.0, 2.0, 0.0, 1.0]);
        // A missing reading at a probing time: the next reading is the probing, the clock is kept.
        let mut gappy = err.clone();
        gappy[5] = f64::NAN;
        let out = rezeroed(&t, &runs, &gappy, &from20, 30.0);
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
        let out = rezeroed(&t, &[0..3, 3..6], &err, &window, 60.0);
        assert_eq!(out, vec![5.0, 0.0, 2.0, 1.0, 0.0, 1.0]);
    }
}
