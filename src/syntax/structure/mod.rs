//! Control-structure pairing and jump-target resolution. Runs over the compact per-block kinds and flags and
//! materialises only the blocks that open/close structures wrongly, define labels or jump.
//!
//! Scope: labels and structures belong to one program unit; an archive header (`%_N_…`) starts the next unit.

mod jumps;

pub use jumps::{JumpTarget, Search, Targets};
// Defined with the program, which keeps the jumps its parse resolved.
pub use super::program::Jump;

use crate::diagnostic::Diagnostic;
use crate::source::Span;
use crate::syntax::{BlockKind, NodeKind, Program, control_statements, flag};

/// The analysed structure of a program.
#[derive(Debug, Clone, Default)]
pub struct Structure {
    /// Matched control structures: opening block, closing block (an IF with ELSE appears twice: IF→ELSE and
    /// ELSE→ENDIF).
    pub pairs: Vec<(usize, usize)>,
    /// Label definitions: upper-cased name and block, every definition (a label may occur more than once).
    pub labels: Vec<(String, usize)>,
    /// Jumps with a literal target and the labels of section repetitions: source block, upper-cased target,
    /// resolved block (None: no target in the search direction).
    pub jumps: Vec<Jump>,
    pub diagnostics: Vec<Diagnostic>,
}

/// Pairs control keywords and resolves jump targets of every program unit.
pub fn analyze(program: &Program) -> Structure {
    let mut out = Structure::default();
    let n = program.block_count();
    let mut unit_start = 0;
    // Units without control keywords, labels or jumps (all of a CAM program) need no second look.
    let mut interesting = false;
    for i in 0..=n {
        if i == n || (program.block_kind(i) == BlockKind::Header && i > unit_start) {
            if interesting {
                analyze_unit(program, unit_start, i, &mut out);
            }
            unit_start = i;
            interesting = false;
        }
        if i < n {
            let kind = program.block_kind(i);
            interesting |= !matches!(kind, BlockKind::Plain | BlockKind::Header)
                || program.block_flags(i) & (flag::LABEL | flag::JUMP) != 0;
        }
    }
    out
}

fn analyze_unit(program: &Program, start: usize, end: usize, out: &mut Structure) {
    pair_controls(program, start, end, out);
    let unit = start..end;
    let mut targets = jumps::collect_labels(program, &unit, out);
    jumps::resolve_jumps(program, &unit, &mut targets, out);
}

/// What closes an opener, and its name for messages.
fn closer_of(kind: BlockKind) -> Option<(&'static [BlockKind], &'static str)> {
    match kind {
        BlockKind::If => Some((&[BlockKind::Else, BlockKind::EndIf], "ENDIF")),
        BlockKind::Else => Some((&[BlockKind::EndIf], "ENDIF")),
        BlockKind::While => Some((&[BlockKind::EndWhile], "ENDWHILE")),
        BlockKind::For => Some((&[BlockKind::EndFor], "ENDFOR")),
        BlockKind::Repeat => Some((&[BlockKind::Until], "UNTIL")),
        BlockKind::Loop => Some((&[BlockKind::EndLoop], "ENDLOOP")),
        _ => None,
    }
}

fn opener_of(kind: BlockKind) -> Option<(&'static [BlockKind], &'static str)> {
    match kind {
        BlockKind::Else => Some((&[BlockKind::If], "IF")),
        BlockKind::EndIf => Some((&[BlockKind::If, BlockKind::Else], "IF")),
        BlockKind::EndWhile => Some((&[BlockKind::While], "WHILE")),
        BlockKind::EndFor => Some((&[BlockKind::For], "FOR")),
        BlockKind::Until => Some((&[BlockKind::Repeat], "REPEAT")),
        BlockKind::EndLoop => Some((&[BlockKind::Loop], "LOOP")),
        _ => None,
    }
}

fn pair_controls(program: &Program, start: usize, end: usize, out: &mut Structure) {
    let mut open: Vec<usize> = Vec::new();
    for i in start..end {
        let kind = program.block_kind(i);
        if let Some((openers, opener_name)) = opener_of(kind) {
            match open
                .iter()
                .rposition(|&o| openers.contains(&program.block_kind(o)))
            {
                Some(at) => {
                    for &inner in &open[at + 1..] {
                        out.diagnostics.push(unclosed(program, inner, i));
                    }
                    out.pairs.push((open[at], i));
                    open.truncate(at);
                }
                None => {
                    let mut d = Diagnostic::error(
                        keyword_span(program, i),
                        format!(
                            "{} on line {} has no matching {opener_name}",
                            kind.keyword(),
                            i + 1
                        ),
                    )
                    .with_help(format!("add the {opener_name} it closes, or remove it"));
                    if let Some(&o) = open.last() {
                        d = d.with_related(
                            keyword_span(program, o),
                            format!(
                                "innermost open {} is on line {}",
                                program.block_kind(o).keyword(),
                                o + 1
                            ),
                        );
                    }
                    out.diagnostics.push(d);
                    continue;
                }
            }
        }
        if closer_of(kind).is_some() {
            open.push(i);
        }
    }
    for &o in &open {
        out.diagnostics.push(unclosed(program, o, end.max(1) - 1));
    }
}

/// "IF on line 12 has no ENDIF", pointing at the opener and at where the search for its end stopped: a closer
/// of an enclosing structure, or the end of the program unit.
fn unclosed(program: &Program, opener: usize, stopped_at: usize) -> Diagnostic {
    let kind = program.block_kind(opener);
    let closer = closer_of(kind).map_or("", |c| c.1);
    let stopper = program.block_kind(stopped_at);
    let note = match opener_of(stopper) {
        Some((_, outer)) => format!(
            "{} on line {} ends the enclosing {outer} first",
            stopper.keyword(),
            stopped_at + 1
        ),
        None => format!(
            "the program ends on line {} without {closer}",
            stopped_at + 1
        ),
    };
    Diagnostic::error(
        keyword_span(program, opener),
        format!("{} on line {} has no {closer}", kind.keyword(), opener + 1),
    )
    .with_help(format!("add {closer} where the block should end"))
    .with_related(program.content_span(stopped_at), note)
}

/// Span of the block's control keyword (the whole line if it has none).
fn keyword_span(program: &Program, i: usize) -> Span {
    let block = program.block(i);
    let statements = control_statements(program.source(), &block.root);
    statements
        .first()
        .and_then(|(_, n)| n.find(NodeKind::Keyword))
        .map_or(program.content_span(i), |k| k.span)
}

fn upper(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).to_ascii_uppercase()
}
