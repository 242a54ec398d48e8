//! Human rendering of diagnostics with source snippets, rustc-style:
//!
//! ```text
//! error: IF on line 3 has no ENDIF
//!  --> part.mpf:3:1
//!   |
//! 3 | IF R1>0
//!   | ^^
//! 9 | M30
//!   | - program ends here
//!   = help: add ENDIF before M30
//! ```
//!
//! Source lines are shown lossily as UTF-8 (programs are often Latin-1 or carry broken bytes) with control
//! characters replaced, so a snippet can never garble the terminal. Columns in the header count bytes, as
//! everywhere in driftloop; the caret is placed by characters of the shown line, tabs kept, so it lines up.

use std::cell::OnceCell;
use std::io::{self, Write};

use anstyle::Style;

use super::style;
use crate::diagnostic::{Diagnostic, Severity};
use crate::source::{LineIndex, Span};

/// The styles of one diagnostic (src/cli/style.rs), all plain when colour is off.
struct Palette {
    severity: Style,
    gutter: Style,
    bold: Style,
}

impl Palette {
    fn new(color: bool, severity: Severity) -> Self {
        if !color {
            return Palette {
                severity: Style::new(),
                gutter: Style::new(),
                bold: Style::new(),
            };
        }
        Palette {
            severity: style::severity(severity),
            gutter: style::GUTTER,
            bold: style::EMPHASIS,
        }
    }
}

/// The lowercase name shown in front of the message and in JSON.
pub fn severity_name(severity: Severity) -> &'static str {
    match severity {
        Severity::Error => "error",
        Severity::Warning => "warning",
        Severity::Note => "note",
    }
}

/// Renders diagnostics of one program. `path` is the name the user knows the program by (`-` for stdin).
pub struct Renderer<'a> {
    path: &'a str,
    source: &'a [u8],
    /// Built on first use: most files have no diagnostics, and the index of a big one costs memory.
    index: OnceCell<LineIndex>,
    color: bool,
}

impl<'a> Renderer<'a> {
    pub fn new(path: &'a str, source: &'a [u8], color: bool) -> Self {
        Renderer {
            path,
            source,
            index: OnceCell::new(),
            color,
        }
    }

    fn index(&self) -> &LineIndex {
        self.index.get_or_init(|| LineIndex::new(self.source))
    }

    /// 1-based (line, byte column) of an offset, for headers and JSON.
    pub fn line_col(&self, offset: usize) -> (usize, usize) {
        self.index().line_col(offset)
    }

    pub fn render(&self, out: &mut impl Write, diagnostic: &Diagnostic) -> io::Result<()> {
        let p = Palette::new(self.color, diagnostic.severity);
        let (line, col) = self.line_col(diagnostic.span.start);
        let shown_lines = std::iter::once(line)
            .chain(
                diagnostic
                    .related
                    .iter()
                    .map(|(span, _)| self.line_col(span.start).0),
            )
            .max()
            .unwrap_or(line);
        let width = shown_lines.to_string().len();
        let pad = " ".repeat(width);

        let (severity, gutter, bold) = (p.severity, p.gutter, p.bold);
        writeln!(
            out,
            "{severity}{}{severity:#}: {bold}{}{bold:#}",
            severity_name(diagnostic.severity),
            diagnostic.message,
        )?;
        writeln!(out, "{pad}{gutter}-->{gutter:#} {}:{line}:{col}", self.path)?;
        writeln!(out, "{pad} {gutter}|{gutter:#}")?;
        // Snippets in line order, as they stand in the file; a gap between them is marked with `...`.
        let mut snippets: Vec<(Span, char, Style, Option<&str>)> =
            vec![(diagnostic.span, '^', severity, None)];
        for (span, label) in &diagnostic.related {
            snippets.push((*span, '-', gutter, Some(label)));
        }
        snippets.sort_by_key(|(span, ..)| self.line_col(span.start).0);
        let mut last_line = None;
        for (span, marker, style, label) in snippets {
            let line = self.line_col(span.start).0;
            if last_line.is_some_and(|last| line > last + 1) {
                writeln!(out, "{gutter}...{gutter:#}")?;
            }
            last_line = Some(line);
            self.snippet(out, &p, width, span, marker, style, label)?;
        }
        if let Some(help) = &diagnostic.help {
            writeln!(out, "{pad} {gutter}={gutter:#} {bold}help{bold:#}: {help}")?;
        }
        writeln!(out)
    }

    /// One source line with a marker line under `span` (clipped to the span's first line).
    #[allow(clippy::too_many_arguments)]
    fn snippet(
        &self,
        out: &mut impl Write,
        p: &Palette,
        width: usize,
        span: Span,
        marker: char,
        marker_style: Style,
        label: Option<&str>,
    ) -> io::Result<()> {
        let start = span.start.min(self.source.len());
        let (line, _) = self.line_col(start);
        let line_span = self.index().line_span(line);
        let text =
            visible_line(&self.source[line_span.start..line_span.end.min(self.source.len())]);
        let text_end = line_span.start + text.len();
        let prefix = &self.source[line_span.start..start.clamp(line_span.start, text_end)];
        let marked =
            &self.source[start.clamp(line_span.start, text_end)..span.end.clamp(start, text_end)];

        let indent: String = shown(prefix)
            .chars()
            .map(|c| if c == '\t' { '\t' } else { ' ' })
            .collect();
        let markers = marker
            .to_string()
            .repeat(shown(marked).chars().count().max(1));
        let gutter = p.gutter;
        writeln!(
            out,
            "{gutter}{line:>width$} |{gutter:#} {}",
            shown(text).trim_end()
        )?;
        let label = label.map(|l| format!(" {l}")).unwrap_or_default();
        writeln!(
            out,
            "{gutter}{:width$} |{gutter:#} {indent}{marker_style}{markers}{label}{marker_style:#}",
            ""
        )
    }
}

/// The line without its line ending.
fn visible_line(line: &[u8]) -> &[u8] {
    let end = line
        .iter()
        .position(|&b| b == b'\n' || b == b'\r')
        .unwrap_or(line.len());
    &line[..end]
}

/// Bytes as text a terminal can show: lossy UTF-8, control characters other than tab replaced.
fn shown(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes)
        .chars()
        .map(|c| {
            if c.is_control() && c != '\t' {
                char::REPLACEMENT_CHARACTER
            } else {
                c
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn diagnostic(span: Span, help: Option<&str>, related: Vec<(Span, String)>) -> Diagnostic {
        Diagnostic {
            severity: Severity::Error,
            span,
            message: "something is wrong".to_string(),
            help: help.map(str::to_string),
            related,
        }
    }

    fn render(source: &[u8], d: &Diagnostic, color: bool) -> String {
        let mut out = Vec::new();
        Renderer::new("p.mpf", source, color)
            .render(&mut out, d)
            .unwrap();
        String::from_utf8(out).unwrap()
    }

    #[test]
    fn caret_sits_under_the_span_on_its_line() {
        let src = b"G0 X0\r\nG1 X= Y1\r\nM30\r\n";
        let start = 11; // the `=` on line 2
        let text = render(
            src,
            &diagnostic(
                Span {
                    start,
                    end: start + 1,
                },
                Some("write a value"),
                vec![],
            ),
            false,
        );
        assert_eq!(
            text,
            "error: something is wrong\n --> p.mpf:2:5\n  |\n2 | G1 X= Y1\n  |     ^\n  = help: write a value\n\n"
        );
    }

    #[test]
    fn related_spans_are_shown_with_their_label_and_a_wide_gutter() {
        let mut src = Vec::new();
        for _ in 0..11 {
            src.extend_from_slice(b"G0\n");
        }
        src.extend_from_slice(b"IF R1>0\n");
        let if_at = 33;
        let d = diagnostic(
            Span { start: 0, end: 2 },
            None,
            vec![(
                Span {
                    start: if_at,
                    end: if_at + 2,
                },
                "IF on line 12".to_string(),
            )],
        );
        let text = render(&src, &d, false);
        assert!(text.contains(" 1 | G0\n   | ^^\n"), "{text}");
        assert!(
            text.contains("12 | IF R1>0\n   | -- IF on line 12\n"),
            "{text}"
        );
    }

    #[test]
    fn snippets_follow_file_order_and_adjacent_lines_need_no_gap_marker() {
        let src = b"A: X1\nA: X2\n";
        let d = diagnostic(
            Span { start: 6, end: 7 },
            None,
            vec![(Span { start: 0, end: 1 }, "first defined here".to_string())],
        );
        let text = render(src, &d, false);
        assert!(
            text.contains("1 | A: X1\n  | - first defined here\n2 | A: X2\n  | ^\n"),
            "{text}"
        );
    }

    #[test]
    fn broken_bytes_tabs_and_control_characters_stay_aligned() {
        let src = b"\tMSG(\"\xE4\x01\") X=\n";
        let at = src.iter().position(|&b| b == b'X').unwrap();
        let text = render(
            src,
            &diagnostic(
                Span {
                    start: at,
                    end: at + 2,
                },
                None,
                vec![],
            ),
            false,
        );
        assert!(
            text.contains("1 | \tMSG(\"\u{FFFD}\u{FFFD}\") X=\n"),
            "{text}"
        );
        assert!(text.contains("  | \t          ^^\n"), "{text}");
    }

    #[test]
    fn empty_span_at_end_of_file_gets_one_caret_and_colour_only_when_asked() {
        let src = b"G1 X";
        let plain = render(
            src,
            &diagnostic(Span { start: 4, end: 4 }, None, vec![]),
            false,
        );
        assert!(plain.contains("1 | G1 X\n  |     ^\n"), "{plain}");
        assert!(!plain.contains('\x1b'));
        let coloured = render(
            src,
            &diagnostic(Span { start: 4, end: 4 }, None, vec![]),
            true,
        );
        let error = style::ERROR;
        assert!(
            coloured.starts_with(&format!("{error}error{error:#}: ")),
            "{coloured}"
        );
    }
}
