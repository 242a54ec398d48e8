//! Forward (rolling-origin) validation: every data-driven choice is scored by fitting on earlier time and
//! predicting later time, never the reverse — the way a model is used on tomorrow's jobs.
//!
//! Time runs through the rows in file order: a file of several runs (characterisation runs, then
//! production jobs) is taken as recorded in that order, each run laid after the one before it on one
//! elapsed-time axis. An origin at elapsed time o trains on every usable row before o and scores on every
//! usable row from o to the end of the window, so the later stretches are predicted at every horizon the
//! window offers and count in every fold that reaches them.

use crate::data::Dataset;
use crate::model::DriftModel;

/// One fold: rows (indices into the data) to fit on and rows to score.
#[derive(Debug, Clone, PartialEq)]
pub struct Fold {
    /// Elapsed time (min) the fold's test rows start at.
    pub origin_min: f64,
    pub train: Vec<usize>,
    pub test: Vec<usize>,
}

/// Where the origins go: `count` origins evenly from `first` (a fraction of the window's elapsed span) to
/// its end, the last one `1 / count` of the remaining span before the end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Origins {
    pub count: usize,
    pub first: f64,
}

impl Default for Origins {
    /// Four origins from half the window on: the shortest training stretch is half the data, and the
    /// last fold still scores an eighth of it.
    fn default() -> Origins {
        Origins {
            count: 4,
            first: 0.5,
        }
    }
}

/// Elapsed minutes of every row: time since its run's first row, plus the durations of the runs before.
pub fn elapsed(ds: &Dataset) -> Vec<f64> {
    let mut out = vec![0.0; ds.len()];
    let mut before = 0.0;
    for run in ds.runs() {
        if run.is_empty() {
            continue;
        }
        let t0 = ds.time_min[run.start];
        for i in run.clone() {
            out[i] = before + ds.time_min[i] - t0;
        }
        // A run's last row is where the next one starts: a gap of one sampling step would be arbitrary.
        before += ds.time_min[run.end - 1] - t0;
    }
    out
}

impl Origins {
    /// The origins' elapsed times for a window whose usable rows span `lo..hi` (minutes).
    pub fn times(&self, lo: f64, hi: f64) -> Vec<f64> {
        let span = hi - lo;
        (0..self.count)
            .map(|k| lo + span * (self.first + (1.0 - self.first) * k as f64 / self.count as f64))
            .collect()
    }

    /// The folds over the rows marked `usable` (a reading, inside the window), each with at least one
    /// training and one test row.
    pub fn folds(&self, elapsed: &[f64], usable: &[bool]) -> Vec<Fold> {
        let rows: Vec<usize> = (0..elapsed.len()).filter(|&i| usable[i]).collect();
        let (Some(&a), Some(&b)) = (rows.first(), rows.last()) else {
            return Vec::new();
        };
        self.times(elapsed[a], elapsed[b])
            .into_iter()
            .filter_map(|o| {
                let (train, test): (Vec<usize>, Vec<usize>) =
                    rows.iter().partition(|&&i| elapsed[i] < o);
                (!train.is_empty() && !test.is_empty()).then_some(Fold {
                    origin_min: o,
                    train,
                    test,
                })
            })
            .collect()
    }

    /// The stretches between consecutive origins (first before the first origin, last from the last
    /// origin on), for adding up statistics once per stretch: fold k trains on stretches `..=k` and tests
    /// on stretches `k + 1..`.
    pub fn stretches(&self, elapsed: &[f64], usable: &[bool]) -> Vec<Vec<usize>> {
        let rows: Vec<usize> = (0..elapsed.len()).filter(|&i| usable[i]).collect();
        let (Some(&a), Some(&b)) = (rows.first(), rows.last()) else {
            return Vec::new();
        };
        let origins = self.times(elapsed[a], elapsed[b]);
        let mut out = vec![Vec::new(); origins.len() + 1];
        for i in rows {
            let k = origins.partition_point(|&o| o <= elapsed[i]);
            out[k].push(i);
        }
        out
    }
}

/// The forward RMS (µm) of a whole fitting procedure on the default folds of `ds`'s rows of `channel`: each
/// fold runs `fit` on the rows before its origin (a time on the data's own clock, as `--until`) and
/// predicts the rows from it on; the RMS pools every fold's test rows. Two procedures (two model kinds)
/// compared this way are each judged as they are used: fitted on the past, scored on the future. `None`
/// where the rows are several runs (their clock starts again), a fold's fit fails, or no fold fits.
pub fn procedure_rms(
    ds: &Dataset,
    channel: &str,
    fit: impl Fn(f64) -> Option<DriftModel>,
) -> Option<f64> {
    let y = ds.values(channel)?;
    let el = elapsed(ds);
    let t0 = *ds.time_min.first()?;
    if el
        .iter()
        .zip(&ds.time_min)
        .any(|(e, t)| (e + t0 - t).abs() > 1e-6)
    {
        return None;
    }
    let (mut sse, mut n) = (0.0, 0usize);
    for fold in Origins::default().folds(&el, &crate::data::measured(y)) {
        let predicted = fit(fold.origin_min + t0)?.predict(ds).ok()?;
        for &i in &fold.test {
            sse += (y[i] - predicted[i]).powi(2);
            n += 1;
        }
    }
    (n > 0).then(|| (sse / n as f64).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::TimeUnit;

    #[test]
    fn runs_are_laid_end_to_end_in_file_order() {
        let mut ds = Dataset::new("x", TimeUnit::Min, vec![0.0, 10.0, 20.0, 5.0, 15.0]);
        ds.run_starts = vec![0, 3];
        assert_eq!(elapsed(&ds), vec![0.0, 10.0, 20.0, 20.0, 30.0]);
    }

    #[test]
    fn folds_train_before_the_origin_and_test_after_it() {
        let t: Vec<f64> = (0..=80).map(f64::from).collect();
        let usable: Vec<bool> = (0..=80).map(|i| i % 10 != 3).collect();
        let o = Origins::default();
        assert_eq!(o.times(0.0, 80.0), vec![40.0, 50.0, 60.0, 70.0]);
        let folds = o.folds(&t, &usable);
        assert_eq!(folds.len(), 4);
        for f in &folds {
            assert!(f.train.iter().all(|&i| t[i] < f.origin_min && usable[i]));
            assert!(f.test.iter().all(|&i| t[i] >= f.origin_min && usable[i]));
            assert_eq!(
                f.train.len() + f.test.len(),
                usable.iter().filter(|u| **u).count()
            );
        }
        let s = o.stretches(&t, &usable);
        assert_eq!(s.len(), 5);
        // Fold k trains on the stretches up to k and tests on the rest.
        for (k, f) in folds.iter().enumerate() {
            let train: Vec<usize> = s[..=k].concat();
            assert_eq!(train, f.train);
            assert_eq!(s[k + 1..].concat(), f.test);
        }
    }
}
