//! A loaded program file and the program units in it: parse, block trees, control-structure partners, labels
//! and N numbers. A file is one unit, or an archive of several (`%_N_NAME_MPF`, `%_N_SUB_SPF`, …) whose
//! subprograms can be called from the others.

use std::cell::RefCell;
use std::collections::HashMap;
use std::ops::Deref;
use std::path::PathBuf;
use std::rc::Rc;

pub use crate::structure::JumpTarget;
use crate::structure::{Search, Targets};
use crate::syntax::{BlockKind, Node, NodeKind, Program, flag};

/// One parsed file. Block trees are built when a block runs; only the first [`CACHED_TREES`] built are kept
/// (loop bodies run again without re-parsing), so a long CAM program costs its source plus a few bytes per block:
/// labels and `PROC` blocks are found through the parser's block flags and a text search, N numbers are read
/// when a jump searches for one.
pub struct Source {
    /// The file's name as shown in messages.
    pub file: Rc<str>,
    pub program: Program,
    /// Opener → its next partner (IF → ELSE or ENDIF, ELSE → ENDIF, WHILE → ENDWHILE …).
    pub forward: HashMap<usize, usize>,
    /// Closer → its opener.
    pub backward: HashMap<usize, usize>,
    /// The blocks carrying each label.
    labels: Targets,
    /// The blocks carrying each block number, read at the first jump to a number (most programs have
    /// none, and a CAM program has millions of N words).
    numbers: std::cell::OnceCell<Targets>,
    /// Blocks holding a `PROC` statement.
    procs: Vec<usize>,
    /// Upper-cased `%` header lines and their blocks.
    headers: Vec<(String, usize)>,
    trees: RefCell<HashMap<usize, Rc<Node>>>,
}

/// How many block trees a file keeps.
pub const CACHED_TREES: usize = 4096;

/// One program unit of a file: blocks `start..end`.
pub struct Unit {
    /// As the user named it (main program) or as found beside it (subprograms).
    pub name: Rc<str>,
    pub dir: Option<PathBuf>,
    pub source: Rc<Source>,
    /// First block after the header and the block after the unit (the next `%` header or the end).
    pub start: usize,
    pub end: usize,
    /// The block holding the unit's `PROC` statement.
    pub proc_block: Option<usize>,
}

impl Deref for Unit {
    type Target = Source;

    fn deref(&self) -> &Source {
        &self.source
    }
}

impl Source {
    fn new(file: Rc<str>, program: Program) -> Self {
        let structure = crate::structure::analyze(&program);
        let mut forward = HashMap::new();
        let mut backward = HashMap::new();
        for &(open, close) in &structure.pairs {
            forward.insert(open, close);
            backward.insert(close, open);
        }
        let src = program.source();
        let upper = |n: &Node| String::from_utf8_lossy(n.span.slice(src)).to_ascii_uppercase();
        let mut labels = Targets::default();
        for i in (0..program.block_count()).filter(|&i| program.block_flags(i) & flag::LABEL != 0) {
            let root = program.block(i).root;
            if let Some(label) = root
                .find(NodeKind::Label)
                .and_then(|l| l.find(NodeKind::Name))
                .map(upper)
            {
                labels.add_label(label, i);
            }
        }
        // PROC is rare: only blocks whose text holds the word (any case) are parsed to be sure.
        let mut procs: Vec<usize> = Vec::new();
        for at in memchr::memchr2_iter(b'P', b'p', src) {
            if !src[at..]
                .get(..4)
                .is_some_and(|w| w.eq_ignore_ascii_case(b"PROC"))
            {
                continue;
            }
            let i = program.block_at(at);
            if procs.last() != Some(&i) && program.block(i).root.find(NodeKind::Proc).is_some() {
                procs.push(i);
            }
        }
        let headers = program
            .header_blocks()
            .iter()
            .map(|&i| {
                let text = program.content_span(i).slice(src);
                (String::from_utf8_lossy(text).trim().to_ascii_uppercase(), i)
            })
            .collect();
        Source {
            file,
            program,
            forward,
            backward,
            labels,
            numbers: std::cell::OnceCell::new(),
            procs,
            headers,
            trees: RefCell::new(HashMap::new()),
        }
    }

    /// The N number of block `i`, if it has one.
    pub fn number(&self, i: usize) -> Option<u64> {
        let root = self.root(i);
        let n = root.find(NodeKind::BlockNumber)?.find(NodeKind::Number)?;
        String::from_utf8_lossy(n.span.slice(self.program.source()))
            .parse()
            .ok()
    }

    /// The syntax tree of block `i`.
    pub fn root(&self, i: usize) -> Rc<Node> {
        if let Some(tree) = self.trees.borrow().get(&i) {
            return tree.clone();
        }
        let tree = Rc::new(self.program.block(i).root);
        let mut trees = self.trees.borrow_mut();
        if trees.len() < CACHED_TREES {
            trees.insert(i, tree.clone());
        }
        tree
    }
}

impl Unit {
    /// The main program of `program`: its first unit (the whole file when it has no `%` headers), or the
    /// first `%_N_NAME_MPF` section of an archive that opens with another file.
    pub fn new(name: String, dir: Option<PathBuf>, program: Program) -> Self {
        let name: Rc<str> = name.into();
        let source = Rc::new(Source::new(name.clone(), program));
        if let Some(h) = source.program.later_main_header() {
            return Unit::at(name, dir, source, h + 1);
        }
        // The main program starts after its `%` header, which comment lines may precede (a title).
        let program = &source.program;
        let src = program.source();
        let first = (0..program.block_count())
            .take_while(|&i| {
                let text = program.content_span(i).slice(src).trim_ascii();
                program.block_kind(i) == BlockKind::Header
                    || text.is_empty()
                    || text.starts_with(b";")
            })
            .find(|&i| program.block_kind(i) == BlockKind::Header)
            .map_or(0, |h| h + 1);
        Unit::at(name, dir, source, first)
    }

    fn at(name: Rc<str>, dir: Option<PathBuf>, source: Rc<Source>, start: usize) -> Self {
        let program = &source.program;
        let end = (start..program.block_count())
            .find(|&i| program.block_kind(i) == BlockKind::Header)
            .unwrap_or(program.block_count());
        let proc_block = source
            .procs
            .iter()
            .copied()
            .find(|b| (start..end).contains(b));
        Unit {
            name,
            dir,
            source,
            start,
            end,
            proc_block,
        }
    }

    /// Another unit of the same file (an archive), by program name: `%_N_NAME_SPF` or `%_N_NAME_MPF`.
    pub fn sibling(&self, name: &str) -> Option<Unit> {
        let wanted = [format!("%_N_{name}_SPF"), format!("%_N_{name}_MPF")];
        let &(_, header) = self
            .source
            .headers
            .iter()
            .find(|(h, _)| wanted.contains(h))?;
        let display = format!("{}[{name}]", self.source.file);
        Some(Unit::at(
            display.into(),
            self.dir.clone(),
            self.source.clone(),
            header + 1,
        ))
    }

    /// The definition sections of the same file (an archive's `%_N_UGUD_DEF`, `%_N_SGUD_DEF`, …).
    pub fn definition_sections(&self) -> Vec<Unit> {
        let program = &self.source.program;
        program
            .header_blocks()
            .iter()
            .filter_map(|&h| {
                let (name, kind) = program.section(h)?;
                let display = format!("{}[{name}_{kind}]", self.source.file);
                (kind == "DEF")
                    .then(|| Unit::at(display.into(), self.dir.clone(), self.source.clone(), h + 1))
            })
            .collect()
    }

    /// The unit's `PROC` statement.
    pub fn proc(&self) -> Option<Node> {
        let root = self.root(self.proc_block?);
        root.children
            .iter()
            .find(|c| c.kind == NodeKind::Proc)
            .cloned()
    }

    pub fn text(&self, node: &Node) -> &[u8] {
        node.span.slice(self.program.source())
    }

    pub fn upper(&self, node: &Node) -> String {
        String::from_utf8_lossy(self.text(node)).to_ascii_uppercase()
    }

    /// The block a jump from block `from` lands on (see [`Targets::destination`]).
    pub fn search(&self, from: usize, target: &JumpTarget, search: Search) -> Option<usize> {
        let targets = match target {
            JumpTarget::Label(_) => &self.labels,
            JumpTarget::Number(_) => self.numbers.get_or_init(|| {
                let mut numbers = Targets::default();
                for i in 0..self.program.block_count() {
                    if let Some(n) = self.number(i) {
                        numbers.add_number(n, i);
                    }
                }
                numbers
            }),
        };
        targets.destination(search, from, target, &(self.start..self.end))
    }

    /// The labelled blocks of a section repetition at block `at` (see [`Targets::section`]).
    pub fn section_labels(
        &self,
        at: usize,
        start: &str,
        end: Option<&str>,
    ) -> (Option<usize>, Option<usize>) {
        self.labels.section(at, start, end, &(self.start..self.end))
    }
}
