//! What QA round 8 found in programs written in machine builders' Siemens dialects (fixtures/shop8, its
//! README lists them: DMG MORI, Monforts, STAMA, Burkhardt+Weber, Pittler, Hermle, INDEX), each through the
//! binary.

mod common;

/// fixtures/shop8/`name` (with the set's subprograms beside it) transformed with `profile` (a builtin's
/// name, or `every` for the default profile measuring at every gate): the run and the output when one was
/// written.
fn transform_fixture(name: &str, profile: &str) -> (std::process::Output, Option<String>) {
    let prog = std::fs::read_to_string(common::fixture(&format!("shop8/{name}"))).unwrap();
    let every = common::measuring_default_profile();
    let (o, dir) = common::transform_in(
        &[("p.mpf", &prog), ("every.toml", &every)],
        "p.mpf",
        profile,
    );
    let out = std::fs::read_to_string(dir.path().join("out.mpf")).ok();
    (o, out)
}

/// The lines of `out` from the first that starts with `from` to the next that starts with `to` after it.
fn between<'a>(out: &'a str, from: &str, to: &str) -> &'a str {
    let start = out.find(from).unwrap_or_else(|| panic!("{from}: {out}"));
    let end = out[start + from.len()..]
        .find(to)
        .map_or(out.len(), |k| start + from.len() + k);
    &out[start..end]
}

#[test]
fn no_zero_before_a_builder_cycle_that_is_the_first_cut_with_no_tool_known() {
    // 08 (Burkhardt+Weber): the program writes its datum, then `NEWCOORD`, `L798` and the builder's tool
    // change `L706(, 1, , "1")`, and selects G54 only after them. driftloop took the first unreadable call
    // for the first cut and put the zero before it: the spindle probe read whatever tool the last program
    // left, swapped it with a bare `M6` (this machine changes tools in L706) and probed X0 Y0 Z10 under the
    // offset the RESET left (G500), before the table was turned to B0; the setters measured the previous
    // program's tool. 01 (DMG, `L710` then `T="…" TC(1)`), 10 (Pittler, `WZW("15226","BLIND2",1)`), 15: the
    // setters' zero measured the turret's last tool before the program selected its own.
    for profile in common::MILLING_PROFILES {
        let (o, out) = transform_fixture("08_bw_mcx_b_table_puifr_search_guard.mpf", profile);
        assert_eq!(o.status.code(), Some(2), "{profile}: {out:?}");
    }
    for (name, call) in [
        (
            "01_dmg_ctx_main_spindle_tc1.mpf",
            "if L710 (line 8) changes the tool",
        ),
        ("10_pittler_pv_vertical_lathe_wzw.mpf", "if WZW"),
        ("15_dmg_ctx_counter_spindle_setms3.mpf", "if L710"),
    ] {
        for profile in ["tool-setter", "lathe-setter"] {
            let (o, out) = transform_fixture(name, profile);
            assert_eq!(o.status.code(), Some(2), "{name} {profile}: {out:?}");
            let err = common::stderr(&o);
            assert!(
                err.contains("its first cut is a call driftloop cannot read") && err.contains(call),
                "{name} {profile}: {err}"
            );
        }
    }
    // The same builder cycle after the program's own first tool change: the zero goes before the cycle
    // (the spindle probe's before that change, which then loads the program's tool).
    let named = "G17 G90 G94 G54\nT=\"FM_D63\" M6\nD1\nS2000 M3\nG0 X-80 Y60 Z50\nL798\nG0 Z5\nG1 Z0 F400\nG1 X80 F900\nG0 Z200\nM30\n";
    for profile in ["blum-tc50", "tool-setter"] {
        let out = common::transformed_in(&[("p.mpf", named)], "p.mpf", profile);
        let zero = out.find("the zero ;DL").expect("a zero");
        assert!(zero < out.find("L798").unwrap(), "{profile}: {out}");
    }
}

#[test]
fn no_gate_measures_on_the_table_a_swivel_left_turned() {
    // 04 (TopSolid post for DMG): `CYCLE800()` deletes the swivel's frames but leaves the table at 90°
    // until the next CYCLE800 turns it back. The gate at the next tool change measured there: the probe
    // went down to X0 Y0 Z10 of the unturned G54 beside (or into) the turned part.
    let (o, out) = transform_fixture("04_topsolid_dmg_dmu_post.mpf", "every.toml");
    let out = out.unwrap_or_else(|| panic!("{}", common::stderr(&o)));
    let turned = between(
        &out,
        "CYCLE800(1,\"DMG\",200000,27,0,0,0,0,90,",
        "CYCLE800(1,\"DMG\",200000,27,0,0,0,0,0,",
    );
    assert!(turned.contains("\nCYCLE800()\n"), "{turned}");
    assert!(!turned.contains("BL9700"), "{turned}");
    // Where the program turns the axes back itself, gates measure again.
    let back = "G17 G90 G94 G54\nT=\"EM\" M6\nD1\nS3000 M3\nG0 X-50 Y-50 Z50\nG1 Z-1 F300\nG1 X50 F900\nG0 Z50\nCYCLE800(0,\"TC\",0,57,0,0,0,0,30,0,0,0,0,1,)\nG0 X-10 Y-10 Z30\nG1 Z-1 F300\nG1 X10\nG0 Z50\nCYCLE800()\nG0 A0 B0 C0\nT=\"DR\" M6\nD1\nS3000 M3\nG0 X40 Y-40 Z50\nG1 Z-5 F200\nG0 Z50\nM30\n";
    let every = common::measuring_default_profile();
    let out = common::transformed_in(
        &[("p.mpf", back), ("every.toml", &every)],
        "p.mpf",
        "every.toml",
    );
    let home = out.find("G0 A0 B0 C0").unwrap();
    assert!(out[home..].contains("BL9700"), "{out}");
}

#[test]
fn no_correction_is_written_under_a_swivel_at_the_programs_offset_selection() {
    // 11 (Hermle, hyperMILL post): `G54 D1` right after `CYCLE800(0,"HERMLE",…,180,0,-90,…)`. driftloop
    // wrote the correction again after the selection, into the frame in force under the swivel; the audit
    // caught it (measure-under-transform) and nothing was written for any profile. Now no inserted block
    // runs there: the correction the selection dropped stays off until the next gate reads what is in
    // force.
    for profile in common::MILLING_PROFILES {
        let (o, out) = transform_fixture("11_hermle_c22_cycle800_3plus2.mpf", profile);
        let out = out.unwrap_or_else(|| panic!("{profile}: {}", common::stderr(&o)));
        let swivelled = between(&out, "CYCLE800(0,\"HERMLE\",0,39,0,0,0,180", "CYCLE800()");
        assert!(swivelled.contains("G54 D1"), "{swivelled}");
        assert!(!swivelled.contains(";DL"), "{profile}: {swivelled}");
    }
}

#[test]
fn a_fixed_point_approach_without_fp_is_audited() {
    // 04: `G75 Z0` (no FP=) approaches fixed point 1 on the control; the dry run stopped there and every
    // output was written "without the safety audit from there on".
    for profile in ["blum-tc50", "tool-setter"] {
        let (o, out) = transform_fixture("04_topsolid_dmg_dmu_post.mpf", profile);
        assert!(out.is_some(), "{profile}: {}", common::stderr(&o));
        let err = common::stderr(&o);
        assert!(!err.contains("audit incomplete"), "{profile}: {err}");
    }
}

/// A mill that also drives a second spindle with extended words (`S2=`, `M2=3`) between tool changes.
const SECOND_SPINDLE: &str = "N10 G17 G90 G94 G71\nN20 T=\"EM_D10\" M6\nN30 D1\nN40 G54\nN50 S3000 M3\n\
N60 G0 X0 Y0 Z20\nN70 G1 Z-1 F300\nN80 X100 F1000\nN90 G0 Z100\nN100 T=\"EM_D6\" M6\nN110 D1\nN120 S4000 M3\n\
N130 G0 X0 Y50 Z20\nN140 G1 Z-1 F300\nN150 X100 F1000\nN160 G0 Z100\nN170 S2=2000 M2=3\nN180 T=\"EM_D8\" M6\n\
N190 D1\nN200 S3500 M3\nN210 G0 X0 Y80 Z20\nN220 G1 Z-1 F300\nN230 X100 F1000\nN240 G0 Z100\nN250 M2=5\nN260 M30\n";

#[test]
fn no_gate_that_moves_measures_once_the_program_drives_another_spindle() {
    // A gate stops the master spindle with M5 and gives back its S and M3 only: with `S2=2000 M2=3` (or
    // `SETMS(2)`, `SPOS[2]`) the spindle that turns may be another, which the timeline does not follow.
    let every = common::measuring_default_profile();
    let model = common::fixture("omm/model.toml");
    for (program, after) in [
        (SECOND_SPINDLE.to_string(), "N170 "),
        (
            SECOND_SPINDLE.replace("N170 S2=2000 M2=3", "N170 SETMS(2)"),
            "N170 ",
        ),
        (
            SECOND_SPINDLE.replace("N170 S2=2000 M2=3", "N170 SPOS[2]=90"),
            "N170 ",
        ),
    ] {
        let (o, _dir) = common::run_in(
            &[("p.mpf", &program), ("every.toml", &every)],
            &[
                "plan",
                "p.mpf",
                "--model",
                &model,
                "--profile",
                "every.toml",
                "--format",
                "json",
            ],
        );
        assert!(o.status.success(), "{}", common::stderr(&o));
        let plan: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let line = program.lines().position(|l| l.starts_with(after)).unwrap() as u64;
        let gates = plan["gates"].as_array().unwrap();
        let measuring = |before: bool| {
            gates.iter().any(|g| {
                g["can_measure"] == true && (g["block"].as_u64().unwrap() < line) == before
            })
        };
        assert!(measuring(true), "{program}: no gate measures before");
        assert!(
            !measuring(false),
            "{program}: a gate measures after {after}"
        );
    }
}
