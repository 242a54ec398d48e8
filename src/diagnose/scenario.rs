//! A virtual machine for testing diagnosis (`driftloop simulate-data`): a known truth model, its
//! characterisation runs, and a production log carrying the truth plus one chosen undeclared effect and
//! noise. The truth (with the injected effect in its `effects`) is kept beside the data, so a test can
//! check that diagnosis found what was put in.
//!
//! Everything random is drawn from the seed: the truth's time constant and gains, the spindle schedule,
//! the slowly wandering ambient and coolant temperatures, the axis positions, the effect's parameters
//! and the noise. The effect's size is given as a multiple of the noise: the standard deviation of its
//! contribution over the production log.

use serde::Serialize;

use crate::data::{Dataset, SPINDLE, TimeUnit};
use crate::model::effects::{Effect, Kind};
use crate::model::synth::{Rng, Sampling, characterisation, measure};
use crate::model::{DriftModel, EffectSpec, PredictError};

/// Grid speeds of the characterisation and the production log (rpm).
pub const SPEEDS: [f64; 3] = [1000.0, 2000.0, 3000.0];
/// Channel name of the simulated displacement.
pub const CHANNEL: &str = "z_um";

/// What to simulate.
#[derive(Debug, Clone, Serialize)]
pub struct Scenario {
    pub seed: u64,
    pub noise_um: f64,
    /// The undeclared effect in the production log; `None` for a control.
    pub effect: Option<String>,
    /// The effect's standard deviation over the production log, in multiples of the noise.
    pub effect_size: f64,
    /// Production log length and sampling step (min).
    pub log_min: f64,
    pub step_min: f64,
    /// Rows from here on are the holdout (min).
    pub holdout_from_min: f64,
    /// The injected effect's θ instead of a random one (τ in minutes for the lagged kinds, the cooling ratio
    /// for `cooling_asymmetry`, the step's time): for cases harder than the random draw, such as a mode far
    /// slower than the characterisation runs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub theta: Option<f64>,
}

impl Scenario {
    pub fn new(seed: u64, effect: Option<Kind>) -> Scenario {
        Scenario {
            seed,
            noise_um: 0.3,
            effect: effect.map(|k| k.name().to_string()),
            effect_size: 5.0,
            log_min: 1440.0,
            step_min: 3.0,
            holdout_from_min: 1080.0,
            theta: None,
        }
    }
}

/// The simulated data and the truth behind them.
#[derive(Debug, Clone)]
pub struct Simulated {
    pub scenario: Scenario,
    /// The truth including the injected effect.
    pub truth: DriftModel,
    pub characterisation: Dataset,
    pub production: Dataset,
}

/// Why a scenario cannot be simulated.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    #[error(
        "unknown effect `{0}` (one of input_lag, extra_mode, cooling_asymmetry, position_slope, time_trend, periodic, step)"
    )]
    UnknownEffect(String),
    #[error(transparent)]
    Predict(#[from] PredictError),
}

/// Runs the scenario.
pub fn simulate(sc: &Scenario) -> Result<Simulated, ScenarioError> {
    let kind = match &sc.effect {
        Some(name) => {
            let kind = Kind::parse(name).filter(|k| Kind::DIAGNOSED.contains(k));
            Some(kind.ok_or_else(|| ScenarioError::UnknownEffect(name.clone()))?)
        }
        None => None,
    };
    let mut rng = Rng::new(sc.seed);
    let tau = 30.0 + 40.0 * rng.uniform();
    let per_krpm = 3.0 + 3.0 * rng.uniform();
    let gains: Vec<f64> = SPEEDS
        .iter()
        .map(|s| per_krpm * s / 1000.0 * (0.9 + 0.2 * rng.uniform()))
        .collect();
    let mut truth = DriftModel::from_modes(
        CHANNEL,
        SPEEDS.to_vec(),
        &[(tau, gains)],
        0.5 * rng.normal(),
    );
    let sampling = Sampling::Sparse {
        dense: 5.0,
        later: (10.0, 20.0),
    };
    let mut characterisation = characterisation(&SPEEDS, 240.0, 60.0, sampling, &mut rng);
    measure(&truth, &mut characterisation, sc.noise_um, &mut rng)?;
    characterisation.source = "characterisation.csv".into();

    let mut production = production_inputs(sc, &mut rng);
    if let Some(kind) = kind {
        let effect = injected(kind, sc, &production, &mut rng);
        truth.effects.push(effect);
    }
    measure(&truth, &mut production, sc.noise_um, &mut rng)?;
    Ok(Simulated {
        scenario: sc.clone(),
        truth,
        characterisation,
        production,
    })
}

/// The production log's inputs: random speed blocks on the grid (and stops), two wandering temperatures,
/// an axis position, on a constant step.
fn production_inputs(sc: &Scenario, rng: &mut Rng) -> Dataset {
    let n = (sc.log_min / sc.step_min).floor() as usize + 1;
    let t: Vec<f64> = (0..n).map(|i| i as f64 * sc.step_min).collect();
    let mut rpm = Vec::with_capacity(n);
    let (mut speed, mut until) = (0.0, 0.0);
    for &ti in &t {
        if ti >= until {
            let pick = (rng.uniform() * 4.0).floor() as usize;
            speed = if pick == 0 { 0.0 } else { SPEEDS[pick - 1] };
            until = ti + 30.0 + 120.0 * rng.uniform();
        }
        rpm.push(speed);
    }
    let mut ds = Dataset::new("production.csv", TimeUnit::Min, t.clone());
    ds.push_column(SPINDLE, rpm);
    ds.push_column("ambient_c", wander(&t, 20.0, 1.5, rng));
    ds.push_column("coolant_c", wander(&t, 22.0, 1.0, rng));
    let mut x = Vec::with_capacity(n);
    let (mut pos, mut until) = (0.0, 0.0);
    for &ti in &t {
        if ti >= until {
            pos = (rng.uniform() * 500.0).round();
            until = ti + 10.0 + 50.0 * rng.uniform();
        }
        x.push(pos);
    }
    ds.push_column("x_mm", x);
    ds
}

/// A temperature wandering around `mean` by about ±`swing`: a few slow sines of random period (3–11 h)
/// and phase — smooth, not daily, different per seed.
fn wander(t: &[f64], mean: f64, swing: f64, rng: &mut Rng) -> Vec<f64> {
    let parts: Vec<(f64, f64, f64)> = (0..3)
        .map(|_| {
            let period = 180.0 + 480.0 * rng.uniform();
            (
                period,
                std::f64::consts::TAU * rng.uniform(),
                0.5 + rng.uniform(),
            )
        })
        .collect();
    let norm: f64 = parts.iter().map(|p| p.2).sum();
    t.iter()
        .map(|&ti| {
            let v: f64 = parts
                .iter()
                .map(|(p, ph, a)| a * (std::f64::consts::TAU * ti / p + ph).sin())
                .sum();
            mean + swing * v / norm * 1.5
        })
        .collect()
}

/// The injected effect, its amplitude set so its contribution's standard deviation is
/// `effect_size × noise` (cooling asymmetry has no amplitude: its size follows from the ratio).
fn injected(kind: Kind, sc: &Scenario, ds: &Dataset, rng: &mut Rng) -> EffectSpec {
    let (signal, theta, amplitudes) = match kind {
        Kind::InputLag => {
            let sig = if rng.uniform() < 0.5 {
                "ambient_c"
            } else {
                "coolant_c"
            };
            (Some(sig), vec![20.0 + 70.0 * rng.uniform()], vec![1.0])
        }
        Kind::ExtraMode => (None, vec![300.0 + 300.0 * rng.uniform()], vec![1.0]),
        Kind::CoolingAsymmetry => {
            let r = if rng.uniform() < 0.5 {
                2.5 + rng.uniform()
            } else {
                0.3 + 0.1 * rng.uniform()
            };
            (None, vec![r], vec![])
        }
        Kind::PositionSlope => (
            Some("x_mm"),
            vec![30.0 + 60.0 * rng.uniform()],
            vec![1.0, 0.0],
        ),
        Kind::TimeTrend => (None, vec![], vec![1.0]),
        Kind::Periodic => {
            let phase = std::f64::consts::TAU * rng.uniform();
            (None, vec![], vec![phase.sin(), phase.cos()])
        }
        Kind::Step => {
            let at = sc.holdout_from_min * (0.25 + 0.5 * rng.uniform());
            (
                None,
                vec![(at / sc.step_min).round() * sc.step_min],
                vec![1.0],
            )
        }
        Kind::StaticInput | Kind::InputSlope | Kind::Geometric => {
            unreachable!("simulate refuses the regression kinds diagnosis does not search for")
        }
    };
    let mut effect = Effect {
        kind,
        signal: signal.map(str::to_string),
        position: None,
        theta: match sc.theta {
            Some(v) if !theta.is_empty() => vec![v],
            _ => theta,
        },
        amplitudes,
    };
    if kind != Kind::CoolingAsymmetry {
        let runs: Vec<_> = ds.runs().collect();
        let series = effect.series(&ds.time_min, &runs, ds.values(SPINDLE), |n| ds.values(n));
        let c = effect.contribution(&series);
        let sd = std_dev(&c);
        let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
        let scale = sign * sc.effect_size * sc.noise_um / sd.max(1e-12);
        effect.amplitudes.iter_mut().for_each(|a| *a *= scale);
    }
    effect.to_spec()
}

fn std_dev(v: &[f64]) -> f64 {
    let n = v.len().max(1) as f64;
    let mean = v.iter().sum::<f64>() / n;
    (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_injected_effect_has_the_asked_size_and_the_truth_predicts_the_log() {
        let sc = Scenario::new(4, Some(Kind::InputLag));
        let sim = simulate(&sc).unwrap();
        let spec = &sim.truth.effects[0];
        assert_eq!(spec.kind, "input_lag");
        let e = Effect::from_spec(spec).unwrap();
        let runs: Vec<_> = sim.production.runs().collect();
        let p = &sim.production;
        let series = e.series(&p.time_min, &runs, p.values(SPINDLE), |n| p.values(n));
        let sd = std_dev(&e.contribution(&series));
        assert!((sd - 1.5).abs() < 1e-9, "{sd}");
        let pred = sim.truth.predict(&sim.production).unwrap();
        let resid: Vec<f64> = pred
            .iter()
            .zip(sim.production.values(CHANNEL).unwrap())
            .map(|(p, y)| y - p)
            .collect();
        assert!((std_dev(&resid) - 0.3).abs() < 0.05);
        assert_eq!(simulate(&sc).unwrap().production, sim.production);
    }
}
