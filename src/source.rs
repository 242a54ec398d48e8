//! The retained source bytes: spans, line splitting and the line index.
//!
//! Nothing here assumes UTF-8. A line ends at LF, at CRLF or at a lone CR; the terminator is kept apart from
//! the line's content so that printing can reproduce every byte.

use serde::Serialize;

/// A half-open byte range `start..end` into a program's source.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default, Serialize)]
pub struct Span {
    pub start: usize,
    pub end: usize,
}

impl Span {
    pub const fn new(start: usize, end: usize) -> Self {
        Span { start, end }
    }

    pub const fn len(&self) -> usize {
        self.end - self.start
    }

    pub const fn is_empty(&self) -> bool {
        self.start == self.end
    }

    /// The bytes this span covers in `src`.
    pub fn slice<'a>(&self, src: &'a [u8]) -> &'a [u8] {
        &src[self.start..self.end]
    }
}

/// One physical line: its content (without terminator) and the terminator (0, 1 or 2 bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RawLine {
    pub start: usize,
    pub content_end: usize,
    pub end: usize,
}

impl RawLine {
    /// The line starting at `start` whose content ends at `content_end` (a CR, an LF or the end of `src`).
    pub fn ending_at(src: &[u8], start: usize, content_end: usize) -> Self {
        let terminator = match src.get(content_end) {
            None => 0,
            Some(b'\r') if src.get(content_end + 1) == Some(&b'\n') => 2,
            Some(_) => 1,
        };
        RawLine {
            start,
            content_end,
            end: content_end + terminator,
        }
    }

    pub fn content(&self) -> Span {
        Span::new(self.start, self.content_end)
    }

    pub fn terminator(&self) -> Span {
        Span::new(self.content_end, self.end)
    }
}

/// Splits `src` into lines at LF, CRLF and lone CR. An empty input has no lines; a final line without a
/// terminator is still a line.
pub fn raw_lines(src: &[u8]) -> RawLines<'_> {
    raw_lines_in(src, 0, src.len())
}

/// The lines of `src[start..end]` with offsets into `src`; `start` and `end` must be line boundaries.
pub fn raw_lines_in(src: &[u8], start: usize, end: usize) -> RawLines<'_> {
    RawLines {
        src: &src[..end],
        pos: start,
    }
}

pub struct RawLines<'a> {
    src: &'a [u8],
    pos: usize,
}

impl Iterator for RawLines<'_> {
    type Item = RawLine;

    fn next(&mut self) -> Option<RawLine> {
        let start = self.pos;
        if start >= self.src.len() {
            return None;
        }
        let rest = &self.src[start..];
        let line = match memchr::memchr2(b'\n', b'\r', rest) {
            None => RawLine {
                start,
                content_end: self.src.len(),
                end: self.src.len(),
            },
            Some(i) => {
                let content_end = start + i;
                let crlf = rest[i] == b'\r' && rest.get(i + 1) == Some(&b'\n');
                RawLine {
                    start,
                    content_end,
                    end: content_end + if crlf { 2 } else { 1 },
                }
            }
        };
        self.pos = line.end;
        Some(line)
    }
}

/// Maps byte offsets to 1-based line and byte column.
#[derive(Debug, Clone)]
pub struct LineIndex {
    lines: Vec<(usize, usize)>,
}

impl LineIndex {
    pub fn new(src: &[u8]) -> Self {
        let mut lines: Vec<(usize, usize)> =
            raw_lines(src).map(|l| (l.start, l.content_end)).collect();
        // A terminator at the very end opens an (empty) last line, which offsets may point at.
        if lines.is_empty() || matches!(src.last(), Some(b'\n' | b'\r')) {
            lines.push((src.len(), src.len()));
        }
        LineIndex { lines }
    }

    /// 1-based line and 1-based byte column of `offset` (offsets past the end map to the last line).
    pub fn line_col(&self, offset: usize) -> (usize, usize) {
        let i = self
            .lines
            .partition_point(|&(start, _)| start <= offset)
            .max(1)
            - 1;
        (i + 1, offset - self.lines[i].0 + 1)
    }

    /// The content of the 1-based `line`, without its terminator (an empty span past the last line).
    pub fn line_span(&self, line: usize) -> Span {
        match line.checked_sub(1).and_then(|i| self.lines.get(i)) {
            Some(&(start, end)) => Span::new(start, end),
            None => {
                let end = self.lines.last().map_or(0, |l| l.1);
                Span::new(end, end)
            }
        }
    }

    pub fn line_count(&self) -> usize {
        self.lines.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_every_line_ending_kind() {
        let src = b"a\nb\r\nc\rd";
        let lines: Vec<_> = raw_lines(src)
            .map(|l| (l.content().slice(src), l.terminator().slice(src)))
            .collect();
        assert_eq!(
            lines,
            vec![
                (&b"a"[..], &b"\n"[..]),
                (b"b", b"\r\n"),
                (b"c", b"\r"),
                (b"d", b"")
            ]
        );
    }

    #[test]
    fn line_col_is_one_based_in_bytes() {
        let idx = LineIndex::new(b"ab\r\ncd\n");
        assert_eq!(idx.line_col(0), (1, 1));
        assert_eq!(idx.line_col(4), (2, 1));
        assert_eq!(idx.line_col(5), (2, 2));
        assert_eq!(idx.line_col(7), (3, 1));
        assert_eq!(idx.line_span(2), Span::new(4, 6));
        assert_eq!(idx.line_count(), 3);
    }
}
