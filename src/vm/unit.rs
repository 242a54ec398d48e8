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
use crate::syntax::{BlockKind, Node, NodeKind, Program};

/// One parsed file. Block trees are built when a block runs; only the first [`CACHED_TREES`] built are kept
/// (loop bodies run again without re-parsing), so a long CAM program costs its source plus a few bytes per block.
pub struct Source {
    /// The file's name as shown in messages.
    pub file: Rc<str>,
    pub program: Program,
    /// Opener → its next partner (IF → ELSE or ENDIF, ELSE → ENDIF, WHILE → ENDWHILE …).
    pub forward: HashMap<usize, usize>,
    /// Closer → its opener.
    pub backward: HashMap<usize, usize>,
    /// The blocks carrying each label and block number.
    targets: Targets,
    pub numbers: Vec<Option<u64>>,
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
        let n = program.block_count();
        let mut forward = HashMap::new();
        let mut backward = HashMap::new();
        for &(open, close) in &structure.pairs {
            forward.insert(open, close);
            backward.insert(close, open);
        }
        let src = program.source();
        let upper = |n: &Node| String::from_utf8_lossy(n.span.slice(src)).to_ascii_uppercase();
        let mut targets = Targets::default();
        for (label, block) in structure.labels {
            targets.add_label(label, block);
        }
        let mut numbers = Vec::with_capacity(n);
        let mut procs = Vec::new();
        for block in program.blocks() {
            let root = &block.root;
            let number = root.find(NodeKind::BlockNumber).and_then(|b| {
                b.find(NodeKind::Number)
                    .and_then(|d| upper(d).parse::<u64>().ok())
            });
            if let Some(number) = number {
                targets.add_number(number, block.index);
            }
            numbers.push(number);
            if root.find(NodeKind::Proc).is_some() {
                procs.push(block.index);
            }
        }
        let headers = (0..n)
            .filter(|&i| program.block_kind(i) == BlockKind::Header)
            .map(|i| {
                let text = program.content_span(i).slice(src);
                (String::from_utf8_lossy(text).trim().to_ascii_uppercase(), i)
            })
            .collect();
        Source {
            file,
            program,
            forward,
            backward,
            targets,
            numbers,
            procs,
            headers,
            trees: RefCell::new(HashMap::new()),
        }
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
    /// The first unit of `program` (the whole file when it has no `%` headers).
    pub fn new(name: String, dir: Option<PathBuf>, program: Program) -> Self {
        let name: Rc<str> = name.into();
        let source = Rc::new(Source::new(name.clone(), program));
        let first = usize::from(
            source.program.block_count() > 0 && source.program.block_kind(0) == BlockKind::Header,
        );
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
        self.targets
            .destination(search, from, target, &(self.start..self.end))
    }

    /// The labelled blocks of a section repetition at block `at` (see [`Targets::section`]).
    pub fn section_labels(
        &self,
        at: usize,
        start: &str,
        end: Option<&str>,
    ) -> (Option<usize>, Option<usize>) {
        self.targets
            .section(at, start, end, &(self.start..self.end))
    }
}
