//! Scores of a prediction on a forward holdout (the later rows): the uncompensated drift, the
//! model's error, and — with a probing interval — the error when a probe re-zeroes the correction every P
//! minutes, with and without the model. The compensation rate is 1 − RMS / RMS uncompensated.

use serde::Serialize;

use crate::data::Dataset;

use super::stats::ErrorStats;
use crate::model::probing::{Probing, rezeroed};

/// One prediction scored on the holdout rows.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HoldoutScore {
    /// Holdout rows with a reading.
    pub rows: usize,
    /// The reading minus its run's first reading: the machine without compensation.
    pub uncompensated: ErrorStats,
    /// Reading minus prediction.
    pub model: ErrorStats,
    /// With a probing interval: the model's error re-zeroed at every probing.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model_probed: Option<ErrorStats>,
    /// With a probing interval: the uncompensated drift re-zeroed at every probing (probe, no model).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub probe_only: Option<ErrorStats>,
}

/// 1 − RMS(error) / RMS(uncompensated).
pub fn rate(error: &ErrorStats, uncompensated: &ErrorStats) -> f64 {
    1.0 - error.rms_um / uncompensated.rms_um
}

impl HoldoutScore {
    /// Scores `predicted` (one value per row) against `measured` on the rows marked `scored`; with
    /// `probing`, probings from each run's first scored reading (the probe alone only re-zeroes: a trend
    /// gain belongs to a model's correction). `None` when no scored row has a reading.
    pub fn of(
        ds: &Dataset,
        measured: &[f64],
        predicted: &[f64],
        scored: &[bool],
        probing: Option<Probing>,
    ) -> Option<HoldoutScore> {
        let runs: Vec<_> = ds.runs().collect();
        let mut uncomp = vec![f64::NAN; ds.len()];
        for r in &runs {
            if let Some(first) = measured[r.clone()].iter().copied().find(|v| !v.is_nan()) {
                for i in r.clone() {
                    uncomp[i] = measured[i] - first;
                }
            }
        }
        let err: Vec<f64> = measured.iter().zip(predicted).map(|(m, p)| m - p).collect();
        let rows: Vec<usize> = (0..ds.len())
            .filter(|&i| scored[i] && !measured[i].is_nan())
            .collect();
        let held = |e: &[f64]| -> Option<ErrorStats> {
            ErrorStats::of(&rows.iter().map(|&i| e[i]).collect::<Vec<_>>())
        };
        let probed = |e: &[f64], p: Probing| held(&rezeroed(&ds.time_min, &runs, e, scored, p));
        Some(HoldoutScore {
            rows: rows.len(),
            uncompensated: held(&uncomp)?,
            model: held(&err)?,
            model_probed: probing.and_then(|p| probed(&err, p)),
            probe_only: probing.and_then(|p| probed(&uncomp, Probing::every(p.every_min))),
        })
    }
}
