//! The terms of a distributed-lag model and their columns. Every term is a kind a model file already
//! holds, and its column is computed by the same code that predicts it from the file — so the exported
//! model predicts exactly what was fitted:
//! - a sensor at lag 0: a `static_input` effect, gain·(u(i) − u at the run's start);
//! - a sensor at lag τ: an `input_lag` effect, the same change through a first-order lag;
//! - the spindle at lag τ: a spindle mode whose gains on the speed grid follow its own power law
//!   gain ∝ (n / n_top)^p.

use std::ops::Range;

use crate::data::{Dataset, SPINDLE};
use crate::model::effects::{Effect, Kind};
use crate::model::speed_law::PowerLaw;
use crate::model::{DriftModel, EffectSpec, Mode};

/// One column of the design.
#[derive(Debug, Clone, PartialEq)]
pub enum Term {
    /// A measured signal (a temperature) as a change from its run's start, lagged by `lag_min` (0: none).
    Sensor { signal: String, lag_min: f64 },
    /// The spindle speed through the power law with `exponent`, lagged by `lag_min` (> 0).
    Spindle { lag_min: f64, exponent: f64 },
}

impl Term {
    /// The model-file effect of a sensor term with gain `gain`; `None` for a spindle term.
    pub fn effect(&self, gain: f64) -> Option<Effect> {
        let Term::Sensor { signal, lag_min } = self else {
            return None;
        };
        let (kind, theta) = if *lag_min == 0.0 {
            (Kind::StaticInput, vec![])
        } else {
            (Kind::InputLag, vec![*lag_min])
        };
        Some(Effect {
            kind,
            signal: Some(signal.clone()),
            position: None,
            theta,
            amplitudes: vec![gain],
        })
    }

    /// The spindle mode of a spindle term with gain `gain` at the top characterised speed.
    pub fn mode(&self, gain: f64, speeds: &SpeedNodes) -> Option<Mode> {
        let Term::Spindle { lag_min, exponent } = self else {
            return None;
        };
        Some(Mode {
            tau_min: *lag_min,
            tau_se_min: None,
            gain_um: speeds.gains(*exponent).iter().map(|g| gain * g).collect(),
            gain_se_um: Vec::new(),
            power_law_exponent: Some(*exponent),
        })
    }

    pub fn lag_min(&self) -> f64 {
        match self {
            Term::Sensor { lag_min, .. } | Term::Spindle { lag_min, .. } => *lag_min,
        }
    }

    /// `t3_c` / `t3_c, lag 15 min` / `spindle, lag 60 min`.
    pub fn label(&self) -> String {
        let lag = |l: f64| {
            if l == 0.0 {
                String::new()
            } else {
                format!(", lag {}", crate::model::lag::fmt_tau(l))
            }
        };
        match self {
            Term::Sensor { signal, lag_min } => format!("{signal}{}", lag(*lag_min)),
            Term::Spindle { lag_min, exponent } => {
                format!("spindle^{exponent}{}", lag(*lag_min))
            }
        }
    }
}

/// One mode per time constant: the modes of spindle terms with the same lag (and different exponents, from
/// averaged designs) are one linear response to the speed, so their grid gains add exactly, and the NC
/// program keeps one state for them. A merged mode whose terms had different exponents carries none: its
/// gains follow their weighted mix.
pub fn merge_modes(modes: impl Iterator<Item = Mode>) -> Vec<Mode> {
    let mut out: Vec<Mode> = Vec::new();
    for m in modes {
        match out.iter_mut().find(|o| o.tau_min == m.tau_min) {
            Some(o) => {
                o.gain_um
                    .iter_mut()
                    .zip(&m.gain_um)
                    .for_each(|(a, b)| *a += b);
                if o.power_law_exponent != m.power_law_exponent {
                    o.power_law_exponent = None;
                }
            }
            None => out.push(m),
        }
    }
    out
}

/// The speed grid the spindle terms' laws are written on: the characterised speeds and the ladder.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedNodes {
    pub top_rpm: f64,
    pub nodes: Vec<f64>,
}

impl SpeedNodes {
    /// `None` without a characterised speed.
    pub fn new(characterised: &[f64]) -> Option<SpeedNodes> {
        let top_rpm = *characterised.last()?;
        let law = PowerLaw {
            top_rpm,
            exponent: 1.0,
        };
        Some(SpeedNodes {
            top_rpm,
            nodes: law.nodes(characterised),
        })
    }

    /// The law's relative gain at every node for exponent `p`.
    pub fn gains(&self, p: f64) -> Vec<f64> {
        PowerLaw {
            top_rpm: self.top_rpm,
            exponent: p,
        }
        .gains(&self.nodes)
    }
}

/// The column of one term on every row of `ds` (`speeds` is needed for spindle terms).
pub fn column(ds: &Dataset, term: &Term, speeds: Option<&SpeedNodes>) -> Vec<f64> {
    match (term, speeds) {
        (Term::Sensor { .. }, _) => {
            let e = term.effect(1.0).expect("a sensor term is an effect");
            let runs: Vec<Range<usize>> = ds.runs().collect();
            let series = e.series(&ds.time_min, &runs, ds.values(SPINDLE), |n| ds.values(n));
            let mut col = vec![0.0; ds.len()];
            e.columns(&series, &e.theta, &mut [&mut col]);
            col
        }
        (Term::Spindle { lag_min, exponent }, Some(s)) => {
            let unit = DriftModel::from_modes(
                "unit",
                s.nodes.clone(),
                &[(*lag_min, s.gains(*exponent))],
                0.0,
            );
            unit.predict(ds)
                .expect("the spindle column exists when spindle terms are built")
        }
        (Term::Spindle { .. }, None) => vec![0.0; ds.len()],
    }
}

/// The effects of the sensor terms with their gains, in term order.
pub fn effect_specs(terms: &[Term], gains: &[f64]) -> Vec<EffectSpec> {
    terms
        .iter()
        .zip(gains)
        .filter_map(|(t, g)| t.effect(*g))
        .map(|e| e.to_spec())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Schedule;

    #[test]
    fn columns_are_what_the_model_file_predicts() {
        let mut ds = "1250:120,0:60,2500:90"
            .parse::<Schedule>()
            .unwrap()
            .to_dataset(2.0);
        let temp: Vec<f64> = ds
            .time_min
            .iter()
            .map(|t| 20.0 + (t / 50.0).sin())
            .collect();
        ds.push_column("t1_c", temp);
        let speeds = SpeedNodes::new(&[1250.0, 2500.0]).unwrap();
        let terms = [
            Term::Sensor {
                signal: "t1_c".into(),
                lag_min: 0.0,
            },
            Term::Sensor {
                signal: "t1_c".into(),
                lag_min: 30.0,
            },
            Term::Spindle {
                lag_min: 40.0,
                exponent: 1.5,
            },
        ];
        let gains = [2.0, -1.0, 3.0];
        let mut model = DriftModel::from_modes("z_um", speeds.nodes.clone(), &[], 0.5);
        model.spindle.modes = vec![terms[2].mode(gains[2], &speeds).unwrap()];
        model.effects = effect_specs(&terms, &gains);
        let predicted = model.predict(&ds).unwrap();
        let cols: Vec<Vec<f64>> = terms
            .iter()
            .map(|t| column(&ds, t, Some(&speeds)))
            .collect();
        for i in 0..ds.len() {
            let sum: f64 = 0.5 + (0..3).map(|k| gains[k] * cols[k][i]).sum::<f64>();
            assert!((sum - predicted[i]).abs() < 1e-12, "row {i}");
        }
        // The spindle column at the end of the 1250 rpm heat is near the law's gain there.
        let at = ds.time_min.iter().position(|&t| t >= 120.0).unwrap();
        assert!((cols[2][at] - 0.5f64.powf(1.5) * (1.0 - (-3.0f64).exp())).abs() < 0.02);
        assert_eq!(terms[1].label(), "t1_c, lag 30.0 min");
    }

    #[test]
    fn modes_of_one_lag_merge_into_one() {
        let speeds = SpeedNodes::new(&[1250.0, 2500.0]).unwrap();
        let term = |lag_min, exponent| Term::Spindle { lag_min, exponent };
        let modes = [
            term(60.0, 1.0).mode(2.0, &speeds).unwrap(),
            term(15.0, 2.0).mode(-1.0, &speeds).unwrap(),
            term(60.0, 3.0).mode(0.5, &speeds).unwrap(),
            term(15.0, 2.0).mode(3.0, &speeds).unwrap(),
        ];
        let merged = merge_modes(modes.clone().into_iter());
        assert_eq!(merged.len(), 2);
        assert_eq!((merged[0].tau_min, merged[1].tau_min), (60.0, 15.0));
        for (j, &n) in speeds.nodes.iter().enumerate() {
            let x = n / 2500.0;
            assert!((merged[0].gain_um[j] - (2.0 * x + 0.5 * x.powi(3))).abs() < 1e-12);
            assert!((merged[1].gain_um[j] - 2.0 * x * x).abs() < 1e-12);
        }
        // Different exponents: the mode follows their mix and carries none; the same exponent stays.
        assert_eq!(merged[0].power_law_exponent, None);
        assert_eq!(merged[1].power_law_exponent, Some(2.0));
    }
}
