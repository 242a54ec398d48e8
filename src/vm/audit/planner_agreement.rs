//! The planner and the virtual machine agree on where no gate may stand. At every place the timeline
//! offers a gate, it calls the place unfit (a transformation, swivel, orientable toolholder, rotated frame
//! or cutter compensation) exactly where the dry run has one of those active — what the audit reports a
//! gate's probing, STOPRE or offset write under — and it sees a sum offset exactly where the dry run has
//! one. A construct one of them follows and the other does not fails here.

use super::state::transforms_active;
use crate::omm::timeline::{self, unknown};
use crate::omm::{Profile, Timeline};
use crate::vm::interp::Interp;
use crate::vm::machine::SimpleMachine;
use crate::vm::unit::Unit;
use crate::vm::{Config, VmError};

/// (what, the block that switches it on, the one that switches it off).
const CONSTRUCTS: &[(&str, &str, &str)] = &[
    ("TRAORI", "TRAORI", "TRAFOOF"),
    ("TRAORI(1)", "TRAORI(1)", "TRAFOOF"),
    ("TRANSMIT(1)", "TRANSMIT(1)", "TRAFOOF"),
    ("TRACYL(40)", "TRACYL(40)", "TRAFOOF"),
    ("TRAANG", "TRAANG", "TRAFOOF"),
    (
        "CYCLE800 swivel",
        "CYCLE800(1,\"TC1\",0,57,0,0,0,0,30,0,0,0,0,-1)",
        "CYCLE800()",
    ),
    ("ROT", "ROT Z30", "ROT"),
    ("AROT RPL=", "AROT RPL=45", "TRANS"),
    ("SCALE", "SCALE X2 Y2", "SCALE"),
    ("MIRROR", "MIRROR X0", "MIRROR"),
    ("TCARR with TCOABS", "TCARR=1 TCOABS", "TCARR=0"),
    ("TCARR with TCOFR", "TCARR=2 TCOFR", "TCARR=0"),
    ("G41", "G41", "G40"),
    ("DL", "D1 DL=2", "DL=0"),
    ("DL ended by D", "D1 DL=1", "D2"),
];

/// A program with places for gates (after each M1) while the construct is on and after it is off.
fn program(on: &str, off: &str) -> String {
    format!(
        "G17 G90 G94 G54\nT=\"MILL\" M6\nD1\nS3000 M3\nG0 X0 Y0 Z50\n{on}\nM1\nG0 X10 Y10 Z5\nG1 Z-1 F200\n\
         G1 X50\nG0 Z50\nM1\nG0 X15\n{off}\nM1\nG0 X20 Y20 Z5\nG1 Z-1\nG0 Z50\nM30\n"
    )
}

/// What the planner and the dry run say before a block the timeline offers a gate at: (unfit, sum offset).
#[derive(Debug)]
struct Verdict {
    block: usize,
    planner: (bool, bool),
    dry_run: (bool, bool),
}

fn verdicts(src: &str) -> Result<Vec<Verdict>, VmError> {
    let program = crate::parse(src.as_bytes());
    let plan: Timeline = timeline::build(&program, &Profile::default_profile());
    let cfg = Config::default();
    let mut machine = SimpleMachine::cold();
    let mut vm = Interp::new(&cfg, &mut machine);
    vm.start(Unit::new("agreement".into(), None, program))?;
    let mut out: Vec<Verdict> = Vec::new();
    while let Some((_, block)) = vm.peek() {
        if let Some(site) = plan.sites.iter().find(|s| s.block == block)
            && !out.iter().any(|v| v.block == block)
        {
            out.push(Verdict {
                block,
                planner: (
                    site.before.unfit().is_some(),
                    site.before.unknown & unknown::SUM_OFFSET != 0,
                ),
                dry_run: (
                    !transforms_active(&vm.motion).is_empty(),
                    vm.motion.dl != 0.0,
                ),
            });
        }
        vm.step()?;
    }
    Ok(out)
}

#[test]
fn the_planner_calls_a_place_unfit_where_the_dry_run_has_a_transformation() {
    for (what, on, off) in CONSTRUCTS {
        let src = program(on, off);
        let verdicts = verdicts(&src).unwrap_or_else(|e| panic!("{what}: {e}"));
        for v in &verdicts {
            assert_eq!(
                v.planner,
                v.dry_run,
                "{what}, before line {}: (unfit, sum offset) for the planner and for the dry run differ",
                v.block + 1
            );
        }
        // Not vacuous: the construct is met on at some place and off at another.
        let on_at = |v: &Verdict| v.planner.0 || v.planner.1;
        assert!(verdicts.iter().any(on_at), "{what}: {verdicts:?}");
        assert!(!verdicts.iter().all(on_at), "{what}: {verdicts:?}");
    }
}
