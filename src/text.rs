//! What a file holds before a reader parses it. UTF-16 text (a Windows editor's "Unicode") and binary files
//! are named as such: a parser would only complain about byte 0, and a program's lossless parser would take
//! them for a PC-format archive.

use std::io;
use std::path::Path;

/// What a reader expects, for its messages.
#[derive(Debug, Clone, Copy)]
pub struct Expected {
    /// The noun of "a binary file, not …".
    pub what: &'static str,
    /// What to do with UTF-16 or non-UTF-8 text.
    pub save_as: &'static str,
}

/// A part program: 8-bit text, UTF-8 or Latin-1.
pub const NC_PROGRAM: Expected = Expected {
    what: "an NC program",
    save_as: "the control reads 8-bit text; save the program as UTF-8 or Latin-1 (ANSI)",
};

/// A measurement CSV (the reader takes UTF-8, with or without a byte-order mark).
pub const CSV: Expected = Expected {
    what: "a CSV file",
    save_as: "save it as UTF-8 (a spreadsheet's \"CSV UTF-8\")",
};

/// A model, machine profile or virtual machine file (TOML is UTF-8 by definition).
pub const TOML: Expected = Expected {
    what: "a TOML file",
    save_as: "save it as UTF-8",
};

/// Why `bytes` are no text of the kind expected, if they are not: UTF-16 text or a binary file (many
/// control bytes). A PC-format archive (binary bytes in its first line only) is text.
pub fn not_text(bytes: &[u8], expected: Expected) -> Option<String> {
    let head = &bytes[..bytes.len().min(8192)];
    if head.starts_with(b"\xFF\xFE") || head.starts_with(b"\xFE\xFF") || utf16_without_bom(head) {
        return Some(format!("UTF-16 text: {}", expected.save_as));
    }
    let control = head
        .iter()
        .filter(|&&b| b < 0x20 && !matches!(b, b'\t' | b'\n' | b'\r' | 0x0B | 0x0C | 0x1A))
        .count();
    (control * 10 >= head.len() && control > 0).then(|| {
        format!(
            "a binary file, not {} ({control} of its first {} bytes are control bytes)",
            expected.what,
            head.len()
        )
    })
}

/// Text in UTF-16 without a byte-order mark: NUL in every other byte.
fn utf16_without_bom(head: &[u8]) -> bool {
    let pairs = head.len() / 2;
    if pairs < 2 {
        return false;
    }
    let nul_at = |parity: usize| {
        head.chunks_exact(2)
            .filter(|p| p[parity] == 0 && p[1 - parity] != 0)
            .count()
    };
    nul_at(0).max(nul_at(1)) * 10 >= pairs * 9
}

/// Where the first byte that is not UTF-8 is, and what to do: `line L, column C: …` (1-based, columns in
/// bytes as everywhere in driftloop).
pub fn not_utf8(bytes: &[u8], valid_up_to: usize, expected: Expected) -> String {
    let (line, column) = crate::source::LineIndex::new(bytes).line_col(valid_up_to);
    let byte = bytes.get(valid_up_to).copied().unwrap_or(0);
    format!(
        "line {line}, column {column}: byte 0x{byte:02X} is not UTF-8 text; {}",
        expected.save_as
    )
}

/// The file as UTF-8 text, or an error (kind `InvalidData`) that says what it holds instead and where.
pub fn read_utf8(path: &Path, expected: Expected) -> io::Result<String> {
    let bytes = std::fs::read(path)?;
    if let Some(why) = not_text(&bytes, expected) {
        return Err(io::Error::new(io::ErrorKind::InvalidData, why));
    }
    String::from_utf8(bytes).map_err(|e| {
        let why = not_utf8(e.as_bytes(), e.utf8_error().valid_up_to(), expected);
        io::Error::new(io::ErrorKind::InvalidData, why)
    })
}

/// A CSV tokeniser's error in words a user acts on. A cell that is not UTF-8 (a Latin-1 `°C` in a header)
/// is named by its column; a row with another number of fields says what the header has. The line is the
/// caller's to name.
pub fn csv_problem(e: &csv::Error) -> String {
    match e.kind() {
        csv::ErrorKind::Utf8 { err, .. } => format!(
            "column {}: a cell that is not UTF-8 text; {}",
            err.field() + 1,
            CSV.save_as
        ),
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => format!(
            "{len} fields, but the rows before have {expected_len}: every row needs one value per column"
        ),
        _ => e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utf16_and_binary_bytes_are_told_from_programs_and_archives() {
        let utf16: Vec<u8> = "G0 X1\r\nM30\r\n"
            .encode_utf16()
            .flat_map(u16::to_le_bytes)
            .collect();
        assert!(not_text(&utf16, NC_PROGRAM).unwrap().contains("UTF-16"));
        let mut with_bom = vec![0xFF, 0xFE];
        with_bom.extend(&utf16);
        assert!(not_text(&with_bom, NC_PROGRAM).unwrap().contains("UTF-16"));
        let binary: Vec<u8> = (0..=255u8).cycle().take(4096).collect();
        assert!(
            not_text(&binary, CSV)
                .unwrap()
                .contains("binary file, not a CSV file")
        );
        assert_eq!(not_text(b"G0 X1\nM30\n", NC_PROGRAM), None);
        assert_eq!(not_text(b"", NC_PROGRAM), None);
        let archive = std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/nc/archive.arc"
        ))
        .unwrap();
        assert_eq!(not_text(&archive, NC_PROGRAM), None);
    }

    #[test]
    fn latin1_in_utf8_text_is_placed_by_line_and_column() {
        let bytes = b"a = 1\nname = \"Fr\xE4se\"\n";
        let valid = bytes.iter().position(|&b| b == 0xE4).unwrap();
        let why = not_utf8(bytes, valid, TOML);
        assert!(
            why.starts_with("line 2, column 11: byte 0xE4 is not UTF-8 text"),
            "{why}"
        );
    }
}
