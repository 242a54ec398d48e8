//! Closing the loop (design.md §1, issue 4): given a drift model and newly measured data, score the model,
//! recalibrate its own parameters, trace the residual to effects the model lacks, add them, refit
//! everything jointly and score again.
//!
//! 0. "before": the model as given, on every row.
//! 1. Recalibration on the fit window (the rows before the holdout): mode scales and time constants,
//!    declared inputs, offset ([`joint`]). A model from `fit --kind dlag` keeps its design (its lags were
//!    chosen by forward validation): its whole prediction gets one scale.
//! 2. While the fit-window residual is not white (Ljung–Box, 10 lags): screen every candidate of the
//!    library ([`candidates`]) on the residual, then, best score first, refit the model with the candidate
//!    jointly and accept it only if (a) the BIC on the effective sample size falls and (b) the forward
//!    error falls: refitted on the rows before each origin, predicting the rows after it, never the
//!    reverse ([`candidates::forward_validate`]).
//! 3. "after": the refined model on every row. Holdout rows are never used for fitting or selecting, with
//!    one exception, the last word: an "after" worse than "before" on the holdout is never reported —
//!    the effects are dropped again, last first, until it is not, and when even the recalibration alone is
//!    worse the model is kept as given and the report says that nothing helped.
//!
//! ```no_run
//! use driftloop::data::{Require, read_path};
//! use driftloop::diagnose::{Options, diagnose};
//! use driftloop::model::DriftModel;
//! # fn main() -> anyhow::Result<()> {
//! let model = DriftModel::read("model.toml".as_ref())?;
//! let data = read_path("log.csv".as_ref(), Require::Displacement)?;
//! let d = diagnose(&model, &data, &Options::new("ch3_um").holdout_from(960.0))?;
//! println!("{}", d.human());
//! std::fs::write("refined.toml", d.refined.to_toml())?;
//! # Ok(())
//! # }
//! ```

pub mod candidates;
pub mod holdout;
pub mod joint;
pub use crate::model::probing;
pub mod report;
pub mod scenario;
pub mod stats;
mod text;

use rayon::prelude::*;
use serde::Serialize;

use crate::data::{ColumnKind, Dataset};
use crate::model::DriftModel;
use crate::model::effects::{Effect, Kind};
use candidates::{Projector, cv_rms, forward_validate, screen};
pub use joint::Holdout;
use joint::{Ctx, Fitted, Joint};
use stats::{ErrorStats, effective_n, ljung_box_white};

/// Lags of the Ljung–Box whiteness test.
const WHITENESS_LAGS: usize = 10;
/// Least share of the fit-window residual variance an effect must explain to be worth adding. The declared
/// model never fits a new log exactly (its gain shape is an estimate), and on a dense log a wandering
/// temperature can "significantly" soak up a few hundredths of a micrometre of that misfit; an effect
/// that removes less than a tenth of what is left is not a finding a process engineer could act on.
const MIN_SHARE: f64 = 0.1;
/// A lagged effect whose target would move more than this many times the measured range over the logged
/// range of its input is refused, as `fit` refuses such a gain: with an input held between rows far apart
/// (a sparse log), a tiny logged change can buy a huge gain whose response the data never see (a 1 min lag
/// of +430 µm/°C fed by 0.004 °C of sensor creep).
const IMPLAUSIBLE_REACH: f64 = 10.0;
/// Best-screened candidates given a full joint refit per round. Screening holds the rest of the model
/// fixed, so a candidate that overlaps a declared term (a slow mode next to a recalibrated one) screens
/// low but refits well; the joint BIC decides among these.
const REFITS_PER_ROUND: usize = 5;

/// What to diagnose.
#[derive(Debug, Clone)]
pub struct Options {
    pub channel: String,
    /// The rows only scored, never fitted or selected on (`Holdout::None` from [`Options::new`]; the
    /// command line holds out the last third by default).
    pub holdout: Holdout,
    /// At most this many effects are added.
    pub max_effects: usize,
    /// Also report the error when a probe re-zeroes the correction this often (minutes), from the holdout's
    /// start (from the first reading without a holdout).
    pub probe_every_min: Option<f64>,
}

impl Options {
    pub fn new(channel: &str) -> Options {
        Options {
            channel: channel.to_ascii_lowercase(),
            holdout: Holdout::None,
            max_effects: 3,
            probe_every_min: None,
        }
    }

    /// Rows from `minutes` (of the data's time axis) on are held out.
    pub fn holdout_from(mut self, minutes: f64) -> Options {
        self.holdout = Holdout::From(minutes);
        self
    }
}

/// The errors with a probe re-zeroing the correction every `every_min` minutes, on the holdout (on the fit
/// window without one): what the gates buy on top of the model, and what probing alone would do.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Probing {
    pub every_min: f64,
    /// The uncompensated drift re-zeroed at every probing: a probe and no model.
    pub probe_only: ErrorStats,
    pub before: ErrorStats,
    pub after: ErrorStats,
}

/// Why diagnosis could not run.
#[derive(Debug, thiserror::Error)]
pub enum DiagnoseError {
    #[error("{source_name}: no displacement channel `{channel}` (found: {available})")]
    NoChannel {
        source_name: String,
        channel: String,
        available: String,
    },
    #[error("the model is of channel `{model}`, not `{asked}`")]
    WrongChannel { model: String, asked: String },
    #[error("{0}")]
    Predict(#[from] crate::model::PredictError),
    #[error(
        "only {0} rows before the holdout; too few to fit the model: give more data, or a later --holdout-from (`none`: no holdout)"
    )]
    TooFewRows(usize),
    #[error("the recalibration failed numerically (singular least-squares problem)")]
    Numerical,
}

/// Error statistics on the fit and holdout windows.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Windows {
    pub fit: ErrorStats,
    pub holdout: Option<ErrorStats>,
}

/// One effect diagnosis added.
#[derive(Debug, Clone)]
pub struct Added {
    pub effect: Effect,
    /// RMS of the fit-window residual the effect explains: √(RMS² before − RMS² after adding it).
    pub explained_rms_um: f64,
    /// Fit-window residual RMS just before the effect was added.
    pub residual_rms_um: f64,
    pub delta_bic: f64,
    pub cv_rms_before_um: f64,
    pub cv_rms_after_um: f64,
}

/// The outcome of a diagnosis.
#[derive(Debug, Clone)]
pub struct Diagnosis {
    pub channel: String,
    pub source: String,
    pub holdout_from_min: Option<f64>,
    /// Rows with a reading before the holdout (fitted) and from it on (scored only).
    pub rows_fit: usize,
    pub rows_holdout: usize,
    /// Rows without a reading of the channel: they carry the inputs between readings, nothing is scored
    /// there.
    pub rows_unmeasured: usize,
    /// The measured drift against the first reading (what an uncompensated machine shows).
    pub uncompensated: Windows,
    pub before: Windows,
    /// After recalibrating the declared parameters only.
    pub recalibrated: Windows,
    pub after: Windows,
    pub effects_added: Vec<Added>,
    /// Candidates that were refitted but rejected, with why (for the human report).
    pub rejected: Vec<String>,
    pub residual_white: bool,
    /// Why effects found on the fit window were dropped again on the holdout (or the recalibration
    /// undone), in words; empty when the holdout kept everything.
    pub holdout_guard: Vec<String>,
    /// Errors with a probe re-zeroing every P minutes, when asked for.
    pub probing: Option<Probing>,
    pub refined: DriftModel,
    /// Per row: time (min), measured (NaN where not measured), model before, refined model after.
    pub time_min: Vec<f64>,
    /// First row of each run (each run's time starts at its own zero), for plots that keep runs apart.
    pub run_starts: Vec<usize>,
    pub measured: Vec<f64>,
    pub predicted_before: Vec<f64>,
    pub predicted_after: Vec<f64>,
    /// Each added effect's own contribution per row (µm), in the order added.
    pub contributions: Vec<Vec<f64>>,
    /// The column each added effect reads (`None` for effects of time or speed only).
    pub signals: Vec<Option<Vec<f64>>>,
}

/// Runs the diagnosis of `model` on `ds`.
pub fn diagnose(
    model: &DriftModel,
    ds: &Dataset,
    opts: &Options,
) -> Result<Diagnosis, DiagnoseError> {
    let channel = opts.channel.to_ascii_lowercase();
    if model.channel != channel {
        return Err(DiagnoseError::WrongChannel {
            model: model.channel.clone(),
            asked: channel,
        });
    }
    let ctx = ds
        .column(&channel)
        .filter(|c| c.kind == ColumnKind::Displacement)
        .and_then(|_| Ctx::new(ds, &channel, opts.holdout))
        .ok_or_else(|| DiagnoseError::NoChannel {
            source_name: ds.source.clone(),
            channel: channel.clone(),
            available: ds
                .channels()
                .map(|c| c.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        })?;
    let start = Joint::start(model, ds)?;
    if ctx.n_fit < start.n_linear() + start.n_nonlinear() + 3 {
        return Err(DiagnoseError::TooFewRows(ctx.n_fit));
    }
    let before_pred = model.predict(ds)?;
    let recal = start.refit(&ctx).ok_or(DiagnoseError::Numerical)?;
    let recalibrated = windows(&ctx, &recal.prediction);
    // Every stage, for the holdout's last word: recalibrated, then with each effect added.
    let mut stages = vec![recal];
    let mut added = Vec::new();
    let mut rejected = Vec::new();
    let mut white = white_residual(&ctx, &stages[0]);
    while !white && added.len() < opts.max_effects {
        let current = stages.last().expect("the recalibration is a stage");
        match next_effect(&ctx, current, &mut rejected) {
            Some((fitted, a)) => {
                white = white_residual(&ctx, &fitted);
                stages.push(fitted);
                added.push(a);
            }
            None => break,
        }
    }
    let before = windows(&ctx, &before_pred);
    let (kept, holdout_guard) = holdout_guard(&ctx, &before, &stages);
    let current = match kept {
        Some(k) => {
            added.truncate(k);
            if k + 1 < stages.len() {
                white = white_residual(&ctx, &stages[k]);
            }
            stages.swap_remove(k)
        }
        None => {
            added.clear();
            white = ljung_box_white(&ctx.fit_rows(&residual(&ctx, &before_pred)), WHITENESS_LAGS);
            Fitted {
                joint: start.clone(),
                model: model.clone(),
                prediction: before_pred.clone(),
                rss: 0.0,
            }
        }
    };
    let after_pred = current.model.predict(ds)?;
    let contributions = current
        .joint
        .effects
        .iter()
        .skip(start.effects.len())
        .map(|e| match e.kind {
            Kind::CoolingAsymmetry => {
                let mut plain = current.model.clone();
                plain.effects.retain(|s| s.kind != e.kind.name());
                let without = plain.predict(ds).unwrap_or_else(|_| after_pred.clone());
                after_pred
                    .iter()
                    .zip(&without)
                    .map(|(a, b)| a - b)
                    .collect()
            }
            _ => e.contribution(&ctx.effect_series(e)),
        })
        .collect();
    let signals = added
        .iter()
        .map(|a| {
            a.effect
                .signal
                .as_deref()
                .and_then(|name| ds.values(name))
                .map(<[f64]>::to_vec)
        })
        .collect();
    let first = ctx.y.iter().copied().find(|v| !v.is_nan()).unwrap_or(0.0);
    let uncomp: Vec<f64> = ctx.y.iter().map(|v| v - first).collect();
    let zero = vec![0.0; ctx.n()];
    let probing = opts
        .probe_every_min
        .and_then(|every| probing(&ctx, every, &before_pred, &after_pred));
    Ok(Diagnosis {
        channel,
        source: ds.source.clone(),
        holdout_from_min: ctx.holdout_from_min,
        rows_fit: ctx.n_fit,
        rows_holdout: ctx.n_holdout,
        rows_unmeasured: ctx.n() - ctx.n_fit - ctx.n_holdout,
        uncompensated: windows_of(&ctx, &uncomp, &zero),
        before,
        recalibrated,
        after: windows(&ctx, &after_pred),
        effects_added: added,
        rejected,
        residual_white: white,
        holdout_guard,
        probing,
        refined: current.model,
        time_min: ds.time_min.clone(),
        run_starts: ds.run_starts.clone(),
        measured: ctx.y.clone(),
        predicted_before: before_pred,
        predicted_after: after_pred,
        contributions,
        signals,
    })
}

/// Screens every candidate, refits the best few jointly and returns, of those passing every test, the one
/// that improves the forward prediction most (rolling-origin CV, relative to the model without it on the
/// same folds). Choosing by the forward CV rather than by the
/// BIC matters when a cause-less effect and a measured one fit the window alike: a warming hall looks like
/// a trend there, but the trend extrapolates blindly while the temperature keeps measuring the cause.
fn next_effect(ctx: &Ctx, current: &Fitted, rejected: &mut Vec<String>) -> Option<(Fitted, Added)> {
    let proj = Projector::new(ctx, current);
    let resid = proj.screened(&residual(ctx, &current.prediction));
    // The best-screened candidates, and every candidate that changes or overlaps the declared modes:
    // screening holds the recalibrated modes fixed, and a recalibrated mode that stretched its τ towards a
    // slower undeclared one leaves that one little or nothing to screen on (its column projected off the
    // modes' vanishes), while refitted jointly it takes its share. Unscreenable, such a candidate starts
    // from the slowest time constant its search allows.
    let overlaps = |s: &candidates::Screened| {
        matches!(s.effect.kind, Kind::ExtraMode | Kind::CoolingAsymmetry)
    };
    // Candidates are screened, and the best refitted, on all cores: each is independent of the others,
    // and the results are taken in candidate order, so the outcome is the same on any number of cores.
    let mut screened: Vec<_> = candidates::candidates(ctx, current)
        .par_iter()
        .filter_map(|c| {
            screen(ctx, current, &proj, &resid, c).or_else(|| {
                (c.kind == Kind::ExtraMode).then(|| candidates::Screened {
                    effect: Effect {
                        theta: vec![ctx.effect_tau_bounds(c.kind).1],
                        ..c.clone()
                    },
                    delta_bic: f64::INFINITY,
                })
            })
        })
        .collect();
    screened.sort_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic));
    let refits: Vec<_> = screened
        .iter()
        .enumerate()
        .filter(|(i, s)| (*i < REFITS_PER_ROUND && s.delta_bic < 0.0) || overlaps(s))
        .map(|(_, s)| s.clone())
        .collect();
    let mut folds_without: Option<Vec<candidates::Fold>> = None;
    let rss0 = current.rss;
    let mut best: Option<(Fitted, Added)> = None;
    let refitted: Vec<Option<Fitted>> = refits
        .par_iter()
        .map(|s| {
            let mut joint = current.joint.clone();
            joint.effects.push(s.effect.clone());
            joint.refit(ctx)
        })
        .collect();
    for (s, fitted) in refits.into_iter().zip(refitted) {
        let Some(fitted) = fitted else {
            continue;
        };
        let r1 = ctx.fit_rows(&residual(ctx, &fitted.prediction));
        let n_eff = effective_n(&r1);
        let dof = (s.effect.amplitudes.len() + s.effect.theta.len()) as f64;
        let delta_bic = n_eff * (fitted.rss.max(f64::MIN_POSITIVE) / rss0).ln() + dof * n_eff.ln();
        let name = text::effect_name(&s.effect);
        let added = fitted.joint.effects.last();
        if let Some(tau) = added.and_then(|e| at_upper_tau_bound(ctx, e)) {
            rejected.push(format!(
                "{name}: its time constant ran to the bound of the search ({}): a lag as long as the window is a trend in disguise, not identified by these data",
                text::duration(tau)
            ));
            continue;
        }
        if let Some(reach) = added.and_then(|e| steady_state_reach(ctx, e)) {
            let range = measured_range(ctx);
            if reach > IMPLAUSIBLE_REACH * range {
                rejected.push(format!(
                    "{name}: would reach {reach:.0} µm at steady state over the logged range of its input, over {IMPLAUSIBLE_REACH:.0} times the measured range of {range:.1} µm: the data see only a sliver of its response"
                ));
                continue;
            }
        }
        let share = 1.0 - fitted.rss / rss0;
        if share < MIN_SHARE {
            rejected.push(format!(
                "{name}: explains only {:.0} % of the residual variance (less than {:.0} %)",
                100.0 * share,
                100.0 * MIN_SHARE
            ));
            continue;
        }
        if delta_bic >= 0.0 {
            rejected.push(format!(
                "{name}: the BIC on the effective sample size does not fall ({delta_bic:+.1})"
            ));
            continue;
        }
        // The new effect's columns sit just before the offset column.
        let p = fitted.joint.n_linear();
        let tested = p - 1 - s.effect.amplitudes.len()..p - 1;
        let folds_with = forward_validate(ctx, &fitted.joint, tested);
        let without =
            folds_without.get_or_insert_with(|| forward_validate(ctx, &current.joint, 0..0));
        // Compared on the folds where the effect can be estimated from the training stretch.
        let usable: Vec<bool> = folds_with
            .iter()
            .zip(without.iter())
            .map(|(a, b)| a.identifiable && b.identifiable)
            .collect();
        let cv_without = cv_rms(without, &usable);
        let cv_with = cv_rms(&folds_with, &usable);
        if !usable.contains(&true) || cv_with >= cv_without {
            rejected.push(format!(
                "{name}: the forward error does not fall (fitted on earlier time, predicting later: {cv_without:.3} → {cv_with:.3} µm)"
            ));
            continue;
        }
        let n = ctx.n_fit as f64;
        let rms0 = (rss0 / n).sqrt();
        let rms1 = (fitted.rss / n).sqrt();
        let effect = fitted.joint.effects.last().cloned().unwrap_or(s.effect);
        let a = Added {
            effect,
            explained_rms_um: (rms0 * rms0 - rms1 * rms1).max(0.0).sqrt(),
            residual_rms_um: rms0,
            delta_bic,
            cv_rms_before_um: cv_without,
            cv_rms_after_um: cv_with,
        };
        let gain = |x: &Added| x.cv_rms_after_um / x.cv_rms_before_um;
        if best.as_ref().is_none_or(|(_, b)| gain(&a) < gain(b)) {
            best = Some((fitted, a));
        }
    }
    best
}

/// How far a lagged effect's target moves over the logged range of what drives it (µm): |gain| times the
/// range of its signal, or of the spindle speed in krpm, on the fit window's rows (read or not).
fn steady_state_reach(ctx: &Ctx, e: &Effect) -> Option<f64> {
    let driver: Vec<f64> = match e.kind {
        Kind::InputLag => ctx.ds.values(e.signal.as_deref()?)?.to_vec(),
        Kind::ExtraMode => ctx.rpm?.iter().map(|r| r.abs() / 1000.0).collect(),
        _ => return None,
    };
    let window: Vec<f64> = driver
        .iter()
        .zip(&ctx.in_window)
        .filter(|(_, w)| **w)
        .map(|(v, _)| *v)
        .collect();
    let lo = window.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = window.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Some(e.amplitudes.first()?.abs() * (hi - lo).max(0.0))
}

/// Spread of the fit window's readings (µm).
fn measured_range(ctx: &Ctx) -> f64 {
    let y = ctx.fit_rows(&ctx.y);
    y.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - y.iter().copied().fold(f64::INFINITY, f64::min)
}

/// The effect's time constant when the refit left it at the upper bound of its search. A lagged input or
/// slope that slow is a wandering signal's trend in disguise; a further spindle mode that slow is not: far
/// slower than the window, it integrates the speed history (its response is k·rpm·t/τ there, only the
/// ratio is identified), which no trend imitates — the forward validation judges it like any other.
fn at_upper_tau_bound(ctx: &Ctx, e: &Effect) -> Option<f64> {
    let lagged = matches!(e.kind, Kind::InputLag | Kind::PositionSlope);
    let (_, hi) = ctx.effect_tau_bounds(e.kind);
    (lagged && e.theta[0] >= 0.99 * hi).then(|| e.theta[0])
}

/// The holdout's last word: the stage kept (index into `stages`: 0 the recalibration, k with k effects) —
/// the last one whose holdout RMS is not above the model before, or `None` when none is (the model as
/// given is kept) — and what was dropped, in words. Without a holdout every stage is kept.
fn holdout_guard(ctx: &Ctx, before: &Windows, stages: &[Fitted]) -> (Option<usize>, Vec<String>) {
    let Some(b) = before.holdout else {
        return (Some(stages.len() - 1), Vec::new());
    };
    let mut notes = Vec::new();
    for (k, stage) in stages.iter().enumerate().rev() {
        let Some(h) = windows(ctx, &stage.prediction).holdout else {
            return (Some(k), notes);
        };
        if h.rms_um <= b.rms_um {
            return (Some(k), notes);
        }
        notes.push(match k {
            0 => format!(
                "the recalibration: holdout RMS {:.3} µm, no better than the model as given ({:.3} µm)",
                h.rms_um, b.rms_um
            ),
            _ => format!(
                "{}: with it the holdout RMS is {:.3} µm, no better than the model before ({:.3} µm)",
                text::effect_name(
                    stage
                        .joint
                        .effects
                        .last()
                        .expect("a stage past 0 added one")
                ),
                h.rms_um,
                b.rms_um
            ),
        });
    }
    (None, notes)
}

/// The errors with a probe re-zeroing every `every` minutes, on the holdout rows (the fit rows without a
/// holdout); `None` without a reading there.
fn probing(ctx: &Ctx, every: f64, before: &[f64], after: &[f64]) -> Option<Probing> {
    let scored: Vec<bool> = if ctx.n_holdout > 0 {
        (0..ctx.n())
            .map(|i| ctx.measured[i] && !ctx.fit[i])
            .collect()
    } else {
        ctx.fit.clone()
    };
    let score = |p: &[f64]| {
        holdout::HoldoutScore::of(
            ctx.ds,
            &ctx.y,
            p,
            &scored,
            Some(probing::Probing::every(every)),
        )
    };
    let (b, a) = (score(before)?, score(after)?);
    Some(Probing {
        every_min: every,
        probe_only: b.probe_only?,
        before: b.model_probed?,
        after: a.model_probed?,
    })
}

fn residual(ctx: &Ctx, prediction: &[f64]) -> Vec<f64> {
    ctx.y.iter().zip(prediction).map(|(y, p)| y - p).collect()
}

fn white_residual(ctx: &Ctx, f: &Fitted) -> bool {
    ljung_box_white(&ctx.fit_rows(&residual(ctx, &f.prediction)), WHITENESS_LAGS)
}

fn windows(ctx: &Ctx, prediction: &[f64]) -> Windows {
    windows_of(ctx, &ctx.y, prediction)
}

fn windows_of(ctx: &Ctx, y: &[f64], prediction: &[f64]) -> Windows {
    let e: Vec<f64> = y.iter().zip(prediction).map(|(a, b)| a - b).collect();
    let hold: Vec<f64> = e
        .iter()
        .zip(ctx.fit.iter().zip(&ctx.measured))
        .filter(|(_, (f, m))| **m && !**f)
        .map(|(v, _)| *v)
        .collect();
    Windows {
        fit: ErrorStats::of(&ctx.fit_rows(&e)).unwrap_or(ErrorStats {
            rms_um: 0.0,
            max_um: 0.0,
            p95_um: 0.0,
        }),
        holdout: ErrorStats::of(&hold),
    }
}
