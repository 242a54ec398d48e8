//! `[continuous]` of a machine profile: between the gates, the program applies its prediction through the
//! control's position-independent temperature compensation (setting data SD43900
//! `$SA_TEMP_COMP_ABS_VALUE[axis]`), with every measurement re-zeroing the residual. Off by default.

use serde::{Deserialize, Serialize};

/// How the prediction is applied between the gates.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContinuousMode {
    /// Only the gates correct (the work offset).
    #[default]
    Off,
    /// SD43900 carries the prediction (less the residual the last measurement found) between the gates.
    TempComp,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Continuous {
    #[serde(default)]
    pub mode: ContinuousMode,
    /// Minutes of machine time (as planned) after which a safe place between two gates refreshes the value.
    #[serde(default = "five")]
    pub interval_min: f64,
    /// The largest change of SD43900 one refresh between gates makes (µm); a gate always corrects fully,
    /// the work offset taking what the step left.
    #[serde(default = "ten")]
    pub max_step_um: f64,
    /// `1`: a positive SD43900 acts like a positive work-offset translation (the axis moves that much in
    /// its positive direction for the same programmed position); `-1`: the opposite. Check on the machine.
    #[serde(default = "plus")]
    pub sign: i32,
    /// The user alarm when MD32750 `$MA_TEMP_COMP_TYPE` bit 0 is not set on a compensated axis.
    #[serde(default = "alarm")]
    pub alarm: u32,
}

fn five() -> f64 {
    5.0
}
fn ten() -> f64 {
    10.0
}
fn plus() -> i32 {
    1
}
fn alarm() -> u32 {
    65002
}

impl Default for Continuous {
    fn default() -> Self {
        Continuous {
            mode: ContinuousMode::Off,
            interval_min: five(),
            max_step_um: ten(),
            sign: plus(),
            alarm: alarm(),
        }
    }
}

impl Continuous {
    pub fn is_default(&self) -> bool {
        *self == Continuous::default()
    }

    pub fn on(&self) -> bool {
        self.mode == ContinuousMode::TempComp
    }

    /// What serde cannot check; `diameter` tells whether the profile measures or corrects in diameters.
    pub fn validate(&self, diameter: bool) -> Result<(), String> {
        if !(self.interval_min.is_finite()
            && self.interval_min > 0.0
            && self.interval_min <= 1440.0)
        {
            return Err(format!(
                "continuous.interval_min must be minutes in (0, 1440], not {}",
                self.interval_min
            ));
        }
        if !(self.max_step_um.is_finite() && self.max_step_um > 0.0 && self.max_step_um <= 1000.0) {
            return Err(format!(
                "continuous.max_step_um must be µm in (0, 1000], not {}",
                self.max_step_um
            ));
        }
        if self.sign != 1 && self.sign != -1 {
            return Err(format!(
                "continuous.sign must be 1 or -1, not {}",
                self.sign
            ));
        }
        if !(60000..=69999).contains(&self.alarm) {
            return Err(format!(
                "continuous.alarm {} is not a user (cycle) alarm number 60000…69999",
                self.alarm
            ));
        }
        if self.on() && diameter {
            return Err(
                "continuous.mode \"temp_comp\" is not supported with position.diameter or offset.diameter: whether SD43900 holds a radius or a diameter on a transverse axis is not confirmed"
                    .into(),
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_off_and_bad_values_name_their_key() {
        let c = Continuous::default();
        assert!(!c.on());
        assert_eq!(c.validate(true), Ok(()), "off never conflicts");
        let on = Continuous {
            mode: ContinuousMode::TempComp,
            ..c.clone()
        };
        assert!(on.validate(true).unwrap_err().contains("diameter"));
        for (bad, key) in [
            (
                Continuous {
                    interval_min: 0.0,
                    ..on.clone()
                },
                "continuous.interval_min",
            ),
            (
                Continuous {
                    max_step_um: f64::NAN,
                    ..on.clone()
                },
                "continuous.max_step_um",
            ),
            (
                Continuous {
                    sign: 0,
                    ..on.clone()
                },
                "continuous.sign",
            ),
            (
                Continuous {
                    alarm: 1,
                    ..on.clone()
                },
                "continuous.alarm",
            ),
        ] {
            assert!(bad.validate(false).unwrap_err().starts_with(key), "{key}");
        }
    }
}
