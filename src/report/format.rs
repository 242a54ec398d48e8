//! Text escaping and fixed-precision number formatting shared by the HTML and SVG writers.

/// Escapes text for HTML/SVG element content and attribute values (`&`, `<`, `>`, `"`, `'`).
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// Formats `value` with exactly `decimals` digits after the point; never prints `-0`, and prints non-finite
/// values as `NaN`, `inf` or `-inf` so the caller can see them instead of a silent zero.
pub fn fmt_num(value: f64, decimals: usize) -> String {
    if value.is_nan() {
        return "NaN".to_string();
    }
    if value.is_infinite() {
        return if value > 0.0 { "inf" } else { "-inf" }.to_string();
    }
    let text = format!("{value:.decimals$}");
    let is_negative_zero = text.starts_with('-') && text[1..].chars().all(|c| c == '0' || c == '.');
    if is_negative_zero {
        text[1..].to_string()
    } else {
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_every_markup_character() {
        assert_eq!(
            escape(r#"a<b>&"c" 'd'"#),
            "a&lt;b&gt;&amp;&quot;c&quot; &#39;d&#39;"
        );
        assert_eq!(escape("x̄ ± 3·s µm"), "x̄ ± 3·s µm");
    }

    #[test]
    fn escaping_is_not_idempotent_so_double_escaping_shows() {
        assert_eq!(escape("&amp;"), "&amp;amp;");
    }

    #[test]
    fn numbers_have_fixed_decimals_and_no_negative_zero() {
        assert_eq!(fmt_num(3.391_164, 2), "3.39");
        assert_eq!(fmt_num(19.173_49, 2), "19.17");
        assert_eq!(fmt_num(-0.001, 2), "0.00");
        assert_eq!(fmt_num(-0.0, 0), "0");
        assert_eq!(fmt_num(-1.173_49, 2), "-1.17");
        assert_eq!(fmt_num(f64::NAN, 2), "NaN");
        assert_eq!(fmt_num(f64::NEG_INFINITY, 1), "-inf");
    }
}
