//! Red-team round: the modal state at every inserted gate, judged as the operator at the machine would
//! (fixtures/redteam holds the programs, written for this repository; its README lists the findings). Each
//! through the binary, which audits its output as planned and with every gate measuring.

mod common;

/// The text of `fixtures/redteam/NAME`.
fn redteam(name: &str) -> String {
    std::fs::read_to_string(common::fixture(&format!("redteam/{name}"))).unwrap()
}

/// Whether the gate right before the line starting with `at` measures.
fn measures_before(out: &str, at: &str) -> bool {
    common::gate_measures(&common::gate_before(out, at))
}

#[test]
fn no_gate_measures_under_a_frame_turned_to_the_tool_or_the_part() {
    // R1: TOFRAME and PAROT turn the programmable frame by angles the kinematics give. The timeline read
    // neither as a rotation: a gate after them measured, its probe point X0 Y0 and its retract along Z
    // taken in the turned frame. The dry run does not model them either, so the output was written "audit
    // incomplete", with that gate in it.
    for (file, after) in [
        ("01_toframe_tool_aligned_frame.mpf", "N120 G0 X10 Y30"),
        ("02_parot_part_aligned_frame.mpf", "N110 G0 X10 Y30"),
    ] {
        let src = redteam(file);
        for profile in common::MILLING_PROFILES {
            let out = common::every_gate_transformed(profile, &[("p.mpf", &src)]);
            assert!(!measures_before(&out, after), "{file} {profile}:\n{out}");
        }
    }
}

#[test]
fn no_gate_measures_while_a_programmed_tool_offset_is_in_force() {
    // R2: TOFFL, TOFFR and TOFF[axis] stay in force through a tool change: a spindle probe measured with
    // the finish pass's 0.05 mm of wear on its length and read it as drift (a scrap alarm, or a correction
    // that undoes the wear the program asked for); a tool setter reads the tool with it too. Each offset
    // counts until it is 0 again, whichever others are.
    let src = redteam("03_toffl_wear_after_zero.mpf");
    for profile in common::MILLING_PROFILES {
        let out = common::every_gate_transformed(profile, &[("p.mpf", &src)]);
        for under in ["N110 G0 X10 Y30", "N170 G0 X10 Y50"] {
            assert!(!measures_before(&out, under), "{profile} {under}:\n{out}");
        }
        assert!(
            measures_before(&out, "N220 G0 X10 Y70"),
            "{profile}:\n{out}"
        );
    }
}

#[test]
fn a_turning_spindle_whose_speed_an_expression_sets_is_no_place_to_measure() {
    // R3: `S=R10 M3` turns the spindle at a speed the timeline cannot evaluate. It took the speed as 0 and
    // so the spindle as standing: a gate measured and wrote no `S… M3` back, and the program's next cut
    // went in with the spindle stopped. The audit saw it and refused the whole program.
    let src = redteam("04_speed_from_parameters.mpf");
    for profile in common::MILLING_PROFILES {
        let out = common::every_gate_transformed(profile, &[("p.mpf", &src)]);
        assert!(!measures_before(&out, "N120 G0 X10 Y30"), "{profile}");
    }
}

#[test]
fn the_probing_runs_in_feed_per_minute_and_the_program_gets_its_feed_type_back() {
    // R4: the measuring cycle ran in the program's feed type: under G93 its probing feed is an inverse
    // time (a probing stroke in a fraction of a second), under G95 or G96 a feed per revolution of the
    // spindle the gate has stopped. The gate selects G94 before it probes and gives G93, G95 or G96 back.
    for (file, profiles, at, back) in [
        (
            "05_g95_drilling.mpf",
            &common::MILLING_PROFILES[..],
            "N90 G0 X40 Y10",
            "G95",
        ),
        (
            "06_g93_inverse_time.mpf",
            &common::MILLING_PROFILES[..],
            "N100 G0 X10 Y20",
            "G93",
        ),
        (
            "07_lathe_g96_g95.mpf",
            &["lathe-setter"][..],
            "N90 G0 X80",
            "G96 S200",
        ),
    ] {
        let src = redteam(file);
        for profile in profiles {
            let out = common::every_gate_transformed(profile, &[("p.mpf", &src)]);
            let gate = common::gate_before(&out, at);
            assert!(common::gate_measures(&gate), "{file} {profile}:\n{out}");
            let position = |p: &dyn Fn(&str) -> bool| gate.iter().position(|l| p(l));
            let g94 = position(&|l| l.starts_with("G94 "));
            let probe = position(&|l| {
                ["BL9700(", "CYCLE978(", "DL_SETTER("]
                    .iter()
                    .any(|c| l.starts_with(c))
            });
            assert!(
                g94.is_some() && g94 < probe,
                "{file} {profile}: G94 before the probing\n{}",
                gate.join("\n")
            );
            let back_line = position(&|l| l.contains(back) && l.contains("G90"));
            assert!(back_line > probe, "{file} {profile}: {back} given back");
        }
    }
}

#[test]
fn no_gate_measures_while_the_main_spindle_is_a_c_axis() {
    // R5: M70 switches the main spindle to axis mode for the driven tools. The timeline took it for a
    // machine M code and kept the spindle turning: the gate at the driven tool's change measured and gave
    // back `S1500 M4`, the chuck turning again under the cross drill that follows. The dry run ignored M70
    // alike.
    let src = redteam("08_m70_c_axis_cross_drilling.mpf");
    for profile in ["lathe-setter", "tool-setter"] {
        let out = common::every_gate_transformed(profile, &[("p.mpf", &src)]);
        assert!(!measures_before(&out, "N130 T3 D1"), "{profile}:\n{out}");
    }
}

#[test]
fn a_tool_setter_measures_no_more_once_the_program_writes_tool_data() {
    // R6: `$TC_DP12[1,1]=…+0.03` then `D1`: the tool's length grows by the wear the program adds. A tool
    // setter gate after it read the 30 µm as drift (beyond the 20 µm tolerance: a scrap alarm; within it, a
    // correction that undoes the wear). A spindle probe, whose own data the program leaves alone, measures.
    let src = redteam("09_tool_table_wear_before_finish.mpf");
    let out = common::every_gate_transformed("tool-setter", &[("p.mpf", &src)]);
    for at in ["N120 G0 X10 Y30", "N160 G0 X10 Y60"] {
        assert!(!measures_before(&out, at), "{at}:\n{out}");
    }
    let out = common::every_gate_transformed("blum-tc50", &[("p.mpf", &src)]);
    assert!(measures_before(&out, "N160 G0 X10 Y60"), "{out}");
}
