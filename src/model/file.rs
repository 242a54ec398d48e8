//! The model file: TOML, `schema = 1`, units in the field names. The schema is checked before anything
//! else so a file from a newer driftloop is refused with a message that says so.

use std::path::Path;

use super::{DriftModel, SCHEMA};

/// Shortest time constant a model may carry (min): 60 ms. A shorter one is no thermal mode, and written
/// into a program as `EXP(-dt/τ)` it would round to a division by zero.
pub const TAU_SHORTEST_MIN: f64 = 1e-3;
/// Longest time constant (min): about 19 years.
pub const TAU_LONGEST_MIN: f64 = 1e7;
pub use crate::data::{FASTEST_RPM, LARGEST_UM};

/// Why a model file could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum ModelFileError {
    #[error("{file}: cannot read: {source}")]
    Io {
        file: String,
        source: std::io::Error,
    },
    /// `at`: `file:line:column` where the TOML could not be read.
    #[error("{at}: not a valid model file: {message}")]
    Syntax { at: String, message: String },
    #[error("{file}: no `schema` number: not a driftloop model file")]
    NoSchema { file: String },
    #[error(
        "{file}: model file schema {found} is not supported: this driftloop reads schema {SCHEMA} only"
    )]
    Schema { file: String, found: i64 },
    /// `message`: `file:line:column: what is wrong` (`file: …` for a key the file does not hold).
    #[error("{message}")]
    Invalid { message: String },
}

impl DriftModel {
    /// The model file text.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a model always serialises to TOML")
    }

    /// Parses a model file's text; `file` names it in errors, which point at the line and column of the
    /// value they are about.
    pub fn from_toml(text: &str, file: &str) -> Result<DriftModel, ModelFileError> {
        let syntax = |e: toml::de::Error| {
            let (at, message) = crate::toml_span::syntax_error(file, text, &e);
            ModelFileError::Syntax { at, message }
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
                message: crate::toml_span::validation_error(file, text, &message),
            })?;
        Ok(model)
    }

    /// Reads a model file.
    pub fn read(path: &Path) -> Result<DriftModel, ModelFileError> {
        let file = path.display().to_string();
        let text = crate::text::read_utf8(path, crate::text::TOML).map_err(|source| {
            ModelFileError::Io {
                file: file.clone(),
                source,
            }
        })?;
        DriftModel::from_toml(&text, &file)
    }

    /// Checks what serde cannot: a usable grid, gains per grid speed, time constants and figures in the
    /// range a machine has ([`TAU_SHORTEST_MIN`], [`LARGEST_UM`], …), names that fit in an NC program's
    /// texts. Each message starts with the key path it is about (`spindle.modes[1].tau_min`).
    pub fn validate(&self) -> Result<(), String> {
        name("channel", &self.channel)?;
        let sp = &self.spindle;
        if !sp.modes.is_empty() && (sp.grid_rpm.is_empty() || self.speed_grid().is_none()) {
            return Err(format!(
                "spindle.grid_rpm {:?} must be ascending speeds above 0",
                sp.grid_rpm
            ));
        }
        for (i, rpm) in sp.grid_rpm.iter().enumerate() {
            if *rpm > FASTEST_RPM {
                return Err(format!(
                    "spindle.grid_rpm[{i}] {rpm:?} rpm is faster than {FASTEST_RPM} rpm"
                ));
            }
        }
        for (i, m) in sp.modes.iter().enumerate() {
            let key = format!("spindle.modes[{i}]");
            if m.gain_um.len() != sp.grid_rpm.len() {
                return Err(format!(
                    "{key}.gain_um has {} gains for {} grid speeds",
                    m.gain_um.len(),
                    sp.grid_rpm.len()
                ));
            }
            tau(&format!("{key}.tau_min"), m.tau_min)?;
            for (j, g) in m.gain_um.iter().enumerate() {
                figure(&format!("{key}.gain_um[{j}]"), *g)?;
            }
        }
        if sp.extrapolation == super::Extrapolation::PowerLaw {
            let top_ok = sp
                .characterised_top_rpm
                .is_some_and(|t| sp.grid_rpm.iter().any(|n| (n - t).abs() <= 1e-9 * t));
            // A mode without an exponent follows a mix of laws (an averaged dlag fit): its gains say it.
            let p_ok = sp.modes.iter().all(|m| {
                m.power_law_exponent
                    .is_none_or(|p| p.is_finite() && p > 0.0 && p <= 10.0)
            });
            if !top_ok || !p_ok {
                return Err(
                    "spindle.extrapolation = \"power-law\" needs characterised_top_rpm (a grid speed) and every power_law_exponent in (0, 10]".into(),
                );
            }
        }
        for (i, input) in self.inputs.iter().enumerate() {
            let key = format!("inputs[{i}]");
            name(&format!("{key}.signal"), &input.signal)?;
            // Earlier `sensors -o` wrote an input acting at once as one with τ far below any step: such
            // files still predict; only the NC program refuses them (see `validate_for_nc`).
            if !(input.tau_min > 0.0 && input.tau_min <= TAU_LONGEST_MIN) {
                tau(&format!("{key}.tau_min"), input.tau_min)?;
            }
            figure(&format!("{key}.gain_um_per_unit"), input.gain_um_per_unit)?;
        }
        for (i, e) in self.effects.iter().enumerate() {
            let key = format!("effects[{i}]");
            for (field, text) in [("signal", &e.signal), ("position", &e.position)] {
                if let Some(text) = text {
                    name(&format!("{key}.{field}"), text)?;
                }
            }
            for (param, v) in &e.params {
                let key = format!("{key}.params.{param}");
                if param.ends_with("tau_min") {
                    tau(&key, *v)?;
                } else {
                    figure(&key, *v)?;
                }
            }
        }
        figure("offset_um", self.offset_um)
    }
}

impl DriftModel {
    /// [`DriftModel::validate`], and what an NC program needs besides: every time constant it divides by
    /// at least [`TAU_SHORTEST_MIN`] (written with six decimals, a shorter one would be `EXP(-dt/0)`).
    pub fn validate_for_nc(&self) -> Result<(), String> {
        self.validate()?;
        for (i, input) in self.inputs.iter().enumerate() {
            tau(&format!("inputs[{i}].tau_min"), input.tau_min).map_err(|e| {
                format!("{e}; a model written by an earlier `driftloop sensors -o` is written again by the current one")
            })?;
        }
        Ok(())
    }
}

/// A column name the NC program writes into its log header and comments: letters, digits, `_ . -`.
fn name(key: &str, text: &str) -> Result<(), String> {
    let plain = |c: char| c.is_ascii_alphanumeric() || matches!(c, '_' | '.' | '-');
    if text.is_empty() || !text.chars().all(plain) {
        return Err(format!(
            "{key} `{}` must be a column name of letters, digits, `_`, `.` or `-`",
            text.escape_default()
        ));
    }
    Ok(())
}

fn tau(key: &str, v: f64) -> Result<(), String> {
    if !(TAU_SHORTEST_MIN..=TAU_LONGEST_MIN).contains(&v) {
        return Err(format!(
            "{key} {v:?} must be a time constant from {TAU_SHORTEST_MIN} to {TAU_LONGEST_MIN} min"
        ));
    }
    Ok(())
}

/// A finite figure within ±[`LARGEST_UM`] (µm, µm per unit, µm per hour, …).
fn figure(key: &str, v: f64) -> Result<(), String> {
    if !(v.is_finite() && v.abs() <= LARGEST_UM) {
        return Err(format!(
            "{key} {v:?} must be a finite number within ±{LARGEST_UM}"
        ));
    }
    Ok(())
}
