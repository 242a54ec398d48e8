//! Drift from a driftloop model file: the virtual machine's "truth". The model's prediction for the spindle
//! schedule the program has produced so far, minus its reading at rest, is the tool centre point's
//! displacement (times `scale`, for a sensor that counts the other way).

use crate::data::{Dataset, SPINDLE, TimeUnit};
use crate::model::DriftModel;

use super::machine::SpindleHistory;

#[derive(Debug, Clone)]
pub struct ModelDrift {
    pub model: DriftModel,
    pub scale: f64,
}

impl ModelDrift {
    /// Refuses models the dry run cannot feed: inputs other than spindle speed (it knows no ambient
    /// temperature), effects this version cannot predict.
    pub fn new(model: DriftModel, scale: f64) -> Result<Self, String> {
        if let Some(input) = model.inputs.first() {
            return Err(format!(
                "the model of {} takes the input `{}`, which the dry run cannot supply (spindle speed only)",
                model.channel, input.signal
            ));
        }
        let probe = ModelDrift { model, scale };
        probe.try_at(1.0, &SpindleHistory::default())?;
        Ok(probe)
    }

    fn try_at(&self, t_min: f64, spindle: &SpindleHistory) -> Result<f64, String> {
        let mut times = Vec::new();
        let mut rpm = Vec::new();
        for (start, _, speed) in spindle.intervals(t_min) {
            times.push(start);
            rpm.push(speed);
        }
        if times.last() != Some(&t_min) {
            times.push(t_min);
            rpm.push(spindle.speed_at(t_min));
        }
        let mut ds = Dataset::new("dry run", TimeUnit::Min, times);
        ds.push_column(SPINDLE, rpm);
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
        let truth = ModelDrift::new(model, -1.0).unwrap();
        let mut h = SpindleHistory::default();
        h.set(0.0, 4000.0);
        h.set(60.0, 0.0);
        let heated = 20.0 * (1.0 - (-2.0f64).exp());
        assert!((truth.at(60.0, &h) + heated).abs() < 1e-9);
        let cooled = heated * (-1.0f64).exp();
        assert!((truth.at(90.0, &h) + cooled).abs() < 1e-9);
        assert!((truth.at(15.0, &h) + 20.0 * (1.0 - (-0.5f64).exp())).abs() < 1e-9);
    }
}
