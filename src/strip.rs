//! Undoing a transform: every line driftloop inserted ends in the marker comment [`MARK`], and the
//! transform never changes a byte of the program's own lines, so removing the marked lines with their own
//! line endings gives the original back byte for byte.
//!
//! The transform writes a new line with the file's dominant line ending after the line it follows. Two
//! places need care: a BOM stays first even when the header comment was inserted before the first line, and
//! in a file without a final newline the restore block at the end is written after the last line (the line
//! ending before it is then an inserted one, removed with it).

use crate::omm::emit::{MARK, SIGNATURE};
use crate::source::raw_lines;

const BOM: &[u8] = b"\xEF\xBB\xBF";

/// A program with driftloop's lines removed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Stripped {
    /// The original program (the input unchanged when it carries no driftloop header).
    pub bytes: Vec<u8>,
    /// 0-based lines (= blocks) of the input that were removed, ascending.
    pub removed: Vec<usize>,
    /// 0-based line of the `driftloop-omm` header comment; `None`: not transformed, nothing removed.
    pub header: Option<usize>,
    /// Lines that end in the marker although the file has no header (left in place).
    pub marked_without_header: usize,
}

/// Whether a line's content (without its terminator) is one driftloop inserted.
pub fn is_inserted(content: &[u8]) -> bool {
    content.ends_with(MARK.as_bytes())
}

/// The lines a transform inserted, found without copying the program.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Inserted {
    /// 0-based lines carrying the marker, ascending (empty when there is no header).
    pub lines: Vec<usize>,
    /// 0-based line of the `driftloop-omm` header comment.
    pub header: Option<usize>,
    /// Lines that end in the marker although the file has no header.
    pub marked_without_header: usize,
    /// The file ends in an inserted line without a line ending (the one before it was inserted too).
    last_unterminated: bool,
}

/// Finds the lines a transform inserted.
pub fn inserted(src: &[u8]) -> Inserted {
    let signature = SIGNATURE.as_bytes();
    let mut lines = Vec::new();
    let mut header = None;
    let mut last_unterminated = false;
    for (i, line) in raw_lines(src).enumerate() {
        let content = line.content().slice(src);
        last_unterminated = false;
        if is_inserted(content) {
            if header.is_none() && memchr::memmem::find(content, signature).is_some() {
                header = Some(i);
            }
            lines.push(i);
            last_unterminated = line.end == line.content_end;
        }
    }
    if header.is_none() {
        return Inserted {
            marked_without_header: lines.len(),
            lines: Vec::new(),
            header,
            last_unterminated: false,
        };
    }
    Inserted {
        lines,
        header,
        marked_without_header: 0,
        last_unterminated,
    }
}

/// The byte ranges of `src` that remain once the inserted lines are removed, in order.
pub fn kept(src: &[u8], inserted: &Inserted) -> Vec<std::ops::Range<usize>> {
    let mut out: Vec<std::ops::Range<usize>> = Vec::new();
    let mut removed = inserted.lines.iter().peekable();
    // Length of the terminator of the last line kept: dropped again when the file ends in an inserted line
    // without one (the transform wrote that terminator before its lines).
    let mut kept_terminator = 0;
    for (i, line) in raw_lines(src).enumerate() {
        if removed.next_if_eq(&&i).is_some() {
            if i == 0 && src.starts_with(BOM) {
                out.push(0..BOM.len());
            }
            continue;
        }
        match out.last_mut() {
            Some(run) if run.end == line.start => run.end = line.end,
            _ => out.push(line.start..line.end),
        }
        kept_terminator = line.end - line.content_end;
    }
    if inserted.last_unterminated
        && let Some(run) = out.last_mut()
    {
        run.end -= kept_terminator.min(run.end - run.start);
    }
    out
}

/// Removes the lines a transform inserted. A file without driftloop's header comes back unchanged.
pub fn strip(src: &[u8]) -> Stripped {
    let found = inserted(src);
    let bytes = if found.header.is_some() {
        let mut bytes = Vec::with_capacity(src.len());
        for run in kept(src, &found) {
            bytes.extend_from_slice(&src[run]);
        }
        bytes
    } else {
        src.to_vec()
    };
    Stripped {
        bytes,
        removed: found.lines,
        header: found.header,
        marked_without_header: found.marked_without_header,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn marked_lines_go_with_their_own_line_endings() {
        let t = b"; driftloop-omm 1 ;DL\r\nG0 X1\r\nR1=2 ;DL\r\nM30\r\n";
        let s = strip(t);
        assert_eq!(s.bytes, b"G0 X1\r\nM30\r\n");
        assert_eq!(s.removed, vec![0, 2]);
        assert_eq!(s.header, Some(0));
    }

    #[test]
    fn an_end_block_after_a_last_line_without_newline_takes_the_inserted_ending() {
        let s = strip(b"; driftloop-omm ;DL\nG0 X1\nM30\nG54 ;DL\nX ;DL");
        assert_eq!(s.bytes, b"G0 X1\nM30");
        let s = strip(b"; driftloop-omm ;DL\rG0 X1\rM30\rG54 ;DL");
        assert_eq!(s.bytes, b"G0 X1\rM30");
    }

    #[test]
    fn a_bom_stays_first() {
        let s = strip(b"\xEF\xBB\xBF; driftloop-omm ;DL\nG0\n");
        assert_eq!(s.bytes, b"\xEF\xBB\xBFG0\n");
    }

    #[test]
    fn without_the_header_nothing_is_removed() {
        let s = strip(b"G0 X1 ;DL\nM30\n");
        assert_eq!(s.bytes, b"G0 X1 ;DL\nM30\n");
        assert_eq!(s.header, None);
        assert_eq!(s.marked_without_header, 1);
        assert!(s.removed.is_empty());
    }
}
