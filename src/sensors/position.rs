//! The position-dependent variant of the third paper: E = E_G(p) + S(θ)·p + I(θ).
//!
//! Estimation. Rows sharing a time (consecutive, same run) are one time step: the axis was measured at
//! several positions in one thermal state. The first step is the reference state: E_G is the polynomial of
//! degree ≤ 2 (fewer with fewer distinct positions) fitted to its errors, so E_G carries the geometric error
//! plus the reference state's thermal part and S, I are relative to the reference. Every other step's
//! E − E_G(p) is fitted by a line in p, giving S and I per step (a step needs two distinct positions). The
//! sensors per step are their means over the step, each relative to its value at the first row of the run.
//! Sensors are ranked by max(|r(θ, S)|, |r(θ, I)|), clustered like the positionless variant, and S and I
//! are each regressed on the kept sensors. Validation is a time holdout on whole steps.
//!
//! Prediction, in the scores and in the model file alike, is row by row: E(i) = E_G(p(i)) + S(i)·p(i) + I(i)
//! with S and I evaluated on the sensors of row i relative to the run's first row (identical to the step
//! means when the sensors are logged once per state). In the model file ([`PositionAnalysis::to_model`]):
//! `offset_um` = E_G's constant + I's intercept, a `geometric` term with E_G's linear (plus S's intercept)
//! and quadratic coefficients, an `input_slope` per kept sensor (S) and a `static_input` per kept sensor (I).

use nalgebra::DMatrix;
use serde::Serialize;

use super::{
    Cluster, Coefficient, Options, Score, SensorError, choose, provenance, regression_model,
    regressors, sensor_terms, stats,
};
use crate::data::{ColumnKind, Dataset};
use crate::model::effects::{Effect, Kind};
use crate::model::{DataProvenance, DriftModel};

/// A sensor's correlation with the slope and with the intercept across time steps.
#[derive(Debug, Clone, Serialize)]
pub struct PositionFactor {
    pub sensor: String,
    pub r_slope: f64,
    pub r_intercept: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct PositionAnalysis {
    pub channel: String,
    pub position: String,
    pub threshold: f64,
    pub min_correlation: f64,
    /// Time steps (states) in the training part, including the reference.
    pub training_steps: usize,
    /// E_G coefficients, constant first (µm, µm/mm, µm/mm²).
    pub geometric: Vec<f64>,
    pub factors: Vec<PositionFactor>,
    pub correlation: Vec<Vec<f64>>,
    pub clusters: Vec<Cluster>,
    pub chosen: Vec<String>,
    /// S(θ) in µm/mm: `offset` then µm/mm per °C.
    pub slope: Vec<Coefficient>,
    /// I(θ) in µm: `offset` then µm per °C.
    pub intercept: Vec<Coefficient>,
    pub fit: Score,
    /// Time holdout from this time (minutes).
    pub holdout_from_min: f64,
    pub default_holdout: bool,
    pub validation: Score,
    #[serde(skip)]
    prediction: Vec<f64>,
    #[serde(skip)]
    provenance: DataProvenance,
}

/// One thermal state: its rows, time, and per-step means of the sensors' changes since the run start.
struct Step {
    rows: std::ops::Range<usize>,
    t: f64,
    theta: Vec<f64>,
}

fn steps(ds: &Dataset, sensors: &[&[f64]]) -> Vec<Step> {
    let mut out = Vec::new();
    for run in ds.runs() {
        let mut start = run.start;
        while start < run.end {
            let mut end = start + 1;
            while end < run.end && ds.time_min[end] == ds.time_min[start] {
                end += 1;
            }
            let n = (end - start) as f64;
            out.push(Step {
                rows: start..end,
                t: ds.time_min[start],
                theta: sensors
                    .iter()
                    .map(|v| v[start..end].iter().sum::<f64>() / n)
                    .collect(),
            });
            start = end;
        }
    }
    out
}

fn poly(c: &[f64], p: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, k| acc * p + k)
}

/// Least squares of `y` on powers 0..=degree of `p`.
fn poly_fit(p: &[f64], y: &[f64], degree: usize) -> Option<stats::LeastSquares> {
    let x = DMatrix::from_fn(p.len(), degree + 1, |i, j| p[i].powi(j as i32));
    stats::least_squares(&x, y)
}

fn distinct(p: &[f64]) -> usize {
    let mut v = p.to_vec();
    v.sort_by(f64::total_cmp);
    v.dedup();
    v.len()
}

fn coefficients(names: &[String], fit: &stats::LeastSquares) -> Vec<Coefficient> {
    std::iter::once("offset".to_string())
        .chain(names.iter().cloned())
        .zip(fit.beta.iter().zip(&fit.se))
        .map(|(term, (&value, &se))| Coefficient { term, value, se })
        .collect()
}

pub fn analyse_position(
    ds: &Dataset,
    position: &str,
    opts: &Options,
) -> Result<PositionAnalysis, SensorError> {
    opts.check()?;
    let bad = |m: String| SensorError::Validation(m);
    let e = ds
        .column(&opts.channel)
        .filter(|c| c.kind == ColumnKind::Displacement)
        .map(|c| c.values.as_slice())
        .ok_or_else(|| SensorError::NoChannel(opts.channel.clone()))?;
    // The position variant fits each thermal state's points as a whole; a state with a gap has no line.
    let gaps = e.iter().filter(|v| v.is_nan()).count();
    if gaps > 0 {
        return Err(bad(format!(
            "{gaps} rows have no reading of {} (an empty cell): the position variant needs every point of every thermal state measured",
            opts.channel
        )));
    }
    let p = ds
        .values(position)
        .ok_or_else(|| bad(format!("no position column `{position}` in the data")))?;
    let (names, sensors): (Vec<String>, Vec<&[f64]>) = ds
        .columns
        .iter()
        .filter(|c| c.kind == ColumnKind::Temperature)
        .map(|c| (c.name.clone(), c.values.as_slice()))
        .unzip();
    if names.is_empty() {
        return Err(SensorError::NoSensors);
    }
    let change: Vec<Vec<f64>> = sensors.iter().map(|v| regressors(ds, v)).collect();
    let steps = steps(ds, &change.iter().map(Vec::as_slice).collect::<Vec<_>>());
    let reference = &steps[0];
    let ref_p = &p[reference.rows.clone()];
    let degree = distinct(ref_p).saturating_sub(1).min(2);
    if degree == 0 {
        return Err(bad(
            "the first time step (the reference state) needs at least two distinct positions"
                .into(),
        ));
    }
    let geometric = poly_fit(ref_p, &e[reference.rows.clone()], degree)
        .ok_or_else(|| bad("E_G cannot be fitted on the reference state".into()))?
        .beta;
    let thermal: Vec<f64> = (0..e.len())
        .map(|i| e[i] - poly(&geometric, p[i]))
        .collect();
    // S and I per step from a line through E − E_G.
    let mut si = Vec::with_capacity(steps.len());
    for st in &steps {
        let sp = &p[st.rows.clone()];
        if distinct(sp) < 2 {
            return Err(bad(format!(
                "the time step at {} min has fewer than two distinct positions",
                st.t
            )));
        }
        let line = poly_fit(sp, &thermal[st.rows.clone()], 1)
            .ok_or_else(|| bad(format!("no line through the step at {} min", st.t)))?;
        si.push((line.beta[1], line.beta[0]));
    }
    let (t0, t1) = (steps[0].t, steps[steps.len() - 1].t);
    let from = opts.holdout_from_min.unwrap_or(t0 + (t1 - t0) * 2.0 / 3.0);
    let train: Vec<usize> = (0..steps.len()).filter(|&k| steps[k].t < from).collect();
    let holdout: Vec<usize> = (0..steps.len()).filter(|&k| steps[k].t >= from).collect();
    if train.len() < 3 || holdout.is_empty() {
        return Err(bad(format!(
            "the holdout from {from} min leaves {} training and {} holdout time steps",
            train.len(),
            holdout.len()
        )));
    }
    let theta: Vec<Vec<f64>> = (0..names.len())
        .map(|j| train.iter().map(|&k| steps[k].theta[j]).collect())
        .collect();
    let s_train: Vec<f64> = train.iter().map(|&k| si[k].0).collect();
    let i_train: Vec<f64> = train.iter().map(|&k| si[k].1).collect();
    let r_s: Vec<f64> = theta.iter().map(|t| stats::pearson(t, &s_train)).collect();
    let r_i: Vec<f64> = theta.iter().map(|t| stats::pearson(t, &i_train)).collect();
    let importance = r_s
        .iter()
        .zip(&r_i)
        .map(|(a, b)| a.abs().max(b.abs()))
        .collect();
    let sel = choose(&theta, importance, opts);
    let chosen = sel.chosen();
    let chosen_names: Vec<String> = chosen.iter().map(|&j| names[j].clone()).collect();
    let x = DMatrix::from_fn(train.len(), chosen.len() + 1, |r, c| {
        if c == 0 {
            1.0
        } else {
            steps[train[r]].theta[chosen[c - 1]]
        }
    });
    let singular = || SensorError::Singular(chosen_names.clone());
    let slope = stats::least_squares(&x, &s_train).ok_or_else(singular)?;
    let intercept = stats::least_squares(&x, &i_train).ok_or_else(singular)?;
    let linear = |row: usize, b: &[f64]| {
        b[0] + chosen
            .iter()
            .zip(&b[1..])
            .map(|(&j, c)| c * change[j][row])
            .sum::<f64>()
    };
    let thermal_prediction: Vec<f64> = (0..e.len())
        .map(|row| linear(row, &slope.beta) * p[row] + linear(row, &intercept.beta))
        .collect();
    let score = |part: &[usize]| {
        let (mut resid, mut unc) = (Vec::new(), Vec::new());
        for &k in part {
            for row in steps[k].rows.clone() {
                resid.push(thermal[row] - thermal_prediction[row]);
                unc.push(thermal[row]);
            }
        }
        Score::of(&resid, &unc)
    };
    Ok(PositionAnalysis {
        channel: opts.channel.clone(),
        position: position.to_string(),
        threshold: opts.threshold,
        min_correlation: opts.min_correlation,
        training_steps: train.len(),
        geometric: geometric.clone(),
        factors: names
            .iter()
            .zip(r_s.iter().zip(&r_i))
            .map(|(n, (&s, &i))| PositionFactor {
                sensor: n.clone(),
                r_slope: s,
                r_intercept: i,
            })
            .collect(),
        correlation: sel.correlation.clone(),
        clusters: sel.describe(&names, opts.min_correlation),
        chosen: chosen_names.clone(),
        slope: coefficients(&chosen_names, &slope),
        intercept: coefficients(&chosen_names, &intercept),
        fit: score(&train),
        holdout_from_min: from,
        default_holdout: opts.holdout_from_min.is_none(),
        validation: score(&holdout),
        prediction: (0..e.len())
            .map(|row| poly(&geometric, p[row]) + thermal_prediction[row])
            .collect(),
        provenance: provenance(ds),
    })
}

impl PositionAnalysis {
    /// The regression's prediction E_G(p) + S·p + I at every row of the data (µm).
    pub fn prediction(&self) -> &[f64] {
        &self.prediction
    }

    /// The separated regression as a driftloop model (see the module comment for its terms); `predict`
    /// reproduces [`PositionAnalysis::prediction`].
    pub fn to_model(&self) -> DriftModel {
        let coefficient = |k: usize| self.geometric.get(k).copied().unwrap_or(0.0);
        let geometric = Effect {
            kind: Kind::Geometric,
            signal: None,
            position: Some(self.position.clone()),
            theta: Vec::new(),
            amplitudes: vec![coefficient(1) + self.slope[0].value, coefficient(2)],
        };
        let terms = std::iter::once(geometric)
            .chain(sensor_terms(
                &self.slope,
                Kind::InputSlope,
                Some(&self.position),
            ))
            .chain(sensor_terms(&self.intercept, Kind::StaticInput, None));
        regression_model(
            &self.channel,
            coefficient(0) + self.intercept[0].value,
            terms,
            &self.provenance,
        )
    }

    pub fn json(&self) -> String {
        serde_json::to_string_pretty(self).expect("the analysis serialises") + "\n"
    }
}
