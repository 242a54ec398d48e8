//! The positioning HTML report: charts of deviation vs position with x̄ ± k·s bands, the corrections, the
//! numbers and how to read them.

use super::text::bidirectional_figure;
use super::{Analysis, AxisResult, sinumerik_text};
use crate::report::{Cell, Chart, Document, Mark, PALETTE, Series, Table, fmt_num};

pub fn html_report(analysis: &Analysis) -> String {
    let standard = analysis.standard;
    let k = fmt_num(standard.k(), 0);
    let mut doc = Document::new(format!("Positioning accuracy — {}", analysis.source));
    doc.paragraph(format!(
        "Evaluated after {} with limits x̄ ± {k}·s (s with n − 1). Deviations are measured minus target position, \
         in µm; corrections are what the control adds to the commanded position.",
        standard.title()
    ));
    doc.how_to_read(&[
        format!(
            "Each target was approached at least five times from below (+, ↑) and from above (−, ↓). The dots are \
             the mean deviations x̄↑ and x̄↓; the shaded bands span x̄ ± {k}·s, where a further approach is expected \
             to land. The vertical gap between the two curves is the reversal (backlash) b; the width of the bands \
             is the scatter no table can remove."
        ),
        "The correction chart shows the negated means at the measured points and the natural cubic spline through \
         them, evaluated on the compensation grid the control uses; the control interpolates linearly between grid \
         points. The residual is what remains at the targets after that correction: near zero when the grid is \
         fine enough, larger where the grid skips a bend."
            .to_string(),
        "“Before → after” compares the systematic error (range of the means) and the accuracy (range of x̄ ± k·s) \
         with the predicted means after correction; the scatter s is assumed unchanged, so the accuracy after \
         correction cannot drop below the widest band, 2k·s."
            .to_string(),
    ]);
    for axis in &analysis.axes {
        axis_sections(&mut doc, axis, analysis);
    }
    doc.section("Sinumerik compensation tables");
    doc.paragraph("LEC table text for the control, one table per approach direction (see its header comment).");
    doc.preformatted(sinumerik_text(analysis));
    doc.render()
}

fn axis_sections(doc: &mut Document, axis: &AxisResult, analysis: &Analysis) {
    let stats = &axis.stats;
    let k = fmt_num(analysis.standard.k(), 0);
    let name = &stats.axis;
    doc.section(format!("Axis {name}"));

    let mean_series = |label: String,
                       mean: fn(&super::TargetStats) -> f64,
                       band: fn(&super::TargetStats) -> (f64, f64)| {
        Series::new(
            label,
            Mark::LineAndPoints,
            stats
                .targets
                .iter()
                .map(|t| (t.target_mm, mean(t)))
                .collect(),
        )
        .with_band(stats.targets.iter().map(band).collect())
    };
    let deviation = Chart::new(
        format!("Axis {name}: positioning deviation"),
        format!("{name} target position in mm"),
        "deviation in µm",
    )
    .series(mean_series(
        format!("x̄↑ ± {k}·s↑"),
        |t| t.plus.mean_um,
        |t| (t.plus.lower_um, t.plus.upper_um),
    ))
    .series(mean_series(
        format!("x̄↓ ± {k}·s↓"),
        |t| t.minus.mean_um,
        |t| (t.minus.lower_um, t.minus.upper_um),
    ));
    doc.figure(
        &deviation,
        format!("Mean deviation per direction with the x̄ ± {k}·s band, axis {name}."),
    );

    let c = &axis.correction;
    let (up, down) = (PALETTE[0], PALETTE[1]);
    let measured = |label: &str, color: &str, value: fn(&super::MeasuredCorrection) -> f64| {
        Series::new(
            label,
            Mark::Points,
            c.measured.iter().map(|m| (m.target_mm, value(m))).collect(),
        )
        .with_color(color)
    };
    let grid = |label: &str, color: &str, value: fn(&super::GridCorrection) -> f64| {
        Series::new(
            label,
            Mark::Dashed,
            c.grid_values
                .iter()
                .map(|g| (g.position_mm, value(g)))
                .collect(),
        )
        .with_color(color)
    };
    let corrections = Chart::new(
        format!("Axis {name}: corrections"),
        format!("{name} position in mm"),
        "correction in µm",
    )
    .series(measured("↑ at the targets (−x̄↑)", up, |m| {
        m.correction_plus_um
    }))
    .series(grid("↑ spline on the grid", up, |g| g.correction_plus_um))
    .series(measured("↓ at the targets (−x̄↓)", down, |m| {
        m.correction_minus_um
    }))
    .series(grid("↓ spline on the grid", down, |g| {
        g.correction_minus_um
    }));
    doc.figure(
        &corrections,
        format!("Corrections at the measured points and the natural cubic spline on the grid {} mm, axis {name}.", c.grid),
    );

    let k_value = analysis.standard.k();
    let residual = |label: String,
                    color: &str,
                    value: fn(&super::MeasuredCorrection) -> f64,
                    s: fn(&super::TargetStats) -> f64| {
        Series::new(
            label,
            Mark::LineAndPoints,
            c.measured.iter().map(|m| (m.target_mm, value(m))).collect(),
        )
        .with_band(
            c.measured
                .iter()
                .zip(&stats.targets)
                .map(|(m, t)| (value(m) - k_value * s(t), value(m) + k_value * s(t)))
                .collect(),
        )
        .with_color(color)
    };
    let after = Chart::new(
        format!("Axis {name}: predicted deviation after correction"),
        format!("{name} target position in mm"),
        "deviation in µm",
    )
    .series(residual(
        format!("residual ↑ ± {k}·s↑"),
        up,
        |m| m.residual_plus_um,
        |t| t.plus.s_um,
    ))
    .series(residual(
        format!("residual ↓ ± {k}·s↓"),
        down,
        |m| m.residual_minus_um,
        |t| t.minus.s_um,
    ));
    doc.figure(
        &after,
        format!(
            "Mean deviation left at the targets when the control applies the grid table (linear between grid points), with the unchanged scatter ± {k}·s, axis {name}."
        ),
    );

    let (figure, figure_value) = bidirectional_figure(analysis.standard);
    let mut per_target = Table::new(&[
        "target mm".to_string(),
        "x̄↑".into(),
        "s↑".into(),
        format!("x̄↑ − {k}s↑"),
        format!("x̄↑ + {k}s↑"),
        "x̄↓".into(),
        "s↓".into(),
        format!("x̄↓ − {k}s↓"),
        format!("x̄↓ + {k}s↓"),
        "b".into(),
        figure.into(),
    ])
    .caption(format!("Axis {name}: statistics per target (µm)"));
    for t in &stats.targets {
        let mut row = vec![Cell::Num(t.target_mm, 3)];
        row.extend(
            [
                t.plus.mean_um,
                t.plus.s_um,
                t.plus.lower_um,
                t.plus.upper_um,
                t.minus.mean_um,
                t.minus.s_um,
                t.minus.lower_um,
                t.minus.upper_um,
                t.reversal_um,
                figure_value(t),
            ]
            .map(|v| Cell::Num(v, 2)),
        );
        per_target.row(row);
    }
    doc.table(per_target);

    let mut summary = Table::new(&["symbol", "value µm", "meaning"]).caption(format!(
        "Axis {name}: {} summary",
        analysis.standard.title()
    ));
    for v in &stats.summary {
        summary.row(vec![
            v.symbol.into(),
            Cell::Num(v.value_um, 2),
            v.name.into(),
        ]);
    }
    doc.table(summary);

    let mut effect = Table::new(&["", "before µm", "after µm (predicted)"])
        .caption(format!("Axis {name}: effect of the correction"));
    effect.row(vec![
        "systematic error (range of means)".into(),
        Cell::Num(c.before.systematic_error_um, 2),
        Cell::Num(c.after.systematic_error_um, 2),
    ]);
    effect.row(vec![
        format!("accuracy (range of x̄ ± {k}·s)").into(),
        Cell::Num(c.before.accuracy_um, 2),
        Cell::Num(c.after.accuracy_um, 2),
    ]);
    doc.table(effect);

    let mut table = Table::new(&[
        "target mm",
        "correction ↑",
        "correction ↓",
        "residual ↑",
        "residual ↓",
    ])
    .caption(format!(
        "Axis {name}: corrections at the measured points (µm)"
    ));
    for m in &c.measured {
        table.row(
            [
                m.target_mm,
                m.correction_plus_um,
                m.correction_minus_um,
                m.residual_plus_um,
                m.residual_minus_um,
            ]
            .iter()
            .enumerate()
            .map(|(i, &v)| Cell::Num(v, if i == 0 { 3 } else { 2 }))
            .collect(),
        );
    }
    doc.table(table);
}
