//! Lossless Sinumerik syntax: one block per line, parsed from raw bytes.

mod block_kind;
mod decimal;
mod fast;
mod grammar;
mod keyword;
mod lexeme;
mod odd_bytes;
mod parse;
mod program;
pub mod structure;
mod tree;

pub use block_kind::{BlockKind, flag};
pub use decimal::{Decimal, decimal_prefix};
pub use fast::Words;
pub(crate) use grammar::control_statements;
pub use lexeme::Digits;
pub(crate) use lexeme::{leading_block_number, word_end_with};
#[cfg(test)]
pub(crate) use parse::parse_owned_in_pieces;
pub use parse::{line_syntax_errors, parse, parse_owned, parse_owned_with};
pub use program::{Block, Program};
pub use tree::{Node, NodeJson, NodeKind, escape};
