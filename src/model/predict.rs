//! Prediction: the exact state update run over a dataset's time axis, one run at a time, each from rest.
//! The inner loop allocates nothing and calls `exp` only when the time step changes.

use crate::data::{Dataset, SPINDLE};

use super::DriftModel;
use super::effects::cooling_asymmetry::Phase;
use super::effects::{Effect, EffectError, Kind};
use super::lag::{Decay, step};
use super::speed_grid::{SpeedGrid, Weights};

/// Why a model cannot predict for a dataset.
#[derive(Debug, thiserror::Error)]
pub enum PredictError {
    #[error("{source_name}: no `{column}` column, but the model of {channel} takes it as an input")]
    MissingInput {
        source_name: String,
        column: String,
        channel: String,
    },
    #[error(transparent)]
    Effect(#[from] EffectError),
    #[error("the model's speed grid {0:?} is not ascending positive speeds")]
    BadGrid(Vec<f64>),
    #[error("mode {mode}: {found} gains for {expected} grid speeds")]
    GainCount {
        mode: usize,
        found: usize,
        expected: usize,
    },
    #[error("output buffer has {found} values for {expected} rows")]
    OutputLength { found: usize, expected: usize },
}

impl DriftModel {
    /// Predicted drift (µm, including the offset) at every row of `ds`.
    pub fn predict(&self, ds: &Dataset) -> Result<Vec<f64>, PredictError> {
        let mut out = vec![0.0; ds.len()];
        self.predict_into(ds, &mut out)?;
        Ok(out)
    }

    /// [`DriftModel::predict`] into a caller's buffer (one value per row), for repeated evaluation.
    pub fn predict_into(&self, ds: &Dataset, out: &mut [f64]) -> Result<(), PredictError> {
        if out.len() != ds.len() {
            return Err(PredictError::OutputLength {
                found: out.len(),
                expected: ds.len(),
            });
        }
        let effects = self
            .effects
            .iter()
            .map(Effect::from_spec)
            .collect::<Result<Vec<_>, _>>()?;
        let mut sim = Simulator::new(self, &effects)?;
        let column = |name: &str| {
            ds.values(name).ok_or_else(|| PredictError::MissingInput {
                source_name: ds.source.clone(),
                column: name.to_string(),
                channel: self.channel.clone(),
            })
        };
        let rpm = if self.spindle.modes.is_empty() {
            None
        } else {
            Some(column(SPINDLE)?)
        };
        let inputs = self
            .inputs
            .iter()
            .map(|i| column(&i.signal))
            .collect::<Result<Vec<_>, _>>()?;
        for run in ds.runs() {
            let r = run.clone();
            let signals: Vec<&[f64]> = inputs.iter().map(|s| &s[r.clone()]).collect();
            sim.run(
                &ds.time_min[r.clone()],
                rpm.map(|s| &s[r.clone()]),
                &signals,
                &mut out[r],
            );
        }
        let runs: Vec<_> = ds.runs().collect();
        for e in effects.iter().filter(|e| !e.amplitudes.is_empty()) {
            for name in e.signal.iter().chain(&e.position) {
                column(name)?;
            }
            let series = e.series(&ds.time_min, &runs, ds.values(SPINDLE), |n| ds.values(n));
            for (o, c) in out.iter_mut().zip(e.contribution(&series)) {
                *o += c;
            }
        }
        Ok(())
    }
}

/// The model laid out for the inner loop.
struct Simulator<'m> {
    offset: f64,
    grid: SpeedGrid,
    modes: Vec<(Decay, &'m [f64])>,
    /// Decays of the modes while cooling, when cooling is slower or faster than heating.
    cooling: Option<Vec<Decay>>,
    mode_x: Vec<f64>,
    inputs: Vec<(Decay, f64)>,
    input_x: Vec<f64>,
}

impl<'m> Simulator<'m> {
    fn new(model: &'m DriftModel, effects: &[Effect]) -> Result<Simulator<'m>, PredictError> {
        let nodes = &model.spindle.grid_rpm;
        let grid = if model.spindle.modes.is_empty() && nodes.is_empty() {
            SpeedGrid::from_speeds(&[])
        } else {
            SpeedGrid::new(nodes.clone()).ok_or_else(|| PredictError::BadGrid(nodes.clone()))?
        };
        for (i, m) in model.spindle.modes.iter().enumerate() {
            if m.gain_um.len() != nodes.len() {
                return Err(PredictError::GainCount {
                    mode: i + 1,
                    found: m.gain_um.len(),
                    expected: nodes.len(),
                });
            }
        }
        Ok(Simulator {
            offset: model.offset_um,
            grid,
            modes: model
                .spindle
                .modes
                .iter()
                .map(|m| (Decay::new(m.tau_min), m.gain_um.as_slice()))
                .collect(),
            cooling: effects
                .iter()
                .find(|e| e.kind == Kind::CoolingAsymmetry)
                .map(|e| {
                    model
                        .spindle
                        .modes
                        .iter()
                        .map(|m| Decay::new(m.tau_min * e.theta[0]))
                        .collect()
                }),
            mode_x: vec![0.0; model.spindle.modes.len()],
            inputs: model
                .inputs
                .iter()
                .map(|i| (Decay::new(i.tau_min), i.gain_um_per_unit))
                .collect(),
            input_x: vec![0.0; model.inputs.len()],
        })
    }

    /// One run from rest; `rpm` is `None` for a model without spindle modes.
    fn run(&mut self, t: &[f64], rpm: Option<&[f64]>, signals: &[&[f64]], out: &mut [f64]) {
        if t.is_empty() {
            return;
        }
        self.mode_x.fill(0.0);
        self.input_x.fill(0.0);
        out[0] = self.offset;
        let speed = |i: usize| rpm.map_or(0.0, |r| r[i]);
        let mut last_rpm = speed(0);
        let mut w: Weights = self.grid.weights(last_rpm);
        let mut phase = Phase::new(last_rpm);
        for i in 1..t.len() {
            let dt = t[i] - t[i - 1];
            let s = speed(i - 1);
            if s != last_rpm {
                last_rpm = s;
                w = self.grid.weights(s);
            }
            let cooling = phase.cooling(s);
            let mut sum = self.offset;
            for (k, ((decay, gains), x)) in self
                .modes
                .iter_mut()
                .zip(self.mode_x.iter_mut())
                .enumerate()
            {
                let e = match &mut self.cooling {
                    Some(c) if cooling => c[k].at(dt),
                    _ => decay.at(dt),
                };
                *x = step(*x, w.apply(gains), e);
                sum += *x;
            }
            for (((decay, gain), x), u) in self
                .inputs
                .iter_mut()
                .zip(self.input_x.iter_mut())
                .zip(signals)
            {
                *x = step(*x, *gain * (u[i - 1] - u[0]), decay.at(dt));
                sum += *x;
            }
            out[i] = sum;
        }
    }
}
