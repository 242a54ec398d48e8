//! Positioning accuracy of machine axes and the corrections that follow from it (the second source paper):
//! bidirectional statistics per target after DSTU/GOST 27843-88, VDI 3441 or ISO 230-2, correction tables at
//! the measured points and on the control's compensation grid (natural cubic spline through the means), and
//! the outputs: human text, JSON, CSV, Sinumerik compensation-table text and an HTML report.

mod correction;
mod input;
mod report;
mod spline;
mod stats;
mod tables;
mod text;

pub use correction::{CorrectionTable, Effect, Grid, GridCorrection, MeasuredCorrection};
pub use input::{AxisSamples, Direction, InputError, TargetSamples, read_samples};
pub use report::html_report;
pub use spline::NaturalSpline;
pub use stats::{AxisStats, DirectionStats, Standard, SummaryValue, TargetStats};
pub use tables::{correction_csv, sinumerik_text};
pub use text::{human, json};

/// ISO 230-2 asks for five approaches per direction at every target; so do the DSTU and VDI procedures.
pub const MIN_APPROACHES: usize = 5;

/// Statistics and corrections of one axis.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisResult {
    pub stats: AxisStats,
    pub correction: CorrectionTable,
}

/// The whole evaluation of one measurement file.
#[derive(Debug, Clone, PartialEq)]
pub struct Analysis {
    /// The input's name as the user gave it, for headers.
    pub source: String,
    pub standard: Standard,
    pub axes: Vec<AxisResult>,
}

/// A grid for one named axis, or for every axis without its own (`axis: None`).
#[derive(Debug, Clone, PartialEq)]
pub struct GridChoice {
    pub axis: Option<String>,
    pub grid: Grid,
}

/// Evaluates every axis; an axis without a grid choice gets [`Grid::covering`] its targets.
pub fn analyse(
    source: &str,
    samples: &[AxisSamples],
    standard: Standard,
    grids: &[GridChoice],
) -> Analysis {
    let axes = samples
        .iter()
        .map(|axis| {
            let stats = AxisStats::new(axis, standard);
            let grid = grids
                .iter()
                .find(|g| g.axis.as_deref() == Some(axis.axis.as_str()))
                .or_else(|| grids.iter().find(|g| g.axis.is_none()))
                .map(|g| g.grid)
                .unwrap_or_else(|| {
                    Grid::covering(&axis.targets.iter().map(|t| t.target_mm).collect::<Vec<_>>())
                });
            let correction = CorrectionTable::new(&stats, grid);
            AxisResult { stats, correction }
        })
        .collect();
    Analysis {
        source: source.to_string(),
        standard,
        axes,
    }
}
