//! Thread cutting (`G33`) and tapping (`G331`/`G332`, `G63`) are cuts, and no inserted block goes inside
//! them: a gate between a tapping-in and its tapping-out, or between chained thread passes, would retract
//! the tool or stop the spindle with the tap in the hole (docs/safety.md, "Threads and tapping"). Each case
//! through the binary, on the emitted program.

mod common;

/// `prog` transformed with the builtin `profile`, as planned or measuring at every gate: the output.
fn transformed(prog: &str, profile: &str, every: bool) -> String {
    if every {
        let files = [
            ("p.mpf", prog),
            ("every.toml", &common::measuring_builtin(profile)),
        ];
        common::transformed_in(&files, "p.mpf", "every.toml")
    } else {
        common::transformed_in(&[("p.mpf", prog)], "p.mpf", profile)
    }
}

fn inserted(line: &str) -> bool {
    line.ends_with(";DL")
}

/// The program's own lines (not inserted) holding motion code `g` as a word.
fn has_g(line: &str, g: &str) -> bool {
    !inserted(line) && line.split_whitespace().any(|w| w == g)
}

/// Panics when an inserted line lies between a program line with `from` and the next program line with
/// `to`; returns how many such stretches there were.
fn nothing_between(out: &str, from: &str, to: &str) -> usize {
    let lines: Vec<&str> = out.lines().collect();
    let mut found = 0;
    for (k, l) in lines.iter().enumerate() {
        if !has_g(l, from) {
            continue;
        }
        let end = lines[k + 1..]
            .iter()
            .position(|l| has_g(l, to))
            .map(|p| k + 1 + p)
            .unwrap_or_else(|| panic!("no {to} after line {l}"));
        let inside: Vec<&&str> = lines[k + 1..end].iter().filter(|l| inserted(l)).collect();
        assert!(
            inside.is_empty(),
            "inserted blocks between `{l}` and `{}`:\n{}",
            lines[end],
            inside
                .iter()
                .map(|l| l.to_string())
                .collect::<Vec<_>>()
                .join("\n")
        );
        found += 1;
    }
    found
}

/// The line index of the reference measurement's header and of the first program line with `g`.
fn reference_and_first(out: &str, g: &str) -> (usize, usize) {
    let lines: Vec<&str> = out.lines().collect();
    let reference = lines
        .iter()
        .position(|l| inserted(l) && l.contains("reference measurement"))
        .expect("a reference measurement");
    let first = lines.iter().position(|l| has_g(l, g)).expect(g);
    (reference, first)
}

/// Rigid tapping without `SPOS` (a machine that switches the spindle into position control itself), a
/// pass boundary at the bottom of the first tap and a long dwell at the bottom of the second. On main the
/// tool setter's gate 2 ran between `N70 G331` and `N80 G332`: a retract along Z with the tap in the hole.
const TAP_ONLY: &str = "\
N10 G17 G90 G94 G71 G40 G54
N20 T=\"GWB_M10\" M6
N30 D1
N40 S400 M3
N50 G0 X30 Y0 Z50
N60 Z5
N70 G331 Z-18 K1.5 S400
; PASS 2 bottom of the thread
N80 G332 Z5 K1.5
N90 G0 Z50
N100 X-30
N110 Z5
N120 G331 Z-18 K1.5 S400
N130 G4 F30
N140 G332 Z5 K1.5
N150 G0 Z50
N160 M5
N170 M30
";

#[test]
fn nothing_is_inserted_between_a_tapping_in_and_its_tapping_out() {
    for profile in ["tool-setter", "grinder-gauge"] {
        for every in [false, true] {
            let out = transformed(TAP_ONLY, profile, every);
            assert_eq!(nothing_between(&out, "G331", "G332"), 2, "{profile}");
        }
    }
}

#[test]
fn the_reference_goes_before_the_first_tap_when_tapping_is_the_first_cut() {
    for profile in ["tool-setter", "grinder-gauge"] {
        let out = transformed(TAP_ONLY, profile, false);
        let (reference, first) = reference_and_first(&out, "G331");
        assert!(reference < first, "{profile}:\n{out}");
    }
}

/// Drilling, then a tool change to the tap, which cuts without `SPOS` under `M3`; a tool change to a
/// chamfer tool follows the tapping right after the tapping-out, and a pass boundary lies inside the
/// second tap.
const DRILL_THEN_TAP: &str = "\
N10 G17 G90 G94 G71 G40 G54
N20 T=\"BOHRER_D8_5\" M6
N30 D1
N40 S2200 M3 M8
N50 G0 X30 Y0 Z50
N60 Z2
N70 G1 Z-22 F250
N80 G0 Z50
N90 X-30
N100 Z2
N110 G1 Z-22
N120 G0 Z50 M9
N130 T=\"GWB_M10\" M6
N140 D1
N150 S400 M3
N160 G0 X30 Y0 Z50
N170 Z5
N180 G331 Z-18 K1.5 S400
N190 G332 Z5 K1.5
N200 G0 X-30
N210 G331 Z-18 K1.5 S400
; PASS 3
N220 G332 Z5 K1.5
N230 T=\"FASER_D16\" M6
N240 D1
N250 S3000 M3
N260 G0 X30 Y0 Z50
N270 Z2
N280 G1 Z-1 F300
N290 G0 Z50
N300 M5
N310 M30
";

#[test]
fn a_tap_after_drilling_gets_no_gate_inside_it_with_any_profile() {
    for profile in ["tool-setter", "grinder-gauge", "blum-tc50"] {
        for every in [false, true] {
            let out = transformed(DRILL_THEN_TAP, profile, every);
            assert_eq!(nothing_between(&out, "G331", "G332"), 2, "{profile}");
            // No gate right after the tapping-out either, where G332 is still the modal motion: a gate
            // there would give back G332.
            let lines: Vec<&str> = out.lines().collect();
            for (k, l) in lines.iter().enumerate() {
                if has_g(l, "G332") {
                    assert!(
                        !inserted(lines[k + 1]),
                        "{profile}: after {l}: {}",
                        lines[k + 1]
                    );
                }
            }
            assert!(
                !out.lines()
                    .any(|l| inserted(l) && (l.contains("G331") || l.contains("G332"))),
                "{profile}: a gate gives a tapping motion back"
            );
        }
    }
}

/// A lathe thread cut straight with `G33` (no cycle): each pass a thread with a chained run-out
/// (`G33 X… Z… K…` right after it), a pass boundary between the two, a long dwell after the retract.
const LATHE_THREAD: &str = "\
N10 G18 G90 G95 G71 DIAMON G54
N20 T=\"GEWINDE_60GRD\" D1
N30 G97 S900 M3
N40 G0 X100 Z100
N50 X26 Z5
N60 X23.4
N70 G33 Z-30 K1.5
; PASS 2 run-out
N80 G33 X26 Z-32 K1.5
N90 G0 X100
N100 Z5
N110 G4 F30
N120 X26
N130 X22.9
N140 G33 Z-30 K1.5
N150 G33 X26 Z-32 K1.5
N160 G0 X100
N170 Z100
N180 M5
N190 M30
";

#[test]
fn nothing_is_inserted_inside_a_chained_lathe_thread() {
    for every in [false, true] {
        let out = transformed(LATHE_THREAD, "lathe-setter", every);
        let lines: Vec<&str> = out.lines().collect();
        // From each thread pass to the first program line that is no thread pass (comments between
        // chained passes belong to the chain): no inserted line.
        let mut chains = 0;
        let mut in_chain = false;
        for l in &lines {
            if has_g(l, "G33") {
                chains += usize::from(!in_chain);
                in_chain = true;
            } else if in_chain {
                assert!(!inserted(l), "inserted inside a thread: `{l}`:\n{out}");
                in_chain = l.trim_start().starts_with(';');
            }
        }
        assert_eq!(chains, 2);
        let (reference, first) = reference_and_first(&out, "G33");
        assert!(reference < first, "{out}");
    }
}

/// Tapping with a compensating chuck (`G63`): in with M3, out with M4, F the feed.
#[test]
fn nothing_is_inserted_between_g63_tapping_in_and_out() {
    let prog = "\
N10 G17 G90 G94 G71 G40 G54
N20 T=\"GWB_M8_AUSGLEICH\" M6
N30 D1
N40 S300 M3
N50 G0 X30 Y0 Z50
N60 Z5
N70 G63 Z-15 F375 S300 M3
; PASS 2
N80 G63 Z5 M4
N90 G0 Z50
N100 M5
N110 M30
";
    for profile in ["tool-setter", "grinder-gauge"] {
        for every in [false, true] {
            let out = transformed(prog, profile, every);
            let lines: Vec<&str> = out.lines().collect();
            let a = lines.iter().position(|l| l.starts_with("N70")).unwrap();
            let b = lines.iter().position(|l| l.starts_with("N90")).unwrap();
            assert!(
                !lines[a..b].iter().any(|l| inserted(l)),
                "{profile}:\n{}",
                lines[a..b].join("\n")
            );
            let (reference, first) = reference_and_first(&out, "G63");
            assert!(reference < first, "{profile}");
        }
    }
}

/// The dry run runs G331 / G332 and G33 (the axis at lead × speed, the spindle positioned after rigid
/// tapping): `transform` audits these programs to their end, with every gate measuring.
#[test]
fn threads_and_taps_are_audited_to_the_end() {
    for (prog, profile) in [
        (TAP_ONLY, "tool-setter"),
        (DRILL_THEN_TAP, "blum-tc50"),
        (LATHE_THREAD, "lathe-setter"),
    ] {
        let files = [
            ("p.mpf", prog),
            ("every.toml", &common::measuring_builtin(profile)),
        ];
        let (o, _dir) = common::transform_in(&files, "p.mpf", "every.toml");
        let err = common::stderr(&o);
        assert!(o.status.success(), "{profile}: {err}");
        assert!(!err.contains("audit incomplete"), "{profile}: {err}");
    }
}

/// The audit's own check: blocks inserted between a tapping-in and its tapping-out (what driftloop wrote
/// before thread moves were cuts) are a `gate-in-thread` finding, once per gate.
#[test]
fn the_audit_finds_blocks_inserted_inside_a_tap() {
    let transformed = "; driftloop-omm (by hand) ;DL\n".to_string()
        + &TAP_ONLY.replace(
            "; PASS 2 bottom of the thread\n",
            "; PASS 2 bottom of the thread\nSTOPRE ;DL\nG0 G90 Z100 ;DL\nG0 Z-18 ;DL\n",
        );
    let profile = common::stdout(&common::run(&["profiles", "tool-setter"]));
    let files = [
        ("o.mpf", TAP_ONLY),
        ("t.mpf", transformed.as_str()),
        ("ts.toml", profile.as_str()),
    ];
    // `driftloop run --audit TRANSFORMED --original o.mpf`: what it prints.
    let audit = |transformed: &str| {
        let args = [
            "run",
            "--audit",
            transformed,
            "--original",
            "o.mpf",
            "--profile",
            "ts.toml",
        ];
        let (o, _dir) = common::run_in(&files, &args);
        String::from_utf8_lossy(&o.stdout).to_string() + &common::stderr(&o)
    };
    let out = audit("t.mpf");
    assert!(out.contains("gate-in-thread 1"), "{out}");
    assert!(out.contains("t.mpf:10: gate-in-thread"), "{out}");
    // The original audited against itself: no finding.
    let out = audit("o.mpf");
    assert!(!out.contains("gate-in-thread"), "{out}");
}
