//! Hazards, lost measurements and wrong refusals QA round 11 found (fixtures/shop11: subprogram- and
//! loop-heavy shop programs; its README lists them), each through the binary. `transform` audits its output
//! as planned and with every gate measuring and writes nothing on a finding.

mod common;

/// `fixtures/shop11/NAME` (its subprograms from `fixtures/shop11/subs`) transformed with the builtin
/// `profile` measuring at every gate: the run and the output, if written.
fn shop11(name: &str, profile: &str) -> (std::process::Output, Option<String>) {
    let dir = tempfile::tempdir().unwrap();
    let every = dir.path().join("e.toml");
    std::fs::write(&every, common::measuring_builtin(profile)).unwrap();
    let out = dir.path().join("out.mpf");
    let (program, subs, model) = (
        common::fixture(&format!("shop11/{name}")),
        common::fixture("shop11/subs"),
        common::fixture("omm/model.toml"),
    );
    let o = common::run(&[
        "transform",
        &program,
        "--model",
        &model,
        "--profile",
        &every.display().to_string(),
        "--subprograms",
        &subs,
        "-o",
        &out.display().to_string(),
    ]);
    let text = std::fs::read_to_string(&out).ok();
    (o, text)
}

/// `fixtures/shop11/NAME` with `profile` is refused, saying `why`.
fn refused_saying(name: &str, profile: &str, why: &str) {
    let (o, out) = shop11(name, profile);
    let err = common::stderr(&o);
    assert!(out.is_none(), "{err}");
    assert!(err.contains(why), "{err}");
}

#[test]
fn no_gate_measures_while_a_modal_cycle_call_is_active() {
    // 08: `MCALL CYCLE81(…)` left active across the tool change (the program's own bug, which the next
    // move would show): every move of the gate's probe swap ran the drilling cycle, three times into the
    // part with the probe. No gate that moves stands where a modal call is active.
    for profile in ["blum-tc50", "tool-setter"] {
        let (o, out) = shop11(
            "08_mcall_cycle81_left_active_across_toolchange.mpf",
            profile,
        );
        let out = out.unwrap_or_else(|| panic!("{profile}: {}", common::stderr(&o)));
        let gate = common::gate_before(&out, "T=\"BO_D8.5\" M6");
        assert!(
            !common::gate_measures(&gate),
            "{profile}:\n{}",
            gate.join("\n")
        );
        assert!(
            !gate
                .iter()
                .any(|l| l.starts_with("G0") || l.starts_with("X")),
            "{profile}: a gate that moves:\n{}",
            gate.join("\n")
        );
    }
}

#[test]
fn a_tool_change_subprogram_that_takes_the_tool_as_argument_is_no_probe_swap() {
    // 14: `PROC TC(INT _NR)` selects `T=_NR`; the probe swap called it bare (`T="BLUM_TC50"` / `TC`), which
    // selects T0: the spindle emptied, and the probe cycle ran with no probe. Refused for a spindle probe
    // (until the profile declares its own change); the audit now also checks the probe is in the spindle
    // when its cycle runs.
    refused_saying(
        "14_tc_proc_param_toolchange_g64_left.mpf",
        "blum-tc50",
        "changes tools with a subprogram that takes the tool as its argument",
    );
}

#[test]
fn the_probe_cycle_must_run_with_the_probe_in_the_spindle() {
    // The audit's own check, on a hand-made gate that swaps with a bare `TC` (as the transform did).
    let dir = tempfile::tempdir().unwrap();
    let tc = "PROC TC(INT _NR)\nM5\nM9\nG0 SUPA Z0 D0\nT=_NR\nM6\nD1\nM17\n";
    std::fs::write(dir.path().join("TC.SPF"), tc).unwrap();
    let original = "G17 G90 G94 G54\nTC(4)\nS3000 M3\nG0 X0 Y0 Z50\nG1 Z-1 F300\nG0 Z50\nM30\n";
    let transformed = "; driftloop-omm ;DL\nG17 G90 G94 G54\nTC(4)\nS3000 M3\nG0 X0 Y0 Z50\n\
                       M5 ;DL\nT=\"BLUM_TC50\" ;DL\nTC ;DL\nG0 Z100 ;DL\nX0 Y0 ;DL\nZ10 ;DL\n\
                       BL9700(1,3,0,10,0.5,300,0,0,0,0,0,0,0,0,0,0) ;DL\nG0 Z100 ;DL\nTC(4) ;DL\n\
                       G0 X0 Y0 Z50 ;DL\nS3000 M3 ;DL\nG1 Z-1 F300\nG0 Z50\nM30\n";
    let mut settings = driftloop::vm::audit::AuditSettings::from_profile(
        &driftloop::omm::Profile::default_profile(),
    );
    settings.dir = Some(dir.path().to_path_buf());
    let found = driftloop::vm::audit::audit(
        original.as_bytes(),
        transformed.as_bytes(),
        &settings,
        &driftloop::vm::Config::default(),
    )
    .unwrap();
    assert!(
        found.findings.iter().any(|f| f
            .message
            .contains("the probe cycle runs with T0 in the spindle")),
        "{:#?}",
        found.findings
    );
}

#[test]
fn the_zero_goes_before_a_part_subprogram_right_after_the_work_offset() {
    // 01: `G54` and at once the part subprogram: the call is the first cut, and the place before it was not
    // taken (the call marked the cut before the block's place was noted), so the spindle probes refused
    // the program.
    let (o, out) = shop11("01_vice4_g54_g57_station_sub_leaves_g41.mpf", "blum-tc50");
    assert!(out.is_some(), "{}", common::stderr(&o));
}

#[test]
fn a_tool_setter_measures_no_zero_before_a_subprogram_that_loads_the_tool() {
    // 06: each operation's subprogram loads its own tool; the setter's zero before the first call measured
    // the tool left in the spindle from before.
    refused_saying(
        "06_op_subs_load_their_own_tools.mpf",
        "tool-setter",
        "loads the tool that cuts: a tool setter's zero here would measure another tool",
    );
}

#[test]
fn gates_after_subprograms_measure_where_their_state_is_known() {
    // 02 (nested calls under PROC … SAVE) and 05 (`L100 P3` leaving G95 F0.08): every place after a call
    // was unsure until the next tool change, and a nested call made the outer subprogram leave everything
    // unknown. Now the fields are followed through the calls: later gates measure, audited clean.
    for name in [
        "02_proc_save_params_for_nested_trans.mpf",
        "05_l100_p3_g95_feed_left_main_relies.mpf",
    ] {
        let (o, out) = shop11(name, "blum-tc50");
        let out = out.unwrap_or_else(|| panic!("{name}: {}", common::stderr(&o)));
        let measuring = out.matches("planned: measure").count();
        assert!(measuring >= 1, "{name}:\n{out}");
    }
}

#[test]
fn a_side_changer_at_the_machine_top_is_no_travel_below_the_clearance() {
    // 13: the machine's L6 travels to `SUPA X-450` at `SUPA Z0`, the top of travel; called from the
    // probe swap, the audit read Z0 as on the part and refused the output. It also checks `$P_TOOLP`
    // against `$P_TOOLNO`, which stopped the dry run before.
    let (o, out) = shop11(
        "13_l6_conditional_toolchange_macro_part_subs.mpf",
        "blum-tc50",
    );
    let err = common::stderr(&o);
    assert!(out.is_some(), "{err}");
    assert!(!err.contains("audit incomplete"), "{err}");
}

#[test]
fn a_tool_change_the_macro_may_skip_gives_the_spindle_back() {
    // 13's L6 changes only where the preselected tool is not in the spindle (`IF $P_TOOLNO==$P_TOOLP GOTOF
    // …`). Taken as a change that always stops the spindle, a setter's gate before it (no probe swap, so
    // the macro skips its change) left the spindle stopped for the next cut; the audit refused the output.
    // Such a change is no tool change for the gate before it, which gives the spindle back, and what the
    // macro sets is unsure after it. A gate right before a call also gives back the spindle from before the
    // call, not the one the call's own words leave. (The lathe setter refuses this milling program.)
    for profile in ["tool-setter", "blum-tc50"] {
        let (o, out) = shop11("13_l6_conditional_toolchange_macro_part_subs.mpf", profile);
        let err = common::stderr(&o);
        assert!(out.is_some(), "{profile}: {err}");
        assert!(!err.contains("audit incomplete"), "{profile}: {err}");
    }
}

#[test]
fn a_tool_change_subprogram_called_with_a_literal_loads_that_tool() {
    // F7: `TC(4)` of `PROC TC(INT _NR)` … `T=_NR`, and `WZW("SF_D16_STUFE", 1)` of `PROC WZW(STRING[32]
    // _WZ, INT _SCHN)` … `T=_WZ` … `D=_SCHN`: the tool and edge are the call's literals, bound to the
    // parameters. The setters refused both ("the tool is set by an expression", "the D number is set by
    // an expression"); the tool setter measures the tool the call loads now (the lathe setter refuses these
    // milling programs).
    for (name, tool) in [
        ("14_tc_proc_param_toolchange_g64_left.mpf", "T4"),
        (
            "15_wzw_string_toolchange_sub_leaves_atrans_d2_m8.mpf",
            "SF_D16_STUFE",
        ),
    ] {
        let profile = "tool-setter";
        let (o, out) = shop11(name, profile);
        let out = out.unwrap_or_else(|| panic!("{name}, {profile}: {}", common::stderr(&o)));
        let zero = format!("(reference, pass 1 {tool})");
        assert!(
            out.contains(&zero),
            "{name}, {profile}: no `{zero}` in\n{out}"
        );
    }
}

#[test]
fn a_string_parameter_with_its_length_runs_in_the_dry_run() {
    // F8: `PROC WZW(STRING[32] _WZ, …)`: `[32]` is the string's length, not an array; the dry run stopped
    // at the first call ("array parameters"), so the setter's audit compared nothing after it.
    let (o, out) = shop11(
        "15_wzw_string_toolchange_sub_leaves_atrans_d2_m8.mpf",
        "tool-setter",
    );
    let err = common::stderr(&o);
    assert!(out.is_some(), "{err}");
    assert!(!err.contains("audit incomplete"), "{err}");
    assert!(!err.contains("array parameters"), "{err}");
}

/// A setter's transform of `p.mpf` calling `TC.SPF` (`tc`) as `call`: refused, saying `why`.
fn tc_refused_saying(tc: &str, call: &str, why: &str) {
    let program = format!(
        "G17 G90 G40 G94 G71\nG54\n{call}\nD1\nS3000 M3\nG0 X10 Y10 Z50\nG1 Z-1 F300\nG1 X40\nG0 Z50\nM30\n"
    );
    let every = common::measuring_builtin("tool-setter");
    let files = [
        ("p.mpf", program.as_str()),
        ("TC.SPF", tc),
        ("e.toml", &every),
    ];
    let (o, dir) = common::transform_in(&files, "p.mpf", "e.toml");
    let err = common::stderr(&o);
    assert!(
        !dir.path().join("out.mpf").exists(),
        "{call}: written\n{err}"
    );
    assert!(err.contains(why), "{call}: {err}");
}

#[test]
fn a_tool_the_call_does_not_pass_as_a_literal_stays_unknown() {
    // The binding takes the call's literal only where the subprogram selects by the parameter as passed.
    let plain = "PROC TC(INT _NR)\nT=_NR\nM6\nM17\n";
    tc_refused_saying(plain, "TC(R5)", "the tool is set by an expression");
    // The subprogram changes the parameter before it selects: not the call's number.
    let shifted = "PROC TC(INT _NR)\n_NR=_NR+100\nT=_NR\nM6\nM17\n";
    tc_refused_saying(shifted, "TC(4)", "the tool is set by an expression");
    // Two selections by different parameters.
    let two = "PROC TC(INT _A, INT _B)\nT=_A\nIF _B>0\nT=_B\nENDIF\nM6\nM17\n";
    tc_refused_saying(two, "TC(4, 5)", "the tool is set by an expression");
}

#[test]
fn a_probe_with_a_t_number_is_written_as_a_number_without_tool_management() {
    // A machine that selects tools by plain T numbers (`tool_by_number = "{t}"`) and changes them with
    // `PROC TC(INT _NR)`: the probe swap wrote `TC("99")`, which the control refuses (a string for an INT
    // parameter); the dry run stopped there and the output was written with its audit incomplete.
    let profile = common::measuring_builtin("blum-tc50")
        .replace("tool = \"BLUM_TC50\"", "tool = \"99\"")
        .replace(
            "tool_by_number = \"$TC_TP2[{t}]\"",
            "tool_by_number = \"{t}\"",
        )
        .replace("[probe]\n", "[probe]\nchange = \"TC({tool})\"\n")
        + "\n[calls.TC]\nloads = \"arg 1\"\n";
    let program = "G17 G90 G40 G94 G71\nG54\nTC(4)\nD1\nS3000 M3\nG0 X60 Y60 Z50\nG1 Z-1 F300\n\
                   G1 X90\nG0 Z50\nM30\n";
    let tc = "PROC TC(INT _NR)\nM5\nT=_NR\nM6\nM17\n";
    let files = [("p.mpf", program), ("TC.SPF", tc), ("e.toml", &profile)];
    let (o, dir) = common::transform_in(&files, "p.mpf", "e.toml");
    let err = common::stderr(&o);
    let out = std::fs::read_to_string(dir.path().join("out.mpf"))
        .unwrap_or_else(|_| panic!("not written: {err}"));
    assert!(out.contains("TC(99) ;DL"), "{out}");
    assert!(!out.contains("TC(\"99\")"), "{out}");
    assert!(!err.contains("audit incomplete"), "{err}");
}
