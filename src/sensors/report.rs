//! The `sensors --report` HTML: the scores, the regression, which sensors were kept and why, and over time
//! the measured error beside the regression's prediction, the residual and the kept sensors (one
//! self-contained file, as `diagnose --report`).

use super::position::PositionAnalysis;
use super::{Analysis, Cluster, Coefficient, Score};
use crate::data::Dataset;
use crate::report::{Cell, Chart, Document, Mark, PALETTE, Series, Table, points_by_run};

/// Most points drawn per series; longer series are thinned evenly.
const MAX_POINTS: usize = 3000;

impl Analysis {
    /// The report as one HTML document; `ds` is the data the analysis was made on.
    pub fn html(&self, ds: &Dataset) -> String {
        let mut doc = Document::new(format!(
            "Temperature sensors for {} — {}",
            self.channel, ds.source
        ));
        let validation = match self.validation.holdout_from_min {
            Some(h) => format!(
                "Validation: the rows from minute {h} on (right of the dashed line{}) were left out of the \
                 selection and the regression and then predicted; their numbers are the honest ones.",
                if self.validation.default_holdout {
                    ", by default the last third of the time span"
                } else {
                    ""
                }
            ),
            None => "Validation: each run was left out in turn, the sensors chosen and the regression fitted \
                     on the others, and the left-out run predicted."
                .to_string(),
        };
        how_to_read(&mut doc, validation);
        doc.section("Numbers");
        doc.table(scores(&[
            ("fit", &self.fit),
            (&self.validation.scheme, &self.validation.score),
        ]));
        doc.section("Regression");
        doc.table(coefficients(
            &self.coefficients,
            "E = b0 + Σ b·(θ − θ at the run's start)",
            "µm",
            "µm/°C",
        ));
        sensor_tables(
            &mut doc,
            self.factors.iter().map(|f| (f.sensor.as_str(), f.r)),
            &self.clusters,
            self.threshold,
        );
        over_time(
            &mut doc,
            ds,
            &self.channel,
            &self.prediction,
            &self.chosen,
            self.validation.holdout_from_min,
        );
        doc.render()
    }
}

impl PositionAnalysis {
    /// The report of the position variant (E = E_G(p) + S(θ)·p + I(θ)) as one HTML document.
    pub fn html(&self, ds: &Dataset) -> String {
        let mut doc = Document::new(format!(
            "Temperature sensors for {} along {} — {}",
            self.channel, self.position, ds.source
        ));
        how_to_read(
            &mut doc,
            format!(
                "Rows sharing a time are one thermal state measured at several positions. Validation: the states \
                 from minute {} on (right of the dashed line) were left out and then predicted.",
                self.holdout_from_min
            ),
        );
        doc.section("Numbers");
        doc.table(scores(&[
            ("fit", &self.fit),
            ("time holdout", &self.validation),
        ]));
        doc.section("Regression");
        let mut geometric = Table::new(&["E_G term", "value"])
            .caption("Geometric part E_G(p) of the reference state (p in mm)");
        for (term, (value, unit)) in ["constant", "linear", "quadratic"]
            .iter()
            .zip(self.geometric.iter().zip(["µm", "µm/mm", "µm/mm²"]))
        {
            geometric.row(vec![
                Cell::from(*term),
                Cell::from(format!("{value:.4} {unit}")),
            ]);
        }
        doc.table(geometric);
        doc.table(coefficients(
            &self.slope,
            "Slope S(θ) = b0 + Σ b·Δθ",
            "µm/mm",
            "µm/mm per °C",
        ));
        doc.table(coefficients(
            &self.intercept,
            "Intercept I(θ) = b0 + Σ b·Δθ",
            "µm",
            "µm/°C",
        ));
        let mut factors = Table::new(&["sensor", "r with S", "r with I"])
            .caption("Main factors: each sensor's correlation with the slope and the intercept over the states");
        for f in &self.factors {
            factors.row(vec![
                Cell::from(f.sensor.as_str()),
                Cell::Num(f.r_slope, 3),
                Cell::Num(f.r_intercept, 3),
            ]);
        }
        doc.section("Sensors");
        doc.table(factors);
        doc.table(cluster_table(&self.clusters, self.threshold));
        over_time(
            &mut doc,
            ds,
            &self.channel,
            self.prediction(),
            &self.chosen,
            Some(self.holdout_from_min),
        );
        doc.render()
    }
}

fn how_to_read(doc: &mut Document, validation: String) {
    doc.how_to_read(&[
        "The error of the channel is explained by a linear regression on a few temperature sensors. Sensors \
         that move together carry the same information: they are grouped (every pair in a group correlates at \
         least at the threshold) and one sensor per group is kept, the one most correlated with the error; a \
         group whose best sensor correlates weakly is dropped."
            .to_string(),
        validation,
        "The compensation rate is 1 − residual RMS / uncompensated RMS, uncompensated being the error relative \
         to its value at the start of its run: the share of the drift a correction by the regression would \
         remove. The standard errors assume independent residuals; thermal residuals are not, so judge the \
         regression by the validation."
            .to_string(),
    ]);
}

fn scores(rows: &[(&str, &Score)]) -> Table {
    let mut table = Table::new(&[
        "",
        "rows",
        "uncompensated RMS µm",
        "residual RMS µm",
        "residual max µm",
        "compensation",
    ])
    .caption("Error of the regression (measured − predicted)");
    for (name, s) in rows {
        table.row(vec![
            Cell::from(*name),
            Cell::Num(s.samples as f64, 0),
            Cell::Num(s.uncompensated_rms_um, 3),
            Cell::Num(s.residual_rms_um, 3),
            Cell::Num(s.residual_max_um, 3),
            Cell::from(format!("{:.1} %", 100.0 * s.compensation_rate)),
        ]);
    }
    table
}

fn coefficients(terms: &[Coefficient], caption: &str, offset_unit: &str, unit: &str) -> Table {
    let mut table = Table::new(&["term", "value", "± standard error", "unit"]).caption(caption);
    for c in terms {
        table.row(vec![
            Cell::from(c.term.as_str()),
            Cell::Num(c.value, 4),
            Cell::Num(c.se, 4),
            Cell::from(if c.term == "offset" {
                offset_unit
            } else {
                unit
            }),
        ]);
    }
    table
}

fn sensor_tables<'a>(
    doc: &mut Document,
    factors: impl Iterator<Item = (&'a str, f64)>,
    clusters: &[Cluster],
    threshold: f64,
) {
    let mut table = Table::new(&["sensor", "r with the error"])
        .caption("Main factors: each sensor's correlation with the error (training rows)");
    for (sensor, r) in factors {
        table.row(vec![Cell::from(sensor), Cell::Num(r, 3)]);
    }
    doc.section("Sensors");
    doc.table(table);
    doc.table(cluster_table(clusters, threshold));
}

fn cluster_table(clusters: &[Cluster], threshold: f64) -> Table {
    let mut table = Table::new(&["sensors", "verdict"]).caption(format!(
        "Groups of redundant sensors (complete linkage, |r| ≥ {threshold} inside a group)"
    ));
    for c in clusters {
        let verdict = c.verdict();
        table.row(vec![Cell::from(c.sensors.join(" ")), Cell::from(verdict)]);
    }
    table
}

/// Measured against predicted, the residual and the kept sensors over time, runs drawn apart.
fn over_time(
    doc: &mut Document,
    ds: &Dataset,
    channel: &str,
    predicted: &[f64],
    chosen: &[String],
    holdout_from_min: Option<f64>,
) {
    let t = &ds.time_min;
    let points = |v: &[f64]| points_by_run(t, v, &ds.run_starts, MAX_POINTS);
    let time_label = if ds.run_starts.len() > 1 {
        "time since the run's start in min (runs drawn apart)"
    } else {
        "time in min"
    };
    let marked = |c: Chart| match holdout_from_min {
        Some(h) => c.marker(h, "holdout"),
        None => c,
    };
    let Some(measured) = ds.values(channel) else {
        return;
    };
    doc.section("Over time");
    let chart = marked(Chart::new(
        format!("{channel}: measured and predicted"),
        time_label,
        format!("{channel} in µm"),
    ))
    .series(Series::new("measured", Mark::Points, points(measured)))
    .series(Series::new("regression", Mark::Line, points(predicted)).with_color(PALETTE[1]));
    doc.figure(
        &chart,
        "The measured error and what the regression on the kept sensors predicts from them.",
    );
    let residual: Vec<f64> = measured.iter().zip(predicted).map(|(m, p)| m - p).collect();
    let chart = marked(Chart::new(
        "Residual (measured − predicted)",
        time_label,
        "residual in µm",
    ))
    .series(Series::new("residual", Mark::Line, points(&residual)).with_color(PALETTE[2]));
    doc.figure(
        &chart,
        "What the regression leaves unexplained; a good one leaves noise around zero.",
    );
    let mut chart = marked(Chart::new(
        "The kept sensors",
        time_label,
        "change since the run's start in °C",
    ));
    for sensor in chosen {
        if let Some(values) = ds.values(sensor) {
            let mut change = values.to_vec();
            for run in ds.runs() {
                let start = values[run.start];
                for v in &mut change[run] {
                    *v -= start;
                }
            }
            chart = chart.series(Series::new(sensor.as_str(), Mark::Line, points(&change)));
        }
    }
    doc.figure(
        &chart,
        "Each kept sensor relative to its value at its run's start: the regressors.",
    );
}
