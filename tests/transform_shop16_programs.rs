//! The places after a Siemens milling or turning cycle (fixtures/shop16, programs written for this
//! repository in CAM and ProgramGUIDE output forms; its README lists the outcomes). Until this round no
//! place after such a cycle measured before the next tool change; now a cycle whose end state the manuals
//! establish leaves unsure only the feed, speed or direction it programs itself (`machining_cycle_leaves`),
//! and the contour cycles that run programs they generate keep the old rule. Each through the binary,
//! which audits its output as planned and with every gate measuring.

mod common;

/// `fixtures/shop16/FILE` as `p.mpf` with the subprograms `subs` beside it, transformed with the builtin
/// `profile` measuring at every gate that can.
fn every_gate(profile: &str, file: &str, subs: &[&str]) -> String {
    common::set_every_gate("shop16", profile, file, subs)
}

/// Whether the gate `lines` writes the word `word` (`S4200`, `M8`, `F900`) in one of its blocks.
fn writes(lines: &[&str], word: &str) -> bool {
    lines
        .iter()
        .any(|l| l.split_whitespace().any(|w| w == word))
}

/// Whether the gate `lines` gives a feed back (an `F` word with a value).
fn gives_a_feed(lines: &[&str]) -> bool {
    lines.iter().any(|l| {
        l.split_whitespace().any(|w| {
            w.len() > 1 && w.starts_with('F') && w[1..].starts_with(|c: char| c.is_ascii_digit())
        })
    })
}

#[test]
fn one_tool_across_face_pocket_and_contour_measures_where_the_cycles_left_nothing_unsure() {
    // 01: one end mill runs CYCLE61 (face), POCKET3 and CYCLE72 (contour), then deburrs by hand; the
    // program never writes F before its own cut. CYCLE61 is taken to leave feed, speed and direction
    // (its parameter list was not read): the rapid after the program's `S4200 M3` (N34) measures. POCKET3
    // leaves only its feed, which the program never set: the rapid to the contour (N42) measures and gives
    // back the speed of N32. CYCLE72 is taken as CYCLE61: the rapid to the deburring (N50), before any
    // `S`/`M3`, does not. Before, none of them measured. At the drill's M6 (N70) the spindle probe measures
    // (its gate gives the spindle nothing back); the tool setter's gate there gives the spindle back, so
    // it does not any more (it gave back `S4200 M3` whatever CYCLE72 left).
    for profile in common::MILLING_PROFILES {
        let out = every_gate(
            profile,
            "01_same_tool_face_pocket_contour.mpf",
            &["CONT_PLATE.SPF"],
        );
        let expected: &[&str] = if profile == "tool-setter" {
            &["N22", "N34", "N42"]
        } else {
            &["N18", "N34", "N42", "N70"]
        };
        assert_eq!(common::measured_before(&out), expected, "{profile}:\n{out}");
        for at in ["N34 G0 X60 Y40", "N42 G0 X-15 Y-15"] {
            let gate = common::gate_before(&out, at);
            assert!(
                writes(&gate, "S4200") && writes(&gate, "M3") && writes(&gate, "M8"),
                "{profile} {at}: {gate:#?}"
            );
            assert!(!gives_a_feed(&gate), "{profile} {at}: {gate:#?}");
        }
    }
}

#[test]
fn a_pocket_then_slots_with_one_tool_measure_until_the_slots_finishing_speed() {
    // 02 (828D ProgramGUIDE form): POCKET4, then SLOT1 with the same end mill, then a chamfer by hand.
    // POCKET4 leaves its feed only: the rapid to the slots (N60) measures. SLOT1 finishes at its own speed
    // SSF: no place measures until the program writes `S6000 M3` (N80); the spindle stop at the end (N115)
    // then measures and gives back the chamfer's `S6000 M3` and `F900`. Before, only the zero measured.
    for profile in common::MILLING_PROFILES {
        let out = every_gate(profile, "02_pocket_then_slot_same_tool.mpf", &[]);
        let zero = if profile == "tool-setter" {
            "N35"
        } else {
            "N25"
        };
        assert_eq!(
            common::measured_before(&out),
            [zero, "N60", "N115"],
            "{profile}:\n{out}"
        );
        let end = common::gate_before(&out, "N115 M5");
        assert!(
            writes(&end, "S6000") && writes(&end, "F900") && !writes(&end, "M8"),
            "{profile}: {end:#?}"
        );
    }
}

#[test]
fn a_lathe_roughing_then_finishing_with_cycle95_measures_at_the_next_turret_index() {
    // 03: one insert roughs (VARI=1) and finishes (VARI=5) with CYCLE95, then a grooving tool. CYCLE95
    // programs its feeds FF1…FF3 only, which the program never set: the turret index after the finishing
    // pass (N120), after the rapid out to X100 Z100, measures and gives back `G96 S280 M4` with the coolant
    // on. The speed change between roughing and finishing (N80) stays unmeasured: the spindle turns there.
    // Before, no place after the first cycle measured.
    for (profile, expected) in [
        ("lathe-setter", vec!["N40", "N120"]),
        ("tool-setter", vec!["N30", "N120", "N190"]),
    ] {
        let out = every_gate(
            profile,
            "03_lathe_cycle95_rough_then_finish.mpf",
            &["CONT_SHAFT.SPF"],
        );
        assert_eq!(common::measured_before(&out), expected, "{profile}:\n{out}");
        let index = common::gate_before(&out, "N120 T=\"GROOVE_W3\"");
        assert!(
            writes(&index, "S280") && writes(&index, "M4") && writes(&index, "M8"),
            "{profile}: {index:#?}"
        );
        assert!(!gives_a_feed(&index), "{profile}: {index:#?}");
    }
}

#[test]
fn thread_milling_measures_only_where_the_program_writes_the_spindle_again() {
    // 04: two threads with one thread mill (CYCLE90). Thread milling is taken to leave feed, speed and
    // direction: the rapid to the second thread measures after the program's `S5000 M3` (N32), the one
    // after the second thread (N40) does not.
    for profile in common::MILLING_PROFILES {
        let out = every_gate(profile, "04_thread_milling_two_threads.mpf", &[]);
        let zero = if profile == "tool-setter" {
            "N20"
        } else {
            "N16"
        };
        assert_eq!(
            common::measured_before(&out),
            [zero, "N32"],
            "{profile}:\n{out}"
        );
    }
}

#[test]
fn a_contour_pocket_keeps_the_old_rule_while_the_circular_pocket_before_it_does_not() {
    // 05: POCKET4 as a start pocket, then the contour pocket (CYCLE62 + CYCLE63) roughed and finished with
    // the same end mill, then a drill. After POCKET4 the rapid following the program's `S5600 M3` (N120)
    // measures; CYCLE63 runs a program it generates from the contour, so after it nothing measures until
    // the drill's tool change (N180 does not, though the program writes `S5600 M3` before it). Since red
    // team 5 (F2) the cycle leaves its feed, speed and direction unsure past that change too: the tool
    // setter's gate there, which gives back the spindle before the program's `M6`, no longer measures.
    for profile in common::MILLING_PROFILES {
        let out = every_gate(
            profile,
            "05_contour_pocket_kept_conservative.mpf",
            &["PCK_HOUSING.SPF"],
        );
        let expected: &[&str] = if profile == "tool-setter" {
            &["N60", "N120"]
        } else {
            &["N40", "N120", "N240", "N320"]
        };
        assert_eq!(common::measured_before(&out), expected, "{profile}:\n{out}");
    }
}
