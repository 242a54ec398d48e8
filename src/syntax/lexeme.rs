//! Allocation-free nom lexemes shared by the fast recogniser and the full block grammar, so that both agree on
//! what a word, a number or a name is.

use nom::branch::alt;
use nom::bytes::complete::{tag, tag_no_case, take_till, take_while, take_while_m_n, take_while1};
use nom::combinator::{opt, recognize};
use nom::error::{ErrorKind, ParseError};
use nom::{IResult, Parser};

/// Parse failure: how much input was left where it happened (smaller = further) and what was expected there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct PErr {
    pub rest: usize,
    pub expected: &'static str,
}

impl ParseError<&[u8]> for PErr {
    fn from_error_kind(input: &[u8], _kind: ErrorKind) -> Self {
        PErr {
            rest: input.len(),
            expected: "",
        }
    }

    fn append(_input: &[u8], _kind: ErrorKind, other: Self) -> Self {
        other
    }

    /// Of two failed alternatives, report the one that got further.
    fn or(self, other: Self) -> Self {
        if other.rest < self.rest || (other.rest == self.rest && self.expected.is_empty()) {
            other
        } else {
            self
        }
    }
}

pub(crate) type R<'a, T> = IResult<&'a [u8], T, PErr>;

pub(crate) fn fail<'a, T>(at: &'a [u8], expected: &'static str) -> R<'a, T> {
    Err(nom::Err::Error(PErr {
        rest: at.len(),
        expected,
    }))
}

/// Blanks separate tokens: space, tab, `&` (a space in Sinumerik), vertical tab and form feed.
#[inline]
pub(crate) fn is_blank(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'&' | 0x0b | 0x0c)
}

/// The DOS end-of-file byte (Ctrl-Z) that old transfer software writes after the last block.
pub(crate) const DOS_EOF: u8 = 0x1a;

/// A control character other than a blank or a line end: the control reads it as a blank (Programming
/// Manual, character set: "non-printable special characters are treated like blanks"). The grammar keeps
/// it as trivia and says so; the fast recogniser leaves such lines to the grammar.
#[inline]
pub(crate) fn is_control(b: u8) -> bool {
    (b < 0x20 && !is_blank(b) && b != b'\n' && b != b'\r') || b == 0x7f
}

/// Trivia between tokens: blanks and control characters.
#[inline]
pub(crate) fn is_trivia(b: u8) -> bool {
    is_blank(b) || is_control(b)
}

pub(crate) fn is_ident_char(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_'
}

pub(crate) fn blanks(i: &[u8]) -> R<'_, &[u8]> {
    take_while1(is_trivia).parse(i)
}

/// `i` after its leading trivia.
#[inline]
pub(crate) fn skip_blanks(i: &[u8]) -> &[u8] {
    let mut n = 0;
    while n < i.len() && is_trivia(i[n]) {
        n += 1;
    }
    &i[n..]
}

/// `[A-Za-z_][A-Za-z0-9_]*`
pub(crate) fn ident(i: &[u8]) -> R<'_, &[u8]> {
    recognize((
        take_while_m_n(1, 1, |b: u8| b.is_ascii_alphabetic() || b == b'_'),
        take_while(is_ident_char),
    ))
    .parse(i)
}

/// What the recogniser hands a number's parts to while it finds the number's end: nothing, for the grammar
/// (`()`), or an accumulator of its value ([`super::Decimal`]), so a value is read in the
/// same pass that recognises it.
pub trait Digits {
    fn sign(&mut self, negative: bool);
    /// One digit (0-9), before or after the point.
    fn digit(&mut self, d: u64);
    /// After the digits: how many came before the point and after it, and whether there was a point.
    fn counts(&mut self, int: usize, fraction: usize, point: bool);
    fn exponent(&mut self);
}

impl Digits for () {
    #[inline(always)]
    fn sign(&mut self, _: bool) {}
    #[inline(always)]
    fn digit(&mut self, _: u64) {}
    #[inline(always)]
    fn counts(&mut self, _: usize, _: usize, _: bool) {}
    #[inline(always)]
    fn exponent(&mut self) {}
}

/// End of the number starting at `s[k]`: `12`, `12.`, `12.5`, `.5` (with a sign if `signed`), each optionally
/// with a Sinumerik exponent `EX[+-]digits`. Index-based and inlined: every word of every block goes
/// through it.
#[inline(always)]
fn number_end(s: &[u8], k: usize, signed: bool) -> Option<usize> {
    number_end_with(s, k, signed, &mut ())
}

/// [`number_end`], handing the number's parts to `d`.
#[inline(always)]
pub(crate) fn number_end_with(
    s: &[u8],
    mut k: usize,
    signed: bool,
    d: &mut impl Digits,
) -> Option<usize> {
    let n = s.len();
    if signed && k < n && (s[k] == b'+' || s[k] == b'-') {
        d.sign(s[k] == b'-');
        k += 1;
    }
    let int_start = k;
    k = digits_end(s, k, d);
    let int = k - int_start;
    if k < n && s[k] == b'.' {
        let frac_start = k + 1;
        k = digits_end(s, frac_start, d);
        if int == 0 && k == frac_start {
            return None;
        }
        d.counts(int, k - frac_start, true);
    } else if int == 0 {
        return None;
    } else {
        d.counts(int, 0, false);
    }
    if k + 1 < n && (s[k] | 0x20) == b'e' && (s[k + 1] | 0x20) == b'x' {
        let mut e = k + 2;
        if e < n && (s[e] == b'+' || s[e] == b'-') {
            e += 1;
        }
        let digits = e;
        while e < n && s[e].is_ascii_digit() {
            e += 1;
        }
        if e > digits {
            d.exponent();
            k = e;
        }
    }
    Some(k)
}

/// End of the digits starting at `s[k]`, each handed to `d`. The digit's value is the test for it, so the
/// test and the hand-over share one subtraction.
#[inline(always)]
fn digits_end(s: &[u8], mut k: usize, d: &mut impl Digits) -> usize {
    while let Some(&b) = s.get(k) {
        // Widened first: the accumulator adds it as it is.
        let digit = u64::from(b).wrapping_sub(u64::from(b'0'));
        if digit > 9 {
            break;
        }
        d.digit(digit);
        k += 1;
    }
    k
}

fn lexeme<'a>(i: &'a [u8], len: Option<usize>, expected: &'static str) -> R<'a, &'a [u8]> {
    match len {
        Some(n) => Ok((&i[n..], &i[..n])),
        None => fail(i, expected),
    }
}

pub(crate) fn unsigned_number(i: &[u8]) -> R<'_, &[u8]> {
    lexeme(i, number_end(i, 0, false), "a number")
}

pub(crate) fn signed_number(i: &[u8]) -> R<'_, &[u8]> {
    lexeme(i, number_end(i, 0, true), "a number")
}

/// End of the address letter and number starting at `s[k]` (`G1`, `X-3.2`, `F.5`, `X 10`) and where the blanks
/// after it end, or None when the name goes on (`X1_A`), is indexed or called (`R1[`, `L1(`, `L340 (`) or
/// assigned (`X1=5` is an assignment to axis `X1`).
#[inline(always)]
pub(crate) fn word_end(s: &[u8], k: usize) -> Option<(usize, usize)> {
    word_end_with(s, k, &mut ())
}

/// [`word_end`], handing the number's parts to `d`.
#[inline(always)]
pub(crate) fn word_end_with(s: &[u8], k: usize, d: &mut impl Digits) -> Option<(usize, usize)> {
    if k >= s.len() || !s[k].is_ascii_alphabetic() {
        return None;
    }
    let end = number_end_with(s, value_start(s, k), true, d)?;
    if matches!(s.get(end), Some(b'_' | b'[')) {
        return None;
    }
    let mut next = end;
    while next < s.len() && is_blank(s[next]) {
        next += 1;
    }
    match s.get(next) {
        Some(b'(') => None,
        Some(b'=') if s.get(next + 1) != Some(&b'=') => None,
        _ => Some((end, next)),
    }
}

/// Where the value of the address letter at `s[k]` starts: right after it, or after the blanks that part
/// them (`X 10`, `S 1000`: the control reads it as `X10`; CAM post-processors and hand edits write it).
#[inline(always)]
fn value_start(s: &[u8], k: usize) -> usize {
    let mut v = k + 1;
    while v < s.len() && is_blank(s[v]) {
        v += 1;
    }
    v
}

/// A word at the start of `i` as where its value starts (after the letter and any blanks) and where it ends.
pub(crate) fn word(i: &[u8]) -> Option<(usize, usize)> {
    word_end(i, 0).map(|(end, _)| (value_start(i, 0), end))
}

/// Length of a skip level at the start of `i`: `/` or `/0` … `/9` (0 if none).
pub(crate) fn skip_level_len(i: &[u8]) -> usize {
    match i {
        [b'/', d, ..] if d.is_ascii_digit() => 2,
        [b'/', ..] => 1,
        _ => 0,
    }
}

/// A block number at the start of `i` — `N10`, `N 10` (a word with digits only) or `:10` — as where its
/// digits start and where it ends.
pub(crate) fn block_number_at(i: &[u8]) -> Option<(usize, usize)> {
    match i.first()? {
        b'N' | b'n' => {
            word(i).filter(|&(digits, end)| i[digits..end].iter().all(u8::is_ascii_digit))
        }
        b':' => {
            let end = 1 + i[1..].iter().take_while(|b| b.is_ascii_digit()).count();
            (end > 1 && !i.get(end).is_some_and(|&b| is_ident_char(b))).then_some((1, end))
        }
        _ => None,
    }
}

/// The number of the block number (`N10`, `N 10`, `:10`) a line starts with, after blanks and a skip level;
/// `None` also for a number beyond `u64`, which no jump can name.
pub(crate) fn leading_block_number(line: &[u8]) -> Option<u64> {
    let i = skip_blanks(line);
    let i = skip_blanks(&i[skip_level_len(i)..]);
    let (digits, end) = block_number_at(i)?;
    std::str::from_utf8(&i[digits..end]).ok()?.parse().ok()
}

/// `"…"`: any bytes but the quote; strings cannot span lines.
pub(crate) fn string(i: &[u8]) -> R<'_, &[u8]> {
    recognize((tag("\""), take_till(|b| b == b'"'), tag("\""))).parse(i)
}

/// `'H1F'` (hex) or `'B101'` (binary).
pub(crate) fn bit_literal(i: &[u8]) -> R<'_, &[u8]> {
    let hex = (tag_no_case("H"), take_while1(|b: u8| b.is_ascii_hexdigit()));
    let bin = (
        tag_no_case("B"),
        take_while1(|b: u8| b == b'0' || b == b'1'),
    );
    recognize((tag("'"), alt((recognize(hex), recognize(bin))), tag("'"))).parse(i)
}

/// `$` followed by a name: `$P_UIFR`, `$AA_IM`, `$A_DBB`; `$$SA_…` (doubled) reads or writes machine and
/// setting data in the main run, in synchronized actions.
pub(crate) fn sysvar_name(i: &[u8]) -> R<'_, &[u8]> {
    recognize((tag("$"), opt(tag("$")), take_while1(is_ident_char))).parse(i)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_stop_where_names_assignments_and_calls_begin() {
        assert_eq!(word(b"X-3.2 Y"), Some((1, 5)));
        assert_eq!(word(b"G1X10"), Some((1, 2)));
        assert_eq!(
            word(b"X 10 Y"),
            Some((2, 4)),
            "blanks part letter and value"
        );
        assert_eq!(word(b"Y\t-2.5"), Some((2, 6)));
        assert_eq!(word(b"X1=5"), None);
        assert_eq!(word(b"X1 = 5"), None);
        assert_eq!(word(b"X 1=5"), None);
        assert_eq!(word(b"R1[2]"), None);
        assert_eq!(word(b"CYCLE800("), None);
        assert_eq!(word(b"T1_X"), None);
        assert_eq!(word(b"IF R1>0"), None, "a keyword is not a word");
        assert_eq!(word(b"X =5"), None);
        assert_eq!(word(b"X - 5"), None, "the sign belongs to the number");
        assert_eq!(word(b"X1==2"), Some((1, 2)));
    }

    #[test]
    fn block_numbers_after_blanks_and_skip_levels() {
        assert_eq!(leading_block_number(b"  /3 N100 G1"), Some(100));
        assert_eq!(leading_block_number(b":20 X1"), Some(20));
        assert_eq!(leading_block_number(b"N 30 X1"), Some(30));
        assert_eq!(leading_block_number(b"n0040"), Some(40));
        assert_eq!(
            leading_block_number(b"N1.5 X1"),
            None,
            "block numbers are whole"
        );
        assert_eq!(
            leading_block_number(b"N10=5"),
            None,
            "an assignment, not a block number"
        );
        assert_eq!(leading_block_number(b":2A"), None);
        assert_eq!(leading_block_number(b"N99999999999999999999999"), None);
        assert_eq!(block_number_at(b"N 10"), Some((2, 4)));
        assert_eq!(skip_level_len(b"/"), 1);
        assert_eq!(skip_level_len(b"/7 N1"), 2);
    }

    #[test]
    fn control_characters_are_trivia_but_not_blanks() {
        assert!(is_trivia(DOS_EOF) && is_control(DOS_EOF) && !is_blank(DOS_EOF));
        assert!(is_trivia(0) && is_trivia(0x7f));
        for b in [b'\n', b'\r', b' ', b'\t', b'&', b'A', 0x80, 0xa3] {
            assert!(!is_control(b), "{b:#x}");
        }
        assert_eq!(skip_blanks(b" \x1a\x00 X1"), b"X1");
    }

    #[test]
    fn numbers_take_sinumerik_exponents() {
        assert_eq!(unsigned_number(b"1.5EX-3 ").unwrap().1, b"1.5EX-3");
        assert_eq!(unsigned_number(b".5").unwrap().1, b".5");
        assert_eq!(unsigned_number(b"12.").unwrap().1, b"12.");
        assert!(unsigned_number(b".").is_err());
    }
}
