//! `cooling_asymmetry`: the spindle modes cool with a different time constant than they heat,
//! τ_cool = r·τ for every mode (θ = r, `cooling_tau_ratio`; no amplitude of its own).
//!
//! Whether a mode heats or cools is decided by the speed, not by the mode's state, so the model stays
//! linear in its gains: after the speed falls the modes cool until the speed next rises, after it rises
//! they heat. For gains that grow with speed (every characterised machine) this is the same as comparing
//! each mode's state with its target; a run starts heating.

/// Follows the speed and says, for each interval, whether the modes cool.
#[derive(Debug, Clone, Copy)]
pub struct Phase {
    last: f64,
    cooling: bool,
}

impl Phase {
    /// At a run's first row.
    pub fn new(rpm: f64) -> Phase {
        Phase {
            last: rpm.abs(),
            cooling: false,
        }
    }

    /// Whether the interval starting at a row with speed `rpm` cools.
    #[inline]
    pub fn cooling(&mut self, rpm: f64) -> bool {
        let r = rpm.abs();
        if r != self.last {
            self.cooling = r < self.last;
            self.last = r;
        }
        self.cooling
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::DriftModel;
    use crate::model::effects::{Effect, Kind};
    use crate::model::schedule::Schedule;

    #[test]
    fn phases_follow_speed_changes() {
        let mut p = Phase::new(0.0);
        let seq: Vec<bool> = [0.0, 2000.0, 2000.0, 1000.0, 1000.0, 0.0, 3000.0]
            .iter()
            .map(|&r| p.cooling(r))
            .collect();
        assert_eq!(seq, [false, false, false, true, true, true, false]);
    }

    #[test]
    fn a_slower_cooling_keeps_the_drift_up_after_the_spindle_stops() {
        let mut model = DriftModel::from_modes("z_um", vec![3000.0], &[(30.0, vec![10.0])], 0.0);
        let ds = "3000:240,0:60".parse::<Schedule>().unwrap().to_dataset(1.0);
        let plain = model.predict(&ds).unwrap();
        let effect = Effect {
            kind: Kind::CoolingAsymmetry,
            signal: None,
            position: None,
            theta: vec![3.0],
            amplitudes: vec![],
        };
        model.effects.push(effect.to_spec());
        let slow = model.predict(&ds).unwrap();
        // Heating is unchanged; 30 min into cooling the state decays with τ = 90 min instead of 30.
        assert!((slow[200] - plain[200]).abs() < 1e-12);
        assert!((plain[270] - 10.0 * (-1.0f64).exp()).abs() < 5e-3);
        assert!((slow[270] - 10.0 * (-1.0f64 / 3.0).exp()).abs() < 5e-3);
        super::super::test_support::assert_round_trip(&effect);
    }
}
