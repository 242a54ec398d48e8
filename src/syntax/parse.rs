//! Parsing a source into a [`Program`]: pieces of a large source parsed in parallel, each line by the fast
//! path for plain blocks or by the grammar, then the structure pass over the whole program.

use super::block_kind::{BlockKind, flag};
use super::fast::{self, Words};
use super::grammar;
use super::odd_bytes::eof_filler;
use super::program::{BlockRec, Endings, Program, line_content};
use super::structure;
use crate::diagnostic::Diagnostic;
use crate::source::{RawLine, Span};

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
            jumps: Vec::new(),
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
        jumps: Vec::new(),
    };
    let structure = structure::analyze(&program);
    program.diagnostics.extend(structure.diagnostics);
    program.jumps = structure.jumps;
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
