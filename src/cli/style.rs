//! The one colour policy of the command line. `--color auto|always|never` is read before clap parses the
//! arguments, so clap's own errors and help follow it too; under `auto` colour goes only to a terminal and
//! `NO_COLOR` (non-empty) turns it off, as does `TERM=dumb` (`CLICOLOR_FORCE` forces it). Styled text is
//! written through anstream's streams, which drop the styles wherever the policy says no colour, so a
//! command never asks whether to colour: it styles, and the stream decides.

use std::ffi::OsString;
use std::fmt;

use anstyle::{AnsiColor, Style};
use clap::ValueEnum;

use crate::diagnostic::Severity;

pub const ERROR: Style = AnsiColor::Red.on_default().bold();
pub const WARNING: Style = AnsiColor::Yellow.on_default().bold();
pub const NOTE: Style = AnsiColor::Cyan.on_default().bold();
/// Source gutters, arrows and the markers of related places in diagnostics.
pub const GUTTER: Style = AnsiColor::Blue.on_default().bold();
pub const EMPHASIS: Style = Style::new().bold();

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub enum ColorChoice {
    /// Colour on a terminal unless NO_COLOR is set.
    #[default]
    Auto,
    /// Colour always, also into files and pipes.
    Always,
    /// No colour.
    Never,
}

impl From<ColorChoice> for anstream::ColorChoice {
    fn from(c: ColorChoice) -> Self {
        match c {
            ColorChoice::Auto => anstream::ColorChoice::Auto,
            ColorChoice::Always => anstream::ColorChoice::Always,
            ColorChoice::Never => anstream::ColorChoice::Never,
        }
    }
}

impl From<ColorChoice> for clap::ColorChoice {
    fn from(c: ColorChoice) -> Self {
        match c {
            ColorChoice::Auto => clap::ColorChoice::Auto,
            ColorChoice::Always => clap::ColorChoice::Always,
            ColorChoice::Never => clap::ColorChoice::Never,
        }
    }
}

/// The `--color` value among raw arguments (`--color X` or `--color=X`, the last one wins), before clap has
/// parsed them; an invalid or missing value is `auto` here and clap reports it.
pub fn choice_from_args(args: &[OsString]) -> ColorChoice {
    let mut choice = ColorChoice::Auto;
    let mut words = args.iter().skip(1).map(|a| a.to_string_lossy());
    while let Some(word) = words.next() {
        if word == "--" {
            break;
        }
        let value = match word.strip_prefix("--color") {
            Some("") => words.next().map(|v| v.into_owned()),
            Some(rest) => rest.strip_prefix('=').map(str::to_string),
            None => None,
        };
        if let Some(parsed) = value.and_then(|v| ColorChoice::from_str(&v, true).ok()) {
            choice = parsed;
        }
    }
    choice
}

/// Makes `choice` the policy of every anstream stream of the process.
pub fn apply(choice: ColorChoice) {
    anstream::ColorChoice::write_global(choice.into());
}

/// Whether text written to stderr keeps its styles under the policy (for output rendered into buffers
/// before it is written).
pub fn stderr_colored() -> bool {
    anstream::AutoStream::choice(&std::io::stderr()) != anstream::ColorChoice::Never
}

/// `error:`, `warning:` or `note:` in its style, for the start of a message line.
pub fn label(severity: Severity) -> Label {
    Label(severity)
}

pub struct Label(Severity);

impl fmt::Display for Label {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (style, name) = match self.0 {
            Severity::Error => (ERROR, "error"),
            Severity::Warning => (WARNING, "warning"),
            Severity::Note => (NOTE, "note"),
        };
        write!(f, "{style}{name}:{style:#}")
    }
}

/// The style of a severity's name in diagnostics.
pub fn severity(severity: Severity) -> Style {
    match severity {
        Severity::Error => ERROR,
        Severity::Warning => WARNING,
        Severity::Note => NOTE,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(words: &[&str]) -> Vec<OsString> {
        std::iter::once("driftloop")
            .chain(words.iter().copied())
            .map(OsString::from)
            .collect()
    }

    #[test]
    fn the_color_flag_is_found_in_both_spellings_anywhere_before_a_double_dash() {
        assert_eq!(choice_from_args(&args(&["check", "x"])), ColorChoice::Auto);
        assert_eq!(
            choice_from_args(&args(&["--color", "never", "check", "x"])),
            ColorChoice::Never
        );
        assert_eq!(
            choice_from_args(&args(&["check", "x", "--color=always"])),
            ColorChoice::Always
        );
        assert_eq!(
            choice_from_args(&args(&["check", "--", "--color=always"])),
            ColorChoice::Auto
        );
        // Left to clap, which names the accepted values.
        assert_eq!(
            choice_from_args(&args(&["--color", "purple"])),
            ColorChoice::Auto
        );
    }

    #[test]
    fn a_label_carries_its_style_around_the_name_only() {
        let text = label(Severity::Warning).to_string();
        assert_eq!(text, format!("{WARNING}warning:{WARNING:#}"));
        assert!(text.starts_with("\x1b[") && text.contains("warning:"));
    }
}
