//! `driftloop check PATH…`: parses programs and reports their diagnostics.
//!
//! Files are read and parsed in parallel; each file's report is rendered into its own buffer and the buffers
//! are written in input order, so output is deterministic whatever the scheduling.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use rayon::prelude::*;
use serde::Serialize;

use super::progress::Progress;
use super::render::{Renderer, severity_name};
use super::style;
use super::{Format, Global};
use crate::diagnostic::Severity;
use crate::walk::{self, Input};

#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  driftloop check fixtures/omm/handwritten.mpf\n  driftloop check programs/ --format json"
)]
pub struct Args {
    /// Programs or directories (walked recursively for .mpf .spf .arc .nc .def); `-` reads stdin.
    #[arg(required = true, value_name = "PATH")]
    paths: Vec<PathBuf>,
    /// `human`: diagnostics with source snippets on stderr; `json`: one JSON object per file on stdout.
    #[arg(long, value_enum, default_value_t = Format::Human)]
    format: Format,
}

/// What checking one file produced: its rendered report and counts, or the error that stopped reading it.
struct FileReport {
    output: Vec<u8>,
    errors: usize,
    warnings: usize,
    notes: usize,
    read_error: Option<String>,
}

#[derive(Serialize)]
struct JsonFile<'a> {
    path: &'a str,
    #[serde(skip_serializing_if = "Option::is_none")]
    error: Option<&'a str>,
    diagnostics: Vec<JsonDiagnostic<'a>>,
}

#[derive(Serialize)]
struct JsonDiagnostic<'a> {
    line: usize,
    column: usize,
    end_line: usize,
    end_column: usize,
    severity: &'static str,
    message: &'a str,
    help: Option<&'a str>,
    related: Vec<JsonRelated<'a>>,
}

#[derive(Serialize)]
struct JsonRelated<'a> {
    line: usize,
    column: usize,
    message: &'a str,
}

pub fn run(args: Args, global: &Global) -> anyhow::Result<ExitCode> {
    let inputs = walk::expand(&args.paths);
    let color = global.stderr_color();
    let progress = Progress::new("checked", inputs.len());
    let reports: Vec<FileReport> = inputs
        .par_iter()
        .map(|input| {
            let report = check_file(input, args.format, color);
            progress.tick();
            report
        })
        .collect();
    progress.finish();

    let mut stdout = super::output::stdout();
    let mut stderr = anstream::stderr().lock();
    for report in &reports {
        if let Some(err) = &report.read_error {
            writeln!(stderr, "{} {err}", style::label(Severity::Error))?;
        }
        match args.format {
            Format::Human => stderr.write_all(&report.output)?,
            Format::Json => stdout.write_all(&report.output)?,
        }
    }
    stdout.flush()?;

    let count = |f: fn(&FileReport) -> usize| reports.iter().map(f).sum::<usize>();
    let errors = count(|r| r.errors);
    let unreadable = count(|r| usize::from(r.read_error.is_some()));
    if args.format == Format::Human {
        writeln!(
            stderr,
            "checked {}: {}, {}, {}{}",
            plural(reports.len() - unreadable, "file"),
            plural(errors, "error"),
            plural(count(|r| r.warnings), "warning"),
            plural(count(|r| r.notes), "note"),
            if unreadable > 0 {
                format!("; {} could not be read", plural(unreadable, "file"))
            } else {
                String::new()
            }
        )?;
    }
    Ok(if unreadable > 0 {
        ExitCode::from(2)
    } else if errors > 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

fn check_file(input: &Input, format: Format, color: bool) -> FileReport {
    let path = input.to_string();
    let mut report = FileReport {
        output: Vec::new(),
        errors: 0,
        warnings: 0,
        notes: 0,
        read_error: None,
    };
    let source = input.read().map_err(|e| e.to_string()).and_then(|bytes| {
        match crate::text::not_text(&bytes, crate::text::NC_PROGRAM) {
            Some(why) => Err(format!("{path}: {why}")),
            None => Ok(bytes),
        }
    });
    let source = match source {
        Ok(source) => source,
        Err(message) => {
            if format == Format::Json {
                write_json_line(
                    &mut report.output,
                    &JsonFile {
                        path: &path,
                        error: Some(&message),
                        diagnostics: Vec::new(),
                    },
                );
            }
            report.read_error = Some(message);
            return report;
        }
    };
    let program = crate::parse_owned(source);
    let diagnostics = program.diagnostics();
    for d in diagnostics {
        match d.severity {
            Severity::Error => report.errors += 1,
            Severity::Warning => report.warnings += 1,
            Severity::Note => report.notes += 1,
        }
    }
    let renderer = Renderer::new(&path, program.source(), color);
    match format {
        Format::Human => {
            for d in diagnostics {
                renderer
                    .render(&mut report.output, d)
                    .expect("writing to a Vec cannot fail");
            }
        }
        Format::Json => {
            let diagnostics = diagnostics
                .iter()
                .map(|d| {
                    let (line, column) = renderer.line_col(d.span.start);
                    let (end_line, end_column) = renderer.line_col(d.span.end);
                    JsonDiagnostic {
                        line,
                        column,
                        end_line,
                        end_column,
                        severity: severity_name(d.severity),
                        message: &d.message,
                        help: d.help.as_deref(),
                        related: d
                            .related
                            .iter()
                            .map(|(span, message)| {
                                let (line, column) = renderer.line_col(span.start);
                                JsonRelated {
                                    line,
                                    column,
                                    message,
                                }
                            })
                            .collect(),
                    }
                })
                .collect();
            write_json_line(
                &mut report.output,
                &JsonFile {
                    path: &path,
                    error: None,
                    diagnostics,
                },
            );
        }
    }
    report
}

fn write_json_line(out: &mut Vec<u8>, file: &JsonFile<'_>) {
    serde_json::to_writer(&mut *out, file).expect("plain structs serialise");
    out.push(b'\n');
}

fn plural(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}
