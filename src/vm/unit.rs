//! A loaded program file: its parse, block trees, control-structure partners, labels and N numbers.

use std::collections::HashMap;
use std::path::PathBuf;

use crate::syntax::{BlockKind, Node, NodeKind, Program};

pub struct Unit {
    /// As the user named it (main program) or as found beside it (subprograms).
    pub name: String,
    pub dir: Option<PathBuf>,
    pub program: Program,
    pub roots: Vec<Node>,
    /// First block after the header and the block after the unit (the next `%` header or the end).
    pub start: usize,
    pub end: usize,
    /// Opener → its next partner (IF → ELSE or ENDIF, ELSE → ENDIF, WHILE → ENDWHILE …).
    pub forward: HashMap<usize, usize>,
    /// Closer → its opener.
    pub backward: HashMap<usize, usize>,
    pub labels: Vec<Option<String>>,
    pub numbers: Vec<Option<u64>>,
}

impl Unit {
    pub fn new(name: String, dir: Option<PathBuf>, program: Program) -> Self {
        let structure = crate::structure::analyze(&program);
        let roots: Vec<Node> = program.blocks().map(|b| b.root).collect();
        let n = roots.len();
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
        for root in &roots {
            labels.push(
                root.find(NodeKind::Label)
                    .and_then(|l| l.find(NodeKind::Name))
                    .map(upper),
            );
            numbers.push(root.find(NodeKind::BlockNumber).and_then(|b| {
                b.find(NodeKind::Number)
                    .and_then(|d| upper(d).parse::<u64>().ok())
            }));
        }
        // A closer with an opener in another unit does not exist: pairs are per unit.
        Unit {
            name,
            dir,
            program,
            roots,
            start,
            end,
            forward,
            backward,
            labels,
            numbers,
        }
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
