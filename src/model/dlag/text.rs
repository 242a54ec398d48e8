//! The human summary of a distributed-lag fit: the design forward validation chose and why, the terms that
//! carry the most, and what the NC program needs to evaluate the model.

use std::fmt::Write as _;

use crate::model::DriftModel;
use crate::model::effects::{Effect, Kind};
use crate::model::fit::fitted_on;
use crate::model::lag::fmt_tau;
use crate::model::speed_law::{extrapolation_law, mode_law};

use super::{DesignTrial, ForwardSelection};

/// Terms listed by name in the summary (the largest steady-state reach first).
const LISTED: usize = 8;

/// The summary, or `None` for a model not fitted by `fit --kind dlag`.
pub fn summary(model: &DriftModel) -> Option<String> {
    let fit = model.fit.as_ref()?;
    let f = fit.forward.as_ref()?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: distributed-lag model{}",
        model.channel,
        fitted_on(model)
    );
    let _ = writeln!(
        s,
        "  sensors: {} ({}), each a change from its run's start at lags {} min",
        f.signals.join(" "),
        f.signals.len(),
        join(&f.sensor_lags_min)
    );
    if !f.spindle_lags_min.is_empty() {
        let _ = writeln!(
            s,
            "  spindle: lags {} min with exponents {} (the best design); above {:.0} rpm: {}",
            join(&f.spindle_lags_min),
            join(&f.exponents),
            model.spindle.characterised_top_rpm.unwrap_or(0.0),
            extrapolation_law(model)
        );
    }
    let _ = writeln!(
        s,
        "  ridge penalty {:.0e} on standardised columns ({:.1} effective parameters), offset {:.3} µm",
        f.penalty, f.dof, model.offset_um
    );
    let _ = writeln!(
        s,
        "  fit: RMS {:.3} µm, max {:.3} µm, R² {:.4}",
        fit.rms_um, fit.max_abs_um, fit.r2
    );
    forward_block(&mut s, f);
    terms_block(&mut s, model);
    let _ = writeln!(s, "  {}", nc_needs(model));
    Some(s)
}

fn join(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// How the design was chosen: the origins and the best forward RMS of each lag set.
fn forward_block(s: &mut String, f: &ForwardSelection) {
    let origins: Vec<String> = f.origins_min.iter().map(|o| format!("{o:.0}")).collect();
    let members: Vec<&DesignTrial> = f.trials.iter().filter(|t| t.weight.is_some()).collect();
    let best = f
        .trials
        .iter()
        .map(|t| t.cv_rms_um)
        .fold(f64::INFINITY, f64::min);
    let chosen = match members.len() {
        0 | 1 => format!("chosen design {:.3} µm RMS", f.cv_rms_um),
        n => format!(
            "best design {best:.3} µm RMS; the model averages the {n} designs within the folds' noise of it (weight ∝ exp(−F·(cv²/cv²best − 1)/2), F folds; the heaviest {:.0} %), forward RMS of the average {:.3} µm",
            100.0 * members.iter().filter_map(|t| t.weight).fold(0.0, f64::max),
            f.cv_rms_um
        ),
    };
    let _ = writeln!(
        s,
        "  forward validation: fitted before each origin ({} min elapsed), scored on every later row; {chosen}",
        origins.join(", "),
    );
    let mut sets: Vec<(&Vec<f64>, &Vec<f64>)> = Vec::new();
    for t in &f.trials {
        let set = (&t.sensor_lags_min, &t.spindle_lags_min);
        if !sets.contains(&set) {
            sets.push(set);
        }
    }
    for (sensor, spindle) in sets {
        let best = f
            .trials
            .iter()
            .filter(|t| &t.sensor_lags_min == sensor && &t.spindle_lags_min == spindle)
            .min_by(|a, b| a.cv_rms_um.total_cmp(&b.cv_rms_um));
        if let Some(t) = best {
            let _ = writeln!(
                s,
                "    sensor lags {:<22} spindle lags {:<20} best {:.3} µm (exponents {}, penalty {:.0e})",
                format!("{} min", join(sensor)),
                format!("{} min", join(spindle)),
                t.cv_rms_um,
                join(&t.exponents),
                t.penalty
            );
        }
    }
    if let Some(p) = &f.probe {
        let trials: Vec<String> = p
            .trials
            .iter()
            .map(|[g, rms]| format!("{g} → {rms:.3}"))
            .collect();
        let _ = writeln!(
            s,
            "    a probe every {} min re-zeroing with trend gain {} (forward RMS with probing, µm: {})",
            p.every_min,
            p.trend_gain,
            trials.join(", ")
        );
    }
}

/// The terms with the largest reach: |gain| × the signal's range is not known here, so the sensor terms
/// are ranked by |gain| within their lag and the spindle terms listed with their top-speed gain.
fn terms_block(s: &mut String, model: &DriftModel) {
    for m in &model.spindle.modes {
        let top = model.spindle.characterised_top_rpm.unwrap_or(0.0);
        let at_top = model
            .speed_grid()
            .map_or(0.0, |g| g.weights(top).apply(&m.gain_um));
        let _ = writeln!(
            s,
            "    spindle, τ {}: {:+.3} µm at {top:.0} rpm, {}",
            fmt_tau(m.tau_min),
            at_top,
            mode_law(model, m)
        );
    }
    let mut effects: Vec<Effect> = model
        .effects
        .iter()
        .filter_map(|e| Effect::from_spec(e).ok())
        .collect();
    effects.sort_by(|a, b| b.amplitudes[0].abs().total_cmp(&a.amplitudes[0].abs()));
    for e in effects.iter().take(LISTED) {
        let lag = match e.kind {
            Kind::InputLag => format!(", lag {}", fmt_tau(e.theta[0])),
            _ => String::new(),
        };
        let _ = writeln!(
            s,
            "    {}{lag}: {:+.3} µm per unit",
            e.signal.as_deref().unwrap_or("?"),
            e.amplitudes[0]
        );
    }
    if effects.len() > LISTED {
        let _ = writeln!(
            s,
            "    … {} more sensor terms (the model file lists them all)",
            effects.len() - LISTED
        );
    }
}

/// What `transform` needs to evaluate the model in NC: analog inputs and R-parameters, counted as the
/// emitter allocates them with the default profile (27 fixed, 2 per spindle mode, 2 per time constant of
/// the lagged inputs — terms of one τ share a state —, 1 per analog input, 1 for the unlagged ones' sum).
pub fn nc_needs(model: &DriftModel) -> String {
    let mut taus: Vec<f64> = model.inputs.iter().map(|i| i.tau_min).collect();
    taus.extend(
        model
            .effects
            .iter()
            .filter(|e| e.kind == Kind::InputLag.name())
            .filter_map(|e| crate::model::effects::Effect::from_spec(e).ok())
            .filter_map(|e| e.theta.first().copied()),
    );
    taus.sort_by(f64::total_cmp);
    taus.dedup();
    let statics = model
        .effects
        .iter()
        .any(|e| e.kind == Kind::StaticInput.name());
    let signals = model.signals().len();
    let registers =
        27 + 2 * model.spindle.modes.len() + 2 * taus.len() + signals + usize::from(statics);
    format!(
        "in NC: {signals} analog inputs to map in the profile's [log] inputs, {registers} R-parameters (registers.r_first … r_last; the default profile offers 50, R50 … R99)"
    )
}
