//! The joint refit: the declared model's own parameters and every added effect fitted together on the fit
//! window, by variable projection — amplitudes by linear least squares for fixed θ, θ (log time
//! constants, log cooling ratio) by Levenberg–Marquardt with a finite-difference Jacobian of the projected
//! residual. Step times are not iterated (they enter discontinuously); the candidate scan places them.
//!
//! Recalibration keeps each spindle mode's speed shape (its gains across the grid, as characterised) and
//! refits its scale and time constant: a production log rarely visits every grid speed, and a free gain per
//! node would leave the unvisited ones undetermined.

use std::ops::Range;

use nalgebra::DMatrix;

use crate::data::{Dataset, SPINDLE};
use crate::model::effects::cooling_asymmetry::Phase;
use crate::model::effects::{Effect, Kind, Series, input_lag};
use crate::model::lag::Decay;
use crate::model::speed_grid::{SpeedGrid, Weights};
use crate::model::varpro::{dot, solve_normal};
use crate::model::{DataProvenance, DriftModel, Mode};

/// Which rows are held out: only scored, never fitted or selected on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Holdout {
    /// Every row is fitted (the numbers are in-sample).
    None,
    /// Rows from this time (minutes of the data's time axis) on.
    From(f64),
    /// The last fraction of the data's elapsed time (runs laid end to end in file order).
    LastFraction(f64),
}

/// The measured data of one diagnosis laid out for the refits. Every row drives the recursions (its
/// inputs hold until the next row); only rows with a reading are fitted, scored and tested.
pub struct Ctx<'a> {
    pub ds: &'a Dataset,
    /// The channel per row; NaN where it was not measured.
    pub y: Vec<f64>,
    pub runs: Vec<Range<usize>>,
    pub rpm: Option<&'a [f64]>,
    /// Rows with a reading.
    pub measured: Vec<bool>,
    /// Rows used for fitting and selecting (a reading, time before the holdout).
    pub fit: Vec<bool>,
    pub n_fit: usize,
    /// Rows scored only (a reading, time from the holdout on).
    pub n_holdout: usize,
    /// Time (min) of the first holdout row, if any.
    pub holdout_from_min: Option<f64>,
    /// Rows before the holdout, with a reading or not (the window the inputs are judged on).
    pub in_window: Vec<bool>,
    /// Forward-validation folds over the fit rows (train before each origin, test after).
    pub folds: Vec<crate::model::forward::Fold>,
    /// Bounds on the declared model's time constants (min).
    pub tau_bounds: (f64, f64),
    /// Duration the fit rows cover (min).
    pub span: f64,
}

impl<'a> Ctx<'a> {
    pub fn new(ds: &'a Dataset, channel: &str, holdout: Holdout) -> Option<Ctx<'a>> {
        let y = ds.values(channel)?.to_vec();
        let measured = crate::data::measured(&y);
        let elapsed = crate::model::forward::elapsed(ds);
        let in_window: Vec<bool> = match holdout {
            Holdout::None => vec![true; ds.len()],
            Holdout::From(h) => ds.time_min.iter().map(|&t| t < h).collect(),
            Holdout::LastFraction(f) => {
                let end = elapsed.last().copied().unwrap_or(0.0);
                elapsed.iter().map(|&e| e < end * (1.0 - f)).collect()
            }
        };
        let fit: Vec<bool> = in_window
            .iter()
            .zip(&measured)
            .map(|(&w, &m)| m && w)
            .collect();
        let holdout_from_min = (0..ds.len())
            .find(|&i| !in_window[i])
            .map(|i| ds.time_min[i]);
        let folds = crate::model::forward::Origins::default().folds(&elapsed, &fit);
        let n_fit = fit.iter().filter(|f| **f).count();
        let n_holdout = measured.iter().filter(|m| **m).count() - n_fit;
        let span = fit_span(ds, &fit);
        let lo = ds.min_step_min().unwrap_or(1.0).max(1e-3);
        Some(Ctx {
            ds,
            y,
            runs: ds.runs().collect(),
            rpm: ds.values(SPINDLE),
            measured,
            fit,
            n_fit,
            n_holdout,
            holdout_from_min,
            in_window,
            folds,
            tau_bounds: (lo, (3.0 * span).max(4.0 * lo)),
            span,
        })
    }

    /// The same data with only the rows `train` to fit on (a fold of the forward validation); bounds and
    /// span stay those of the whole window, so a fold's refit searches the same space.
    pub fn training(&self, train: &[usize]) -> Ctx<'a> {
        let mut fit = vec![false; self.n()];
        for &i in train {
            fit[i] = true;
        }
        Ctx {
            ds: self.ds,
            y: self.y.clone(),
            runs: self.runs.clone(),
            rpm: self.rpm,
            measured: self.measured.clone(),
            n_fit: train.len(),
            n_holdout: 0,
            holdout_from_min: self.holdout_from_min,
            in_window: self.in_window.clone(),
            folds: Vec::new(),
            fit,
            tau_bounds: self.tau_bounds,
            span: self.span,
        }
    }

    /// Bounds on an effect's time constant: a lag much longer than the fit window cannot be told from a
    /// trend, so an input's lag stays within the window's span and a further mode within twice it.
    pub fn effect_tau_bounds(&self, kind: Kind) -> (f64, f64) {
        let reach = if kind == Kind::ExtraMode { 2.0 } else { 1.0 };
        let hi = (reach * self.span).clamp(2.0 * self.tau_bounds.0, self.tau_bounds.1);
        (self.tau_bounds.0, hi)
    }

    pub fn series(&self, signal: Option<&str>) -> Series<'_> {
        Series {
            t: &self.ds.time_min,
            runs: &self.runs,
            rpm: self.rpm,
            signal: signal.and_then(|s| self.ds.values(s)),
            position: None,
        }
    }

    /// The columns `e` reads (its signal and, for the kinds that have one, its position).
    pub fn effect_series(&self, e: &Effect) -> Series<'_> {
        e.series(&self.ds.time_min, &self.runs, self.rpm, |n| {
            self.ds.values(n)
        })
    }

    pub fn n(&self) -> usize {
        self.y.len()
    }

    /// The fit-window values of a full-length series.
    pub fn fit_rows(&self, v: &[f64]) -> Vec<f64> {
        v.iter()
            .zip(&self.fit)
            .filter(|(_, f)| **f)
            .map(|(x, _)| *x)
            .collect()
    }
}

/// Duration covered by the fit rows (min).
fn fit_span(ds: &Dataset, fit: &[bool]) -> f64 {
    let t: Vec<f64> = ds
        .time_min
        .iter()
        .zip(fit)
        .filter(|(_, f)| **f)
        .map(|(t, _)| *t)
        .collect();
    let lo = t.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = t.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if hi > lo { hi - lo } else { 1.0 }
}

/// A model structure: the declared model (its mode shapes, inputs) plus effects, with current values.
#[derive(Debug, Clone)]
pub struct Joint {
    pub base: DriftModel,
    /// The base model's whole prediction (offset removed), when its design is kept as it is: a model whose
    /// terms were chosen by forward validation (`fit --kind dlag`) is not refitted term by term on the
    /// window — its prediction is one column with one scale, and only the added effects are fitted.
    pub frozen: Option<std::sync::Arc<Vec<f64>>>,
    pub effects: Vec<Effect>,
}

/// A refitted structure: the model, its prediction on every row and its fit-window RSS.
#[derive(Debug, Clone)]
pub struct Fitted {
    pub joint: Joint,
    pub model: DriftModel,
    pub prediction: Vec<f64>,
    pub rss: f64,
}

impl Joint {
    fn grid(&self) -> SpeedGrid {
        SpeedGrid::new(self.base.spindle.grid_rpm.clone())
            .unwrap_or_else(|| SpeedGrid::from_speeds(&[]))
    }

    fn cooling_ratio_index(&self) -> Option<usize> {
        self.effects
            .iter()
            .position(|e| e.kind == Kind::CoolingAsymmetry)
    }

    /// A structure starting from `model`: its effects join the refit, unless the model's design is kept
    /// (see [`Joint::frozen`]), in which case they stay part of the base.
    pub fn start(model: &DriftModel, ds: &Dataset) -> Result<Joint, crate::model::PredictError> {
        let keep = model.fit.as_ref().is_some_and(|f| f.forward.is_some());
        if keep {
            let column = model
                .predict(ds)?
                .into_iter()
                .map(|p| p - model.offset_um)
                .collect();
            return Ok(Joint {
                base: model.clone(),
                frozen: Some(std::sync::Arc::new(column)),
                effects: Vec::new(),
            });
        }
        let mut base = model.clone();
        base.effects.clear();
        Ok(Joint {
            base,
            frozen: None,
            effects: model
                .effects
                .iter()
                .map(Effect::from_spec)
                .collect::<Result<_, _>>()?,
        })
    }

    /// Spindle modes and inputs refitted one by one (none when the base is frozen).
    fn own_modes(&self) -> &[Mode] {
        if self.frozen.is_some() {
            &[]
        } else {
            &self.base.spindle.modes
        }
    }

    fn own_inputs(&self) -> &[crate::model::InputLag] {
        if self.frozen.is_some() {
            &[]
        } else {
            &self.base.inputs
        }
    }

    /// Columns of the base before the effects': one per mode and input, or the frozen prediction.
    fn n_base(&self) -> usize {
        if self.frozen.is_some() {
            1
        } else {
            self.base.spindle.modes.len() + self.base.inputs.len()
        }
    }

    /// θ in the iterated coordinates: ln τ of modes, ln τ of inputs, ln of each effect's smooth θ.
    pub fn theta(&self) -> Vec<f64> {
        let modes = self.own_modes().iter().map(|m| m.tau_min.ln());
        let inputs = self.own_inputs().iter().map(|i| i.tau_min.ln());
        let effects = self
            .effects
            .iter()
            .filter(|e| e.kind.theta_smooth())
            .flat_map(|e| e.theta.iter().map(|v| v.ln()));
        modes.chain(inputs).chain(effects).collect()
    }

    /// Bounds of each θ entry.
    fn bounds(&self, ctx: &Ctx) -> Vec<(f64, f64)> {
        let tau = (ctx.tau_bounds.0.ln(), ctx.tau_bounds.1.ln());
        let k = self.own_modes().len() + self.own_inputs().len();
        let mut b = vec![tau; k];
        for e in self.effects.iter().filter(|e| e.kind.theta_smooth()) {
            let r = match e.kind {
                Kind::CoolingAsymmetry => (0.1f64.ln(), 10f64.ln()),
                kind => {
                    let (lo, hi) = ctx.effect_tau_bounds(kind);
                    (lo.ln(), hi.ln())
                }
            };
            b.extend(std::iter::repeat_n(r, e.theta.len()));
        }
        b
    }

    fn with_theta(&self, theta: &[f64]) -> Joint {
        let mut j = self.clone();
        let mut it = theta.iter().map(|v| v.exp());
        if j.frozen.is_none() {
            for m in &mut j.base.spindle.modes {
                m.tau_min = it.next().unwrap_or(m.tau_min);
            }
            for i in &mut j.base.inputs {
                i.tau_min = it.next().unwrap_or(i.tau_min);
            }
        }
        for e in j.effects.iter_mut().filter(|e| e.kind.theta_smooth()) {
            for v in &mut e.theta {
                *v = it.next().unwrap_or(*v);
            }
        }
        j
    }

    /// Number of amplitude columns.
    pub fn n_linear(&self) -> usize {
        self.n_base()
            + self
                .effects
                .iter()
                .map(|e| e.amplitudes.len())
                .sum::<usize>()
            + 1
    }

    /// Number of θ entries (iterated and scanned).
    pub fn n_nonlinear(&self) -> usize {
        self.own_modes().len()
            + self.own_inputs().len()
            + self.effects.iter().map(|e| e.theta.len()).sum::<usize>()
    }

    /// The columns (N × P, all rows) for the current values: one per mode (its characterised speed shape),
    /// one per input, the effects' columns, the offset.
    pub fn basis(&self, ctx: &Ctx) -> DMatrix<f64> {
        let n = ctx.n();
        let mut phi = DMatrix::zeros(n, self.n_linear());
        let mut cols: Vec<&mut [f64]> = phi.as_mut_slice().chunks_mut(n).collect();
        let ratio = self.cooling_ratio_index().map(|i| self.effects[i].theta[0]);
        let mut at = 0;
        if let Some(frozen) = &self.frozen {
            cols[0].copy_from_slice(frozen);
            at = 1;
        } else if let Some(rpm) = ctx.rpm {
            let grid = self.grid();
            let w: Vec<Weights> = rpm.iter().map(|&s| grid.weights(s)).collect();
            for m in &self.base.spindle.modes {
                mode_column(ctx, rpm, &w, m, ratio, cols[at]);
                at += 1;
            }
        } else {
            at += self.base.spindle.modes.len();
        }
        for i in self.own_inputs() {
            input_lag::columns(&ctx.series(Some(&i.signal)), i.tau_min, cols[at]);
            at += 1;
        }
        for e in &self.effects {
            let k = e.amplitudes.len();
            e.columns(&ctx.effect_series(e), &e.theta, &mut cols[at..at + k]);
            at += k;
        }
        cols[at].fill(1.0);
        phi
    }

    /// Amplitudes for the current θ on the rows `rows` (least squares), `None` if singular.
    pub fn amplitudes(&self, phi: &DMatrix<f64>, y: &[f64], rows: &[bool]) -> Option<Vec<f64>> {
        let (gram, b) = normal_equations(phi, y, rows);
        solve_normal(&gram, &b).map(|c| c.as_slice().to_vec())
    }

    /// Refits everything on the fit window starting from the current values.
    pub fn refit(&self, ctx: &Ctx) -> Option<Fitted> {
        let bounds = self.bounds(ctx);
        let theta0: Vec<f64> = self
            .theta()
            .iter()
            .zip(&bounds)
            .map(|(t, (lo, hi))| t.clamp(*lo, *hi))
            .collect();
        let rss_at = |theta: &[f64]| -> Option<f64> {
            let j = self.with_theta(theta);
            let phi = j.basis(ctx);
            let c = j.amplitudes(&phi, &ctx.y, &ctx.fit)?;
            Some(fit_rss(&phi, &c, &ctx.y, &ctx.fit))
        };
        let theta = levenberg_marquardt(ctx, self, &theta0, &bounds, rss_at)?;
        self.with_theta(&theta).finish(ctx)
    }

    /// Amplitudes for the current θ and the model they make.
    pub fn finish(&self, ctx: &Ctx) -> Option<Fitted> {
        let phi = self.basis(ctx);
        let c = self.amplitudes(&phi, &ctx.y, &ctx.fit)?;
        let mut prediction = vec![0.0; ctx.n()];
        for (col, cj) in phi.as_slice().chunks(ctx.n()).zip(&c) {
            for (p, v) in prediction.iter_mut().zip(col) {
                *p += cj * v;
            }
        }
        let rss = fit_rss(&phi, &c, &ctx.y, &ctx.fit);
        // The scaled gains become the modes' shapes, so a further refit starts from scale 1.
        let mut joint = self.clone();
        let mut it = c.iter().copied();
        if let Some(frozen) = &self.frozen {
            let scale = it.next().unwrap_or(1.0);
            joint.base = scaled(&self.base, scale);
            joint.frozen = Some(std::sync::Arc::new(
                frozen.iter().map(|v| v * scale).collect(),
            ));
        } else {
            for m in &mut joint.base.spindle.modes {
                let scale = it.next().unwrap_or(1.0);
                for g in &mut m.gain_um {
                    *g *= scale;
                }
                m.tau_se_min = None;
                m.gain_se_um.clear();
            }
            for i in &mut joint.base.inputs {
                i.gain_um_per_unit = it.next().unwrap_or(0.0);
                i.tau_se_min = None;
                i.gain_se_um_per_unit = None;
            }
        }
        for e in &mut joint.effects {
            for a in &mut e.amplitudes {
                *a = it.next().unwrap_or(0.0);
            }
        }
        joint.base.offset_um = it.next().unwrap_or(0.0);
        let mut model = joint.base.clone();
        model
            .effects
            .extend(joint.effects.iter().map(Effect::to_spec));
        model.fit = None;
        model.data = Some(DataProvenance {
            file: ctx.ds.source.clone(),
            sha256: ctx.ds.sha256.clone().unwrap_or_default(),
            rows: ctx.n(),
            time_unit: ctx.ds.time_unit,
        });
        Some(Fitted {
            joint,
            model,
            prediction,
            rss,
        })
    }
}

/// The model with every gain and amplitude (not the offset) multiplied by `scale`.
fn scaled(model: &DriftModel, scale: f64) -> DriftModel {
    let mut m = model.clone();
    for mode in &mut m.spindle.modes {
        mode.gain_um.iter_mut().for_each(|g| *g *= scale);
        mode.gain_se_um.clear();
    }
    for i in &mut m.inputs {
        i.gain_um_per_unit *= scale;
        i.gain_se_um_per_unit = None;
    }
    for spec in &mut m.effects {
        // Every effect of a model that predicts is known (`Joint::start` predicted with it).
        if let Ok(mut e) = Effect::from_spec(spec) {
            e.amplitudes.iter_mut().for_each(|a| *a *= scale);
            *spec = e.to_spec();
        }
    }
    m
}

/// One spindle mode's response to its characterised gain shape (scale 1), cooling with τ·ratio when set.
fn mode_column(
    ctx: &Ctx,
    rpm: &[f64],
    w: &[Weights],
    m: &Mode,
    ratio: Option<f64>,
    out: &mut [f64],
) {
    let mut heat = Decay::new(m.tau_min);
    let mut cool = Decay::new(m.tau_min * ratio.unwrap_or(1.0));
    for run in &ctx.runs {
        if run.is_empty() {
            continue;
        }
        let mut x = 0.0;
        let mut phase = Phase::new(rpm[run.start]);
        out[run.start] = 0.0;
        for i in run.start + 1..run.end {
            let dt = ctx.ds.time_min[i] - ctx.ds.time_min[i - 1];
            let cooling = phase.cooling(rpm[i - 1]);
            let e = if cooling && ratio.is_some() {
                cool.at(dt)
            } else {
                heat.at(dt)
            };
            let g = w[i - 1].apply(&m.gain_um);
            x = g + (x - g) * e;
            out[i] = x;
        }
    }
}

/// ΦᵀΦ and Φᵀy over the selected rows.
pub fn normal_equations(
    phi: &DMatrix<f64>,
    y: &[f64],
    rows: &[bool],
) -> (DMatrix<f64>, DMatrix<f64>) {
    let n = y.len();
    let p = phi.ncols();
    // Only the selected rows, gathered once: rows left out may hold no reading (NaN), and a long log's
    // holdout need not be carried through the p² products.
    let keep: Vec<usize> = (0..n).filter(|&r| rows[r]).collect();
    let gather = |c: &[f64]| -> Vec<f64> { keep.iter().map(|&r| c[r]).collect() };
    let masked: Vec<Vec<f64>> = phi.as_slice().chunks(n).map(gather).collect();
    let y = gather(y);
    let mut gram = DMatrix::zeros(p, p);
    let mut b = DMatrix::zeros(p, 1);
    for i in 0..p {
        for j in i..p {
            let v = dot(&masked[i], &masked[j]);
            gram[(i, j)] = v;
            gram[(j, i)] = v;
        }
        b[(i, 0)] = dot(&masked[i], &y);
    }
    (gram, b)
}

/// Σ (y − Φc)² over the selected rows.
pub fn fit_rss(phi: &DMatrix<f64>, c: &[f64], y: &[f64], rows: &[bool]) -> f64 {
    let n = y.len();
    let mut r = y.to_vec();
    for (col, cj) in phi.as_slice().chunks(n).zip(c) {
        for (ri, v) in r.iter_mut().zip(col) {
            *ri -= cj * v;
        }
    }
    r.iter()
        .zip(rows)
        .filter(|(_, f)| **f)
        .map(|(v, _)| v * v)
        .sum()
}

/// Bounded Levenberg–Marquardt on the projected residual with a forward-difference Jacobian; returns θ.
fn levenberg_marquardt(
    ctx: &Ctx,
    joint: &Joint,
    theta0: &[f64],
    bounds: &[(f64, f64)],
    rss_at: impl Fn(&[f64]) -> Option<f64>,
) -> Option<Vec<f64>> {
    let q = theta0.len();
    let resid_at = |theta: &[f64]| -> Option<Vec<f64>> {
        let j = joint.with_theta(theta);
        let phi = j.basis(ctx);
        let c = j.amplitudes(&phi, &ctx.y, &ctx.fit)?;
        let mut r = ctx.y.clone();
        for (col, cj) in phi.as_slice().chunks(ctx.n()).zip(&c) {
            for (ri, v) in r.iter_mut().zip(col) {
                *ri -= cj * v;
            }
        }
        Some(ctx.fit_rows(&r))
    };
    let mut theta = theta0.to_vec();
    let mut r = resid_at(&theta)?;
    let mut rss = dot(&r, &r);
    if q == 0 {
        return Some(theta);
    }
    let mut lambda = 1e-2;
    for _ in 0..40 {
        let h = 1e-4;
        // One basis and projection per parameter, independent of each other: on all cores.
        let jac: Vec<Vec<f64>> = {
            use rayon::prelude::*;
            (0..q)
                .into_par_iter()
                .map(|k| {
                    let mut t = theta.clone();
                    // Step inward at an upper bound so the difference stays inside.
                    t[k] += if theta[k] + h > bounds[k].1 { -h } else { h };
                    let rk = resid_at(&t)?;
                    let d = t[k] - theta[k];
                    Some(r.iter().zip(&rk).map(|(a, b)| (a - b) / d).collect())
                })
                .collect::<Option<_>>()?
        };
        // Gauss–Newton on r(θ) ≈ r − J δ (J = −∂r/∂θ as built above).
        let jtj = DMatrix::from_fn(q, q, |a, b| dot(&jac[a], &jac[b]));
        let jtr = DMatrix::from_fn(q, 1, |a, _| dot(&jac[a], &r));
        let mut improved = false;
        for _ in 0..10 {
            let mut damped = jtj.clone();
            for a in 0..q {
                damped[(a, a)] += lambda * jtj[(a, a)].max(1e-12);
            }
            let Some(delta) = solve_normal(&damped, &jtr) else {
                lambda *= 10.0;
                continue;
            };
            let trial: Vec<f64> = (0..q)
                .map(|a| (theta[a] + delta[a]).clamp(bounds[a].0, bounds[a].1))
                .collect();
            match rss_at(&trial) {
                Some(v) if v < rss => {
                    let gain = (rss - v) / rss.max(f64::MIN_POSITIVE);
                    theta = trial;
                    r = resid_at(&theta)?;
                    rss = dot(&r, &r);
                    lambda = (lambda * 0.3).max(1e-9);
                    improved = gain > 1e-8;
                    break;
                }
                _ => lambda *= 5.0,
            }
        }
        if !improved {
            break;
        }
    }
    Some(theta)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::synth::{Rng, measure};
    use crate::model::{Schedule, effects::Effect};

    #[test]
    fn refit_recovers_a_scaled_mode_and_an_input_lag_and_matches_predict() {
        let declared = DriftModel::from_modes(
            "z_um",
            vec![2000.0, 4000.0],
            &[(40.0, vec![4.0, 10.0])],
            0.0,
        );
        let mut truth = DriftModel::from_modes(
            "z_um",
            vec![2000.0, 4000.0],
            &[(55.0, vec![6.0, 15.0])],
            1.0,
        );
        let lag = Effect {
            kind: Kind::InputLag,
            signal: Some("ambient_c".into()),
            position: None,
            theta: vec![90.0],
            amplitudes: vec![-2.0],
        };
        truth.effects.push(lag.to_spec());
        let mut ds = "2000:200,4000:150,0:100,4000:150"
            .parse::<Schedule>()
            .unwrap()
            .to_dataset(2.0);
        let amb: Vec<f64> = ds
            .time_min
            .iter()
            .map(|t| 20.0 + 2.0 * (t / 200.0).sin())
            .collect();
        ds.push_column("ambient_c", amb);
        measure(&truth, &mut ds, 0.05, &mut Rng::new(5)).unwrap();
        let ctx = Ctx::new(&ds, "z_um", Holdout::None).unwrap();
        let mut start = lag.clone();
        start.theta = vec![40.0];
        start.amplitudes = vec![0.0];
        let joint = Joint {
            base: declared,
            frozen: None,
            effects: vec![start],
        };
        let fitted = joint.refit(&ctx).unwrap();
        let m = &fitted.model;
        assert!((m.spindle.modes[0].tau_min - 55.0).abs() < 2.0, "{m:?}");
        assert!((m.spindle.modes[0].gain_um[1] - 15.0).abs() < 0.3);
        assert!((m.offset_um - 1.0).abs() < 0.1);
        let e = Effect::from_spec(&m.effects[0]).unwrap();
        assert!(
            (e.theta[0] - 90.0).abs() < 10.0 && (e.amplitudes[0] + 2.0).abs() < 0.2,
            "{e:?}"
        );
        // The model file predicts exactly what the refit computed.
        let again = m.predict(&ds).unwrap();
        for (a, b) in again.iter().zip(&fitted.prediction) {
            assert!((a - b).abs() < 1e-9);
        }
    }
}
