//! `driftloop sensors`: which temperature sensors explain a displacement channel, and a linear regression
//! on them (the third source paper's two strategies).
//!
//! 1. Main factors: the Pearson correlation of every `*_c` column (as measured) with the error.
//! 2. Irrelevance: mutually correlated sensors are clustered ([`cluster::clusters`]); per cluster the one
//!    most correlated with the error is kept, and clusters whose best |r| is below `min_correlation` are
//!    dropped as irrelevant.
//! 3. Multiple linear regression on the kept sensors ([`stats::least_squares`]), validated leave-one-run-out
//!    when the data has runs, else on a time holdout.
//!
//! The regression is written in the form a driftloop model file evaluates exactly, so `predict` reproduces
//! it: E(i) = b₀ + Σⱼ bⱼ·(θⱼ(i) − θⱼ(run start)). Each sensor enters at its own row, relative to its value
//! at the start of the run (a model's runs start from rest; on the machine, the zero measurement). In the
//! model file b₀ is `offset_um` and each sensor a `static_input` effect
//! ([`crate::model::effects::static_input`]); the position variant ([`position`]) adds `input_slope` and
//! `geometric` terms.
//!
//! Model files of earlier versions stored each sensor as an `inputs` entry with τ = 1e-9 min (a static gain
//! one row late); they are still read and predict what they predicted then.

pub mod cluster;
pub mod position;
pub mod stats;
pub mod synth;

use std::ops::Range;

use nalgebra::DMatrix;
use serde::Serialize;

use crate::data::{ColumnKind, Dataset};
use crate::model::effects::{Effect, Kind};
use crate::model::{
    DataProvenance, DriftModel, Extrapolation, Interpolation, SCHEMA, SpindleModes,
};

#[derive(Debug, Clone)]
pub struct Options {
    pub channel: String,
    /// Sensors with |r| at least this are one cluster (complete linkage on 1 − |r|).
    pub threshold: f64,
    /// A cluster whose best sensor correlates less than this with the error is irrelevant.
    pub min_correlation: f64,
    /// Time holdout start (minutes) when the data has no runs; default: the last third of the time span.
    pub holdout_from_min: Option<f64>,
}

impl Options {
    fn check(&self) -> Result<(), SensorError> {
        if (0.0..=1.0).contains(&self.threshold) && (0.0..=1.0).contains(&self.min_correlation) {
            Ok(())
        } else {
            Err(SensorError::BadThreshold)
        }
    }

    pub fn new(channel: &str) -> Options {
        Options {
            channel: channel.to_string(),
            threshold: 0.9,
            min_correlation: 0.5,
            holdout_from_min: None,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum SensorError {
    #[error("no displacement channel `{0}` in the data")]
    NoChannel(String),
    #[error("the data has no temperature columns (`*_c`)")]
    NoSensors,
    #[error("--threshold and --min-correlation must lie in [0, 1]")]
    BadThreshold,
    #[error("{0}")]
    Validation(String),
    #[error(
        "the regression on {0:?} cannot be solved (too few rows or linearly dependent sensors in the training part)"
    )]
    Singular(Vec<String>),
}

/// A sensor's correlation with the error.
#[derive(Debug, Clone, Serialize)]
pub struct Factor {
    pub sensor: String,
    pub r: f64,
}

/// One cluster of mutually correlated sensors and the one kept from it (if any).
#[derive(Debug, Clone, Serialize)]
pub struct Cluster {
    pub sensors: Vec<String>,
    pub kept: Option<String>,
    /// Why a cluster is dropped, or `None` when its sensor was kept.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dropped: Option<String>,
}

impl Cluster {
    /// `keep SENSOR`, or `drop (why)`, as the reports print it.
    pub fn verdict(&self) -> String {
        match (&self.kept, &self.dropped) {
            (Some(k), _) => format!("keep {k}"),
            (None, Some(why)) => format!("drop ({why})"),
            (None, None) => "drop".into(),
        }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct Coefficient {
    /// `offset` for the intercept, else the sensor.
    pub term: String,
    /// µm (offset) or µm per °C.
    pub value: f64,
    pub se: f64,
}

/// Errors on one part of the data: the compensation rate is 1 − RMS(residual)/RMS(uncompensated), where
/// uncompensated is the error relative to its value at the start of its run.
#[derive(Debug, Clone, Serialize)]
pub struct Score {
    pub samples: usize,
    pub uncompensated_rms_um: f64,
    pub residual_rms_um: f64,
    pub residual_max_um: f64,
    pub compensation_rate: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Validation {
    /// `leave-one-run-out` or `time-holdout`.
    pub scheme: String,
    /// Start of the time holdout in minutes (time holdout only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub holdout_from_min: Option<f64>,
    /// Whether the holdout start was the default (last third of the time span).
    pub default_holdout: bool,
    pub score: Score,
}

#[derive(Debug, Clone, Serialize)]
pub struct Analysis {
    pub channel: String,
    pub threshold: f64,
    pub min_correlation: f64,
    /// Rows the selection and the regression were computed on.
    pub training_samples: usize,
    pub factors: Vec<Factor>,
    /// Sensor × sensor correlations, in the order of `factors`.
    pub correlation: Vec<Vec<f64>>,
    pub clusters: Vec<Cluster>,
    pub chosen: Vec<String>,
    pub coefficients: Vec<Coefficient>,
    pub fit: Score,
    pub validation: Validation,
    #[serde(skip)]
    prediction: Vec<f64>,
    #[serde(skip)]
    provenance: DataProvenance,
}

/// The regressors: each sensor relative to its run-start value (see the module comment).
fn regressors(ds: &Dataset, values: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; values.len()];
    for run in ds.runs() {
        for i in run.clone() {
            out[i] = values[i] - values[run.start];
        }
    }
    out
}

/// The error relative to its value at the start of its run: what the machine drifts without compensation.
fn uncompensated(ds: &Dataset, e: &[f64]) -> Vec<f64> {
    let mut out = vec![f64::NAN; e.len()];
    for run in ds.runs() {
        // Against the run's first reading (a row without one, NaN, stays NaN and is never scored).
        let first = run.clone().map(|i| e[i]).find(|v| !v.is_nan());
        for i in run {
            out[i] = e[i] - first.unwrap_or(f64::NAN);
        }
    }
    out
}

struct Inputs<'a> {
    names: Vec<String>,
    /// The sensors as measured: what the selection correlates.
    raw: Vec<&'a [f64]>,
    /// The regressors.
    x: Vec<Vec<f64>>,
    e: &'a [f64],
    drift: Vec<f64>,
}

impl Inputs<'_> {
    fn gather<'a>(ds: &'a Dataset, channel: &str) -> Result<Inputs<'a>, SensorError> {
        let e = ds
            .column(channel)
            .filter(|c| c.kind == ColumnKind::Displacement)
            .map(|c| c.values.as_slice())
            .ok_or_else(|| SensorError::NoChannel(channel.to_string()))?;
        let sensors: Vec<_> = ds
            .columns
            .iter()
            .filter(|c| c.kind == ColumnKind::Temperature)
            .collect();
        let names: Vec<String> = sensors.iter().map(|c| c.name.clone()).collect();
        let raw = sensors.iter().map(|c| c.values.as_slice()).collect();
        let x = sensors.iter().map(|c| regressors(ds, &c.values)).collect();
        if names.is_empty() {
            return Err(SensorError::NoSensors);
        }
        Ok(Inputs {
            names,
            raw,
            x,
            e,
            drift: uncompensated(ds, e),
        })
    }
}

fn pick(v: &[f64], rows: &[usize]) -> Vec<f64> {
    rows.iter().map(|&i| v[i]).collect()
}

/// Main factors, correlation matrix, clusters and the kept sensors (indices).
struct Selection {
    factors: Vec<f64>,
    correlation: Vec<Vec<f64>>,
    clusters: Vec<Vec<usize>>,
    kept: Vec<Option<usize>>,
}

/// Clusters the sensor series and keeps per cluster the one of highest `importance` (|r| with what is to
/// be explained), unless even that is below `min_correlation`.
fn choose(sensors: &[Vec<f64>], importance: Vec<f64>, opts: &Options) -> Selection {
    let correlation: Vec<Vec<f64>> = sensors
        .iter()
        .map(|a| sensors.iter().map(|b| stats::pearson(a, b)).collect())
        .collect();
    let clusters = cluster::clusters(&correlation, opts.threshold);
    let kept = clusters
        .iter()
        .map(|g| {
            let best = *g
                .iter()
                .max_by(|&&a, &&b| importance[a].total_cmp(&importance[b]))
                .expect("clusters are never empty");
            (importance[best] >= opts.min_correlation).then_some(best)
        })
        .collect();
    Selection {
        factors: importance,
        correlation,
        clusters,
        kept,
    }
}

impl Selection {
    fn chosen(&self) -> Vec<usize> {
        self.kept.iter().flatten().copied().collect()
    }

    fn describe(&self, names: &[String], min_correlation: f64) -> Vec<Cluster> {
        self.clusters
            .iter()
            .zip(&self.kept)
            .map(|(g, kept)| Cluster {
                sensors: g.iter().map(|&j| names[j].clone()).collect(),
                kept: kept.map(|j| names[j].clone()),
                dropped: kept.is_none().then(|| {
                    format!(
                        "irrelevant: best |r| {:.3} < {min_correlation}",
                        g.iter().map(|&j| self.factors[j]).fold(0.0, f64::max),
                    )
                }),
            })
            .collect()
    }
}

fn select(inp: &Inputs, rows: &[usize], opts: &Options) -> (Vec<f64>, Selection) {
    let e = pick(inp.e, rows);
    // The sensors as measured, not the regressors: a noisy run-start reading shifts a whole run of the
    // regressor and would split a redundant group when the data has several runs.
    let x: Vec<Vec<f64>> = inp.raw.iter().map(|c| pick(c, rows)).collect();
    let r: Vec<f64> = x.iter().map(|c| stats::pearson(c, &e)).collect();
    let sel = choose(&x, r.iter().map(|v| v.abs()).collect(), opts);
    (r, sel)
}

/// Regression of the error on the chosen sensors over `rows`.
fn regress(
    inp: &Inputs,
    chosen: &[usize],
    rows: &[usize],
) -> Result<stats::LeastSquares, SensorError> {
    let x = DMatrix::from_fn(rows.len(), chosen.len() + 1, |r, c| {
        if c == 0 {
            1.0
        } else {
            inp.x[chosen[c - 1]][rows[r]]
        }
    });
    stats::least_squares(&x, &pick(inp.e, rows)).ok_or_else(|| {
        SensorError::Singular(chosen.iter().map(|&j| inp.names[j].clone()).collect())
    })
}

fn predict_row(inp: &Inputs, chosen: &[usize], beta: &[f64], i: usize) -> f64 {
    beta[0]
        + chosen
            .iter()
            .zip(&beta[1..])
            .map(|(&j, b)| b * inp.x[j][i])
            .sum::<f64>()
}

fn score(inp: &Inputs, rows: &[usize], prediction: impl Fn(usize) -> f64) -> Score {
    let resid: Vec<f64> = rows.iter().map(|&i| inp.e[i] - prediction(i)).collect();
    Score::of(&resid, &pick(&inp.drift, rows))
}

impl Score {
    /// Scores residuals against the uncompensated error of the same rows.
    fn of(resid: &[f64], uncompensated: &[f64]) -> Score {
        let (u, r) = (stats::rms(uncompensated), stats::rms(resid));
        Score {
            samples: resid.len(),
            uncompensated_rms_um: u,
            residual_rms_um: r,
            residual_max_um: resid.iter().fold(0.0, |m, v| f64::max(m, v.abs())),
            compensation_rate: if u > 0.0 { 1.0 - r / u } else { 0.0 },
        }
    }
}

fn rows_of(ranges: impl Iterator<Item = Range<usize>>) -> Vec<usize> {
    ranges.flatten().collect()
}

/// Runs both strategies and the regression on `ds`. With runs (a `run` column with ≥ 2 runs) the sensors
/// are chosen and the regression fitted on all runs, and validated by repeating the selection and the
/// regression with each run left out in turn and predicting that run. Without runs everything is computed on the rows before the holdout
/// start and validated on the rows from it on.
pub fn analyse(ds: &Dataset, opts: &Options) -> Result<Analysis, SensorError> {
    opts.check()?;
    let inp = Inputs::gather(ds, &opts.channel)?;
    let n = ds.len();
    let runs: Vec<Range<usize>> = ds.runs().collect();
    let by_run = ds.run_labels.is_some() && runs.len() >= 2;
    // The regression is static (each row on its own): a row without a reading takes no part.
    let read = |i: &usize| !inp.e[*i].is_nan();
    let (train, holdout, holdout_from, default_holdout) = if by_run {
        (
            (0..n).filter(read).collect::<Vec<_>>(),
            Vec::new(),
            None,
            false,
        )
    } else {
        let t = &ds.time_min;
        let (t0, t1) = (t[0], t[n - 1]);
        let from = opts.holdout_from_min.unwrap_or(t0 + (t1 - t0) * 2.0 / 3.0);
        let train: Vec<usize> = (0..n).filter(|i| t[*i] < from && read(i)).collect();
        let holdout: Vec<usize> = (0..n).filter(|i| t[*i] >= from && read(i)).collect();
        if train.len() < 3 || holdout.is_empty() {
            return Err(SensorError::Validation(format!(
                "the holdout from {from} min leaves {} training and {} holdout rows",
                train.len(),
                holdout.len()
            )));
        }
        (train, holdout, Some(from), opts.holdout_from_min.is_none())
    };
    let (r, sel) = select(&inp, &train, opts);
    let chosen = sel.chosen();
    let fit = regress(&inp, &chosen, &train)?;
    let fit_score = score(&inp, &train, |i| predict_row(&inp, &chosen, &fit.beta, i));
    let validation = if by_run {
        let mut prediction = vec![0.0; n];
        for (k, run) in runs.iter().enumerate() {
            let others = rows_of(
                runs.iter()
                    .enumerate()
                    .filter(|(j, _)| *j != k)
                    .map(|(_, r)| r.clone()),
            )
            .into_iter()
            .filter(read)
            .collect::<Vec<_>>();
            // The left-out run must not influence which sensors are chosen, or the score is optimistic.
            let fold = select(&inp, &others, opts).1.chosen();
            let part = regress(&inp, &fold, &others)?;
            for i in run.clone() {
                prediction[i] = predict_row(&inp, &fold, &part.beta, i);
            }
        }
        Validation {
            scheme: "leave-one-run-out".into(),
            holdout_from_min: None,
            default_holdout: false,
            score: score(&inp, &train, |i| prediction[i]),
        }
    } else {
        Validation {
            scheme: "time-holdout".into(),
            holdout_from_min: holdout_from,
            default_holdout,
            score: score(&inp, &holdout, |i| predict_row(&inp, &chosen, &fit.beta, i)),
        }
    };
    let names = &inp.names;
    let clusters = sel.describe(names, opts.min_correlation);
    let coefficients = std::iter::once("offset".to_string())
        .chain(chosen.iter().map(|&j| names[j].clone()))
        .zip(fit.beta.iter().zip(&fit.se))
        .map(|(term, (&value, &se))| Coefficient { term, value, se })
        .collect();
    Ok(Analysis {
        channel: opts.channel.clone(),
        threshold: opts.threshold,
        min_correlation: opts.min_correlation,
        training_samples: train.len(),
        factors: names
            .iter()
            .zip(&r)
            .map(|(s, &r)| Factor {
                sensor: s.clone(),
                r,
            })
            .collect(),
        correlation: sel.correlation,
        clusters,
        chosen: chosen.iter().map(|&j| names[j].clone()).collect(),
        coefficients,
        fit: fit_score,
        validation,
        prediction: (0..n)
            .map(|i| predict_row(&inp, &chosen, &fit.beta, i))
            .collect(),
        provenance: provenance(ds),
    })
}

/// A regression as a driftloop model: no spindle modes, the offset and the regression's terms.
fn regression_model(
    channel: &str,
    offset_um: f64,
    terms: impl Iterator<Item = Effect>,
    provenance: &DataProvenance,
) -> DriftModel {
    DriftModel {
        schema: SCHEMA,
        channel: channel.to_string(),
        offset_um,
        spindle: SpindleModes {
            grid_rpm: Vec::new(),
            interpolation: Interpolation::PiecewiseLinear,
            extrapolation: Extrapolation::LinearLastSegment,
            characterised_top_rpm: None,
            modes: Vec::new(),
        },
        inputs: Vec::new(),
        effects: terms.map(|e| e.to_spec()).collect(),
        fit: None,
        data: Some(provenance.clone()),
    }
}

/// One regression term per sensor coefficient (`offset` skipped): `kind` with the sensor as its signal.
fn sensor_terms<'a>(
    coefficients: &'a [Coefficient],
    kind: Kind,
    position: Option<&'a str>,
) -> impl Iterator<Item = Effect> + 'a {
    coefficients[1..].iter().map(move |c| Effect {
        kind,
        signal: Some(c.term.clone()),
        position: position.map(str::to_string),
        theta: Vec::new(),
        amplitudes: vec![c.value],
    })
}

fn provenance(ds: &Dataset) -> DataProvenance {
    DataProvenance {
        file: ds.source.clone(),
        sha256: ds.sha256.clone().unwrap_or_default(),
        rows: ds.len(),
        time_unit: ds.time_unit,
    }
}

impl Analysis {
    /// The regression fitted on the training rows, predicting every row of the data (µm).
    pub fn prediction(&self) -> &[f64] {
        &self.prediction
    }

    /// The regression as a driftloop model: no spindle modes, the intercept as `offset_um`, one
    /// `static_input` term per chosen sensor.
    pub fn to_model(&self) -> DriftModel {
        regression_model(
            &self.channel,
            self.coefficients[0].value,
            sensor_terms(&self.coefficients, Kind::StaticInput, None),
            &self.provenance,
        )
    }

    pub fn json(&self) -> String {
        serde_json::to_string_pretty(self).expect("the analysis serialises") + "\n"
    }
}

mod report;
mod text;
