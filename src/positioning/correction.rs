//! Correction tables: per-direction corrections at the measured targets, a natural cubic spline through the
//! means evaluated on the control's equidistant compensation grid, and the residual predicted at the targets
//! when the control interpolates that grid linearly.

use std::fmt;
use std::str::FromStr;

use super::spline::NaturalSpline;
use super::stats::{AxisStats, TargetStats, accuracy, systematic_error};

/// The control's compensation grid: START, START + STEP, …, END (mm).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Grid {
    pub start_mm: f64,
    pub step_mm: f64,
    pub end_mm: f64,
}

/// Largest grid a table may have; Sinumerik tables are limited far below this by machine data.
const MAX_GRID_POINTS: usize = 100_000;

impl Grid {
    pub fn positions(&self) -> Vec<f64> {
        (0..self.point_count())
            .map(|i| self.start_mm + i as f64 * self.step_mm)
            .collect()
    }

    pub fn point_count(&self) -> usize {
        ((self.end_mm - self.start_mm) / self.step_mm).round() as usize + 1
    }

    /// The default when the user gives none: from the first to past the last target with the largest
    /// 1-2-5 step that is not coarser than the closest pair of targets, but with at most
    /// `DEFAULT_MAX_INTERVALS` intervals.
    pub fn covering(targets_mm: &[f64]) -> Grid {
        let first = targets_mm[0];
        let last = targets_mm[targets_mm.len() - 1];
        let closest = targets_mm
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min);
        let step =
            nice_at_most(closest).max(nice_at_least((last - first) / DEFAULT_MAX_INTERVALS as f64));
        let count = ((last - first) / step - 1e-9).ceil().max(1.0);
        Grid {
            start_mm: first,
            step_mm: step,
            end_mm: first + count * step,
        }
    }
}

/// Keeps a default table small when two targets are very close; a finer table is one `--grid` away.
pub const DEFAULT_MAX_INTERVALS: usize = 1000;

const NICE: [f64; 3] = [1.0, 2.0, 5.0];

/// The largest 1-2-5 number not above `value` (> 0).
fn nice_at_most(value: f64) -> f64 {
    let magnitude = 10f64.powf(value.log10().floor());
    NICE.iter()
        .rev()
        .map(|f| f * magnitude)
        .find(|&s| s <= value * (1.0 + 1e-9))
        .unwrap_or(magnitude)
}

/// The smallest 1-2-5 number not below `value` (> 0).
fn nice_at_least(value: f64) -> f64 {
    let magnitude = 10f64.powf(value.log10().floor());
    NICE.iter()
        .map(|f| f * magnitude)
        .find(|&s| s >= value * (1.0 - 1e-9))
        .unwrap_or(10.0 * magnitude)
}

impl FromStr for Grid {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let parts: Vec<&str> = text.split(':').collect();
        let [start, step, end] = parts.as_slice() else {
            return Err(format!("expected START:STEP:END in mm, found `{text}`"));
        };
        let number = |part: &str, what: &str| -> Result<f64, String> {
            part.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("{what} `{part}` is not a number"))
        };
        let grid = Grid {
            start_mm: number(start, "START")?,
            step_mm: number(step, "STEP")?,
            end_mm: number(end, "END")?,
        };
        if grid.step_mm <= 0.0 {
            return Err(format!("STEP must be positive, found {}", grid.step_mm));
        }
        if grid.end_mm <= grid.start_mm {
            return Err(format!(
                "END ({}) must be greater than START ({})",
                grid.end_mm, grid.start_mm
            ));
        }
        let intervals = (grid.end_mm - grid.start_mm) / grid.step_mm;
        if (intervals - intervals.round()).abs() > 1e-6 * intervals.max(1.0) {
            return Err(format!(
                "END − START = {} is not a whole number of STEP = {}",
                grid.end_mm - grid.start_mm,
                grid.step_mm
            ));
        }
        if grid.point_count() > MAX_GRID_POINTS {
            return Err(format!(
                "{} grid points is more than the {MAX_GRID_POINTS} allowed",
                grid.point_count()
            ));
        }
        Ok(grid)
    }
}

impl fmt::Display for Grid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.start_mm, self.step_mm, self.end_mm)
    }
}

/// Corrections (the negated means) and residuals after the grid correction at one measured target (µm).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MeasuredCorrection {
    pub target_mm: f64,
    pub correction_plus_um: f64,
    pub correction_minus_um: f64,
    /// x̄↑ plus the correction the control applies here (grid values interpolated linearly).
    pub residual_plus_um: f64,
    pub residual_minus_um: f64,
}

/// Corrections on the compensation grid (µm), from the spline through the means of each direction.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct GridCorrection {
    pub position_mm: f64,
    pub correction_plus_um: f64,
    pub correction_minus_um: f64,
}

/// Systematic error and accuracy (µm) computed from the statistics, before and after correction.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Effect {
    pub systematic_error_um: f64,
    pub accuracy_um: f64,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CorrectionTable {
    pub grid: Grid,
    pub measured: Vec<MeasuredCorrection>,
    pub grid_values: Vec<GridCorrection>,
    pub before: Effect,
    /// Predicted: the means shifted by the correction, the scatter (s) unchanged.
    pub after: Effect,
}

impl CorrectionTable {
    pub fn new(stats: &AxisStats, grid: Grid) -> Self {
        let targets: Vec<f64> = stats.targets.iter().map(|t| t.target_mm).collect();
        let spline_of = |mean: fn(&TargetStats) -> f64| {
            let means: Vec<f64> = stats.targets.iter().map(mean).collect();
            NaturalSpline::new(&targets, &means)
        };
        let plus = spline_of(|t| t.plus.mean_um);
        let minus = spline_of(|t| t.minus.mean_um);
        let grid_values: Vec<GridCorrection> = grid
            .positions()
            .into_iter()
            .map(|p| GridCorrection {
                position_mm: p,
                correction_plus_um: -plus.eval(p),
                correction_minus_um: -minus.eval(p),
            })
            .collect();
        let measured: Vec<MeasuredCorrection> = stats
            .targets
            .iter()
            .map(|t| MeasuredCorrection {
                target_mm: t.target_mm,
                correction_plus_um: -t.plus.mean_um,
                correction_minus_um: -t.minus.mean_um,
                residual_plus_um: t.plus.mean_um
                    + applied(&grid_values, t.target_mm, |g| g.correction_plus_um),
                residual_minus_um: t.minus.mean_um
                    + applied(&grid_values, t.target_mm, |g| g.correction_minus_um),
            })
            .collect();
        let k = stats.standard.k();
        let corrected: Vec<TargetStats> = stats
            .targets
            .iter()
            .zip(&measured)
            .map(|(t, m)| {
                let mut c = t.clone();
                for (side, residual) in [
                    (&mut c.plus, m.residual_plus_um),
                    (&mut c.minus, m.residual_minus_um),
                ] {
                    side.mean_um = residual;
                    side.lower_um = residual - k * side.s_um;
                    side.upper_um = residual + k * side.s_um;
                }
                c
            })
            .collect();
        let effect = |t: &[TargetStats]| Effect {
            systematic_error_um: systematic_error(t),
            accuracy_um: accuracy(t),
        };
        CorrectionTable {
            grid,
            measured,
            grid_values,
            before: effect(&stats.targets),
            after: effect(&corrected),
        }
    }
}

/// The correction the control applies at `position`: linear between grid points, end values held outside.
fn applied(grid: &[GridCorrection], position: f64, value: fn(&GridCorrection) -> f64) -> f64 {
    let last = grid.len() - 1;
    if position <= grid[0].position_mm {
        return value(&grid[0]);
    }
    if position >= grid[last].position_mm {
        return value(&grid[last]);
    }
    let i = grid
        .partition_point(|g| g.position_mm <= position)
        .saturating_sub(1)
        .min(last - 1);
    let (a, b) = (&grid[i], &grid[i + 1]);
    let f = (position - a.position_mm) / (b.position_mm - a.position_mm);
    value(a) + f * (value(b) - value(a))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::positioning::input::{AxisSamples, TargetSamples};
    use crate::positioning::stats::Standard;

    fn stats(targets: &[(f64, f64, f64)]) -> AxisStats {
        let samples = AxisSamples {
            axis: "X".into(),
            targets: targets
                .iter()
                .map(|&(t, up, down)| TargetSamples {
                    target_mm: t,
                    plus_um: [-1.0, 0.0, 1.0, 0.5, -0.5].iter().map(|d| up + d).collect(),
                    minus_um: [-1.0, 0.0, 1.0, 0.5, -0.5]
                        .iter()
                        .map(|d| down + d)
                        .collect(),
                })
                .collect(),
        };
        AxisStats::new(&samples, Standard::Iso230_2)
    }

    #[test]
    fn grid_parsing_and_validation() {
        let g: Grid = "0:10:100".parse().unwrap();
        assert_eq!(g.point_count(), 11);
        assert_eq!(g.positions()[10], 100.0);
        assert!(
            "0:0:10"
                .parse::<Grid>()
                .unwrap_err()
                .contains("STEP must be positive")
        );
        assert!(
            "10:1:0"
                .parse::<Grid>()
                .unwrap_err()
                .contains("greater than START")
        );
        assert!(
            "0:3:10"
                .parse::<Grid>()
                .unwrap_err()
                .contains("not a whole number")
        );
        assert!("0:a:10".parse::<Grid>().unwrap_err().contains("STEP `a`"));
        assert!("0:10".parse::<Grid>().is_err());
        assert_eq!("-5:2.5:5".parse::<Grid>().unwrap().point_count(), 5);
    }

    #[test]
    fn default_grid_uses_a_nice_step_no_coarser_than_the_targets() {
        let g = Grid::covering(&[0.0, 52.0, 98.0, 151.0]);
        assert_eq!(
            g,
            Grid {
                start_mm: 0.0,
                step_mm: 20.0,
                end_mm: 160.0
            }
        );
        let g = Grid::covering(&[0.0, 0.001, 500.0]);
        assert_eq!(
            g,
            Grid {
                start_mm: 0.0,
                step_mm: 0.5,
                end_mm: 500.0
            },
            "at most 1000 intervals"
        );
        let g = Grid::covering(&[-10.0, 15.0, 40.0]);
        assert_eq!(
            g,
            Grid {
                start_mm: -10.0,
                step_mm: 20.0,
                end_mm: 50.0
            }
        );
    }

    #[test]
    fn corrections_negate_the_means_and_cancel_them_on_a_grid_through_the_targets() {
        let stats = stats(&[
            (0.0, 3.0, -2.0),
            (50.0, 9.0, -8.8),
            (100.0, -4.0, -6.0),
            (150.0, 1.0, 2.0),
        ]);
        let table = CorrectionTable::new(&stats, "0:50:150".parse().unwrap());
        assert_eq!(table.measured[1].correction_plus_um, -9.0);
        assert!((table.measured[1].correction_minus_um - 8.8).abs() < 1e-12);
        for m in &table.measured {
            assert!(m.residual_plus_um.abs() < 1e-12 && m.residual_minus_um.abs() < 1e-12);
        }
        assert!((table.after.systematic_error_um).abs() < 1e-12);
        assert!((table.before.systematic_error_um - 17.8).abs() < 1e-12);
        assert!(table.after.accuracy_um < table.before.accuracy_um);
    }

    #[test]
    fn a_coarse_grid_leaves_a_residual_between_its_points() {
        let stats = stats(&[(0.0, 0.0, 0.0), (25.0, 10.0, 10.0), (50.0, 0.0, 0.0)]);
        let table = CorrectionTable::new(&stats, "0:50:50".parse().unwrap());
        // Grid points are the end targets (correction 0 there), so the peak at 25 mm stays uncorrected.
        assert!((table.measured[1].residual_plus_um - 10.0).abs() < 1e-12);
        let fine = CorrectionTable::new(&stats, "0:5:50".parse().unwrap());
        assert!(fine.measured[1].residual_plus_um.abs() < 1e-12);
        assert_eq!(fine.grid_values.len(), 11);
        // Between nodes the spline bulges above the straight line 0 → 10 (natural spline of a peak).
        assert!(-fine.grid_values[3].correction_plus_um > 6.0);
    }
}
