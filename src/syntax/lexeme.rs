//! Allocation-free nom lexemes shared by the fast recogniser and the full block grammar, so that both agree on
//! what a word, a number or a name is.

use nom::branch::alt;
use nom::bytes::complete::{tag, tag_no_case, take_till, take_while, take_while_m_n, take_while1};
use nom::combinator::recognize;
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

pub(crate) fn is_ident_char(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_'
}

pub(crate) fn blanks(i: &[u8]) -> R<'_, &[u8]> {
    take_while1(is_blank).parse(i)
}

#[inline]
pub(crate) fn skip_blanks(i: &[u8]) -> &[u8] {
    let mut n = 0;
    while n < i.len() && is_blank(i[n]) {
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

#[inline]
fn digits_end(i: &[u8], mut end: usize) -> usize {
    while end < i.len() && i[end].is_ascii_digit() {
        end += 1;
    }
    end
}

/// Length of the number at the start of `i`: `12`, `12.`, `12.5`, `.5`, each optionally with a Sinumerik
/// exponent `EX[+-]digits`. Hand-rolled because every word of every block goes through it.
#[inline]
fn scan_unsigned_number(i: &[u8]) -> Option<usize> {
    let int_end = digits_end(i, 0);
    let mut end = int_end;
    if i.get(end) == Some(&b'.') {
        let frac_end = digits_end(i, end + 1);
        if int_end == 0 && frac_end == end + 1 {
            return None;
        }
        end = frac_end;
    } else if int_end == 0 {
        return None;
    }
    if matches!(i.get(end), Some(b'E' | b'e')) && matches!(i.get(end + 1), Some(b'X' | b'x')) {
        let sign = usize::from(matches!(i.get(end + 2), Some(b'+' | b'-')));
        let exp_end = digits_end(i, end + 2 + sign);
        if exp_end > end + 2 + sign {
            end = exp_end;
        }
    }
    Some(end)
}

#[inline]
fn scan_signed_number(i: &[u8]) -> Option<usize> {
    let sign = usize::from(matches!(i.first(), Some(b'+' | b'-')));
    scan_unsigned_number(&i[sign..]).map(|n| n + sign)
}

fn lexeme<'a>(i: &'a [u8], len: Option<usize>, expected: &'static str) -> R<'a, &'a [u8]> {
    match len {
        Some(n) => Ok((&i[n..], &i[..n])),
        None => fail(i, expected),
    }
}

pub(crate) fn unsigned_number(i: &[u8]) -> R<'_, &[u8]> {
    lexeme(i, scan_unsigned_number(i), "a number")
}

pub(crate) fn signed_number(i: &[u8]) -> R<'_, &[u8]> {
    lexeme(i, scan_signed_number(i), "a number")
}

/// Length of the address letter and number at the start of `i` (`G1`, `X-3.2`, `F.5`), or None when the
/// name goes on (`X1_A`), is indexed or called (`R1[`, `L1(`, `L340 (`) or assigned (`X1=5` is an
/// assignment to axis `X1`).
#[inline]
pub(crate) fn scan_word(i: &[u8]) -> Option<usize> {
    if !i.first()?.is_ascii_alphabetic() {
        return None;
    }
    let end = 1 + scan_signed_number(&i[1..])?;
    let rest = &i[end..];
    let next = skip_blanks(rest);
    let continues = matches!(rest.first(), Some(b'_' | b'[')) || next.first() == Some(&b'(');
    let assigned = next.first() == Some(&b'=') && next.get(1) != Some(&b'=');
    (!continues && !assigned).then_some(end)
}

/// A word as (letter, number).
pub(crate) fn word(i: &[u8]) -> R<'_, (&[u8], &[u8])> {
    match scan_word(i) {
        Some(end) => Ok((&i[end..], (&i[..1], &i[1..end]))),
        None => fail(i, "a word"),
    }
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

/// `$` followed by a name: `$P_UIFR`, `$AA_IM`, `$A_DBB`.
pub(crate) fn sysvar_name(i: &[u8]) -> R<'_, &[u8]> {
    recognize((tag("$"), take_while1(is_ident_char))).parse(i)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_stop_where_names_assignments_and_calls_begin() {
        assert_eq!(
            word(b"X-3.2 Y").unwrap(),
            (&b" Y"[..], (&b"X"[..], &b"-3.2"[..]))
        );
        assert_eq!(word(b"G1X10").unwrap().0, b"X10");
        assert!(word(b"X1=5").is_err());
        assert!(word(b"X1 = 5").is_err());
        assert!(word(b"R1[2]").is_err());
        assert!(word(b"CYCLE800(").is_err());
        assert!(word(b"T1_X").is_err());
        assert_eq!(word(b"X1==2").unwrap().0, b"==2");
    }

    #[test]
    fn numbers_take_sinumerik_exponents() {
        assert_eq!(unsigned_number(b"1.5EX-3 ").unwrap().1, b"1.5EX-3");
        assert_eq!(unsigned_number(b".5").unwrap().1, b".5");
        assert_eq!(unsigned_number(b"12.").unwrap().1, b"12.");
        assert!(unsigned_number(b".").is_err());
    }
}
