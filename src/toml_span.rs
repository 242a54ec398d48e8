//! Where in a TOML file (a model, a machine profile) an error is: `file:line:column` for the messages of
//! their loaders. The serde error carries a byte span; a value the loader's own validation refuses is
//! found again by its key path (`limits.tolerance_um`, `spindle.modes[1].tau_min`) in the spanned document.
//! Lines and columns are 1-based, columns count bytes as everywhere in driftloop.

use std::ops::Range;

use toml::de::{DeTable, DeValue};

/// 1-based line and byte column of `offset` in `text`.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text.as_bytes()[..offset.min(text.len())];
    let line_start = before
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |i| i + 1);
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    (line, before.len() - line_start + 1)
}

/// Where a TOML syntax or type error is (`file:line:column`, or `file` when it has no span) and what it is.
pub fn syntax_error(file: &str, text: &str, err: &toml::de::Error) -> (String, String) {
    let at = match err.span() {
        Some(span) => {
            let (line, col) = line_col(text, span.start);
            format!("{file}:{line}:{col}")
        }
        None => file.to_string(),
    };
    (at, err.message().trim_end().to_string())
}

/// `file:line:column: message` of a validation message that starts with the key it is about
/// (`limits.tolerance_um must be …`, `spindle.modes[2].tau_min: …`), pointing at the key's value; a key the
/// file does not hold (a default) gives `file: message`.
pub fn validation_error(file: &str, text: &str, message: &str) -> String {
    let key_len = message
        .find(|c: char| !(c.is_ascii_alphanumeric() || matches!(c, '_' | '.' | '[' | ']')))
        .unwrap_or(message.len());
    let key = message[..key_len].trim_end_matches('.');
    match value_span(text, key) {
        Some(span) => {
            let (line, col) = line_col(text, span.start);
            format!("{file}:{line}:{col}: {message}")
        }
        None => format!("{file}: {message}"),
    }
}

/// Byte span of the value at `path` (`a.b[2].c`) in the TOML `text`.
pub fn value_span(text: &str, path: &str) -> Option<Range<usize>> {
    if path.is_empty() {
        return None;
    }
    let doc = DeTable::parse(text).ok()?;
    let mut span = doc.span();
    let mut value: Option<&DeValue<'_>> = None;
    let mut table = Some(doc.get_ref());
    for part in path.split('.') {
        let (name, indices) = split_indices(part)?;
        let (_, v) = table?.iter().find(|(k, _)| k.get_ref().as_ref() == name)?;
        span = v.span();
        let mut current = v.get_ref();
        for index in indices {
            let DeValue::Array(items) = current else {
                return None;
            };
            let item = items.get(index)?;
            span = item.span();
            current = item.get_ref();
        }
        value = Some(current);
        table = match current {
            DeValue::Table(t) => Some(t),
            _ => None,
        };
    }
    value.map(|_| span)
}

/// `modes[1][0]` → (`modes`, [1, 0]).
fn split_indices(part: &str) -> Option<(&str, Vec<usize>)> {
    let name_end = part.find('[').unwrap_or(part.len());
    let mut indices = Vec::new();
    let mut rest = &part[name_end..];
    while let Some(inner) = rest.strip_prefix('[') {
        let close = inner.find(']')?;
        indices.push(inner[..close].parse().ok()?);
        rest = &inner[close + 1..];
    }
    rest.is_empty().then_some((&part[..name_end], indices))
}

#[cfg(test)]
mod tests {
    use super::*;

    const DOC: &str = "name = \"a\"\n[limits]\ntolerance_um = -1.0\n\n[[modes]]\ntau_min = 1\n[[modes]]\ntau_min = 0.0\ngain = [1, 2, 3]\n";

    #[test]
    fn keys_are_found_through_tables_and_arrays_of_tables() {
        let at = |path: &str| value_span(DOC, path).map(|s| line_col(DOC, s.start));
        assert_eq!(at("name"), Some((1, 8)));
        assert_eq!(at("limits.tolerance_um"), Some((3, 16)));
        assert_eq!(at("modes[1].tau_min"), Some((8, 11)));
        assert_eq!(at("modes[1].gain[2]"), Some((9, 15)));
        assert_eq!(at("modes[2].tau_min"), None);
        assert_eq!(at("limits.missing"), None);
        assert_eq!(at(""), None);
    }

    #[test]
    fn messages_are_located_by_their_leading_key() {
        assert_eq!(
            validation_error("p.toml", DOC, "limits.tolerance_um must be positive"),
            "p.toml:3:16: limits.tolerance_um must be positive"
        );
        assert_eq!(
            validation_error("p.toml", DOC, "modes[1].tau_min: too small"),
            "p.toml:8:11: modes[1].tau_min: too small"
        );
        assert_eq!(
            validation_error("p.toml", DOC, "`x` is wrong"),
            "p.toml: `x` is wrong"
        );
    }

    #[test]
    fn syntax_errors_carry_line_and_column() {
        let err = toml::from_str::<toml::Table>("a = 1\nb = = 2\n").unwrap_err();
        let (at, message) = syntax_error("m.toml", "a = 1\nb = = 2\n", &err);
        assert!(at.starts_with("m.toml:2:"), "{at}");
        assert!(!message.is_empty());
    }
}
