//! Bytes that look like something else: control characters the control reads as blanks, the DOS end-of-file
//! filler after the last block, and the full-width punctuation that Chinese (GBK) and UTF-8 editors put where
//! an ASCII `;`, `:` or `(` was meant.

use super::lexeme::{DOS_EOF, is_control};
use super::tree::{Node, NodeKind};
use crate::diagnostic::Diagnostic;
use crate::source::Span;

/// Where the DOS end-of-file filler at the end of `src` starts: the longest tail of 0x1A bytes and line
/// ends that holds at least one 0x1A (`src.len()` when there is none). DOS tools wrote 0x1A after the last
/// line; the control reads it as a blank.
pub(crate) fn eof_filler(src: &[u8]) -> usize {
    let tail = src
        .iter()
        .rev()
        .take_while(|&&b| matches!(b, DOS_EOF | b'\r' | b'\n'))
        .count();
    let start = src.len() - tail;
    if src[start..].contains(&DOS_EOF) {
        start
    } else {
        src.len()
    }
}

/// Reports the control characters a block's trivia holds, except the end-of-file filler.
pub(crate) struct ControlCharacters<'a> {
    src: &'a [u8],
    filler: usize,
}

impl<'a> ControlCharacters<'a> {
    pub(crate) fn new(src: &'a [u8], filler: usize) -> Self {
        ControlCharacters { src, filler }
    }

    /// One warning per run of control characters in a trivia leaf of `tree`.
    pub(crate) fn report(&self, tree: &Node, diags: &mut Vec<Diagnostic>) {
        tree.walk(&mut |n| {
            if n.kind != NodeKind::Trivia {
                return;
            }
            let bytes = n.span.slice(self.src);
            let mut k = 0;
            while k < bytes.len() {
                if !is_control(bytes[k]) {
                    k += 1;
                    continue;
                }
                let run = bytes[k..].iter().take_while(|&&b| is_control(b)).count();
                let span = Span::new(n.span.start + k, n.span.start + k + run);
                if let Some(d) = self.warning(span) {
                    diags.push(d);
                }
                k += run;
            }
        });
    }

    fn warning(&self, span: Span) -> Option<Diagnostic> {
        let bytes = span.slice(self.src);
        if bytes.iter().all(|&b| b == DOS_EOF) {
            if span.start >= self.filler {
                return None;
            }
            return Some(
                Diagnostic::warning(span, "DOS end-of-file byte 0x1A before the end of the file")
                    .with_help(
                        "the control reads it as a blank, but a transfer that stops at this byte \
                         drops the rest of the file; remove it",
                    ),
            );
        }
        let first = bytes
            .iter()
            .copied()
            .find(|&b| b != DOS_EOF)
            .unwrap_or(DOS_EOF);
        Some(
            Diagnostic::warning(
                span,
                format!("control character 0x{first:02X} read as a blank"),
            )
            .with_help(
                "the control treats non-printable characters as blanks; remove it, other \
                     tools may not",
            ),
        )
    }
}

/// Names the non-ASCII bytes at the start of `at` where the grammar failed: their length, what they are
/// and what the control needs instead. `None` when `at` starts with ASCII.
pub(crate) fn name_odd_bytes(at: &[u8]) -> Option<(usize, String, &'static str)> {
    if at.first().is_none_or(u8::is_ascii) {
        return None;
    }
    if let Some((len, ascii, encoding)) = full_width(at) {
        let bytes = hex(&at[..len]);
        let what = match ascii {
            b' ' => format!("an ideographic space ({encoding} {bytes})"),
            _ => format!("a full-width `{}` ({encoding} {bytes})", ascii as char),
        };
        let help = match ascii {
            b';' => "the control needs an ASCII `;` to start a comment",
            b':' => "the control needs an ASCII `:` after a label",
            b'(' | b')' => {
                "the control needs ASCII parentheses; `( … )` is not a comment, start comments with `;`"
            }
            b' ' => "the control separates words with ASCII blanks",
            _ => {
                "outside comments and strings the control reads ASCII only; write the ASCII character"
            }
        };
        return Some((len, what, help));
    }
    if at.starts_with(b"\xEF\xBB\xBF") {
        return Some((
            3,
            "a byte-order mark (EF BB BF) inside the file".into(),
            "files joined together? a byte-order mark belongs only at the start of the file",
        ));
    }
    let len = utf8_len(at);
    let what = match std::str::from_utf8(&at[..len]) {
        Ok(c) if len > 1 => format!("the non-ASCII character `{c}` (UTF-8 {})", hex(&at[..len])),
        _ => format!("the non-ASCII byte 0x{:02X}", at[0]),
    };
    Some((
        len,
        what,
        "outside comments and strings the control reads ASCII only; start a comment with `;`",
    ))
}

/// `A3 BB`: bytes as hex pairs.
fn hex(bytes: &[u8]) -> String {
    let pairs: Vec<String> = bytes.iter().map(|b| format!("{b:02X}")).collect();
    pairs.join(" ")
}

/// A full-width form of an ASCII character at the start of `i` (`；` `：` `（` `）` `，` `＝` …, and the
/// ideographic space): its length, the ASCII character and the encoding.
fn full_width(i: &[u8]) -> Option<(usize, u8, &'static str)> {
    match i {
        // GBK (GB 2312 row 3) holds the full-width forms of ASCII 0x21–0x7E at A3 A1–A3 FE.
        [0xA3, b @ 0xA1..=0xFE, ..] => Some((2, b - 0x80, "GBK")),
        [0xA1, 0xA1, ..] => Some((2, b' ', "GBK")),
        // UTF-8: U+FF01–U+FF5E are the full-width forms of ASCII 0x21–0x7E.
        [0xEF, 0xBC, b @ 0x81..=0xBF, ..] => Some((3, b - 0x81 + 0x21, "UTF-8")),
        [0xEF, 0xBD, b @ 0x80..=0x9E, ..] => Some((3, b - 0x80 + 0x60, "UTF-8")),
        [0xE3, 0x80, 0x80, ..] => Some((3, b' ', "UTF-8")),
        _ => None,
    }
}

/// Length of the character at the start of `i`: a whole UTF-8 sequence when the bytes form one (so spans
/// never split a character of a UTF-8 file), else one byte (Latin-1, GBK, broken bytes); 0 at the end.
pub(crate) fn utf8_len(i: &[u8]) -> usize {
    let n = match i.first() {
        None => return 0,
        Some(0xC0..=0xDF) => 2,
        Some(0xE0..=0xEF) => 3,
        Some(0xF0..=0xF7) => 4,
        Some(_) => 1,
    };
    if i.len() >= n && std::str::from_utf8(&i[..n]).is_ok() {
        n
    } else {
        1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_filler_is_the_tail_of_eof_bytes_and_line_ends() {
        assert_eq!(eof_filler(b"M30\n\x1a"), 3);
        assert_eq!(eof_filler(b"M30\r\n\x1a\r\n\x1a\x1a"), 3);
        assert_eq!(eof_filler(b"M30\x1a"), 3);
        assert_eq!(eof_filler(b"M30\n"), 4, "line ends alone are no filler");
        assert_eq!(
            eof_filler(b"\x1aM30\n"),
            5,
            "a 0x1A before the last block is not filler"
        );
        assert_eq!(eof_filler(b""), 0);
    }

    #[test]
    fn full_width_punctuation_is_named_with_its_bytes() {
        let (len, what, help) = name_odd_bytes(b"\xA3\xBB comment").unwrap();
        assert_eq!((len, what.as_str()), (2, "a full-width `;` (GBK A3 BB)"));
        assert!(help.contains("ASCII `;`"));
        let named = |b: &[u8]| name_odd_bytes(b).map(|(len, what, _)| (len, what));
        assert_eq!(
            named(b"\xA3\xBA"),
            Some((2, "a full-width `:` (GBK A3 BA)".into()))
        );
        assert_eq!(
            named(b"\xA3\xA8x\xA3\xA9"),
            Some((2, "a full-width `(` (GBK A3 A8)".into()))
        );
        assert_eq!(
            named("；".as_bytes()),
            Some((3, "a full-width `;` (UTF-8 EF BC 9B)".into()))
        );
        assert_eq!(
            named("～".as_bytes()),
            Some((3, "a full-width `~` (UTF-8 EF BD 9E)".into()))
        );
        assert_eq!(
            named("\u{3000}".as_bytes()),
            Some((3, "an ideographic space (UTF-8 E3 80 80)".into()))
        );
        assert_eq!(
            named("ü".as_bytes()),
            Some((2, "the non-ASCII character `ü` (UTF-8 C3 BC)".into()))
        );
        assert_eq!(
            named(b"\xFC\n"),
            Some((1, "the non-ASCII byte 0xFC".into()))
        );
        assert_eq!(named(b"X1"), None);
        assert_eq!(named(b""), None);
    }
}
