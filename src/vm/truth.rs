//! Drift from a driftloop model file: the virtual machine's "truth". The model's prediction for the spindle
//! schedule the program has produced so far (and for the signals of its declared inputs, e.g. ambient
//! temperature), minus its reading at rest, is the tool centre point's displacement (times `scale`, for a
//! sensor that counts the other way).

use std::collections::BTreeMap;

use crate::data::{Dataset, SPINDLE, TimeUnit};
use crate::model::DriftModel;

use super::machine::{SpindleHistory, piecewise_linear};

/// Input signals are sampled this often (minutes) between spindle changes: the model holds each input
/// constant from one row to the next.
const SIGNAL_STEP_MIN: f64 = 1.0;

#[derive(Debug, Clone)]
pub struct ModelDrift {
    pub model: DriftModel,
    pub scale: f64,
    /// `(minutes, value)` points of each declared input, by its column name.
    signals: BTreeMap<String, Vec<(f64, f64)>>,
}

impl ModelDrift {
    /// Refuses models the dry run cannot feed: a declared input without a signal among `signals` (by column
    /// name), effects this version cannot predict.
    pub fn new(
        model: DriftModel,
        scale: f64,
        signals: &BTreeMap<String, Vec<(f64, f64)>>,
    ) -> Result<Self, String> {
        let mut used = BTreeMap::new();
        // Every column the model reads besides the spindle, positions included (the machine has no
        // position column of its own: a position term's column is given as a signal over time).
        let positions = model.effects.iter().filter_map(|e| e.position.as_deref());
        for name in model.signals().into_iter().chain(positions) {
            let points = signals.get(name).ok_or_else(|| {
                format!(
                    "the model of {} takes the input `{name}`: give its signal ([signals.{name}])",
                    model.channel
                )
            })?;
            used.insert(name.to_string(), points.clone());
        }
        let truth = ModelDrift {
            model,
            scale,
            signals: used,
        };
        truth.try_at(1.0, &SpindleHistory::default())?;
        Ok(truth)
    }

    fn try_at(&self, t_min: f64, spindle: &SpindleHistory) -> Result<f64, String> {
        let mut times: Vec<f64> = spindle
            .intervals(t_min)
            .map(|(start, _, _)| start)
            .collect();
        if !self.signals.is_empty() {
            let steps = (t_min / SIGNAL_STEP_MIN).ceil() as usize;
            times.extend((0..steps).map(|k| k as f64 * SIGNAL_STEP_MIN));
            times.sort_by(f64::total_cmp);
            times.dedup();
        }
        times.retain(|&t| t < t_min);
        times.push(t_min);
        let rpm = times.iter().map(|&t| spindle.speed_at(t)).collect();
        let columns: Vec<(&String, Vec<f64>)> = self
            .signals
            .iter()
            .map(|(name, pts)| {
                (
                    name,
                    times.iter().map(|&t| piecewise_linear(pts, t)).collect(),
                )
            })
            .collect();
        let mut ds = Dataset::new("dry run", TimeUnit::Min, times);
        ds.push_column(SPINDLE, rpm);
        for (name, values) in columns {
            ds.push_column(name, values);
        }
        let predicted = self.model.predict(&ds).map_err(|e| e.to_string())?;
        let last = predicted.last().copied().unwrap_or(self.model.offset_um);
        Ok(self.scale * (last - self.model.offset_um))
    }

    /// Drift (µm) at `t_min` after the spindle `history` from rest.
    pub fn at(&self, t_min: f64, spindle: &SpindleHistory) -> f64 {
        // `new` checked that this model predicts for a spindle-only dataset.
        self.try_at(t_min, spindle).unwrap_or(f64::NAN)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MODEL: &str = r#"
schema = 1
channel = "drift_z_um"
offset_um = 2.0
[spindle]
grid_rpm = [4000.0]
interpolation = "piecewise-linear"
extrapolation = "linear-last-segment"
[[spindle.modes]]
tau_min = 30.0
gain_um = [20.0]
"#;

    #[test]
    fn heating_and_cooling_follow_the_lag_without_the_rest_offset() {
        let model = DriftModel::from_toml(MODEL, "m.toml").unwrap();
        let truth = ModelDrift::new(model, -1.0, &BTreeMap::new()).unwrap();
        let mut h = SpindleHistory::default();
        h.set(0.0, 4000.0);
        h.set(60.0, 0.0);
        let heated = 20.0 * (1.0 - (-2.0f64).exp());
        assert!((truth.at(60.0, &h) + heated).abs() < 1e-9);
        let cooled = heated * (-1.0f64).exp();
        assert!((truth.at(90.0, &h) + cooled).abs() < 1e-9);
        assert!((truth.at(15.0, &h) + 20.0 * (1.0 - (-0.5f64).exp())).abs() < 1e-9);
    }

    #[test]
    fn a_declared_input_follows_its_signal() {
        let text = format!(
            "{MODEL}[[inputs]]\nsignal = \"ambient_c\"\ntau_min = 20.0\ngain_um_per_unit = 2.0\n"
        );
        let model = DriftModel::from_toml(&text, "m.toml").unwrap();
        assert!(ModelDrift::new(model.clone(), 1.0, &BTreeMap::new()).is_err());
        // Ambient steps from 20 to 23 °C at once and stays: 3 °C × 2 µm/°C through a 20 min lag.
        let signals = BTreeMap::from([("ambient_c".to_string(), vec![(0.0, 20.0), (0.001, 23.0)])]);
        let truth = ModelDrift::new(model, 1.0, &signals).unwrap();
        let h = SpindleHistory::default();
        let expected = 6.0 * (1.0 - (-(60.0 - 1.0) / 20.0f64).exp());
        assert!(
            (truth.at(60.0, &h) - expected).abs() < 1e-9,
            "{} vs {expected}",
            truth.at(60.0, &h)
        );
    }

    #[test]
    fn a_sensor_regression_term_follows_its_signal_without_lag() {
        // What `sensors -o` writes: a static gain on a temperature, read at its own time.
        let text = format!(
            "{MODEL}[[effects]]\nkind = \"static_input\"\nsignal = \"t3_c\"\n[effects.params]\ngain_um_per_unit = 1.5\n"
        );
        let model = DriftModel::from_toml(&text, "m.toml").unwrap();
        let refused = ModelDrift::new(model.clone(), 1.0, &BTreeMap::new()).unwrap_err();
        assert!(refused.contains("[signals.t3_c]"), "{refused}");
        let signals = BTreeMap::from([("t3_c".to_string(), vec![(0.0, 25.0), (100.0, 27.0)])]);
        let truth = ModelDrift::new(model, 1.0, &signals).unwrap();
        let h = SpindleHistory::default();
        // 50 min in, the sensor reads 26 °C: 1 °C above the start × 1.5 µm/°C.
        assert!(
            (truth.at(50.0, &h) - 1.5).abs() < 1e-9,
            "{}",
            truth.at(50.0, &h)
        );
    }
}
