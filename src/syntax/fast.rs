//! Allocation-free recogniser for the blocks CAM output is made of: optional skip level, address words and a
//! comment. Whatever it accepts the full grammar accepts as a plain block without diagnostics (a test checks
//! this over every fixture line); anything else goes to the full grammar.

use super::lexeme::{Digits, is_blank, skip_level_len, word_end_with};

pub(crate) fn plain_block(line: &[u8]) -> bool {
    plain_prefix(line) == Some(line.len())
}

/// Length of the plain block at the start of `rest`, up to (not including) its CR / LF, or None when the
/// line is not plain. Finds the line end in the same pass as the words.
pub(crate) fn plain_prefix(rest: &[u8]) -> Option<usize> {
    plain_prefix_with(rest, &mut ())
}

/// What the recogniser reports of a line while it reads it: nothing (`()`), or the words and their values to a
/// reader that times the moves (`omm::timeline::moves`). Every line ends with exactly one of
/// [`Words::end_line`] (the recogniser accepted it) or [`Words::other_line`] (it did not, whatever was
/// reported of it before).
pub trait Words {
    type Number: Digits + Default;
    fn skip_level(&mut self);
    /// An address word: its letter as written and its number's parts.
    fn word(&mut self, letter: u8, number: &Self::Number);
    fn comment(&mut self);
    /// The recogniser accepted the line.
    fn end_line(&mut self);
    /// The recogniser did not accept the line; `plain` is its text when the full grammar found it a plain
    /// block without flags or diagnostics (`G2 X1 Y1 CR=5`), which a reader may read on its own terms.
    fn other_line(&mut self, plain: Option<&[u8]>);
}

impl Words for () {
    type Number = ();
    #[inline(always)]
    fn skip_level(&mut self) {}
    #[inline(always)]
    fn word(&mut self, _: u8, _: &()) {}
    #[inline(always)]
    fn comment(&mut self) {}
    #[inline(always)]
    fn end_line(&mut self) {}
    #[inline(always)]
    fn other_line(&mut self, _: Option<&[u8]>) {}
}

/// [`plain_prefix`], reporting the line's parts to `w` (but not its end: see [`Words`]).
#[inline(always)]
pub(crate) fn plain_prefix_with<W: Words>(rest: &[u8], w: &mut W) -> Option<usize> {
    let n = rest.len();
    // Blanks only: a control character (read as a blank, with a warning) is the grammar's to report.
    let mut k = 0;
    while k < n && is_blank(rest[k]) {
        k += 1;
    }
    let level = skip_level_len(&rest[k..]);
    if level > 0 {
        w.skip_level();
        k += level;
    }
    loop {
        while k < n && is_blank(rest[k]) {
            k += 1;
        }
        match rest.get(k) {
            None | Some(b'\r' | b'\n') => return Some(k),
            Some(b';') => {
                w.comment();
                return Some(k + memchr::memchr2(b'\n', b'\r', &rest[k..]).unwrap_or(n - k));
            }
            Some(&letter) => {
                let mut number = W::Number::default();
                k = word_end_with(rest, k, &mut number)?.1;
                w.word(letter, &number);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::plain_block;
    use crate::source::{Span, raw_lines};
    use crate::syntax::BlockKind;
    use crate::syntax::grammar::parse_block;

    /// Every line the fast path accepts, the full grammar accepts as a plain block without diagnostics.
    fn check_agreement(src: &[u8]) -> usize {
        let mut accepted = 0;
        for line in raw_lines(src) {
            let content = line.content().slice(src);
            if !plain_block(content) {
                continue;
            }
            accepted += 1;
            let end = Span::new(content.len(), content.len());
            let full = parse_block(content, Span::new(0, content.len()), end, content.len());
            assert!(
                full.diagnostics.is_empty(),
                "{:?}",
                content.escape_ascii().to_string()
            );
            assert_eq!(
                (full.kind, full.flags),
                (BlockKind::Plain, 0),
                "{}",
                content.escape_ascii()
            );
        }
        accepted
    }

    fn files_under(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
        for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
            let path = entry.path();
            if path.is_dir() {
                files_under(&path, out)
            } else {
                out.push(path)
            }
        }
    }

    #[test]
    fn fast_path_agrees_with_the_grammar_on_fixtures_and_corpus() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut files = Vec::new();
        files_under(&root.join("fixtures/nc"), &mut files);
        if let Some(corpus) = crate::shared_data::path("corpus") {
            files_under(&corpus, &mut files);
        }
        let accepted: usize = files
            .iter()
            .map(|f| check_agreement(&std::fs::read(f).unwrap()))
            .sum();
        assert!(
            accepted > 50,
            "the fast path takes the plain word blocks ({accepted})"
        );
    }

    #[test]
    fn fast_path_leaves_everything_else_to_the_grammar() {
        for line in [
            &b"X1=5"[..],
            b"R1=2",
            b"G1 X=R1",
            b"CYCLE800()",
            b"IF R1>0",
            b":10 X1",
            b"LBL: X1",
            b"%_N_A_MPF",
            b"M30\x1a",
            b"\x1a",
            b"G1 X10 \xa3\xbb",
        ] {
            assert!(!plain_block(line), "{}", line.escape_ascii());
        }
        for line in [
            &b"N10 G1 X12.345 Y-3.2 Z0.5 F800"[..],
            b"/2 G0X0Y0 ; c",
            b"",
            b"   ",
            b"\tM30&",
            b"N 10 G 1 X 10 Y -2.5 S 1000 T 5 F 100 M 3 D 1",
        ] {
            assert!(plain_block(line), "{}", line.escape_ascii());
            assert_eq!(check_agreement(line), usize::from(!line.is_empty()));
        }
    }
}
