//! The parsed program: the retained source plus one compact record per block. Full block trees are
//! materialised on demand from the block's bytes, which keeps a 100 MB program within twice its size.

use std::io::Write;

use serde::Serialize;
use serde::ser::{SerializeStruct, Serializer};

use super::block_kind::{BlockKind, flag};
use super::fast::{self, Words};
use super::grammar;
use super::odd_bytes::eof_filler;
use super::tree::{Node, NodeJson, NodeKind};
use crate::diagnostic::{Diagnostic, Severity};
use crate::source::{RawLine, Span};
use crate::structure;

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
    src: Vec<u8>,
    blocks: Vec<BlockRec>,
    diagnostics: Vec<Diagnostic>,
    endings: Endings,
    /// The `%…` header blocks, in order: where program units start.
    headers: Vec<usize>,
}

/// How many lines end in LF, CRLF and a lone CR, counted while parsing: an editor asks for the dominant
/// one, and searching a large source again for it costs a pass over every byte.
#[derive(Debug, Clone, Copy, Default)]
struct Endings {
    lf: usize,
    crlf: usize,
    cr: usize,
}

impl Endings {
    #[inline(always)]
    fn count(&mut self, src: &[u8], line: &RawLine) {
        match line.end - line.content_end {
            2 => self.crlf += 1,
            1 if src[line.content_end] == b'\r' => self.cr += 1,
            1 => self.lf += 1,
            _ => {}
        }
    }

    fn add(&mut self, other: Endings) {
        self.lf += other.lf;
        self.crlf += other.crlf;
        self.cr += other.cr;
    }
}

/// Parses any bytes. Never fails and never panics; `parse(x).to_bytes() == x`.
pub fn parse(src: &[u8]) -> Program {
    parse_owned(src.to_vec())
}

/// Like [`parse`], but takes ownership of the buffer, so the program costs no second copy of the source.
pub fn parse_owned(src: Vec<u8>) -> Program {
    parse_owned_with(src, || ()).0
}

/// Like [`parse_owned`], with what a `words()` of its own heard of each piece of the source the parser
/// read (with the piece's first block): a reader of the plain blocks' words in the same pass that
/// recognises them (see [`Words`]).
pub fn parse_owned_with<W: Words + Send>(
    src: Vec<u8>,
    words: impl Fn() -> W + Sync,
) -> (Program, Vec<(usize, W)>) {
    parse_owned_in_pieces(src, PARALLEL_CHUNK, words)
}

/// [`parse_owned_with`] with pieces of about `chunk` bytes (small in tests, to cut small programs).
pub(crate) fn parse_owned_in_pieces<W: Words + Send>(
    src: Vec<u8>,
    chunk: usize,
    words: impl Fn() -> W + Sync,
) -> (Program, Vec<(usize, W)>) {
    if u32::try_from(src.len()).is_err() {
        let span = Span::new(0, src.len());
        let blocks = vec![BlockRec {
            start: 0,
            kind: BlockKind::Plain,
            flags: flag::ERROR,
            terminator_len: 0,
        }];
        let diagnostics = vec![
            Diagnostic::error(span, "file is larger than 4 GiB").with_help("split the program"),
        ];
        let program = Program {
            src,
            blocks,
            diagnostics,
            endings: Endings::default(),
            headers: Vec::new(),
        };
        return (program, Vec::new());
    }
    let Parsed {
        blocks,
        diagnostics,
        endings,
        headers,
        pieces,
    } = parse_blocks(&src, chunk, words);
    let mut program = Program {
        src,
        blocks,
        diagnostics,
        endings,
        headers,
    };
    let structural = structure::analyze(&program).diagnostics;
    program.diagnostics.extend(structural);
    program
        .diagnostics
        .sort_by_key(|d| (d.span.start, d.severity, d.span.end));
    (program, pieces)
}

/// Size of the pieces a large source is cut into (at line ends) to parse them on all cores.
const PARALLEL_CHUNK: usize = 8 << 20;

/// The blocks of one piece of the source, parsed as if a `…_COM` text section were (or were not) open at its
/// start, and whether one is open at its end.
struct Chunk<W> {
    blocks: Vec<BlockRec>,
    diagnostics: Vec<Diagnostic>,
    endings: Endings,
    headers: Vec<usize>,
    in_text_section: bool,
    words: W,
}

/// Parses the blocks of `src[start..end]`; `filler` is where the end-of-file filler of `src` starts.
fn parse_chunk<W: Words>(
    src: &[u8],
    (start, end): (usize, usize),
    filler: usize,
    mut in_text_section: bool,
    mut words: W,
) -> Chunk<W> {
    let mut blocks = Vec::with_capacity((end - start) / 32 + 1);
    let mut diagnostics = Vec::new();
    let mut endings = Endings::default();
    let mut headers = Vec::new();
    let mut pos = start;
    while pos < end {
        let rest = &src[pos..end];
        let plain = fast::plain_prefix_with(rest, &mut words);
        let content_end = pos
            + plain.unwrap_or_else(|| memchr::memchr2(b'\n', b'\r', rest).unwrap_or(rest.len()));
        let line = RawLine::ending_at(src, pos, content_end);
        endings.count(src, &line);
        pos = line.end;
        let content = line_content(src, &line);
        let bytes = content.slice(src);
        let (kind, flags) = if plain.is_some() {
            words.end_line();
            (BlockKind::Plain, 0)
        } else if in_text_section && !bytes.starts_with(b"%") {
            words.other_line(None);
            (BlockKind::Plain, flag::TEXT)
        } else {
            let parsed = grammar::parse_block(src, content, line.terminator(), filler);
            let clean = parsed.kind == BlockKind::Plain
                && parsed.flags == 0
                && parsed.diagnostics.is_empty();
            words.other_line(clean.then_some(bytes));
            diagnostics.extend(parsed.diagnostics);
            if parsed.kind == BlockKind::Header {
                in_text_section = is_text_section(bytes);
                headers.push(blocks.len());
            }
            (parsed.kind, parsed.flags)
        };
        blocks.push(BlockRec {
            start: line.start as u32,
            kind,
            flags,
            terminator_len: (line.end - line.content_end) as u8,
        });
    }
    Chunk {
        blocks,
        diagnostics,
        endings,
        headers,
        in_text_section,
        words,
    }
}

/// What parsing every block gives: blocks, diagnostics, line endings, header blocks, and the pieces' word
/// reports with their first blocks.
struct Parsed<W> {
    blocks: Vec<BlockRec>,
    diagnostics: Vec<Diagnostic>,
    endings: Endings,
    headers: Vec<usize>,
    pieces: Vec<(usize, W)>,
}

/// Parses every block. Sources larger than two chunks are cut after an LF near each multiple of `chunk` and
/// the pieces parsed in parallel; the rare piece that starts inside a text section is parsed again with that
/// state, so the result equals a sequential parse. Each piece's blocks are reported to a `words()` of its
/// own.
fn parse_blocks<W: Words + Send>(
    src: &[u8],
    chunk: usize,
    words: impl Fn() -> W + Sync,
) -> Parsed<W> {
    use rayon::prelude::*;
    let mut cuts = vec![0];
    while let Some(&last) = cuts.last() {
        let next = last + chunk;
        if next >= src.len() {
            break;
        }
        match memchr::memchr(b'\n', &src[next..]) {
            Some(k) if next + k + 1 < src.len() => cuts.push(next + k + 1),
            _ => break,
        }
    }
    cuts.push(src.len());
    let ranges: Vec<(usize, usize)> = cuts.windows(2).map(|w| (w[0], w[1])).collect();
    let filler = eof_filler(src);
    let piece =
        |&range: &(usize, usize), open: bool| parse_chunk(src, range, filler, open, words());
    let mut chunks: Vec<Chunk<W>> = if ranges.len() > 2 {
        ranges.par_iter().map(|r| piece(r, false)).collect()
    } else {
        ranges.iter().map(|r| piece(r, false)).collect()
    };
    let mut open = false;
    for (chunk, range) in chunks.iter_mut().zip(&ranges) {
        if open {
            *chunk = piece(range, true);
        }
        open = chunk.in_text_section;
    }
    if chunks.len() == 1 {
        let only = chunks.pop().expect("one chunk");
        return Parsed {
            blocks: only.blocks,
            diagnostics: only.diagnostics,
            endings: only.endings,
            headers: only.headers,
            pieces: vec![(0, only.words)],
        };
    }
    let mut blocks = Vec::with_capacity(chunks.iter().map(|c| c.blocks.len()).sum());
    let mut diagnostics = Vec::new();
    let mut endings = Endings::default();
    let mut headers = Vec::new();
    let mut pieces = Vec::with_capacity(chunks.len());
    for chunk in chunks {
        let first = blocks.len();
        pieces.push((first, chunk.words));
        blocks.extend_from_slice(&chunk.blocks);
        diagnostics.extend(chunk.diagnostics);
        endings.add(chunk.endings);
        headers.extend(chunk.headers.iter().map(|h| first + h));
    }
    Parsed {
        blocks,
        diagnostics,
        endings,
        headers,
        pieces,
    }
}

/// Archive sections named `…_COM` hold alarm texts and HMI masks, not NC code.
fn is_text_section(header: &[u8]) -> bool {
    let name = header.trim_ascii_end();
    name.len() >= 4 && name[name.len() - 4..].eq_ignore_ascii_case(b"_COM")
}

/// The parsable part of a line: its content without the BOM of the first line.
fn line_content(src: &[u8], line: &RawLine) -> Span {
    let skip = if line.start == 0 && src.starts_with(BOM) {
        BOM.len().min(line.content_end)
    } else {
        0
    };
    Span::new(line.start + skip, line.content_end)
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
        self.diagnostics
            .iter()
            .any(|d| d.severity == Severity::Error)
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

/// Syntax diagnostics of one line on its own (spans relative to `line`); control pairing and jump targets are
/// not checked, since they depend on the rest of the program.
pub fn line_syntax_errors(line: &[u8]) -> Vec<Diagnostic> {
    if fast::plain_block(line) {
        return Vec::new();
    }
    let end = Span::new(line.len(), line.len());
    grammar::parse_block(line, Span::new(0, line.len()), end, line.len()).diagnostics
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parallel_chunks_give_the_sequential_result() {
        let src =
            b"N10 G0 X0\r\n%_N_T_COM\n700 0 \"t\"\n7 \"u\"\nIF R1\n%_N_A_MPF\nX=(\nENDIF\n\rM30"
                .repeat(20);
        let seq = parse_blocks(&src, usize::MAX / 2, || ());
        let (seq_blocks, seq_diags, seq_endings) = (seq.blocks, seq.diagnostics, seq.endings);
        let seq_headers: Vec<usize> = (0..seq_blocks.len())
            .filter(|&i| seq_blocks[i].kind == BlockKind::Header)
            .collect();
        assert_eq!(seq.headers, seq_headers);
        assert_eq!(seq_headers.len(), 40);
        // 20 lines end in CRLF, 20 in a lone CR, 140 in LF; the last has no terminator.
        let Endings { lf, crlf, cr } = seq_endings;
        assert_eq!((lf, crlf, cr), (140, 20, 20));
        for chunk in [1, 7, 40, 100] {
            let Parsed {
                blocks,
                diagnostics: diags,
                endings,
                headers,
                ..
            } = parse_blocks(&src, chunk, || ());
            assert_eq!(headers, seq_headers, "chunk {chunk}");
            assert_eq!(
                (endings.lf, endings.crlf, endings.cr),
                (lf, crlf, cr),
                "chunk {chunk}"
            );
            let key = |b: &BlockRec| (b.start, b.kind, b.flags, b.terminator_len);
            assert_eq!(
                blocks.iter().map(key).collect::<Vec<_>>(),
                seq_blocks.iter().map(key).collect::<Vec<_>>()
            );
            assert_eq!(diags, seq_diags, "chunk {chunk}");
        }
        assert!(seq_blocks.iter().any(|b| b.flags & flag::TEXT != 0));
    }
}
