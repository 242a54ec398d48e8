//! The `--report` HTML: measured vs predicted before and after, the residual before and after, each added
//! effect's own contribution, the table of numbers and how to read them (one self-contained file).

use super::stats::ErrorStats;
use super::text::{duration, sentence};
use super::{Diagnosis, Windows};
use crate::report::{Cell, Chart, Document, Mark, PALETTE, Series, Table, points_by_run};

/// Most points drawn per series; longer series are thinned evenly (every k-th row).
const MAX_POINTS: usize = 3000;

impl Diagnosis {
    /// The report as one HTML document.
    pub fn html(&self) -> String {
        let mut doc = Document::new(format!("Diagnosis of {} — {}", self.channel, self.source));
        let holdout = match self.holdout_from_min {
            Some(h) => format!(
                "Rows from minute {h} on (right of the dashed line) were never used to fit or to choose effects; their numbers are the honest ones."
            ),
            None => "There was no holdout: every number is in-sample and flatters the model."
                .to_string(),
        };
        doc.how_to_read(&[
            "The model predicts the drift of the channel from the spindle speed (and any declared inputs). \
             \"Before\" is the model as it was given; \"after\" is the model with its own parameters recalibrated on \
             the fit window and the effects listed below added, everything refitted together."
                .to_string(),
            holdout,
            "An effect is added only if it lowers the BIC computed on the effective number of independent \
             samples (neighbouring samples of a dense log are correlated), if it predicts later time better \
             (forward validation on the fit window: refitted on the rows before each origin, scored on the rows \
             after it), and if it explains at least a tenth of the residual variance. An \"after\" worse than \
             \"before\" on the holdout is never reported: such effects are dropped again. The compensation rate is 1 − after/uncompensated RMS: \
             the share of the drift a correction by the model would remove."
                .to_string(),
        ]);
        doc.section("Numbers");
        let mut table = Table::new(&[
            "µm",
            "fit RMS",
            "fit max",
            "fit P95",
            "holdout RMS",
            "holdout max",
            "holdout P95",
        ])
        .caption("Error of each prediction (measured − predicted); uncompensated = measured − first reading");
        for (name, w) in [
            ("uncompensated", &self.uncompensated),
            ("model before", &self.before),
            ("recalibrated only", &self.recalibrated),
            ("model after", &self.after),
        ] {
            table.row(row(name, w));
        }
        doc.table(table);
        let rate = |h| {
            self.compensation_rate(h)
                .map_or("—".into(), |r| format!("{:.0} %", 100.0 * r))
        };
        doc.paragraph(format!(
            "Compensation rate after diagnosis: fit window {}, holdout {}.",
            rate(false),
            rate(true)
        ));
        doc.section("Effects added");
        if self.effects_added.is_empty() {
            doc.paragraph(
                "None: no candidate passed both the BIC and the blocked cross-validation.",
            );
        }
        for (i, a) in self.effects_added.iter().enumerate() {
            doc.paragraph(format!(
                "{}. {}: {}.",
                i + 1,
                a.effect.kind.name(),
                sentence(a)
            ));
        }
        for r in &self.rejected {
            doc.paragraph(format!("Tried and rejected — {r}."));
        }
        doc.paragraph(if self.residual_white {
            "The remaining residual is white (Ljung–Box): nothing systematic is left to explain."
        } else {
            "The remaining residual is not white (Ljung–Box): some structure is left that no candidate of the library explains."
        });

        let t = &self.time_min;
        let points = |t: &[f64], v: &[f64]| points_by_run(t, v, &self.run_starts, MAX_POINTS);
        let time_label = if self.run_starts.len() > 1 {
            "time since the run's start in min (runs drawn apart)"
        } else {
            "time in min"
        };
        let marked = |c: Chart| match self.holdout_from_min {
            Some(h) => c.marker(h, "holdout"),
            None => c,
        };
        let chart = marked(Chart::new(
            "Measured and predicted drift",
            time_label,
            "drift in µm",
        ))
        .series(Series::new(
            "measured",
            Mark::Points,
            points(t, &self.measured),
        ))
        .series(Series::new(
            "model before",
            Mark::Dashed,
            points(t, &self.predicted_before),
        ))
        .series(Series::new(
            "model after",
            Mark::Line,
            points(t, &self.predicted_after),
        ));
        doc.section("Over time").figure(
            &chart,
            "Measured drift with the model's prediction before and after diagnosis.",
        );
        let resid =
            |p: &[f64]| -> Vec<f64> { self.measured.iter().zip(p).map(|(m, q)| m - q).collect() };
        let chart = marked(Chart::new(
            "Residual (measured − predicted)",
            time_label,
            "residual in µm",
        ))
        .series(
            Series::new(
                "before",
                Mark::Dashed,
                points(t, &resid(&self.predicted_before)),
            )
            .with_color(PALETTE[1]),
        )
        .series(
            Series::new(
                "after",
                Mark::Line,
                points(t, &resid(&self.predicted_after)),
            )
            .with_color(PALETTE[2]),
        );
        doc.figure(
            &chart,
            "What each model leaves unexplained; a good model leaves noise around zero.",
        );
        for (a, c) in self.effects_added.iter().zip(&self.contributions) {
            let title = match (&a.effect.signal, a.effect.theta.first()) {
                (Some(s), Some(tau)) => {
                    format!("{} of {s} (τ {})", a.effect.kind.name(), duration(*tau))
                }
                _ => a.effect.kind.name().to_string(),
            };
            let chart = marked(Chart::new(title, time_label, "contribution in µm"))
                .series(Series::new("effect", Mark::Line, points(t, c)));
            doc.figure(&chart, sentence(a));
        }
        for (a, sig) in self.effects_added.iter().zip(&self.signals) {
            if let (Some(name), Some(values)) = (&a.effect.signal, sig) {
                let chart = marked(Chart::new(
                    format!("The column {name}"),
                    time_label,
                    column_axis(name),
                ))
                .series(Series::new(name.as_str(), Mark::Line, points(t, values)));
                doc.figure(
                    &chart,
                    format!(
                        "{name} as logged: the signal the {} effect reads.",
                        a.effect.kind.name()
                    ),
                );
            }
        }
        doc.render()
    }
}

/// A data column's axis label with the unit its name declares (design.md §3: `_c` °C, `_um` µm, `_mm` mm).
fn column_axis(name: &str) -> String {
    let unit = [("_c", "°C"), ("_um", "µm"), ("_mm", "mm"), ("_rpm", "rpm")]
        .iter()
        .find(|(suffix, _)| name.to_ascii_lowercase().ends_with(suffix));
    match unit {
        Some((_, unit)) => format!("{name} in {unit}"),
        None => name.to_string(),
    }
}

fn row(name: &str, w: &Windows) -> Vec<Cell> {
    let cells = |s: Option<ErrorStats>| -> Vec<Cell> {
        match s {
            Some(e) => vec![
                Cell::Num(e.rms_um, 2),
                Cell::Num(e.max_um, 2),
                Cell::Num(e.p95_um, 2),
            ],
            None => vec![Cell::Num(f64::NAN, 2); 3],
        }
    };
    let mut out = vec![Cell::from(name)];
    out.extend(cells(Some(w.fit)));
    out.extend(cells(w.holdout));
    out
}
