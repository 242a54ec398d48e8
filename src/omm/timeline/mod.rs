//! The program's timeline, estimated from its moves: feed moves take distance / F (arcs by their length,
//! G95 feeds per revolution by F·S), rapids distance / rapid rate, dwells their time, tool changes the
//! profile's time. It also collects what the emitter needs to know about the program: where passes start,
//! where the spindle speed changes, where the tool is retracted (safe points for extra measurements),
//! where the program ends, and which R-parameters and labels it already uses.
//!
//! The program is read once, in order, without running it: loops and jumps are counted once, expressions
//! as coordinates count as no move (`inexact_blocks` says how many blocks that affected).
//!
//! A pipeline, each step a module that uses only the ones before it (`tests/architecture.rs` checks this):
//!
//! - `modal`, `record`, `timing`: what the steps share — the modal state at a block, the [`Timeline`]
//!   they produce, time in ticks and the length of a move.
//! - `read`: each block reduced to the facts the timeline needs (a word scanner for the plain lines CAM
//!   output is made of, the syntax tree for any other), packed in chunks.
//! - `moves`: runs of plain moves the parser already timed while it read them ([`parse_timed`]); the
//!   chunks leave their blocks out.
//! - `fold`: the chunks and runs folded in block order into time, modal state, passes, gate sites, loops
//!   and calls.
//! - `unit`: one program unit through read and fold, chunks read in parallel, folded in order.
//! - `build`: the whole file — an archive's units, callees first, and subprograms from the profile's
//!   folders ([`build`], [`build_with_moves`]).

mod build;
mod fold;
mod modal;
mod moves;
mod read;
mod record;
mod timing;
mod unit;

#[cfg(test)]
mod tests;

pub use build::{build, build_with_moves};
pub use modal::{Modal, POSITIONED, frame, is_thread, unknown};
pub use moves::{Moves, parse_timed};
pub use record::{Loop, LoopKind, Pass, Site, SiteKind, Timeline};
pub(crate) use timing::on_tick;
