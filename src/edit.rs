//! Editing a parsed program: insert blocks before or after a block, replace or delete a block. Untouched blocks are
//! written verbatim; new blocks are given as text, checked by the block grammar before they are accepted,
//! and written with the file's dominant line ending. A BOM stays first and a missing final newline stays
//! missing.

use std::collections::{BTreeMap, HashSet};
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
    edits: Edits,
    /// Lines already found to parse without errors: a transform inserts the same lines many times.
    clean: HashSet<Vec<u8>>,
}

/// The accepted edits on their own, without the program they were made against: kept next to the program
/// (as a batch of transformed files keeps them until every file is known to transform), they write the
/// edited program without ever holding a copy of it.
#[derive(Debug, Default)]
pub struct Edits {
    slots: BTreeMap<usize, Slot>,
}

impl<'p> Editor<'p> {
    pub fn new(program: &'p Program) -> Self {
        Editor {
            program,
            edits: Edits::default(),
            clean: HashSet::new(),
        }
    }

    /// Inserts `text` (one or more lines) before block `index`.
    pub fn insert_before(&mut self, index: usize, text: &str) -> Result<(), EditError> {
        let lines = self.accept(index, text)?;
        self.slot(index).before.extend(lines);
        Ok(())
    }

    /// Inserts `text` (one or more lines) after block `index` (after earlier insertions there).
    pub fn insert_after(&mut self, index: usize, text: &str) -> Result<(), EditError> {
        let lines = self.accept(index, text)?;
        self.slot(index).after.extend(lines);
        Ok(())
    }

    /// Replaces block `index` by `text` (one or more lines; empty text deletes the block's content).
    pub fn replace(&mut self, index: usize, text: &str) -> Result<(), EditError> {
        let lines = self.accept(index, text)?;
        self.slot(index).replace = Some(lines);
        Ok(())
    }

    /// Removes block `index`, terminator included.
    pub fn delete(&mut self, index: usize) -> Result<(), EditError> {
        let count = self.program.block_count();
        if index >= count {
            return Err(EditError::NoSuchBlock { index, count });
        }
        self.slot(index).replace = Some(Vec::new());
        Ok(())
    }

    fn slot(&mut self, index: usize) -> &mut Slot {
        self.edits.slots.entry(index).or_default()
    }

    /// The edits, to be written later against the same program.
    pub fn into_edits(self) -> Edits {
        self.edits
    }

    pub fn write_to<W: Write>(&self, w: &mut W) -> std::io::Result<()> {
        self.edits.write_to(self.program, w)
    }

    /// The edited program's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        self.edits.to_bytes(self.program)
    }

    /// The edited program, parsed again (its diagnostics include control pairing and jump targets).
    pub fn finish(&self) -> Program {
        parse_owned(self.to_bytes())
    }

    /// Splits `text` into lines and parses each; a line with an error diagnostic refuses the whole edit.
    fn accept(&mut self, index: usize, text: &str) -> Result<Vec<Vec<u8>>, EditError> {
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
            if self.clean.contains(line) {
                continue;
            }
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
            self.clean.insert(line.clone());
        }
        Ok(lines)
    }
}

impl Edits {
    /// Writes `program` (the one the edits were made against) with the edits applied.
    pub fn write_to<W: Write>(&self, program: &Program, w: &mut W) -> std::io::Result<()> {
        self.pieces(program)
            .into_iter()
            .try_for_each(|p| w.write_all(p))
    }

    /// The edited program as byte slices in order: runs of untouched blocks straight from the source, new
    /// lines and the terminators between them.
    fn pieces<'s>(&'s self, program: &'s Program) -> Vec<&'s [u8]> {
        let src = program.source();
        let eol = program.dominant_line_ending();
        let bom = if program.has_bom() { 3 } else { 0 };
        let mut out = vec![&src[..bom]];
        // Terminators are written lazily, so that a file without a final newline still ends without one.
        let mut pending: Option<&[u8]> = None;
        let mut piece = |out: &mut Vec<&'s [u8]>, content: &'s [u8], terminator: &'s [u8]| {
            if let Some(t) = pending {
                out.push(if t.is_empty() { eol } else { t });
            }
            out.push(content);
            pending = Some(terminator);
        };
        // A run of untouched blocks is one piece: the source's bytes, inner terminators included.
        let run = |from: usize, to: usize| {
            let last = program.content_span(to - 1);
            (
                &src[program.block_span(from).start.max(bom)..last.end],
                &src[last.end..program.block_span(to - 1).end],
            )
        };
        let mut last = 0;
        for (&i, slot) in &self.slots {
            if last < i {
                let (content, terminator) = run(last, i);
                piece(&mut out, content, terminator);
            }
            last = i + 1;
            let span = program.content_span(i);
            let terminator = &src[span.end..program.block_span(i).end];
            for line in &slot.before {
                piece(&mut out, line, eol);
            }
            match &slot.replace {
                Some(lines) => {
                    for (n, line) in lines.iter().enumerate() {
                        let t = if n + 1 == lines.len() {
                            terminator
                        } else {
                            eol
                        };
                        piece(&mut out, line, t);
                    }
                }
                None => piece(&mut out, &src[span.start.max(bom)..span.end], terminator),
            }
            for line in &slot.after {
                piece(&mut out, line, eol);
            }
        }
        if last < program.block_count() {
            let (content, terminator) = run(last, program.block_count());
            piece(&mut out, content, terminator);
        }
        let ends_with_newline = matches!(src.last(), Some(b'\n' | b'\r'));
        if let (Some(t), true) = (pending, ends_with_newline) {
            out.push(if t.is_empty() { eol } else { t });
        }
        out
    }

    /// The edited program's bytes. A large one is copied on all cores: filling a fresh buffer of 100 MB
    /// costs about as much in page faults as the copy itself, and both share out.
    pub fn to_bytes(&self, program: &Program) -> Vec<u8> {
        use rayon::prelude::*;
        const PART: usize = 1 << 20;
        let pieces = self.pieces(program);
        let total = pieces.iter().map(|p| p.len()).sum();
        if total < 4 * PART {
            return pieces.concat();
        }
        let mut out = vec![0u8; total];
        let mut rest = out.as_mut_slice();
        let mut copies = Vec::new();
        for part in pieces.iter().flat_map(|p| p.chunks(PART)) {
            let (to, after) = std::mem::take(&mut rest).split_at_mut(part.len());
            copies.push((part, to));
            rest = after;
        }
        copies
            .into_par_iter()
            .for_each(|(from, to)| to.copy_from_slice(from));
        out
    }
}
