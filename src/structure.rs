//! Control-structure pairing and jump-target resolution. Runs over the compact per-block kinds and flags and
//! materialises only the blocks that open/close structures wrongly, define labels or jump.
//!
//! Scope: labels and structures belong to one program unit; an archive header (`%_N_…`) starts the next unit.

use std::collections::HashMap;

use crate::diagnostic::{Diagnostic, Severity};
use crate::source::Span;
use crate::syntax::{BlockKind, Node, NodeKind, Program, flag, leading_block_number};

/// The analysed structure of a program.
#[derive(Debug, Clone, Default)]
pub struct Structure {
    /// Matched control structures: opening block, closing block (an IF with ELSE appears twice: IF→ELSE and
    /// ELSE→ENDIF).
    pub pairs: Vec<(usize, usize)>,
    /// Label definitions: upper-cased name and block.
    pub labels: Vec<(String, usize)>,
    /// Jumps with a literal target: source block, upper-cased target, resolved block (None: unknown target).
    pub jumps: Vec<Jump>,
    pub diagnostics: Vec<Diagnostic>,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Jump {
    pub from: usize,
    pub target: String,
    pub to: Option<usize>,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Direction {
    Forward,
    Backward,
    /// GOTO / GOTOC: forward first, then backward.
    Both,
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
    let labels = collect_labels(program, start, end, out);
    resolve_jumps(program, start, end, &labels, out);
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

fn keyword_name(kind: BlockKind) -> &'static str {
    match kind {
        BlockKind::If => "IF",
        BlockKind::Else => "ELSE",
        BlockKind::EndIf => "ENDIF",
        BlockKind::While => "WHILE",
        BlockKind::EndWhile => "ENDWHILE",
        BlockKind::For => "FOR",
        BlockKind::EndFor => "ENDFOR",
        BlockKind::Repeat => "REPEAT",
        BlockKind::Until => "UNTIL",
        BlockKind::Loop => "LOOP",
        BlockKind::EndLoop => "ENDLOOP",
        BlockKind::Plain | BlockKind::Header => "",
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
                            keyword_name(kind),
                            i + 1
                        ),
                    )
                    .with_help(format!("add the {opener_name} it closes, or remove it"));
                    if let Some(&o) = open.last() {
                        d = d.with_related(
                            keyword_span(program, o),
                            format!(
                                "innermost open {} is on line {}",
                                keyword_name(program.block_kind(o)),
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
            keyword_name(stopper),
            stopped_at + 1
        ),
        None => format!(
            "the program ends on line {} without {closer}",
            stopped_at + 1
        ),
    };
    Diagnostic::error(
        keyword_span(program, opener),
        format!(
            "{} on line {} has no {closer}",
            keyword_name(kind),
            opener + 1
        ),
    )
    .with_help(format!("add {closer} where the block should end"))
    .with_related(program.content_span(stopped_at), note)
}

/// Span of the block's control keyword (the whole line if it has none).
fn keyword_span(program: &Program, i: usize) -> Span {
    let block = program.block(i);
    let control = block.root.significant().find(|n| {
        matches!(
            n.kind,
            NodeKind::If
                | NodeKind::ControlKeyword
                | NodeKind::While
                | NodeKind::Until
                | NodeKind::For
                | NodeKind::Repeat
        )
    });
    control
        .and_then(|n| n.find(NodeKind::Keyword))
        .map_or(program.content_span(i), |k| k.span)
}

fn upper(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).to_ascii_uppercase()
}

fn collect_labels(
    program: &Program,
    start: usize,
    end: usize,
    out: &mut Structure,
) -> HashMap<String, (usize, Span)> {
    let mut labels: HashMap<String, (usize, Span)> = HashMap::new();
    for i in start..end {
        if program.block_flags(i) & flag::LABEL == 0 {
            continue;
        }
        let block = program.block(i);
        let Some(name) = block
            .root
            .find(NodeKind::Label)
            .and_then(|l| l.find(NodeKind::Name))
        else {
            continue;
        };
        let key = upper(block.text(name));
        match labels.get(&key) {
            Some(&(first, first_span)) => out.diagnostics.push(
                Diagnostic::error(name.span, format!("label {key} is defined twice"))
                    .with_help("jumps go to the first definition; rename one of them")
                    .with_related(first_span, format!("first defined on line {}", first + 1)),
            ),
            None => {
                labels.insert(key.clone(), (i, name.span));
                out.labels.push((key, i));
            }
        }
    }
    labels
}

/// A jump found in a block: direction, target name (upper case) and the target's span.
struct JumpSite {
    direction: Direction,
    keyword: String,
    target: String,
    span: Span,
}

fn jump_sites(program: &Program, i: usize) -> Vec<JumpSite> {
    let block = program.block(i);
    let mut sites = Vec::new();
    block.root.walk(&mut |n: &Node| match n.kind {
        NodeKind::Goto => {
            let Some(kw) = n.find(NodeKind::Keyword) else {
                return;
            };
            let keyword = upper(block.text(kw));
            let direction = match keyword.as_str() {
                "GOTOF" => Direction::Forward,
                "GOTOB" => Direction::Backward,
                "GOTOS" => return,
                _ => Direction::Both,
            };
            if let Some((target, span)) = n
                .significant()
                .nth(1)
                .and_then(|t| literal_target(&block, t))
            {
                sites.push(JumpSite {
                    direction,
                    keyword,
                    target,
                    span,
                });
            }
        }
        NodeKind::Repeat => {
            for name in n.children.iter().filter(|c| c.kind == NodeKind::Name) {
                let target = upper(block.text(name));
                sites.push(JumpSite {
                    direction: Direction::Backward,
                    keyword: "REPEAT".into(),
                    target,
                    span: name.span,
                });
            }
        }
        _ => {}
    });
    sites
}

/// A jump target known without running the program: a name (label or `N100`), a bare block number (`90`
/// means `N90`) or a string literal.
fn literal_target(block: &crate::syntax::Block<'_>, target: &Node) -> Option<(String, Span)> {
    match target.kind {
        NodeKind::Var if target.children.len() == 1 => {
            Some((upper(block.text(&target.children[0])), target.span))
        }
        NodeKind::Number => Some((format!("N{}", upper(block.text(target))), target.span)),
        NodeKind::Str => {
            let text = block.text(target);
            Some((upper(&text[1..text.len() - 1]), target.span))
        }
        _ => None,
    }
}

fn resolve_jumps(
    program: &Program,
    start: usize,
    end: usize,
    labels: &HashMap<String, (usize, Span)>,
    out: &mut Structure,
) {
    let mut block_numbers: Option<HashMap<String, Vec<usize>>> = None;
    for i in start..end {
        if program.block_flags(i) & flag::JUMP == 0 {
            continue;
        }
        for site in jump_sites(program, i) {
            let label = labels.get(&site.target).map(|&(at, _)| vec![at]);
            let candidates = match label {
                Some(at) => at,
                None if is_block_number(&site.target) => {
                    let numbers = block_numbers
                        .get_or_insert_with(|| collect_block_numbers(program, start, end));
                    numbers.get(&site.target).cloned().unwrap_or_default()
                }
                None => Vec::new(),
            };
            let forward = candidates.iter().copied().find(|&at| at > i);
            let backward = candidates.iter().copied().rfind(|&at| at <= i);
            let (to, other_way) = match site.direction {
                Direction::Forward => (forward, backward),
                Direction::Backward => (backward, forward),
                Direction::Both => (forward.or(backward), None),
            };
            let wrong_way = to.is_none() && other_way.is_some();
            let found = to.or(other_way);
            out.jumps.push(Jump {
                from: i,
                target: site.target.clone(),
                to,
            });
            let severity = if site.keyword == "GOTOC" {
                Severity::Warning
            } else {
                Severity::Error
            };
            match found {
                None => out.diagnostics.push(Diagnostic {
                    severity,
                    ..Diagnostic::error(site.span, format!("{} target {} is not defined", site.keyword, site.target))
                        .with_help("define the label as `NAME:` at the start of a block, or jump to an existing N number")
                }),
                Some(at) if wrong_way => {
                    let way = if site.direction == Direction::Forward { "forward" } else { "backward" };
                    out.diagnostics.push(Diagnostic {
                        severity,
                        ..Diagnostic::error(
                            site.span,
                            format!("{} searches {way}, but {} is on line {}", site.keyword, site.target, at + 1),
                        )
                        .with_help("use GOTO to search both directions, or the jump of the other direction")
                        .with_related(program.content_span(at), format!("{} is defined here", site.target))
                    });
                }
                Some(_) => {}
            }
        }
    }
}

fn is_block_number(name: &str) -> bool {
    name.len() > 1 && name.starts_with('N') && name[1..].bytes().all(|b| b.is_ascii_digit())
}

/// Blocks carrying each block number of a unit (`N100` may repeat), built only when a jump needs them; read
/// straight from the bytes, so no block tree is built.
fn collect_block_numbers(
    program: &Program,
    start: usize,
    end: usize,
) -> HashMap<String, Vec<usize>> {
    let mut numbers: HashMap<String, Vec<usize>> = HashMap::new();
    for i in start..end {
        if program.block_flags(i) & flag::TEXT != 0 {
            continue;
        }
        let content = program.content_span(i).slice(program.source());
        let content = content.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(content);
        if let Some(number) = leading_block_number(content) {
            numbers.entry(upper(number)).or_default().push(i);
        }
    }
    numbers
}
