//! Hazards QA round 4 found in the blocks `transform` inserted into programs with tool changes (the
//! realistic set in fixtures/shop4, mostly for the default spindle-probe profile), each as a minimal
//! program through the binary. `transform` audits its output as planned and with every gate measuring on
//! shifted work offsets, and writes nothing on a finding: each case must be written and carry the right
//! blocks.

mod common;

/// `prog` transformed with each of `tool-setter` and `blum-tc50` measuring at every gate: the profile, the
/// output and the inserted lines between the original lines starting with `from` and `to`.
fn every_gate_between(
    prog: &str,
    from: &str,
    to: &str,
) -> Vec<(&'static str, String, Vec<String>)> {
    ["tool-setter", "blum-tc50"]
        .into_iter()
        .map(|profile| {
            let files = [
                ("p.mpf", prog),
                ("every.toml", &common::measuring_builtin(profile)),
            ];
            let out = common::transformed_in(&files, "p.mpf", "every.toml");
            let gate = common::lines_between(&out, from, to)
                .into_iter()
                .filter(|l| l.ends_with(";DL"))
                .map(String::from)
                .collect();
            (profile, out, gate)
        })
        .collect()
}

/// Whether an NC line holds the word M3 (not M30).
fn starts_spindle(line: &str) -> bool {
    line.split_whitespace().any(|w| w == "M3")
}

#[test]
fn a_gate_after_a_tool_change_does_not_start_the_new_tool_at_the_last_ones_speed() {
    // M6 stops the spindle; the program starts the face mill at 2000 rpm. A gate between gave back the
    // small tool's S12000 M3 (a warm-up here): the face mill, rated far lower, spun at 12000.
    let prog = "\
G17 G90 G94 G71
G54
T=\"EM_D6\" M6
D1
S12000 M3 M8
G4 F120
G0 Z50
T=\"FM_D80\" M6
D1 ; PASS 2
S2000 M3
G0 X-50 Y0 Z5
G1 Z-0.5 F500
G1 X150 F1200
G0 Z50
M30
";
    for (profile, out, gate) in every_gate_between(prog, "T=\"FM_D80\" M6", "S2000 M3") {
        assert!(
            gate.iter().any(|l| l.starts_with("G0 G90 Z=R")),
            "{profile}: a measuring gate\n{out}"
        );
        assert!(
            !gate.iter().any(|l| starts_spindle(l)),
            "{profile}: {gate:#?}"
        );
    }
}

#[test]
fn no_gate_measures_while_the_spindle_is_positioned_for_a_back_boring_bar() {
    // The bar is oriented (SPOS), shifted and moved through a bore narrower than its sweep. A gate at the
    // pass marked between measured and gave back the spindle turning (and lost the angle): the bar went
    // through the bore spinning.
    let prog = "\
G17 G90 G94 G71
G54
T=\"BACKBORE_D30\" M6
D1
S800 M3 M8
G0 X0 Y0 Z20
G1 Z-1 F100
G0 Z20
SPOS=0
G0 X-3 ; PASS 2
G0 Z-42
G0 X0
M3 S800
G1 Z-38 F50
G0 Z-42
SPOS=0
G0 X-3
G0 Z20
G0 X0
M9 M5
M30
";
    for (profile, out, gate) in every_gate_between(prog, "SPOS=0", "G0 Z-42") {
        assert!(
            !gate.is_empty(),
            "{profile}: the pass start keeps its prediction update\n{out}"
        );
        assert!(
            !gate
                .iter()
                .any(|l| l.starts_with("G0 G90 Z=R") || starts_spindle(l)),
            "{profile}: {gate:#?}"
        );
    }
}

#[test]
fn the_zero_of_a_spindle_probe_is_not_measured_where_d0_is_active() {
    // The post retracts with `SUPA Z-0.1 D0` before every tool change and swivels its first operation:
    // the only pass starts carried D0, and the zero went there. With D0 the saved height is the
    // spindle's: the probe travelled with its tip there, a probe length above the top. It goes after the
    // tool change and D1 instead, where the tool is known.
    let prog = "\
G17 G90 G71 G40
G0 SUPA Z-0.1 D0
T=\"EM_D16\"
M6
T=\"BALL_D8\"
D1
G54
CYCLE800(1,\"TABLE\",200000,57,0,0,0,0,-30,0,0,0,0,1,100,1)
S9000 M3 M8
G0 X-10 Y0 Z60
G1 Z-3 F2500
G1 X40 F4800
G0 Z60
M5 M9
CYCLE800()
G0 B0 C0
G0 SUPA Z-0.1 D0
M6
T=\"EM_D16\"
D1
G54
S8000 M3 M8
G0 X30 Y10 Z50
G1 Z-1.2 F1500
G1 X55
G0 Z50
M5 M9
G0 SUPA Z-0.1 D0
M30
";
    let out = common::transformed_in(&[("p.mpf", prog)], "p.mpf", "blum-tc50");
    let lines: Vec<&str> = out.lines().collect();
    let zero = lines
        .iter()
        .position(|l| l.starts_with("; driftloop stage 1"))
        .unwrap();
    let own = |k: usize| {
        lines[..k]
            .iter()
            .rev()
            .find(|l| !l.ends_with(";DL"))
            .copied()
    };
    assert_eq!(own(zero), Some("G54"), "{out}");
    assert!(
        lines[..zero].iter().filter(|l| **l == "D1").count() == 2,
        "{out}"
    );
}

/// A face milled in steps by a WHILE loop the timeline cannot count (`R22` to `R20`): after it the feed is
/// the body's or, had it not run, the one before it (F250). `after` follows the loop.
fn stepdown(after: &str) -> String {
    format!(
        "G17 G90 G94 G71 G40\nG54\nT=\"FM_D80\" M6\nD1\nS1600 M3 M8 F250\nR20=-6 R21=1.2 R22=0\n\
         WHILE R22>R20\nR22=R22-R21\nG0 X-50 Y0 Z5\nG1 Z=R22 F400\nG1 X250 F1800\nG0 Z5\nENDWHILE\n\
         G0 Z100\nM9 M5\n{after}M30\n"
    )
}

#[test]
fn a_feed_the_program_sets_again_before_it_cuts_does_not_cost_the_measurement() {
    // shop4/14: the program sets F300 on its next cut, so the feed left by the loop is never used; the
    // places at its M5 and the tool change measured nothing (the state "varies"). They measure now, and
    // their gates give no feed back.
    let prog = stepdown(
        "T=\"EM_D12\" M6\nD1\nS6000 M3 M8\nG0 X-7 Y-7 Z5\nG1 Z-7 F300\nG1 X207 F1500\nG0 Z100\n",
    );
    for profile in ["blum-tc50", "tool-setter"] {
        let out = common::every_gate_transformed(profile, &[("p.mpf", &prog)]);
        let gate = common::gate_before(&out, "M9 M5");
        assert!(
            common::gate_measures(&gate),
            "{profile}:\n{}",
            gate.join("\n")
        );
        let feed = |l: &&str| {
            l.split_whitespace()
                .any(|w| w.starts_with('F') && w[1..].starts_with(|c: char| c.is_ascii_digit()))
        };
        assert!(
            !gate.iter().any(feed),
            "{profile}: a feed given back:\n{}",
            gate.join("\n")
        );
    }
}

#[test]
fn a_feed_the_program_uses_after_the_loop_still_keeps_the_place_from_measuring() {
    // The next cut has no F: it runs at whichever feed the loop left. No gate can give that back.
    let reads = stepdown("G0 X-7 Y-7 Z5\nG1 Z-7\nG0 Z100\n");
    // A label between: a jump may come there with yet another feed.
    let label = stepdown("BACK:\nG0 X-7 Y-7 Z5\nG1 Z-7 F300\nG0 Z100\n");
    for prog in [reads, label] {
        let out = common::every_gate_transformed("tool-setter", &[("p.mpf", &prog)]);
        let gate = common::gate_before(&out, "M9 M5");
        assert!(!common::gate_measures(&gate), "{prog}\n{}", gate.join("\n"));
    }
}
