//! The full block parser (placeholder: one Text leaf per line until the nom grammar lands).

use super::program::BlockKind;
use super::tree::{Node, NodeKind};
use crate::diagnostic::Diagnostic;
use crate::source::Span;

pub(crate) struct ParsedBlock {
    pub tree: Node,
    pub diagnostics: Vec<Diagnostic>,
    pub kind: BlockKind,
    pub flags: u8,
}

pub(crate) fn parse_block(_src: &[u8], content: Span, terminator: Span) -> ParsedBlock {
    let mut children = Vec::new();
    if content.start > 0 && terminator.start >= content.start && content.start == 3 {
        children.push(Node::leaf(NodeKind::Bom, Span::new(0, 3)));
    }
    children.push(Node::leaf(NodeKind::Text, content));
    children.push(Node::leaf(NodeKind::Newline, terminator));
    ParsedBlock {
        tree: Node::with_children(NodeKind::Block, children),
        diagnostics: Vec::new(),
        kind: BlockKind::Plain,
        flags: 0,
    }
}
