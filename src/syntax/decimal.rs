//! The value of a number read in the recogniser's pass (see [`super::Digits`]), for a reader of the plain
//! blocks' words that wants the values without reading the numbers a second time.

use super::lexeme::{Digits, number_end_with};

/// `[+-]digits[.digits]`, exact for up to 15 significant digits, which is what CAM output carries; more
/// digits or an exponent have no value here.
#[derive(Debug, Default, Clone, Copy)]
pub struct Decimal {
    mantissa: u64,
    /// Digits after the point.
    scale: u32,
    /// [`NEGATIVE`], [`SIGNED`], [`POINT`], [`NO_VALUE`]: one byte, so a word's number costs two stores
    /// to start.
    flags: u8,
}

const NEGATIVE: u8 = 1;
const SIGNED: u8 = 2;
const POINT: u8 = 4;
const NO_VALUE: u8 = 8;

impl Digits for Decimal {
    #[inline(always)]
    fn sign(&mut self, negative: bool) {
        self.flags |= SIGNED | (u8::from(negative) * NEGATIVE);
    }

    #[inline(always)]
    fn digit(&mut self, d: u64) {
        self.mantissa = self.mantissa.wrapping_mul(10).wrapping_add(d);
    }

    #[inline(always)]
    fn counts(&mut self, int: usize, fraction: usize, point: bool) {
        self.scale = fraction as u32;
        self.flags |= (u8::from(point) * POINT) | (u8::from(int + fraction > 15) * NO_VALUE);
    }

    #[inline(always)]
    fn exponent(&mut self) {
        self.flags |= NO_VALUE;
    }
}

impl Decimal {
    #[inline(always)]
    pub fn value(&self) -> Option<f64> {
        static POW10: [f64; 16] = [
            1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
        ];
        if self.flags & NO_VALUE != 0 {
            return None;
        }
        // At most 15 digits (so the scale indexes the table): the mantissa and the power of ten are exact
        // doubles, the quotient is rounded once (as `str::parse` rounds); the signed conversion is the one
        // x86 does in one instruction. No branch on the scale or the sign: a division by 1 is exact and a
        // negation flips the sign bit, a mispredicted branch per word is not cheap.
        let v = self.mantissa as i64 as f64 / POW10[self.scale as usize & 15];
        Some(f64::from_bits(
            v.to_bits() ^ u64::from(self.flags & NEGATIVE) << 63,
        ))
    }

    /// The number as a whole number written with digits only (`12`, `01`; not `+1`, `1.`, `1.0`).
    pub fn whole(&self) -> Option<u64> {
        (self.flags & (SIGNED | POINT | NO_VALUE) == 0).then_some(self.mantissa)
    }
}

/// The decimal at the start of `text` (an optional sign, then digits and a point) and its length in bytes;
/// `None` when `text` does not start with one that has a value (see [`Decimal`]).
#[inline]
pub fn decimal_prefix(text: &[u8]) -> Option<(f64, usize)> {
    let mut d = Decimal::default();
    let end = number_end_with(text, 0, true, &mut d)?;
    Some((d.value()?, end))
}

#[cfg(test)]
mod tests {
    use super::decimal_prefix;

    #[test]
    fn values_as_str_parse_gives_them() {
        for text in [
            "12",
            "-3.25",
            "+.5",
            "5.",
            "0.001",
            "-0",
            "400.123",
            "123456789012345",
        ] {
            let (v, len) = decimal_prefix(text.as_bytes()).unwrap();
            assert_eq!(len, text.len());
            assert_eq!(v, text.parse::<f64>().unwrap(), "{text}");
        }
        assert_eq!(
            decimal_prefix(b"1.5EX3"),
            None,
            "exponents have no value here"
        );
        assert_eq!(decimal_prefix(b"1234567890123456"), None, "16 digits");
        assert_eq!(decimal_prefix(b"7 X"), Some((7.0, 1)));
        assert_eq!(decimal_prefix(b"X"), None);
    }
}
