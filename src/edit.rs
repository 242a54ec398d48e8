//! Editing a parsed program: insert blocks before or after a block, replace or delete a block. Untouched blocks are
//! written verbatim; new blocks are given as text, checked by the block grammar before they are accepted,
//! and written with the file's dominant line ending. A BOM stays first and a missing final newline stays
//! missing.

use std::collections::BTreeMap;
use std::io::Write;

use crate::diagnostic::{Diagnostic, Severity};
use crate::source::raw_lines;
use crate::syntax::{Program, line_syntax_errors, parse_owned};

#[derive(Debug, thiserror::Error)]
pub enum EditError {
    #[error("block {index} does not exist (the program has {count} blocks)")]
    NoSuchBlock { index: usize, count: usize },
    #[error("new block `{text}` does not parse: {}", diagnostics.first().map_or("", |d| d.message.as_str()))]
    Rejected {
        text: String,
        diagnostics: Vec<Diagnostic>,
    },
}

#[derive(Debug, Default)]
struct Slot {
    before: Vec<Vec<u8>>,
    replace: Option<Vec<Vec<u8>>>,
    after: Vec<Vec<u8>>,
}

/// Pending edits against one program.
#[derive(Debug)]
pub struct Editor<'p> {
    program: &'p Program,
    slots: BTreeMap<usize, Slot>,
}

impl<'p> Editor<'p> {
    pub fn new(program: &'p Program) -> Self {
        Editor {
            program,
            slots: BTreeMap::new(),
        }
    }

    /// Inserts `text` (one or more lines) before block `index`.
    pub fn insert_before(&mut self, index: usize, text: &str) -> Result<(), EditError> {
        let lines = self.accept(index, text)?;
        self.slots.entry(index).or_default().before.extend(lines);
        Ok(())
    }

    /// Inserts `text` (one or more lines) after block `index` (after earlier insertions there).
    pub fn insert_after(&mut self, index: usize, text: &str) -> Result<(), EditError> {
        let lines = self.accept(index, text)?;
        self.slots.entry(index).or_default().after.extend(lines);
        Ok(())
    }

    /// Replaces block `index` by `text` (one or more lines; empty text deletes the block's content).
    pub fn replace(&mut self, index: usize, text: &str) -> Result<(), EditError> {
        let lines = self.accept(index, text)?;
        self.slots.entry(index).or_default().replace = Some(lines);
        Ok(())
    }

    /// Removes block `index`, terminator included.
    pub fn delete(&mut self, index: usize) -> Result<(), EditError> {
        let count = self.program.block_count();
        if index >= count {
            return Err(EditError::NoSuchBlock { index, count });
        }
        self.slots.entry(index).or_default().replace = Some(Vec::new());
        Ok(())
    }

    /// Splits `text` into lines and parses each; a line with an error diagnostic refuses the whole edit.
    fn accept(&self, index: usize, text: &str) -> Result<Vec<Vec<u8>>, EditError> {
        let count = self.program.block_count();
        if index >= count {
            return Err(EditError::NoSuchBlock { index, count });
        }
        let bytes = text.as_bytes();
        let mut lines: Vec<Vec<u8>> = raw_lines(bytes)
            .map(|l| l.content().slice(bytes).to_vec())
            .collect();
        if lines.is_empty() {
            lines.push(Vec::new());
        }
        for line in &lines {
            let diagnostics: Vec<Diagnostic> = line_syntax_errors(line)
                .into_iter()
                .filter(|d| d.severity == Severity::Error)
                .collect();
            if !diagnostics.is_empty() {
                return Err(EditError::Rejected {
                    text: String::from_utf8_lossy(line).into_owned(),
                    diagnostics,
                });
            }
        }
        Ok(lines)
    }

    pub fn write_to<W: Write>(&self, w: &mut W) -> std::io::Result<()> {
        let program = self.program;
        let src = program.source();
        let eol = program.dominant_line_ending();
        let bom = if program.has_bom() { 3 } else { 0 };
        w.write_all(&src[..bom])?;
        // Terminators are written lazily, so that a file without a final newline still ends without one.
        let mut pending: Option<&[u8]> = None;
        let mut piece = |w: &mut W, content: &[u8], terminator: &'p [u8]| -> std::io::Result<()> {
            if let Some(t) = pending {
                w.write_all(if t.is_empty() { eol } else { t })?;
            }
            w.write_all(content)?;
            pending = Some(terminator);
            Ok(())
        };
        let mut last = 0;
        for (&i, slot) in &self.slots {
            for k in last..i {
                let span = program.content_span(k);
                piece(
                    w,
                    &src[span.start.max(bom)..span.end],
                    &src[span.end..program.block_span(k).end],
                )?;
            }
            last = i + 1;
            let span = program.content_span(i);
            let terminator = &src[span.end..program.block_span(i).end];
            for line in &slot.before {
                piece(w, line, eol)?;
            }
            match &slot.replace {
                Some(lines) => {
                    for (n, line) in lines.iter().enumerate() {
                        piece(
                            w,
                            line,
                            if n + 1 == lines.len() {
                                terminator
                            } else {
                                eol
                            },
                        )?;
                    }
                }
                None => piece(w, &src[span.start.max(bom)..span.end], terminator)?,
            }
            for line in &slot.after {
                piece(w, line, eol)?;
            }
        }
        for k in last..program.block_count() {
            let span = program.content_span(k);
            piece(
                w,
                &src[span.start.max(bom)..span.end],
                &src[span.end..program.block_span(k).end],
            )?;
        }
        let ends_with_newline = matches!(src.last(), Some(b'\n' | b'\r'));
        if let (Some(t), true) = (pending, ends_with_newline) {
            w.write_all(if t.is_empty() { eol } else { t })?;
        }
        Ok(())
    }

    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.program.source().len() + 256);
        self.write_to(&mut out)
            .expect("writing to a Vec cannot fail");
        out
    }

    /// The edited program, parsed again (its diagnostics include control pairing and jump targets).
    pub fn finish(&self) -> Program {
        parse_owned(self.to_bytes())
    }
}
