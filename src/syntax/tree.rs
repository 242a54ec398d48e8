//! The lossless syntax tree of one block. Every byte of the block, terminator included, belongs to exactly one
//! leaf, so the leaves in order reproduce the block (see [`Node::leaves`]).

use serde::Serialize;
use serde::ser::{SerializeStruct, Serializer};

use crate::source::Span;

macro_rules! node_kinds {
    ($($(#[$doc:meta])* $name:ident),* $(,)?) => {
        /// What a node is. Each kind is one rule of `grammar/sinumerik.ebnf`.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
        pub enum NodeKind { $($(#[$doc])* $name),* }

        impl NodeKind {
            pub const ALL: &'static [NodeKind] = &[$(NodeKind::$name),*];

            pub fn name(self) -> &'static str {
                match self { $(NodeKind::$name => stringify!($name)),* }
            }
        }
    };
}

node_kinds! {
    // Structure of a block.
    /// One line of the program, terminator included.
    Block,
    /// Archive / transfer header such as `%_N_PART_MPF` or `%MPF100`.
    Header,
    /// Skip level `/` or `/0` … `/9`.
    Skip,
    /// Block number `N10` or main block `:10`.
    BlockNumber,
    /// Jump label `NAME:`.
    Label,
    /// A line (or rest of line) that could not be parsed.
    Error,
    // Statements.
    /// Address with a number: `G1`, `X-3.2`, `M30`, `L123`.
    Word,
    /// `target = expr`: extended addresses (`X=R1+5`, `M3=5`, `T="MILL"`), parameters, variables.
    Assign,
    /// `NAME(args)` as a statement: cycles, subprograms, `MSG`, `WRITE`, `SETAL`, frames like `CTRANS`.
    Call,
    /// A bare name: subprogram call, `STOPRE`, `TRANS`, `RET`, `DISPLOF`.
    Command,
    /// `IF expr` (block IF, or one-line IF when the block also jumps).
    If,
    /// `ELSE`, `ENDIF`, `ENDWHILE`, `ENDFOR`, `LOOP`, `ENDLOOP`.
    ControlKeyword,
    /// `WHILE expr`.
    While,
    /// `UNTIL expr`.
    Until,
    /// `FOR var = expr TO expr`.
    For,
    /// `REPEAT` (loop start) or `REPEAT lbl [lbl]` / `REPEATB lbl` (section repeat).
    Repeat,
    /// `CASE expr OF const GOTOF lbl … DEFAULT GOTOF lbl`.
    Case,
    /// One `const GOTOx lbl` or `DEFAULT GOTOx lbl` of a CASE.
    CaseArm,
    /// `GOTO`, `GOTOF`, `GOTOB`, `GOTOC` with a target, or `GOTOS`.
    Goto,
    /// `DEF [modifiers] type [STRING length] declarators`.
    Def,
    /// `REDEF target {attribute [value]}`.
    Redef,
    /// One declared name with optional dimensions and initialiser.
    Declarator,
    /// `PROC name(params) attributes`.
    Proc,
    /// One PROC or EXTERN parameter: `[VAR] type [dims] [name [dims]]`.
    Param,
    /// `EXTERN name(types)`.
    Extern,
    /// `DEFINE name AS body`.
    Define,
    /// Synchronized action condition `WHENEVER expr DO`, `WHEN`, `EVERY`, `FROM`, or a bare `DO`.
    SyncCondition,
    /// `CALL`, `PCALL`, `MCALL`, `EXTCALL`, `ISOCALL` … with an optional target.
    ProgramCall,
    // Expressions.
    /// Binary operation; the operator is the middle leaf.
    Binary,
    /// `-x`, `NOT x`, `B_NOT x`.
    Unary,
    /// `( expr )`.
    Paren,
    /// Function call in an expression: `SIN(30)`, `IC(5)`, `SET(1,2)`.
    FnCall,
    /// `( [expr] {, [expr]} )` argument list; empty arguments allowed.
    Args,
    /// `[ expr {, expr} ]` index list.
    Index,
    /// R parameter: `R1`, `R[2]`, `R[R1+1]`.
    RParam,
    /// System variable `$P_UIFR[1,Z,TR]`, `$AA_IM[X]`.
    SysVar,
    /// User variable, axis name or constant, optionally indexed: `CNT`, `ARR[1,2]`, `X`.
    Var,
    // Leaves (tokens).
    /// Blanks: space, tab, `&`, vertical tab, form feed.
    Trivia,
    /// Byte-order mark at the start of the file.
    Bom,
    /// `; …` to the end of the line.
    Comment,
    /// The line terminator: LF, CRLF or lone CR (empty for a last line without one).
    Newline,
    /// A reserved word: `IF`, `DEF`, `GOTOF`, `AND`, `TO` …
    Keyword,
    /// An identifier.
    Name,
    /// The address letter of a word.
    Address,
    /// A number: `12`, `-3.5`, `.5`, `1.5EX3`.
    Number,
    /// A string literal `"…"` (any bytes but `"`).
    Str,
    /// A bit literal `'H1F'` or `'B101'`.
    BitLiteral,
    /// Operators and punctuation.
    Punct,
    /// Bytes kept verbatim: header text, DEFINE bodies, unparsable rest of a line.
    Text,
}

impl NodeKind {
    pub fn is_leaf(self) -> bool {
        self >= NodeKind::Trivia
    }
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Node {
    pub kind: NodeKind,
    /// Absolute byte range in the program source.
    pub span: Span,
    pub children: Vec<Node>,
}

impl Node {
    pub fn leaf(kind: NodeKind, span: Span) -> Self {
        Node {
            kind,
            span,
            children: Vec::new(),
        }
    }

    /// A composite node spanning its children (which must be non-empty and contiguous).
    pub fn with_children(kind: NodeKind, children: Vec<Node>) -> Self {
        let start = children.first().map_or(0, |c| c.span.start);
        let end = children.last().map_or(start, |c| c.span.end);
        Node {
            kind,
            span: Span::new(start, end),
            children,
        }
    }

    /// The leaves in source order.
    pub fn leaves(&self) -> Vec<&Node> {
        let mut out = Vec::new();
        self.walk(&mut |n| {
            if n.children.is_empty() {
                out.push(n);
            }
        });
        out
    }

    /// Visits this node and all descendants, parents first.
    pub fn walk<'a>(&'a self, f: &mut impl FnMut(&'a Node)) {
        f(self);
        for c in &self.children {
            c.walk(f);
        }
    }

    /// Children that are not trivia, comments or newlines.
    pub fn significant(&self) -> impl Iterator<Item = &Node> {
        self.children.iter().filter(|c| {
            !matches!(
                c.kind,
                NodeKind::Trivia | NodeKind::Comment | NodeKind::Newline | NodeKind::Bom
            )
        })
    }

    pub fn find(&self, kind: NodeKind) -> Option<&Node> {
        self.children.iter().find(|c| c.kind == kind)
    }

    /// The address and number leaves of a `Word` or `BlockNumber` (blanks may stand between them: `X 10`).
    pub fn address_and_number(&self) -> Option<(&Node, &Node)> {
        let address = self
            .children
            .first()
            .filter(|c| c.kind == NodeKind::Address)?;
        let number = self
            .children
            .last()
            .filter(|c| c.kind == NodeKind::Number)?;
        Some((address, number))
    }

    /// The expressions of an argument list `( a, , c )`: `None` for an empty argument. The list's own direct
    /// punctuation is its parentheses (first and last) and the commas between; an argument is never a bare
    /// `Punct`.
    pub fn arguments(&self) -> Vec<Option<&Node>> {
        let parts: Vec<&Node> = self.significant().collect();
        let inner = parts.get(1..parts.len().saturating_sub(1)).unwrap_or(&[]);
        if inner.is_empty() {
            return Vec::new();
        }
        let mut out = vec![None];
        for &c in inner {
            match (c.kind, out.last_mut()) {
                (NodeKind::Punct, _) => out.push(None),
                (_, Some(slot)) => *slot = Some(c),
                (_, None) => {}
            }
        }
        out
    }

    /// The arguments of a call or function call (`NAME(a, , c)`): those of its argument list, none
    /// without one.
    pub fn call_arguments(&self) -> Vec<Option<&Node>> {
        self.find(NodeKind::Args)
            .map_or_else(Vec::new, Node::arguments)
    }

    /// Indented text dump, one node per line, leaves with their bytes (escaped).
    pub fn dump(&self, src: &[u8], depth: usize, out: &mut String) {
        use std::fmt::Write;
        let _ = write!(
            out,
            "{:indent$}{}@{}..{}",
            "",
            self.kind.name(),
            self.span.start,
            self.span.end,
            indent = depth * 2
        );
        if self.children.is_empty() {
            let _ = write!(out, " \"{}\"", escape(self.span.slice(src)));
        }
        out.push('\n');
        for c in &self.children {
            c.dump(src, depth + 1, out);
        }
    }
}

/// Bytes as text: printable ASCII as is, everything else as `\xNN` (and `\t`, `\r`, `\n`).
pub fn escape(bytes: &[u8]) -> String {
    bytes.escape_ascii().to_string()
}

/// A node together with the source, so it can serialise its text.
pub struct NodeJson<'a> {
    pub node: &'a Node,
    pub src: &'a [u8],
}

impl Serialize for NodeJson<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let n = self.node;
        let mut st = s.serialize_struct("Node", 3)?;
        st.serialize_field("kind", n.kind.name())?;
        st.serialize_field("span", &n.span)?;
        if n.children.is_empty() {
            st.serialize_field("text", &String::from_utf8_lossy(n.span.slice(self.src)))?;
        } else {
            let children: Vec<NodeJson<'_>> = n
                .children
                .iter()
                .map(|node| NodeJson {
                    node,
                    src: self.src,
                })
                .collect();
            st.serialize_field("children", &children)?;
        }
        st.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn argument_lists_keep_empty_arguments() {
        let count = |src: &str| {
            let p = crate::parse(src.as_bytes());
            let root = p.block(0).root;
            let call = root.find(NodeKind::Call).unwrap();
            call.call_arguments()
                .iter()
                .map(Option::is_some)
                .collect::<Vec<bool>>()
        };
        assert_eq!(count("SUB(1,,R1+2)"), [true, false, true]);
        assert_eq!(count("SUB(,)"), [false, false]);
        assert_eq!(count("SUB()"), Vec::<bool>::new());
    }
}
