//! The plan as a table for people: one row per gate.

use std::io::{self, Write};

use crate::source::LineIndex;
use crate::syntax::Program;

use super::plan::{GateKind, Plan};

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
        };
        let measure = match (g.measure, g.can_measure) {
            (true, _) => "yes",
            (false, true) => "no",
            (false, false) => "-",
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
