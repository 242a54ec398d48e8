//! A token stream of Rust source that is just fine enough for paths: identifiers, `::` and single
//! punctuation, each with its line. Comments, strings, byte strings, raw strings and character literals
//! are dropped, so a path named in a doc comment or a message is no dependency.

#[derive(Debug, Clone, PartialEq)]
pub enum Tok {
    Ident(String),
    PathSep,
    Punct(char),
}

pub fn tokens(src: &str) -> Vec<(Tok, usize)> {
    let b = src.as_bytes();
    let mut out = Vec::new();
    let (mut i, mut line) = (0, 1);
    while i < b.len() {
        let c = b[i];
        match c {
            b'\n' => {
                line += 1;
                i += 1;
            }
            b'/' if b.get(i + 1) == Some(&b'/') => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
            }
            b'/' if b.get(i + 1) == Some(&b'*') => i = block_comment_end(b, i, &mut line),
            b'"' => i = string_end(b, i + 1, &mut line),
            b'\'' => i = quote_end(b, i),
            b'r' | b'b' if raw_string_start(b, i).is_some() => {
                let (hashes, open) = raw_string_start(b, i).expect("checked");
                i = raw_string_end(b, open + 1, hashes, &mut line);
            }
            b'b' if b.get(i + 1) == Some(&b'"') => i = string_end(b, i + 2, &mut line),
            b'b' if b.get(i + 1) == Some(&b'\'') => i = quote_end(b, i + 1),
            b':' if b.get(i + 1) == Some(&b':') => {
                out.push((Tok::PathSep, line));
                i += 2;
            }
            _ if c == b'_' || c.is_ascii_alphabetic() => {
                let start = i;
                while i < b.len() && (b[i] == b'_' || b[i].is_ascii_alphanumeric()) {
                    i += 1;
                }
                // `r#type`: a raw identifier is the identifier.
                let text = src[start..i].to_string();
                out.push((Tok::Ident(text), line));
            }
            _ if c.is_ascii_digit() => {
                while i < b.len() && (b[i] == b'_' || b[i] == b'.' || b[i].is_ascii_alphanumeric())
                {
                    // `1..n`: a range, not a number's point.
                    if b[i] == b'.' && b.get(i + 1) == Some(&b'.') {
                        break;
                    }
                    i += 1;
                }
            }
            _ if c.is_ascii_whitespace() => i += 1,
            _ if c.is_ascii() => {
                out.push((Tok::Punct(c as char), line));
                i += 1;
            }
            _ => i += 1,
        }
    }
    out
}

/// Past the `*/` that closes the comment at `i` (comments nest).
fn block_comment_end(b: &[u8], mut i: usize, line: &mut usize) -> usize {
    let mut depth = 0;
    while i < b.len() {
        if b[i..].starts_with(b"/*") {
            depth += 1;
            i += 2;
        } else if b[i..].starts_with(b"*/") {
            depth -= 1;
            i += 2;
            if depth == 0 {
                return i;
            }
        } else {
            *line += usize::from(b[i] == b'\n');
            i += 1;
        }
    }
    i
}

/// Past the `"` that closes a string whose text starts at `i`.
fn string_end(b: &[u8], mut i: usize, line: &mut usize) -> usize {
    while i < b.len() {
        match b[i] {
            b'\\' => i += 2,
            b'"' => return i + 1,
            c => {
                *line += usize::from(c == b'\n');
                i += 1;
            }
        }
    }
    i
}

/// Past a character literal at `i` (`'x'`, `'\n'`, `'\u{1F}'`), or past the quote of a lifetime or label.
fn quote_end(b: &[u8], i: usize) -> usize {
    if b.get(i + 1) == Some(&b'\\') {
        let close = b[i + 2..]
            .iter()
            .position(|&c| c == b'\'')
            .map_or(b.len(), |p| i + 2 + p);
        return close + 1;
    }
    // One character (of as many bytes as its UTF-8 lead byte says) and the closing quote.
    let len = match b.get(i + 1) {
        Some(&c) if c >= 0xF0 => 4,
        Some(&c) if c >= 0xE0 => 3,
        Some(&c) if c >= 0xC0 => 2,
        _ => 1,
    };
    if b.get(i + 1 + len) == Some(&b'\'') {
        i + 2 + len
    } else {
        i + 1
    }
}

/// `r"`, `r#"`, `br##"`…: the number of hashes and where the opening quote is.
fn raw_string_start(b: &[u8], i: usize) -> Option<(usize, usize)> {
    let mut k = i + usize::from(b[i] == b'b');
    if b.get(k) != Some(&b'r') || (i > 0 && (b[i - 1] == b'_' || b[i - 1].is_ascii_alphanumeric()))
    {
        return None;
    }
    k += 1;
    let hashes = b[k..].iter().take_while(|&&c| c == b'#').count();
    (b.get(k + hashes) == Some(&b'"')).then_some((hashes, k + hashes))
}

fn raw_string_end(b: &[u8], mut i: usize, hashes: usize, line: &mut usize) -> usize {
    while i < b.len() {
        if b[i] == b'"'
            && b[i + 1..]
                .iter()
                .take(hashes)
                .filter(|&&c| c == b'#')
                .count()
                == hashes
        {
            return i + 1 + hashes;
        }
        *line += usize::from(b[i] == b'\n');
        i += 1;
    }
    i
}

#[test]
fn only_code_gives_tokens() {
    let idents = |src: &str| -> Vec<String> {
        tokens(src)
            .into_iter()
            .filter_map(|(t, _)| match t {
                Tok::Ident(s) => Some(s),
                _ => None,
            })
            .collect()
    };
    assert_eq!(idents("a // b\n/* c /* d */ e */ f"), ["a", "f"]);
    assert_eq!(
        idents(r##"x("y::z", r#"q"#, b'"', '\'', br"w") 'a: loop"##),
        ["x", "a", "loop"]
    );
    assert_eq!(
        idents("fn f<'a, 'b>(c: &'a u8) -> char { 'é' }"),
        ["fn", "f", "a", "b", "c", "a", "u8", "char"]
    );
    let lines: Vec<usize> = tokens("a\n\"x\ny\"\nb")
        .into_iter()
        .map(|(_, l)| l)
        .collect();
    assert_eq!(lines, [1, 4]);
}
