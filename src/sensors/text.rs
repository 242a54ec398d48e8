//! The human report of `driftloop sensors`.

use std::fmt::Write as _;

use super::{Analysis, Score};

fn score_line(s: &mut String, label: &str, sc: &Score) {
    let _ = writeln!(
        s,
        "  {label:<11} {:>6} rows  uncompensated RMS {:>8.3} µm  residual RMS {:>8.3} µm  max {:>8.3} µm  compensation {:>5.1} %",
        sc.samples,
        sc.uncompensated_rms_um,
        sc.residual_rms_um,
        sc.residual_max_um,
        100.0 * sc.compensation_rate
    );
}

impl Analysis {
    pub fn human(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{}: {} temperature sensors, selection and regression on {} rows",
            self.channel,
            self.factors.len(),
            self.training_samples
        );
        let _ = writeln!(s, "\ncorrelation with the error (r) and between sensors:");
        let _ = write!(s, "  {:<12} {:>7} ", "sensor", "error");
        for k in 0..self.factors.len() {
            let _ = write!(s, " {:>6}", k + 1);
        }
        s.push('\n');
        for (k, (f, row)) in self.factors.iter().zip(&self.correlation).enumerate() {
            let _ = write!(
                s,
                "  {:<12} {:>7.3} ",
                format!("{} {}", k + 1, f.sensor),
                f.r
            );
            for r in row {
                let _ = write!(s, " {r:>6.2}");
            }
            s.push('\n');
        }
        let _ = writeln!(
            s,
            "\nclusters (complete linkage, |r| ≥ {} inside a cluster):",
            self.threshold
        );
        for c in &self.clusters {
            let verdict = match (&c.kept, &c.dropped) {
                (Some(k), _) => format!("keep {k}"),
                (None, Some(why)) => format!("drop ({why})"),
                (None, None) => "drop".into(),
            };
            let _ = writeln!(s, "  {:<40} {verdict}", c.sensors.join(" "));
        }
        let _ = writeln!(
            s,
            "\nregression E = b0 + Σ b·(θ − θ at run start), θ one row late:"
        );
        for c in &self.coefficients {
            let unit = if c.term == "offset" { "µm" } else { "µm/°C" };
            let _ = writeln!(s, "  {:<12} {:>10.4} ± {:.4} {unit}", c.term, c.value, c.se);
        }
        score_line(&mut s, "fit", &self.fit);
        let v = &self.validation;
        let label = match v.holdout_from_min {
            Some(t) => {
                let why = if v.default_holdout {
                    " (default: the last third of the time span)"
                } else {
                    ""
                };
                let _ = writeln!(s, "  validation: time holdout from {t:.1} min{why}");
                "holdout"
            }
            None => {
                let _ = writeln!(
                    s,
                    "  validation: leave-one-run-out (sensors chosen on all runs)"
                );
                "left out"
            }
        };
        score_line(&mut s, label, &v.score);
        s
    }
}
