//! Control-structure pairing and jump-target resolution over the compact block records.

use crate::diagnostic::Diagnostic;
use crate::syntax::Program;

pub(crate) fn check(_program: &Program) -> Vec<Diagnostic> {
    Vec::new()
}
