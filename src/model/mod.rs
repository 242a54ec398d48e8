//! The thermal drift model (design.md §1): per displacement channel, K first-order modes with time
//! constants τₖ shared across speeds; mode k relaxes towards a target gₖ(u) set by the inputs.
//!
//! - Spindle modes: gₖ = the mode's steady-state gain at the current speed, interpolated on the
//!   characterised speed grid ([`speed_grid`] documents the interpolation and extrapolation rules).
//! - Declared extra inputs (`--inputs spindle_rpm,ambient_c`): each a lagged linear term with its own τ,
//!   target = gain·(u − u at the run's start), so every run starts from equilibrium at zero.
//! - A constant offset (the reading at rest).
//!
//! Prediction is the exact update for piecewise-constant inputs ([`lag`]); for a constant speed from cold it
//! is Σ aₖ(1 − e^(−t/τₖ)). Fitting lives in [`mod@fit`], the model file in [`mod@file`], synthetic data in [`synth`].
//!
//! ```
//! use driftloop::data::{Require, read_path};
//! use driftloop::model::{DriftModel, FitOptions, ModesChoice, Schedule, fit};
//!
//! # fn main() -> anyhow::Result<()> {
//! let ds = read_path("fixtures/data/characterisation.csv".as_ref(), Require::Displacement)?;
//! let mut opts = FitOptions::new("drift_z_um"); // spindle_rpm only, order by BIC
//! opts.modes = ModesChoice::Fixed(2);
//! let model: DriftModel = fit(&ds, &opts)?;
//! let on_data: Vec<f64> = model.predict(&ds)?; // one value per row, µm
//! assert_eq!(on_data.len(), ds.len());
//! let schedule: Schedule = "3000:60,0:30,5000:120".parse().map_err(anyhow::Error::msg)?;
//! let on_plan = model.predict(&schedule.to_dataset(1.0))?;
//! assert_eq!(on_plan.len(), 211);
//! let text = model.to_toml();
//! assert_eq!(DriftModel::from_toml(&text, "model.toml")?, model);
//! # Ok(())
//! # }
//! ```

pub mod dlag;
pub mod effects;
pub mod file;
pub mod fit;
pub mod forward;
pub mod lag;
pub mod modes_law;
mod predict;
pub mod probing;
pub mod ridge;
pub mod schedule;
pub mod speed_grid;
pub mod speed_law;
pub mod synth;
pub(crate) mod varpro;

use serde::{Deserialize, Serialize};

use crate::data::TimeUnit;

pub use fit::{FitError, FitOptions, ModesChoice, fit};
pub use predict::PredictError;
pub use schedule::Schedule;
pub use speed_grid::SpeedGrid;
pub use speed_law::extrapolation_warning;

/// The model file schema this version reads and writes.
pub const SCHEMA: u32 = 1;

/// A fitted drift model of one displacement channel; serialised as the model file (see [`mod@file`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DriftModel {
    pub schema: u32,
    /// The displacement channel the model predicts (e.g. `ch3_um`).
    pub channel: String,
    /// Reading at rest (µm).
    pub offset_um: f64,
    pub spindle: SpindleModes,
    /// Declared inputs other than spindle speed, each a lagged linear term.
    #[serde(default)]
    pub inputs: Vec<InputLag>,
    /// Effects added by `diagnose` ([`effects`]; none are produced by `fit`); a model carrying an effect
    /// kind this version does not know is refused by `predict` rather than predicted without it.
    #[serde(default)]
    pub effects: Vec<EffectSpec>,
    /// Present in fitted models; absent in hand-made (e.g. synthetic truth) models.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit: Option<FitSummary>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub data: Option<DataProvenance>,
}

/// The spindle-driven modes on their speed grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpindleModes {
    /// Characterised speeds (rpm), ascending; 0 rpm is the implicit node with gain 0 (cooling).
    pub grid_rpm: Vec<f64>,
    pub interpolation: Interpolation,
    pub extrapolation: Extrapolation,
    /// Modes sorted by time constant, fastest first.
    #[serde(default)]
    pub modes: Vec<Mode>,
    /// With `extrapolation = "power-law"`: the top speed the data held; grid nodes above it carry the law.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub characterised_top_rpm: Option<f64>,
}

/// How gains between grid speeds are found (the only scheme; named in the file so a reader knows).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Interpolation {
    PiecewiseLinear,
}

/// How gains above the top characterised speed are found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Extrapolation {
    /// The grid holds the characterised speeds only; above the top one its last segment is continued.
    LinearLastSegment,
    /// The grid's nodes above `characterised_top_rpm` carry the power law (see [`speed_law`]); above the
    /// last node its last segment is continued.
    PowerLaw,
}

/// One first-order mode: time constant and steady-state gain at each grid speed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Mode {
    pub tau_min: f64,
    /// Standard error of τ from the Jacobian (assumes independent residuals; optimistic for dense,
    /// autocorrelated logs). Absent when the fit could not determine it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tau_se_min: Option<f64>,
    /// Steady-state drift of this mode at each `grid_rpm` speed.
    pub gain_um: Vec<f64>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gain_se_um: Vec<f64>,
    /// With `extrapolation = "power-law"`: p in gain ∝ (n / characterised_top_rpm)^p, the law the gains
    /// follow on the whole grid.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub power_law_exponent: Option<f64>,
}

/// A declared input entering through its own first-order lag: target = gain·(u − u₀), u₀ its value at the
/// run's first row.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputLag {
    /// Column name (lower case), e.g. `ambient_c`.
    pub signal: String,
    pub tau_min: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tau_se_min: Option<f64>,
    /// µm per unit of the signal (per °C for a `_c` column).
    pub gain_um_per_unit: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gain_se_um_per_unit: Option<f64>,
}

/// An effect added by diagnosis or written by `sensors`: its kind, the signal and the axis position column
/// it reads (if any) and named parameters. A field this version does not know fails the file: a newer
/// driftloop's term must not be predicted without it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffectSpec {
    pub kind: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub signal: Option<String>,
    /// Axis position column (`*_mm`) of the kinds that read one besides their signal.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<String>,
    #[serde(default)]
    pub params: std::collections::BTreeMap<String, f64>,
}

/// How well the model fitted the data it came from, and how its order was chosen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitSummary {
    pub samples: usize,
    /// Only rows before this time (data's time unit) were used, if set (`fit --until`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub until: Option<f64>,
    /// Bounds the time constants were searched in: [smallest sampling step, 3 × longest run].
    pub tau_bounds_min: [f64; 2],
    pub rms_um: f64,
    pub max_abs_um: f64,
    pub r2: f64,
    /// Residual standard deviation with the fitted parameters' degrees of freedom removed.
    pub sigma_um: f64,
    pub bic: f64,
    pub aicc: f64,
    /// `auto` (BIC) or `fixed`.
    pub selection: String,
    pub per_run: Vec<RunStats>,
    /// Every model order tried, with why it was or was not chosen.
    pub orders: Vec<OrderTrial>,
    /// How a forward-validated fit (`fit --kind dlag`) chose its design.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forward: Option<dlag::ForwardSelection>,
    /// How a spindle-mode fit chose its law above the top characterised speed (absent: no fold predicted
    /// a faster speed than it was fitted on, and the last segment is continued).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_law: Option<modes_law::LawChoice>,
}

/// Fit statistics of one run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunStats {
    pub run: String,
    pub samples: usize,
    pub rms_um: f64,
    pub max_abs_um: f64,
}

/// One model order tried during the fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrderTrial {
    pub modes: usize,
    pub rms_um: f64,
    pub bic: f64,
    pub aicc: f64,
    pub tau_min: Vec<f64>,
    pub chosen: bool,
    /// Why the order was rejected or chosen, in words.
    pub note: String,
}

/// The data the model was fitted on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DataProvenance {
    pub file: String,
    /// SHA-256 of the data file's bytes (hex); empty for generated data.
    pub sha256: String,
    /// Rows in the file (the fit may have used fewer, see `fit.samples`).
    pub rows: usize,
    /// Time unit of the data; predictions for data in this unit are written in it.
    pub time_unit: TimeUnit,
}

impl DriftModel {
    /// A hand-made model of spindle modes `(τ in min, gain at each grid speed in µm)`, no fit statistics.
    pub fn from_modes(
        channel: &str,
        grid_rpm: Vec<f64>,
        modes: &[(f64, Vec<f64>)],
        offset_um: f64,
    ) -> DriftModel {
        DriftModel {
            schema: SCHEMA,
            channel: channel.to_ascii_lowercase(),
            offset_um,
            spindle: SpindleModes {
                grid_rpm,
                interpolation: Interpolation::PiecewiseLinear,
                extrapolation: Extrapolation::LinearLastSegment,
                characterised_top_rpm: None,
                modes: modes
                    .iter()
                    .map(|(tau, gains)| Mode {
                        tau_min: *tau,
                        tau_se_min: None,
                        gain_um: gains.clone(),
                        gain_se_um: Vec::new(),
                        power_law_exponent: None,
                    })
                    .collect(),
            },
            inputs: Vec::new(),
            effects: Vec::new(),
            fit: None,
            data: None,
        }
    }

    /// The speed grid of the spindle modes.
    pub fn speed_grid(&self) -> Option<SpeedGrid> {
        SpeedGrid::new(self.spindle.grid_rpm.clone())
    }

    /// Names of the declared inputs: `spindle_rpm` (when the model has spindle modes), the lagged ones and
    /// the columns of the regression terms `sensors` writes (`static_input`, `input_slope`, `geometric`).
    pub fn declared_inputs(&self) -> Vec<String> {
        let spindle = (!self.spindle.modes.is_empty()).then(|| crate::data::SPINDLE.to_string());
        let regression = self
            .effects
            .iter()
            .filter(|e| {
                effects::Kind::parse(&e.kind).is_some_and(|k| effects::Kind::SENSOR.contains(&k))
            })
            .flat_map(|e| e.signal.iter().chain(&e.position).cloned());
        let mut out: Vec<String> = spindle
            .into_iter()
            .chain(self.inputs.iter().map(|i| i.signal.clone()))
            .collect();
        for name in regression {
            if !out.contains(&name) {
                out.push(name);
            }
        }
        out
    }

    /// The signals the model reads besides the spindle speed: its lagged inputs and its effects' signals
    /// (a diagnosed `input_lag`, a sensor regression's terms), each once, in model order. Position columns are
    /// not signals: see the effects' `position`.
    pub fn signals(&self) -> Vec<&str> {
        let mut out: Vec<&str> = Vec::new();
        let names = self
            .inputs
            .iter()
            .map(|i| i.signal.as_str())
            .chain(self.effects.iter().filter_map(|e| e.signal.as_deref()));
        for name in names.filter(|&n| n != crate::data::SPINDLE) {
            if !out.contains(&name) {
                out.push(name);
            }
        }
        out
    }

    /// Steady-state drift at a constant speed, all spindle modes together (µm, without offset).
    pub fn steady_state_um(&self, rpm: f64) -> f64 {
        let Some(grid) = self.speed_grid() else {
            return 0.0;
        };
        let w = grid.weights(rpm);
        self.spindle.modes.iter().map(|m| w.apply(&m.gain_um)).sum()
    }
}
