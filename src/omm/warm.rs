//! `[warm_start]` of a machine profile: the model's mode states carry from one job to the next in retentive
//! R-parameters, stamped with the control's clock, so a machine still warm from the last job is not taken
//! for a cold one. Off by default.

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WarmStart {
    /// The first R-parameter of the store: a validity marker, the model fingerprint, the stamp (day number,
    /// seconds of the day), then every spindle mode state. No other program may use these.
    pub r_first: u32,
    /// A stamp older than this many times the model's longest time constant is ignored (cold start).
    #[serde(default = "ten")]
    pub max_age_tau: f64,
}

fn ten() -> f64 {
    10.0
}

/// What the store's first register holds once a program has written it: "there is a stored state".
pub const MARKER: u32 = 271_828;
/// Registers of the store before the states.
pub const HEADER: u32 = 4;

impl WarmStart {
    /// What serde cannot check; `range` is the profile's own R range (`registers.r_first..=r_last`).
    /// `last` is the highest R-parameter a profile may name.
    pub fn validate(&self, range: (u32, u32), last: u32) -> Result<(), String> {
        if !(self.max_age_tau.is_finite() && self.max_age_tau > 0.0 && self.max_age_tau <= 1000.0) {
            return Err(format!(
                "warm_start.max_age_tau must be in (0, 1000], not {}",
                self.max_age_tau
            ));
        }
        if self.r_first >= range.0 && self.r_first <= range.1 {
            return Err(format!(
                "warm_start.r_first R{} lies in registers.r_first…r_last (R{}…R{}): the store needs R-parameters of its own",
                self.r_first, range.0, range.1
            ));
        }
        if self.r_first > last {
            return Err(format!(
                "warm_start.r_first R{} is above R{last}",
                self.r_first
            ));
        }
        Ok(())
    }
}

/// A number that tells models apart (< 2^24, exact in an R-parameter): from the SHA-256 of each model file.
pub fn fingerprint(shas: &[&str]) -> u32 {
    shas.iter().fold(0u32, |acc, sha| {
        let head = u32::from_str_radix(sha.get(..6).unwrap_or("0"), 16).unwrap_or(0);
        (acc.wrapping_mul(31) ^ head) & 0x00ff_ffff
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fingerprints_differ_by_model_and_fit_an_r_parameter() {
        let a = fingerprint(&["a1b2c3d4"]);
        assert_eq!(a, 0xa1b2c3);
        assert_ne!(a, fingerprint(&["a1b2c4d4"]));
        assert!(fingerprint(&["ffffff", "ffffff"]) < 1 << 24);
    }

    #[test]
    fn the_store_must_lie_outside_the_profile_range() {
        let w = WarmStart {
            r_first: 60,
            max_age_tau: 10.0,
        };
        assert!(
            w.validate((50, 99), 9999)
                .unwrap_err()
                .starts_with("warm_start.r_first")
        );
        let ok = WarmStart { r_first: 900, ..w };
        assert_eq!(ok.validate((50, 99), 9999), Ok(()));
    }
}
