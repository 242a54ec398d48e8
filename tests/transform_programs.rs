//! Real kinds of programs through the `transform` command with the profile made for them — a cylindrical
//! grinder with an in-process gauge, a single-tool milling part with a tool setter, a lathe with a setter
//! arm, a program whose labels are defined twice — each passing the safety audit the command runs on its
//! output (exit 0: no hazard the inserted blocks caused; the audit ran to the end), with golden files.

mod common;

use common::fixture;

/// The transformed program, after checking the command succeeded with a complete audit.
fn transformed(program: &str, profile: &str) -> String {
    let o = common::run(&[
        "transform",
        &fixture(&format!("programs/{program}")),
        "--model",
        &fixture("omm/model.toml"),
        "--profile",
        profile,
        "-o",
        "-",
    ]);
    let stderr = common::stderr(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(!stderr.contains("audit incomplete"), "{stderr}");
    assert!(!stderr.contains("warning:"), "{stderr}");
    String::from_utf8(o.stdout).unwrap()
}

#[test]
fn a_grinder_with_a_gauge() {
    let out = transformed("grinder.mpf", "grinder-gauge");
    // The gauge is read after the dressing call: the wheel is off the part there.
    let after_dress = out.split("\nDRESS\n").nth(1).unwrap();
    assert!(after_dress.starts_with("; driftloop gate"), "{after_dress}");
    insta::assert_snapshot!("grinder", out);
}

#[test]
fn a_single_tool_milling_part_with_a_tool_setter() {
    let out = transformed("single_tool.mpf", "tool-setter");
    assert!(!out.lines().any(|l| l.ends_with(";DL") && l.contains("M6")));
    insta::assert_snapshot!("single_tool", out);
}

#[test]
fn a_lathe_with_a_setter_arm() {
    let out = transformed("lathe.mpf", "lathe-setter");
    // Radius while the gate moves, diameters again after it.
    assert!(
        out.contains("DIAMOF ;DL") && out.contains(" DIAMON ;DL"),
        "{out}"
    );
    insta::assert_snapshot!("lathe", out);
}

#[test]
fn a_program_with_labels_defined_twice() {
    let out = transformed("duplicate_labels.mpf", "blum-tc50");
    insta::assert_snapshot!("duplicate_labels", out);
}

#[test]
fn a_cam_program_with_a_title_above_its_header_cycles_and_a_modal_call() {
    // A GBK title comment above `%_N_…_MPF`, CYCLE832 with symbolic arguments, G41, MCALL CYCLE81: the
    // header goes after the `%` lines, the program's own flow is followed, and the audit runs to the end
    // (the cycles it cannot find are skipped alike in both runs).
    let o = common::run(&[
        "transform",
        &fixture("programs/gbk_title.mpf"),
        "--model",
        &fixture("omm/model.toml"),
        "-o",
        "-",
    ]);
    let stderr = common::stderr(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(!stderr.contains("audit incomplete"), "{stderr}");
    let out = o.stdout;
    let lines: Vec<&[u8]> = out.split(|&b| b == b'\n').collect();
    assert!(lines[1].starts_with(b"%_N_PART1_MPF") && lines[3].starts_with(b"; driftloop-omm"));
}

/// What the operator panel writes around a program block (`GROUP_BEGIN`/`GROUP_END`) and a wait for a
/// positioned spindle (`WAITS`) move nothing: they were read as unknown calls, so a program that opens
/// with a block marker had no place for its zero (found on real programs). Now it transforms, with an audit
/// that runs to the end, and its gates are where the plain program's are.
#[test]
fn program_block_markers_and_waits_move_nothing() {
    let plain = "G54\nT1 M6\nS2000 M3\nG0 X30 Y30 Z5\nG1 Z-1 F100\nG1 X80 F500\nG0 Z50\nSPOS=0\nG1 X90 F300\nM30\n";
    let marked = "GROUP_BEGIN(0,\"ROUGH\",0,0)\nG54\nT1 M6\nS2000 M3\nG0 X30 Y30 Z5\nG1 Z-1 F100\nG1 X80 F500\nG0 Z50\nGROUP_END(0,0)\nSPOS=0\nWAITS(1)\nG1 X90 F300\nM30\n";
    for profile in ["blum-tc50", "tool-setter"] {
        let gates = |src: &str| {
            let out = common::transformed_in(&[("p.mpf", src)], "p.mpf", profile);
            out.lines()
                .filter(|l| l.starts_with("; driftloop gate"))
                .count()
        };
        let plain_gates = gates(plain);
        assert!(plain_gates > 0, "{profile}");
        assert_eq!(gates(marked), plain_gates, "{profile}");
    }
}

/// A feed group of the geometry axes (`FGROUP(X,Y,Z)`, `FGROUP()`, which 5-axis posts write), the rapid
/// interpolated axis by axis (`RTLIOF`) and a workpiece counted for tool monitoring (`SETPIECE`) leave
/// nothing a gate gives back otherwise: they were
/// read as calls of unknown subprograms, and no place after them measured until the next tool change. Now
/// the gates are where the plain program's are, and the audit runs to the end.
#[test]
fn feed_groups_of_the_geometry_axes_and_a_workpiece_count_keep_the_places_after_them() {
    let program = |first: &str, last: &str| {
        format!(
            "G54\nT1 M6\nD1\nS2000 M3\n{first}\nG0 X30 Y30 Z5\nG1 Z-1 F100\nG1 X80 F500\nG0 Z50\nG0 X0\nG1 Z-1 F100\nG1 X-40\nG0 Z50\n{last}\nM30\n"
        )
    };
    let plain = program("", "");
    let with = program("FGROUP(X,Y,Z)\nRTLIOF", "RTLION\nFGROUP()\nSETPIECE(1)");
    for profile in ["blum-tc50", "tool-setter"] {
        let every = common::measuring_builtin(profile);
        let measuring = |src: &str| {
            let files = [("p.mpf", src), ("every.toml", every.as_str())];
            let (o, dir) = common::transform_in(&files, "p.mpf", "every.toml");
            let err = common::stderr(&o);
            assert!(o.status.success(), "{err}");
            assert!(!err.contains("audit incomplete"), "{err}");
            let out = std::fs::read_to_string(dir.path().join("out.mpf")).unwrap();
            out.lines()
                .filter(|l| l.contains("stage 4") || l.contains("planned: measure"))
                .count()
        };
        let plain_measuring = measuring(&plain);
        assert!(plain_measuring > 1, "{profile}");
        assert_eq!(measuring(&with), plain_measuring, "{profile}");
    }
}

/// A block the operator's skip switch may leave out (`/T="DR5" M6`, `/S3000 M3`: an optional operation)
/// runs or not. The gate before the skippable change took it for certain and left the probe in the
/// spindle for it to change (with the switch on the program went on cutting with the probe), and the gate
/// after it gave back `T="DR5" M6` and `S3000 M3`, a tool and speed the program with the switch on never
/// had. Now the gate before gives the cutting tool back, and no later gate gives back what the skippable
/// blocks set until the program sets it again.
#[test]
fn a_block_the_skip_switch_may_leave_out_is_no_certain_tool_change_or_speed() {
    let prog = "G54\nT=\"EM10\" M6\nD1\nS2000 M3\nG0 X0 Y0 Z50\nG0 X10 Y10 Z5\nG1 Z-1 F100\nG1 X50\nG0 Z50\n/T=\"DR5\" M6\n/S3000 M3\nG0 X0\nG0 Z5\nG1 Z-1\nG1 X-30\nG0 Z50\nG0 X20\nT=\"FM50\" M6\nD1\nS2500 M3\nG0 X40 Z5\nG1 Z-1\nG1 X80\nG0 Z50\nM30\n";
    for profile in common::MILLING_PROFILES {
        let out = common::every_gate_transformed(profile, &[("p.mpf", prog)]);
        let inserted: Vec<&str> = out.lines().filter(|l| l.ends_with(";DL")).collect();
        assert!(
            !inserted
                .iter()
                .any(|l| l.starts_with("T=\"DR5\"") || l.starts_with("S3000")),
            "{profile}:\n{out}"
        );
        // The gate before the skippable change measures and gives back the cutting tool turning.
        let gate = common::gate_before(&out, "/T=\"DR5\" M6");
        assert!(common::gate_measures(&gate), "{profile}:\n{out}");
        assert!(
            gate.iter().any(|l| l.starts_with("S2000 M3")),
            "{profile}:\n{gate:#?}"
        );
        if profile != "tool-setter" {
            assert!(
                gate.iter().any(|l| l.starts_with("T=\"EM10\" M6")),
                "{profile}: the cutting tool back before a change that may not run\n{gate:#?}"
            );
        }
    }
}

/// A field a skippable block sets is unsure after it until the program sets it again. Setting it again to
/// the value the timeline already held (the skippable `/S3000 M3`, then `S3000 M3`) changed nothing and
/// left it unsure: no gate after it measured until the next tool change. A write settles it on every way.
#[test]
fn a_speed_written_again_after_a_skippable_block_is_certain_even_at_the_same_value() {
    let prog = "G54\nT=\"EM10\" M6\nD1\nS2000 M3\nG0 X0 Y0 Z50\nG0 X10 Y10 Z5\nG1 Z-1 F100\nG1 X50\nG0 Z50\n/S3000 M3\nG0 X0\nS3000 M3\nG0 Z5\nG1 Z-1\nG1 X-30\nG0 Z50\nG0 X20\nT=\"FM50\" M6\nD1\nS2500 M3\nG0 X40 Z5\nG1 Z-1\nG1 X80\nG0 Z50\nM30\n";
    for profile in common::MILLING_PROFILES {
        let out = common::every_gate_transformed(profile, &[("p.mpf", prog)]);
        let after = common::lines_between(&out, "G1 X-30", "T=\"FM50\" M6");
        let after = after.join("\n");
        assert!(
            common::measured_before(&after).iter().any(|b| b == "G0"),
            "{profile}: no gate measures after the speed is written again\n{out}"
        );
    }
}

/// What a cycle may leave (CYCLE61's speed, direction, feed) is settled only by a write that runs on
/// every way: one inside an IF, or in a block the skip switch may leave out, may not run. Such a write
/// settled it, and the gate after gave back `S3000 M3` where the program, with the IF not taken, turned
/// at the cycle's speed.
#[test]
fn a_write_that_may_not_run_does_not_settle_what_a_cycle_left() {
    let head = "G54\nT=\"EM10\" M6\nD1\nS3000 M3\nG0 X0 Y0 Z50\nG0 X10 Y10 Z5\nG1 Z-1 F100\nG1 X50\nG0 Z50\nCYCLE61(50,1,1,0,0,0,100,100,1,80,0,800,11,0,2,5000,0,0)\nG0 Z50\n";
    let tail = "; PASS 2\nG0 X0 Y0 Z5\nG1 Z-1 F100\nG1 X-30\nG0 Z50\nT=\"FM50\" M6\nD1\nS2500 M3\nG0 X40 Z5\nG1 Z-1\nG1 X80\nG0 Z50\nM30\n";
    for write in ["IF R1==1\nS3000 M3\nENDIF\n", "/S3000 M3\n"] {
        let prog = format!("{head}{write}{tail}");
        for profile in common::MILLING_PROFILES {
            let out = common::every_gate_transformed(profile, &[("p.mpf", &prog)]);
            let gate = common::gate_before(&out, "; PASS 2");
            assert!(
                !common::gate_measures(&gate),
                "{profile}, {write:?}: the gate after the cycle measured\n{gate:#?}"
            );
        }
    }
}

/// A long cut at `S=R1` after `R1=4000`: the prediction ran at 0 rpm (the speed before the block), so the
/// plan predicted no drift over hours of cutting and the gates measured nothing. The speed of a variable
/// last assigned a number now drives the prediction; a speed driftloop cannot evaluate is named in a
/// warning.
#[test]
fn a_speed_from_a_variable_assigned_a_number_drives_the_prediction() {
    let cut: String = (0..40).map(|_| "G1 X500\nG1 X0\n").collect();
    let prog = format!(
        "G54\nR1=4000\nT=\"EM10\" M6\nD1\nS=R1 M3\nG0 X0 Y0 Z50\nG0 Z5\nG1 Z-1 F100\n{cut}G0 Z50\nT=\"EM12\" M6\nD1\nS=R1*1.5 M3\nG0 X0 Y0 Z5\nG1 Z-1 F100\n{cut}G0 Z50\nM30\n"
    );
    let model = common::fixture("omm/model.toml");
    let (o, _dir) = common::run_in(&[("p.mpf", &prog)], &["plan", "p.mpf", "--model", &model]);
    let (out, err) = (common::stdout(&o), common::stderr(&o));
    assert!(o.status.success(), "{err}");
    let pass_one = out.lines().find(|l| l.contains("\"EM10\"")).unwrap();
    assert!(pass_one.trim_end().ends_with("4000"), "{out}");
    assert!(
        err.contains(
            "line 92: the spindle speed is set by an expression driftloop cannot evaluate"
        ),
        "{err}"
    );
}

/// A subprogram that takes its speed as a parameter (`PROC OP_BOHREN(REAL _RPM, …)`, `S=_RPM M3`) turns
/// at the number its call passes: the prediction runs at it. A call that passes an expression is named in
/// the warning, by its own line.
#[test]
fn a_subprograms_speed_parameter_takes_the_number_its_call_passes() {
    let sub =
        "PROC OP_BOHREN(REAL _RPM, REAL _F)\nS=_RPM M3\nG0 X10 Y10 Z5\nG1 Z-20 F=_F\nG0 Z5\nM17\n";
    let main = "G54\nT=\"DR5\" M6\nD1\nG0 X0 Y0 Z50\nOP_BOHREN(4000, 100)\nG0 Z50\nOP_BOHREN(R5, 100)\nG0 Z50\nM30\n";
    let model = common::fixture("omm/model.toml");
    let (o, _dir) = common::run_in(
        &[("p.mpf", main), ("OP_BOHREN.SPF", sub)],
        &["plan", "p.mpf", "--model", &model],
    );
    let (out, err) = (common::stdout(&o), common::stderr(&o));
    assert!(o.status.success(), "{err}");
    let pass = out.lines().find(|l| l.contains("\"DR5\"")).unwrap();
    assert!(pass.trim_end().ends_with("4000"), "{out}");
    assert!(
        err.contains("line 7: the spindle speed is set by an expression"),
        "{err}"
    );
    assert!(!err.contains("line 5"), "{err}");
}

/// The timeline reads the program in order, so a variable's last number is the value on one way only:
/// after `IF` / `R1=4000` / `ELSE` / `R1=6000` / `ENDIF`, `S=R1` turns at 4000 or 6000. A gate after it
/// must not give back either number.
#[test]
fn a_gate_gives_back_no_speed_taken_from_a_variable_that_branches_set() {
    let prog = "G54\nIF R10==1\nR1=4000\nELSE\nR1=6000\nENDIF\nT=\"EM10\" M6\nD1\nS=R1 M3\nG0 X0 Y0 Z50\nG0 X10 Y10 Z5\nG1 Z-1 F100\nG1 X50\nG0 Z50\nG0 X0\nG0 Z5\nG1 Z-1\nG1 X-30\nG0 Z50\nG0 X20\nT=\"FM50\" M6\nD1\nS2500 M3\nG0 X40 Z5\nG1 Z-1\nG1 X80\nG0 Z50\nM30\n";
    for profile in common::MILLING_PROFILES {
        let out = common::every_gate_transformed(profile, &[("p.mpf", prog)]);
        assert!(
            !out.lines()
                .any(|l| l.ends_with(";DL") && (l.starts_with("S4000") || l.starts_with("S6000"))),
            "{profile}:\n{out}"
        );
    }
}

/// An archive saved from the control may open with a definition file or a subprogram (sections in
/// the order of their folders). The gates, the zero and the initial data belong in its main program: they
/// went into the first section, so a subprogram the main calls mid-cut measured with a tool swap, and the
/// main program had no zero. Now the first `%_N_…_MPF` section is the main one for the timeline and the
/// dry run, the other sections stay byte for byte, the GUD section's variables are known to the audit,
/// and a second main program is named in a warning.
#[test]
fn an_archive_that_opens_with_a_definition_file_and_a_subprogram_is_gated_in_its_main_program() {
    let head = "%_N_UGUD_DEF\n;$PATH=/_N_DEF_DIR\nDEF NCK REAL XSTART=10\nM30\n%_N_SIDE_SPF\n;$PATH=/_N_SPF_DIR\nG1 X20 F100\nM17\n";
    let main = "%_N_PART_MPF\n;$PATH=/_N_MPF_DIR\nG54\nT1 M6\nD1\nS2000 M3\nG0 X=XSTART Y30 Z5\nG1 Z-1 F100\nSIDE\nG1 X50 F500\nG0 Z50\nM30\n";
    let second = "%_N_OTHER_MPF\n;$PATH=/_N_MPF_DIR\nG54\nT1 M6\nD1\nS2000 M3\nG0 X0 Y30 Z5\nG1 Z-1 F100\nG0 Z50\nM30\n";
    for (src, warns) in [
        (format!("{head}{main}"), false),
        (format!("{head}{main}{second}"), true),
    ] {
        let (o, dir) = common::transform_in(&[("part.arc", &src)], "part.arc", "blum-tc50");
        let stderr = common::stderr(&o);
        assert!(o.status.success(), "{stderr}");
        assert!(!stderr.contains("audit incomplete"), "{stderr}");
        assert_eq!(
            stderr.contains("the archive holds 2 main programs: gates go into the first, PART; OTHER left as they are"),
            warns,
            "{stderr}"
        );
        let out = std::fs::read_to_string(dir.path().join("out.mpf")).unwrap();
        assert!(
            out.starts_with(head),
            "the sections before the main one changed:\n{out}"
        );
        let main_at = out.find("%_N_PART_MPF").unwrap();
        assert!(out[main_at..].contains("; driftloop gate"), "{out}");
        if warns {
            let other_at = out.find("%_N_OTHER_MPF").unwrap();
            assert!(out.ends_with(second) && other_at > main_at, "{out}");
        }
    }
}

/// The dry run of such an archive runs its main program, with the GUD variables of the archive's
/// definition section or of a `.DEF` file beside the program.
#[test]
fn the_dry_run_starts_at_the_main_program_and_knows_the_global_user_data() {
    let main =
        "G54\nT1 M6\nD1\nS2000 M3\nG0 X=XSTART Y30 Z5\nG1 Z-1 F100\nG1 X50 F500\nG0 Z50\nM30\n";
    let archive = format!(
        "%_N_UGUD_DEF\nDEF NCK REAL XSTART=10\nM30\n%_N_SIDE_SPF\nG1 X20 F100\nM17\n%_N_PART_MPF\n{main}"
    );
    let with_def: [(&str, &str); 2] = [
        ("part.mpf", main),
        ("UGUD.DEF", "DEF NCK REAL XSTART=10\nM30\n"),
    ];
    for (files, program) in [
        (vec![("part.arc", archive.as_str())], "part.arc"),
        (with_def.to_vec(), "part.mpf"),
    ] {
        let (o, _dir) = common::run_in(&files, &["run", program]);
        let stdout = common::stdout(&o);
        assert!(o.status.success(), "{program}: {}", common::stderr(&o));
        assert!(
            stdout.contains("program end (M30)") && stdout.contains("machined error over 1 passes"),
            "{program}: {stdout}"
        );
    }
    // Without the definition the control stops with alarm 12550, and so does the dry run.
    let (o, _dir) = common::run_in(&[("part.mpf", main)], &["run", "part.mpf"]);
    assert!(!o.status.success());
    assert!(common::stderr(&o).contains("XSTART is not defined"));
}

/// Shops keep the clearance height in a GUD or R-parameter (`G0 Z=_ZSICHER`): that rapid of the tool axis
/// alone was not taken as leaving the cut, so the gate at the next tool change never measured (QA round 9,
/// F7). A literal `G0 Z50` and a variable one now count alike; an XY rapid to a variable does not.
#[test]
fn a_retract_to_a_height_held_in_a_variable_leaves_the_cut() {
    let measures_at_second_tool = |retract: &str| {
        let src = format!(
            "G54\nT1 M6\nD1\nS3000 M3\nG0 X0 Y0 Z50\nG1 Z-1 F500\nG1 X10\n{retract}\nT2 M6\nD1\nS3000 M3\nG0 X0 Y0 Z5\nG1 Z-1 F500\nG1 X10\nG0 Z50\nM30\n"
        );
        let every = common::measuring_default_profile();
        let out = common::transformed_in(
            &[("p.mpf", &src), ("every.toml", &every)],
            "p.mpf",
            "every.toml",
        );
        let second = out.find("\nT2 M6\n").unwrap();
        out[..second].matches("BL9700").count() > 1
    };
    assert!(measures_at_second_tool("G0 Z50"));
    assert!(measures_at_second_tool("G0 Z=R20"));
    assert!(!measures_at_second_tool("G0 X=R20"));
}

/// The audit's dry run reads what it cannot know from a machine file, as `run --machine` does: an
/// R-parameter the operator set (`R10 = 1` chooses the variant), an input. Without it the variant the dry
/// run took stopped the audit (QA round 9, `06`).
#[test]
fn the_audit_reads_the_machine_file_given_to_transform() {
    let src = "G54\nT1 M6\nD1\nS3000 M3\nIF R10==0\nR1=UNSET_GUD\nENDIF\nG0 X0 Y0 Z5\nG1 Z-1 F500\nG1 X10\nG0 Z50\nM30\n";
    let machine = "[variables]\nR10 = 1\n";
    let model = common::fixture("omm/model.toml");
    let run = |extra: &[&str]| {
        let mut args = vec!["transform", "p.mpf", "--model", &model, "-o", "out.mpf"];
        args.extend(extra);
        let (o, _dir) = common::run_in(&[("p.mpf", src), ("m.toml", machine)], &args);
        assert!(o.status.success(), "{}", common::stderr(&o));
        common::stderr(&o)
    };
    assert!(run(&[]).contains("UNSET_GUD is not defined"));
    assert!(!run(&["--machine", "m.toml"]).contains("audit incomplete"));
    // R-parameters beyond the control's are refused with the file's name.
    let (o, _dir) = common::run_in(
        &[("p.mpf", src), ("m.toml", "[variables]\nR1000 = 1\n")],
        &[
            "transform",
            "p.mpf",
            "--model",
            &model,
            "--machine",
            "m.toml",
            "-o",
            "out.mpf",
        ],
    );
    assert!(!o.status.success() && common::stderr(&o).contains("R1000 is beyond R999"));
}
