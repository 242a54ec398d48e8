//! The candidate library: which effects can be tried on a dataset, the θ values each is scanned at, and the
//! screening of one candidate against the current residual.
//!
//! Screening projects the candidate's columns off the current model's columns (on the fit window) and
//! regresses the residual on what is left: the RSS drop the candidate would bring with the current θ of
//! everything else held. Its score is a BIC difference on an effective sample size taken from the
//! residual *with* the candidate, n·(1 − ρ)/(1 + ρ): if the candidate leaves correlated structure behind,
//! the data carry less independent information and the penalty weighs more.

use nalgebra::DMatrix;

use super::joint::{Ctx, Fitted, Joint};
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
/// Most step times one scan around the grid's best tries (see [`screen`]).
const FINE_STEP_POINTS: usize = 512;

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
    // A kept (frozen) design is not refitted mode by mode, so its modes' cooling cannot be changed.
    if spindle_runs
        && !model.spindle.modes.is_empty()
        && current.joint.frozen.is_none()
        && !has(Kind::CoolingAsymmetry, None)
    {
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

/// Most fit rows a candidate is screened on. A longer log is screened on every k-th of its fit rows: the
/// screening only ranks the candidates and places their θ on a grid (the ones taken are refitted on every
/// row), thermal responses change over many samples, and it keeps the screening's cost bounded.
const SCREEN_ROWS: usize = 65_536;

/// Orthonormal basis (screened rows) of the current model's columns, for projecting candidates off them.
pub struct Projector {
    /// The rows screened: every fit row, or every k-th of a long log's.
    rows: Vec<usize>,
    q: Vec<Vec<f64>>,
}

impl Projector {
    pub fn new(ctx: &Ctx, current: &Fitted) -> Projector {
        let fit: Vec<usize> = (0..ctx.n()).filter(|&r| ctx.fit[r]).collect();
        let stride = fit.len().div_ceil(SCREEN_ROWS).max(1);
        let rows: Vec<usize> = fit.into_iter().step_by(stride).collect();
        let phi = current.joint.basis(ctx);
        let mut q: Vec<Vec<f64>> = Vec::new();
        for col in phi.as_slice().chunks(ctx.n()) {
            let mut v: Vec<f64> = rows.iter().map(|&r| col[r]).collect();
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
        Projector { rows, q }
    }

    /// The screened rows of a full-length series.
    pub fn screened(&self, v: &[f64]) -> Vec<f64> {
        self.rows.iter().map(|&r| v[r]).collect()
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
        // The step is placed at a row's time near the grid's best: every row time around it when there
        // are at most FINE_STEP_POINTS, else that many spread over them and again between the neighbours
        // of the best, until the rows are few enough to try each. A scan of every row near the grid's
        // best would cost rows² (a 400 000-row log: 16 000 scans of all rows).
        let mut times = ctx.fit_rows(&ctx.ds.time_min);
        times.sort_by(f64::total_cmp);
        times.dedup();
        let at = best.effect.theta[0];
        let half = ctx.span / STEP_POINTS as f64;
        let (mut lo, mut hi) = (at - half, at + half);
        loop {
            let window: Vec<f64> = times
                .iter()
                .copied()
                .filter(|t| (lo..=hi).contains(t))
                .collect();
            let stride = window.len().div_ceil(FINE_STEP_POINTS).max(1);
            let fine: Vec<Vec<f64>> = window.iter().step_by(stride).map(|t| vec![*t]).collect();
            if let Some(b) = best_of(ctx, current, proj, resid, cand, &fine)
                && b.delta_bic < best.delta_bic
            {
                best = b;
            }
            if stride == 1 {
                break;
            }
            let at = best.effect.theta[0];
            let k = fine.partition_point(|t| t[0] < at);
            lo = fine.get(k.wrapping_sub(1)).map_or(lo, |t| t[0]);
            hi = fine.get(k + 1).map_or(hi, |t| t[0]);
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
                let mut v = proj.screened(c);
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

/// One fold of the forward validation: squared error summed over its test rows, their number, and whether
/// the structure could be fitted on its training rows with the columns under test varying there.
#[derive(Debug, Clone, Copy)]
pub struct Fold {
    pub sse: f64,
    pub rows: usize,
    pub identifiable: bool,
}

/// Forward validation on the fit window (issue I.1: every choice judged on later time): for each origin
/// of `ctx.folds` the structure is refitted — amplitudes and time constants — on the rows before it and
/// predicts the rows after it. Data of several runs are taken in file order, each run after the one before
/// (characterisation runs, then production jobs as they were logged). A fold counts for the columns
/// `tested` only when each of them varies over its training rows: a term constant there (an input a later
/// job first moves, a step after the origin) cannot be estimated from that past, and the fold says nothing
/// about it.
pub fn forward_validate(ctx: &Ctx, joint: &Joint, tested: std::ops::Range<usize>) -> Vec<Fold> {
    let phi = joint.basis(ctx);
    ctx.folds
        .iter()
        .map(|fold| {
            let varies = tested.clone().all(|j| {
                let col = phi.column(j);
                fold.train
                    .first()
                    .is_some_and(|&f| fold.train.iter().any(|&i| (col[i] - col[f]).abs() > 1e-12))
            });
            let train = ctx.training(&fold.train);
            let refit = varies
                .then(|| rescan_steps(joint, &train).refit(&train))
                .flatten();
            match refit {
                Some(f) => Fold {
                    sse: fold
                        .test
                        .iter()
                        .map(|&i| (ctx.y[i] - f.prediction[i]).powi(2))
                        .sum(),
                    rows: fold.test.len(),
                    identifiable: true,
                },
                None => Fold {
                    sse: 0.0,
                    rows: fold.test.len(),
                    identifiable: false,
                },
            }
        })
        .collect()
}

/// The structure with each step's time scanned again on the fit rows of `ctx` (a fold's training rows):
/// the time a step was placed at on the whole window was chosen with the rows after the fold's origin, and
/// a forward fold must not know them. Other θ are refitted by the fold's refit itself.
fn rescan_steps(joint: &Joint, ctx: &Ctx) -> Joint {
    let mut out = joint.clone();
    let times = ctx.fit_rows(&ctx.ds.time_min);
    let (Some(&lo), Some(&hi)) = (times.first(), times.last()) else {
        return out;
    };
    for k in 0..out.effects.len() {
        if out.effects[k].kind != Kind::Step {
            continue;
        }
        let mut best: Option<(f64, f64)> = None;
        for i in 1..STEP_POINTS {
            let at = lo + (hi - lo) * (0.04 + 0.92 * i as f64 / STEP_POINTS as f64);
            let mut trial = out.clone();
            trial.effects[k].theta = vec![at];
            if let Some(f) = trial.finish(ctx)
                && best.is_none_or(|(_, rss)| f.rss < rss)
            {
                best = Some((at, f.rss));
            }
        }
        if let Some((at, _)) = best {
            out.effects[k].theta = vec![at];
        }
    }
    out
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
