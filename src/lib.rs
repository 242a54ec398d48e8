//! driftloop: lossless Sinumerik NC program handling, thermal drift models and on-machine-measurement
//! compensation for CNC machines that drift while they warm up.

pub mod cli;
pub mod data;
pub mod demo;
pub mod diagnose;
pub mod diagnostic;
pub mod edit;
pub mod model;
pub mod omm;
pub mod positioning;
pub mod report;
pub mod sensors;
// The unit tests find ../shared through the same helper as the integration tests.
#[cfg(test)]
#[path = "../tests/shared_data/mod.rs"]
mod shared_data;
pub mod source;
pub mod strip;
pub mod syntax;
pub mod views;
pub mod vm;
pub mod walk;

pub use diagnostic::{Diagnostic, Severity};
pub use edit::{EditError, Editor, Edits};
pub use source::{LineIndex, Span};
pub use syntax::structure::{self, Structure, analyze};
pub use syntax::{Block, BlockKind, Node, NodeKind, Program, escape, parse, parse_owned};
