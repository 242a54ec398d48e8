//! Red-team round 2: the route of every inserted gate (how it leaves the cut, where it travels, how it
//! comes back to where the program resumes), judged as the operator at the machine would
//! (fixtures/redteam2 holds the programs, written for this repository; its README lists the findings).
//! Each through the binary, which audits its output as planned and with every gate measuring.

mod common;

/// The text of `fixtures/redteam2/NAME`.
fn redteam2(name: &str) -> String {
    std::fs::read_to_string(common::fixture(&format!("redteam2/{name}"))).unwrap()
}

/// The gate right before the line starting with `at`, its blocks without driftloop's `;DL`.
fn gate(out: &str, at: &str) -> Vec<String> {
    common::gate_before(out, at)
        .iter()
        .map(|l| l.trim_end_matches(";DL").trim_end().to_string())
        .collect()
}

/// Whether `block` programs one of `axes` (`Z=R62`, `Z10`, `SUPA Z-300`; not `$AA_IW[Z]`).
fn moves(block: &str, axes: &[char]) -> bool {
    let inserted_statement = ["R", "IF", "WRITE", "MSG", "$", "ENDIF", ";"]
        .iter()
        .any(|s| block.starts_with(s));
    !inserted_statement
        && block.split_whitespace().any(|w| {
            let mut c = w.chars();
            c.next().is_some_and(|a| axes.contains(&a))
                && c.next()
                    .is_some_and(|n| n == '=' || n == '-' || n.is_ascii_digit())
        })
}

#[test]
fn a_tool_setter_gate_under_a_programmable_translation_travels_at_the_clearance_of_the_work_offset()
{
    // T1: under `TRANS Z-40` (or `G58 Z-10` with `ATRANS Z-20`) the gate travelled to the setter at the
    // clearance Z100 of the translated frame, 40 (30) mm below the clearance of the work offset. The
    // audit refused the whole program (`xy-below-clearance`). As shipped only the zero measures, after
    // the translation, and it travelled as low: that output passed the audit. The travel height now counts
    // the programmable translation, and the program is written with its gates measuring.
    let src = redteam2("01_trans_z_tool_setter.mpf");
    let shipped = common::transformed_in(&[("p.mpf", &src)], "p.mpf", "tool-setter");
    let zero = gate(&shipped, "N80 G0 X10 Y10 Z5");
    assert!(
        zero.iter()
            .any(|l| l == "R62=100-($P_PFRAME[Z,TR]+$P_PFRAME[Z,FI])"),
        "{shipped}"
    );
    for (file, at) in [
        ("01_trans_z_tool_setter.mpf", "N120 G0 X10 Y30"),
        ("02_g58_atrans_tool_setter.mpf", "N130 G0 X10 Y30"),
    ] {
        let out = common::every_gate_transformed("tool-setter", &[("p.mpf", &redteam2(file))]);
        let gate = gate(&out, at);
        assert!(
            common::gate_measures(&common::gate_before(&out, at)),
            "{file}:\n{out}"
        );
        assert!(
            gate.iter()
                .any(|l| l == "R62=100-($P_PFRAME[Z,TR]+$P_PFRAME[Z,FI])"),
            "{file}:\n{}",
            gate.join("\n")
        );
    }
}

#[test]
fn under_g18_or_g19_on_a_mill_the_gate_travels_across_only_after_a_rise_in_g17() {
    // T2: with SD42940 TOOL_LENGTH_CONST = 0 the tool length acts along Y under G18, along X under G19: a
    // height along Z there is the spindle's, the tip a tool length lower. The gate retracted in the
    // program's plane and selected G17 after it (a tool setter then travelled to the setter with the tip a
    // tool length below the clearance), and the spindle-probe gate gave the plane back before its rise to
    // the travel height (the cutting tool travelled back across the part that low). Every travel across
    // now follows a move along Z made in G17; the descent to the saved height runs in the program's plane.
    for (file, at, plane) in [
        ("03_g18_ball_end_xz_arcs.mpf", "N120 G0 X0 Y30", "G18"),
        ("04_g19_ball_end_yz_arcs.mpf", "N120 G0 X20 Y10", "G19"),
    ] {
        let src = redteam2(file);
        for profile in common::MILLING_PROFILES {
            let out = common::every_gate_transformed(profile, &[("p.mpf", &src)]);
            let gate = gate(&out, at);
            assert!(
                common::gate_measures(&common::gate_before(&out, at)),
                "{file} {profile}"
            );
            let mut in_plane = plane;
            let mut last_z_in = None;
            for block in &gate {
                if let Some(p) = ["G17", "G18", "G19"]
                    .into_iter()
                    .find(|p| block.contains(p))
                {
                    in_plane = p;
                }
                if moves(block, &['Z']) {
                    last_z_in = Some(in_plane);
                } else if moves(block, &['X', 'Y']) {
                    assert_eq!(
                        last_z_in,
                        Some("G17"),
                        "{file} {profile}: `{block}` travels across after a move along Z in {last_z_in:?}\n{}",
                        gate.join("\n")
                    );
                }
            }
            let descent = gate.iter().rposition(|l| l == "Z=R65").unwrap();
            let given_back = gate.iter().rposition(|l| l == plane).unwrap();
            assert!(
                given_back < descent,
                "{file} {profile}:\n{}",
                gate.join("\n")
            );
        }
    }
}

#[test]
fn no_gate_that_moves_goes_before_an_arc_tangent_to_the_move_before_it() {
    // T3: `CT` takes its arc's tangent from the move before it. A measuring gate before it ended with its
    // own descent to the saved height, straight down the tool axis: the control would start the arc
    // tangent to that (or refuse an arc with no tangent in the plane), not to the program's rapid. The
    // audit passed it. Such a gate now only updates the prediction and corrects, which moves nothing.
    let src = redteam2("05_ct_after_optional_stop.mpf");
    for profile in common::MILLING_PROFILES {
        let out = common::every_gate_transformed(profile, &[("p.mpf", &src)]);
        let gate = common::gate_before(&out, "N160 CT X40 Y60");
        assert!(!gate.is_empty(), "{profile}: the pass marker's gate\n{out}");
        assert!(
            !common::gate_measures(&gate),
            "{profile}:\n{}",
            gate.join("\n")
        );
        assert!(
            !gate.iter().any(|l| moves(l, &['X', 'Y', 'Z'])),
            "{profile}:\n{}",
            gate.join("\n")
        );
        assert!(
            common::gate_before(&out, "N130 CT X80 Y60").is_empty(),
            "{profile}"
        );
    }
}

#[test]
fn no_gate_that_moves_measures_under_modal_rounding() {
    // T4: `RNDM=2` rounds the corner between every two moves in the plane until `RNDM=0`, a gate's
    // included: its rise, travel across and descent (to the probe point, and back to the saved height)
    // would be rounded off the route they are written on, and the probe cycle's moves with them. The
    // timeline did not read RNDM: a gate measured there. A gauge, which moves nothing, still does.
    let src = redteam2("06_rndm_across_retract.mpf");
    let probing = |l: &&str| {
        ["BL9700(", "CYCLE978(", "DL_SETTER("]
            .iter()
            .any(|c| l.starts_with(c))
    };
    for profile in common::MILLING_PROFILES {
        let out = common::every_gate_transformed(profile, &[("p.mpf", &src)]);
        let lines: Vec<&str> = out.lines().collect();
        let on = common::line_starting(&lines, "N70 RNDM=2");
        let off = common::line_starting(&lines, "N170 RNDM=0");
        assert!(!lines[on..off].iter().any(probing), "{profile}:\n{out}");
        assert!(
            lines[..on].iter().any(probing),
            "{profile}: the zero\n{out}"
        );
    }
    let out = common::every_gate_transformed("grinder-gauge", &[("p.mpf", &src)]);
    let gate = common::gate_before(&out, "N130 G0 X10 Y60");
    assert!(common::gate_measures(&gate), "{out}");
}
