//! The plan for people and programs: the passes of the timeline and one row per gate.

use std::io::{self, Write};

use serde::Serialize;

use crate::source::LineIndex;
use crate::syntax::Program;

use super::plan::{GateKind, Plan};
use super::timeline::Timeline;

/// One pass as reported: where it starts, its tool, when it runs and its top speed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PassRow {
    pub pass: usize,
    pub line: usize,
    pub tool: Option<String>,
    pub start_min: f64,
    pub end_min: f64,
    pub max_rpm: f64,
}

/// The passes of a timeline with their input lines.
pub fn pass_rows(program: &Program, timeline: &Timeline) -> Vec<PassRow> {
    let lines = LineIndex::new(program.source());
    timeline
        .passes
        .iter()
        .map(|p| PassRow {
            pass: p.number,
            line: lines.line_col(program.block_span(p.first_block).start).0,
            tool: p.tool.as_deref().map(str::to_string),
            start_min: p.start_min,
            end_min: p.end_min,
            max_rpm: p.max_rpm,
        })
        .collect()
}

/// The passes (program time, without measurements): pass, line, tool, start, end, top speed.
pub fn write_passes(out: &mut impl Write, rows: &[PassRow]) -> io::Result<()> {
    writeln!(
        out,
        "{:>4}  {:>6}  {:<20}  {:>9}  {:>9}  {:>7}",
        "pass", "line", "tool", "start min", "end min", "max rpm"
    )?;
    for r in rows {
        writeln!(
            out,
            "{:>4}  {:>6}  {:<20}  {:>9.2}  {:>9.2}  {:>7.0}",
            r.pass,
            r.line,
            r.tool.as_deref().unwrap_or("-"),
            r.start_min,
            r.end_min,
            r.max_rpm
        )?;
    }
    Ok(())
}

/// One row per gate: where, when, at what speed, the drift predicted there, and whether it measures.
pub fn write_table(out: &mut impl Write, program: &Program, plan: &Plan) -> io::Result<()> {
    writeln!(
        out,
        "{:>4}  {:>4}  {:>6}  {:<9}  {:>9}  {:>7}  {:>13}  measure?",
        "gate", "pass", "line", "kind", "start min", "rpm", "predicted µm"
    )?;
    let lines = LineIndex::new(program.source());
    for g in &plan.gates {
        let (line, _) = lines.line_col(program.block_span(g.block).start);
        let kind = match g.kind {
            GateKind::Reference => "reference",
            GateKind::PassStart => "pass",
            GateKind::Extra => "extra",
            GateKind::Update => "update",
            GateKind::Refresh => "refresh",
        };
        let measure = match (g.measurements, g.runs, g.can_measure) {
            (0, 1, true) => "no".to_string(),
            (0, 1, false) => "-".to_string(),
            (0, n, true) => format!("no ({n} runs)"),
            (0, n, false) => format!("- ({n} runs)"),
            (_, 1, _) => "yes".to_string(),
            (m, n, _) => format!("yes, {m} of {n} runs"),
        };
        writeln!(
            out,
            "{:>4}  {:>4}  {:>6}  {:<9}  {:>9.2}  {:>7.0}  {:>13.1}  {measure}",
            g.number, g.pass, line, kind, g.time_min, g.rpm, g.predicted_um
        )?;
    }
    writeln!(
        out,
        "program {:.1} min with measurements; {} measurement(s) planned; predicted drift up to {:.1} µm; δ' = {:.1} µm",
        plan.total_min, plan.measurements, plan.max_predicted_um, plan.working_limit_um
    )
}

/// Why each gate that cannot measure cannot, so that a user sees what to change in the program.
pub fn write_unfit(out: &mut impl Write, program: &Program, plan: &Plan) -> io::Result<()> {
    let lines = LineIndex::new(program.source());
    let mut unfit = plan
        .gates
        .iter()
        .filter_map(|g| g.cannot_measure.as_ref().map(|why| (g, why)))
        .peekable();
    if unfit.peek().is_none() {
        return Ok(());
    }
    writeln!(out, "gates that cannot measure:")?;
    for (g, why) in unfit {
        let (line, _) = lines.line_col(program.block_span(g.block).start);
        writeln!(out, "  gate {} (line {line}): {why}", g.number)?;
    }
    Ok(())
}

/// How the plan counts the program's loops: a counted loop's runs, or why one is counted once.
pub fn write_loops(out: &mut impl Write, program: &Program, plan: &Plan) -> io::Result<()> {
    if plan.loops.is_empty() {
        return Ok(());
    }
    let lines = LineIndex::new(program.source());
    let line = |block: usize| lines.line_col(program.block_span(block).start).0;
    writeln!(out, "loops:")?;
    for l in &plan.loops {
        let what = format!("line {} {}", line(l.block), l.kind.keyword());
        let body = format!("lines {}-{}", line(l.body.0), line(l.body.1));
        match (l.runs, l.unknown) {
            (Some(n), _) => writeln!(
                out,
                "  {what:<22} {body:<15} counted {n} times ({:.2} min each)",
                l.body_min
            )?,
            (None, why) => writeln!(
                out,
                "  {what:<22} {body:<15} counted once: {}",
                why.unwrap_or("runs not known")
            )?,
        }
    }
    if !plan.every_run_planned {
        writeln!(
            out,
            "  (a loop runs so often that the plan follows only the first {} gate runs; the time of all runs is counted)",
            super::loops::MAX_SITE_RUNS
        )?;
    }
    Ok(())
}

/// Calls of one subprogram or cycle: how many call statements, and the line of the first.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CallCount {
    pub name: String,
    pub calls: usize,
    pub first_line: usize,
}

/// A subprogram the plan timed (the archive's, or one in a subprogram folder), with the time of one run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TimedCall {
    #[serde(flatten)]
    pub call: CallCount,
    pub min_per_run: f64,
}

/// Calls grouped per name, in order of the first call.
fn count_calls<'a>(calls: impl Iterator<Item = (usize, &'a str)>) -> Vec<CallCount> {
    let mut rows: Vec<CallCount> = Vec::new();
    for (line, name) in calls {
        match rows.iter_mut().find(|r| r.name == name) {
            Some(row) => row.calls += 1,
            None => rows.push(CallCount {
                name: name.to_string(),
                calls: 1,
                first_line: line,
            }),
        }
    }
    rows
}

/// The subprograms and cycles a program calls whose time the plan does not know.
pub fn untimed_calls(timeline: &Timeline) -> Vec<CallCount> {
    count_calls(timeline.untimed_calls.iter().map(|(l, n)| (*l, n.as_str())))
}

/// The subprograms a program calls whose time the plan counts.
pub fn timed_calls(timeline: &Timeline) -> Vec<TimedCall> {
    let calls = timeline
        .timed_calls
        .iter()
        .map(|(l, n, _)| (*l, n.as_str()));
    count_calls(calls)
        .into_iter()
        .map(|call| {
            let run = timeline.timed_calls.iter().find(|c| c.1 == call.name);
            let min_per_run = run.map_or(0.0, |c| c.2);
            TimedCall { call, min_per_run }
        })
        .collect()
}

pub fn write_timed(out: &mut impl Write, rows: &[TimedCall]) -> io::Result<()> {
    write_calls(
        out,
        "timed subprograms (of the archive or a subprogram folder; their calls of others included):",
        rows.iter().map(|r| (&r.call, Some(r.min_per_run))),
    )
}

pub fn write_untimed(out: &mut impl Write, rows: &[CallCount]) -> io::Result<()> {
    write_calls(
        out,
        "not timed (subprogram and cycle calls: the plan counts no time for them, so it may measure less often than needed; every gate still decides with the real elapsed time):",
        rows.iter().map(|c| (c, None)),
    )
}

/// A heading and a line per called name (with the minutes of one run when timed); nothing without rows.
fn write_calls<'a>(
    out: &mut impl Write,
    heading: &str,
    rows: impl ExactSizeIterator<Item = (&'a CallCount, Option<f64>)>,
) -> io::Result<()> {
    if rows.len() == 0 {
        return Ok(());
    }
    writeln!(out, "{heading}")?;
    for (c, min) in rows {
        let calls = if c.calls == 1 { "call" } else { "calls" };
        let run = min
            .map(|m| format!(", {m:.2} min a run"))
            .unwrap_or_default();
        writeln!(
            out,
            "  {:<22} {} {calls}, first at line {}{run}",
            c.name, c.calls, c.first_line
        )?;
    }
    Ok(())
}
