//! Human-readable text and JSON renderings of an [`Analysis`].

use std::fmt::Write;

use serde_json::{Map, Value, json};

use super::stats::Standard;
use super::{Analysis, AxisResult};
use crate::report::fmt_num;

/// Column header and value of the per-target bidirectional figure each standard names.
pub(crate) fn bidirectional_figure(
    standard: Standard,
) -> (&'static str, fn(&super::TargetStats) -> f64) {
    match standard {
        Standard::Dstu27843 => ("w", |t| t.spread_um),
        Standard::Vdi3441 => ("Ps+U", |t| t.spread_um),
        Standard::Iso230_2 => ("R", |t| t.repeatability_um),
    }
}

/// The report for a terminal: per-target table, axis summary, correction effect and table. µm, 2 decimals.
pub fn human(analysis: &Analysis) -> String {
    let standard = analysis.standard;
    let k = fmt_num(standard.k(), 0);
    let mut out = String::new();
    let _ = writeln!(
        out,
        "positioning accuracy of {} after {} (limits x̄ ± {k}·s, values in µm)",
        analysis.source,
        standard.title()
    );
    for axis in &analysis.axes {
        axis_text(&mut out, axis, standard, &k);
    }
    out
}

fn axis_text(out: &mut String, axis: &AxisResult, standard: Standard, k: &str) {
    let stats = &axis.stats;
    let (figure, figure_value) = bidirectional_figure(standard);
    let _ = writeln!(
        out,
        "\naxis {}: {} targets",
        stats.axis,
        stats.targets.len()
    );
    let widths = [10, 3, 8, 7, 8, 8, 3, 8, 7, 8, 8, 8, 8];
    let header = [
        "target mm".to_string(),
        "n↑".into(),
        "x̄↑".into(),
        "s↑".into(),
        format!("−{k}s↑"),
        format!("+{k}s↑"),
        "n↓".into(),
        "x̄↓".into(),
        "s↓".into(),
        format!("−{k}s↓"),
        format!("+{k}s↓"),
        "b".into(),
        figure.into(),
    ];
    let _ = writeln!(out, "{}", columns(&header, &widths));
    for t in &stats.targets {
        let mut cells = vec![fmt_num(t.target_mm, 3)];
        for side in [&t.plus, &t.minus] {
            cells.push(side.n.to_string());
            cells.extend(
                [side.mean_um, side.s_um, side.lower_um, side.upper_um].map(|v| fmt_num(v, 2)),
            );
        }
        cells.extend([t.reversal_um, figure_value(t)].map(|v| fmt_num(v, 2)));
        let _ = writeln!(out, "{}", columns(&cells, &widths));
    }
    let _ = writeln!(out, "summary ({}):", standard.title());
    for value in &stats.summary {
        let _ = writeln!(
            out,
            "  {} {:>8} µm  {}",
            left(value.symbol, 6),
            fmt_num(value.value_um, 2),
            value.name
        );
    }
    let c = &axis.correction;
    let _ = writeln!(
        out,
        "correction: spline through the means on grid {} mm ({} points); predicted at the targets:",
        c.grid,
        c.grid.point_count()
    );
    let _ = writeln!(
        out,
        "  systematic error {} → {} µm, accuracy (x̄ ± {k}·s) {} → {} µm",
        fmt_num(c.before.systematic_error_um, 2),
        fmt_num(c.after.systematic_error_um, 2),
        fmt_num(c.before.accuracy_um, 2),
        fmt_num(c.after.accuracy_um, 2)
    );
    let widths = [10, 9, 9, 10, 10];
    let header = ["target mm", "corr↑", "corr↓", "residual↑", "residual↓"].map(String::from);
    let _ = writeln!(out, "{}", columns(&header, &widths));
    for m in &c.measured {
        let mut cells = vec![fmt_num(m.target_mm, 3)];
        cells.extend(
            [
                m.correction_plus_um,
                m.correction_minus_um,
                m.residual_plus_um,
                m.residual_minus_um,
            ]
            .map(|v| fmt_num(v, 2)),
        );
        let _ = writeln!(out, "{}", columns(&cells, &widths));
    }
}

/// Right-aligned columns separated by one space.
fn columns(cells: &[String], widths: &[usize]) -> String {
    cells
        .iter()
        .zip(widths)
        .map(|(cell, &width)| right(cell, width))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Terminal columns `text` occupies: combining marks (the bar of x̄, b̄) take none.
fn display_width(text: &str) -> usize {
    text.chars()
        .filter(|c| !('\u{300}'..='\u{36f}').contains(c))
        .count()
}

fn right(text: &str, width: usize) -> String {
    format!(
        "{}{text}",
        " ".repeat(width.saturating_sub(display_width(text)))
    )
}

fn left(text: &str, width: usize) -> String {
    format!(
        "{text}{}",
        " ".repeat(width.saturating_sub(display_width(text)))
    )
}

/// One JSON object with the same numbers as [`human`] plus the grid corrections.
pub fn json(analysis: &Analysis) -> Value {
    let axes: Vec<Value> = analysis
        .axes
        .iter()
        .map(|axis| {
            let summary: Map<String, Value> = axis
                .stats
                .summary
                .iter()
                .map(|v| (v.key.to_string(), json!(v.value_um)))
                .collect();
            json!({
                "axis": axis.stats.axis,
                "targets": axis.stats.targets,
                "summary": summary,
                "correction": axis.correction,
            })
        })
        .collect();
    json!({
        "source": analysis.source,
        "standard": analysis.standard,
        "k": analysis.standard.k(),
        "axes": axes,
    })
}
