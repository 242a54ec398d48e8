//! The model file: TOML, `schema = 1`, units in the field names. The schema is checked before anything
//! else so a file from a newer driftloop is refused with a message that says so.

use std::path::Path;

use super::{DriftModel, SCHEMA};

/// Why a model file could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum ModelFileError {
    #[error("{file}: {source}")]
    Io {
        file: String,
        source: std::io::Error,
    },
    #[error("{file}: not a valid model file: {message}")]
    Syntax { file: String, message: String },
    #[error("{file}: no `schema` number: not a driftloop model file")]
    NoSchema { file: String },
    #[error(
        "{file}: model file schema {found} is not supported: this driftloop reads schema {SCHEMA} only"
    )]
    Schema { file: String, found: i64 },
    #[error("{file}: {message}")]
    Invalid { file: String, message: String },
}

impl DriftModel {
    /// The model file text.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a model always serialises to TOML")
    }

    /// Parses a model file's text; `file` names it in errors.
    pub fn from_toml(text: &str, file: &str) -> Result<DriftModel, ModelFileError> {
        let syntax = |e: toml::de::Error| ModelFileError::Syntax {
            file: file.to_string(),
            message: e.message().to_string(),
        };
        let table: toml::Table = toml::from_str(text).map_err(syntax)?;
        match table.get("schema").and_then(toml::Value::as_integer) {
            None => {
                return Err(ModelFileError::NoSchema {
                    file: file.to_string(),
                });
            }
            Some(found) if found != i64::from(SCHEMA) => {
                return Err(ModelFileError::Schema {
                    file: file.to_string(),
                    found,
                });
            }
            Some(_) => {}
        }
        let model: DriftModel = toml::from_str(text).map_err(syntax)?;
        model
            .validate()
            .map_err(|message| ModelFileError::Invalid {
                file: file.to_string(),
                message,
            })?;
        Ok(model)
    }

    /// Reads a model file.
    pub fn read(path: &Path) -> Result<DriftModel, ModelFileError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| ModelFileError::Io {
            file: file.clone(),
            source,
        })?;
        DriftModel::from_toml(&text, &file)
    }

    /// Checks what serde cannot: a usable grid, gains per grid speed, positive finite time constants.
    pub fn validate(&self) -> Result<(), String> {
        let sp = &self.spindle;
        if !sp.modes.is_empty() && self.speed_grid().is_none() {
            return Err(format!(
                "spindle.grid_rpm {:?} must be ascending speeds above 0",
                sp.grid_rpm
            ));
        }
        for (i, m) in sp.modes.iter().enumerate() {
            if m.gain_um.len() != sp.grid_rpm.len() {
                return Err(format!(
                    "mode {} has {} gains for {} grid speeds",
                    i + 1,
                    m.gain_um.len(),
                    sp.grid_rpm.len()
                ));
            }
            if !(m.tau_min.is_finite() && m.tau_min > 0.0)
                || m.gain_um.iter().any(|g| !g.is_finite())
            {
                return Err(format!(
                    "mode {} needs a positive τ and finite gains",
                    i + 1
                ));
            }
        }
        if sp.extrapolation == super::Extrapolation::PowerLaw {
            let top_ok = sp
                .characterised_top_rpm
                .is_some_and(|t| sp.grid_rpm.iter().any(|n| (n - t).abs() <= 1e-9 * t));
            let p_ok = sp.modes.iter().all(|m| {
                m.power_law_exponent
                    .is_some_and(|p| p.is_finite() && p > 0.0)
            });
            if !top_ok || !p_ok {
                return Err(
                    "spindle.extrapolation = \"power-law\" needs characterised_top_rpm (a grid speed) and a positive power_law_exponent in every mode".into(),
                );
            }
        }
        for i in &self.inputs {
            if !(i.tau_min.is_finite() && i.tau_min > 0.0 && i.gain_um_per_unit.is_finite()) {
                return Err(format!(
                    "input `{}` needs a positive τ and a finite gain",
                    i.signal
                ));
            }
        }
        if !self.offset_um.is_finite() {
            return Err("offset_um must be finite".into());
        }
        Ok(())
    }
}
