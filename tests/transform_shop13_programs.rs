//! Lost measurements and needless refusals QA round 13 found in public Sinumerik programs driftloop had not
//! seen (fixtures/shop13 holds reductions written for this repository; its README lists them). Each through
//! the binary, which audits its output as planned and with every gate measuring.

mod common;

/// The text of `fixtures/shop13/NAME`.
fn shop13(name: &str) -> String {
    std::fs::read_to_string(common::fixture(&format!("shop13/{name}"))).unwrap()
}

#[test]
fn after_a_retract_with_d0_the_spindle_start_of_the_next_tool_measures() {
    // 01: the post retracts to machine zero with the length deselected (`G0 SUPA Z0 D0`) before every
    // tool change. The pass start there is no place for a spindle probe (heights are the spindle's), and a
    // spindle start measured only where the spindle stopped: no gate after the zero measured at any tool
    // change, only after the first tool's cuts. The place after the change and its `D1`, before the
    // spindle starts, measures now, with the new tool given back.
    let src = shop13("01_supa_d0_retract_before_each_toolchange.mpf");
    for profile in ["blum-tc50", "siemens-cycle978"] {
        let out = common::every_gate_transformed(profile, &[("p.mpf", &src)]);
        for (start, tool) in [("N200 S5000 M3", "T=2 M6"), ("N330 S3000 M3", "T=3 M6")] {
            let gate = common::gate_before(&out, start);
            assert!(common::gate_measures(&gate), "{profile} {start}:\n{out}");
            assert!(
                gate.iter().any(|l| l.starts_with(tool)),
                "{profile} {start}"
            );
        }
        // The pass start before the change, under D0, still does not measure.
        assert!(!common::gate_measures(&common::gate_before(
            &out,
            "N180 T2 M6"
        )));
    }
    // A gate that could measure at the tool change keeps the spindle start after it from measuring again.
    let with_length = src.replace("SUPA Z0 D0", "SUPA Z0");
    let out = common::every_gate_transformed("blum-tc50", &[("p.mpf", &with_length)]);
    assert!(common::gate_measures(&common::gate_before(
        &out,
        "N180 T2 M6"
    )));
    assert!(!common::gate_measures(&common::gate_before(
        &out,
        "N200 S5000 M3"
    )));
}

#[test]
fn a_grinder_program_with_pi_and_an_axis_variable_is_audited_to_its_end() {
    // 02: the wheel speed from the cutting speed with `$PI`, the oscillation axis held in an AXIS variable
    // set as `PENDEL=(Z)` (both as grinder builders' macros write them). The dry run stopped at each, so
    // the output was written "audit incomplete", without the safety audit from there on.
    let src = shop13("02_grinder_pi_wheel_speed_axis_variable.mpf");
    for profile in ["grinder-gauge", "lathe-setter"] {
        let every = common::measuring_builtin(profile);
        let (o, _dir) = common::transform_in(
            &[("p.mpf", &src), ("every.toml", &every)],
            "p.mpf",
            "every.toml",
        );
        let err = common::stderr(&o);
        assert!(o.status.success(), "{profile}: {err}");
        assert!(!err.contains("audit incomplete"), "{profile}: {err}");
    }
}

#[test]
fn an_old_sinumerik_drilling_cycle_is_refused_by_what_it_is() {
    // F5: `G81 … R2=… R3=…`, the drilling cycle of the Sinumerik 810/820 syntax, was refused as "a word of
    // the ISO dialect (G291 mode)". The refusal is right (an 840D in Siemens mode refuses G81 too); the
    // message names both readings now, and other ISO words keep theirs.
    let prog =
        "G17 G90 G54\nT1 M6\nS1000 M3\nG0 X10 Y10 Z5\nG81 X10 Y10 R2=5 R3=-10\nG0 Z50\nM30\n";
    let (o, _dir) = common::transform_in(&[("p.mpf", prog)], "p.mpf", "blum-tc50");
    assert_eq!(o.status.code(), Some(2));
    let err = common::stderr(&o);
    assert!(
        err.contains("line 5: G81 is a drilling cycle of the ISO dialect")
            && err.contains("older Sinumerik 810/820 syntax"),
        "{err}"
    );
}

#[test]
fn a_spindle_start_under_the_part_does_not_measure() {
    // The spindle start that measures since F1 (a pass whose start is unfit under D0) must not be one where
    // the tool went down without cutting since it last rose: a tool lowered into a bore or a pocket with
    // its spindle stopped (a back-boring bar goes down through its bore so) starts it there, below what
    // was cut. A gate there would retract along Z through the part.
    let prog = "G17 G90 G94 G54\nT=\"FRAESER\" M6\nD1\nS4000 M3\nG0 X0 Y0 Z5\nG1 Z-2 F300\nG1 X40\n\
                G0 Z50\nM5\nG0 SUPA Z0 D0\nT=\"RUECKWAERTS\" M6\nD1\nG0 X50 Y48 Z20\nG0 Z-35\nG0 Y50\n\
                S600 M3\nG1 Z-30 F50\nM5\nG0 Y48\nG0 Z50\nM30\n";
    for profile in ["blum-tc50", "tool-setter"] {
        let out = common::every_gate_transformed(profile, &[("p.mpf", prog)]);
        let gate = common::gate_before(&out, "S600 M3");
        assert!(!common::gate_measures(&gate), "{profile}:\n{out}");
    }
}

#[test]
fn a_builder_tool_change_m_code_is_read_and_written_with_the_profile_key() {
    // 03 (F4): the builder made M16 the tool change (MD22560 TOOL_CHANGE_M_CODE) and every change follows
    // a retract with D0. Read with M6 as the change, `T1 M16` only preselects, D0 stays in force and every
    // place is refused: the message now names the M-code and the key that reads it.
    let src = shop13("03_builder_m16_toolchange.mpf");
    let (o, _dir) = common::transform_in(&[("p.mpf", &src)], "p.mpf", "blum-tc50");
    assert_eq!(o.status.code(), Some(2));
    let err = common::stderr(&o);
    assert!(
        err.contains("if M16 (line 4, beside the T word) is this machine's tool change")
            && err.contains("set tool_change_m = 16"),
        "{err}"
    );
    // With `tool_change_m = 16` the change loads the tool and its default edge: the reference measures,
    // the probe is swapped in and each tool given back with M16 (never M6, which this machine does not
    // take as a change), and the audit, which reads M16 as the change too, passes.
    let every = common::measuring_builtin("blum-tc50").replace(
        "tool_change = \"m6\"",
        "tool_change = \"m6\"\ntool_change_m = 16",
    );
    assert!(every.contains("tool_change_m = 16"));
    let out = common::transformed_in(
        &[("p.mpf", &src), ("m16.toml", &every)],
        "p.mpf",
        "m16.toml",
    );
    assert!(out.contains("T=\"BLUM_TC50\" M16 ;DL"), "{out}");
    assert!(
        !out.lines().any(|l| l.ends_with(";DL") && l.contains(" M6")),
        "{out}"
    );
    for (start, tool) in [("N40 S12000", "T=1 M16"), ("N140 S8000", "T=2 M16")] {
        let gate = common::gate_before(&out, start);
        assert!(common::gate_measures(&gate), "{start}:\n{out}");
        assert!(gate.iter().any(|l| l.starts_with(tool)), "{start}:\n{out}");
    }
}
