//! Bidirectional positioning statistics per target and per axis, after DSTU/GOST 27843-88, VDI 3441 and
//! ISO 230-2.
//!
//! All three start from the same per-direction means x̄ and standard deviations s (n − 1) at every target; they
//! differ in the coverage factor k (3 for DSTU/GOST and VDI 3441, 2 for ISO 230-2) and in which combinations
//! they name and summarise for the axis.

use super::input::{AxisSamples, TargetSamples};

/// The standard whose definitions are reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum Standard {
    #[value(name = "dstu27843")]
    #[serde(rename = "dstu27843")]
    Dstu27843,
    #[value(name = "vdi3441")]
    #[serde(rename = "vdi3441")]
    Vdi3441,
    #[value(name = "iso230-2")]
    #[serde(rename = "iso230-2")]
    Iso230_2,
}

impl Standard {
    /// Coverage factor of the limits x̄ ± k·s.
    pub fn k(self) -> f64 {
        match self {
            Standard::Dstu27843 | Standard::Vdi3441 => 3.0,
            Standard::Iso230_2 => 2.0,
        }
    }

    pub fn title(self) -> &'static str {
        match self {
            Standard::Dstu27843 => "DSTU/GOST 27843-88",
            Standard::Vdi3441 => "VDI 3441",
            Standard::Iso230_2 => "ISO 230-2",
        }
    }
}

/// Statistics of the repeated approaches to one target from one direction (µm).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct DirectionStats {
    pub n: usize,
    pub mean_um: f64,
    /// Sample standard deviation (n − 1).
    pub s_um: f64,
    /// x̄ − k·s
    pub lower_um: f64,
    /// x̄ + k·s
    pub upper_um: f64,
}

impl DirectionStats {
    fn new(values: &[f64], k: f64) -> Self {
        let n = values.len();
        let mean = values.iter().sum::<f64>() / n as f64;
        let s = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n as f64 - 1.0)).sqrt();
        DirectionStats {
            n,
            mean_um: mean,
            s_um: s,
            lower_um: mean - k * s,
            upper_um: mean + k * s,
        }
    }
}

/// Everything computed at one target (µm).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TargetStats {
    pub target_mm: f64,
    pub plus: DirectionStats,
    pub minus: DirectionStats,
    /// b = B_i = x̄↑ − x̄↓ (signed reversal).
    pub reversal_um: f64,
    /// (x̄↑ + x̄↓) / 2, the mean bidirectional deviation.
    pub bidirectional_mean_um: f64,
    /// k·s↑ + k·s↓ + |b|: DSTU's w, VDI's Ps_j + U_j, and the first term of ISO's R_i.
    pub spread_um: f64,
    /// 2k·s↑ = ISO's R↑_i (4 s↑).
    pub repeatability_plus_um: f64,
    /// 2k·s↓ = ISO's R↓_i.
    pub repeatability_minus_um: f64,
    /// max(spread, R↑_i, R↓_i) = ISO's R_i.
    pub repeatability_um: f64,
}

impl TargetStats {
    pub fn new(samples: &TargetSamples, k: f64) -> Self {
        let plus = DirectionStats::new(&samples.plus_um, k);
        let minus = DirectionStats::new(&samples.minus_um, k);
        let reversal = plus.mean_um - minus.mean_um;
        let spread = k * plus.s_um + k * minus.s_um + reversal.abs();
        let r_plus = 2.0 * k * plus.s_um;
        let r_minus = 2.0 * k * minus.s_um;
        TargetStats {
            target_mm: samples.target_mm,
            plus,
            minus,
            reversal_um: reversal,
            bidirectional_mean_um: (plus.mean_um + minus.mean_um) / 2.0,
            spread_um: spread,
            repeatability_plus_um: r_plus,
            repeatability_minus_um: r_minus,
            repeatability_um: spread.max(r_plus).max(r_minus),
        }
    }
}

/// One named axis value of the chosen standard.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SummaryValue {
    /// Identifier used as the JSON key, ASCII.
    pub key: &'static str,
    /// The standard's symbol.
    pub symbol: &'static str,
    pub name: &'static str,
    pub value_um: f64,
}

/// Per-target statistics and the axis summary of one axis.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisStats {
    pub axis: String,
    pub standard: Standard,
    pub targets: Vec<TargetStats>,
    pub summary: Vec<SummaryValue>,
}

impl AxisStats {
    pub fn new(samples: &AxisSamples, standard: Standard) -> Self {
        let k = standard.k();
        let targets: Vec<TargetStats> = samples
            .targets
            .iter()
            .map(|t| TargetStats::new(t, k))
            .collect();
        let summary = summarise(&targets, standard);
        AxisStats {
            axis: samples.axis.clone(),
            standard,
            targets,
            summary,
        }
    }

    pub fn summary_value(&self, key: &str) -> Option<f64> {
        self.summary
            .iter()
            .find(|v| v.key == key)
            .map(|v| v.value_um)
    }
}

fn range(values: impl Iterator<Item = f64> + Clone) -> f64 {
    max(values.clone()) - min(values)
}

fn max(values: impl Iterator<Item = f64>) -> f64 {
    values.fold(f64::NEG_INFINITY, f64::max)
}

fn min(values: impl Iterator<Item = f64>) -> f64 {
    values.fold(f64::INFINITY, f64::min)
}

/// Range over both directions of the limits x̄ ± k·s: the accuracy A of ISO 230-2 and of DSTU/GOST.
pub fn accuracy(targets: &[TargetStats]) -> f64 {
    let upper = targets
        .iter()
        .flat_map(|t| [t.plus.upper_um, t.minus.upper_um]);
    let lower = targets
        .iter()
        .flat_map(|t| [t.plus.lower_um, t.minus.lower_um]);
    max(upper) - min(lower)
}

/// Range of all directional means: ISO 230-2's bidirectional systematic positioning error E.
pub fn systematic_error(targets: &[TargetStats]) -> f64 {
    range(
        targets
            .iter()
            .flat_map(|t| [t.plus.mean_um, t.minus.mean_um]),
    )
}

fn summarise(t: &[TargetStats], standard: Standard) -> Vec<SummaryValue> {
    let value = |key, symbol, name, value_um| SummaryValue {
        key,
        symbol,
        name,
        value_um,
    };
    let count = t.len() as f64;
    let max_abs_reversal = max(t.iter().map(|t| t.reversal_um.abs()));
    let mean_reversal = t.iter().map(|t| t.reversal_um).sum::<f64>() / count;
    match standard {
        Standard::Dstu27843 => vec![
            value(
                "b_max",
                "b max",
                "largest reversal |x̄↑ − x̄↓| (dead band)",
                max_abs_reversal,
            ),
            value("b_mean", "b̄", "mean reversal", mean_reversal),
            value(
                "w_max",
                "w max",
                "bidirectional repeatability, largest 3s↑ + 3s↓ + |b|",
                max(t.iter().map(|t| t.spread_um)),
            ),
            value(
                "E",
                "E",
                "systematic error, range of the means x̄↑, x̄↓",
                systematic_error(t),
            ),
            value(
                "A",
                "A",
                "positioning accuracy, range of x̄ ± 3s over both directions",
                accuracy(t),
            ),
        ],
        Standard::Vdi3441 => vec![
            value(
                "U_mean",
                "Ū",
                "mean reversal span, mean of U_j = |x̄↑ − x̄↓|",
                t.iter().map(|t| t.reversal_um.abs()).sum::<f64>() / count,
            ),
            value("U_max", "U max", "largest reversal span", max_abs_reversal),
            value(
                "Ps",
                "Ps",
                "position scatter, largest Ps_j = 3s↑ + 3s↓",
                max(t.iter().map(|t| 3.0 * (t.plus.s_um + t.minus.s_um))),
            ),
            value(
                "Pa",
                "Pa",
                "position deviation, range of the mean positions x̄_j = (x̄↑ + x̄↓)/2",
                range(t.iter().map(|t| t.bidirectional_mean_um)),
            ),
            value(
                "P",
                "P",
                "position uncertainty, range of x̄_j ± (Ps_j + U_j)/2",
                max(t
                    .iter()
                    .map(|t| t.bidirectional_mean_um + t.spread_um / 2.0))
                    - min(t
                        .iter()
                        .map(|t| t.bidirectional_mean_um - t.spread_um / 2.0)),
            ),
        ],
        Standard::Iso230_2 => vec![
            value(
                "B",
                "B",
                "reversal value of the axis, max |B_i|",
                max_abs_reversal,
            ),
            value(
                "B_mean",
                "B̄",
                "mean reversal value, mean of B_i",
                mean_reversal,
            ),
            value(
                "R_up",
                "R↑",
                "unidirectional repeatability, max 4s↑",
                max(t.iter().map(|t| t.repeatability_plus_um)),
            ),
            value(
                "R_down",
                "R↓",
                "unidirectional repeatability, max 4s↓",
                max(t.iter().map(|t| t.repeatability_minus_um)),
            ),
            value(
                "R",
                "R",
                "bidirectional repeatability, max R_i",
                max(t.iter().map(|t| t.repeatability_um)),
            ),
            value(
                "E_up",
                "E↑",
                "unidirectional systematic positioning error",
                range(t.iter().map(|t| t.plus.mean_um)),
            ),
            value(
                "E_down",
                "E↓",
                "unidirectional systematic positioning error",
                range(t.iter().map(|t| t.minus.mean_um)),
            ),
            value(
                "E",
                "E",
                "bidirectional systematic positioning error",
                systematic_error(t),
            ),
            value(
                "M",
                "M",
                "range of the mean bidirectional positional deviation",
                range(t.iter().map(|t| t.bidirectional_mean_um)),
            ),
            value(
                "A_up",
                "A↑",
                "unidirectional accuracy, range of x̄↑ ± 2s↑",
                max(t.iter().map(|t| t.plus.upper_um)) - min(t.iter().map(|t| t.plus.lower_um)),
            ),
            value(
                "A_down",
                "A↓",
                "unidirectional accuracy, range of x̄↓ ± 2s↓",
                max(t.iter().map(|t| t.minus.upper_um)) - min(t.iter().map(|t| t.minus.lower_um)),
            ),
            value(
                "A",
                "A",
                "bidirectional accuracy, range of x̄ ± 2s over both directions",
                accuracy(t),
            ),
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::fmt_num;

    fn worked_row() -> TargetSamples {
        TargetSamples {
            target_mm: 50.0,
            plus_um: vec![4.0, 11.0, 11.0, 12.0, 7.0],
            minus_um: vec![-9.0, -10.0, -11.0, -7.0, -7.0],
        }
    }

    /// design.md §1, second paper: X = 50 mm, printed with the paper's rounding.
    #[test]
    fn worked_row_matches_the_paper() {
        let t = TargetStats::new(&worked_row(), Standard::Dstu27843.k());
        assert_eq!(fmt_num(t.plus.mean_um, 0), "9");
        assert_eq!(fmt_num(t.plus.s_um, 2), "3.39");
        assert_eq!(fmt_num(t.plus.upper_um, 2), "19.17");
        assert_eq!(fmt_num(t.plus.lower_um, 2), "-1.17");
        assert_eq!(fmt_num(t.minus.mean_um, 1), "-8.8");
        assert_eq!(fmt_num(t.minus.s_um, 2), "1.79");
        assert_eq!(fmt_num(t.reversal_um, 1), "17.8");
        assert_eq!(fmt_num(t.spread_um, 1), "33.3");
        assert_eq!(t.plus.n, 5);
    }

    #[test]
    fn iso_uses_two_sigma_and_four_sigma() {
        let t = TargetStats::new(&worked_row(), Standard::Iso230_2.k());
        assert!((t.plus.upper_um - (9.0 + 2.0 * 11.5f64.sqrt())).abs() < 1e-12);
        assert!((t.repeatability_plus_um - 4.0 * 11.5f64.sqrt()).abs() < 1e-12);
        assert!((t.repeatability_minus_um - 4.0 * 3.2f64.sqrt()).abs() < 1e-12);
        // 2s↑ + 2s↓ + |B| = 6.78 + 3.58 + 17.8 dominates 4s↑ = 13.56.
        let expected = 2.0 * 11.5f64.sqrt() + 2.0 * 3.2f64.sqrt() + 17.8;
        assert!((t.repeatability_um - expected).abs() < 1e-12);
        let dstu = TargetStats::new(&worked_row(), Standard::Dstu27843.k());
        assert!((dstu.spread_um - t.spread_um - 11.5f64.sqrt() - 3.2f64.sqrt()).abs() < 1e-12);
        assert_eq!(Standard::Vdi3441.k(), 3.0);
    }

    #[test]
    fn iso_repeatability_falls_back_to_unidirectional_when_reversal_is_small() {
        let samples = TargetSamples {
            target_mm: 0.0,
            plus_um: vec![0.0, 10.0, 0.0, 10.0, 0.0, 10.0],
            minus_um: vec![5.0; 6],
        };
        let t = TargetStats::new(&samples, 2.0);
        assert_eq!(t.minus.s_um, 0.0);
        assert!((t.repeatability_um - t.repeatability_plus_um).abs() < 1e-12);
        assert!(t.repeatability_plus_um > t.spread_um);
    }

    fn axis() -> AxisSamples {
        let shifted = |offset: f64, r: &TargetSamples, target| TargetSamples {
            target_mm: target,
            plus_um: r.plus_um.iter().map(|v| v + offset).collect(),
            minus_um: r.minus_um.iter().map(|v| v - offset).collect(),
        };
        let row = worked_row();
        AxisSamples {
            axis: "X".into(),
            targets: vec![
                shifted(0.0, &row, 0.0),
                shifted(2.0, &row, 50.0),
                shifted(-1.0, &row, 100.0),
            ],
        }
    }

    #[test]
    fn iso_axis_summary_follows_the_definitions() {
        let stats = AxisStats::new(&axis(), Standard::Iso230_2);
        // x̄↑ = 9, 11, 8; x̄↓ = −8.8, −10.8, −7.8; B_i = 17.8, 21.8, 15.8.
        let v = |key| stats.summary_value(key).unwrap();
        assert!((v("B") - 21.8).abs() < 1e-9);
        assert!((v("B_mean") - (17.8 + 21.8 + 15.8) / 3.0).abs() < 1e-9);
        assert!((v("E_up") - 3.0).abs() < 1e-9);
        assert!((v("E_down") - 3.0).abs() < 1e-9);
        assert!((v("E") - 21.8).abs() < 1e-9);
        assert!(
            (v("M") - 0.0).abs() < 1e-9,
            "the shifts cancel in the bidirectional mean"
        );
        let s_up = 11.5f64.sqrt();
        let s_down = 3.2f64.sqrt();
        assert!((v("A_up") - (11.0 + 2.0 * s_up - (8.0 - 2.0 * s_up))).abs() < 1e-9);
        assert!((v("A") - (11.0 + 2.0 * s_up - (-10.8 - 2.0 * s_down))).abs() < 1e-9);
        assert!((v("R_up") - 4.0 * s_up).abs() < 1e-9);
        assert!((v("R") - (2.0 * s_up + 2.0 * s_down + 21.8)).abs() < 1e-9);
    }

    #[test]
    fn dstu_and_vdi_summaries() {
        let dstu = AxisStats::new(&axis(), Standard::Dstu27843);
        let s = 11.5f64.sqrt() + 3.2f64.sqrt();
        assert!((dstu.summary_value("w_max").unwrap() - (3.0 * s + 21.8)).abs() < 1e-9);
        assert!(
            (dstu.summary_value("A").unwrap()
                - (11.0 + 3.0 * 11.5f64.sqrt() + 10.8 + 3.0 * 3.2f64.sqrt()))
            .abs()
                < 1e-9
        );
        let vdi = AxisStats::new(&axis(), Standard::Vdi3441);
        assert!((vdi.summary_value("Ps").unwrap() - 3.0 * s).abs() < 1e-9);
        assert!((vdi.summary_value("U_mean").unwrap() - (17.8 + 21.8 + 15.8) / 3.0).abs() < 1e-9);
        // Mean positions x̄_j are 0.1 everywhere, so P is set by the largest Ps_j + U_j.
        assert!((vdi.summary_value("Pa").unwrap()).abs() < 1e-9);
        assert!((vdi.summary_value("P").unwrap() - (3.0 * s + 21.8)).abs() < 1e-9);
    }
}
