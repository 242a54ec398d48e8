//! driftloop: lossless Sinumerik NC program handling, thermal drift models and on-machine-measurement
//! compensation for CNC machines that drift while they warm up.
//!
//! The library is what the `driftloop` command line is built from; everything the commands do is here:
//!
//! - **Programs**: [`parse`] reads any bytes into a lossless [`Program`] (never fails; problems become
//!   [`Diagnostic`]s), [`Program::to_bytes`] gives the input back byte for byte, [`Editor`] inserts and
//!   replaces blocks, [`analyze`] pairs IF/WHILE/FOR/… and resolves jumps, [`views`] reads a block's typed
//!   facts (tool, spindle, feed, axes, offsets).
//! - **Data and models**: [`data`] reads measurement CSV files, [`model`] fits, predicts, reads and writes the
//!   thermal drift model (first-order modes driven by spindle speed and other inputs).
//! - **Compensation**: [`omm`] plans measurements from a model and inserts the measuring gates into a
//!   program ([`omm::transform`]) for a machine [`omm::Profile`]; [`strip`] removes them again.
//! - **Checking on a virtual machine**: [`vm`] dry-runs programs (time, passes, machined error, probe
//!   readings) and audits a transformed program against its original ([`vm::audit`]).
//! - **Closing the loop**: [`diagnose`] traces a model's residual on new data to the effects it lacks;
//!   [`sensors`] selects temperature sensors and regresses on them; [`positioning`] evaluates positioning
//!   accuracy after DSTU/GOST 27843-88, VDI 3441 and ISO 230-2; [`report`] draws the self-contained HTML
//!   reports.
//!
//! From measured data to a compensated program and back:
//!
//! ```
//! use driftloop::data::{Require, read_path};
//! use driftloop::model::{FitOptions, fit};
//! use driftloop::omm::{ModelRef, Profile, transform};
//!
//! let data = read_path("fixtures/data/characterisation.csv".as_ref(), Require::Displacement)?;
//! let model = fit(&data, &FitOptions::new("drift_z_um"))?;
//! let program = driftloop::parse(&std::fs::read("fixtures/omm/handwritten.mpf")?);
//! let drift = ModelRef { model: &model, sha256: "not from a file" };
//! let out = transform(&program, drift, &Profile::default_profile(), false)?;
//! assert!(out.summary.gates > 0);
//! assert_eq!(driftloop::strip::strip(&out.bytes).bytes, program.source()); // undo, byte for byte
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The command line and its conventions are documented in the repository's `docs/` folder.

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
pub mod text;
pub mod toml_span;
pub mod views;
pub mod vm;
pub mod walk;

/// Millimetres in an inch: what G70/G700 values and G700 feeds are worth in the metric basic system.
pub(crate) const MM_PER_INCH: f64 = 25.4;

pub use diagnostic::{Diagnostic, Severity};
pub use edit::{EditError, Editor, Edits};
pub use source::{LineIndex, Span};
pub use syntax::structure::{self, Structure, analyze};
pub use syntax::{Block, BlockKind, Node, NodeKind, Program, escape, parse, parse_owned};
