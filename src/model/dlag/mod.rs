//! A distributed-lag model over the sensors the machine has (`fit --kind dlag`): every temperature column,
//! as a change from its value at the run's start, at several first-order lags (0, 15 min, 1 h, 4 h by
//! default), plus the spindle speed through a power law gain ∝ (n / n_top)^p at several lags; ridge
//! regression on standardised columns.
//!
//! Every data-driven choice — the penalty, the speed law's exponent p, the lag sets — is made by forward
//! validation ([`super::forward`]): fitted on the rows before each origin, scored on the rows after it, the
//! design with the lowest pooled forward RMS wins. The fold that trains on the lower speeds only and scores
//! a higher one is what chooses p: the law is judged on a speed it was not trained on, as it will be on the
//! machine.
//!
//! The fitted model is written as a plain model file ([`basis`]): `static_input` and `input_lag` effects
//! for the sensors, spindle modes whose grid gains follow the law (extra nodes above the top characterised
//! speed) for the spindle, so `predict`, `plan` and `transform` evaluate it with nothing new.

pub mod basis;

use serde::{Deserialize, Serialize};

use crate::data::{ColumnKind, Dataset, SPINDLE};

use super::fit::{FitError, max_abs, rms};
use super::forward::{Origins, elapsed};
use super::ridge::{Coefficients, Moments, Ridge};
use super::speed_grid::SpeedGrid;
use super::speed_law::PowerLaw;
use super::{
    DataProvenance, DriftModel, Extrapolation, FitSummary, Interpolation, RunStats, SCHEMA,
    SpindleModes,
};
use basis::{LawGrid, Term, column, effect_specs};

/// What `fit --kind dlag` fits and which designs forward validation chooses among.
#[derive(Debug, Clone, PartialEq)]
pub struct DlagOptions {
    pub channel: String,
    /// Fit only rows before this time (minutes).
    pub until_min: Option<f64>,
    /// Sensor columns; `None`: every temperature (`*_c`) column that varies in the window.
    pub signals: Option<Vec<String>>,
    /// Candidate lag sets of the sensors (minutes, 0 = unlagged); forward validation picks one.
    pub sensor_lags: Vec<Vec<f64>>,
    /// Lags of the spindle terms (minutes, each > 0).
    pub spindle_lags: Vec<f64>,
    /// Candidate exponents p of the speed law.
    pub exponents: Vec<f64>,
    /// Candidate penalties (on standardised columns, per row).
    pub penalties: Vec<f64>,
    pub origins: Origins,
}

impl DlagOptions {
    /// The defaults: lags 0, 15 min, 1 h, 4 h for the sensors (or without the 15 min lag, or with 16 h
    /// added), 15 min, 1 h, 4 h for the spindle, p from 0.5 to 3, penalties 10⁻⁶ … 10.
    pub fn new(channel: impl Into<String>) -> DlagOptions {
        DlagOptions {
            channel: channel.into().to_ascii_lowercase(),
            until_min: None,
            signals: None,
            sensor_lags: vec![
                vec![0.0, 15.0, 60.0, 240.0],
                vec![0.0, 60.0, 240.0],
                vec![0.0, 15.0, 60.0, 240.0, 960.0],
            ],
            spindle_lags: vec![15.0, 60.0, 240.0],
            exponents: vec![0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.5, 3.0],
            penalties: (0..=14)
                .map(|i| 10f64.powf(-6.0 + 0.5 * f64::from(i)))
                .collect(),
            origins: Origins::default(),
        }
    }
}

/// How the design was chosen, written into the model file's `[fit.forward]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ForwardSelection {
    /// Elapsed minutes (from the first row, runs laid end to end) of the validation origins.
    pub origins_min: Vec<f64>,
    pub signals: Vec<String>,
    pub sensor_lags_min: Vec<f64>,
    pub spindle_lags_min: Vec<f64>,
    /// p of the speed law (absent without spindle terms).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exponent: Option<f64>,
    pub penalty: f64,
    /// Pooled forward RMS of the chosen design.
    pub cv_rms_um: f64,
    /// Effective degrees of freedom of the final fit.
    pub dof: f64,
    /// Every design tried, with its best penalty.
    pub trials: Vec<DesignTrial>,
}

/// One design scored by forward validation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DesignTrial {
    pub sensor_lags_min: Vec<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exponent: Option<f64>,
    pub penalty: f64,
    pub cv_rms_um: f64,
}

/// The window's data laid out for the search.
struct Prepared<'a> {
    ds: &'a Dataset,
    y: Vec<f64>,
    usable: Vec<bool>,
    signals: Vec<String>,
    /// Characterised speeds (grid of the window's logged speeds); empty without spindle terms.
    characterised: Vec<f64>,
    stretches: Vec<Vec<usize>>,
    origins_min: Vec<f64>,
}

/// Fits the distributed-lag model of `opts.channel`.
pub fn fit_dlag(all: &Dataset, opts: &DlagOptions) -> Result<DriftModel, FitError> {
    let windowed;
    let ds = match opts.until_min {
        Some(u) => {
            windowed = all.until(u);
            &windowed
        }
        None => all,
    };
    let prep = Prepared::new(ds, opts)?;
    let exponents: Vec<Option<f64>> = if prep.characterised.is_empty() {
        vec![None]
    } else {
        opts.exponents.iter().copied().map(Some).collect()
    };
    let mut trials = Vec::new();
    for lags in &opts.sensor_lags {
        let sensor_cols: Vec<Vec<f64>> = prep
            .sensor_terms(lags)
            .iter()
            .map(|t| column(ds, t, None))
            .collect();
        for &p in &exponents {
            let (terms, law) = prep.terms(lags, &opts.spindle_lags, p);
            let mut cols = sensor_cols.clone();
            cols.extend(
                terms[sensor_cols.len()..]
                    .iter()
                    .map(|t| column(ds, t, law.as_ref())),
            );
            if let Some((penalty, cv)) = prep.validate(&cols, &opts.penalties) {
                trials.push(DesignTrial {
                    sensor_lags_min: lags.clone(),
                    exponent: p,
                    penalty,
                    cv_rms_um: cv,
                });
            }
        }
    }
    let best = trials
        .iter()
        .min_by(|a, b| a.cv_rms_um.total_cmp(&b.cv_rms_um))
        .cloned()
        .ok_or(FitError::TooFewSamples {
            samples: prep.rows().len(),
            needed: 2 * opts.origins.count.max(1),
        })?;
    let (terms, law) = prep.terms(&best.sensor_lags_min, &opts.spindle_lags, best.exponent);
    let cols: Vec<Vec<f64>> = terms.iter().map(|t| column(ds, t, law.as_ref())).collect();
    let rows = prep.rows();
    let fit = Ridge::new(&Moments::of_rows(&cols, &prep.y, &rows))
        .ok_or(FitError::Numerical)?
        .solve(best.penalty);
    let selection = ForwardSelection {
        origins_min: prep.origins_min.clone(),
        signals: prep.signals.clone(),
        sensor_lags_min: best.sensor_lags_min.clone(),
        spindle_lags_min: if law.is_some() {
            opts.spindle_lags.clone()
        } else {
            Vec::new()
        },
        exponent: best.exponent,
        penalty: best.penalty,
        cv_rms_um: best.cv_rms_um,
        dof: fit.dof,
        trials,
    };
    Ok(prep.model(
        all.len(),
        opts,
        &terms,
        law.as_ref(),
        &cols,
        &fit,
        selection,
    ))
}

impl<'a> Prepared<'a> {
    fn new(ds: &'a Dataset, opts: &DlagOptions) -> Result<Prepared<'a>, FitError> {
        let y = ds
            .column(&opts.channel)
            .filter(|c| c.kind == ColumnKind::Displacement)
            .ok_or_else(|| FitError::NoChannel {
                source_name: ds.source.clone(),
                channel: opts.channel.clone(),
                available: ds
                    .channels()
                    .map(|c| c.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })?
            .values
            .clone();
        let usable = crate::data::measured(&y);
        let varies = |v: &[f64]| {
            let mut it = (0..v.len()).filter(|&i| usable[i]).map(|i| v[i]);
            it.next()
                .is_some_and(|first| it.any(|x| (x - first).abs() > 1e-12))
        };
        let signals: Vec<String> = match &opts.signals {
            Some(names) => names
                .iter()
                .map(|n| {
                    let c = ds.column(n).ok_or_else(|| FitError::MissingInput {
                        source_name: ds.source.clone(),
                        column: n.to_ascii_lowercase(),
                    })?;
                    match c.kind {
                        ColumnKind::Displacement => Err(FitError::ChannelAsInput(c.name.clone())),
                        _ => Ok(c.name.clone()),
                    }
                })
                .collect::<Result<_, _>>()?,
            None => ds
                .columns
                .iter()
                .filter(|c| c.kind == ColumnKind::Temperature && varies(&c.values))
                .map(|c| c.name.clone())
                .collect(),
        };
        let characterised = ds
            .values(SPINDLE)
            .map(|rpm| {
                let window: Vec<f64> = (0..rpm.len())
                    .filter(|&i| usable[i])
                    .map(|i| rpm[i])
                    .collect();
                SpeedGrid::from_speeds(&window).nodes().to_vec()
            })
            .unwrap_or_default();
        if signals.is_empty() && characterised.is_empty() {
            return Err(FitError::NoInputs);
        }
        let el = elapsed(ds);
        let stretches = opts.origins.stretches(&el, &usable);
        let rows: Vec<usize> = (0..ds.len()).filter(|&i| usable[i]).collect();
        let origins_min = match (rows.first(), rows.last()) {
            (Some(&a), Some(&b)) => opts.origins.times(el[a], el[b]),
            _ => Vec::new(),
        };
        Ok(Prepared {
            ds,
            y,
            usable,
            signals,
            characterised,
            stretches,
            origins_min,
        })
    }

    fn rows(&self) -> Vec<usize> {
        (0..self.usable.len()).filter(|&i| self.usable[i]).collect()
    }

    fn sensor_terms(&self, lags: &[f64]) -> Vec<Term> {
        self.signals
            .iter()
            .flat_map(|s| {
                lags.iter().map(move |&l| Term::Sensor {
                    signal: s.clone(),
                    lag_min: l,
                })
            })
            .collect()
    }

    /// Every term of a design (sensors first) and the speed law's grid, when the design has spindle terms.
    fn terms(
        &self,
        lags: &[f64],
        spindle_lags: &[f64],
        p: Option<f64>,
    ) -> (Vec<Term>, Option<LawGrid>) {
        let mut terms = self.sensor_terms(lags);
        let law = p.and_then(|exponent| {
            let top_rpm = *self.characterised.last()?;
            Some(LawGrid::new(
                PowerLaw { top_rpm, exponent },
                &self.characterised,
            ))
        });
        if law.is_some() {
            terms.extend(spindle_lags.iter().map(|&l| Term::Spindle { lag_min: l }));
        }
        (terms, law)
    }

    /// The best penalty of a design and its pooled forward RMS; `None` when no fold can be fitted.
    fn validate(&self, cols: &[Vec<f64>], penalties: &[f64]) -> Option<(f64, f64)> {
        let parts: Vec<Moments> = self
            .stretches
            .iter()
            .map(|rows| Moments::of_rows(cols, &self.y, rows))
            .collect();
        let mut sse = vec![0.0; penalties.len()];
        let mut scored = 0.0;
        for k in 0..parts.len().saturating_sub(1) {
            let train = sum(&parts[..=k]);
            let test = sum(&parts[k + 1..]);
            if test.n == 0.0 {
                continue;
            }
            let ridge = Ridge::new(&train)?;
            for (s, &lambda) in sse.iter_mut().zip(penalties) {
                *s += test.sse(&ridge.solve(lambda));
            }
            scored += test.n;
        }
        if scored == 0.0 {
            return None;
        }
        let (best, s) = sse.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1))?;
        Some((penalties[best], (s / scored).sqrt()))
    }

    #[allow(clippy::too_many_arguments)]
    fn model(
        &self,
        rows_in_file: usize,
        opts: &DlagOptions,
        terms: &[Term],
        law: Option<&LawGrid>,
        cols: &[Vec<f64>],
        fit: &Coefficients,
        forward: ForwardSelection,
    ) -> DriftModel {
        let ds = self.ds;
        let gains: Vec<f64> = fit.beta.iter().copied().collect();
        let modes = terms
            .iter()
            .zip(&gains)
            .filter_map(|(t, g)| t.mode(*g, law.map_or(&[], |l| l.gains.as_slice())))
            .collect();
        let predicted: Vec<f64> = (0..ds.len())
            .map(|i| fit.intercept + cols.iter().zip(&gains).map(|(c, g)| g * c[i]).sum::<f64>())
            .collect();
        let rows = self.rows();
        let resid: Vec<f64> = rows.iter().map(|&i| self.y[i] - predicted[i]).collect();
        let n = resid.len() as f64;
        let rss: f64 = resid.iter().map(|e| e * e).sum();
        let mean = rows.iter().map(|&i| self.y[i]).sum::<f64>() / n;
        let tss: f64 = rows.iter().map(|&i| (self.y[i] - mean).powi(2)).sum();
        let k = fit.dof + 1.0;
        let ll = n * (rss.max(f64::MIN_POSITIVE) / n).ln();
        let per_run = ds
            .runs()
            .enumerate()
            .map(|(i, r)| {
                let e: Vec<f64> = r
                    .filter(|&j| self.usable[j])
                    .map(|j| self.y[j] - predicted[j])
                    .collect();
                RunStats {
                    run: ds.run_label(i),
                    samples: e.len(),
                    rms_um: rms(&e),
                    max_abs_um: max_abs(&e),
                }
            })
            .collect();
        let lags = terms.iter().map(Term::lag_min).filter(|l| *l > 0.0);
        let tau_bounds_min = [
            lags.clone().fold(f64::INFINITY, f64::min),
            lags.fold(0.0, f64::max),
        ];
        DriftModel {
            schema: SCHEMA,
            channel: opts.channel.clone(),
            offset_um: fit.intercept,
            spindle: SpindleModes {
                grid_rpm: law.map(|l| l.nodes.clone()).unwrap_or_default(),
                interpolation: Interpolation::PiecewiseLinear,
                extrapolation: if law.is_some() {
                    Extrapolation::PowerLaw
                } else {
                    Extrapolation::LinearLastSegment
                },
                characterised_top_rpm: law.map(|l| l.law.top_rpm),
                power_law_exponent: law.map(|l| l.law.exponent),
                modes,
            },
            inputs: Vec::new(),
            effects: effect_specs(terms, &gains),
            fit: Some(FitSummary {
                samples: rows.len(),
                until: opts.until_min.map(|u| ds.time_unit.from_minutes(u)),
                tau_bounds_min: if tau_bounds_min[0].is_finite() {
                    tau_bounds_min
                } else {
                    [0.0, 0.0]
                },
                rms_um: rms(&resid),
                max_abs_um: max_abs(&resid),
                r2: if tss > 0.0 { 1.0 - rss / tss } else { 0.0 },
                sigma_um: (rss / (n - k).max(1.0)).sqrt(),
                bic: ll + k * n.ln(),
                aicc: ll + 2.0 * k + 2.0 * k * (k + 1.0) / (n - k - 1.0).max(1.0),
                selection: "forward-ridge".into(),
                per_run,
                orders: Vec::new(),
                forward: Some(forward),
            }),
            data: Some(DataProvenance {
                file: ds.source.clone(),
                sha256: ds.sha256.clone().unwrap_or_default(),
                rows: rows_in_file,
                time_unit: ds.time_unit,
            }),
        }
    }
}

fn sum(parts: &[Moments]) -> Moments {
    parts[1..].iter().fold(parts[0].clone(), |a, b| a.plus(b))
}
