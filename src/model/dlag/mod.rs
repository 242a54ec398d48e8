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
    pub sensor_lags_min: Vec<f64>,
    pub spindle_lags_min: Vec<f64>,
    /// p of each spindle term's speed law, in the order of `spindle_lags_min`.
    pub exponents: Vec<f64>,
    pub penalty: f64,
    /// Pooled forward RMS of the chosen design.
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
    let window = all.until_opt(opts.until_min);
    let ds = window.as_ref();
    let prep = Prepared::new(ds, opts)?;
    let mut trials = Vec::new();
    let mut best: Option<(Design, f64, f64)> = None;
    // Without a spindle speed in the window every spindle lag set is the same design: no spindle terms.
    let spindle_sets: Vec<&[f64]> = match prep.speeds {
        Some(_) => opts.spindle_lags.iter().map(Vec::as_slice).collect(),
        None => vec![&[]],
    };
    for lags in &opts.sensor_lags {
        let mut search = Search::new(&prep, opts, lags);
        for &spindle_lags in &spindle_sets {
            let Some(found) = search.run(spindle_lags, &mut trials) else {
                continue;
            };
            if best.as_ref().is_none_or(|b| found.2 < b.2) {
                best = Some(found);
            }
        }
    }
    let (design, penalty, cv) = best.ok_or(FitError::TooFewSamples {
        samples: prep.rows().len(),
        needed: 2 * opts.origins.count.max(1),
    })?;
    let terms = prep.terms(&design);
    let cols: Vec<Vec<f64>> = terms
        .iter()
        .map(|t| column(ds, t, prep.speeds.as_ref()))
        .collect();
    let rows = prep.rows();
    let fit = Ridge::new(&Moments::of_rows(&cols, &prep.y, &rows))
        .ok_or(FitError::Numerical)?
        .solve(penalty);
    let probe = opts
        .probe_every_min
        .and_then(|every| prep.choose_trend_gain(&cols, penalty, every, &opts.trend_gains));
    let selection = ForwardSelection {
        origins_min: prep.origins_min.clone(),
        signals: prep.signals.clone(),
        sensor_lags_min: design.sensor_lags.clone(),
        spindle_lags_min: design.spindle.iter().map(|s| s.0).collect(),
        exponents: design.spindle.iter().map(|s| s.1).collect(),
        penalty,
        cv_rms_um: cv,
        dof: fit.dof,
        trials,
        probe,
    };
    Ok(prep.model(all.len(), opts, &terms, &cols, &fit, selection))
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
    spindle_lags: Vec<f64>,
    sensor_lags: Vec<f64>,
    sensor_cols: Vec<Vec<f64>>,
    base: Vec<Moments>,
    /// Spindle columns by (lag index, exponent index).
    spindle_cols: std::collections::HashMap<(usize, usize), Vec<f64>>,
}

impl<'p, 'a> Search<'p, 'a> {
    fn new(prep: &'p Prepared<'a>, opts: &'p DlagOptions, lags: &[f64]) -> Search<'p, 'a> {
        let sensor_cols: Vec<Vec<f64>> = prep
            .sensor_terms(lags)
            .iter()
            .map(|t| column(prep.ds, t, None))
            .collect();
        let base = prep
            .stretches
            .iter()
            .map(|rows| Moments::of_rows(&sensor_cols, &prep.y, rows))
            .collect();
        Search {
            prep,
            penalties: &opts.penalties,
            exponents: &opts.exponents,
            spindle_lags: Vec::new(),
            sensor_lags: lags.to_vec(),
            sensor_cols,
            base,
            spindle_cols: std::collections::HashMap::new(),
        }
    }

    fn design(&self, exps: &[usize]) -> Design {
        Design {
            sensor_lags: self.sensor_lags.clone(),
            spindle: self
                .spindle_lags
                .iter()
                .zip(exps)
                .map(|(&l, &e)| (l, self.exponents[e]))
                .collect(),
        }
    }

    /// Best penalty and pooled forward RMS of the design with exponent indices `exps`.
    fn score(&mut self, exps: &[usize]) -> Option<(f64, f64)> {
        for (j, &e) in exps.iter().enumerate() {
            if !self.spindle_cols.contains_key(&(j, e)) {
                let term = Term::Spindle {
                    lag_min: self.spindle_lags[j],
                    exponent: self.exponents[e],
                };
                let col = column(self.prep.ds, &term, self.prep.speeds.as_ref());
                self.spindle_cols.insert((j, e), col);
            }
        }
        let extra: Vec<&[f64]> = exps
            .iter()
            .enumerate()
            .map(|(j, &e)| self.spindle_cols[&(j, e)].as_slice())
            .collect();
        let parts: Vec<Moments> = self
            .base
            .iter()
            .zip(&self.prep.stretches)
            .map(|(m, rows)| m.extended(&self.sensor_cols, &extra, &self.prep.y, rows))
            .collect();
        validate(&parts, self.penalties)
    }

    /// With the spindle terms at `spindle_lags`: one
    /// exponent shared by every spindle term on the grid, then each term's own exponent by coordinate
    /// descent from there (two sweeps); every design scored is appended to `trials`. Returns the best
    /// design, its penalty and its forward RMS.
    fn run(
        &mut self,
        spindle_lags: &[f64],
        trials: &mut Vec<DesignTrial>,
    ) -> Option<(Design, f64, f64)> {
        if spindle_lags != self.spindle_lags {
            self.spindle_lags = spindle_lags.to_vec();
            self.spindle_cols.clear();
        }
        let m = self.spindle_lags.len();
        let mut record = |s: &Search, exps: &[usize], (penalty, cv): (f64, f64)| {
            let d = s.design(exps);
            trials.push(DesignTrial {
                sensor_lags_min: d.sensor_lags,
                spindle_lags_min: d.spindle.iter().map(|x| x.0).collect(),
                exponents: d.spindle.iter().map(|x| x.1).collect(),
                penalty,
                cv_rms_um: cv,
            });
        };
        if m == 0 {
            let found = self.score(&[])?;
            record(self, &[], found);
            return Some((self.design(&[]), found.0, found.1));
        }
        let mut best: Option<(Vec<usize>, (f64, f64))> = None;
        for e in 0..self.exponents.len() {
            let exps = vec![e; m];
            if let Some(found) = self.score(&exps) {
                record(self, &exps, found);
                if best.as_ref().is_none_or(|b| found.1 < b.1.1) {
                    best = Some((exps, found));
                }
            }
        }
        let (mut exps, mut found) = best?;
        for _sweep in 0..2 {
            let mut changed = false;
            for j in 0..m {
                for e in 0..self.exponents.len() {
                    if e == exps[j] {
                        continue;
                    }
                    let mut trial = exps.clone();
                    trial[j] = e;
                    if let Some(f) = self.score(&trial)
                        && f.1 < found.1
                    {
                        (exps, found, changed) = (trial, f, true);
                    }
                }
            }
            if !changed {
                break;
            }
        }
        if exps.iter().any(|&e| e != exps[0]) {
            record(self, &exps, found);
        }
        Some((self.design(&exps), found.0, found.1))
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

impl<'a> Prepared<'a> {
    fn new(ds: &'a Dataset, opts: &DlagOptions) -> Result<Prepared<'a>, FitError> {
        let y = channel_values(ds, &opts.channel)?.to_vec();
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
        let modes: Vec<super::Mode> = terms
            .iter()
            .zip(&gains)
            .filter_map(|(t, g)| self.speeds.as_ref().and_then(|s| t.mode(*g, s)))
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

impl Prepared<'_> {
    /// The trend gain among `gains` with the lowest pooled RMS after probing every `every` minutes: each
    /// fold's fit (at `penalty`, on the columns `cols`) predicts its test rows, which a probe corrects from
    /// the fold's origin on. `None` without a fold or a candidate.
    fn choose_trend_gain(
        &self,
        cols: &[Vec<f64>],
        penalty: f64,
        every: f64,
        gains: &[f64],
    ) -> Option<ProbeChoice> {
        let runs: Vec<std::ops::Range<usize>> = self.ds.runs().collect();
        let mut sse = vec![0.0; gains.len()];
        let mut scored = 0usize;
        let s = &self.stretches;
        for k in 0..s.len().saturating_sub(1) {
            let test: Vec<usize> = s[k + 1..].concat();
            let train: Vec<usize> = s[..=k].concat();
            let Some(ridge) = Ridge::new(&Moments::of_rows(cols, &self.y, &train)) else {
                continue;
            };
            let fit = ridge.solve(penalty);
            let mut err = vec![f64::NAN; self.ds.len()];
            let mut window = vec![false; self.ds.len()];
            for &i in &test {
                let predicted = fit.intercept
                    + cols
                        .iter()
                        .zip(fit.beta.iter())
                        .map(|(c, b)| b * c[i])
                        .sum::<f64>();
                err[i] = self.y[i] - predicted;
                window[i] = true;
            }
            for (acc, &trend_gain) in sse.iter_mut().zip(gains) {
                let probing = Probing {
                    every_min: every,
                    trend_gain,
                };
                let out = rezeroed(&self.ds.time_min, &runs, &err, &window, probing);
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

fn sum(parts: &[Moments]) -> Moments {
    parts[1..].iter().fold(parts[0].clone(), |a, b| a.plus(b))
}
