//! Small helpers for writing NC text: numbers as the control reads them.

/// A number as an NC literal: at most 6 decimals, no exponent, no trailing zeros (`0.0125`, `-3`, `12.5`).
pub fn number(v: f64) -> String {
    let v = if v.abs() < 5e-7 { 0.0 } else { v };
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

#[cfg(test)]
mod tests {
    use super::number;

    #[test]
    fn numbers_are_plain_decimals() {
        assert_eq!(number(0.0125), "0.0125");
        assert_eq!(number(-3.0), "-3");
        assert_eq!(number(12.5), "12.5");
        assert_eq!(number(1e-9), "0");
        assert_eq!(number(-1e-9), "0");
        assert_eq!(number(1234567.25), "1234567.25");
        assert_eq!(number(1.0 / 3.0), "0.333333");
    }
}
