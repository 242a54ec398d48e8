//! Dry run: an interpreter for the Sinumerik subset that part programs and driftloop's own blocks use, running
//! against a virtual [`Machine`] whose tool centre point drifts. It shows what a (transformed) program will do
//! before it runs on a real machine: positions per block, time, spindle schedule, probe measurements, work-offset
//! corrections, alarms, files written, and per pass the Z depth actually cut minus the nominal one.
//!
//! The drift is commanded minus actual tool centre point (µm): a positive Z drift is a spindle grown towards
//! the part, so the machined error of a pass is the drift minus the correction applied since program start.
//!
//! ```
//! use driftloop::vm::{Config, SimpleMachine, run_source};
//! // The spindle grows 0.15 µm per minute; nothing corrects it.
//! let mut machine = SimpleMachine::with_drift(|axis, t_min, _spindle| if axis == "Z" { 0.15 * t_min } else { 0.0 });
//! let program = b"G90 G94 S3000 M3\nG4 F600\nG0 X0 Y0 Z1\nG1 Z0 F100\nG1 X100 F1000\nG0 Z5\nM30\n";
//! let run = run_source("part.mpf", program, None, &Config::default(), &mut machine).unwrap();
//! assert_eq!(run.passes.len(), 1);
//! assert!((run.totals.max_abs_error_um - 0.15 * run.passes[0].start_min).abs() < 0.01);
//! ```

pub mod audit;
mod config;
mod cycle_extent;
mod interp;
mod machine;
mod motion;
mod orientation;
mod passes;
mod polynomial;
mod report;
mod tool_numbers;
mod truth;
mod unit;
mod value;

use std::path::Path;

pub use config::{
    Config, MachineSpec, ProbeTarget, StartSpindle, StartTool, offset_frame, parse_machine_file,
};
pub use machine::{
    LaterJob, Machine, ProbeCall, ProbeFault, ProbeResult, SimpleMachine, SpindleHistory,
};
pub use passes::Pass;
pub use report::{
    Alarm, At, AxisError, Correction, End, Measurement, Message, Run, TempCompWrite, Totals,
    TraceRow,
};
pub use truth::ModelDrift;

/// A program the dry run cannot carry on with: unsupported construct, undefined variable, missing jump target,
/// iteration limit. Names the file and line.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}:{line}: {message}")]
pub struct VmError {
    pub file: String,
    pub line: usize,
    pub message: String,
}

/// Runs the program in `path`; subprograms are looked up beside it.
pub fn run_file(path: &Path, cfg: &Config, machine: &mut dyn Machine) -> Result<Run, VmError> {
    let bytes = std::fs::read(path).map_err(|e| VmError {
        file: path.display().to_string(),
        line: 0,
        message: e.to_string(),
    })?;
    let dir = path.parent().map(|d| {
        if d.as_os_str().is_empty() {
            Path::new(".").to_path_buf()
        } else {
            d.to_path_buf()
        }
    });
    let unit = unit::Unit::new(path.display().to_string(), dir, crate::parse_owned(bytes));
    interp::Interp::new(cfg, machine).run(unit)
}

/// Runs program text named `name`; subprograms are looked up in `dir` when given.
pub fn run_source(
    name: &str,
    src: &[u8],
    dir: Option<&Path>,
    cfg: &Config,
    machine: &mut dyn Machine,
) -> Result<Run, VmError> {
    let unit = unit::Unit::new(
        name.to_string(),
        dir.map(Path::to_path_buf),
        crate::parse(src),
    );
    interp::Interp::new(cfg, machine).run(unit)
}
