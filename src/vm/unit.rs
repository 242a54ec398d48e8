//! A loaded program file: its parse, block trees, control-structure partners, labels and N numbers.

use std::cell::RefCell;
use std::collections::HashMap;
use std::path::PathBuf;
use std::rc::Rc;

use crate::syntax::{BlockKind, Node, NodeKind, Program};

/// Block trees are built when a block runs; only the first [`CACHED_TREES`] built are kept (loop bodies run
/// again without re-parsing), so a long CAM program costs its source plus a few bytes per block.
pub struct Unit {
    /// As the user named it (main program) or as found beside it (subprograms).
    pub name: Rc<str>,
    pub dir: Option<PathBuf>,
    pub program: Program,
    /// First block after the header and the block after the unit (the next `%` header or the end).
    pub start: usize,
    pub end: usize,
    /// Opener → its next partner (IF → ELSE or ENDIF, ELSE → ENDIF, WHILE → ENDWHILE …).
    pub forward: HashMap<usize, usize>,
    /// Closer → its opener.
    pub backward: HashMap<usize, usize>,
    pub labels: Vec<Option<String>>,
    pub numbers: Vec<Option<u64>>,
    /// The block holding the unit's `PROC` statement.
    pub proc_block: Option<usize>,
    trees: RefCell<HashMap<usize, Rc<Node>>>,
}

/// How many block trees a unit keeps.
pub const CACHED_TREES: usize = 4096;

impl Unit {
    pub fn new(name: String, dir: Option<PathBuf>, program: Program) -> Self {
        let structure = crate::structure::analyze(&program);
        let n = program.block_count();
        let start = usize::from(n > 0 && program.block_kind(0) == BlockKind::Header);
        let end = (start..n)
            .find(|&i| program.block_kind(i) == BlockKind::Header)
            .unwrap_or(n);
        let mut forward = HashMap::new();
        let mut backward = HashMap::new();
        for &(open, close) in &structure.pairs {
            forward.insert(open, close);
            backward.insert(close, open);
        }
        let src = program.source();
        let upper = |n: &Node| String::from_utf8_lossy(n.span.slice(src)).to_ascii_uppercase();
        let mut labels = Vec::with_capacity(n);
        let mut numbers = Vec::with_capacity(n);
        let mut proc_block = None;
        for block in program.blocks() {
            let root = &block.root;
            labels.push(
                root.find(NodeKind::Label)
                    .and_then(|l| l.find(NodeKind::Name))
                    .map(upper),
            );
            numbers.push(root.find(NodeKind::BlockNumber).and_then(|b| {
                b.find(NodeKind::Number)
                    .and_then(|d| upper(d).parse::<u64>().ok())
            }));
            if proc_block.is_none()
                && (start..end).contains(&block.index)
                && root.find(NodeKind::Proc).is_some()
            {
                proc_block = Some(block.index);
            }
        }
        Unit {
            name: name.into(),
            dir,
            program,
            start,
            end,
            forward,
            backward,
            labels,
            numbers,
            proc_block,
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

    /// The block a jump lands on: forward searches after `from`, backward from `from` towards the start, both
    /// forward first (GOTO, GOTOC). The nearest match in the search direction wins, as on the control.
    pub fn search(
        &self,
        from: usize,
        target: &JumpTarget,
        forward: bool,
        backward: bool,
    ) -> Option<usize> {
        let hit = |i: &usize| match target {
            JumpTarget::Label(l) => self.labels[*i].as_deref() == Some(l.as_str()),
            JumpTarget::Number(n) => self.numbers[*i] == Some(*n),
        };
        let ahead = if forward {
            (from + 1..self.end).find(hit)
        } else {
            None
        };
        ahead.or_else(|| {
            if backward {
                (self.start..=from).rev().find(hit)
            } else {
                None
            }
        })
    }
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub enum JumpTarget {
    Label(String),
    Number(u64),
}

impl std::fmt::Display for JumpTarget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            JumpTarget::Label(l) => f.write_str(l),
            JumpTarget::Number(n) => write!(f, "N{n}"),
        }
    }
}
