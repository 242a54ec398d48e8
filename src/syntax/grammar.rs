//! The full block grammar (nom over the block's bytes). It builds the lossless tree of one block, reports
//! what it could not parse, and classifies the block for the structure pass. `grammar/sinumerik.ebnf` is the
//! readable form of what this accepts; node kinds are its rule names.

use nom::Parser;
use nom::bytes::complete::tag;

use super::block_kind::{BlockKind, flag};
use super::keyword::{Kw, keyword};
use super::lexeme::{
    PErr, R, bit_literal, blanks, block_number_at, fail, ident, is_control, is_ident_char,
    signed_number, skip_blanks, skip_level_len, string, sysvar_name, unsigned_number, word,
};
use super::odd_bytes::{ControlCharacters, name_odd_bytes, utf8_len};
use super::tree::{Node, NodeKind as K};
use crate::diagnostic::Diagnostic;
use crate::source::Span;

pub(crate) struct ParsedBlock {
    pub tree: Node,
    pub diagnostics: Vec<Diagnostic>,
    pub kind: BlockKind,
    pub flags: u8,
}

/// Parses the block whose parsable content is `content` (the BOM of line 1 excluded) and whose terminator is
/// `terminator`. From `filler` on, `src` holds only DOS end-of-file filler (see [`super::odd_bytes::eof_filler`]).
pub(crate) fn parse_block(
    src: &[u8],
    content: Span,
    terminator: Span,
    filler: usize,
) -> ParsedBlock {
    let line = content.slice(src);
    let cx = Cx {
        base: content.start,
        len: line.len(),
        depth: std::cell::Cell::new(0),
    };
    let mut children = Vec::new();
    if content.start == 3 && src.starts_with(b"\xEF\xBB\xBF") {
        children.push(Node::leaf(K::Bom, Span::new(0, 3)));
    }
    let mut diagnostics = Vec::new();
    cx.block_body(line, &mut children, &mut diagnostics);
    children.push(Node::leaf(K::Newline, terminator));
    let tree = Node::with_children(K::Block, children);
    if line.iter().any(|&b| is_control(b)) {
        ControlCharacters::new(src, filler).report(&tree, &mut diagnostics);
    }
    let (kind, flags) = classify(src, &tree, &mut diagnostics);
    ParsedBlock {
        tree,
        diagnostics,
        kind,
        flags,
    }
}

/// The block's control role and flags, from its statements. A second control statement in the block (`ELSE
/// IF …`) is reported: a block has one role, as a block has one control statement on the control.
fn classify(src: &[u8], tree: &Node, diags: &mut Vec<Diagnostic>) -> (BlockKind, u8) {
    let mut flags = 0;
    for n in tree.significant() {
        flags |= match n.kind {
            K::Label => flag::LABEL,
            K::Goto | K::Case => flag::JUMP,
            K::Repeat if n.find(K::Name).is_some() => flag::JUMP,
            K::Error => flag::ERROR,
            _ => 0,
        };
    }
    let roles = control_statements(src, tree);
    let kind = roles.first().map_or(BlockKind::Plain, |r| r.0);
    // `IF cond GOTOF label` is a conditional jump, not the start of an IF … ENDIF (several may share a block).
    if flags & flag::JUMP != 0 && roles.iter().all(|r| r.0 == BlockKind::If) {
        return (BlockKind::Plain, flags);
    }
    if let [(first, _), (second, node), ..] = roles[..] {
        let (first, second) = (first.keyword(), second.keyword());
        diags.push(
            Diagnostic::error(
                node.span,
                format!(
                    "{second} after {first} in the same block: a block holds one control statement"
                ),
            )
            .with_help(format!("put {second} on a line of its own")),
        );
    }
    (kind, flags)
}

/// The statements of a block that give it a control role (IF, ELSE, WHILE, a `%` header …), in order; the
/// first decides the role. In `WHEN cond DO action ELSE action` the ELSE is the synchronized action's.
pub(crate) fn control_statements<'n>(src: &[u8], tree: &'n Node) -> Vec<(BlockKind, &'n Node)> {
    let mut roles = Vec::new();
    let mut action_else = false;
    for n in tree.significant() {
        let role = match n.kind {
            K::SyncCondition => {
                action_else = true;
                None
            }
            K::Header => Some(BlockKind::Header),
            K::Repeat if n.find(K::Name).is_none() => Some(BlockKind::Repeat),
            K::If => Some(BlockKind::If),
            K::While => Some(BlockKind::While),
            K::Until => Some(BlockKind::Until),
            K::For => Some(BlockKind::For),
            K::ControlKeyword => {
                n.find(K::Keyword)
                    .and_then(|k| match keyword(k.span.slice(src)) {
                        Some(Kw::Else) if action_else => {
                            action_else = false;
                            None
                        }
                        Some(Kw::Else) => Some(BlockKind::Else),
                        Some(Kw::EndIf) => Some(BlockKind::EndIf),
                        Some(Kw::EndWhile) => Some(BlockKind::EndWhile),
                        Some(Kw::EndFor) => Some(BlockKind::EndFor),
                        Some(Kw::Loop) => Some(BlockKind::Loop),
                        Some(Kw::EndLoop) => Some(BlockKind::EndLoop),
                        _ => None,
                    })
            }
            _ => None,
        };
        if let Some(role) = role {
            roles.push((role, n));
        }
    }
    roles
}

/// Turns suffixes of the block's content into absolute spans, and bounds expression nesting.
struct Cx {
    base: usize,
    len: usize,
    depth: std::cell::Cell<usize>,
}

/// Deepest expression: parentheses, calls, indices and prefix operators each count one level, and so does
/// each binary operator in a row (it wraps the tree once more). Keeps hostile input (a line of 100 000 `(`,
/// `1+1+…` with 200 000 terms) from exhausting the stack of the parser and of everything that walks the tree
/// (the tree is at most about twice as deep). A block of the control's 512 characters stays below it.
const MAX_DEPTH: usize = 256;

/// What a parse failure beyond [`MAX_DEPTH`] expected; the diagnostic words it on its own.
const TOO_DEEP: &str = "a less deeply nested expression";

impl Cx {
    fn pos(&self, i: &[u8]) -> usize {
        self.base + self.len - i.len()
    }

    fn leaf(&self, kind: K, from: &[u8], to: &[u8]) -> Node {
        Node::leaf(kind, Span::new(self.pos(from), self.pos(to)))
    }

    /// Pushes blanks (if any) as a trivia leaf.
    fn ws<'a>(&self, i: &'a [u8], out: &mut Vec<Node>) -> &'a [u8] {
        match blanks(i) {
            Ok((rest, _)) => {
                out.push(self.leaf(K::Trivia, i, rest));
                rest
            }
            Err(_) => i,
        }
    }

    /// Consumes `len` bytes as a leaf of `kind`.
    fn take<'a>(&self, kind: K, i: &'a [u8], len: usize, out: &mut Vec<Node>) -> &'a [u8] {
        out.push(self.leaf(kind, i, &i[len..]));
        &i[len..]
    }

    /// Requires the punctuation `p` (after optional blanks).
    fn punct<'a>(
        &self,
        i: &'a [u8],
        p: &'static str,
        expected: &'static str,
        out: &mut Vec<Node>,
    ) -> R<'a, ()> {
        let j = self.ws(i, out);
        match tag::<_, _, PErr>(p.as_bytes()).parse(j) {
            Ok((rest, _)) => {
                out.push(self.leaf(K::Punct, j, rest));
                Ok((rest, ()))
            }
            Err(_) => {
                if j.len() < i.len() {
                    out.pop();
                }
                fail(j, expected)
            }
        }
    }

    /// Requires the keyword `kw` (after optional blanks).
    fn keyword_leaf<'a>(
        &self,
        i: &'a [u8],
        kw: Kw,
        expected: &'static str,
        out: &mut Vec<Node>,
    ) -> R<'a, ()> {
        let j = self.ws(i, out);
        match ident(j) {
            Ok((rest, name)) if keyword(name) == Some(kw) => {
                out.push(self.leaf(K::Keyword, j, rest));
                Ok((rest, ()))
            }
            _ => fail(j, expected),
        }
    }

    fn block_body(&self, line: &[u8], out: &mut Vec<Node>, diags: &mut Vec<Diagnostic>) {
        let mut i = self.ws(line, out);
        if i.first() == Some(&b'%') {
            let header = vec![self.leaf(K::Text, i, &[])];
            out.push(Node::with_children(K::Header, header));
            return;
        }
        let skip = skip_level_len(i);
        if skip > 0 {
            let mut parts = Vec::new();
            i = self.take(K::Punct, i, skip, &mut parts);
            out.push(Node::with_children(K::Skip, parts));
            i = self.ws(i, out);
        }
        if let Some((rest, node)) = self.block_number(i) {
            out.push(node);
            i = self.ws(rest, out);
        }
        if let Some((rest, node)) = self.label(i) {
            let name = &i[..node.children[0].span.len()];
            let leading_ok = name.len() >= 2
                && name[..2]
                    .iter()
                    .all(|&b| b.is_ascii_alphabetic() || b == b'_');
            if !leading_ok || name.len() > 32 {
                let span = node.children[0].span;
                diags.push(
                    Diagnostic::error(
                        span,
                        "label names have 2 to 32 characters, the first two letters or `_`",
                    )
                    .with_help("rename the label and the jumps to it"),
                );
            }
            out.push(node);
            i = rest;
        }
        loop {
            i = self.ws(i, out);
            match i.first() {
                None => return,
                Some(b';') => {
                    out.push(self.leaf(K::Comment, i, &[]));
                    return;
                }
                Some(_) => match self.statement(i) {
                    Ok((rest, node)) => {
                        out.push(node);
                        i = rest;
                    }
                    Err(e) => {
                        let e = match e {
                            nom::Err::Error(e) | nom::Err::Failure(e) => e,
                            nom::Err::Incomplete(_) => PErr {
                                rest: i.len(),
                                expected: "",
                            },
                        };
                        self.error_rest(i, e, out, diags);
                        return;
                    }
                },
            }
        }
    }

    /// Keeps the unparsable rest of the line (up to a comment) as an error node and reports it.
    fn error_rest(&self, i: &[u8], e: PErr, out: &mut Vec<Node>, diags: &mut Vec<Diagnostic>) {
        let at = &i[i.len() - e.rest.min(i.len())..];
        let comment = comment_start(i);
        let comment = &i[comment..];
        out.push(Node::with_children(
            K::Error,
            vec![self.leaf(K::Text, i, comment)],
        ));
        if !comment.is_empty() {
            out.push(self.leaf(K::Comment, comment, &[]));
        }
        let start = self.pos(at);
        if e.expected == TOO_DEEP {
            let span = Span::new(start, start + utf8_len(at));
            diags.push(
                Diagnostic::error(
                    span,
                    format!("expression nested deeper than {MAX_DEPTH} levels"),
                )
                .with_help("split it over several assignments (the control takes 512 characters per block)"),
            );
            return;
        }
        let expected = if e.expected.is_empty() {
            "a word, assignment, call or keyword"
        } else {
            e.expected
        };
        if let Some((len, what, help)) = name_odd_bytes(at) {
            let span = Span::new(start, start + len);
            let message = format!("expected {expected}, found {what}");
            diags.push(Diagnostic::error(span, message).with_help(help));
            return;
        }
        let found = match at.first() {
            None => "end of line".to_string(),
            Some(_) => {
                let n = at
                    .iter()
                    .position(|&b| b == b' ' || b == b';')
                    .unwrap_or(at.len())
                    .clamp(1, 16);
                // Quotes stay as typed (`escape_ascii` writes `\"`); only bytes a terminal cannot show
                // are escaped.
                let shown: String = at[..n]
                    .iter()
                    .map(|&b| match b {
                        b' '..=b'~' => char::from(b).to_string(),
                        _ => b.escape_ascii().to_string(),
                    })
                    .collect();
                format!("`{shown}`")
            }
        };
        let span = Span::new(start, start + utf8_len(at));
        let general = if at.first() == Some(&b'(') && i.first() == Some(&b'(') {
            "`( … )` is not a comment in Sinumerik programs; start comments with `;`"
        } else if at.first() == Some(&b'"') {
            "strings are closed by `\"` on the same line"
        } else if at.starts_with(b"=<") {
            "the relational operators are == <> < > <= >=: write `<=`"
        } else if at.starts_with(b"=>") {
            "the relational operators are == <> < > <= >=: write `>=`"
        } else if at.first() == Some(&b'$') && e.expected == "a variable name" {
            "`$` names are the control's system variables; DEF declares a user variable, whose name starts with a letter or `_`"
        } else {
            "the accepted forms are listed in grammar/sinumerik.ebnf"
        };
        let help = empty_assignment_help(&i[..i.len() - at.len()], at)
            .unwrap_or_else(|| general.to_string());
        diags.push(
            Diagnostic::error(span, format!("expected {expected}, found {found}")).with_help(help),
        );
    }

    /// `N10`, `N 10` or `:10` at the start of a block.
    fn block_number<'a>(&self, i: &'a [u8]) -> Option<(&'a [u8], Node)> {
        let (digits, end) = block_number_at(i)?;
        Some((
            &i[end..],
            self.address_and_number(K::BlockNumber, i, digits, end),
        ))
    }

    /// A node of `kind` from the address letter at the start of `i`, the blanks up to `value` (if any) and
    /// the number from there to `end`.
    fn address_and_number(&self, kind: K, i: &[u8], value: usize, end: usize) -> Node {
        let mut parts = vec![self.leaf(K::Address, i, &i[1..])];
        if value > 1 {
            parts.push(self.leaf(K::Trivia, &i[1..], &i[value..]));
        }
        parts.push(self.leaf(K::Number, &i[value..], &i[end..]));
        Node::with_children(kind, parts)
    }

    /// `NAME:` (not a keyword, not `NAME:=`).
    fn label<'a>(&self, i: &'a [u8]) -> Option<(&'a [u8], Node)> {
        let (rest, name) = ident(i).ok()?;
        if rest.first() != Some(&b':') || keyword(name).is_some() {
            return None;
        }
        let parts = vec![
            self.leaf(K::Name, i, rest),
            self.leaf(K::Punct, rest, &rest[1..]),
        ];
        Some((&rest[1..], Node::with_children(K::Label, parts)))
    }

    fn statement<'a>(&self, i: &'a [u8]) -> R<'a, Node> {
        if let Some((value, end)) = word(i) {
            return Ok((&i[end..], self.address_and_number(K::Word, i, value, end)));
        }
        if i.first() == Some(&b'$') {
            return self.assignment(i);
        }
        let (after, name) = ident(i).map_err(|_| {
            nom::Err::Error(PErr {
                rest: i.len(),
                expected: "",
            })
        })?;
        match keyword(name) {
            Some(kw) => self.keyword_statement(kw, i, after),
            None if skip_blanks(after).first() == Some(&b'(') => {
                let mut parts = vec![self.leaf(K::Name, i, after)];
                let after = self.ws(after, &mut parts);
                let (rest, args) = self.args(after)?;
                parts.push(args);
                Ok((rest, Node::with_children(K::Call, parts)))
            }
            None => {
                let (rest, target) = self.var_ref(i)?;
                let next = skip_blanks(rest);
                if next.first() == Some(&b'=') || target.find(K::Index).is_some() {
                    self.assignment(i)
                } else {
                    Ok((
                        rest,
                        Node::with_children(K::Command, vec![self.leaf(K::Name, i, after)]),
                    ))
                }
            }
        }
    }

    /// `target = expr`, or `target = (a, b …)` for the targets whose value is a list.
    fn assignment<'a>(&self, i: &'a [u8]) -> R<'a, Node> {
        let list = ident(i).is_ok_and(|(_, name)| {
            LIST_TARGETS
                .iter()
                .any(|target| name.eq_ignore_ascii_case(target))
        });
        let (i, target) = self.var_ref(i)?;
        let mut parts = vec![target];
        let (i, ()) = self.punct(i, "=", "`=`", &mut parts)?;
        let i = self.ws(i, &mut parts);
        let (rest, value) = if list && i.first() == Some(&b'(') {
            self.args(i)?
        } else {
            self.expr(i)?
        };
        parts.push(value);
        Ok((rest, Node::with_children(K::Assign, parts)))
    }

    /// What can be assigned: `R1`, `R[i]`, `$P_UIFR[1,X,TR]`, `NAME`, `NAME[i,j]`.
    fn var_ref<'a>(&self, i: &'a [u8]) -> R<'a, Node> {
        let (after, name) = match i.first() {
            Some(b'$') => sysvar_name(i)?,
            _ => ident(i)?,
        };
        let kind = if name.first() == Some(&b'$') {
            K::SysVar
        } else if is_rparam(name)
            || (name.eq_ignore_ascii_case(b"R") && skip_blanks(after).first() == Some(&b'['))
        {
            K::RParam
        } else {
            K::Var
        };
        let mut parts = vec![self.leaf(K::Name, i, after)];
        let rest = self.opt_index(after, &mut parts)?;
        Ok((rest, Node::with_children(kind, parts)))
    }

    fn keyword_statement<'a>(&self, kw: Kw, i: &'a [u8], after: &'a [u8]) -> R<'a, Node> {
        let mut parts = vec![self.leaf(K::Keyword, i, after)];
        let (rest, kind) = match kw {
            Kw::If | Kw::While | Kw::Until => {
                let j = self.ws(after, &mut parts);
                let (rest, cond) = self.expr(j)?;
                parts.push(cond);
                let kind = match kw {
                    Kw::If => K::If,
                    Kw::While => K::While,
                    _ => K::Until,
                };
                (rest, kind)
            }
            Kw::Else | Kw::EndIf | Kw::EndWhile | Kw::EndFor | Kw::Loop | Kw::EndLoop => {
                (after, K::ControlKeyword)
            }
            Kw::For => {
                let j = self.ws(after, &mut parts);
                let (j, var) = self
                    .var_ref(j)
                    .map_err(|_| expected_at(j, "a loop variable"))?;
                parts.push(var);
                let (j, ()) = self.punct(j, "=", "`=`", &mut parts)?;
                let j = self.ws(j, &mut parts);
                let (j, from) = self.expr(j)?;
                parts.push(from);
                let (j, ()) = self.keyword_leaf(j, Kw::To, "`TO`", &mut parts)?;
                let j = self.ws(j, &mut parts);
                let (rest, to) = self.expr(j)?;
                parts.push(to);
                (rest, K::For)
            }
            Kw::Repeat => {
                let single = i[..i.len() - after.len()].eq_ignore_ascii_case(b"REPEATB");
                (self.repeat_labels(after, single, &mut parts)?, K::Repeat)
            }
            Kw::Case => (self.case(after, &mut parts)?.0, K::Case),
            Kw::Goto => {
                let j = self.ws(after, &mut parts);
                let (rest, target) = self.expr(j).map_err(|_| expected_at(j, "a jump target"))?;
                parts.push(target);
                (rest, K::Goto)
            }
            Kw::GotoS => (after, K::Goto),
            Kw::Def => (self.def(after, &mut parts)?.0, K::Def),
            Kw::Proc => (self.proc(after, &mut parts)?.0, K::Proc),
            Kw::Extern => (self.extern_decl(after, &mut parts)?.0, K::Extern),
            Kw::Define => (self.define(after, &mut parts)?.0, K::Define),
            Kw::Sync => {
                let j = self.ws(after, &mut parts);
                let (j, cond) = self.expr(j)?;
                parts.push(cond);
                let (rest, ()) = self.keyword_leaf(j, Kw::Do, "`DO`", &mut parts)?;
                (rest, K::SyncCondition)
            }
            Kw::Do => (after, K::SyncCondition),
            Kw::ProgCall => (self.program_call(after, &mut parts)?.0, K::ProgramCall),
            Kw::Redef => (self.redef(after, &mut parts)?.0, K::Redef),
            _ => return fail(i, "a statement (this keyword only continues one)"),
        };
        Ok((rest, Node::with_children(kind, parts)))
    }

    /// `REPEAT` alone opens a loop; `REPEAT a [b]` repeats a section, `REPEATB a` (`single`) the labelled block
    /// (`P=n` follows as an assignment).
    fn repeat_labels<'a>(
        &self,
        mut i: &'a [u8],
        single: bool,
        parts: &mut Vec<Node>,
    ) -> Result<&'a [u8], nom::Err<PErr>> {
        let (mut names, most) = (0, if single { 1 } else { 2 });
        loop {
            let mut trivia = Vec::new();
            let j = self.ws(i, &mut trivia);
            match ident(j) {
                Ok((rest, name))
                    if keyword(name).is_none()
                        && skip_blanks(rest).first() != Some(&b'=')
                        && !matches!(rest.first(), Some(b'(' | b'[')) =>
                {
                    if names == most {
                        let expected = if single {
                            "`P=` or the end of the block (REPEATB takes one label)"
                        } else {
                            "`P=` or the end of the block (REPEAT takes two labels)"
                        };
                        return Err(expected_at(j, expected));
                    }
                    parts.append(&mut trivia);
                    parts.push(self.leaf(K::Name, j, rest));
                    i = rest;
                    names += 1;
                }
                _ => return Ok(i),
            }
        }
    }

    /// `CASE expr OF { (const | DEFAULT) GOTOx target }`.
    fn case<'a>(&self, i: &'a [u8], parts: &mut Vec<Node>) -> R<'a, &'a [u8]> {
        let j = self.ws(i, parts);
        let (j, selector) = self.expr(j)?;
        parts.push(selector);
        let (mut i, ()) = self.keyword_leaf(j, Kw::Of, "`OF`", parts)?;
        loop {
            let mut trivia = Vec::new();
            let j = self.ws(i, &mut trivia);
            if j.is_empty() || j[0] == b';' {
                return Ok((i, i));
            }
            parts.append(&mut trivia);
            let mut arm = Vec::new();
            let j = match ident(j) {
                Ok((rest, name)) if keyword(name) == Some(Kw::Default) => {
                    arm.push(self.leaf(K::Keyword, j, rest));
                    rest
                }
                _ => {
                    let (rest, value) = self.expr(j)?;
                    arm.push(value);
                    rest
                }
            };
            let j = self.ws(j, &mut arm);
            let (after, name) =
                ident(j).map_err(|_| expected_at(j, "a GOTO after the CASE value"))?;
            if keyword(name) != Some(Kw::Goto) {
                return fail(j, "a GOTO after the CASE value");
            }
            // The target is a name, number or string, or strings joined with `<<`, not any expression: in
            // `GOTO LBL1-2 GOTO LBL2` the `-2` is the next arm's value.
            let mut goto = vec![self.leaf(K::Keyword, j, after)];
            let t = self.ws(after, &mut goto);
            let (rest, target) = self
                .nested(t, |cx| cx.binary(t, 0, JOINED))
                .map_err(|e| relabel(e, t, "a jump target"))?;
            goto.push(target);
            arm.push(Node::with_children(K::Goto, goto));
            parts.push(Node::with_children(K::CaseArm, arm));
            i = rest;
        }
    }

    /// `DEF {modifier} type [[len]] declarator {, declarator}`.
    fn def<'a>(&self, i: &'a [u8], parts: &mut Vec<Node>) -> R<'a, &'a [u8]> {
        let mut i = self.attributes(i, parts);
        let j = self.ws(i, parts);
        let (after, name) = ident(j)?;
        if keyword(name) != Some(Kw::Type) {
            return fail(j, "a type (REAL, INT, BOOL, CHAR, STRING, AXIS, FRAME)");
        }
        parts.push(self.leaf(K::Keyword, j, after));
        i = after;
        i = self.opt_index(i, parts)?;
        i = self.attributes(i, parts);
        loop {
            let j = self.ws(i, parts);
            let mut decl = Vec::new();
            let (rest, _) = ident(j).map_err(|_| expected_at(j, "a variable name"))?;
            decl.push(self.leaf(K::Name, j, rest));
            let k = self.opt_index(rest, &mut decl)?;
            let k = self.opt_value(k, &mut decl)?;
            parts.push(Node::with_children(K::Declarator, decl));
            i = k;
            if skip_blanks(i).first() != Some(&b',') {
                return Ok((i, i));
            }
            let (r, ()) = self.punct(i, ",", "`,`", parts)?;
            i = r;
        }
    }

    /// Storage and access attributes of DEF: `NCK CHAN LUD GUD PRLOC SYNR SYNW SYNRW` and the valued
    /// `APR APW PHU LLI ULI n`.
    fn attributes<'a>(&self, mut i: &'a [u8], parts: &mut Vec<Node>) -> &'a [u8] {
        loop {
            let mut more = Vec::new();
            let j = self.ws(i, &mut more);
            let Ok((rest, name)) = ident(j) else { return i };
            let valued = match keyword(name) {
                Some(Kw::Attr) => false,
                Some(Kw::ValuedAttr) => true,
                _ => return i,
            };
            more.push(self.leaf(K::Keyword, j, rest));
            let mut k = rest;
            if valued {
                let v = self.ws(k, &mut more);
                match signed_number(v) {
                    Ok((r, _)) => {
                        more.push(self.leaf(K::Number, v, r));
                        k = r;
                    }
                    Err(_) => return i,
                }
            }
            parts.append(&mut more);
            i = k;
        }
    }

    /// `PROC name [(param {, param})] {attribute}`.
    fn proc<'a>(&self, i: &'a [u8], parts: &mut Vec<Node>) -> R<'a, &'a [u8]> {
        let j = self.ws(i, parts);
        let (mut i, _) = ident(j).map_err(|_| expected_at(j, "a program name"))?;
        parts.push(self.leaf(K::Name, j, i));
        if skip_blanks(i).first() == Some(&b'(') {
            i = self.ws(i, parts);
            let (rest, params) = self.param_list(i, true)?;
            parts.push(params);
            i = rest;
        }
        loop {
            let mut attr = Vec::new();
            let j = self.ws(i, &mut attr);
            match ident(j) {
                Ok((rest, _)) => {
                    parts.append(&mut attr);
                    parts.push(self.leaf(K::Name, j, rest));
                    i = rest;
                }
                Err(_) => return Ok((i, i)),
            }
        }
    }

    /// `EXTERN name(type {, type})`.
    fn extern_decl<'a>(&self, i: &'a [u8], parts: &mut Vec<Node>) -> R<'a, &'a [u8]> {
        let j = self.ws(i, parts);
        let (i, _) = ident(j).map_err(|_| expected_at(j, "a program name"))?;
        parts.push(self.leaf(K::Name, j, i));
        let mut i = i;
        if skip_blanks(i).first() == Some(&b'(') {
            i = self.ws(i, parts);
            let (rest, params) = self.param_list(i, false)?;
            parts.push(params);
            i = rest;
        }
        Ok((i, i))
    }

    /// `( [param] {, [param]} )` where param = `[VAR] type [[dims]] [name [[dims]]]` (names only in PROC).
    fn param_list<'a>(&self, i: &'a [u8], named: bool) -> R<'a, Node> {
        let mut parts = Vec::new();
        let mut i = self.take(K::Punct, i, 1, &mut parts);
        loop {
            i = self.ws(i, &mut parts);
            if let Some(b')') = i.first() {
                let rest = self.take(K::Punct, i, 1, &mut parts);
                return Ok((rest, Node::with_children(K::Args, parts)));
            }
            if i.first() != Some(&b',') {
                let (rest, param) = self.param(i, named)?;
                parts.push(param);
                i = self.ws(rest, &mut parts);
            }
            match i.first() {
                Some(b',') => i = self.take(K::Punct, i, 1, &mut parts),
                Some(b')') => {}
                _ => return fail(i, "`,` or `)`"),
            }
        }
    }

    fn param<'a>(&self, i: &'a [u8], named: bool) -> R<'a, Node> {
        let mut parts = Vec::new();
        let (mut rest, mut name) = ident(i).map_err(|_| expected_at(i, "a parameter type"))?;
        let mut type_at = i;
        if keyword(name) == Some(Kw::Var) {
            parts.push(self.leaf(K::Keyword, i, rest));
            type_at = self.ws(rest, &mut parts);
            (rest, name) = ident(type_at).map_err(|_| expected_at(type_at, "a parameter type"))?;
        }
        if keyword(name) != Some(Kw::Type) {
            return fail(type_at, "a parameter type");
        }
        parts.push(self.leaf(K::Keyword, type_at, rest));
        let mut i = rest;
        i = self.opt_index(i, &mut parts)?;
        if named {
            let j = self.ws(i, &mut parts);
            let (rest, _) = ident(j).map_err(|_| expected_at(j, "a parameter name"))?;
            parts.push(self.leaf(K::Name, j, rest));
            i = self.opt_index(rest, &mut parts)?;
            i = self.opt_value(i, &mut parts)?;
        }
        Ok((i, Node::with_children(K::Param, parts)))
    }

    /// `DEFINE name AS body`: the body is kept as text up to a comment.
    fn define<'a>(&self, i: &'a [u8], parts: &mut Vec<Node>) -> R<'a, &'a [u8]> {
        let j = self.ws(i, parts);
        let (i, _) = ident(j).map_err(|_| expected_at(j, "a macro name"))?;
        parts.push(self.leaf(K::Name, j, i));
        let (i, ()) = self.keyword_leaf(i, Kw::As, "`AS`", parts)?;
        let i = self.ws(i, parts);
        let end = comment_start(i);
        if end == 0 {
            return fail(i, "a macro body");
        }
        parts.push(self.leaf(K::Text, i, &i[end..]));
        Ok((&i[end..], &i[end..]))
    }

    /// `CALL|PCALL|MCALL|EXTCALL|ISOCALL [target [args]] [BLOCK start [TO end]]`; the target is an expression
    /// or a path such as `/_N_MPF_DIR/PART` or `NC:/MPF_DIR/PART`.
    fn program_call<'a>(&self, i: &'a [u8], parts: &mut Vec<Node>) -> R<'a, &'a [u8]> {
        let mut trivia = Vec::new();
        let j = self.ws(i, &mut trivia);
        if j.is_empty() || j[0] == b';' {
            return Ok((i, i));
        }
        parts.append(&mut trivia);
        let mut i = j;
        if !at_keyword(j, Kw::Block) {
            let path = path_len(j);
            i = if path > 0 {
                let rest = self.take(K::Text, j, path, parts);
                if rest.first() == Some(&b'(') {
                    let (rest, args) = self.args(rest)?;
                    parts.push(args);
                    rest
                } else {
                    rest
                }
            } else {
                let (rest, target) = self.expr(j).map_err(|_| expected_at(j, "a program name"))?;
                parts.push(target);
                rest
            };
        }
        if at_keyword(i, Kw::Block) {
            i = self.keyword_then_expr(i, Kw::Block, "a start label", parts)?;
            if at_keyword(i, Kw::To) {
                i = self.keyword_then_expr(i, Kw::To, "an end label", parts)?;
            }
        }
        Ok((i, i))
    }

    /// The keyword `kw` (known to come next) followed by an expression.
    fn keyword_then_expr<'a>(
        &self,
        i: &'a [u8],
        kw: Kw,
        expected: &'static str,
        parts: &mut Vec<Node>,
    ) -> Result<&'a [u8], nom::Err<PErr>> {
        let (rest, ()) = self.keyword_leaf(i, kw, "a keyword", parts)?;
        let j = self.ws(rest, parts);
        let (rest, value) = self.expr(j).map_err(|e| relabel(e, j, expected))?;
        parts.push(value);
        Ok(rest)
    }

    /// `REDEF target {attribute [value]}`: attributes and values are kept as operands.
    fn redef<'a>(&self, i: &'a [u8], parts: &mut Vec<Node>) -> R<'a, &'a [u8]> {
        let j = self.ws(i, parts);
        let (mut i, target) = self
            .var_ref(j)
            .map_err(|_| expected_at(j, "a variable name"))?;
        parts.push(target);
        loop {
            let mut trivia = Vec::new();
            let j = self.ws(i, &mut trivia);
            if j.is_empty() || j[0] == b';' || trivia.is_empty() {
                return Ok((i, i));
            }
            parts.append(&mut trivia);
            let (rest, value) = self.expr(j)?;
            parts.push(value);
            i = rest;
        }
    }

    /// `( [expr] {, [expr]} )`
    fn args<'a>(&self, i: &'a [u8]) -> R<'a, Node> {
        let mut parts = Vec::new();
        let mut i = self.take(K::Punct, i, 1, &mut parts);
        loop {
            i = self.ws(i, &mut parts);
            match i.first() {
                Some(b')') => {
                    let rest = self.take(K::Punct, i, 1, &mut parts);
                    return Ok((rest, Node::with_children(K::Args, parts)));
                }
                Some(b',') => i = self.take(K::Punct, i, 1, &mut parts),
                _ => {
                    let (rest, arg) = self.expr(i)?;
                    parts.push(arg);
                    i = self.ws(rest, &mut parts);
                    match i.first() {
                        Some(b',' | b')') => {}
                        _ => return fail(i, "`,` or `)`"),
                    }
                }
            }
        }
    }

    /// An optional index list (after optional blanks), pushed to `out`.
    fn opt_index<'a>(&self, i: &'a [u8], out: &mut Vec<Node>) -> Result<&'a [u8], nom::Err<PErr>> {
        if skip_blanks(i).first() != Some(&b'[') {
            return Ok(i);
        }
        let j = self.ws(i, out);
        let (rest, index) = self.index(j)?;
        out.push(index);
        Ok(rest)
    }

    /// An optional `= value` (initialiser or default): an expression or a parenthesised list.
    fn opt_value<'a>(&self, i: &'a [u8], out: &mut Vec<Node>) -> Result<&'a [u8], nom::Err<PErr>> {
        if skip_blanks(i).first() != Some(&b'=') {
            return Ok(i);
        }
        let (j, ()) = self.punct(i, "=", "`=`", out)?;
        let j = self.ws(j, out);
        let (rest, value) = if j.first() == Some(&b'(') {
            self.args(j)?
        } else {
            self.expr(j)?
        };
        out.push(value);
        Ok(rest)
    }

    /// `[ expr {, expr} ]`
    fn index<'a>(&self, i: &'a [u8]) -> R<'a, Node> {
        let mut parts = Vec::new();
        let mut i = self.take(K::Punct, i, 1, &mut parts);
        loop {
            i = self.ws(i, &mut parts);
            let (rest, e) = self.expr(i)?;
            parts.push(e);
            i = self.ws(rest, &mut parts);
            match i.first() {
                Some(b',') => i = self.take(K::Punct, i, 1, &mut parts),
                Some(b']') => {
                    let rest = self.take(K::Punct, i, 1, &mut parts);
                    return Ok((rest, Node::with_children(K::Index, parts)));
                }
                _ => return fail(i, "`,` or `]`"),
            }
        }
    }

    fn expr<'a>(&self, i: &'a [u8]) -> R<'a, Node> {
        self.nested(i, |cx| cx.binary(i, 0, EXPRESSION))
    }

    /// Runs `parse` one level deeper, failing beyond [`MAX_DEPTH`].
    fn nested<'a>(&self, i: &'a [u8], parse: impl FnOnce(&Self) -> R<'a, Node>) -> R<'a, Node> {
        let depth = self.depth.get();
        if depth >= MAX_DEPTH {
            return fail(i, TOO_DEEP);
        }
        self.depth.set(depth + 1);
        let result = parse(self);
        self.depth.set(depth);
        result
    }

    /// The operand at `i` and the operators of `level` or tighter after it (precedence climbing: the
    /// recursion goes one level deeper only where a tighter operator follows). Each operator in a row wraps
    /// the tree once more, so it counts as one level of depth.
    fn binary<'a>(&self, i: &'a [u8], level: usize, ops: Operators) -> R<'a, Node> {
        let depth = self.depth.get();
        let result = self.operations(i, level, ops);
        self.depth.set(depth);
        result
    }

    fn operations<'a>(&self, i: &'a [u8], level: usize, ops: Operators) -> R<'a, Node> {
        let (mut i, mut lhs) = (ops.operand)(self, i)?;
        loop {
            let mut parts = Vec::new();
            let j = self.ws(i, &mut parts);
            let Some((op_level, len, op_kind)) = (ops.at)(j).filter(|op| op.0 >= level) else {
                return Ok((i, lhs));
            };
            let j = self.deeper(j)?;
            let j = self.take(op_kind, j, len, &mut parts);
            let j = self.ws(j, &mut parts);
            let (rest, rhs) = self
                .binary(j, op_level + 1, ops)
                .map_err(|e| relabel(e, j, "an operand"))?;
            parts.insert(0, lhs);
            parts.push(rhs);
            lhs = Node::with_children(K::Binary, parts);
            i = rest;
        }
    }

    /// Counts one more level of depth (an operator in a row), failing beyond [`MAX_DEPTH`].
    fn deeper<'a>(&self, i: &'a [u8]) -> Result<&'a [u8], nom::Err<PErr>> {
        let depth = self.depth.get();
        if depth >= MAX_DEPTH {
            return Err(expected_at(i, TOO_DEEP));
        }
        self.depth.set(depth + 1);
        Ok(i)
    }

    fn unary<'a>(&self, i: &'a [u8]) -> R<'a, Node> {
        let op = match i.first() {
            Some(b'-' | b'+') => Some((1, K::Punct)),
            // `<<R1`: the value as a string (a concatenation with nothing before it).
            Some(b'<') if i.starts_with(b"<<") => Some((2, K::Punct)),
            _ => match ident(i) {
                Ok((rest, name)) if keyword(name) == Some(Kw::Not) => {
                    Some((i.len() - rest.len(), K::Keyword))
                }
                _ => None,
            },
        };
        let Some((len, kind)) = op else {
            return self.primary(i);
        };
        let mut parts = Vec::new();
        let j = self.take(kind, i, len, &mut parts);
        let j = self.ws(j, &mut parts);
        let (rest, operand) = self
            .nested(j, |cx| cx.unary(j))
            .map_err(|e| relabel(e, j, "an operand"))?;
        parts.push(operand);
        Ok((rest, Node::with_children(K::Unary, parts)))
    }

    /// An operand. Each form has its own function, so that the frames on the recursion through nested
    /// parentheses and calls stay small (unoptimised builds give a function one slot per local of every arm).
    fn primary<'a>(&self, i: &'a [u8]) -> R<'a, Node> {
        match i.first() {
            Some(b'(') => self.paren(i),
            Some(b'$') => self.var_ref(i),
            Some(b'0'..=b'9' | b'.' | b'"' | b'\'') => self.literal(i),
            _ => self.named(i),
        }
    }

    fn paren<'a>(&self, i: &'a [u8]) -> R<'a, Node> {
        let mut parts = Vec::new();
        let j = self.take(K::Punct, i, 1, &mut parts);
        let j = self.ws(j, &mut parts);
        let (j, inner) = self.expr(j)?;
        parts.push(inner);
        let (rest, ()) = self.punct(j, ")", "`)`", &mut parts)?;
        Ok((rest, Node::with_children(K::Paren, parts)))
    }

    /// A number, string or bit literal.
    fn literal<'a>(&self, i: &'a [u8]) -> R<'a, Node> {
        let (rest, kind) = match i[0] {
            b'"' => (
                string(i).map_err(|_| expected_at(i, "a closed string"))?.0,
                K::Str,
            ),
            b'\'' => (
                bit_literal(i)
                    .map_err(|_| expected_at(i, "a bit literal 'H…' or 'B…'"))?
                    .0,
                K::BitLiteral,
            ),
            _ => (
                unsigned_number(i)
                    .map_err(|_| expected_at(i, "a number"))?
                    .0,
                K::Number,
            ),
        };
        Ok((rest, self.leaf(kind, i, rest)))
    }

    /// A function call, variable, axis or constant.
    fn named<'a>(&self, i: &'a [u8]) -> R<'a, Node> {
        let (after, name) = ident(i).map_err(|_| expected_at(i, "an operand"))?;
        if keyword(name).is_some_and(Kw::is_reserved) {
            return fail(i, "an operand");
        }
        if skip_blanks(after).first() != Some(&b'(') {
            return self.var_ref(i);
        }
        let mut parts = vec![self.leaf(K::Name, i, after)];
        let after = self.ws(after, &mut parts);
        let (rest, args) = self.args(after)?;
        parts.push(args);
        Ok((rest, Node::with_children(K::FnCall, parts)))
    }
}

/// A binary operator: its level (0 binds loosest), length and leaf kind.
type Op = (usize, usize, K);

/// The binary operators an expression takes and its operands.
#[derive(Clone, Copy)]
struct Operators {
    /// The operator at the start of the input.
    at: fn(&[u8]) -> Option<Op>,
    operand: for<'a> fn(&Cx, &'a [u8]) -> R<'a, Node>,
}

/// Every operator, with prefix operators on the operands.
const EXPRESSION: Operators = Operators {
    at: operator,
    operand: Cx::unary,
};

/// `<<` alone between plain operands: a CASE arm's jump target (`"LBL"<<R1`).
const JOINED: Operators = Operators {
    at: |i| i.starts_with(b"<<").then_some((1, 2, K::Punct)),
    operand: Cx::primary,
};

/// The binary operator at the start of `i`.
fn operator(i: &[u8]) -> Option<Op> {
    const SYMBOLS: &[(&str, usize)] = &[
        ("<<", 1),
        ("==", 0),
        ("<>", 0),
        ("<=", 0),
        (">=", 0),
        ("<", 0),
        (">", 0),
        ("+", 8),
        ("-", 8),
        ("*", 9),
        ("/", 9),
        (":", 9),
    ];
    if let Some(&(op, level)) = SYMBOLS.iter().find(|(op, _)| i.starts_with(op.as_bytes())) {
        return Some((level, op.len(), K::Punct));
    }
    let (rest, name) = ident(i).ok()?;
    let level = match keyword(name)? {
        Kw::Or => 2,
        Kw::Xor => 3,
        Kw::And => 4,
        Kw::BOr => 5,
        Kw::BXor => 6,
        Kw::BAnd => 7,
        Kw::Div | Kw::Mod => 9,
        _ => return None,
    };
    Some((level, i.len() - rest.len(), K::Keyword))
}

/// Whether the next word (after blanks) is the keyword `kw`.
fn at_keyword(i: &[u8], kw: Kw) -> bool {
    ident(skip_blanks(i)).is_ok_and(|(_, name)| keyword(name) == Some(kw))
}

/// Length of a program path at the start of `i` (`/_N_MPF_DIR/X`, `NC:/X`, `//NC:/X`), 0 if none.
fn path_len(i: &[u8]) -> usize {
    let dev = i
        .iter()
        .position(|&b| b == b':')
        .filter(|&k| k > 0 && i[..k].iter().all(|&b| b == b'/' || b.is_ascii_alphabetic()));
    let body = dev.map_or(0, |k| k + 1);
    if i.get(body) != Some(&b'/') {
        return 0;
    }
    body + i[body..]
        .iter()
        .take_while(|&&b| b == b'/' || is_ident_char(b))
        .count()
}

/// Targets assigned a parenthesised list rather than an expression: a polynomial's coefficients
/// `PO[X]=(xe, a2, a3 …)` (POLY), the oscillation control options `OSCTRL[Z]=(set, reset)` and the infeed axes
/// of an oscillating axis `OSCILL[Z]=(X, Y)` (Job Planning, oscillation).
const LIST_TARGETS: [&[u8]; 3] = [b"PO", b"OSCTRL", b"OSCILL"];

fn is_rparam(name: &[u8]) -> bool {
    name.len() > 1
        && (name[0] == b'R' || name[0] == b'r')
        && name[1..].iter().all(u8::is_ascii_digit)
}

fn expected_at(i: &[u8], expected: &'static str) -> nom::Err<PErr> {
    nom::Err::Error(PErr {
        rest: i.len(),
        expected,
    })
}

/// Names what was expected where a failure happened right at `at` (deeper failures keep their own words).
fn relabel(e: nom::Err<PErr>, at: &[u8], expected: &'static str) -> nom::Err<PErr> {
    e.map(|e| {
        if e.expected != TOO_DEEP && (e.rest >= at.len() || e.expected.is_empty()) {
            PErr {
                rest: e.rest.min(at.len()),
                expected,
            }
        } else {
            e
        }
    })
}

/// Offset of the first `;` outside a string (or the length).
fn comment_start(i: &[u8]) -> usize {
    let mut in_string = false;
    for (k, &b) in i.iter().enumerate() {
        match b {
            b'"' => in_string = !in_string,
            b';' if !in_string => return k,
            _ => {}
        }
    }
    i.len()
}

/// The help for an assignment that ends the line with nothing after its `=` (`_K=`, as one CAM post writes a
/// measuring cycle's parameter it has no value for): the control stops there too, so the line needs a value
/// or the word taken out. `before` is the line up to where parsing stopped, `at` the rest.
fn empty_assignment_help(before: &[u8], at: &[u8]) -> Option<String> {
    let rest = at.iter().position(|&b| b == b';').map_or(at, |c| &at[..c]);
    if !rest.iter().all(u8::is_ascii_whitespace) {
        return None;
    }
    let before = before.trim_ascii_end().strip_suffix(b"=")?.trim_ascii_end();
    let name_start = before
        .iter()
        .rposition(|&b| !(b.is_ascii_alphanumeric() || b == b'_' || b == b'$'))
        .map_or(0, |p| p + 1);
    let name = std::str::from_utf8(&before[name_start..]).ok()?;
    (!name.is_empty()).then(|| {
        format!(
            "`{name}=` assigns no value (the control stops at this line too): write the value, e.g. `{name}=1`, or delete `{name}=` if the cycle does not need it; a post that writes it leaves out a parameter it has no value for"
        )
    })
}
