//! The abort paths a clean run does not take. Before the first probe call of a gate, a copy of the
//! transformed run carries on against a probe that returns NaN, one that returns a value orders of magnitude
//! off (1e6 mm), and one that sees a drift between the tolerance and the plausibility limit (scrap); each copy
//! runs until it stops in inserted blocks (an abort) or reaches an original block again (no abort there).

use super::{At, Key, Runner};
use crate::omm::nc::shown as num;
use crate::vm::VmError;
use crate::vm::audit::{Kind, state};
use crate::vm::interp::Interp;
use crate::vm::machine::{Machine, ProbeCall, ProbeResult, SimpleMachine, SpindleHistory};

/// Blocks an abort path may take before it is given up (the measuring loop of a gate is a few hundred).
const BLOCK_LIMIT: usize = 100_000;

#[derive(Debug, Clone, Copy)]
enum Fault {
    Nan,
    Garbage,
    Scrap,
}

/// A probe that fails one way on every call; drift held at its value when the copy was made.
struct FaultyProbe {
    fault: Fault,
    drift_um: f64,
    scrap_um: f64,
    /// The machine's analog inputs, which the inserted blocks may read.
    inputs: SimpleMachine,
}

impl Machine for FaultyProbe {
    fn drift_um(&mut self, _axis: &str, _t_min: f64, _spindle: &SpindleHistory) -> f64 {
        self.drift_um
    }

    fn probe(&mut self, _call: &ProbeCall<'_>) -> ProbeResult {
        match self.fault {
            Fault::Nan => ProbeResult::Raw(f64::NAN),
            Fault::Garbage => ProbeResult::Raw(1.0e6),
            Fault::Scrap => ProbeResult::Drift(self.drift_um + self.scrap_um),
        }
    }

    fn analog_input(&self, n: usize, t_min: f64) -> Option<f64> {
        self.inputs.analog_input(n, t_min)
    }
}

impl std::fmt::Display for Fault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Fault::Nan => "NaN",
            Fault::Garbage => "1e6 mm",
            Fault::Scrap => "a scrap-size drift",
        })
    }
}

/// A faulty probe value the program let through to a work offset before it carried on with the original.
fn reached_offset(
    runner: &mut Runner<'_>,
    copy: &Interp<'_>,
    o: &Interp<'_>,
    fault: Fault,
    wrote: Option<At>,
) {
    let (Some(at), Some(entry)) = (
        wrote,
        state::wild_entry(&copy.motion.frames, &o.motion.frames, &copy.cfg.axes),
    ) else {
        return;
    };
    runner.add(at.finding(
        Kind::FaultReachesOffset,
        format!(
            "with a probe that returns {fault} this write leaves {} = {} mm (the original has {} mm) and the \
             program carries on: the plausibility check lets the faulty value through",
            entry.name(),
            num(entry.transformed),
            num(entry.original)
        ),
    ));
}

/// Follows each abort path from the probe call `t` is about to make.
pub(super) fn follow(
    runner: &mut Runner<'_>,
    t: &mut Interp<'_>,
    o: &Interp<'_>,
) -> Result<(), VmError> {
    let s = runner.settings;
    let axis = ["X", "Y", "Z"][s.axis];
    let drift_um = t.drift_now(axis);
    for fault in [Fault::Nan, Fault::Garbage, Fault::Scrap] {
        let mut probe = FaultyProbe {
            fault,
            drift_um,
            scrap_um: (s.tolerance_um + s.plausibility_um) / 2.0,
            inputs: s.machine.build(s.seed),
        };
        let mut copy = t.fork(&mut probe);
        runner.audit.abort_runs += 1;
        // The inserted block that last wrote a work offset on this path.
        let mut wrote = None;
        for _ in 0..BLOCK_LIMIT {
            let Some((unit, block)) = copy.peek() else {
                break;
            };
            if runner.lines.key_in(&copy, &unit, block) != Key::Inserted {
                if !matches!(fault, Fault::Scrap) {
                    reached_offset(runner, &copy, o, fault, wrote.take());
                }
                break;
            }
            let at = At::of(&runner.lines, &unit, block);
            let (corrections, trans) = (
                copy.report().corrections.len(),
                copy.motion.frames.trans.clone(),
            );
            let step = copy
                .step()
                .map_err(|e| VmError {
                    message: format!(
                        "{} (on the abort path with a probe that returns {fault})",
                        e.message
                    ),
                    ..e
                })?
                .expect("peeked");
            if copy.report().corrections.len() > corrections || copy.motion.frames.trans != trans {
                wrote = Some(at.clone());
            }
            if step.stop.is_some() || step.end.is_some() {
                runner.offset_on_stop(&at, &step, &copy, o);
            }
            if step.end.is_some() {
                runner.audit.aborts_reached += 1;
                break;
            }
        }
    }
    Ok(())
}
