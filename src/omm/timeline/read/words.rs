//! The word scanner: the plain lines CAM output is made of read without a syntax tree, straight into a
//! [`Scan`]; any other line is left to the tree.

use std::sync::Arc;

use crate::syntax::decimal_prefix;

use super::{Scan, comment};

/// The same facts without a syntax tree, for the lines CAM output is made of: one-letter address words with
/// plain numbers and an optional comment (`N120 G1 X10.5 Y-3 F800 ; finish`). Anything else — `=`, names,
/// strings, labels, R-parameters — returns `None` and takes the tree path.
pub(crate) fn scan_words_into(line: &[u8], marker: &str, s: &mut Scan) -> bool {
    s.g.len = 0;
    s.m.len = 0;
    s.mv.axes = [None; 3];
    s.mv.centre = [None; 3];
    (s.mv.radius, s.mv.f, s.s, s.tool, s.d) = (None, None, None, None, None);
    (s.marker, s.path_comment) = (false, false);
    (s.rotary_away, s.rotary_home) = (0, 0);
    s.offsets.clear();
    scan_words(line, marker, s).is_some()
}

/// The word scanner proper; `None` hands the line to the tree path (the buffer is then left half filled).
fn scan_words(line: &[u8], marker: &str, s: &mut Scan) -> Option<()> {
    let mut i = 0;
    while i < line.len() {
        let b = line[i];
        if matches!(b, b' ' | b'\t') {
            i += 1;
            continue;
        }
        if b == b';' {
            comment(&line[i..], marker, s);
            break;
        }
        // Read here so arcs stay on this path.
        if at_radius(line, i) {
            let (radius, end) = radius_at(line, i)?;
            s.mv.radius = Some(radius);
            i = end;
            continue;
        }
        let letter = b.to_ascii_uppercase();
        // R-parameters, and `L` subprogram calls with their `P`, which the tree path reads.
        if !letter.is_ascii_uppercase() || matches!(letter, b'R' | b'L' | b'P') {
            return None;
        }
        let start = i + 1;
        if letter == b'N' {
            // Block numbers only need skipping.
            let digits = line[start..]
                .iter()
                .take_while(|c| c.is_ascii_digit())
                .count();
            i = start + digits;
            if digits == 0
                || line
                    .get(i)
                    .is_some_and(|c| !matches!(c, b' ' | b'\t' | b';'))
            {
                return None;
            }
            continue;
        }
        let (v, len) = decimal_prefix(&line[start..])?;
        let end = start + len;
        if line
            .get(end)
            .is_some_and(|c| !matches!(c, b' ' | b'\t' | b';'))
        {
            return None;
        }
        i = end;
        let digits = &line[start..end];
        // Only G, M and D need whole numbers: the conversion is left to them.
        let int = || (v >= 0.0 && v == (v as u32) as f64).then_some(v as u32);
        match letter {
            b'G' => {
                let g = int()?;
                // G58 / G59 change the programmable frame: their axis words are its values, which the tree
                // path reads as such.
                if matches!(g, 58 | 59) {
                    return None;
                }
                if matches!(g, 53 | 153 | 500 | 54..=57 | 505..=599) {
                    s.offsets.push(g);
                }
                if !s.g.push(g) {
                    return None;
                }
            }
            b'X' => s.mv.axes[0] = Some((v, false)),
            b'Y' => s.mv.axes[1] = Some((v, false)),
            b'Z' => s.mv.axes[2] = Some((v, false)),
            b'I' => s.mv.centre[0] = Some(v),
            b'J' => s.mv.centre[1] = Some(v),
            b'K' => s.mv.centre[2] = Some(v),
            b'F' => s.mv.f = Some(v),
            b'S' => s.s = Some(v),
            // The guard stores the code; a block with more codes than fit goes to the tree path.
            b'M' if !s.m.push(int()?) => return None,
            b'T' => s.tool = Some(Arc::from(std::str::from_utf8(digits).ok()?)),
            b'D' => s.d = Some(int()?),
            b'A' | b'B' | b'C' => {
                let bit = 1 << (letter - b'A');
                if v == 0.0 {
                    s.rotary_home |= bit;
                } else {
                    s.rotary_away |= bit;
                }
            }
            _ => {}
        }
    }
    Some(())
}

/// `[+-]digits[.digits]` as f64, for the word scanner: exact for up to 15 significant digits, which is
/// what CAM output carries; anything else (exponents, more digits) returns `None` and takes the tree path.
pub(crate) fn decimal(text: &[u8]) -> Option<f64> {
    decimal_prefix(text).and_then(|(v, len)| (len == text.len()).then_some(v))
}

/// Whether `line[i..]` starts `CR=`, the radius of an arc: the one assignment CAM arcs carry.
pub(crate) fn at_radius(line: &[u8], i: usize) -> bool {
    line.get(i..i + 3)
        .is_some_and(|t| t.eq_ignore_ascii_case(b"CR="))
}

/// The radius of the `CR=` at `line[i..]` and where it ends (at a blank, `;` or the line's end); `None` when
/// it is not a plain number.
pub(crate) fn radius_at(line: &[u8], i: usize) -> Option<(f64, usize)> {
    let end = line[i + 3..]
        .iter()
        .position(|c| matches!(c, b' ' | b'\t' | b';'))
        .map_or(line.len(), |p| i + 3 + p);
    Some((decimal(&line[i + 3..end])?, end))
}
