//! Allocation-free recogniser for the blocks CAM output is made of: optional skip level, address words and a
//! comment. Whatever it accepts the full grammar accepts as a plain block without diagnostics (a test checks
//! this over every fixture line); anything else goes to the full grammar.

use super::lexeme::{skip_blanks, word};

pub(crate) fn plain_block(line: &[u8]) -> bool {
    let mut i = skip_blanks(line);
    if let Some(rest) = i.strip_prefix(b"/") {
        i = match rest.first() {
            Some(d) if d.is_ascii_digit() => &rest[1..],
            _ => rest,
        };
    }
    loop {
        i = skip_blanks(i);
        match i.first() {
            None | Some(b';') => return true,
            Some(_) => match word(i) {
                Ok((rest, _)) => i = rest,
                Err(_) => return false,
            },
        }
    }
}
