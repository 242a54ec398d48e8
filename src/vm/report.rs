//! What a run returns, and its human-readable report.

use std::collections::BTreeMap;
use std::fmt::Write;

use serde::Serialize;

use super::machine::{ProbeResult, SpindleHistory};
use super::passes::Pass;

/// How the run ended.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum End {
    /// M2 / M30 (or M17 / RET in the main program).
    ProgramEnd { code: String },
    /// The main program ran off its last block.
    EndOfProgram,
    /// SETAL raised an alarm; the alarm reaction stops the program.
    Alarm { number: i64 },
}

/// Where in the program something happened.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct At {
    pub file: String,
    pub line: usize,
    pub time_min: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Measurement {
    pub at: At,
    pub cycle: String,
    pub axis: String,
    /// The machine's true drift of the axis at that moment (µm).
    pub true_drift_um: f64,
    pub result: ProbeResult,
    /// What the result parameter holds afterwards (mm).
    pub value_mm: f64,
}

/// A write to a settable frame (`$P_UIFR[n, axis, TR | FI]`), or to the one in force (`$P_IFRAME[axis, TR
/// | FI]`): a work-offset correction.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Correction {
    pub at: At,
    pub frame: usize,
    /// `TR` (coarse) or `FI` (fine).
    pub component: String,
    pub axis: String,
    pub old_mm: f64,
    pub new_mm: f64,
    /// Written to the frame in force (`$P_IFRAME`), not to the stored one.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub in_force: bool,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Alarm {
    pub at: At,
    pub number: i64,
    pub text: Option<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Message {
    pub at: At,
    pub text: String,
}

/// A write of the temperature compensation's position-independent value SD43900 of an axis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TempCompWrite {
    pub at: At,
    pub axis: String,
    pub old_mm: f64,
    pub new_mm: f64,
}

/// One executed block.
#[derive(Debug, Clone, PartialEq)]
pub struct TraceRow {
    pub file: std::rc::Rc<str>,
    pub line: usize,
    pub block_number: Option<u64>,
    pub time_min: f64,
    pub spindle_rpm: f64,
    /// Programmed (work) position per axis, in the order of [`Run::axes`].
    pub programmed: Vec<f64>,
    /// Commanded machine position per axis: programmed plus the active offsets.
    pub machine: Vec<f64>,
    /// Bit i set once axis i has been programmed.
    pub moved_axes: u64,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Totals {
    pub passes: usize,
    pub max_abs_error_um: f64,
    pub rms_error_um: f64,
    /// The same over the drift during the passes: the machined error had no correction been applied.
    pub max_abs_drift_um: f64,
    pub rms_drift_um: f64,
}

/// The outcome of a dry run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Run {
    pub program: String,
    pub end: End,
    pub blocks_executed: u64,
    pub time_min: f64,
    pub axes: Vec<String>,
    pub passes: Vec<Pass>,
    pub totals: Totals,
    pub measurements: Vec<Measurement>,
    pub corrections: Vec<Correction>,
    /// Writes of the temperature compensation SD43900 (`$SA_TEMP_COMP_ABS_VALUE`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub temp_comp_writes: Vec<TempCompWrite>,
    pub alarms: Vec<Alarm>,
    pub messages: Vec<Message>,
    /// What the dry run took without knowing it: a value the machine file does not give (read as 0), a
    /// synchronized action recorded but not run. Each once, where the run first met it.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub assumptions: Vec<Message>,
    /// Auxiliary functions the dry run passes by (M codes for the PLC), with how often they were output.
    pub aux_functions: BTreeMap<String, u64>,
    /// Files written with `WRITE`, by name.
    pub files: BTreeMap<String, String>,
    pub spindle: SpindleHistory,
    /// The tool centre point's error while cutting, per geometry axis (X, Y, Z): the
    /// machined error of each axis (a wall's position along X, a floor's depth along Z).
    pub cutting_error: BTreeMap<String, AxisError>,
    #[serde(skip)]
    pub trace: Vec<TraceRow>,
    /// The R-parameters at the end: retentive, what the next job starts with.
    #[serde(skip)]
    pub r_final: Vec<f64>,
}

/// Drift minus correction along one axis over the time the tool cut (feed moves with the spindle on),
/// sampled at each move's middle and weighted by its time.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct AxisError {
    pub max_abs_um: f64,
    pub rms_um: f64,
    /// The same for the drift alone: the error had nothing been corrected.
    pub max_abs_drift_um: f64,
    pub rms_drift_um: f64,
    pub cutting_min: f64,
    #[serde(skip)]
    sums: (f64, f64),
}

impl AxisError {
    pub fn add(&mut self, error_um: f64, drift_um: f64, minutes: f64) {
        self.max_abs_um = self.max_abs_um.max(error_um.abs());
        self.max_abs_drift_um = self.max_abs_drift_um.max(drift_um.abs());
        self.sums.0 += error_um * error_um * minutes;
        self.sums.1 += drift_um * drift_um * minutes;
        self.cutting_min += minutes;
        if self.cutting_min > 0.0 {
            self.rms_um = (self.sums.0 / self.cutting_min).sqrt();
            self.rms_drift_um = (self.sums.1 / self.cutting_min).sqrt();
        }
    }
}

impl Run {
    /// A run that has not started.
    pub fn empty(axes: Vec<String>) -> Run {
        Run {
            program: String::new(),
            end: End::EndOfProgram,
            blocks_executed: 0,
            time_min: 0.0,
            axes,
            passes: Vec::new(),
            totals: Totals::default(),
            measurements: Vec::new(),
            corrections: Vec::new(),
            temp_comp_writes: Vec::new(),
            alarms: Vec::new(),
            messages: Vec::new(),
            assumptions: Vec::new(),
            aux_functions: BTreeMap::new(),
            files: BTreeMap::new(),
            spindle: SpindleHistory::default(),
            cutting_error: BTreeMap::new(),
            trace: Vec::new(),
            r_final: Vec::new(),
        }
    }
}

impl Totals {
    pub fn of(passes: &[Pass]) -> Totals {
        let n = passes.len();
        let max = |f: fn(&Pass) -> f64| passes.iter().map(|p| f(p).abs()).fold(0.0, f64::max);
        let rms = |f: fn(&Pass) -> f64| {
            if n == 0 {
                0.0
            } else {
                (passes.iter().map(|p| f(p).powi(2)).sum::<f64>() / n as f64).sqrt()
            }
        };
        Totals {
            passes: n,
            max_abs_error_um: max(|p| p.error_um),
            rms_error_um: rms(|p| p.error_um),
            max_abs_drift_um: max(|p| p.drift_um),
            rms_drift_um: rms(|p| p.drift_um),
        }
    }
}

fn at(a: &At) -> String {
    format!("{:>8.2} min  {}:{}", a.time_min, a.file, a.line)
}

impl Run {
    /// The report a person reads: ending, time, passes with their machined error, measurements, corrections,
    /// alarms and messages, files written.
    pub fn human(&self) -> String {
        let mut o = String::new();
        let end = match &self.end {
            End::ProgramEnd { code } => format!("program end ({code})"),
            End::EndOfProgram => "end of program text (no M30)".to_string(),
            End::Alarm { number } => format!("stopped by alarm {number}"),
        };
        let _ = writeln!(
            o,
            "dry run of {}: {end} after {} blocks, {:.2} min",
            self.program, self.blocks_executed, self.time_min
        );
        let t = &self.totals;
        let _ = writeln!(
            o,
            "machined error over {} passes: max {:.2} µm, RMS {:.2} µm (drift during them: max {:.2} µm, RMS {:.2} µm)",
            t.passes, t.max_abs_error_um, t.rms_error_um, t.max_abs_drift_um, t.rms_drift_um
        );
        let drifted = self
            .cutting_error
            .iter()
            .filter(|(_, e)| e.max_abs_um > 0.0 || e.max_abs_drift_um > 0.0);
        for (axis, e) in drifted {
            let _ = writeln!(
                o,
                "cutting error along {axis} over {:.1} min of cutting: max {:.2} µm, RMS {:.2} µm (drift: max {:.2} µm, RMS {:.2} µm)",
                e.cutting_min, e.max_abs_um, e.rms_um, e.max_abs_drift_um, e.rms_drift_um
            );
        }
        if !self.passes.is_empty() {
            let _ = writeln!(
                o,
                "\npasses (error = depth cut − nominal depth, µm; + too deep; drift = error without correction)\n    #    start      end   nominal Z      rpm    drift    error    worst  at"
            );
            for p in &self.passes {
                let _ = writeln!(
                    o,
                    "{:>5} {:>8.2} {:>8.2} {:>11.3} {:>8.0} {:>8.2} {:>8.2} {:>8.2}  {}:{}",
                    p.number,
                    p.start_min,
                    p.end_min,
                    p.nominal_z_mm + 0.0, // no "-0.000"
                    p.spindle_rpm,
                    p.drift_um,
                    p.error_um,
                    p.worst_um,
                    p.file,
                    p.line
                );
            }
        }
        if !self.measurements.is_empty() {
            let _ = writeln!(o, "\nmeasurements");
            for m in &self.measurements {
                let got = match m.result {
                    ProbeResult::Drift(d) => format!("saw {d:.2} µm"),
                    ProbeResult::Raw(v) => format!("faulty: returned {v}"),
                    ProbeResult::Nothing => "faulty: returned nothing".to_string(),
                };
                let _ = writeln!(
                    o,
                    "  {}  {} {}: true drift {:.2} µm, {got}, R = {:.4} mm",
                    at(&m.at),
                    m.cycle,
                    m.axis,
                    m.true_drift_um,
                    m.value_mm
                );
            }
        }
        if !self.corrections.is_empty() {
            let _ = writeln!(o, "\ncorrections (settable frame writes)");
            for c in &self.corrections {
                let frame = if c.in_force {
                    "$P_IFRAME[".to_string()
                } else {
                    format!("$P_UIFR[{},", c.frame)
                };
                let name = format!("{frame}{},{}]", c.axis, c.component);
                change_line(&mut o, &at(&c.at), &name, c.old_mm, c.new_mm);
            }
        }
        if !self.temp_comp_writes.is_empty() {
            let _ = writeln!(o, "\ntemperature compensation (SD43900 writes)");
            for c in &self.temp_comp_writes {
                let name = format!("$SA_TEMP_COMP_ABS_VALUE[{}]", c.axis);
                change_line(&mut o, &at(&c.at), &name, c.old_mm, c.new_mm);
            }
        }
        if !self.alarms.is_empty() {
            let _ = writeln!(o, "\nalarms");
            for a in &self.alarms {
                let text = a
                    .text
                    .as_deref()
                    .map(|t| format!(" {t}"))
                    .unwrap_or_default();
                let _ = writeln!(o, "  {}  {}{text}", at(&a.at), a.number);
            }
        }
        for (title, list) in [
            ("messages", &self.messages),
            ("assumed (not known to the dry run)", &self.assumptions),
        ] {
            if !list.is_empty() {
                let _ = writeln!(o, "\n{title}");
                for m in list {
                    let _ = writeln!(o, "  {}  {}", at(&m.at), m.text);
                }
            }
        }
        if !self.aux_functions.is_empty() {
            let list: Vec<String> = self
                .aux_functions
                .iter()
                .map(|(k, n)| format!("{k}×{n}"))
                .collect();
            let _ = writeln!(
                o,
                "\nauxiliary functions passed to the PLC (no effect here): {}",
                list.join(" ")
            );
        }
        for (name, text) in &self.files {
            let _ = writeln!(o, "\nfile {name} ({} lines)", text.lines().count());
            for line in text.lines() {
                let _ = writeln!(o, "  {line}");
            }
        }
        o
    }

    /// The trace as CSV: one row per executed block.
    pub fn trace_csv(&self) -> String {
        let mut o = String::from("file,line,n,time_min,spindle_rpm");
        for a in &self.axes {
            let _ = write!(o, ",{a}_prog,{a}_mach");
        }
        o.push('\n');
        for r in &self.trace {
            let n = r.block_number.map(|n| n.to_string()).unwrap_or_default();
            let _ = write!(
                o,
                "{},{},{n},{:.6},{}",
                r.file, r.line, r.time_min, r.spindle_rpm
            );
            for i in 0..self.axes.len() {
                let _ = write!(o, ",{:.4},{:.4}", r.programmed[i], r.machine[i]);
            }
            o.push('\n');
        }
        o
    }
}

/// One line of the human report for a value the program changed: where, what, from, to (mm), the change (µm).
fn change_line(o: &mut String, at: &str, name: &str, old_mm: f64, new_mm: f64) {
    let _ = writeln!(
        o,
        "  {at}  {name} {old_mm:.4} → {new_mm:.4} mm ({:+.2} µm)",
        (new_mm - old_mm) * 1000.0
    );
}
