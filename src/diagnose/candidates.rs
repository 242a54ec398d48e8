//! The candidate library: which effects can be tried on a dataset, the θ values each is scanned at, and the
//! screening of one candidate against the current residual.
//!
//! Screening projects the candidate's columns off the current model's columns (on the fit window) and
//! regresses the residual on what is left: the RSS drop the candidate would bring with the current θ of
//! everything else held. Its score is a BIC difference on an effective sample size taken from the
//! residual *with* the candidate, n·(1 − ρ)/(1 + ρ): if the candidate leaves correlated structure behind,
//! the data carry less independent information and the penalty weighs more.

use nalgebra::DMatrix;

use super::joint::{Ctx, Fitted};
use super::stats::effective_n;
use crate::data::ColumnKind;
use crate::model::effects::periodic::PERIOD_MIN;
use crate::model::effects::{Effect, Kind};
use crate::model::varpro::{dot, solve_normal};

/// Time constants scanned (as fractions of the fit window's span, bounded by the sampling step).
const TAU_POINTS: usize = 8;
/// Cooling-to-heating time-constant ratios scanned.
const RATIOS: [f64; 6] = [0.3, 0.5, 0.7, 1.5, 2.0, 3.0];
/// Step times scanned across the fit window.
const STEP_POINTS: usize = 48;

/// An effect not yet in the model, with a θ to start from and its screening score.
#[derive(Debug, Clone)]
pub struct Screened {
    pub effect: Effect,
    /// BIC(with) − BIC(without) on the effective sample size; negative favours the candidate.
    pub delta_bic: f64,
}

/// Every candidate effect the data and the current model allow, θ unset.
pub fn candidates(ctx: &Ctx, current: &Fitted) -> Vec<Effect> {
    let model = &current.model;
    let declared = model.declared_inputs();
    let has = |kind: Kind, signal: Option<&str>| {
        current
            .joint
            .effects
            .iter()
            .any(|e| e.kind == kind && e.signal.as_deref() == signal)
    };
    let blank = |kind: Kind, signal: Option<&str>| Effect {
        kind,
        signal: signal.map(str::to_string),
        position: None,
        theta: vec![0.0; kind.theta_names().len()],
        amplitudes: vec![0.0; kind.amplitude_names().len()],
    };
    let mut out = Vec::new();
    for col in ctx.ds.candidate_signals(&declared) {
        if col.kind == ColumnKind::Spindle || !varies(&ctx.fit_rows(&col.values)) {
            continue;
        }
        let kind = match col.kind {
            ColumnKind::Position => Kind::PositionSlope,
            _ => Kind::InputLag,
        };
        if kind == Kind::PositionSlope && ctx.rpm.is_none() {
            continue;
        }
        if !has(kind, Some(&col.name)) {
            out.push(blank(kind, Some(&col.name)));
        }
    }
    let spindle_runs = ctx.rpm.is_some_and(|r| varies(&ctx.fit_rows(r)));
    if spindle_runs && !has(Kind::ExtraMode, None) {
        out.push(blank(Kind::ExtraMode, None));
    }
    if spindle_runs && !model.spindle.modes.is_empty() && !has(Kind::CoolingAsymmetry, None) {
        out.push(blank(Kind::CoolingAsymmetry, None));
    }
    for kind in [Kind::TimeTrend, Kind::Periodic, Kind::Step] {
        // A daily cycle cannot be told from a trend on less than half a day.
        if kind == Kind::Periodic && ctx.span < PERIOD_MIN / 2.0 {
            continue;
        }
        if !has(kind, None) {
            out.push(blank(kind, None));
        }
    }
    out
}

fn varies(v: &[f64]) -> bool {
    v.iter().any(|x| (x - v[0]).abs() > 1e-12)
}

/// θ values (natural units) a candidate is scanned at.
fn theta_grid(ctx: &Ctx, kind: Kind) -> Vec<Vec<f64>> {
    let span = ctx.span;
    match kind {
        Kind::InputLag | Kind::ExtraMode | Kind::PositionSlope => {
            // From a few sampling steps (an unlagged input) to the bound, log-spaced.
            let (lo, b) = ctx.effect_tau_bounds(kind);
            let a = (3.0 * lo).min(b / 10.0).max(lo);
            (0..TAU_POINTS)
                .map(|i| vec![a * (b / a).powf(i as f64 / (TAU_POINTS - 1) as f64)])
                .collect()
        }
        Kind::CoolingAsymmetry => RATIOS.iter().map(|r| vec![*r]).collect(),
        Kind::Step => {
            let t = ctx.fit_rows(&ctx.ds.time_min);
            let t0 = t.iter().copied().fold(f64::INFINITY, f64::min);
            (1..STEP_POINTS)
                .map(|i| vec![t0 + span * (0.04 + 0.92 * i as f64 / STEP_POINTS as f64)])
                .collect()
        }
        Kind::TimeTrend
        | Kind::Periodic
        | Kind::StaticInput
        | Kind::InputSlope
        | Kind::Geometric => vec![vec![]],
    }
}

/// The candidate's columns on all rows for θ. `cooling_asymmetry` has none of its own: its column is the
/// change of the current model's prediction when its modes cool with the ratio.
fn candidate_columns(ctx: &Ctx, current: &Fitted, effect: &Effect) -> Option<Vec<Vec<f64>>> {
    let n = ctx.n();
    if effect.kind == Kind::CoolingAsymmetry {
        let mut m = current.model.clone();
        m.effects.push(effect.to_spec());
        let with = m.predict(ctx.ds).ok()?;
        return Some(vec![
            with.iter()
                .zip(&current.prediction)
                .map(|(a, b)| a - b)
                .collect(),
        ]);
    }
    let mut store = vec![vec![0.0; n]; effect.amplitudes.len()];
    let mut cols: Vec<&mut [f64]> = store.iter_mut().map(|c| c.as_mut_slice()).collect();
    effect.columns(&ctx.effect_series(effect), &effect.theta, &mut cols);
    Some(store)
}

/// Orthonormal basis (fit rows) of the current model's columns, for projecting candidates off them.
pub struct Projector {
    q: Vec<Vec<f64>>,
}

impl Projector {
    pub fn new(ctx: &Ctx, current: &Fitted) -> Projector {
        let phi = current.joint.basis(ctx);
        let mut q: Vec<Vec<f64>> = Vec::new();
        for col in phi.as_slice().chunks(ctx.n()) {
            let mut v = ctx.fit_rows(col);
            let norm0 = dot(&v, &v).sqrt();
            for b in &q {
                let a = dot(&v, b);
                v.iter_mut().zip(b).for_each(|(x, y)| *x -= a * y);
            }
            let norm = dot(&v, &v).sqrt();
            if norm > 1e-9 * norm0.max(f64::MIN_POSITIVE) {
                v.iter_mut().for_each(|x| *x /= norm);
                q.push(v);
            }
        }
        Projector { q }
    }

    fn project_off(&self, v: &mut [f64]) {
        for b in &self.q {
            let a = dot(v, b);
            v.iter_mut().zip(b).for_each(|(x, y)| *x -= a * y);
        }
    }
}

/// The best θ of one candidate on the grid, with its score; `None` when it explains nothing. A step's
/// time is refined to the sampled times between the neighbours of the best grid time.
pub fn screen(
    ctx: &Ctx,
    current: &Fitted,
    proj: &Projector,
    resid: &[f64],
    cand: &Effect,
) -> Option<Screened> {
    let grid = theta_grid(ctx, cand.kind);
    let mut best = best_of(ctx, current, proj, resid, cand, &grid)?;
    if cand.kind == Kind::Step {
        let at = best.effect.theta[0];
        let half = ctx.span / STEP_POINTS as f64;
        let fine: Vec<Vec<f64>> = ctx
            .fit_rows(&ctx.ds.time_min)
            .into_iter()
            .filter(|t| (t - at).abs() <= half)
            .map(|t| vec![t])
            .collect();
        if let Some(b) = best_of(ctx, current, proj, resid, cand, &fine) {
            if b.delta_bic < best.delta_bic {
                best = b;
            }
        }
    }
    Some(best)
}

fn best_of(
    ctx: &Ctx,
    current: &Fitted,
    proj: &Projector,
    resid: &[f64],
    cand: &Effect,
    grid: &[Vec<f64>],
) -> Option<Screened> {
    let rss0 = dot(resid, resid);
    let dof = (cand.amplitudes.len() + cand.theta.len()) as f64;
    let mut best: Option<Screened> = None;
    for theta in grid {
        let mut e = cand.clone();
        e.theta = theta.clone();
        let Some(cols) = candidate_columns(ctx, current, &e) else {
            continue;
        };
        let cols: Vec<Vec<f64>> = cols
            .iter()
            .map(|c| {
                let mut v = ctx.fit_rows(c);
                proj.project_off(&mut v);
                v
            })
            .collect();
        let k = cols.len();
        let gram = DMatrix::from_fn(k, k, |a, b| dot(&cols[a], &cols[b]));
        if (0..k).any(|a| gram[(a, a)] <= 1e-12 * rss0.max(1e-12)) {
            continue;
        }
        let rhs = DMatrix::from_fn(k, 1, |a, _| dot(&cols[a], resid));
        let Some(beta) = solve_normal(&gram, &rhs) else {
            continue;
        };
        let mut r1 = resid.to_vec();
        for (c, b) in cols.iter().zip(beta.iter()) {
            r1.iter_mut().zip(c).for_each(|(x, y)| *x -= b * y);
        }
        let rss1 = dot(&r1, &r1);
        let n_eff = effective_n(&r1);
        let delta_bic = n_eff * (rss1.max(f64::MIN_POSITIVE) / rss0).ln() + dof * n_eff.ln();
        if best.as_ref().is_none_or(|b| delta_bic < b.delta_bic) {
            // Cooling asymmetry screens through a derived column but has no amplitude of its own.
            if e.kind != Kind::CoolingAsymmetry {
                e.amplitudes = beta.iter().copied().collect();
            }
            best = Some(Screened {
                effect: e,
                delta_bic,
            });
        }
    }
    best
}

/// One fold of the rolling-origin cross-validation: squared error summed over its test rows, their number,
/// and whether the columns under test could be estimated from its training rows.
#[derive(Debug, Clone, Copy)]
pub struct Fold {
    pub sse: f64,
    pub rows: usize,
    pub identifiable: bool,
}

/// Cross-validation on the fit window. A model is used to predict forward in time, so a single record is
/// validated forward (rolling origin): the fit rows are cut into `blocks` consecutive stretches and, from the
/// third on, each is predicted from amplitudes fitted on the stretches before it only (θ held); a term that
/// fits the past but extrapolates badly loses here, where leaving out an interior block would only test
/// interpolation. Data of several runs (independent experiments, each from rest: characterisation runs,
/// production jobs) are validated by leaving one run out instead: their order in the file is not time, and an
/// input that varies only in the later runs (a hall temperature logged by production jobs, constant during the
/// characterisation) could never be estimated from the stretches before them. A fold is marked not
/// identifiable for the columns `tested` when one of them does not vary over its training rows: such a fold
/// says nothing about that term.
pub fn cross_validate(
    ctx: &Ctx,
    fitted: &Fitted,
    blocks: usize,
    tested: std::ops::Range<usize>,
) -> Option<Vec<Fold>> {
    let phi = fitted.joint.basis(ctx);
    let splits = if ctx.runs.len() >= MIN_RUNS_FOR_RUN_CV {
        leave_one_run_out(ctx)
    } else {
        rolling_origin(ctx, blocks)
    };
    splits
        .into_iter()
        .map(|(train, test)| {
            let c = fitted.joint.amplitudes(&phi, &ctx.y, &train)?;
            let sse: f64 = test
                .iter()
                .map(|&i| {
                    let pred: f64 = (0..phi.ncols()).map(|j| phi[(i, j)] * c[j]).sum();
                    (ctx.y[i] - pred).powi(2)
                })
                .sum();
            let trained: Vec<usize> = (0..train.len()).filter(|&i| train[i]).collect();
            let identifiable = tested.clone().all(|j| {
                let col = phi.column(j);
                trained
                    .first()
                    .is_some_and(|&f| trained.iter().any(|&i| (col[i] - col[f]).abs() > 1e-12))
            });
            Some(Fold {
                sse,
                rows: test.len(),
                identifiable,
            })
        })
        .collect()
}

/// Runs needed before cross-validation leaves one run out rather than rolling forward in time.
const MIN_RUNS_FOR_RUN_CV: usize = 3;

/// (training mask, test rows) of the rolling-origin folds: block k ≥ 2 predicted from blocks 0..k.
fn rolling_origin(ctx: &Ctx, blocks: usize) -> Vec<(Vec<bool>, Vec<usize>)> {
    let n = ctx.n();
    let fit_idx: Vec<usize> = (0..n).filter(|&i| ctx.fit[i]).collect();
    let per = fit_idx.len().div_ceil(blocks.max(1)).max(1);
    let chunks: Vec<&[usize]> = fit_idx.chunks(per).collect();
    let mut train = vec![false; n];
    let mut splits = Vec::new();
    for (k, chunk) in chunks.iter().enumerate() {
        if k >= 2 {
            splits.push((train.clone(), chunk.to_vec()));
        }
        for &i in chunk.iter() {
            train[i] = true;
        }
    }
    splits
}

/// (training mask, test rows) with each run's fit rows predicted from the fit rows of all other runs.
fn leave_one_run_out(ctx: &Ctx) -> Vec<(Vec<bool>, Vec<usize>)> {
    ctx.runs
        .iter()
        .filter_map(|run| {
            let test: Vec<usize> = run.clone().filter(|&i| ctx.fit[i]).collect();
            if test.is_empty() {
                return None;
            }
            let train: Vec<bool> = (0..ctx.n())
                .map(|i| ctx.fit[i] && !run.contains(&i))
                .collect();
            Some((train, test))
        })
        .collect()
}

/// RMS over the folds `use_fold` keeps.
pub fn cv_rms(folds: &[Fold], use_fold: &[bool]) -> f64 {
    let (sse, rows) = folds
        .iter()
        .zip(use_fold)
        .filter(|(_, u)| **u)
        .fold((0.0, 0usize), |(s, r), (f, _)| (s + f.sse, r + f.rows));
    (sse / rows.max(1) as f64).sqrt()
}
