//! Effects `diagnose` adds to a drift model, one module per kind. Every effect is linear in its amplitudes
//! once its nonlinear parameters θ (a time constant, a step time, a ratio) are fixed, so the same column
//! generator serves prediction ([`Effect::contribution`]) and the joint refit in `diagnose` (which solves the
//! amplitudes by least squares and iterates θ).
//!
//! In the model file an effect is an [`EffectSpec`] `{kind, signal, position, params}`; [`Effect::from_spec`]
//! and [`Effect::to_spec`] convert losslessly. `signal` names the measured input a kind reads (a temperature,
//! ambient, …; for `position_slope` the position itself, as before `position` existed), `position` the axis
//! position column (`*_mm`) of the kinds that also need one. A spec with a field, parameter or kind this
//! version does not know is refused, never predicted without it. The kinds diagnosis searches for
//! ([`Kind::DIAGNOSED`]):
//! - [`input_lag`]: an undeclared numeric column through a first-order lag;
//! - [`extra_mode`]: another spindle-driven mode with its own time constant;
//! - [`cooling_asymmetry`]: the spindle modes cool with a different time constant than they heat
//!   (it changes the modes' dynamics, so it has no column of its own);
//! - [`position_slope`]: the thermal drift grows with an axis position, E = S(θ)·p + I(θ);
//! - [`time_trend`]: slow linear creep; [`periodic`]: a daily cycle; [`step`]: a sudden offset.
//!
//! And the terms of a temperature-sensor regression (`driftloop sensors -o`, the third paper's
//! E = E_G(p) + S(θ)·p + I(θ)), written by the regression and refitted (amplitudes only, they have no θ)
//! but never proposed by diagnosis:
//! - [`static_input`]: gain·(u(i) − u at the run's first row), at its own row, no lag;
//! - [`input_slope`]: gain·(u(i) − u₀)·p(i), a slope S that follows an input, not the spindle;
//! - [`geometric`]: the geometric error E_G(p) = a·p + b·p² of the axis position (its constant part is the
//!   model's offset).

pub mod cooling_asymmetry;
pub mod extra_mode;
pub mod geometric;
pub mod input_lag;
pub mod input_slope;
pub mod periodic;
pub mod position_slope;
pub mod static_input;
pub mod step;
pub mod time_trend;

use std::collections::BTreeMap;
use std::ops::Range;

use super::EffectSpec;
use super::lag::Decay;

/// The kinds of effect, named as in the model file and in `diagnose --format json`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Kind {
    InputLag,
    ExtraMode,
    CoolingAsymmetry,
    PositionSlope,
    TimeTrend,
    Periodic,
    Step,
    StaticInput,
    InputSlope,
    Geometric,
}

impl Kind {
    /// The kinds diagnosis proposes and `simulate-data` injects.
    pub const DIAGNOSED: [Kind; 7] = [
        Kind::InputLag,
        Kind::ExtraMode,
        Kind::CoolingAsymmetry,
        Kind::PositionSlope,
        Kind::TimeTrend,
        Kind::Periodic,
        Kind::Step,
    ];

    /// The terms of a sensor regression, written by `sensors`.
    pub const SENSOR: [Kind; 3] = [Kind::StaticInput, Kind::InputSlope, Kind::Geometric];

    /// Every kind a model file may carry: the diagnosed ones, then the sensor terms.
    pub const ALL: [Kind; Kind::DIAGNOSED.len() + Kind::SENSOR.len()] = {
        let mut all = [Kind::InputLag; Kind::DIAGNOSED.len() + Kind::SENSOR.len()];
        let mut i = 0;
        while i < all.len() {
            all[i] = if i < Kind::DIAGNOSED.len() {
                Kind::DIAGNOSED[i]
            } else {
                Kind::SENSOR[i - Kind::DIAGNOSED.len()]
            };
            i += 1;
        }
        all
    };

    pub fn name(self) -> &'static str {
        match self {
            Kind::InputLag => "input_lag",
            Kind::ExtraMode => "extra_mode",
            Kind::CoolingAsymmetry => "cooling_asymmetry",
            Kind::PositionSlope => "position_slope",
            Kind::TimeTrend => "time_trend",
            Kind::Periodic => "periodic",
            Kind::Step => "step",
            Kind::StaticInput => "static_input",
            Kind::InputSlope => "input_slope",
            Kind::Geometric => "geometric",
        }
    }

    pub fn parse(name: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Whether the effect reads a data column (named in `signal`).
    pub fn reads_signal(self) -> bool {
        matches!(
            self,
            Kind::InputLag | Kind::PositionSlope | Kind::StaticInput | Kind::InputSlope
        )
    }

    /// Whether the effect reads an axis position column (named in `position`).
    pub fn reads_position(self) -> bool {
        matches!(self, Kind::InputSlope | Kind::Geometric)
    }

    /// Names of θ in the model file, in θ order.
    pub fn theta_names(self) -> &'static [&'static str] {
        match self {
            Kind::InputLag | Kind::ExtraMode | Kind::PositionSlope => &["tau_min"],
            Kind::CoolingAsymmetry => &["cooling_tau_ratio"],
            Kind::Step => &["at_min"],
            Kind::TimeTrend
            | Kind::Periodic
            | Kind::StaticInput
            | Kind::InputSlope
            | Kind::Geometric => &[],
        }
    }

    /// Names of the amplitudes in the model file, in column order.
    pub fn amplitude_names(self) -> &'static [&'static str] {
        match self {
            Kind::InputLag => &["gain_um_per_unit"],
            Kind::ExtraMode => &["gain_um_per_krpm"],
            Kind::CoolingAsymmetry => &[],
            Kind::PositionSlope => &["um_per_mm_per_krpm", "um_per_mm"],
            Kind::TimeTrend => &["um_per_h"],
            Kind::Periodic => &["sin_um", "cos_um"],
            Kind::Step => &["offset_um"],
            Kind::StaticInput => &["gain_um_per_unit"],
            Kind::InputSlope => &["um_per_mm_per_unit"],
            Kind::Geometric => &["um_per_mm", "um_per_mm2"],
        }
    }

    /// Names of the parameters in the model file: θ, then the amplitudes as written.
    fn param_names(self) -> Vec<&'static str> {
        let amplitudes = match self {
            Kind::Periodic => periodic::PARAM_NAMES.as_slice(),
            _ => self.amplitude_names(),
        };
        self.theta_names()
            .iter()
            .chain(amplitudes)
            .copied()
            .collect()
    }

    /// Whether θ enters smoothly (iterated in the joint refit) rather than found by a scan only.
    pub fn theta_smooth(self) -> bool {
        !matches!(self, Kind::Step)
    }
}

/// Why a model file's effect cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EffectError {
    #[error(
        "the model carries a `{0}` effect, which this version of driftloop cannot predict; refusing rather than predicting without it"
    )]
    UnknownKind(String),
    #[error("`{kind}` effect: parameter `{param}` is missing or not a finite number")]
    BadParam { kind: String, param: String },
    #[error("`{0}` effect: it needs a `signal` column name")]
    NoSignal(String),
    #[error("`{0}` effect: it needs a `position` column name (the axis position, `*_mm`)")]
    NoPosition(String),
    #[error(
        "`{kind}` effect: `{field}` is not a field this version of driftloop knows for it; refusing rather than predicting without it"
    )]
    UnknownField { kind: String, field: String },
}

/// One effect with its parameters in natural units (θ: τ in minutes, step time in minutes, ratio).
#[derive(Debug, Clone, PartialEq)]
pub struct Effect {
    pub kind: Kind,
    pub signal: Option<String>,
    /// The axis position column, for the kinds that read one ([`Kind::reads_position`]).
    pub position: Option<String>,
    pub theta: Vec<f64>,
    pub amplitudes: Vec<f64>,
}

/// The data an effect's columns are computed from. `t` in minutes; a row's inputs hold until the next row.
#[derive(Debug, Clone, Copy)]
pub struct Series<'a> {
    pub t: &'a [f64],
    pub runs: &'a [Range<usize>],
    pub rpm: Option<&'a [f64]>,
    /// The effect's `signal` column, when it reads one.
    pub signal: Option<&'a [f64]>,
    /// The effect's `position` column, when it reads one.
    pub position: Option<&'a [f64]>,
}

impl Series<'_> {
    pub fn len(&self) -> usize {
        self.t.len()
    }
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
}

impl Effect {
    pub fn from_spec(spec: &EffectSpec) -> Result<Effect, EffectError> {
        let kind =
            Kind::parse(&spec.kind).ok_or_else(|| EffectError::UnknownKind(spec.kind.clone()))?;
        if kind.reads_signal() && spec.signal.is_none() {
            return Err(EffectError::NoSignal(spec.kind.clone()));
        }
        if kind.reads_position() && spec.position.is_none() {
            return Err(EffectError::NoPosition(spec.kind.clone()));
        }
        let unknown = |field: &str| EffectError::UnknownField {
            kind: spec.kind.clone(),
            field: field.to_string(),
        };
        if spec.position.is_some() && !kind.reads_position() {
            return Err(unknown("position"));
        }
        let names = kind.param_names();
        if let Some(extra) = spec.params.keys().find(|k| !names.contains(&k.as_str())) {
            return Err(unknown(extra));
        }
        let get = |name: &&str| {
            spec.params
                .get(*name)
                .copied()
                .filter(|v| v.is_finite())
                .ok_or_else(|| EffectError::BadParam {
                    kind: spec.kind.clone(),
                    param: name.to_string(),
                })
        };
        let effect = Effect {
            kind,
            signal: spec.signal.clone().filter(|_| kind.reads_signal()),
            position: spec.position.clone(),
            theta: kind
                .theta_names()
                .iter()
                .map(get)
                .collect::<Result<_, _>>()?,
            amplitudes: match kind {
                Kind::Periodic => periodic::amplitudes_from_params(&spec.params)
                    .ok_or_else(|| EffectError::BadParam {
                        kind: spec.kind.clone(),
                        param: "amplitude_um".into(),
                    })?
                    .to_vec(),
                _ => kind
                    .amplitude_names()
                    .iter()
                    .map(get)
                    .collect::<Result<_, _>>()?,
            },
        };
        Ok(effect)
    }

    pub fn to_spec(&self) -> EffectSpec {
        let mut params = BTreeMap::new();
        for (name, v) in self.kind.theta_names().iter().zip(&self.theta) {
            params.insert(name.to_string(), *v);
        }
        match self.kind {
            // Amplitude and time of day of the maximum read better than sine and cosine parts.
            Kind::Periodic => params.extend(periodic::params_from_amplitudes(&self.amplitudes)),
            _ => {
                for (name, v) in self.kind.amplitude_names().iter().zip(&self.amplitudes) {
                    params.insert(name.to_string(), *v);
                }
            }
        }
        EffectSpec {
            kind: self.kind.name().to_string(),
            signal: self.signal.clone(),
            position: self.position.clone(),
            params,
        }
    }

    /// The data the effect's columns are computed from: `column` finds a data column by name.
    pub fn series<'a>(
        &self,
        t: &'a [f64],
        runs: &'a [Range<usize>],
        rpm: Option<&'a [f64]>,
        column: impl Fn(&str) -> Option<&'a [f64]>,
    ) -> Series<'a> {
        Series {
            t,
            runs,
            rpm,
            signal: self.signal.as_deref().and_then(&column),
            position: self.position.as_deref().and_then(&column),
        }
    }

    /// Unit responses (one column per amplitude) for θ, each of `s.len()` rows, into `cols`.
    pub fn columns(&self, s: &Series, theta: &[f64], cols: &mut [&mut [f64]]) {
        match self.kind {
            Kind::InputLag => input_lag::columns(s, theta[0], cols[0]),
            Kind::ExtraMode => extra_mode::columns(s, theta[0], cols[0]),
            Kind::CoolingAsymmetry => {}
            Kind::PositionSlope => position_slope::columns(s, theta[0], cols),
            Kind::TimeTrend => time_trend::columns(s, cols[0]),
            Kind::Periodic => periodic::columns(s, cols),
            Kind::Step => step::columns(s, theta[0], cols[0]),
            Kind::StaticInput => static_input::columns(s, cols[0]),
            Kind::InputSlope => input_slope::columns(s, cols[0]),
            Kind::Geometric => geometric::columns(s, cols),
        }
    }

    /// The effect's additive contribution at every row (µm); zero for `cooling_asymmetry`.
    pub fn contribution(&self, s: &Series) -> Vec<f64> {
        let n = s.len();
        let mut store = vec![vec![0.0; n]; self.amplitudes.len()];
        let mut cols: Vec<&mut [f64]> = store.iter_mut().map(|c| c.as_mut_slice()).collect();
        self.columns(s, &self.theta, &mut cols);
        let mut out = vec![0.0; n];
        for (col, a) in store.iter().zip(&self.amplitudes) {
            for (o, v) in out.iter_mut().zip(col) {
                *o += a * v;
            }
        }
        out
    }
}

/// Response of a first-order lag from rest at each run's start to `target(i)` (held from row i to row i+1),
/// into `out`: the building block of the lagged effects.
pub fn lag_into(s: &Series, tau: f64, target: impl Fn(usize) -> f64, out: &mut [f64]) {
    let mut decay = Decay::new(tau);
    for run in s.runs {
        if run.is_empty() {
            continue;
        }
        let mut x = 0.0;
        out[run.start] = 0.0;
        for (i, o) in out.iter_mut().enumerate().take(run.end).skip(run.start + 1) {
            let e = decay.at(s.t[i] - s.t[i - 1]);
            let g = target(i - 1);
            x = g + (x - g) * e;
            *o = x;
        }
    }
}

#[cfg(test)]
pub(crate) mod test_support {
    use super::*;

    /// One run, constant step, the given signal and speed.
    pub fn series<'a>(
        t: &'a [f64],
        runs: &'a [Range<usize>],
        rpm: Option<&'a [f64]>,
        signal: Option<&'a [f64]>,
    ) -> Series<'a> {
        Series {
            t,
            runs,
            rpm,
            signal,
            position: None,
        }
    }

    /// The rows of one run of `n` rows.
    pub fn whole(n: usize) -> Vec<Range<usize>> {
        std::iter::once(0..n).collect()
    }

    /// A spec round trip gives the same effect back.
    pub fn assert_round_trip(e: &Effect) {
        let back = Effect::from_spec(&e.to_spec()).unwrap();
        assert_eq!(back.kind, e.kind);
        assert_eq!(back.signal, e.signal);
        assert_eq!(back.position, e.position);
        for (a, b) in back.theta.iter().zip(&e.theta) {
            assert!((a - b).abs() < 1e-9 * (1.0 + b.abs()));
        }
        for (a, b) in back.amplitudes.iter().zip(&e.amplitudes) {
            assert!((a - b).abs() < 1e-9 * (1.0 + b.abs()), "{a} {b}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_kinds_and_missing_params_are_refused() {
        // A spec of `kind` with no signal, position or parameters.
        let bare = |kind: &str| EffectSpec {
            kind: kind.into(),
            signal: None,
            position: None,
            params: BTreeMap::new(),
        };
        assert_eq!(
            Effect::from_spec(&bare("ghost")),
            Err(EffectError::UnknownKind("ghost".into()))
        );
        assert!(matches!(
            Effect::from_spec(&bare("time_trend")),
            Err(EffectError::BadParam { .. })
        ));
        assert!(matches!(
            Effect::from_spec(&bare("input_lag")),
            Err(EffectError::NoSignal(_))
        ));
    }

    #[test]
    fn fields_and_params_a_kind_does_not_know_are_refused() {
        let e = Effect {
            kind: Kind::InputSlope,
            signal: Some("t3_c".into()),
            position: Some("x_mm".into()),
            theta: vec![],
            amplitudes: vec![0.01],
        };
        assert!(Effect::from_spec(&e.to_spec()).is_ok());
        let mut no_position = e.to_spec();
        no_position.position = None;
        assert_eq!(
            Effect::from_spec(&no_position),
            Err(EffectError::NoPosition("input_slope".into()))
        );
        // A position on a kind that does not read one would be ignored by this version: refused.
        let mut stray = Effect {
            kind: Kind::StaticInput,
            signal: Some("t3_c".into()),
            position: None,
            theta: vec![],
            amplitudes: vec![2.0],
        }
        .to_spec();
        stray.position = Some("x_mm".into());
        assert!(matches!(
            Effect::from_spec(&stray),
            Err(EffectError::UnknownField { field, .. }) if field == "position"
        ));
        // So is a parameter it does not know (a newer version's term, or a typo).
        let mut extra = e.to_spec();
        extra.params.insert("um_per_mm2_per_unit".into(), 1e-4);
        assert!(matches!(
            Effect::from_spec(&extra),
            Err(EffectError::UnknownField { field, .. }) if field == "um_per_mm2_per_unit"
        ));
        // A field of the spec itself this version does not know fails the file, not the term.
        let text = "kind = \"static_input\"\nsignal = \"t3_c\"\nlag_rows = 1\n[params]\ngain_um_per_unit = 2.0\n";
        assert!(toml::from_str::<EffectSpec>(text).is_err());
    }

    #[test]
    fn a_model_with_every_kind_survives_its_file_and_predicts() {
        use crate::model::{DriftModel, Schedule};
        let mut ds = "2000:120,0:60,3000:120"
            .parse::<Schedule>()
            .unwrap()
            .to_dataset(5.0);
        let amb: Vec<f64> = ds.time_min.iter().map(|t| 20.0 + t / 100.0).collect();
        let x: Vec<f64> = ds.time_min.iter().map(|t| (t % 50.0) * 4.0).collect();
        ds.push_column("ambient_c", amb);
        ds.push_column("x_mm", x);
        let plain =
            DriftModel::from_modes("z_um", vec![2000.0, 3000.0], &[(30.0, vec![4.0, 7.0])], 0.0);
        let mut model = plain.clone();
        for kind in Kind::ALL {
            let signal = match kind {
                Kind::InputLag | Kind::StaticInput | Kind::InputSlope => {
                    Some("ambient_c".to_string())
                }
                Kind::PositionSlope => Some("x_mm".to_string()),
                _ => None,
            };
            let e = Effect {
                kind,
                signal,
                position: kind.reads_position().then(|| "x_mm".to_string()),
                theta: vec![
                    if kind == Kind::CoolingAsymmetry {
                        2.0
                    } else {
                        40.0
                    };
                    kind.theta_names().len()
                ],
                amplitudes: vec![0.5; kind.amplitude_names().len()],
            };
            model.effects.push(e.to_spec());
        }
        let text = model.to_toml();
        let back = DriftModel::from_toml(&text, "refined.toml").unwrap();
        assert_eq!(back.to_toml(), text);
        let with = back.predict(&ds).unwrap();
        let without = plain.predict(&ds).unwrap();
        assert!(with.iter().zip(&without).any(|(a, b)| (a - b).abs() > 0.1));
        // Without the signal an effect reads, prediction is refused rather than done without it.
        let mut bare = ds.clone();
        bare.columns.retain(|c| c.name != "x_mm");
        assert!(back.predict(&bare).is_err());
    }

    #[test]
    fn lag_restarts_at_every_run() {
        let t = [0.0, 1.0, 2.0, 0.0, 1.0];
        let runs = [0..3, 3..5];
        let s = test_support::series(&t, &runs, None, None);
        let mut out = [9.0; 5];
        lag_into(&s, 1.0, |_| 1.0, &mut out);
        let e = (-1.0f64).exp();
        assert!((out[1] - (1.0 - e)).abs() < 1e-12);
        assert!((out[2] - (1.0 - e * e)).abs() < 1e-12);
        assert_eq!(out[3], 0.0);
        assert!((out[4] - (1.0 - e)).abs() < 1e-12);
    }
}
