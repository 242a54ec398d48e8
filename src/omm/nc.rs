//! Small helpers for writing NC text: numbers as the control reads them, and the one range check every
//! number driftloop writes into a program passes.

/// Largest magnitude driftloop writes as an NC number: nine digits before the point, as a Sinumerik
/// position, feed or speed is entered (±999 999 999.999999). Anything larger (a 309-digit literal from
/// 1e308) or not a number at all (NaN, ∞) is no value a machine should act on.
pub const LARGEST: f64 = 999_999_999.0;

/// Brackets what [`number`] writes for a value it must not write. No control reads it, and
/// [`find_unwritable`] finds it in the inserted text, which is then refused as a whole.
const UNWRITABLE: char = '¤';

/// A number as an NC literal: at most 6 decimals, no exponent, no trailing zeros (`0.0125`, `-3`, `12.5`).
///
/// A value outside ±[`LARGEST`], or not finite, is written as `¤value¤`: the transform that inserts the text
/// refuses it (see [`find_unwritable`]) rather than putting a number no one meant into a program.
pub fn number(v: f64) -> String {
    if !(v.is_finite() && v.abs() <= LARGEST) {
        return format!("{UNWRITABLE}{v:e}{UNWRITABLE}");
    }
    let v = if v.abs() < 5e-7 { 0.0 } else { v };
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

/// [`number`] for messages and reports, where a value no NC program may hold is shown as it is (`NaN`,
/// `1e12`) rather than refused.
pub fn shown(v: f64) -> String {
    if v.is_finite() && v.abs() <= LARGEST {
        number(v)
    } else {
        format!("{v:e}")
    }
}

/// The first value in `text` that [`number`] refused to write (`NaN`, `1e308`), if any.
pub fn find_unwritable(text: &str) -> Option<&str> {
    let start = text.find(UNWRITABLE)? + UNWRITABLE.len_utf8();
    let len = text[start..].find(UNWRITABLE).unwrap_or(text.len() - start);
    Some(&text[start..start + len])
}

#[cfg(test)]
mod tests {
    use super::{find_unwritable, number};

    #[test]
    fn numbers_are_plain_decimals() {
        assert_eq!(number(0.0125), "0.0125");
        assert_eq!(number(-3.0), "-3");
        assert_eq!(number(12.5), "12.5");
        assert_eq!(number(1e-9), "0");
        assert_eq!(number(-1e-9), "0");
        assert_eq!(number(1234567.25), "1234567.25");
        assert_eq!(number(1.0 / 3.0), "0.333333");
        assert_eq!(number(-999_999_999.0), "-999999999");
    }

    #[test]
    fn values_out_of_range_are_marked_and_found() {
        for (v, shown) in [
            (f64::NAN, "NaN"),
            (f64::INFINITY, "inf"),
            (f64::NEG_INFINITY, "-inf"),
            (1e308, "1e308"),
            (-1e9 - 1.0, "-1.000000001e9"),
        ] {
            let text = format!("R1=R2*{} ;DL", number(v));
            assert_eq!(find_unwritable(&text), Some(shown), "{text}");
        }
        assert_eq!(find_unwritable(&format!("X{}", number(1e9 - 1.0))), None);
        assert_eq!(super::shown(f64::NAN), "NaN");
        assert_eq!(super::shown(2e12), "2e12");
        assert_eq!(super::shown(0.5), "0.5");
    }
}
