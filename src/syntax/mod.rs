//! Lossless Sinumerik syntax: one block per line, parsed from raw bytes.

mod fast;
mod grammar;
mod keyword;
mod lexeme;
mod program;
mod tree;

pub(crate) use lexeme::leading_block_number;
pub use program::flag;
pub use program::{Block, BlockKind, Program, line_syntax_errors, parse, parse_owned};
pub use tree::{Node, NodeJson, NodeKind, escape};
