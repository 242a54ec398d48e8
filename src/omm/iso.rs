//! Words that only the ISO dialect (Fanuc-style, the mode `G291` selects or a control set to run ISO
//! programs) has, found in the program's text before it is parsed for Siemens mode: such a program may not
//! parse there at all (`(…)` comments), so the refusal must not wait for the syntax tree.

/// The first word of the ISO dialect in `src` that Siemens mode lacks: (line, 1-based; the word as written).
/// An `O` program number opening the program (`O2041`), `M99` (the end of an ISO subprogram, or of a main
/// program that repeats itself) or `G291` anywhere outside a comment or a string.
pub(crate) fn iso_word(src: &[u8]) -> Option<(usize, String)> {
    if let Some(found) = program_number(src) {
        return Some(found);
    }
    ["M99", "G291"]
        .into_iter()
        .filter_map(|word| first_word(src, word.as_bytes()))
        .min_by_key(|(line, _)| *line)
}

/// `O1234` as the first significant line (after empty lines, `;` comments and the `%…` transfer header).
fn program_number(src: &[u8]) -> Option<(usize, String)> {
    for (k, line) in src.split(|&b| b == b'\n').enumerate() {
        let text = line.trim_ascii();
        if text.is_empty() || text[0] == b';' || text[0] == b'%' {
            continue;
        }
        let digits = text[1..].iter().take_while(|b| b.is_ascii_digit()).count();
        let end = text.get(1 + digits);
        let is_number = matches!(text[0], b'O' | b'o')
            && digits > 0
            && end.is_none_or(|b| matches!(b, b' ' | b'\t' | b'(' | b';'));
        return is_number.then(|| (k + 1, String::from_utf8_lossy(&text[..1 + digits]).into()));
    }
    None
}

/// The first occurrence of the address word `word` (upper case; either case matches) that stands as a word
/// of its own, outside a `;` comment, a `(…)` comment and a string.
fn first_word(src: &[u8], word: &[u8]) -> Option<(usize, String)> {
    let lower = word.to_ascii_lowercase();
    let mut hits: Vec<usize> = memchr::memmem::find_iter(src, word)
        .chain(memchr::memmem::find_iter(src, &lower))
        .collect();
    hits.sort_unstable();
    hits.into_iter().find_map(|at| {
        let start = memchr::memrchr(b'\n', &src[..at]).map_or(0, |p| p + 1);
        let before = &src[start..at];
        let after = src.get(at + word.len());
        let alone = before
            .last()
            .is_none_or(|b| !(b.is_ascii_alphabetic() || matches!(b, b'_' | b'$' | b'.')))
            && after.is_none_or(|b| !(b.is_ascii_alphanumeric() || matches!(b, b'_' | b'.')));
        let quoted = before.iter().filter(|&&b| b == b'"').count() % 2 == 1;
        let open = before.iter().filter(|&&b| b == b'(').count();
        let commented =
            before.contains(&b';') || open > before.iter().filter(|&&b| b == b')').count();
        (alone && !quoted && !commented).then(|| {
            let line = memchr::memchr_iter(b'\n', &src[..at]).count() + 1;
            (
                line,
                String::from_utf8_lossy(&src[at..at + word.len()]).into_owned(),
            )
        })
    })
}

/// What an ISO-dialect word found in a program is, for the refusal: a drilling code G80 … G89 is also the
/// older Sinumerik 810/820 cycle syntax (`G81 R2=… R3=…`), which an 840D in Siemens mode refuses too.
pub(super) fn what_word_is(word: &str) -> &'static str {
    match word.strip_prefix('G').and_then(|g| g.parse::<u32>().ok()) {
        Some(80..=89) => {
            "a drilling cycle of the ISO dialect (Fanuc-style, G291 mode) or of the older Sinumerik 810/820 syntax with R-parameters, neither of which the Siemens mode of an 840D runs (its cycles are CYCLE81 …)"
        }
        _ => "a word of the ISO dialect (Fanuc-style, G291 mode)",
    }
}

#[cfg(test)]
mod tests {
    use super::iso_word;

    #[test]
    fn iso_words_are_found_with_their_line() {
        assert_eq!(
            iso_word(b"O2041 (BUCHSE)\nG90\nM30\n"),
            Some((1, "O2041".into()))
        );
        assert_eq!(iso_word(b"; head\n\nO12\nG0 X0\n"), Some((3, "O12".into())));
        assert_eq!(iso_word(b"G0 X0\nM5\nM99\n"), Some((3, "M99".into())));
        assert_eq!(
            iso_word(b"G0 X0\nN20 G291\nM99\n"),
            Some((2, "G291".into()))
        );
    }

    #[test]
    fn siemens_programs_have_none() {
        for src in [
            &b"OUTLINE\nG0 X0\nM30\n"[..],
            b"; M99 in a comment\nMSG(\"no M99 here\")\nM990\nRM99=1\nM30\n",
            b"OP10:\nG0 X0\nM30\n",
            b"G0 X0 ; G291 mentioned\nM30\n",
        ] {
            assert_eq!(iso_word(src), None, "{}", String::from_utf8_lossy(src));
        }
    }
}
