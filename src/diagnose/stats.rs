//! Error statistics and the residual tests diagnosis stops on.

use serde::Serialize;

/// RMS, largest |e| and 95th percentile of |e| of one error series (µm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ErrorStats {
    pub rms_um: f64,
    pub max_um: f64,
    pub p95_um: f64,
}

impl ErrorStats {
    /// `None` for an empty series.
    pub fn of(e: &[f64]) -> Option<ErrorStats> {
        if e.is_empty() {
            return None;
        }
        let mut abs: Vec<f64> = e.iter().map(|v| v.abs()).collect();
        abs.sort_by(f64::total_cmp);
        let rank = (0.95 * (abs.len() - 1) as f64).round() as usize;
        Some(ErrorStats {
            rms_um: rms(e),
            max_um: abs[abs.len() - 1],
            p95_um: abs[rank],
        })
    }
}

pub fn rms(e: &[f64]) -> f64 {
    if e.is_empty() {
        return 0.0;
    }
    (e.iter().map(|v| v * v).sum::<f64>() / e.len() as f64).sqrt()
}

/// Autocorrelation of `e` (mean removed) at `lag`.
pub fn autocorrelation(e: &[f64], lag: usize) -> f64 {
    let n = e.len();
    if n <= lag + 1 {
        return 0.0;
    }
    let mean = e.iter().sum::<f64>() / n as f64;
    let var: f64 = e.iter().map(|v| (v - mean).powi(2)).sum();
    if var <= 0.0 {
        return 0.0;
    }
    let cov: f64 = (lag..n).map(|i| (e[i] - mean) * (e[i - lag] - mean)).sum();
    cov / var
}

/// Sample size worth of independent information in `n` AR(1)-like residuals with lag-1 correlation ρ:
/// n·(1 − ρ)/(1 + ρ), at least 10 (or n when smaller). Dense logs are strongly correlated; counting every
/// sample would make any candidate "significant".
pub fn effective_n(e: &[f64]) -> f64 {
    let n = e.len() as f64;
    let rho = autocorrelation(e, 1).clamp(0.0, 0.99);
    (n * (1.0 - rho) / (1.0 + rho)).max(n.min(10.0))
}

/// Ljung–Box test of whiteness at the 5 % level over `lags` lags: Q = n(n+2) Σ ρ²ₖ/(n−k) against the
/// χ² quantile (Wilson–Hilferty approximation). True when no autocorrelation is detected.
pub fn ljung_box_white(e: &[f64], lags: usize) -> bool {
    let n = e.len();
    if n <= lags + 2 {
        return true;
    }
    let nf = n as f64;
    let q: f64 = (1..=lags)
        .map(|k| autocorrelation(e, k).powi(2) / (nf - k as f64))
        .sum::<f64>()
        * nf
        * (nf + 2.0);
    q < chi2_quantile_95(lags as f64)
}

/// 95 % quantile of χ² with `k` degrees of freedom (Wilson–Hilferty; within 1 % for k ≥ 3).
fn chi2_quantile_95(k: f64) -> f64 {
    let z = 1.644_853_6;
    let a = 2.0 / (9.0 * k);
    k * (1.0 - a + z * a.sqrt()).powi(3)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::synth::Rng;

    #[test]
    fn stats_of_a_known_series() {
        let e: Vec<f64> = (1..=100)
            .map(|i| if i % 2 == 0 { i as f64 } else { -(i as f64) })
            .collect();
        let s = ErrorStats::of(&e).unwrap();
        assert_eq!(s.max_um, 100.0);
        assert_eq!(s.p95_um, 95.0);
        assert!((s.rms_um - (338350.0f64 / 100.0).sqrt()).abs() < 1e-9);
        assert!(ErrorStats::of(&[]).is_none());
    }

    #[test]
    fn white_noise_is_white_and_a_random_walk_is_not() {
        let mut rng = Rng::new(3);
        let noise: Vec<f64> = (0..2000).map(|_| rng.normal()).collect();
        assert!(ljung_box_white(&noise, 10));
        assert!(effective_n(&noise) > 1800.0);
        let walk: Vec<f64> = noise
            .iter()
            .scan(0.0, |s, v| {
                *s += v;
                Some(*s)
            })
            .collect();
        assert!(!ljung_box_white(&walk, 10));
        assert!(effective_n(&walk) < 100.0);
        assert!((chi2_quantile_95(10.0) - 18.307).abs() < 0.1);
    }
}
