//! Correction tables as CSV and as Sinumerik compensation-table text.

use std::fmt::Write;

use super::Analysis;
use super::correction::CorrectionTable;
use crate::report::fmt_num;

/// CSV with one row per measured target (`kind` = `measured`, with residuals) and per grid point
/// (`kind` = `grid`); corrections are what to add to the commanded position, µm.
pub fn correction_csv(analysis: &Analysis) -> String {
    let mut out = String::from(
        "axis,kind,position_mm,correction_plus_um,correction_minus_um,residual_plus_um,residual_minus_um\n",
    );
    for axis in &analysis.axes {
        let name = csv_field(&axis.stats.axis);
        for m in &axis.correction.measured {
            let values = [
                m.target_mm,
                m.correction_plus_um,
                m.correction_minus_um,
                m.residual_plus_um,
                m.residual_minus_um,
            ];
            let _ = writeln!(out, "{name},measured,{}", csv_numbers(&values));
        }
        for g in &axis.correction.grid_values {
            let values = [g.position_mm, g.correction_plus_um, g.correction_minus_um];
            let _ = writeln!(out, "{name},grid,{},,", csv_numbers(&values));
        }
    }
    out
}

fn csv_numbers(values: &[f64]) -> String {
    values
        .iter()
        .map(|v| fmt_num(*v, 3))
        .collect::<Vec<_>>()
        .join(",")
}

fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

/// What the operator must know before loading the tables (the facts are from the Sinumerik K3 manual).
const SINUMERIK_NOTES: &str = "\
; $AA_ENC_COMP values are the mean positioning error in mm (natural cubic spline through the
; measured means); LEC moves the axis by minus the table value. One table per approach direction:
; LEC acts in both directions, so load one of them as LEC and put the difference into a
; direction-dependent compensation ($AN_CEC_DIRECTION) or the backlash value.
; Measuring system index 0 (first encoder); axis names as in the measurement file.
; A value of zero at the reference point avoids a jump when the compensation switches on.
";

/// Sinumerik leadscrew-error compensation (LEC) text, one `$AA_ENC_COMP` table per axis and direction.
///
/// A positive LEC value moves the axis in the negative direction, so the values are the measured error
/// (−correction) in mm. An LEC table acts in both directions of travel; each direction is written as a complete
/// table so the shop can load one as LEC and keep the difference as a direction-dependent compensation, as the
/// header comment says.
pub fn sinumerik_text(analysis: &Analysis) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "; driftloop positioning: compensation tables from {} ({})",
        analysis.source,
        analysis.standard.title()
    );
    out.push_str(SINUMERIK_NOTES);
    for axis in &analysis.axes {
        let mean_reversal = axis
            .stats
            .targets
            .iter()
            .map(|t| t.reversal_um)
            .sum::<f64>()
            / axis.stats.targets.len() as f64;
        let _ = writeln!(
            out,
            ";\n; axis {}: mean reversal x̄↑ − x̄↓ = {} µm; needs MD38000 $MA_MM_ENC_COMP_MAX_POINTS >= {}",
            axis.stats.axis,
            fmt_num(mean_reversal, 2),
            axis.correction.grid.point_count()
        );
        for (label, plus) in [("+ direction", true), ("- direction", false)] {
            let _ = writeln!(out, "; {} {label}", axis.stats.axis);
            direction_table(&mut out, &axis.stats.axis, &axis.correction, plus);
        }
    }
    out
}

fn direction_table(out: &mut String, axis: &str, table: &CorrectionTable, plus: bool) {
    out.push_str("%_N_AX_EEC_INI\nCHANDATA(1)\n");
    for (n, g) in table.grid_values.iter().enumerate() {
        let correction_um = if plus {
            g.correction_plus_um
        } else {
            g.correction_minus_um
        };
        let error_mm = -correction_um / 1000.0;
        let _ = writeln!(out, "$AA_ENC_COMP[0,{n},{axis}]={}", fmt_num(error_mm, 4));
    }
    let grid = table.grid;
    let _ = writeln!(
        out,
        "$AA_ENC_COMP_STEP[0,{axis}]={}",
        fmt_num(grid.step_mm, 3)
    );
    let _ = writeln!(
        out,
        "$AA_ENC_COMP_MIN[0,{axis}]={}",
        fmt_num(grid.start_mm, 3)
    );
    let _ = writeln!(
        out,
        "$AA_ENC_COMP_MAX[0,{axis}]={}",
        fmt_num(grid.end_mm, 3)
    );
    let _ = writeln!(out, "$AA_ENC_COMP_IS_MODULO[0,{axis}]=0");
    out.push_str("M17\n");
}
