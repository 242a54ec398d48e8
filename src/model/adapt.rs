//! Adaptive re-zeroing: at each probing the controller re-estimates, from the probe readings of the
//! current run, not only an offset but also how wrong the model's *scale* is. At a speed the model never
//! saw, its spindle part is extrapolated by a law that may be off by a factor, and the error then grows
//! with that part rather than staying constant between probings; an offset alone cannot follow it.
//!
//! The state θ = (a, b, c): the offset, the scale error of the model's spindle part s(t) and of its sensor
//! part q(t), both counted from the run's first probing (so the first probing is a plain re-zeroing and
//! the scales only learn from how the error changes afterwards). The correction applied until the next
//! probing is model(t) + a + b·(s(t) − s₀) + c·(q(t) − q₀). A Kalman filter updates θ at each probing:
//! - the offset starts diffuse (any first error is believed) and walks (drift neither part explains);
//! - b and c start at 0 with a prior spread (how far the model's parts may be mis-scaled) and may walk
//!   (forgetting: the mis-scaling changes with the speed);
//! - a probing's reading has a variance of 1 µm², the unit the other spreads are relative to.
//!
//! In NC one probing costs a 3 × 3 update (about 60 R-parameter operations, [`Filter::probe`]); the state
//! is never carried from one run into the next. The spreads are chosen by forward validation inside the
//! fit window (`fit --kind dlag`, [`super::dlag`]) from [`Adaptive::candidates`].

use std::ops::Range;

use serde::{Deserialize, Serialize};

use super::DriftModel;
use super::predict::PredictError;
use super::probing::probings;

/// A probing's reading noise (µm²): the unit of the filter's other spreads.
const READING_VAR: f64 = 1.0;
/// The offset's prior variance (µm²): diffuse, so the first probing re-zeroes to within 10⁻⁴ of the error.
const OFFSET_PRIOR_VAR: f64 = 1e4;

/// The filter's hyper-parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Adaptive {
    /// Prior standard deviation of b, the relative scale error of the model's spindle part.
    pub spindle_scale_sd: f64,
    /// Prior standard deviation of c, the relative scale error of the sensor part (0: not estimated).
    pub sensor_scale_sd: f64,
    /// The offset's random walk (µm per √h).
    pub offset_walk_um: f64,
    /// The scales' random walk (per √h): how fast the filter forgets what earlier probings said.
    pub scale_walk: f64,
}

impl Adaptive {
    /// The grid forward validation chooses from, fixed before any number was looked at (docs/forward.md,
    /// "Branch adapt"): spindle scale spread 0.1 … 3 (a law off by 10 % … 300 %), the sensor scale not
    /// estimated or with spread 0.3, offset walk 0.3 … 3 µm/√h, scales fixed or walking 0.1 or 0.3 /√h.
    pub fn candidates() -> Vec<Adaptive> {
        let mut out = Vec::new();
        for spindle_scale_sd in [0.1, 0.3, 1.0, 3.0] {
            for sensor_scale_sd in [0.0, 0.3] {
                for offset_walk_um in [0.3, 1.0, 3.0] {
                    for scale_walk in [0.0, 0.1, 0.3] {
                        out.push(Adaptive {
                            spindle_scale_sd,
                            sensor_scale_sd,
                            offset_walk_um,
                            scale_walk,
                        });
                    }
                }
            }
        }
        out
    }
}

/// The state the controller keeps between probings of one run: θ = (a, b, c), its 3 × 3 covariance, the
/// time of the last probing and the parts at the first.
#[derive(Debug, Clone, PartialEq)]
pub struct Filter {
    hyper: Adaptive,
    theta: [f64; 3],
    cov: [[f64; 3]; 3],
    /// Minutes of the last probing; `None` before the run's first.
    last_min: Option<f64>,
    /// The spindle and sensor parts at the run's first probing.
    origin: [f64; 2],
}

impl Filter {
    pub fn new(hyper: Adaptive) -> Filter {
        Filter {
            hyper,
            theta: [0.0; 3],
            cov: [[0.0; 3]; 3],
            last_min: None,
            origin: [0.0; 2],
        }
    }

    /// The regressors of the error at parts (s, q).
    fn regressors(&self, spindle: f64, sensors: f64) -> [f64; 3] {
        [1.0, spindle - self.origin[0], sensors - self.origin[1]]
    }

    /// What the correction adds to the model at parts (s, q): a + b·(s − s₀) + c·(q − q₀); 0 before the
    /// first probing.
    pub fn correction(&self, spindle: f64, sensors: f64) -> f64 {
        let h = self.regressors(spindle, sensors);
        (0..3).map(|k| self.theta[k] * h[k]).sum()
    }

    /// A probing at `t_min` read the error `err` (reading − model) where the model's parts were (s, q).
    pub fn probe(&mut self, t_min: f64, err: f64, spindle: f64, sensors: f64) {
        let hp = self.hyper;
        match self.last_min {
            None => {
                self.origin = [spindle, sensors];
                self.cov = [
                    [OFFSET_PRIOR_VAR, 0.0, 0.0],
                    [0.0, hp.spindle_scale_sd.powi(2), 0.0],
                    [0.0, 0.0, hp.sensor_scale_sd.powi(2)],
                ];
            }
            Some(t0) => {
                // The walks between probings; a scale not estimated (prior spread 0) stays 0.
                let hours = (t_min - t0).max(0.0) / 60.0;
                self.cov[0][0] += hp.offset_walk_um.powi(2) * hours;
                let walk = hp.scale_walk.powi(2) * hours;
                if hp.spindle_scale_sd > 0.0 {
                    self.cov[1][1] += walk;
                }
                if hp.sensor_scale_sd > 0.0 {
                    self.cov[2][2] += walk;
                }
            }
        }
        self.last_min = Some(t_min);
        let h = self.regressors(spindle, sensors);
        let ph: [f64; 3] = std::array::from_fn(|i| (0..3).map(|j| self.cov[i][j] * h[j]).sum());
        let s: f64 = READING_VAR + (0..3).map(|i| h[i] * ph[i]).sum::<f64>();
        let innovation = err - self.correction(spindle, sensors);
        for (th, p) in self.theta.iter_mut().zip(ph) {
            *th += p / s * innovation;
        }
        // P ← P − (Ph)(Ph)ᵀ / S, kept symmetric.
        for i in 0..3 {
            for j in 0..=i {
                let v = self.cov[i][j] - ph[i] * ph[j] / s;
                self.cov[i][j] = v;
                self.cov[j][i] = v;
            }
        }
    }

    /// (a, b, c).
    pub fn theta(&self) -> [f64; 3] {
        self.theta
    }
}

/// The error series corrected by adaptive re-zeroing: the probings on the schedule of
/// [`super::probing::rezeroed`] (each run from its first reading in `window`, every `every_min`), each run
/// with a fresh [`Filter`]; from a probing on, the error minus the filter's correction. `spindle` and
/// `sensors` are the model's two parts at every row.
pub fn adapted(
    t: &[f64],
    runs: &[Range<usize>],
    err: &[f64],
    parts: (&[f64], &[f64]),
    window: &[bool],
    every_min: f64,
    hyper: Adaptive,
) -> Vec<f64> {
    let (spindle, sensors) = parts;
    let mut out = err.to_vec();
    for run in runs {
        let at = probings(t, run.clone(), err, window, every_min);
        let Some(&first) = at.first() else {
            continue;
        };
        let mut filter = Filter::new(hyper);
        let mut next = at.iter().peekable();
        for i in first..run.end {
            if next.peek() == Some(&&i) {
                next.next();
                filter.probe(t[i], err[i], spindle[i], sensors[i]);
            }
            out[i] = err[i] - filter.correction(spindle[i], sensors[i]);
        }
    }
    out
}

/// The model's spindle part (its spindle modes, without offset) and its sensor part (everything else
/// but the offset) at every row of `ds`.
pub fn parts(model: &DriftModel, ds: &crate::data::Dataset) -> Result<[Vec<f64>; 2], PredictError> {
    let total = model.predict(ds)?;
    let mut alone = model.clone();
    alone.offset_um = 0.0;
    alone.effects.clear();
    alone.inputs.clear();
    let spindle = alone.predict(ds)?;
    let sensors = total
        .iter()
        .zip(&spindle)
        .map(|(p, s)| p - model.offset_um - s)
        .collect();
    Ok([spindle, sensors])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hyper(spindle_scale_sd: f64) -> Adaptive {
        Adaptive {
            spindle_scale_sd,
            sensor_scale_sd: 0.0,
            offset_walk_um: 1.0,
            scale_walk: 0.0,
        }
    }

    /// Every 10 min for 100 min, a spindle part rising along a first-order lag.
    fn spindle() -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..=10).map(|i| f64::from(i) * 10.0).collect();
        let s = t.iter().map(|x| 8.0 * (1.0 - (-x / 30.0).exp())).collect();
        (t, s)
    }

    #[test]
    fn a_mis_scaled_spindle_part_is_removed_after_three_probings() {
        let (t, s) = spindle();
        // The model's spindle part is 1.3 times too small, and 2 µm are off: err = 2 + 1.3·s.
        let err: Vec<f64> = s.iter().map(|s| 2.0 + 1.3 * s).collect();
        let q = vec![0.0; t.len()];
        let runs: Vec<Range<usize>> = std::iter::once(0..t.len()).collect();
        let all = vec![true; t.len()];
        // A wide prior on the scale (so it is learnt, not shrunk) and readings at every row's probing.
        let out = adapted(&t, &runs, &err, (&s, &q), &all, 20.0, hyper(1e3));
        // Probings at 0, 20, 40 min; from the third on the error is gone.
        for (i, o) in out.iter().enumerate().skip(4) {
            assert!(o.abs() < 1e-3, "row {i}: {o}");
        }
        // The first probing is a plain re-zeroing: between it and the second, the growth is left.
        assert!((out[1] - 1.3 * (s[1] - s[0])).abs() < 1e-3, "{}", out[1]);
        // With a narrow prior the scale is shrunk towards 0: part of the growth stays.
        let shrunk = adapted(&t, &runs, &err, (&s, &q), &all, 20.0, hyper(0.01));
        assert!(shrunk[10].abs() > 0.5, "{}", shrunk[10]);
    }

    #[test]
    fn the_filter_recovers_offset_and_both_scales() {
        let mut f = Filter::new(Adaptive {
            spindle_scale_sd: 1e3,
            sensor_scale_sd: 1e3,
            offset_walk_um: 0.0,
            scale_walk: 0.0,
        });
        let s = [0.0, 3.0, 5.0, 6.0, 6.5];
        let q = [1.0, 0.0, 2.0, -1.0, 4.0];
        let e = |k: usize| 2.0 + 1.3 * s[k] - 0.4 * (q[k] - q[0]);
        for k in 0..5 {
            f.probe(60.0 * k as f64, e(k), s[k], q[k]);
        }
        let th = f.theta();
        assert!((th[1] - 1.3).abs() < 1e-3, "{th:?}");
        assert!((th[2] + 0.4).abs() < 1e-3, "{th:?}");
        assert!((f.correction(10.0, 3.0) - (2.0 + 13.0 - 0.8)).abs() < 1e-2);
    }

    #[test]
    fn the_first_probing_is_a_plain_re_zeroing_and_a_scale_off_stays_zero() {
        let mut f = Filter::new(hyper(0.0));
        f.probe(0.0, 5.0, 4.0, 1.0);
        assert!((f.correction(9.0, 7.0) - 5.0).abs() < 1e-3);
        f.probe(60.0, 8.0, 9.0, 7.0);
        assert_eq!(f.theta()[1], 0.0);
        assert_eq!(f.theta()[2], 0.0);
    }

    #[test]
    fn no_information_crosses_runs() {
        let (t1, s1) = spindle();
        let n = t1.len();
        let t: Vec<f64> = t1.iter().chain(&t1).copied().collect();
        let s: Vec<f64> = s1.iter().chain(&s1).copied().collect();
        let q = vec![0.0; 2 * n];
        // The first run's error grows with the spindle part; the second's is a constant 1 µm.
        let err: Vec<f64> = (0..2 * n)
            .map(|i| if i < n { 2.0 + 1.3 * s[i] } else { 1.0 })
            .collect();
        let all = vec![true; 2 * n];
        let out = adapted(
            &t,
            &[0..n, n..2 * n],
            &err,
            (&s, &q),
            &all,
            20.0,
            hyper(1e3),
        );
        // The second run starts from a fresh filter: re-zeroed at its first row, nothing learnt before.
        for (i, o) in out.iter().enumerate().skip(n) {
            assert!(o.abs() < 1e-3, "row {i}: {o}");
        }
        // And the second run alone gives the same.
        let alone = adapted(
            &t1,
            std::slice::from_ref(&(0..n)),
            &err[n..],
            (&s[n..], &q[n..]),
            &all[n..],
            20.0,
            hyper(1e3),
        );
        assert_eq!(alone, out[n..]);
    }

    #[test]
    fn rows_outside_the_window_and_before_the_first_probing_keep_their_error() {
        let (t, s) = spindle();
        let err: Vec<f64> = s.iter().map(|s| 2.0 + s).collect();
        let q = vec![0.0; t.len()];
        let from30: Vec<bool> = t.iter().map(|&x| x >= 30.0).collect();
        let runs: Vec<Range<usize>> = std::iter::once(0..t.len()).collect();
        let out = adapted(&t, &runs, &err, (&s, &q), &from30, 20.0, hyper(1.0));
        assert_eq!(out[..3], err[..3]);
        assert!(out[3].abs() < 1e-3);
    }
}
