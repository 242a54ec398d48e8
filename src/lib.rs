//! driftloop: lossless Sinumerik NC program handling, thermal drift models and on-machine-measurement
//! compensation for CNC machines that drift while they warm up.

pub mod cli;
pub mod walk;
