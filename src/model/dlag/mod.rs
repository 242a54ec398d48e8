//! A distributed-lag model over the sensors the machine has (`fit --kind dlag`): every temperature column,
//! as a change from its value at the run's start, at several first-order lags (0, 15 min, 1 h, 4 h by
//! default), plus the spindle speed through a power law gain ∝ (n / n_top)^p at several lags; ridge
//! regression on standardised columns.
//!
//! Every data-driven choice — the penalty, the speed law's exponent p, the lag sets of the sensors and of the
//! spindle, the trend gain of a probe's re-zeroing — is made by forward
//! validation ([`super::forward`]): fitted on the rows before each origin, scored on the rows after it, the
//! design with the lowest pooled forward RMS wins. The fold that trains on the lower speeds only and scores
//! a higher one is what chooses p: the law is judged on a speed it was not trained on, as it will be on the
//! machine.
//!
//! The fitted model is written as a plain model file ([`basis`]): `static_input` and `input_lag` effects
//! for the sensors, spindle modes whose grid gains follow the law (extra nodes above the top characterised
//! speed) for the spindle, so `predict`, `plan` and `transform` evaluate it with nothing new.

pub mod basis;
pub mod text;

use serde::{Deserialize, Serialize};

use super::probing::{Probing, rezeroed};
use crate::data::{ColumnKind, Dataset, SPINDLE};

use super::fit::{FitError, channel_values, max_abs, rms};
use super::forward::{Origins, elapsed};
use super::ridge::{Coefficients, Moments, Ridge};
use super::speed_grid::SpeedGrid;
use super::{
    DataProvenance, DriftModel, Extrapolation, FitSummary, Interpolation, RunStats, SCHEMA,
    SpindleModes,
};
use basis::{SpeedNodes, Term, column, effect_specs};

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
    /// Candidate lag sets of the spindle terms (minutes, each > 0); forward validation picks one.
    pub spindle_lags: Vec<Vec<f64>>,
    /// Candidate exponents p of the speed law.
    pub exponents: Vec<f64>,
    /// Which scored designs make the model.
    pub averaging: Averaging,
    /// Candidate penalties (on standardised columns, per row).
    pub penalties: Vec<f64>,
    pub origins: Origins,
    /// The probing interval (minutes) the trend gain of the re-zeroing is chosen for; `None`: not chosen.
    pub probe_every_min: Option<f64>,
    /// Candidate trend gains of the re-zeroing ([`super::probing`]).
    pub trend_gains: Vec<f64>,
}

impl DlagOptions {
    /// The defaults: lags 0, 15 min, 1 h, 4 h for the sensors (or without the 15 min lag, or with 16 h
    /// added), 15 min, 1 h, 4 h for the spindle, p from 0.5 to 3, penalties
    /// 10⁻⁶ … 10, a probe every 60 min with trend gains 0, ¼, ½, ¾, 1.
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
            // One set: a further 16 h spindle lag won the forward RMS on three channels but lost when the
            // whole selection was validated forward (docs/forward.md, "Which choices …").
            spindle_lags: vec![vec![15.0, 60.0, 240.0]],
            exponents: vec![0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.5, 3.0],
            averaging: Averaging::Weighted,
            penalties: (0..=14)
                .map(|i| 10f64.powf(-6.0 + 0.5 * f64::from(i)))
                .collect(),
            origins: Origins::default(),
            probe_every_min: Some(60.0),
            trend_gains: vec![0.0, 0.25, 0.5, 0.75, 1.0],
        }
    }
}

/// How the design was chosen, written into the model file's `[fit.forward]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ForwardSelection {
    /// Elapsed minutes (from the first row, runs laid end to end) of the validation origins.
    pub origins_min: Vec<f64>,
    pub signals: Vec<String>,
    /// The design with the lowest forward RMS (with averaging: the heaviest member, see `trials`).
    pub sensor_lags_min: Vec<f64>,
    pub spindle_lags_min: Vec<f64>,
    /// p of each spindle term's speed law, in the order of `spindle_lags_min`.
    pub exponents: Vec<f64>,
    pub penalty: f64,
    /// Pooled forward RMS of the model: of the best design, or of the average of the members (each fitted
    /// on each fold's training rows) when the model averages several.
    pub cv_rms_um: f64,
    /// Effective degrees of freedom of the final fit.
    pub dof: f64,
    /// Every design tried, with its best penalty.
    pub trials: Vec<DesignTrial>,
    /// The re-zeroing by a probe, chosen on the same folds (absent in files from older builds).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub probe: Option<ProbeChoice>,
}

/// The trend gain of a probe's re-zeroing chosen by forward validation: each fold's model predicts its
/// test rows, a probe corrects them every `every_min` from the fold's origin, for each candidate gain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProbeChoice {
    pub every_min: f64,
    pub trend_gain: f64,
    /// Every candidate gain with its pooled forward RMS after probing.
    pub trials: Vec<[f64; 2]>,
}

impl ProbeChoice {
    pub fn probing(&self) -> Probing {
        Probing {
            every_min: self.every_min,
            trend_gain: self.trend_gain,
        }
    }
}

/// One design scored by forward validation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DesignTrial {
    pub sensor_lags_min: Vec<f64>,
    /// Absent in files from builds with one spindle lag set.
    #[serde(default)]
    pub spindle_lags_min: Vec<f64>,
    /// p of each spindle term (the order of `spindle_lags_min`).
    pub exponents: Vec<f64>,
    pub penalty: f64,
    pub cv_rms_um: f64,
    /// The design's weight in the averaged model (absent: not a member).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weight: Option<f64>,
}

/// The window's data laid out for the search.
struct Prepared<'a> {
    ds: &'a Dataset,
    y: Vec<f64>,
    usable: Vec<bool>,
    signals: Vec<String>,
    /// The speed grid of the spindle terms; `None` when the window never runs the spindle.
    speeds: Option<SpeedNodes>,
    stretches: Vec<Vec<usize>>,
    origins_min: Vec<f64>,
}

/// Fits the distributed-lag model of `opts.channel`.
pub fn fit_dlag(all: &Dataset, opts: &DlagOptions) -> Result<DriftModel, FitError> {
    let window = crate::model::fit::fit_window(all, opts.until_min)?;
    let ds = window.as_ref();
    let prep = Prepared::new(ds, opts)?;
    let mut scored: Vec<Scored> = Vec::new();
    // Without a spindle speed in the window every spindle lag set is the same design: no spindle terms.
    let spindle_sets: Vec<&[f64]> = match prep.speeds {
        Some(_) => opts.spindle_lags.iter().map(Vec::as_slice).collect(),
        None => vec![&[]],
    };
    for lags in &opts.sensor_lags {
        let mut search = Search::new(&prep, opts, lags);
        for &spindle_lags in &spindle_sets {
            search.run(spindle_lags, &mut scored);
        }
    }
    let members = opts
        .averaging
        .members(&scored, prep.stretches.len().saturating_sub(1));
    let Some(best) = members.first().map(|m| &scored[m.0]) else {
        return Err(FitError::TooFewSamples {
            samples: prep.rows().len(),
            needed: 2 * opts.origins.count.max(1),
        });
    };
    let ensemble = Ensemble::new(&prep, &scored, &members);
    let cv = match members.len() {
        1 => best.cv_rms_um,
        _ => ensemble.cv_rms_um(&prep).unwrap_or(f64::NAN),
    };
    let fit = ensemble.fit().ok_or(FitError::Numerical)?;
    let probe = opts
        .probe_every_min
        .and_then(|every| ensemble.choose_trend_gain(&prep, every, &opts.trend_gains));
    let selection = ForwardSelection {
        origins_min: prep.origins_min.clone(),
        signals: prep.signals.clone(),
        sensor_lags_min: best.design.sensor_lags.clone(),
        spindle_lags_min: best.design.spindle.iter().map(|s| s.0).collect(),
        exponents: best.design.spindle.iter().map(|s| s.1).collect(),
        penalty: best.penalty,
        cv_rms_um: cv,
        dof: fit.dof,
        trials: scored
            .iter()
            .enumerate()
            .map(|(i, d)| d.trial(members.iter().find(|m| m.0 == i).map(|m| m.1)))
            .collect(),
        probe,
    };
    Ok(prep.model(
        all.len(),
        opts,
        &ensemble.terms,
        &ensemble.cols,
        &fit,
        selection,
    ))
}

/// Which of the scored designs make the model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Averaging {
    /// The design with the lowest forward RMS.
    Best,
    /// Every design, weighted by exp(−F·(cv²/cv_min² − 1)/2) with F the number of forward folds: a fold's
    /// errors are strongly autocorrelated (a few transients), so it counts as about one observation of the
    /// design's error, and designs within the folds' noise of the best share the prediction. Designs under
    /// 1 % of the best's weight are left out.
    Weighted,
}

impl Averaging {
    /// (index into `scored`, weight) of the members, best first; the weights sum to 1.
    fn members(self, scored: &[Scored], folds: usize) -> Vec<(usize, f64)> {
        let mut order: Vec<usize> = (0..scored.len()).collect();
        order.sort_by(|&a, &b| scored[a].cv_rms_um.total_cmp(&scored[b].cv_rms_um));
        let Some(&first) = order.first() else {
            return Vec::new();
        };
        let mut members: Vec<(usize, f64)> = match self {
            Averaging::Best => vec![(first, 1.0)],
            Averaging::Weighted => {
                let min = scored[first].cv_rms_um.powi(2);
                order
                    .into_iter()
                    .map(|i| {
                        let excess = scored[i].cv_rms_um.powi(2) / min - 1.0;
                        (i, (-0.5 * folds as f64 * excess).exp())
                    })
                    .filter(|m| m.1 >= 0.01)
                    .collect()
            }
        };
        let total: f64 = members.iter().map(|m| m.1).sum();
        members.iter_mut().for_each(|m| m.1 /= total);
        members
    }
}

/// A design scored by forward validation.
#[derive(Debug, Clone, PartialEq)]
struct Scored {
    design: Design,
    penalty: f64,
    cv_rms_um: f64,
}

impl Scored {
    fn trial(&self, weight: Option<f64>) -> DesignTrial {
        DesignTrial {
            sensor_lags_min: self.design.sensor_lags.clone(),
            spindle_lags_min: self.design.spindle.iter().map(|x| x.0).collect(),
            exponents: self.design.spindle.iter().map(|x| x.1).collect(),
            penalty: self.penalty,
            cv_rms_um: self.cv_rms_um,
            weight,
        }
    }
}

/// The weighted sum of the members' linear models: one model over the union of their terms.
struct Ensemble {
    terms: Vec<Term>,
    cols: Vec<Vec<f64>>,
    /// Per member: weight, penalty, the indices of its terms in `terms`.
    members: Vec<(f64, f64, Vec<usize>)>,
    /// The moments of every term on each stretch between the forward origins.
    parts: Vec<Moments>,
}

impl Ensemble {
    fn new(prep: &Prepared, scored: &[Scored], members: &[(usize, f64)]) -> Ensemble {
        let mut terms: Vec<Term> = Vec::new();
        let mut parts = Vec::new();
        for &(i, w) in members {
            let idx: Vec<usize> = prep
                .terms(&scored[i].design)
                .into_iter()
                .map(|t| match terms.iter().position(|u| *u == t) {
                    Some(k) => k,
                    None => {
                        terms.push(t);
                        terms.len() - 1
                    }
                })
                .collect();
            parts.push((w, scored[i].penalty, idx));
        }
        // Sensors first, as a single design lists them.
        let mut order: Vec<usize> = (0..terms.len()).collect();
        order.sort_by_key(|&k| matches!(terms[k], Term::Spindle { .. }));
        let mut at = vec![0; terms.len()];
        order
            .iter()
            .enumerate()
            .for_each(|(new, &old)| at[old] = new);
        let terms: Vec<Term> = order.iter().map(|&k| terms[k].clone()).collect();
        for p in &mut parts {
            p.2.iter_mut().for_each(|k| *k = at[*k]);
        }
        let (cols, moments) = prep.columns(&terms);
        Ensemble {
            terms,
            cols,
            members: parts,
            parts: moments,
        }
    }

    /// The weighted coefficients of the members fitted on the rows whose moments (of every term) are
    /// `train`.
    fn fit_on(&self, train: &Moments) -> Option<Coefficients> {
        let mut out = Coefficients {
            intercept: 0.0,
            beta: nalgebra::DVector::zeros(self.terms.len()),
            dof: 0.0,
        };
        for (w, penalty, idx) in &self.members {
            let c = Ridge::new(&train.select(idx))?.solve(*penalty);
            out.intercept += w * c.intercept;
            out.dof += w * c.dof;
            for (&k, b) in idx.iter().zip(c.beta.iter()) {
                out.beta[k] += w * b;
            }
        }
        Some(out)
    }

    /// The members fitted on the whole window.
    fn fit(&self) -> Option<Coefficients> {
        self.fit_on(&sum(&self.parts))
    }

    fn predict(&self, c: &Coefficients, i: usize) -> f64 {
        c.intercept
            + self
                .cols
                .iter()
                .zip(c.beta.iter())
                .map(|(col, b)| b * col[i])
                .sum::<f64>()
    }

    /// Each forward fold's test rows and the model's error on them (NaN elsewhere), fitted on the rows
    /// before the fold's origin.
    fn fold_errors(&self, prep: &Prepared) -> Vec<(Vec<usize>, Vec<f64>)> {
        let s = &prep.stretches;
        (0..s.len().saturating_sub(1))
            .filter_map(|k| {
                let test: Vec<usize> = s[k + 1..].concat();
                let fit = self.fit_on(&sum(&self.parts[..=k]))?;
                let mut err = vec![f64::NAN; prep.ds.len()];
                for &i in &test {
                    err[i] = prep.y[i] - self.predict(&fit, i);
                }
                (!test.is_empty()).then_some((test, err))
            })
            .collect()
    }

    /// The pooled forward RMS of the weighted model.
    fn cv_rms_um(&self, prep: &Prepared) -> Option<f64> {
        let folds = self.fold_errors(prep);
        let n: usize = folds.iter().map(|f| f.0.len()).sum();
        let sse: f64 = folds
            .iter()
            .flat_map(|(test, err)| test.iter().map(|&i| err[i] * err[i]))
            .sum();
        (n > 0).then(|| (sse / n as f64).sqrt())
    }

    /// The trend gain among `gains` with the lowest pooled RMS after probing every `every` minutes: each
    /// fold's fit predicts its test rows, which a probe corrects from the fold's origin on. `None` without
    /// a fold or a candidate.
    fn choose_trend_gain(&self, prep: &Prepared, every: f64, gains: &[f64]) -> Option<ProbeChoice> {
        let runs: Vec<std::ops::Range<usize>> = prep.ds.runs().collect();
        let mut sse = vec![0.0; gains.len()];
        let mut scored = 0usize;
        for (test, err) in self.fold_errors(prep) {
            let mut window = vec![false; prep.ds.len()];
            test.iter().for_each(|&i| window[i] = true);
            for (acc, &trend_gain) in sse.iter_mut().zip(gains) {
                let probing = Probing {
                    every_min: every,
                    trend_gain,
                };
                let out = rezeroed(&prep.ds.time_min, &runs, &err, &window, probing);
                *acc += test.iter().map(|&i| out[i] * out[i]).sum::<f64>();
            }
            scored += test.len();
        }
        if scored == 0 {
            return None;
        }
        let trials: Vec<[f64; 2]> = gains
            .iter()
            .zip(&sse)
            .map(|(&g, &e)| [g, (e / scored as f64).sqrt()])
            .collect();
        let best = trials.iter().min_by(|a, b| a[1].total_cmp(&b[1]))?;
        Some(ProbeChoice {
            every_min: every,
            trend_gain: best[0],
            trials: trials.clone(),
        })
    }
}

/// A design: the sensors' lag set and the spindle terms' (lag, exponent).
#[derive(Debug, Clone, PartialEq)]
struct Design {
    sensor_lags: Vec<f64>,
    spindle: Vec<(f64, f64)>,
}

/// The forward-validation search over the spindle exponents for one sensor lag set. The sensor columns and
/// their moments per stretch are computed once; a spindle configuration only appends its columns.
struct Search<'p, 'a> {
    prep: &'p Prepared<'a>,
    penalties: &'p [f64],
    exponents: &'p [f64],
    sensor_lags: Vec<f64>,
    sensor_cols: Vec<Vec<f64>>,
    base: Vec<Moments>,
    /// Spindle columns by (lag, exponent) bit patterns.
    spindle_cols: std::collections::HashMap<(u64, u64), Vec<f64>>,
}

impl<'p, 'a> Search<'p, 'a> {
    fn new(prep: &'p Prepared<'a>, opts: &'p DlagOptions, lags: &[f64]) -> Search<'p, 'a> {
        let (sensor_cols, base) = prep.columns(&prep.sensor_terms(lags));
        Search {
            prep,
            penalties: &opts.penalties,
            exponents: &opts.exponents,
            sensor_lags: lags.to_vec(),
            sensor_cols,
            base,
            spindle_cols: std::collections::HashMap::new(),
        }
    }

    /// Best penalty and pooled forward RMS of the design with the spindle terms `spindle` (lag, exponent);
    /// the design is appended to `scored`.
    fn score(&mut self, spindle: &[(f64, f64)], scored: &mut Vec<Scored>) -> Option<(f64, f64)> {
        for &(lag_min, exponent) in spindle {
            self.spindle_cols
                .entry((lag_min.to_bits(), exponent.to_bits()))
                .or_insert_with(|| {
                    let term = Term::Spindle { lag_min, exponent };
                    column(self.prep.ds, &term, self.prep.speeds.as_ref())
                });
        }
        let extra: Vec<&[f64]> = spindle
            .iter()
            .map(|(l, p)| self.spindle_cols[&(l.to_bits(), p.to_bits())].as_slice())
            .collect();
        let parts: Vec<Moments> = self
            .base
            .iter()
            .zip(&self.prep.stretches)
            .map(|(m, rows)| m.extended(&self.sensor_cols, &extra, &self.prep.y, rows))
            .collect();
        let found = validate(&parts, self.penalties)?;
        let design = Design {
            sensor_lags: self.sensor_lags.clone(),
            spindle: spindle.to_vec(),
        };
        if !scored.iter().any(|s| s.design == design) {
            scored.push(Scored {
                design,
                penalty: found.0,
                cv_rms_um: found.1,
            });
        }
        Some(found)
    }

    /// Scores the designs with the spindle terms at `spindle_lags`, every one appended to `scored`: one
    /// exponent shared by every spindle term on the grid, then each term's own exponent by coordinate
    /// descent from there (two sweeps).
    fn run(&mut self, spindle_lags: &[f64], scored: &mut Vec<Scored>) {
        let exponents = self.exponents;
        let with = |exps: &[usize]| -> Vec<(f64, f64)> {
            spindle_lags
                .iter()
                .zip(exps)
                .map(|(&l, &e)| (l, exponents[e]))
                .collect()
        };
        let m = spindle_lags.len();
        if m == 0 {
            self.score(&[], scored);
            return;
        }
        let mut best: Option<(Vec<usize>, f64)> = None;
        for e in 0..exponents.len() {
            let exps = vec![e; m];
            if let Some(found) = self.score(&with(&exps), scored)
                && best.as_ref().is_none_or(|b| found.1 < b.1)
            {
                best = Some((exps, found.1));
            }
        }
        let Some((mut exps, mut cv)) = best else {
            return;
        };
        for _sweep in 0..2 {
            let mut changed = false;
            for j in 0..m {
                for e in 0..exponents.len() {
                    if e == exps[j] {
                        continue;
                    }
                    let mut trial = exps.clone();
                    trial[j] = e;
                    if let Some(f) = self.score(&with(&trial), scored)
                        && f.1 < cv
                    {
                        (exps, cv, changed) = (trial, f.1, true);
                    }
                }
            }
            if !changed {
                break;
            }
        }
    }
}

/// The best penalty and its pooled forward RMS, from the moments of the stretches between the origins:
/// fold k trains on stretches `..=k` and scores stretches `k + 1..`. `None` when no fold can be fitted.
fn validate(parts: &[Moments], penalties: &[f64]) -> Option<(f64, f64)> {
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

/// The temperature columns that vary over the rows marked `usable`: the sensors a dlag model takes
/// without `--signals`.
pub fn varying_temperatures(ds: &Dataset, usable: &[bool]) -> Vec<String> {
    let varies = |v: &[f64]| {
        let mut it = (0..v.len()).filter(|&i| usable[i]).map(|i| v[i]);
        it.next()
            .is_some_and(|first| it.any(|x| (x - first).abs() > 1e-12))
    };
    ds.columns
        .iter()
        .filter(|c| c.kind == ColumnKind::Temperature && varies(&c.values))
        .map(|c| c.name.clone())
        .collect()
}

impl<'a> Prepared<'a> {
    fn new(ds: &'a Dataset, opts: &DlagOptions) -> Result<Prepared<'a>, FitError> {
        let y = channel_values(ds, &opts.channel)?.to_vec();
        let usable = crate::data::measured(&y);
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
            None => varying_temperatures(ds, &usable),
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
        let speeds = SpeedNodes::new(&characterised);
        if signals.is_empty() && speeds.is_none() {
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
            speeds,
            stretches,
            origins_min,
        })
    }

    /// The terms' columns and their moments on each stretch between the forward origins.
    fn columns(&self, terms: &[Term]) -> (Vec<Vec<f64>>, Vec<Moments>) {
        let cols: Vec<Vec<f64>> = terms
            .iter()
            .map(|t| column(self.ds, t, self.speeds.as_ref()))
            .collect();
        let parts = self
            .stretches
            .iter()
            .map(|rows| Moments::of_rows(&cols, &self.y, rows))
            .collect();
        (cols, parts)
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

    /// Every term of a design, sensors first.
    fn terms(&self, design: &Design) -> Vec<Term> {
        let mut terms = self.sensor_terms(&design.sensor_lags);
        terms.extend(
            design
                .spindle
                .iter()
                .map(|&(lag_min, exponent)| Term::Spindle { lag_min, exponent }),
        );
        terms
    }

    fn model(
        &self,
        rows_in_file: usize,
        opts: &DlagOptions,
        terms: &[Term],
        cols: &[Vec<f64>],
        fit: &Coefficients,
        forward: ForwardSelection,
    ) -> DriftModel {
        let ds = self.ds;
        let gains: Vec<f64> = fit.beta.iter().copied().collect();
        let modes = basis::merge_modes(
            terms
                .iter()
                .zip(&gains)
                .filter_map(|(t, g)| self.speeds.as_ref().and_then(|s| t.mode(*g, s))),
        );
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
        let speeds = self.speeds.as_ref().filter(|_| !modes.is_empty());
        DriftModel {
            schema: SCHEMA,
            channel: opts.channel.clone(),
            offset_um: fit.intercept,
            spindle: SpindleModes {
                grid_rpm: speeds.map(|s| s.nodes.clone()).unwrap_or_default(),
                interpolation: Interpolation::PiecewiseLinear,
                extrapolation: if speeds.is_some() {
                    Extrapolation::PowerLaw
                } else {
                    Extrapolation::LinearLastSegment
                },
                characterised_top_rpm: speeds.map(|s| s.top_rpm),
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
                speed_law: None,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Schedule;

    /// 16 h at 2 min: 1000 and 2000 rpm with stops; a wandering temperature; a drift that reads both.
    fn data() -> Dataset {
        let mut ds = "1000:240,0:240,2000:240,0:240"
            .parse::<Schedule>()
            .unwrap()
            .to_dataset(2.0);
        let t1: Vec<f64> = ds
            .time_min
            .iter()
            .map(|t| 20.0 + (t / 90.0).sin())
            .collect();
        let rpm = ds.values(SPINDLE).unwrap().to_vec();
        let mut heat = 0.0;
        let y: Vec<f64> = (0..ds.len())
            .map(|i| {
                heat += ((rpm[i] / 1000.0).powi(2) - heat) * 0.03;
                0.7 * (t1[i] - 20.0) + 2.0 * heat + 0.05 * (1.7 * i as f64).sin()
            })
            .collect();
        ds.push_column("t1_c", t1);
        ds.push_column("z_um", y);
        ds
    }

    /// Runs `check` on the prepared data and every design the default search scores on it.
    fn with_scored(check: impl FnOnce(&Dataset, &Prepared, &[Scored])) {
        let ds = data();
        let opts = DlagOptions::new("z_um");
        let prep = Prepared::new(&ds, &opts).unwrap();
        let mut scored = Vec::new();
        for lags in &opts.sensor_lags {
            Search::new(&prep, &opts, lags).run(&opts.spindle_lags[0], &mut scored);
        }
        check(&ds, &prep, &scored);
    }

    #[test]
    fn the_average_is_the_weighted_sum_of_its_members_fitted_alone() {
        with_scored(|ds, prep, scored| {
            let members = Averaging::Weighted.members(scored, 4);
            assert!(members.len() > 1, "{members:?}");
            let ensemble = Ensemble::new(prep, scored, &members);
            let fit = ensemble.fit().unwrap();
            let mut beta = vec![0.0; ensemble.terms.len()];
            let mut intercept = 0.0;
            for &(i, w) in &members {
                let terms = prep.terms(&scored[i].design);
                let cols: Vec<Vec<f64>> = terms
                    .iter()
                    .map(|t| column(ds, t, prep.speeds.as_ref()))
                    .collect();
                let alone = Ridge::new(&Moments::of_rows(&cols, &prep.y, &prep.rows()))
                    .unwrap()
                    .solve(scored[i].penalty);
                intercept += w * alone.intercept;
                for (t, b) in terms.iter().zip(alone.beta.iter()) {
                    let k = ensemble.terms.iter().position(|u| u == t).unwrap();
                    beta[k] += w * b;
                }
            }
            assert!((fit.intercept - intercept).abs() < 1e-8);
            for (a, b) in fit.beta.iter().zip(&beta) {
                assert!((a - b).abs() < 1e-8 * (1.0 + b.abs()), "{a} vs {b}");
            }
            // Sensors first, as in a single design, and no term twice.
            let first_spindle = ensemble
                .terms
                .iter()
                .position(|t| matches!(t, Term::Spindle { .. }))
                .unwrap();
            assert!(
                ensemble.terms[first_spindle..]
                    .iter()
                    .all(|t| matches!(t, Term::Spindle { .. }))
            );
            assert!(
                (0..ensemble.terms.len())
                    .all(|a| (0..a).all(|b| ensemble.terms[a] != ensemble.terms[b]))
            );
        });
    }

    #[test]
    fn one_member_scores_its_own_forward_rms() {
        with_scored(|_, prep, scored| {
            for i in [0, scored.len() / 2, scored.len() - 1] {
                let ensemble = Ensemble::new(prep, scored, &[(i, 1.0)]);
                let cv = ensemble.cv_rms_um(prep).unwrap();
                assert!(
                    (cv - scored[i].cv_rms_um).abs() < 1e-6 * cv,
                    "{cv} vs {}",
                    scored[i].cv_rms_um
                );
            }
        });
    }

    #[test]
    fn weights_follow_the_forward_rms_relative_to_the_best() {
        let design = Design {
            sensor_lags: vec![0.0],
            spindle: vec![],
        };
        let at = |cv: f64| Scored {
            design: design.clone(),
            penalty: 1e-3,
            cv_rms_um: cv,
        };
        let scored = [at(1.1), at(2.0), at(1.0)];
        assert_eq!(Averaging::Best.members(&scored, 4), [(2, 1.0)]);
        let m = Averaging::Weighted.members(&scored, 4);
        // 1.1 µm: exp(−4·0.21/2) of the best's weight; 2 µm: exp(−6), under 1 %, left out.
        let second = (-2.0f64 * 0.21).exp();
        assert_eq!(m.iter().map(|x| x.0).collect::<Vec<_>>(), [2, 0]);
        assert!((m[0].1 - 1.0 / (1.0 + second)).abs() < 1e-12);
        assert!((m[1].1 - second / (1.0 + second)).abs() < 1e-12);
        // More folds: the same excess counts more.
        assert!(Averaging::Weighted.members(&scored, 16)[1].1 < m[1].1);
    }
}
