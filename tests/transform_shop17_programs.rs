//! Predefined procedures that CAM posts and shop programmers write in part programs (fixtures/shop17,
//! programs written for this repository in today's post output forms; its README lists the outcomes).
//! Until this round the timeline read `SOFTA(X,Y,Z)`, `BRISKA(…)`, `DRIVEA(…)`, `JERKA(…)`, `WAITP(…)`,
//! `TOFFON(…)`/`TOFFOF(…)` and the bare `COMPSURF` as calls of subprograms it cannot see into, after which
//! no moving gate measured to the program's end. Now the acceleration and wait procedures and COMPSURF are
//! no calls, and the online tool length offset is followed as the programmed offsets are: no spindle probe
//! or tool setter measures while it is on. Each through the binary, which audits its output.

mod common;

/// `fixtures/shop17/FILE` transformed with the builtin `profile` measuring at every gate that can.
fn every_gate(profile: &str, file: &str) -> String {
    common::set_every_gate("shop17", profile, file, &[])
}

/// `file` with every gate measuring, per milling profile: asserts the program's blocks before which a gate
/// measures (`probe` for the spindle probes, `setter` for the tool setter) and returns each output.
fn measures_at(file: &str, probe: &[&str], setter: &[&str]) -> Vec<(&'static str, String)> {
    common::MILLING_PROFILES
        .into_iter()
        .map(|profile| {
            let out = every_gate(profile, file);
            let expected = if profile == "tool-setter" {
                setter
            } else {
                probe
            };
            assert_eq!(common::measured_before(&out), expected, "{profile}:\n{out}");
            (profile, out)
        })
        .collect()
}

/// [`measures_at`] with `(probe, setter)`, and the gate before the block that starts with `at` writes
/// each of `words` with every milling profile.
fn measures_at_giving_back(file: &str, places: (&[&str], &[&str]), at: &str, words: &[&str]) {
    for (profile, out) in measures_at(file, places.0, places.1) {
        let gate = common::gate_before(&out, at);
        for word in words {
            assert!(writes(&gate, word), "{profile} {word}: {gate:#?}");
        }
    }
}

/// Whether the gate `lines` writes the word `word` (`S6500`, `M8`) in one of its blocks.
fn writes(lines: &[&str], word: &str) -> bool {
    lines
        .iter()
        .any(|l| l.split_whitespace().any(|w| w == word))
}

#[test]
fn acceleration_per_axis_is_no_call_and_the_same_tool_measures_between_operations() {
    // 01: one end mill roughs under `BRISKA(X,Y,Z)`/`DRIVEA(Z)` and finishes under `SOFTA(X,Y,Z)` and
    // `JERKA(X,Y,Z)`, then a drill. Before, BRISKA (N22) was read as the program's first cut, a call
    // driftloop cannot read: the spindle probe refused the program, the tool setter measured only the
    // zero. Now the zero goes after the setup (N28), the rapid to the finishing pass (N54) measures and
    // gives back `S6500 M3 M8`, and so do the drill's change (N74) and, for a spindle probe, the end.
    measures_at_giving_back(
        "01_axis_dynamics_between_operations.mpf",
        (&["N28", "N54", "N74", "N90"], &["N28", "N54", "N74"]),
        "N54 G0 X18 Y18",
        &["S6500", "M3", "M8"],
    );
}

#[test]
fn the_online_tool_offset_keeps_probe_and_setter_from_measuring_until_toffof() {
    // 02: `TOFFON(Z,0.2)` (N22) after the zero, a tool change with the offset still on (N40), `TOFFOF(Z)`
    // (N56), then a chamfer tool. A spindle probe's change carries the offset and a tool setter reads the
    // tool with it: from N22 to N56 neither measures. After TOFFOF the chamfer's change (N60) and the end
    // (N76) measure with the spindle probe; before, TOFFON and TOFFOF were calls and nothing after them
    // measured. The gauge, which moves nothing and reads no tool, measures at every tool change.
    // After TOFFOF only other tools than the zero's cut: a setter compares the zero's tool only.
    measures_at(
        "02_toffon_left_on_across_tool_change.mpf",
        &["N20", "N60", "N76"],
        &["N20"],
    );
    let out = every_gate("grinder-gauge", "02_toffon_left_on_across_tool_change.mpf");
    assert_eq!(
        common::measured_before(&out),
        ["N20", "N40", "N60", "N76"],
        "{out}"
    );
}

#[test]
fn the_surface_compressor_is_a_predefined_command() {
    // 04: `COMPSURF` with `G645`, `SOFT` and `FFWON` in a post's high-speed block. Before, COMPSURF was
    // read as a subprogram: no place after it measured. Now the rapid between the two finishing passes
    // (N44) and the end mill's change (N60) measure as after COMPCAD.
    measures_at_giving_back(
        "04_compsurf_g645_hsc.mpf",
        (&["N20", "N44", "N60", "N76"], &["N20", "N44", "N60"]),
        "N44 G0 X0 Y5",
        &["S14000", "M3", "M7"],
    );
}

#[test]
fn waiting_for_a_positioning_axis_is_no_call_and_the_turned_axis_is_followed() {
    // 05: the A axis indexed by `POS[A]=90` and `WAITP(A)` between two cuts of one tool, then back by
    // `POS[A]=0`. Before, WAITP was a call and no place after it measured. Now the drill's change (N50)
    // measures after A is home again; the rapid right after the first WAITP (N36) does not: `POS[A]=90`
    // turns A as `A90` does, a spindle probe does not measure the part turned away from where the zero
    // was taken, and a tool setter does not measure while A or B stands away from 0, which on a swivel
    // head tilts the tool (red team 5, F1; POS was not read at all; only WAITP hid it).
    measures_at(
        "05_waitp_indexed_fourth_axis.mpf",
        &["N20", "N50", "N64"],
        &["N20", "N50"],
    );
}
