//! The diagnosis in words (human) and as one JSON object.

use std::fmt::Write;

use serde_json::{Value, json};

use super::stats::ErrorStats;
use super::{Added, Diagnosis, Windows};
use crate::model::effects::{Effect, Kind};

/// "30 min", "6.5 h".
pub(crate) fn duration(min: f64) -> String {
    if min < 120.0 {
        format!("{min:.0} min")
    } else {
        format!("{:.1} h", min / 60.0)
    }
}

/// Short name: kind and signal.
pub(crate) fn effect_name(e: &Effect) -> String {
    match &e.signal {
        Some(s) => format!("{} of {s}", e.kind.name()),
        None => e.kind.name().to_string(),
    }
}

/// What the effect means, in a process engineer's words (without the "explains" part).
pub(crate) fn describe(e: &Effect) -> String {
    let sig = e.signal.as_deref().unwrap_or("");
    match e.kind {
        Kind::InputLag => {
            format!(
                "{sig}, lagged {}, {:+.2} µm/{}",
                duration(e.theta[0]),
                e.amplitudes[0],
                unit(sig)
            )
        }
        Kind::ExtraMode => format!(
            "a further spindle-driven mode, time constant {}, {:+.2} µm per 1000 rpm once settled",
            duration(e.theta[0]),
            e.amplitudes[0]
        ),
        Kind::CoolingAsymmetry => {
            let r = e.theta[0];
            let how = if r >= 1.0 { "slower" } else { "faster" };
            let factor = if r >= 1.0 { r } else { 1.0 / r };
            format!("the spindle modes cool {factor:.1}× {how} than they heat")
        }
        Kind::PositionSlope => format!(
            "drift grows with {sig}: {:+.2} µm per 100 mm per 1000 rpm once warm (lag {}), {:+.2} µm per 100 mm static",
            100.0 * e.amplitudes[0],
            duration(e.theta[0]),
            100.0 * e.amplitudes[1]
        ),
        Kind::TimeTrend => format!("a slow creep of {:+.3} µm per hour", e.amplitudes[0]),
        Kind::Periodic => {
            let p = e.to_spec().params;
            format!(
                "a daily cycle of ±{:.2} µm, peaking at {} on the time axis (mod 24 h)",
                p["amplitude_um"],
                duration(p["peak_min"])
            )
        }
        Kind::Step => format!(
            "a sudden offset of {:+.2} µm from minute {:.0} on",
            e.amplitudes[0], e.theta[0]
        ),
        Kind::StaticInput => format!(
            "{sig}, without lag, {:+.2} µm/{}",
            e.amplitudes[0],
            unit(sig)
        ),
        Kind::InputSlope => format!(
            "drift grows with {} as {sig} changes: {:+.2} µm per 100 mm per {}",
            e.position.as_deref().unwrap_or(""),
            100.0 * e.amplitudes[0],
            unit(sig)
        ),
        Kind::Geometric => format!(
            "geometric error along {}: {:+.2} µm per 100 mm, {:+.2} µm per (100 mm)²",
            e.position.as_deref().unwrap_or(""),
            100.0 * e.amplitudes[0],
            1e4 * e.amplitudes[1]
        ),
    }
}

fn unit(signal: &str) -> &'static str {
    if signal.ends_with("_c") {
        "°C"
    } else {
        "unit"
    }
}

/// The full sentence for an added effect.
pub(crate) fn sentence(a: &Added) -> String {
    format!(
        "{}, explains {:.2} of the {:.2} µm RMS residual",
        describe(&a.effect),
        a.explained_rms_um,
        a.residual_rms_um
    )
}

fn stats_json(s: &ErrorStats) -> Value {
    json!({"rms_um": round(s.rms_um), "max_um": round(s.max_um), "p95_um": round(s.p95_um)})
}

fn windows_json(w: &Windows) -> Value {
    json!({"fit": stats_json(&w.fit), "holdout": w.holdout.as_ref().map(stats_json)})
}

/// Numbers in the JSON are rounded to 0.1 nm so that output is stable across platforms.
fn round(v: f64) -> f64 {
    (v * 1e4).round() / 1e4
}

impl Diagnosis {
    /// The single JSON object of `--format json`.
    pub fn json(&self) -> Value {
        let effects: Vec<Value> = self
            .effects_added
            .iter()
            .map(|a| {
                let spec = a.effect.to_spec();
                let params: serde_json::Map<String, Value> = spec
                    .params
                    .iter()
                    .map(|(k, v)| (k.clone(), json!(round(*v))))
                    .collect();
                json!({
                    "kind": spec.kind,
                    "signal": spec.signal,
                    "params": params,
                    "explained_rms_um": round(a.explained_rms_um),
                })
            })
            .collect();
        let probing = self.probing.map(|p| {
            json!({
                "every_min": p.every_min,
                "probe_only": stats_json(&p.probe_only),
                "before": stats_json(&p.before),
                "after": stats_json(&p.after),
            })
        });
        json!({
            "channel": self.channel,
            "uncompensated": windows_json(&self.uncompensated),
            "before": windows_json(&self.before),
            "after": windows_json(&self.after),
            "effects_added": effects,
            "residual_white": self.residual_white,
            "holdout_guard": self.holdout_guard,
            "probing": probing,
        })
    }

    /// Compensation rate 1 − after/uncompensated (RMS) of a window.
    pub fn compensation_rate(&self, holdout: bool) -> Option<f64> {
        let pick = |w: &Windows| if holdout { w.holdout } else { Some(w.fit) };
        let (u, a) = (pick(&self.uncompensated)?, pick(&self.after)?);
        (u.rms_um > 0.0).then(|| 1.0 - a.rms_um / u.rms_um)
    }

    /// The human-readable report.
    pub fn human(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "diagnosis of {} on {}", self.channel, self.source);
        if self.rows_unmeasured > 0 {
            let _ = writeln!(
                s,
                "{} rows carry the inputs but no reading of {} (not measured there): they drive the model between readings; every count and number below is of the {} rows with a reading",
                self.rows_unmeasured,
                self.channel,
                self.rows_fit + self.rows_holdout
            );
        }
        match self.holdout_from_min {
            Some(h) => {
                let _ = writeln!(
                    s,
                    "fit window: {} rows before minute {h}; holdout: {} rows from minute {h} on (never used to fit or select; only to veto an \"after\" worse than \"before\")",
                    self.rows_fit, self.rows_holdout
                );
            }
            None => {
                let _ = writeln!(
                    s,
                    "no holdout (--holdout-from none): all {} rows fitted; the numbers below are in-sample only",
                    self.rows_fit
                );
            }
        }
        let _ = writeln!(
            s,
            "\n{:<24} {:>26} {:>26}",
            "µm", "fit  rms / max / p95", "holdout  rms / max / p95"
        );
        let rows = [
            ("uncompensated", &self.uncompensated),
            ("model before", &self.before),
            ("recalibrated", &self.recalibrated),
            ("model after", &self.after),
        ];
        for (name, w) in rows {
            let f = |x: Option<ErrorStats>| match x {
                Some(e) => format!("{:.2} / {:.2} / {:.2}", e.rms_um, e.max_um, e.p95_um),
                None => "—".to_string(),
            };
            let _ = writeln!(s, "{name:<24} {:>26} {:>26}", f(Some(w.fit)), f(w.holdout));
        }
        let pct = |r: Option<f64>| r.map_or("—".to_string(), |v| format!("{:.0} %", 100.0 * v));
        let _ = writeln!(
            s,
            "compensation rate (1 − after/uncompensated, RMS): fit {}, holdout {}",
            pct(self.compensation_rate(false)),
            pct(self.compensation_rate(true))
        );
        if let Some(p) = &self.probing {
            let unc = if self.rows_holdout > 0 {
                self.uncompensated.holdout
            } else {
                Some(self.uncompensated.fit)
            };
            let rate = |e: &ErrorStats| {
                unc.filter(|u| u.rms_um > 0.0).map_or("—".to_string(), |u| {
                    format!("{:.0} %", 100.0 * (1.0 - e.rms_um / u.rms_um))
                })
            };
            let _ = writeln!(
                s,
                "\nwith a probe re-zeroing the correction every {} ({}), rms / max, rate:",
                duration(p.every_min),
                if self.rows_holdout > 0 {
                    "on the holdout"
                } else {
                    "on the fit window"
                }
            );
            for (name, e) in [
                ("probe alone", &p.probe_only),
                ("probe + model before", &p.before),
                ("probe + model after", &p.after),
            ] {
                let _ = writeln!(
                    s,
                    "  {name:<22} {:.2} / {:.2} µm, {}",
                    e.rms_um,
                    e.max_um,
                    rate(e)
                );
            }
        }
        if !self.holdout_guard.is_empty() {
            let _ = writeln!(s);
        }
        for g in &self.holdout_guard {
            let _ = writeln!(s, "dropped on the holdout: {g}");
        }
        let kept_as_given = self
            .holdout_guard
            .iter()
            .any(|g| g.starts_with("the recalibration"));
        if kept_as_given {
            let _ = writeln!(
                s,
                "\nnothing helps on the forward holdout: the model is kept as given (\"after\" = \"before\")"
            );
        } else if self.effects_added.is_empty() && !self.holdout_guard.is_empty() {
            let _ = writeln!(
                s,
                "\nnothing found on the fit window helps on the forward holdout: no effect kept"
            );
        } else if self.effects_added.is_empty() {
            let _ = writeln!(s, "\nno effect added");
        } else {
            let _ = writeln!(s, "\neffects added:");
            for (i, a) in self.effects_added.iter().enumerate() {
                let _ = writeln!(s, "  {}. {}: {}", i + 1, a.effect.kind.name(), sentence(a));
                let _ = writeln!(
                    s,
                    "     (ΔBIC {:+.1} on the effective sample; forward error {:.3} → {:.3} µm)",
                    a.delta_bic, a.cv_rms_before_um, a.cv_rms_after_um
                );
            }
        }
        for r in &self.rejected {
            let _ = writeln!(s, "  rejected: {r}");
        }
        let _ = writeln!(
            s,
            "residual {} (Ljung–Box, 10 lags, 5 %)",
            if self.residual_white {
                "is white: nothing systematic left"
            } else {
                "is not white: structure remains that no candidate explains"
            }
        );
        s
    }
}
