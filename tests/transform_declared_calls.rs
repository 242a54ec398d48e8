//! Builder calls declared in the machine profile (`[calls.NAME]`, `[probe] change`): what the transform
//! then does with the programs of fixtures/shop8 and two small programs in the same dialects
//! (fixtures/declared_calls, with the test profiles of fixtures/shop8/profiles: DMG's `T="NAME"` then `TC(1)`, Burkhardt+Weber's `L706(, 5, , "1")`), each
//! through the binary. docs/profiles.md, "Builder calls"; docs/safety.md, "Declared calls".

mod common;

/// The text of fixtures/shop8/`name`.
fn shop8(name: &str) -> String {
    std::fs::read_to_string(common::fixture(&format!("shop8/{name}"))).unwrap()
}

/// A test profile of fixtures/shop8/profiles, measuring at every gate (so every gate swaps the probe).
fn every_gate(profile: &str) -> String {
    format!(
        "{}\n[log]\nmeasure_every_gate = true\n",
        shop8(&format!("profiles/{profile}"))
    )
}

/// The lines of `out` inserted by driftloop, without the marker.
fn inserted(out: &str) -> Vec<&str> {
    out.lines().filter_map(|l| l.strip_suffix(" ;DL")).collect()
}

#[test]
fn a_declared_tool_change_and_change_point_let_a_dmg_program_transform() {
    // 01 (DMG CTX): `L710` (the change point) is the first call, `T="…"` then `TC(1)` changes tools.
    // Undeclared, L710 is taken for the first cut with no tool known: refused.
    let prog = shop8("01_dmg_ctx_main_spindle_tc1.mpf");
    let (o, _) = common::transform_in(&[("p.mpf", &prog)], "p.mpf", "blum-tc50");
    assert_eq!(o.status.code(), Some(2));
    assert!(
        common::stderr(&o).contains("its first cut is a call driftloop cannot read"),
        "{}",
        common::stderr(&o)
    );
    // Declared (TC loads the preselected tool, L710 moves the axes only): the zero goes before the
    // program's own TC(1), loads the probe the machine's way, and selects the program's tool again for
    // that TC(1) to load.
    let profile = shop8("profiles/dmg.toml");
    let out = common::transformed_in(
        &[("p.mpf", &prog), ("dmg.toml", &profile)],
        "p.mpf",
        "dmg.toml",
    );
    let zero = &out[..out.find("N80 TC(1)").unwrap()];
    let lines = inserted(zero);
    let probe_in = lines.iter().position(|l| *l == "T=\"BLUM_TC50\"").unwrap();
    assert_eq!(lines[probe_in + 1], "TC(1)", "{zero}");
    assert!(!lines.iter().any(|l| l.contains("M6")), "{zero}");
    assert!(lines.contains(&"T=\"SCHRUPP_80_R08\""), "{zero}");
    // With the tool change declared but not the change point, L710 may still change anything.
    let no_l710 = profile.replace("[calls.L710]\nleaves = [\"position\"]\n", "");
    assert_ne!(no_l710, profile);
    let (o, _) = common::transform_in(
        &[("p.mpf", &prog), ("dmg.toml", &no_l710)],
        "p.mpf",
        "dmg.toml",
    );
    assert_eq!(o.status.code(), Some(2), "{}", common::stderr(&o));
}

/// `fixtures/declared_calls/<program>`: refused with the builtin profile, and transformed with the
/// declarations of `profile` measuring at every gate, its audit run to the end (the declared change a tool
/// change in both runs). The program, the profile's text and the output.
fn declared(program: &str, profile: &str) -> (String, String, String) {
    let prog =
        std::fs::read_to_string(common::fixture(&format!("declared_calls/{program}"))).unwrap();
    let (o, _) = common::transform_in(&[("p.mpf", &prog)], "p.mpf", "blum-tc50");
    assert_eq!(
        o.status.code(),
        Some(2),
        "undeclared: {}",
        common::stderr(&o)
    );
    let text = every_gate(profile);
    let (o, dir) = common::transform_in(&[("p.mpf", &prog), (profile, &text)], "p.mpf", profile);
    let err = common::stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("audit incomplete"), "{err}");
    let out = std::fs::read_to_string(dir.path().join("out.mpf")).unwrap();
    (prog, text, out)
}

#[test]
fn a_gate_swaps_the_probe_with_the_declared_tc1_and_the_audit_passes() {
    let (prog, profile, out) = declared("dmu_tc1.mpf", "dmg.toml");
    let lines = inserted(&out);
    assert!(!lines.iter().any(|l| l.contains("M6")), "{out}");
    // Every probe load is T= and TC(1); a gate inside the first pass gives the face mill back alike.
    let loads: Vec<usize> = (0..lines.len())
        .filter(|&k| lines[k] == "T=\"BLUM_TC50\"")
        .collect();
    assert!(loads.len() >= 3, "{out}");
    for k in loads {
        assert_eq!(lines[k + 1], "TC(1)", "{out}");
    }
    let back = lines
        .windows(2)
        .filter(|w| w == &["T=\"FM_D63\"", "TC(1)"])
        .count();
    assert!(back >= 1, "{out}");
    let again = common::transformed_in(
        &[("p.mpf", &prog), ("dmg.toml", &profile)],
        "p.mpf",
        "dmg.toml",
    );
    assert_eq!(again, out);
    insta::assert_snapshot!("dmu_tc1_dmg_every_gate", out);
}

#[test]
fn a_gate_swaps_the_probe_with_a_call_that_takes_the_tool_as_an_argument() {
    let (_, _, out) = declared("mcx_l706.mpf", "bw.toml");
    let lines = inserted(&out);
    assert!(lines.contains(&"L706(, \"BLUM_TC50\", , \"1\")"), "{out}");
    // The tool the program's L706 loaded, given back by its argument.
    assert!(lines.contains(&"L706(, 1, , \"1\")"), "{out}");
    assert!(!lines.iter().any(|l| l.contains("M6")), "{out}");
}

#[test]
fn a_tool_change_declared_with_an_argument_a_call_does_not_give_is_refused_naming_the_line() {
    let prog = std::fs::read_to_string(common::fixture("declared_calls/mcx_l706.mpf"))
        .unwrap()
        .replace("L706(, 2, , \"1\")", "L706(, , , \"1\")");
    let profile = shop8("profiles/bw.toml");
    let (o, dir) = common::transform_in(
        &[("p.mpf", &prog), ("bw.toml", &profile)],
        "p.mpf",
        "bw.toml",
    );
    assert_eq!(o.status.code(), Some(2));
    let err = common::stderr(&o);
    assert!(
        err.contains("line 19: L706 is declared to load the tool its argument 2 gives"),
        "{err}"
    );
    assert!(!dir.path().join("out.mpf").exists());
}

#[test]
fn a_datum_cycle_declared_to_write_frames_keeps_the_zero_after_it_and_refuses_one_after_the_zero() {
    // 07 (STAMA): NPL writes the datum; undeclared it leaves everything unsure ("the call NPL … may
    // leave"), declared with frames it is a frame write of the program's before the zero.
    let prog = shop8("07_stama_turnmill_zyk_start_npl_l6.mpf");
    let subs = std::fs::read_to_string(common::fixture("shop8/subs/L6.SPF")).unwrap();
    let profile = shop8("profiles/stama.toml");
    let files = [
        ("p.mpf", prog.as_str()),
        ("L6.SPF", &subs),
        ("stama.toml", &profile),
    ];
    let (o, dir) = common::transform_in(&files, "p.mpf", "stama.toml");
    let err = common::stderr(&o);
    assert!(!err.contains("the call NPL"), "{err}");
    // The zero goes after NPL and G55, at the first tool's change (its L6), before the program's own TRANS
    // that the first cut runs under.
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("audit incomplete"), "{err}");
    let out = std::fs::read_to_string(dir.path().join("out.mpf")).unwrap();
    let at = |text: &str| out.find(text).unwrap_or_else(|| panic!("{text}: {out}"));
    assert!(at("N50 G55") < at("stage 4: reference"), "{out}");
    assert!(at("stage 4: reference") < at("N90 L6"), "{out}");
    assert!(at("N90 L6") < at("N140 TRANS"), "{out}");
    // A datum cycle declared so before the first cut lets the zero go after it; one after the zero is
    // refused as a frame write of the program's would be (the gates' correction and the cycle's datum
    // would overwrite each other).
    let dmu = std::fs::read_to_string(common::fixture("declared_calls/dmu_tc1.mpf"))
        .unwrap()
        .replace("G54\n", "NPL(1)\nG54\n");
    let with_npl = format!(
        "{}\n[calls.NPL]\nleaves = [\"frames\", \"offset\"]\n",
        shop8("profiles/dmg.toml")
    );
    let files = [("p.mpf", dmu.as_str()), ("dmg.toml", &with_npl)];
    let out = common::transformed_in(&files, "p.mpf", "dmg.toml");
    let npl = out.find("NPL(1)\n").unwrap();
    let zero = out.find("stage 4: reference").unwrap();
    assert!(npl < zero, "{out}");
    let twice = dmu.replace("L711\nT=\"DR_D14\"", "L711\nNPL(1)\nT=\"DR_D14\"");
    assert_ne!(twice, dmu);
    let files = [("p.mpf", twice.as_str()), ("dmg.toml", &with_npl)];
    let (o, _) = common::transform_in(&files, "p.mpf", "dmg.toml");
    assert_eq!(o.status.code(), Some(2));
    let err = common::stderr(&o);
    let lines: Vec<&str> = twice.lines().collect();
    let line = lines.iter().rposition(|l| *l == "NPL(1)").unwrap() + 1;
    assert!(
        err.contains(&format!("writes a frame itself at line {line}")),
        "{err}"
    );
}

#[test]
fn declarations_that_do_not_fit_are_refused_pointing_into_the_profile() {
    let dmg = shop8("profiles/dmg.toml");
    for (what, from, to, expected) in [
        (
            "argument 0",
            "loads = \"preselected\"",
            "loads = \"arg 0\"",
            "dmg.toml:",
        ),
        (
            "unknown field",
            "leaves = [\"position\"]",
            "leaves = [\"spindel\"]",
            "unknown variant `spindel`",
        ),
        (
            "change without the declaration",
            "change = \"TC(1)\"",
            "change = \"TC2(1)\"",
            "must call a tool change declared in [calls]",
        ),
        (
            "preselected call given the tool",
            "change = \"TC(1)\"",
            "change = \"TC({tool})\"",
            "does not fit calls.TC.loads",
        ),
        (
            "spindle probe without change",
            "change = \"TC(1)\"\n",
            "",
            "calls.TC declares a tool change",
        ),
        (
            "a Siemens cycle",
            "[calls.L711]",
            "[calls.CYCLE800]",
            "driftloop reads itself",
        ),
        (
            "nothing said",
            "leaves = [\"position\"]\n\n[calls.L711]",
            "\n[calls.L711]",
            "calls.L710 says nothing",
        ),
    ] {
        let bad = dmg.replacen(from, to, 1);
        assert_ne!(bad, dmg, "{what}");
        let prog = std::fs::read_to_string(common::fixture("declared_calls/dmu_tc1.mpf")).unwrap();
        let (o, _) =
            common::transform_in(&[("p.mpf", &prog), ("dmg.toml", &bad)], "p.mpf", "dmg.toml");
        assert_eq!(o.status.code(), Some(2), "{what}");
        let err = common::stderr(&o);
        assert!(err.contains(expected), "{what}: {err}");
        // Each message points at the line of the value in the file.
        assert!(
            err.contains("dmg.toml:")
                && err
                    .split("dmg.toml:")
                    .nth(1)
                    .is_some_and(|r| r.starts_with(char::is_numeric)),
            "{what}: {err}"
        );
    }
}
