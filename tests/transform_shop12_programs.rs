//! Lost measurements, needless refusals and hazards QA round 12 found by editing the real programs of
//! ../shared/corpus (and the shop sets) the ordinary ways an operator or another CAM post does — blank lines,
//! comments, block numbers, case, the tool by name or number, loops and subprograms around the body — and
//! comparing what `transform` makes of each edit with what it makes of the program unedited
//! (fixtures/shop12 holds the reductions; its README lists them). Each through the binary, which audits its
//! output as planned and with every gate measuring.

mod common;

/// The text of `fixtures/shop12/NAME`.
fn shop12(name: &str) -> String {
    std::fs::read_to_string(common::fixture(&format!("shop12/{name}"))).unwrap()
}

/// How many gates of `out` measure where they are due.
fn measuring_gates(out: &str) -> usize {
    out.lines().filter(|l| common::gate_measures(&[l])).count()
}

#[test]
fn a_blank_line_or_a_switch_after_the_retract_keeps_the_place_after_it() {
    // 01: the post writes a blank line after each retract, the operator a comment, a bare block number or
    // `M9` before the next approach. Each of those lines ended the retract for the timeline, so the rapid
    // after it was no place to measure: the real CAM program of the corpus lost 7 of its 29 measurements
    // to blank lines, this one all but the zero (a 31 µm change unwatched in a long roughing).
    let src = shop12("01_blank_lines_between_retract_and_approach.mpf");
    // The same program with each retract followed at once by its rapid.
    let tight: String = src
        .lines()
        .filter(|l| {
            let code = l.split(';').next().unwrap_or("").trim();
            let code = code
                .trim_start_matches(|c: char| c == 'N' || c.is_ascii_digit())
                .trim();
            !code.is_empty() && code != "M9"
        })
        .map(|l| format!("{l}\n"))
        .collect();
    for profile in ["blum-tc50", "tool-setter"] {
        let spaced = common::every_gate_transformed(profile, &[("p.mpf", &src)]);
        let tight = common::every_gate_transformed(profile, &[("p.mpf", &tight)]);
        assert_eq!(measuring_gates(&tight), 6, "{profile}:\n{tight}");
        assert_eq!(
            measuring_gates(&spaced),
            measuring_gates(&tight),
            "{profile}:\n{spaced}"
        );
        // The gate after `M9` gives the spindle back and not the coolant the program switched off.
        let gate = common::gate_before(&spaced, "N240 X200 Y-10");
        assert!(common::gate_measures(&gate), "{profile}");
        assert!(
            !gate.iter().any(|l| l.contains("M8")),
            "{}",
            gate.join("\n")
        );
    }
}

#[test]
fn the_zero_is_measured_once_before_a_loop_over_the_parts() {
    // 02: `FOR _TEIL=0 TO 3` / `TRANS X=_TEIL*100` around each part. A tool setter's zero went after the
    // TRANS, inside the loop: measured again on every part, it took the drift of the parts before as the
    // reference and started the model cold, so no later part was corrected for it. It goes before the
    // loop now (a gate inside the loop still updates and measures). The lathe setter refuses this milling
    // program.
    let src = shop12("02_part_loop_trans_per_part.mpf");
    for profile in ["blum-tc50", "tool-setter", "grinder-gauge"] {
        let out = common::every_gate_transformed(profile, &[("p.mpf", &src)]);
        let line = |text: &str| out.lines().position(|l| l.contains(text)).unwrap();
        assert!(
            line("stage 1: initial data") < line("N60 FOR"),
            "{profile}:\n{out}"
        );
        assert_eq!(
            out.matches("stage 4: reference measurement").count(),
            1,
            "{profile}"
        );
    }
}

#[test]
fn a_gate_after_g700_and_g71_gives_the_feed_back_in_the_units_in_force() {
    // F4: `F60.` under G700 is 60 inch/min; after G71 the control reads a programmed F in mm/min, so the gate
    // before the second tool change gave back F60 (60 mm/min, the next cut has no F) and the audit refused
    // the program. The feed is 1524 mm/min there.
    let prog = "G17 G90 G94 G40\nG700\nG54\nT=\"EM_D12\" M6\nD1\nS3000 M3\nG0 X1. Y1. Z1.\n\
                G1 Z-0.1 F60.\nG1 X3.\nG0 Z1.\nG71\nG0 Z100 M9\nT=\"EM_D8\" M6\nD1\nS4000 M3\n\
                G0 X60 Y60 Z5\nG1 Z-2\nG1 X90\nG0 Z100\nM30\n";
    let out = common::every_gate_transformed("blum-tc50", &[("p.mpf", prog)]);
    let gate = common::gate_before(&out, "T=\"EM_D8\" M6");
    assert!(
        gate.iter().any(|l| l.ends_with(" F1524 ;DL")),
        "{}",
        gate.join("\n")
    );
}
