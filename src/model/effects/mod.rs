//! Effects `diagnose` adds to a drift model, one module per kind. Every effect is linear in its amplitudes
//! once its nonlinear parameters θ (a time constant, a step time, a ratio) are fixed, so the same column
//! generator serves prediction ([`Effect::contribution`]) and the joint refit in `diagnose` (which solves the
//! amplitudes by least squares and iterates θ).
//!
//! In the model file an effect is an [`EffectSpec`] `{kind, signal, params}`; [`Effect::from_spec`] and
//! [`Effect::to_spec`] convert losslessly. The kinds:
//! - [`input_lag`]: an undeclared numeric column through a first-order lag;
//! - [`extra_mode`]: another spindle-driven mode with its own time constant;
//! - [`cooling_asymmetry`]: the spindle modes cool with a different time constant than they heat
//!   (it changes the modes' dynamics, so it has no column of its own);
//! - [`position_slope`]: the thermal drift grows with an axis position, E = S(θ)·p + I(θ);
//! - [`time_trend`]: slow linear creep; [`periodic`]: a daily cycle; [`step`]: a sudden offset.

pub mod cooling_asymmetry;
pub mod extra_mode;
pub mod input_lag;
pub mod periodic;
pub mod position_slope;
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
}

impl Kind {
    pub const ALL: [Kind; 7] = [
        Kind::InputLag,
        Kind::ExtraMode,
        Kind::CoolingAsymmetry,
        Kind::PositionSlope,
        Kind::TimeTrend,
        Kind::Periodic,
        Kind::Step,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Kind::InputLag => "input_lag",
            Kind::ExtraMode => "extra_mode",
            Kind::CoolingAsymmetry => "cooling_asymmetry",
            Kind::PositionSlope => "position_slope",
            Kind::TimeTrend => "time_trend",
            Kind::Periodic => "periodic",
            Kind::Step => "step",
        }
    }

    pub fn parse(name: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Whether the effect reads a data column (named in `signal`).
    pub fn reads_signal(self) -> bool {
        matches!(self, Kind::InputLag | Kind::PositionSlope)
    }

    /// Names of θ in the model file, in θ order.
    pub fn theta_names(self) -> &'static [&'static str] {
        match self {
            Kind::InputLag | Kind::ExtraMode | Kind::PositionSlope => &["tau_min"],
            Kind::CoolingAsymmetry => &["cooling_tau_ratio"],
            Kind::Step => &["at_min"],
            Kind::TimeTrend | Kind::Periodic => &[],
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
        }
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
}

/// One effect with its parameters in natural units (θ: τ in minutes, step time in minutes, ratio).
#[derive(Debug, Clone, PartialEq)]
pub struct Effect {
    pub kind: Kind,
    pub signal: Option<String>,
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
            params,
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
        let spec = EffectSpec {
            kind: "ghost".into(),
            signal: None,
            params: BTreeMap::new(),
        };
        assert_eq!(
            Effect::from_spec(&spec),
            Err(EffectError::UnknownKind("ghost".into()))
        );
        let spec = EffectSpec {
            kind: "time_trend".into(),
            signal: None,
            params: BTreeMap::new(),
        };
        assert!(matches!(
            Effect::from_spec(&spec),
            Err(EffectError::BadParam { .. })
        ));
        let spec = EffectSpec {
            kind: "input_lag".into(),
            signal: None,
            params: BTreeMap::new(),
        };
        assert!(matches!(
            Effect::from_spec(&spec),
            Err(EffectError::NoSignal(_))
        ));
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
                Kind::InputLag => Some("ambient_c".to_string()),
                Kind::PositionSlope => Some("x_mm".to_string()),
                _ => None,
            };
            let e = Effect {
                kind,
                signal,
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
