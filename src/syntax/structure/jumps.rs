//! Jump targets and where a jump lands. The rule is the control's search: a jump looks for its label or
//! block number from the jump on, in its direction, and takes the first match — so a label may occur more
//! than once (`check` warns), and each jump goes to the nearest occurrence in its direction. The structure
//! check and the dry run both resolve jumps through [`Targets::destination`] and [`Targets::section`].

use std::collections::HashMap;
use std::ops::Range;

use super::{Structure, upper};
use crate::diagnostic::{Diagnostic, Severity};
use crate::source::Span;
use crate::syntax::{Block, Node, NodeKind, Program, flag, leading_block_number};

/// Where a jump looks for its target.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Search {
    /// GOTOF: towards the end of the program.
    Forward,
    /// GOTOB: towards the start, from the jump's own block on.
    Backward,
    /// GOTO, GOTOC: towards the end first, then towards the start.
    ForwardThenBackward,
    /// The start label of REPEAT / REPEATB: towards the start first, then towards the end.
    BackwardThenForward,
}

impl Search {
    /// The search of a jump keyword (any case): GOTOF, GOTOB, GOTO, GOTOC; `None` for others (GOTOS).
    pub fn of_jump(keyword: &str) -> Option<Search> {
        match keyword.to_ascii_uppercase().as_str() {
            "GOTOF" => Some(Search::Forward),
            "GOTOB" => Some(Search::Backward),
            "GOTO" | "GOTOC" => Some(Search::ForwardThenBackward),
            _ => None,
        }
    }
}

/// What a jump names: a label, or a block number (`N100`, `:100`, a bare `100`).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum JumpTarget {
    Label(String),
    Number(u64),
}

impl JumpTarget {
    /// The target a name (or string) denotes: `N` or `:` with digits only is a block number, anything else
    /// a label (upper-cased).
    pub fn named(name: &str) -> JumpTarget {
        let name = name.to_ascii_uppercase();
        let number = name
            .strip_prefix('N')
            .or_else(|| name.strip_prefix(':'))
            .filter(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
            .and_then(|d| d.parse().ok());
        number.map_or(JumpTarget::Label(name), JumpTarget::Number)
    }
}

impl std::fmt::Display for JumpTarget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            JumpTarget::Label(l) => f.write_str(l),
            JumpTarget::Number(n) => write!(f, "N{n}"),
        }
    }
}

/// The blocks that carry each label and block number, ascending.
#[derive(Debug, Clone, Default)]
pub struct Targets {
    labels: HashMap<String, Vec<usize>>,
    numbers: HashMap<u64, Vec<usize>>,
}

impl Targets {
    /// Adds a label (upper-cased) defined on `block`; blocks must come in ascending order.
    pub fn add_label(&mut self, name: String, block: usize) {
        self.labels.entry(name).or_default().push(block);
    }

    /// Adds a block number carried by `block`; blocks must come in ascending order.
    pub fn add_number(&mut self, number: u64, block: usize) {
        self.numbers.entry(number).or_default().push(block);
    }

    /// The blocks in `unit` that carry `target`, ascending.
    pub fn blocks(&self, target: &JumpTarget, unit: &Range<usize>) -> &[usize] {
        let all = match target {
            JumpTarget::Label(l) => self.labels.get(l),
            JumpTarget::Number(n) => self.numbers.get(n),
        };
        let all = all.map_or(&[][..], Vec::as_slice);
        let lo = all.partition_point(|&b| b < unit.start);
        let hi = all.partition_point(|&b| b < unit.end);
        &all[lo..hi]
    }

    /// The block a jump from block `from` of `unit` to `target` lands on: the nearest block carrying it in
    /// the search direction (towards the start the search begins at the jump's own block).
    pub fn destination(
        &self,
        search: Search,
        from: usize,
        target: &JumpTarget,
        unit: &Range<usize>,
    ) -> Option<usize> {
        let blocks = self.blocks(target, unit);
        let after = blocks.partition_point(|&b| b <= from);
        let forward = blocks.get(after).copied();
        let backward = after.checked_sub(1).map(|k| blocks[k]);
        match search {
            Search::Forward => forward,
            Search::Backward => backward,
            Search::ForwardThenBackward => forward.or(backward),
            Search::BackwardThenForward => backward.or(forward),
        }
    }

    /// The labelled blocks of `REPEAT start [end]` / `REPEATB start` at block `at`: the start label, searched
    /// towards the program start first, and the end label, searched from the start label towards the end
    /// (the start label's own block when both names are the same).
    pub fn section(
        &self,
        at: usize,
        start: &str,
        end: Option<&str>,
        unit: &Range<usize>,
    ) -> (Option<usize>, Option<usize>) {
        let label = |name: &str| JumpTarget::Label(name.to_string());
        let first = self.destination(Search::BackwardThenForward, at, &label(start), unit);
        let last = match (first, end) {
            (Some(first), Some(end)) if end == start => Some(first),
            (Some(first), Some(end)) => self.destination(Search::Forward, first, &label(end), unit),
            _ => None,
        };
        (first, last)
    }
}

/// The labels of a unit: every definition goes into `out.labels`; a name defined again gets a warning.
pub(super) fn collect_labels(
    program: &Program,
    unit: &Range<usize>,
    out: &mut Structure,
) -> Targets {
    let mut targets = Targets::default();
    let mut first: HashMap<String, (usize, Span)> = HashMap::new();
    for i in unit.clone() {
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
        match first.get(&key) {
            Some(&(at, span)) => out.diagnostics.push(
                Diagnostic::warning(name.span, format!("label {key} is defined again"))
                    .with_help(
                        "the control jumps to the nearest one in the jump's direction (GOTOF towards \
                         the end, GOTOB towards the start, GOTO forward first); rename one if that is \
                         not meant",
                    )
                    .with_related(span, format!("first defined on line {}", at + 1)),
            ),
            None => {
                first.insert(key.clone(), (i, name.span));
            }
        }
        targets.add_label(key.clone(), i);
        out.labels.push((key, i));
    }
    targets
}

/// One literal jump of a block: keyword, search, target and where the target is written.
struct Site {
    keyword: String,
    search: Search,
    target: String,
    span: Span,
}

/// The literal jumps of block `i` (`GOTOx` with a name, number or string, CASE arms) and its section
/// repetition (`REPEAT a [b]`) if any.
fn sites(program: &Program, i: usize) -> (Vec<Site>, Vec<(String, Span)>) {
    let block = program.block(i);
    let mut jumps = Vec::new();
    let mut section = Vec::new();
    block.root.walk(&mut |n: &Node| match n.kind {
        NodeKind::Goto => {
            let Some(kw) = n.find(NodeKind::Keyword) else {
                return;
            };
            let keyword = upper(block.text(kw));
            let Some(search) = Search::of_jump(&keyword) else {
                return;
            };
            if let Some((target, span)) = n
                .significant()
                .nth(1)
                .and_then(|t| literal_target(&block, t))
            {
                jumps.push(Site {
                    keyword,
                    search,
                    target,
                    span,
                });
            }
        }
        NodeKind::Repeat => {
            let names = n.children.iter().filter(|c| c.kind == NodeKind::Name);
            section.extend(names.map(|name| (upper(block.text(name)), name.span)));
        }
        _ => {}
    });
    (jumps, section)
}

/// A jump target known without running the program: a name (label or `N100`), a bare block number (`90`
/// means `N90`) or a string literal.
fn literal_target(block: &Block<'_>, target: &Node) -> Option<(String, Span)> {
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

/// Resolves every literal jump and section repetition of a unit and reports those that find no target.
pub(super) fn resolve_jumps(
    program: &Program,
    unit: &Range<usize>,
    targets: &mut Targets,
    out: &mut Structure,
) {
    let mut numbers_read = false;
    for i in unit.clone() {
        if program.block_flags(i) & flag::JUMP == 0 {
            continue;
        }
        let (jumps, section) = sites(program, i);
        if !numbers_read && jumps.iter().any(|s| is_number(&s.target)) {
            add_block_numbers(program, unit, targets);
            numbers_read = true;
        }
        for site in jumps {
            let target = JumpTarget::named(&site.target);
            let to = targets.destination(site.search, i, &target, unit);
            out.jumps.push(super::Jump {
                from: i,
                target: site.target.clone(),
                to,
            });
            if to.is_none() {
                out.diagnostics.push(jump_not_found(
                    program,
                    &site,
                    targets.blocks(&target, unit),
                ));
            }
        }
        resolve_section(program, unit, targets, i, &section, out);
    }
}

/// The labels of `REPEAT start [end]` / `REPEATB start` (`names`) at block `i`.
fn resolve_section(
    program: &Program,
    unit: &Range<usize>,
    targets: &Targets,
    i: usize,
    names: &[(String, Span)],
    out: &mut Structure,
) {
    let Some((start, start_span)) = names.first() else {
        return;
    };
    let end = names.get(1);
    let (first, last) = targets.section(i, start, end.map(|e| e.0.as_str()), unit);
    out.jumps.push(super::Jump {
        from: i,
        target: start.clone(),
        to: first,
    });
    if first.is_none() {
        out.diagnostics
            .push(not_defined("REPEAT", start, *start_span));
    }
    let Some((end, end_span)) = end else {
        return;
    };
    out.jumps.push(super::Jump {
        from: i,
        target: end.clone(),
        to: last,
    });
    let defined = targets.blocks(&JumpTarget::Label(end.clone()), unit);
    match (first, last, defined.first()) {
        (_, None, None) => out.diagnostics.push(not_defined("REPEAT", end, *end_span)),
        (Some(first), None, Some(&at)) => out.diagnostics.push(
            Diagnostic::error(
                *end_span,
                format!(
                    "REPEAT's end label {end} is not after {start} (line {})",
                    first + 1
                ),
            )
            .with_help("the section runs from the start label down to the end label")
            .with_related(program.content_span(at), format!("{end} is defined here")),
        ),
        // Found, or the start label is missing (reported above).
        _ => {}
    }
}

fn not_defined(keyword: &str, target: &str, span: Span) -> Diagnostic {
    Diagnostic::error(span, format!("{keyword} target {target} is not defined")).with_help(
        "define the label as `NAME:` at the start of a block, or jump to an existing N number",
    )
}

/// A jump that finds nothing in its direction: an error, or a warning for GOTOC (the control goes on with
/// the next block). `defined` are the blocks that carry the target elsewhere in the unit.
fn jump_not_found(program: &Program, site: &Site, defined: &[usize]) -> Diagnostic {
    let d = match defined.first() {
        None => not_defined(&site.keyword, &site.target, site.span),
        Some(&at) => {
            let way = if site.search == Search::Forward {
                "forward"
            } else {
                "backward"
            };
            Diagnostic::error(
                site.span,
                format!(
                    "{} searches {way}, but {} is on line {}",
                    site.keyword,
                    site.target,
                    at + 1
                ),
            )
            .with_help("use GOTO to search both directions, or the jump of the other direction")
            .with_related(
                program.content_span(at),
                format!("{} is defined here", site.target),
            )
        }
    };
    let severity = if site.keyword == "GOTOC" {
        Severity::Warning
    } else {
        Severity::Error
    };
    Diagnostic { severity, ..d }
}

fn is_number(target: &str) -> bool {
    matches!(JumpTarget::named(target), JumpTarget::Number(_))
}

/// The block numbers of a unit, read only when a jump names one; straight from the bytes, so no block tree
/// is built.
fn add_block_numbers(program: &Program, unit: &Range<usize>, targets: &mut Targets) {
    for i in unit.clone() {
        if program.block_flags(i) & flag::TEXT != 0 {
            continue;
        }
        let content = program.content_span(i).slice(program.source());
        let content = content.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(content);
        if let Some(number) = leading_block_number(content) {
            targets.add_number(number, i);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn targets(labels: &[(&str, usize)]) -> Targets {
        let mut t = Targets::default();
        for &(name, block) in labels {
            t.add_label(name.into(), block);
        }
        t
    }

    #[test]
    fn each_search_takes_the_nearest_target_in_its_direction() {
        let t = targets(&[("A", 2), ("A", 5), ("A", 9)]);
        let a = JumpTarget::Label("A".into());
        let unit = 0..20;
        let land = |search, from| t.destination(search, from, &a, &unit);
        assert_eq!(land(Search::Forward, 5), Some(9));
        assert_eq!(land(Search::Forward, 4), Some(5));
        assert_eq!(land(Search::Forward, 9), None);
        assert_eq!(land(Search::Backward, 5), Some(5), "the jump's own block");
        assert_eq!(land(Search::Backward, 8), Some(5));
        assert_eq!(land(Search::Backward, 1), None);
        assert_eq!(land(Search::ForwardThenBackward, 6), Some(9));
        assert_eq!(land(Search::ForwardThenBackward, 12), Some(9));
        assert_eq!(land(Search::BackwardThenForward, 1), Some(2));
        assert_eq!(land(Search::BackwardThenForward, 7), Some(5));
        assert_eq!(
            t.destination(Search::ForwardThenBackward, 6, &a, &(3..8)),
            Some(5),
            "only the unit's blocks"
        );
    }

    #[test]
    fn sections_search_the_start_backward_first_and_the_end_after_it() {
        let t = targets(&[("S", 1), ("E", 3), ("S", 6), ("E", 8)]);
        let unit = 0..20;
        assert_eq!(t.section(10, "S", Some("E"), &unit), (Some(6), Some(8)));
        assert_eq!(t.section(4, "S", Some("E"), &unit), (Some(1), Some(3)));
        assert_eq!(t.section(0, "S", None, &unit), (Some(1), None));
        assert_eq!(t.section(7, "S", Some("S"), &unit), (Some(6), Some(6)));
        assert_eq!(t.section(10, "X", Some("E"), &unit), (None, None));
    }

    #[test]
    fn names_of_block_numbers_and_labels() {
        assert_eq!(JumpTarget::named("n100"), JumpTarget::Number(100));
        assert_eq!(JumpTarget::named(":20"), JumpTarget::Number(20));
        assert_eq!(JumpTarget::named("N1A"), JumpTarget::Label("N1A".into()));
        assert_eq!(JumpTarget::named("n"), JumpTarget::Label("N".into()));
        assert_eq!(JumpTarget::Number(7).to_string(), "N7");
    }
}
