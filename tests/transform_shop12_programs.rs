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
