//! Lossless Sinumerik syntax: one block per line, parsed from raw bytes.

mod fast;
mod grammar;
mod program;
mod tree;

pub use program::flag;
pub use program::{Block, BlockKind, Program, parse, parse_owned};
pub use tree::{Node, NodeJson, NodeKind, escape};
