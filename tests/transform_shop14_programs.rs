//! Lost measurements and needless refusals QA round 14 found in programs written in the exact output forms
//! of public Sinumerik post-processors (fixtures/shop14 holds reductions written for this repository; its
//! README lists them). Each through the binary, which audits its output as planned and with every gate
//! measuring.

mod common;

/// The text of `fixtures/shop14/NAME`.
fn shop14(name: &str) -> String {
    std::fs::read_to_string(common::fixture(&format!("shop14/{name}"))).unwrap()
}

#[test]
fn call_block_sections_are_read_as_the_operations_they_run() {
    // 01: a post that writes each operation as a labelled section after M30 and runs it with
    // `CALL BLOCK LABELn TO LABEL0`. The call was read as an unknown subprogram `BLOCK`, which may leave any
    // state: no gate after the first section measured. The sections are read now as a subprogram is, the
    // drilling section's Siemens cycle included (it leaves its caller what the cycle leaves when the program
    // calls it itself).
    let src = shop14("01_call_block_operations_after_m30.mpf");
    for profile in ["blum-tc50", "siemens-cycle978"] {
        let out = common::every_gate_transformed(profile, &[("p.mpf", &src)]);
        for (change, tool) in [("N35 M6", "T=12"), ("N48 M6", "T=13"), ("N61 M6", "T=14")] {
            let gate = common::gate_before(&out, change);
            assert!(common::gate_measures(&gate), "{profile} {change}:\n{out}");
            assert!(
                gate.iter().any(|l| l.starts_with(tool)),
                "{profile} {change}"
            );
        }
        // Nothing goes into the sections after the end.
        let end = out.find("N70 M30").unwrap();
        assert!(!out[end..].contains(";DL"), "{profile}:\n{out}");
    }
}

#[test]
fn a_subprogram_whose_only_unread_calls_are_siemens_cycles_leaves_its_caller_sure() {
    // 02: one subprogram file per operation (`SUB_CAP2 ; SPF CALL`); the drilling one calls CYCLE83 and
    // CYCLE82, which the timeline cannot read. A subprogram with such a call counted as one that leaves
    // every field unsure, so the next tool change had no gate that measured, while the same cycle called by
    // the program itself leaves the state sure (the cycles are declared SAVE).
    let main = shop14("02_operation_subprogram_files_with_drilling.mpf");
    let subs: Vec<(String, String)> = ["SUB_CAP1.SPF", "SUB_CAP2.SPF", "SUB_CAP3.SPF"]
        .iter()
        .map(|n| (n.to_string(), shop14(&format!("subs/{n}"))))
        .collect();
    let mut files = vec![("p.mpf", main.as_str())];
    files.extend(subs.iter().map(|(n, t)| (n.as_str(), t.as_str())));
    for profile in ["blum-tc50", "siemens-cycle978"] {
        let out = common::every_gate_transformed(profile, &files);
        for change in ["N34 M6", "N47 M6"] {
            let gate = common::gate_before(&out, change);
            assert!(common::gate_measures(&gate), "{profile} {change}:\n{out}");
        }
    }
}

#[test]
fn constant_cutting_speed_then_a_fixed_speed_gives_back_feed_per_revolution() {
    // 03: a mill-turn post's program opens in G94, turns under G96 and ends each turning operation with
    // G97 (which keeps feed per revolution). The timeline read G96 as no feed type: a gate after G97 gave
    // back G94, the audit found the rest of the operation at F0.3 mm/min, and the program was refused.
    let src = shop14("03_millturn_g96_then_g97_in_g94_program.mpf");
    for profile in ["lathe-setter", "blum-tc50"] {
        let out = common::every_gate_transformed(profile, &[("p.mpf", &src)]);
        let gate = common::gate_before(&out, "N35 G0 G53 X250 D0");
        assert!(common::gate_measures(&gate), "{profile}:\n{out}");
        // The modal line the gate gives back, in the turning plane.
        let back = gate
            .iter()
            .find(|l| l.starts_with("G18 ") && l.contains(" G90"))
            .unwrap();
        assert!(
            back.contains("G95") && !back.contains("G94"),
            "{profile}: {back}"
        );
    }
}

#[test]
fn the_high_speed_settings_call_between_a_retract_and_the_next_rapid_keeps_the_place() {
    // 04: the post calls CYCLE832 at the start of every operation, also between two operations of one tool
    // (after the retract, before the rapid to the next start). The call ended the retract's place: no gate
    // between the two operations. CYCLE832 moves nothing.
    let src = shop14("04_cycle832_at_each_operation_same_tool.mpf");
    for profile in common::MILLING_PROFILES {
        let out = common::every_gate_transformed(profile, &[("p.mpf", &src)]);
        let gate = common::gate_before(&out, "N40 G90 G0 X55 Y25");
        assert!(common::gate_measures(&gate), "{profile}:\n{out}");
    }
}

#[test]
fn back_to_the_top_plane_with_the_rotary_axes_turned_home_is_a_place_again() {
    // 05: after a side face under a swivel, the post retracts in machine coordinates (`G0 SUPA Z0 D0`),
    // deselects the swivel without moving (`CYCLE800(…,0)`) and swivels to the untilted plane with the rotary
    // axes turning (`CYCLE800(…,0,0,0,…,-1)`), selects D1 and goes on on top. The rotary axes were taken
    // as turned for the rest of the program, and neither the retract in machine coordinates nor the
    // CYCLE800 calls kept a place for the rapid after them: no gate measured after the first swivel.
    let src = shop14("05_swivel_side_then_back_to_top_plane.mpf");
    for profile in ["blum-tc50", "siemens-cycle978"] {
        let out = common::every_gate_transformed(profile, &[("p.mpf", &src)]);
        let top = common::gate_before(&out, "N51 G90 G0 X60 Y35");
        assert!(common::gate_measures(&top), "{profile}:\n{out}");
        // Under the swivel, nothing.
        assert!(common::gate_before(&out, "N38 G90 G0 X20 Y10").is_empty());
    }
}

#[test]
fn after_a_drilling_cycle_the_places_of_the_same_tool_measure_unless_the_cycle_left_the_spindle() {
    // 07 (F8): two drilling operations with one drill (`MCALL CYCLE81`, then `MCALL CYCLE83`), two tapping
    // operations with one tap (`MCALL CYCLE84`), then a pocket. Any Siemens cycle kept every place up to
    // the next tool change from measuring. The drilling cycles are declared SAVE and leave only what they
    // program themselves: CYCLE81 nothing, so the rapid to the second drilling operation measures; CYCLE84
    // ends with the spindle as its SDAC says, so the rapid to the second row of taps does not (its gate
    // would give back the speed and direction from before the cycle), while the gate before the pocket's
    // tool change does: it gives the spindle nothing back, the change stops it.
    let src = shop14("07_same_tool_drilling_operations_then_tapping.mpf");
    for profile in ["blum-tc50", "siemens-cycle978"] {
        let out = common::every_gate_transformed(profile, &[("p.mpf", &src)]);
        let second_drilling = common::gate_before(&out, "N46 G0 X20 Y60");
        assert!(common::gate_measures(&second_drilling), "{profile}:\n{out}");
        let second_row = common::gate_before(&out, "N80 G0 X20 Y60");
        assert!(!common::gate_measures(&second_row), "{profile}:\n{out}");
        let pocket = common::gate_before(&out, "N94 M6");
        assert!(common::gate_measures(&pocket), "{profile}:\n{out}");
        assert!(
            !pocket.iter().any(|l| l.split_whitespace().any(|w| w == "M3"
                || w == "M4"
                || w.starts_with('S') && w[1..].starts_with(|c: char| c.is_ascii_digit()))),
            "{profile}: {pocket:#?}"
        );
    }
}

#[test]
fn plan_says_why_a_gate_cannot_measure_and_names_the_call() {
    // fixtures/shop/04 taps a bolt circle under `MCALL CYCLE84` and stops the spindle after it: the gate
    // there cannot measure, the tap may have left another speed. `plan` says so beside the table, naming
    // the cycle and the field, and the JSON carries the same reason; gates that can measure carry none.
    let path = common::fixture("shop/04_mastercam_drill_g55.mpf");
    let model = common::fixture("omm/model.toml");
    let plan = |format: &str| {
        common::stdout(&common::run(&[
            "plan", &path, "--model", &model, "--format", format,
        ]))
    };
    let human = plan("human");
    let why = human
        .lines()
        .skip_while(|l| *l != "gates that cannot measure:")
        .find(|l| l.contains("(line 37)"))
        .unwrap_or_else(|| panic!("{human}"));
    assert!(
        why.contains("the call CYCLE84 (line 34) may leave the spindle speed (S)"),
        "{why}"
    );
    let json: serde_json::Value = serde_json::from_str(&plan("json")).unwrap();
    let gates = json["gates"].as_array().unwrap();
    for gate in gates {
        assert_eq!(
            gate.get("cannot_measure").is_some(),
            gate["can_measure"] == false,
            "{gate}"
        );
    }
    assert!(gates.iter().any(|g| {
        g["cannot_measure"]
            .as_str()
            .is_some_and(|w| w.contains("CYCLE84 (line 34)"))
    }));
}
