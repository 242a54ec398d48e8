//! The parsed program: the retained source plus one compact record per block. Full block trees are
//! materialised on demand from the block's bytes, which keeps a 100 MB program within twice its size.

use std::io::Write;

use serde::Serialize;
use serde::ser::{SerializeStruct, Serializer};

use super::block_kind::{BlockKind, flag};
use super::grammar;
use super::tree::{Node, NodeJson, NodeKind};
use crate::diagnostic::{Diagnostic, Severity};
use crate::source::{RawLine, Span};

const BOM: &[u8] = b"\xEF\xBB\xBF";

/// What the program keeps per block: 8 bytes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BlockRec {
    pub start: u32,
    pub kind: BlockKind,
    pub flags: u8,
    pub terminator_len: u8,
}

/// A parsed NC program (or archive of programs). Never fails to build; problems are in [`Program::diagnostics`].
#[derive(Debug, Clone)]
pub struct Program {
    pub(super) src: Vec<u8>,
    pub(super) blocks: Vec<BlockRec>,
    pub(super) diagnostics: Vec<Diagnostic>,
    pub(super) endings: Endings,
    /// The `%…` header blocks, in order: where program units start.
    pub(super) headers: Vec<usize>,
    /// The jumps the structure pass resolved while parsing (see [`Program::jumps`]).
    pub(super) jumps: Vec<Jump>,
}

/// A jump with a literal target, or a section repetition's label: source block, upper-cased target,
/// resolved block (None: no target in the search direction).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Jump {
    pub from: usize,
    pub target: String,
    pub to: Option<usize>,
}

/// How many lines end in LF, CRLF and a lone CR, counted while parsing: an editor asks for the dominant
/// one, and searching a large source again for it costs a pass over every byte.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Endings {
    pub(super) lf: usize,
    pub(super) crlf: usize,
    pub(super) cr: usize,
}

impl Endings {
    #[inline(always)]
    pub(super) fn count(&mut self, src: &[u8], line: &RawLine) {
        match line.end - line.content_end {
            2 => self.crlf += 1,
            1 if src[line.content_end] == b'\r' => self.cr += 1,
            1 => self.lf += 1,
            _ => {}
        }
    }

    pub(super) fn add(&mut self, other: Endings) {
        self.lf += other.lf;
        self.crlf += other.crlf;
        self.cr += other.cr;
    }
}

impl Program {
    pub fn source(&self) -> &[u8] {
        &self.src
    }

    /// The program's bytes; for a parsed program exactly the input.
    pub fn to_bytes(&self) -> Vec<u8> {
        self.src.clone()
    }

    pub fn write_to<W: Write>(&self, w: &mut W) -> std::io::Result<()> {
        w.write_all(&self.src)
    }

    /// Syntax and structure diagnostics, sorted by position.
    pub fn diagnostics(&self) -> &[Diagnostic] {
        &self.diagnostics
    }

    pub fn has_errors(&self) -> bool {
        self.errors().next().is_some()
    }

    /// The diagnostics that are errors (not warnings), in source order.
    pub fn errors(&self) -> impl Iterator<Item = &Diagnostic> {
        self.diagnostics
            .iter()
            .filter(|d| d.severity == Severity::Error)
    }

    pub fn has_bom(&self) -> bool {
        self.src.starts_with(BOM)
    }

    /// Number of blocks (physical lines).
    pub fn block_count(&self) -> usize {
        self.blocks.len()
    }

    /// The whole line of block `i`, terminator included.
    pub fn block_span(&self, i: usize) -> Span {
        let start = self.blocks[i].start as usize;
        let end = self
            .blocks
            .get(i + 1)
            .map_or(self.src.len(), |b| b.start as usize);
        Span::new(start, end)
    }

    /// The content of block `i` without its terminator (the BOM, if any, is part of block 0's content).
    pub fn content_span(&self, i: usize) -> Span {
        let full = self.block_span(i);
        Span::new(
            full.start,
            full.end - self.blocks[i].terminator_len as usize,
        )
    }

    /// The control-flow role of block `i`.
    pub fn block_kind(&self, i: usize) -> BlockKind {
        self.blocks[i].kind
    }

    pub fn block_flags(&self, i: usize) -> u8 {
        self.blocks[i].flags
    }

    /// Index of the block containing byte `offset` (the last block for offsets at the end).
    pub fn block_at(&self, offset: usize) -> usize {
        self.blocks
            .partition_point(|b| b.start as usize <= offset)
            .max(1)
            - 1
    }

    /// The full syntax tree of block `i`, built from its bytes. Panics if `i >= block_count()`.
    pub fn block(&self, i: usize) -> Block<'_> {
        let full = self.block_span(i);
        let content = self.content_span(i);
        let root = if self.src.len() > u32::MAX as usize {
            Node::with_children(NodeKind::Block, vec![Node::leaf(NodeKind::Text, full)])
        } else if self.blocks[i].flags & flag::TEXT != 0 {
            let text = Node::leaf(NodeKind::Text, content);
            let newline = Node::leaf(NodeKind::Newline, Span::new(content.end, full.end));
            Node::with_children(NodeKind::Block, vec![text, newline])
        } else {
            let line = RawLine {
                start: full.start,
                content_end: content.end,
                end: full.end,
            };
            let content = line_content(&self.src, &line);
            // The tree alone: where the filler starts only matters to the diagnostics.
            grammar::parse_block(&self.src, content, line.terminator(), self.src.len()).tree
        };
        Block {
            src: &self.src,
            index: i,
            kind: self.blocks[i].kind,
            root,
        }
    }

    pub fn blocks(&self) -> impl ExactSizeIterator<Item = Block<'_>> {
        (0..self.blocks.len()).map(|i| self.block(i))
    }

    /// The `%…` header blocks (where program units start), in order.
    pub fn header_blocks(&self) -> &[usize] {
        &self.headers
    }

    /// The file an archive's header block `%_N_NAME_KIND` heads: `NAME` and `KIND` (`MPF`, `SPF`,
    /// `DEF`, …), upper case; `None` for any other block.
    pub fn section(&self, header: usize) -> Option<(String, String)> {
        let text = String::from_utf8_lossy(self.content_span(header).slice(self.source()));
        let file = text.trim().to_ascii_uppercase();
        let (name, kind) = file.strip_prefix("%_N_")?.rsplit_once('_')?;
        (!name.is_empty()).then(|| (name.to_string(), kind.to_string()))
    }

    /// The main programs of an archive: each `%_N_NAME_MPF` header block with `NAME`, in order.
    pub fn main_sections(&self) -> Vec<(usize, String)> {
        self.headers
            .iter()
            .filter_map(|&h| {
                let (name, kind) = self.section(h)?;
                (kind == "MPF").then_some((h, name))
            })
            .collect()
    }

    /// The header of the main program of an archive whose first section is another file (a subprogram, a
    /// GUD definition file, a text): its first `%_N_NAME_MPF` section. `None` when the first section is
    /// the main program or the file has no such section.
    pub fn later_main_header(&self) -> Option<usize> {
        let &first = self.headers.first()?;
        let (h, _) = self.main_sections().into_iter().next()?;
        (self.section(first).is_some() && h != first).then_some(h)
    }

    /// The jumps of every program unit as the structure pass resolved them while parsing (what
    /// [`crate::syntax::structure::analyze`] gives as `jumps`): kept, so that a reader of the program's
    /// flow need not pass over every block again to pair its structures.
    pub fn jumps(&self) -> &[Jump] {
        &self.jumps
    }

    /// The line ending most blocks use (LF when there is none), for rendering new blocks.
    pub fn dominant_line_ending(&self) -> &'static [u8] {
        let Endings { lf, crlf, cr } = self.endings;
        if crlf > lf && crlf >= cr {
            b"\r\n"
        } else if cr > lf && cr > crlf {
            b"\r"
        } else {
            b"\n"
        }
    }

    /// Indented tree dump of every block (for snapshots and debugging).
    pub fn dump_tree(&self) -> String {
        let mut out = String::new();
        for b in self.blocks() {
            b.root.dump(&self.src, 0, &mut out);
        }
        out
    }
}

/// One block's full syntax tree.
#[derive(Debug, Clone)]
pub struct Block<'a> {
    pub src: &'a [u8],
    pub index: usize,
    pub kind: BlockKind,
    /// A `Block` node whose leaves cover the line, terminator included.
    pub root: Node,
}

impl Block<'_> {
    pub fn span(&self) -> Span {
        self.root.span
    }

    pub fn text(&self, node: &Node) -> &[u8] {
        node.span.slice(self.src)
    }
}

impl Serialize for Block<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut st = s.serialize_struct("Block", 3)?;
        st.serialize_field("index", &self.index)?;
        st.serialize_field("kind", &self.kind)?;
        st.serialize_field(
            "tree",
            &NodeJson {
                node: &self.root,
                src: self.src,
            },
        )?;
        st.end()
    }
}

/// Serialises blocks one at a time, so a dump never holds every tree at once.
struct BlocksJson<'a>(&'a Program);

impl Serialize for BlocksJson<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.0.blocks())
    }
}

impl Serialize for Program {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut st = s.serialize_struct("Program", 2)?;
        st.serialize_field("blocks", &BlocksJson(self))?;
        st.serialize_field("diagnostics", &self.diagnostics)?;
        st.end()
    }
}

/// The parsable part of a line: its content without the BOM of the first line.
pub(super) fn line_content(src: &[u8], line: &RawLine) -> Span {
    let skip = if line.start == 0 && src.starts_with(BOM) {
        BOM.len().min(line.content_end)
    } else {
        0
    };
    Span::new(line.start + skip, line.content_end)
}
